"""A PLC closing a loop around `twin serve --lockstep`, on Python asyncua: a PD law on one joint.

Usage: plc.py URL MACHINE JOINT KP KD RATE PERIODS OUT.json. At each of PERIODS control updates
it reads the time, JOINT.position x and JOINT.velocity v, computes the effort

    u = KP·(r − x) + KD·(ṙ − v),   r(t) = RATE·t, ṙ = RATE   (a ramp: the joint at RATE)

writes it to effort.JOINT and advances one control period (the command acts from the next
update: one period of delay). Writes the history to OUT.json: per update, the time, the
tracking error r − x and the effort written.
"""

import asyncio
import json
import pathlib
import sys

from asyncua import ua

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent.parent))
from opcua_connect import connect, disconnect  # noqa: E402  (the tests' shared helper)


async def main(url, machine_name, joint, kp, kd, rate, periods, out):
    client = await connect(url)
    history = {"time": [], "error": [], "effort": []}
    try:
        ns = await client.get_namespace_index(f"urn:twin:{machine_name}")
        machine = await client.nodes.objects.get_child(f"{ns}:{machine_name}")
        measured = [
            client.get_node(ua.NodeId(name, ns))
            for name in ("status.time", f"{joint}.position", f"{joint}.velocity")
        ]
        effort = client.get_node(ua.NodeId(f"effort.{joint}", ns))
        advance = ua.QualifiedName("Advance", ns)
        for _ in range(periods):
            time, x, v = await client.read_values(measured)
            error = rate * time - x
            u = kp * error + kd * (rate - v)
            await effort.write_value(ua.DataValue(ua.Variant(u, ua.VariantType.Double)))
            await machine.call_method(advance, ua.Variant(1, ua.VariantType.UInt32))
            history["time"].append(time)
            history["error"].append(error)
            history["effort"].append(u)
    finally:
        await disconnect(client)
    with open(out, "w", encoding="utf-8") as file:
        json.dump(history, file)


if __name__ == "__main__":
    url, machine_name, joint, kp, kd, rate, periods, out = sys.argv[1:]
    args = (float(kp), float(kd), float(rate), int(periods), out)
    asyncio.run(main(url, machine_name, joint, *args))
