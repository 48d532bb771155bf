"""An OPC UA client of the shadow's own server, on Python asyncua (a stack the twin did not
write).

Usage: reader.py URL URI OBJECT. Browses OBJECT in namespace URI, reads every variable under
its folders with its source timestamp and its EngineeringUnits property (if any), tries to write
one variable (it must be refused) and prints what it saw as one JSON object:
{"folders": [...], "values": {"Folder/name": {"value": …, "source": s since epoch,
"unit": {"id": UnitId, "name": DisplayName} or null}}, "write": "<status name>"}.
"""

import asyncio
import json
import pathlib
import sys
from datetime import timezone

from asyncua import ua

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent.parent))
from opcua_connect import connect  # noqa: E402  (the tests' shared helper)


def utc(stamp):
    # asyncua gives naive datetimes in UTC.
    return stamp if stamp.tzinfo else stamp.replace(tzinfo=timezone.utc)


async def unit_of(variable, ns):
    for child in await variable.get_properties():
        if (await child.read_browse_name()).Name == "EngineeringUnits":
            eu = await child.read_value()
            return {"id": eu.UnitId, "name": eu.DisplayName.Text, "namespace": eu.NamespaceUri}
    return None


async def main(url, uri, object_name):
    client = await connect(url)
    try:
        ns = await client.get_namespace_index(uri)
        machine = await client.nodes.objects.get_child(f"{ns}:{object_name}")
        seen = {"folders": [], "values": {}}
        first = None
        for folder in await machine.get_children():
            folder_name = (await folder.read_browse_name()).Name
            seen["folders"].append(folder_name)
            for variable in await folder.get_children():
                name = (await variable.read_browse_name()).Name
                data = await variable.read_data_value()
                seen["values"][f"{folder_name}/{name}"] = {
                    "value": data.Value.Value,
                    "source": utc(data.SourceTimestamp).timestamp(),
                    "node": variable.nodeid.to_string(),
                    "unit": await unit_of(variable, ns),
                }
                first = first or variable
        try:
            await first.write_value(ua.DataValue(ua.Variant(1.0, ua.VariantType.Double)))
            seen["write"] = "Good"
        except ua.UaStatusCodeError as error:
            seen["write"] = ua.StatusCode(error.code).name
        print(json.dumps(seen))
    finally:
        await client.disconnect()


if __name__ == "__main__":
    asyncio.run(main(*sys.argv[1:4]))
