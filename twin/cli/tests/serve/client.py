"""An OPC UA client of `twin serve --lockstep`, on Python asyncua (a stack the twin did not write).

Usage: client.py URL MACHINE JOINT TORQUE PERIODS. Connects (retrying while the server starts),
browses the machine, reads JOINT.position, writes TORQUE to effort.JOINT, advances PERIODS
control periods, reads the position again, tries to write the position (must be refused), then
advances to the run's end. Prints what it saw as one JSON object.
"""

import asyncio
import json
import pathlib
import sys

from asyncua import ua

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent.parent))
from opcua_connect import connect, disconnect, final_state  # noqa: E402  (the tests' shared helper)


async def names(node):
    return sorted([(await child.read_browse_name()).Name for child in await node.get_children()])


async def main(url, machine_name, joint, torque, periods):
    client = await connect(url)
    try:
        ns = await client.get_namespace_index(f"urn:twin:{machine_name}")
        machine = await client.nodes.objects.get_child(f"{ns}:{machine_name}")
        axis = await machine.get_child([f"{ns}:Axes", f"{ns}:{joint}"])
        position = client.get_node(ua.NodeId(f"{joint}.position", ns))
        effort = client.get_node(ua.NodeId(f"effort.{joint}", ns))
        period = client.get_node(ua.NodeId("status.period", ns))
        seen = {
            "machine": await names(machine),
            "axis": await names(axis),
            "signals": await names(await machine.get_child(f"{ns}:Signals")),
            "position_before": await position.read_value(),
            "period_before": await period.read_value(),
        }
        await effort.write_value(ua.DataValue(ua.Variant(torque, ua.VariantType.Double)))
        seen["effort_read_back"] = await effort.read_value()
        seen["advanced_to"] = await machine.call_method(
            f"{ns}:Advance", ua.Variant(periods, ua.VariantType.UInt32)
        )
        seen["position_after"] = await position.read_value()
        seen["period_after"] = await period.read_value()
        try:
            await position.write_value(ua.DataValue(ua.Variant(1.0, ua.VariantType.Double)))
            seen["position_write"] = "accepted"
        except ua.UaStatusCodeError as error:
            seen["position_write"] = type(error).__name__
        try:
            await effort.write_value(ua.DataValue(ua.Variant(float("nan"), ua.VariantType.Double)))
            seen["nan_write"] = "accepted"
        except ua.UaStatusCodeError as error:
            seen["nan_write"] = type(error).__name__
        seen["advanced_to_end"] = await machine.call_method(
            f"{ns}:Advance", ua.Variant(1_000_000, ua.VariantType.UInt32)
        )
        seen["state"] = await final_state(client, ns)
    finally:
        await disconnect(client)
    print(json.dumps(seen))


if __name__ == "__main__":
    url, machine_name, joint, torque, periods = sys.argv[1:]
    asyncio.run(main(url, machine_name, joint, float(torque), int(periods)))
