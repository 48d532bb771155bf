"""An OPC UA client of `twin serve --lockstep --with-controller`, on Python asyncua.

Usage: setpoint.py URL MACHINE JOINT BLOCK OFFSETS_JSON. Connects (retrying while the server
starts), browses the machine's Commands, then for each [reference, rate, acceleration] offset of
OFFSETS_JSON writes it to setpoint.reference, setpoint.reference_rate and
setpoint.reference_acceleration, advances BLOCK control periods and reads every measured signal
and effort.JOINT (the controller's command), as their IEEE 754 bits. Tries to write effort.JOINT (must be refused) and a
NaN setpoint (must be refused), then advances to the run's end. Prints what it saw as one JSON
object.
"""

import asyncio
import json
import struct
import pathlib
import sys

from asyncua import ua

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent.parent))
from opcua_connect import connect, disconnect, final_state  # noqa: E402  (the tests' shared helper)

SETPOINTS = ["reference", "reference_rate", "reference_acceleration"]


async def names(node):
    return sorted([(await child.read_browse_name()).Name for child in await node.get_children()])


def bits(value):
    """A double's IEEE 754 bits, so that the test compares values exactly."""
    return struct.unpack("<Q", struct.pack("<d", value))[0]


async def refusal(node, value):
    try:
        await node.write_value(ua.DataValue(ua.Variant(value, ua.VariantType.Double)))
        return "accepted"
    except ua.UaStatusCodeError as error:
        return type(error).__name__


async def main(url, machine_name, joint, block, offsets):
    client = await connect(url)
    try:
        ns = await client.get_namespace_index(f"urn:twin:{machine_name}")
        machine = await client.nodes.objects.get_child(f"{ns}:{machine_name}")
        signals = await machine.get_child(f"{ns}:Signals")
        signal_nodes = {
            (await node.read_browse_name()).Name: node for node in await signals.get_children()
        }
        setpoints = [client.get_node(ua.NodeId(f"setpoint.{name}", ns)) for name in SETPOINTS]
        effort = client.get_node(ua.NodeId(f"effort.{joint}", ns))
        commands = await machine.get_child(f"{ns}:Commands")
        seen = {
            "commands": await names(commands),
            "descriptions": {
                name: (await client.get_node(ua.NodeId(name, ns)).read_description()).Text
                for name in await names(commands)
            },
            "blocks": [],
        }
        for offset in offsets:
            for node, value in zip(setpoints, offset):
                await node.write_value(ua.DataValue(ua.Variant(value, ua.VariantType.Double)))
            read_back = [await node.read_value() for node in setpoints]
            period = await machine.call_method(
                f"{ns}:Advance", ua.Variant(block, ua.VariantType.UInt32)
            )
            measured = {
                name: bits(await node.read_value()) for name, node in signal_nodes.items()
            }
            seen["blocks"].append(
                {
                    "read_back": read_back,
                    "period": period,
                    "measured": measured,
                    "effort": bits(await effort.read_value()),
                }
            )
        seen["effort_write"] = await refusal(effort, 1.0)
        seen["nan_write"] = await refusal(setpoints[0], float("nan"))
        await machine.call_method(f"{ns}:Advance", ua.Variant(1_000_000, ua.VariantType.UInt32))
        seen["state"] = await final_state(client, ns)
    finally:
        await disconnect(client)
    print(json.dumps(seen))


if __name__ == "__main__":
    url, machine_name, joint, block, offsets = sys.argv[1:]
    asyncio.run(main(url, machine_name, joint, int(block), json.loads(offsets)))
