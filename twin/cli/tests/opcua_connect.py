"""Connecting the tests' Python OPC UA clients (asyncua) to a twin that may still be starting:
retries for up to 20 s, then gives up with one line."""

import asyncio

from asyncua import Client


async def connect(url):
    for _ in range(400):
        client = Client(url=url, timeout=10)
        try:
            await client.connect()
            return client
        except (OSError, asyncio.TimeoutError):
            await asyncio.sleep(0.05)
    raise SystemExit(f"no OPC UA server at {url}")
