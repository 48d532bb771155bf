"""A machine's OPC UA server for `twin shadow`'s link tests, on Python asyncua (a stack the twin
did not write).

Usage: machine.py PORT URI FIRST COUNT [BASE]. Serves, in namespace URI (index 2), the Double
variables ns=2;s=Crank.Position, Crank.Velocity and Crank.Torque and the String variable
Crank.Mode. Once listening it prints `ready BASE` (BASE: the source time of sample 0, s since the
UNIX epoch; now unless given), then every 10 ms writes sample k = FIRST, FIRST+1, … of each
variable j: value j * 1e6 + k, source timestamp BASE + k * 0.01, until COUNT samples are written;
then it keeps serving until killed. Mode is written once, "running".
"""

import asyncio
import sys
import time
from datetime import datetime, timezone

from asyncua import Server, ua

NAMES = ["Crank.Position", "Crank.Velocity", "Crank.Torque"]
PERIOD = 0.01


def stamp(seconds):
    return datetime.fromtimestamp(seconds, timezone.utc)


async def main(port, uri, first, count, base):
    server = Server()
    await server.init()
    server.set_endpoint(f"opc.tcp://127.0.0.1:{port}/")
    server.set_security_policy([ua.SecurityPolicyType.NoSecurity])
    ns = await server.register_namespace(uri)
    machine = await server.nodes.objects.add_object(ua.NodeId("Crank", ns), f"{ns}:Crank")
    variables = []
    for name in NAMES:
        variables.append(await machine.add_variable(ua.NodeId(name, ns), f"{ns}:{name}", 0.0))
    mode = await machine.add_variable(ua.NodeId("Crank.Mode", ns), f"{ns}:Crank.Mode", "idle")
    async with server:
        await mode.write_value("running")
        print(f"ready {base!r}", flush=True)
        start = time.monotonic()
        for n in range(count):
            k = first + n
            now = stamp(time.time())
            for j, variable in enumerate(variables):
                value = ua.DataValue(
                    ua.Variant(float(j * 1_000_000 + k), ua.VariantType.Double),
                    SourceTimestamp=stamp(base + k * PERIOD),
                    ServerTimestamp=now,
                )
                await server.write_attribute_value(variable.nodeid, value)
            # Paced to the schedule, not to the last write: no drift.
            await asyncio.sleep(max(0.0, start + (n + 1) * PERIOD - time.monotonic()))
        print(f"done {first + count}", flush=True)
        while True:
            await asyncio.sleep(1)


if __name__ == "__main__":
    port, uri, first, count = sys.argv[1], sys.argv[2], int(sys.argv[3]), int(sys.argv[4])
    base = float(sys.argv[5]) if len(sys.argv) > 5 else round(time.time(), 2)
    asyncio.run(main(port, uri, first, count, base))
