"""A machine that is not the twin, for `twin shadow`'s tests: an OPC UA server (Python asyncua)
publishing a logged run as a live machine's controller would.

Usage: machine.py --csv RUN.csv --port P [--namespace urn:machine] [--columns a,b] [--unit a=F]
    [--sampling 0.010] [--jitter 0.003] [--seed 0] [--epoch 1800000000|-1] [--speed 1] [--tick 0.005]
    [--out-of-order P] [--duplicate P] [--restart-at T --down D] [--linger 2] [--command-rows]

RUN.csv is in the twin's CSV format (`twin run SCENARIO --csv RUN.csv`: `time [s]`, then
`<column> [unit]`). Each published column is a Double variable `ns=<index of the namespace
URI>;s=<column>` under Objects, in the CSV's units or × F with `--unit column=F`. It is sampled
every `--sampling` s of data time, each sample's time jittered uniformly by ± `--jitter` (the
value is the one at the jittered time: interpolated, or for commands, `effort.*`, the last row at
or before), and written with SourceTimestamp = epoch + data time: the sample's time for a
measurement, the row's for a command (when the controller wrote it, as a PLC stamps its outputs). `--speed` data seconds run per
wall second; every `--tick` wall seconds the samples then due are written in data-time order.
`--out-of-order P`: a sample is, with probability P, held back and written just after the next
one of its node; `--duplicate P`: written again just after the next one (a re-sent sample: two
identical writes in a row reach no client, see below). `--restart-at T --down D`: at data time T
the server stops (its sessions die, the port closes), stays down D wall seconds, then serves the
same nodes again on the same port from the data time reached (the samples due meanwhile are
lost). `--command-rows`: each command (`effort.*`) row is written once instead, at its own time,
unjittered, as a PLC writes its outputs at each control update (sampled, a quarter of the rows
fall between two samples at the default jitter and are never published). A node reads
BadWaitingForInitialData until its first sample after each start. Prints `ready <endpoint>`,
`down`, `up` and `done` on stdout.

What an asyncua 2.1 server delivers, found by experiment (a client subscribed at a 50 ms
publishing interval, 10 samples of a node written per interval, `--speed 2`):
- Writes are not coalesced: every write that passes the monitored item's trigger is queued, and
  the next publish response carries them all, in write order, each with its source timestamp
  (out-of-order ones too). The queue holds the client's requested size, the oldest dropped when
  full; a requested size of 0 (asyncua's client default) is revised to 10,000, not to the
  standard's 1. A client asking for a queue of 1 gets one value per interval, the last.
- A write passes the default trigger (StatusValue) only if its value or status differs from the
  node's previous write: a command held over several samples (same value, new timestamp) is
  delivered once. With a DataChangeFilter of trigger StatusValueTimestamp every new timestamp
  passes. Two identical writes in a row (same value and timestamp) never pass either trigger,
  which is why a duplicate is re-sent after the next sample instead.
So the machine writes at its real sampling rate, and a consumer with a queue larger than the
samples per publishing interval and the timestamp trigger receives every sample.
"""

import argparse
import asyncio
import csv
import datetime
import logging
import sys
import time

import numpy as np
from asyncua import Server, ua


def arguments(argv):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--csv", required=True, help="the run, in the twin's CSV format")
    parser.add_argument("--port", type=int, required=True)
    parser.add_argument("--namespace", default="urn:machine")
    parser.add_argument("--columns", help="columns to publish, comma-separated (default: all)")
    parser.add_argument("--unit", action="append", default=[], metavar="COLUMN=FACTOR")
    parser.add_argument("--sampling", type=float, default=0.010, help="data seconds")
    parser.add_argument("--jitter", type=float, default=0.003, help="data seconds, ± uniform")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--epoch", type=float, default=1_800_000_000.0,
                        help="UNIX seconds of data time 0; negative: the wall clock when it is published")
    parser.add_argument("--speed", type=float, default=1.0, help="data seconds per wall second")
    parser.add_argument("--tick", type=float, default=0.005, help="wall seconds")
    parser.add_argument("--out-of-order", type=float, default=0.0, metavar="P")
    parser.add_argument("--duplicate", type=float, default=0.0, metavar="P")
    parser.add_argument("--restart-at", type=float, metavar="T", help="data seconds")
    parser.add_argument("--down", type=float, default=1.0, metavar="D", help="wall seconds")
    parser.add_argument("--linger", type=float, default=2.0, help="wall seconds")
    parser.add_argument(
        "--command-rows", action="store_true", help="write each command row, at its time"
    )
    args = parser.parse_args(argv)
    if not (args.sampling > 0 and args.speed > 0 and args.tick > 0 and args.jitter >= 0):
        parser.error("--sampling, --speed and --tick must be > 0, --jitter >= 0")
    return args


def read_run(path):
    """The run's times and its columns by name (the header's text before ` [unit]`)."""
    with open(path, newline="", encoding="utf-8") as file:
        rows = csv.reader(file)
        header = [name.split(" [")[0] for name in next(rows)]
        data = np.array([[float(v) for v in row] for row in rows if row])
    if header[0] != "time" or data.ndim != 2 or len(data) < 2:
        raise SystemExit(f"{path}: not a run in the twin's CSV format (time [s], then columns)")
    return data[:, 0], {name: data[:, i] for i, name in enumerate(header) if i > 0}


def sampled(times, values, at, command):
    """The column at the times `at`: interpolated, or a command's last row at or before."""
    if command:
        # A row stamped a rounding above the sample time (2.7600000000000002 for 2.76) is the
        # one written at that time.
        rows = np.searchsorted(times, at + 1e-9, side="right") - 1
        return values[np.clip(rows, 0, len(times) - 1)]
    return np.interp(at, times, values)


