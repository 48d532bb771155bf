"""What the tests' Python OPC UA clients (asyncua) share: connecting to a twin that may still be
starting (retried for up to 20 s, then one line), waiting for the run's end to be published, and
leaving a server that may already be gone."""

import asyncio

from asyncua import Client, ua


async def connect(url, prepare=None):
    """A connected client; `prepare(client)`, if given, sets it up (security, user) first."""
    last = None
    for _ in range(400):
        client = Client(url=url, timeout=10)
        try:
            if prepare is not None:
                await prepare(client)
            await client.connect()
            return client
        except (OSError, asyncio.TimeoutError) as error:
            last = error
            await asyncio.sleep(0.05)
    raise SystemExit(f"no OPC UA server at {url}: {last!r}")


async def final_state(client, ns):
    """`status.state` once it is no longer `running` (it is published after the last Advance
    returns, once the recording is finished: more than a second later on a loaded machine), or
    the last read after 10 s."""
    state = client.get_node(ua.NodeId("status.state", ns))
    for _ in range(1000):
        value = await state.read_value()
        if value != "running":
            break
        await asyncio.sleep(0.01)
    return value


async def disconnect(client):
    try:
        await client.disconnect()
    except Exception:  # the server may already be gone at the run's end
        pass
