"""A secured OPC UA client of `twin serve`, on Python asyncua (a stack the twin did not write).

Usage: client.py URL SECURITY CERT_DIR USER PASSWORD ACTION

SECURITY is `None`, `Sign` or `SignAndEncrypt` (Basic256Sha256 for the last two). CERT_DIR holds
the client's certificate (cert.der) and key (key.pem), made there by asyncua's cert_gen if they
are not (common name "twin test client"). USER and PASSWORD are `-` for an anonymous session.
ACTION is:

- `lockstep`: reads crank.position and status.period, writes 20 N·m to effort.crank, advances
  10 periods, reads again, then advances to the run's end;
- `connect`: connects and disconnects.

Connection attempts are retried while the server is not up yet (a refused connection, a
timeout); a refusal by the server is not retried. Prints one JSON object: {"refused": "<why>"}
or what was seen.
"""

import asyncio
import json
import sys
from pathlib import Path

from asyncua import ua
from asyncua.crypto.cert_gen import setup_self_signed_certificate
from cryptography.x509.oid import ExtendedKeyUsageOID

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))
from opcua_connect import connect, disconnect  # noqa: E402  (the tests' shared helper)

APP_URI = "urn:twin:test:client"


async def certificate(cert_dir):
    cert_dir = Path(cert_dir)
    cert_dir.mkdir(parents=True, exist_ok=True)
    cert, key = cert_dir / "cert.der", cert_dir / "key.pem"
    await setup_self_signed_certificate(
        key, cert, APP_URI, "localhost", [ExtendedKeyUsageOID.CLIENT_AUTH],
        {"commonName": "twin test client"},
    )
    return cert, key


async def connect_as(url, security, cert_dir, user, password):
    cert, key = await certificate(cert_dir) if security != "None" else (None, None)

    async def prepare(client):
        client.application_uri = APP_URI
        if user != "-":
            client.set_user(user)
            client.set_password(password)
        if security != "None":
            await client.set_security_string(f"Basic256Sha256,{security},{cert},{key}")

    return await connect(url, prepare)


async def lockstep(client):
    ns = await client.get_namespace_index("urn:twin:whitworth")
    machine = await client.nodes.objects.get_child(f"{ns}:whitworth")
    position = client.get_node(ua.NodeId("crank.position", ns))
    period = client.get_node(ua.NodeId("status.period", ns))
    effort = client.get_node(ua.NodeId("effort.crank", ns))
    seen = {"position_before": await position.read_value(), "period_before": await period.read_value()}
    await effort.write_value(ua.DataValue(ua.Variant(20.0, ua.VariantType.Double)))
    seen["advanced_to"] = await machine.call_method(f"{ns}:Advance", ua.Variant(10, ua.VariantType.UInt32))
    seen["position_after"] = await position.read_value()
    seen["period_after"] = await period.read_value()
    seen["advanced_to_end"] = await machine.call_method(
        f"{ns}:Advance", ua.Variant(1_000_000, ua.VariantType.UInt32)
    )
    return seen


async def main(url, security, cert_dir, user, password, action):
    try:
        client = await connect_as(url, security, cert_dir, user, password)
    except (ua.UaError, ua.UaStatusCodeError) as error:
        print(json.dumps({"refused": f"{type(error).__name__}: {error}"}))
        return
    try:
        seen = await lockstep(client) if action == "lockstep" else {"connected": True}
    finally:
        await disconnect(client)
    print(json.dumps(seen))


if __name__ == "__main__":
    asyncio.run(main(*sys.argv[1:]))
