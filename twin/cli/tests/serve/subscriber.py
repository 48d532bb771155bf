"""A subscriber of `twin serve` on Python asyncua (a stack the twin did not write): does it get
every control update?

Usage: subscriber.py URL MACHINE SIGNAL QUEUE OUT (lockstep CHUNK | watch)

Subscribes (publishing interval 20 ms) to status.period, status.time and SIGNAL with sampling
interval 0, queue QUEUE and trigger StatusValueTimestamp (a repeated value with a new source
timestamp is a sample too), as `twin shadow` does. With `lockstep CHUNK` it calls Advance(CHUNK)
and waits until the subscription has delivered the period reached before advancing again, so
the queues never hold more than CHUNK updates however slow the machine is; with `watch` the run
is paced by the wall clock and the client only listens. Stops once status.state is no longer
`running`. Writes one JSON object to OUT: each item's revised sampling interval (ms) and queue
size, each item's notifications in order of arrival ([source timestamp in µs since the UNIX
epoch, value, overflow bit]), and the share of control updates received between the first and
last period seen; prints the share, one line.
"""

import asyncio
import datetime
import json
import pathlib
import sys
import time

from asyncua import ua

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent.parent))
from opcua_connect import connect, disconnect  # noqa: E402  (the tests' shared helper)

PUBLISHING_INTERVAL_MS = 20
# How long a chunk's notifications may take to arrive, s (generous: a loaded machine).
ARRIVAL_TIMEOUT = 60.0
# How long `watch` waits for the run's end after it stopped hearing of it, s.
QUIET_TIMEOUT = 10.0
OVERFLOW_BIT = 0x480  # InfoType DataValue | Overflow, in a StatusCode's low bits
EPOCH = datetime.datetime(1970, 1, 1)


class Collector:
    """Keeps every notification of every item, in order of arrival."""

    def __init__(self):
        self.items = {}
        self.period = -1
        self.state = "starting"
        self.changed = asyncio.Event()
        self.last_heard = time.monotonic()

    def datachange_notification(self, node, value, data):
        dv = data.monitored_item.Value
        name = node.nodeid.Identifier
        stamp = dv.SourceTimestamp
        micros = None if stamp is None else to_micros(stamp)
        status = dv.StatusCode.value if dv.StatusCode is not None else 0
        self.items.setdefault(name, []).append([micros, value, bool(status & OVERFLOW_BIT == OVERFLOW_BIT)])
        if name == "status.period" and isinstance(value, int):
            self.period = max(self.period, value)
        if name == "status.state":
            self.state = value
        self.last_heard = time.monotonic()
        self.changed.set()

    def status_change_notification(self, status):
        pass



def to_micros(stamp):
    """A source timestamp (naive UTC, or aware) in whole µs since the UNIX epoch."""
    naive = stamp.replace(tzinfo=None) if stamp.tzinfo is None else stamp.astimezone(
        datetime.timezone.utc
    ).replace(tzinfo=None)
    delta = naive - EPOCH
    return (delta.days * 86_400 + delta.seconds) * 1_000_000 + delta.microseconds


async def wait_for(collector, done, timeout):
    """Waits until `done()` or `timeout` s without it."""
    deadline = time.monotonic() + timeout
    while not done():
        collector.changed.clear()
        remaining = deadline - time.monotonic()
        if remaining <= 0:
            return False
        try:
            await asyncio.wait_for(collector.changed.wait(), remaining)
        except asyncio.TimeoutError:
            return done()
    return True


async def subscribe(client, sub, nodes, queue):
    """Monitored items on `nodes`: sampling 0, `queue`, StatusValueTimestamp; their revised
    sampling intervals and queue sizes, as the server answered."""
    answered = []
    create = sub.server.create_monitored_items

    async def keep(params):
        results = await create(params)
        answered.extend(results)
        return results

    sub.server.create_monitored_items = keep
    trigger = ua.DataChangeFilter(Trigger=ua.DataChangeTrigger.StatusValueTimestamp)
    requests = [
        sub._make_monitored_item_request(
            node, ua.AttributeIds.Value, trigger, queue, ua.MonitoringMode.Reporting, 0.0
        )
        for node in nodes
    ]
    ids = await sub.create_monitored_items(requests)
    for node, id_ in zip(nodes, ids):
        if isinstance(id_, ua.StatusCode):
            raise SystemExit(f"cannot monitor {node}: {id_}")
    return [
        {"sampling_ms": r.RevisedSamplingInterval, "queue": r.RevisedQueueSize} for r in answered
    ]


async def lockstep(client, machine, ns, collector, chunk):
    """Advances CHUNK periods at a time, each time waiting for the period reached to arrive."""
    while True:
        try:
            reached = await machine.call_method(
                f"{ns}:Advance", ua.Variant(chunk, ua.VariantType.UInt32)
            )
        except ua.UaStatusCodeError:
            break  # the run is over
        if not await wait_for(collector, lambda: collector.period >= reached, ARRIVAL_TIMEOUT):
            raise SystemExit(f"period {reached} never arrived (last {collector.period})")
        if collector.state not in ("starting", "running"):
            break


async def main(url, machine_name, signal, queue, out, mode, chunk):
    client = await connect(url)
    try:
        ns = await client.get_namespace_index(f"urn:twin:{machine_name}")
        machine = await client.nodes.objects.get_child(f"{ns}:{machine_name}")
        names = ["status.period", "status.time", signal, "status.state"]
        nodes = [client.get_node(ua.NodeId(name, ns)) for name in names]
        collector = Collector()
        sub = await client.create_subscription(PUBLISHING_INTERVAL_MS, collector)
        revised = await subscribe(client, sub, nodes, queue)
        if mode == "lockstep":
            await lockstep(client, machine, ns, collector, chunk)
        ended = lambda: collector.state not in ("starting", "running")  # noqa: E731
        while not await wait_for(collector, ended, QUIET_TIMEOUT):
            if time.monotonic() - collector.last_heard > QUIET_TIMEOUT:
                break
    finally:
        await disconnect(client)
    periods = sorted({v for _, v, _ in collector.items.get("status.period", [])})
    span = periods[-1] - periods[0] + 1 if periods else 0
    seen = {
        "revised": dict(zip(names, revised)),
        "items": collector.items,
        "state": collector.state,
        "updates": span,
        "received": len(periods),
        "share": len(periods) / span if span else 0.0,
    }
    pathlib.Path(out).write_text(json.dumps(seen))
    print(f"{seen['received']} of {span} control updates received ({100 * seen['share']:.2f} %)")


if __name__ == "__main__":
    url, machine_name, signal, queue, out, mode = sys.argv[1:7]
    chunk = int(sys.argv[7]) if mode == "lockstep" else 0
    asyncio.run(main(url, machine_name, signal, int(queue), out, mode, chunk))