def schedule(times, columns, names, factors, args):
    """The writes in the order they are made: (due data time, copy?, column, value, data time)."""
    rng = np.random.default_rng(args.seed)
    nominal = np.arange(0.0, times[-1] + 1e-12, args.sampling)
    writes = []
    for name in names:
        at = np.clip(nominal + rng.uniform(-args.jitter, args.jitter, len(nominal)), 0, times[-1])
        at = np.round(np.sort(at), 6)  # as stamped: a source timestamp holds whole microseconds
        command = name.startswith("effort.")
        if command and args.command_rows:
            at = np.round(times, 6)
        values = sampled(times, columns[name], at, command) * factors[name]
        # A command is stamped when the controller wrote it (its row), as a PLC stamps its
        # outputs; a measurement when it was sampled.
        stamps = sampled(times, times, at, True) if command else at
        samples = [(t, name, v, s) for t, v, s in zip(at.tolist(), values.tolist(), stamps.tolist())]
        i = 0
        while i < len(samples) - 1:  # held back: written when the next one is, just after it
            if rng.random() < args.out_of_order:
                held, samples[i] = samples[i], samples[i + 1]
                samples[i + 1] = (samples[i][0], *held[1:])
                i += 1
            i += 1
        for i, (due, *sample) in enumerate(samples):
            writes.append((due, 0, *sample))
            if rng.random() < args.duplicate:  # again, after the node's next sample (see above)
                writes.append((samples[min(i + 1, len(samples) - 1)][0], 1, *sample))
    # Stable: a node's held-back sample stays after the one it waits for, a copy after both.
    writes.sort(key=lambda w: w[:2])
    return writes


async def made(args, names):
    """A server with the nodes, each waiting for its first sample; not listening yet."""
    server = Server()
    await server.init()
    server.set_endpoint(f"opc.tcp://127.0.0.1:{args.port}/")
    server.set_security_policy([ua.SecurityPolicyType.NoSecurity])
    index = await server.register_namespace(args.namespace)
    nodes = {}
    for name in names:
        node = await server.nodes.objects.add_variable(
            ua.NodeId(name, index), ua.QualifiedName(name, index), 0.0, ua.VariantType.Double
        )
        waiting = ua.DataValue(StatusCode=ua.StatusCode(ua.StatusCodes.BadWaitingForInitialData))
        await server.write_attribute_value(node.nodeid, waiting)
        nodes[name] = node.nodeid
    return server, nodes


async def write(server, node, sample, epoch):
    """One sample, stamped at its data time (to the microsecond)."""
    _, _, _, value, source = sample
    await server.write_attribute_value(
        node,
        ua.DataValue(
            ua.Variant(value, ua.VariantType.Double),
            SourceTimestamp=epoch + datetime.timedelta(seconds=source),
            ServerTimestamp=datetime.datetime.now(datetime.timezone.utc),
        ),
    )


def say(text):
    print(text, flush=True)


async def stopped(server):
    """Stops the server so that every session dies. asyncua's stop closes the sessions' transports
    and only then the listening socket, and waits for every connection to end: a client
    reconnecting in between (the shadow does, 0.1 s after it lost its session) is accepted,
    never closed, and the stop waits forever. So the listener is closed first, and connections
    still open after a while are aborted."""
    binary = server.bserver
    if binary is not None and binary._server is not None:
        binary._server.close()
    stopping = asyncio.ensure_future(server.stop())
    while True:
        done, _ = await asyncio.wait({stopping}, timeout=1.0)
        if done:
            return
        for transport in list(binary.iserver.asyncio_transports):
            transport.abort()


async def play(args):
    times, columns = read_run(args.csv)
    names = args.columns.split(",") if args.columns else list(columns)
    unknown = [n for n in names if n not in columns]
    if unknown:
        known = ", ".join(columns)
        raise SystemExit(f"no column {', '.join(unknown)} in {args.csv} (known: {known})")
    factors = {name: 1.0 for name in names}
    for entry in args.unit:
        name, _, factor = entry.partition("=")
        if name not in factors:
            raise SystemExit(f"--unit {entry}: {name} is not a published column")
        factors[name] = float(factor)
    writes = schedule(times, columns, names, factors, args)
    epoch = datetime.datetime.fromtimestamp(args.epoch, datetime.timezone.utc)
    server, nodes = await made(args, names)
    # The server after the restart is made now: an asyncua server takes a second to make.
    spare = await made(args, names) if args.restart_at is not None else None
    await server.start()
    say(f"ready opc.tcp://127.0.0.1:{args.port}/")
    start = time.monotonic()
    if args.epoch < 0:  # stamped with the wall clock, for latency figures (--speed 1)
        epoch = datetime.datetime.now(datetime.timezone.utc)
    restart_at = args.restart_at if args.restart_at is not None else float("inf")
    i = 0
    while i < len(writes):
        clock = (time.monotonic() - start) * args.speed
        while i < len(writes) and writes[i][0] <= min(clock, restart_at):
            await write(server, nodes[writes[i][2]], writes[i], epoch)
            i += 1
        if clock >= restart_at:
            restart_at, wake = float("inf"), time.monotonic() + args.down
            await stopped(server)
            say("down")
            server, nodes = spare
            await asyncio.sleep(max(0.0, wake - time.monotonic()))
            await server.start()
            say("up")
            clock = (time.monotonic() - start) * args.speed
            while i < len(writes) and writes[i][0] <= clock:  # lost while down
                i += 1
        await asyncio.sleep(args.tick)
    await asyncio.sleep(args.linger)
    await server.stop()
    say("done")


if __name__ == "__main__":
    logging.basicConfig(level=logging.ERROR)
    asyncio.run(play(arguments(sys.argv[1:])))
