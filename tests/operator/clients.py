"""Two OPC UA clients behind one interface, for the same test suite: asyncua (in this process)
and o6 (open62541, an independent implementation; run in a subprocess of its own, so its
evaluation licence's ten-minute limit never touches the test process).

A session is a list of operations (JSON-able dicts), run in order on one connection;
``run_ops(kind, endpoint, security, ops)`` returns one result per operation:

* ``{"op": "connect", "mode": "None"|"Sign"|"SignAndEncrypt", "user": str|None,
  "password": str|None}`` -> ``{"status": int}`` (0: the session is active);
* ``{"op": "read", "node": "s=axis.x.ActualPosition"}`` -> ``{"status", "value"}``;
* ``{"op": "browse", "node": ...}`` -> ``{"status", "names": [browse names]}``;
* ``{"op": "call", "object": ..., "method": ..., "args": [[value, "Double"|"Int32"|"Boolean"|
  "String"], ...]}`` -> ``{"status", "outputs": [...]}``;
* ``{"op": "subscribe", "nodes": [...], "interval_ms": 10, "seconds": 0.5}`` ->
  ``{"status", "changes": {node: [values]}}``;
* ``{"op": "sleep", "seconds": s}``.

Node ids are written without the namespace (``s=axis.x``): each client puts the index of
``urn:motionplc:machine`` in front. Status codes are the numeric OPC UA codes.
"""

from __future__ import annotations

import asyncio
import json
import subprocess
import sys
from pathlib import Path
from typing import Any

NS_URI = "urn:motionplc:machine"
POLICY = "http://opcfoundation.org/UA/SecurityPolicy#Basic256Sha256"
HERE = Path(__file__).resolve().parent


class O6Worker:
    """The o6 client in a process of its own (``o6_session.py``), one session per job."""

    def __init__(self) -> None:
        self.proc = subprocess.Popen(
            [sys.executable, str(HERE / "o6_session.py")],
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            stderr=subprocess.DEVNULL,
            text=True,
        )
        self._expect("READY")

    def _expect(self, head: str) -> str:
        assert self.proc.stdout is not None
        for line in self.proc.stdout:
            if line.startswith(head):
                return line[len(head) :].strip()
        raise RuntimeError(f"the o6 client process ended (exit {self.proc.wait(10)})")

    def run(self, endpoint: str, security: dict[str, str], ops: list[dict[str, Any]]) -> list:
        assert self.proc.stdin is not None
        job = {"endpoint": endpoint, "security": security, "ops": ops}
        self.proc.stdin.write(json.dumps(job) + "\n")
        self.proc.stdin.flush()
        return json.loads(self._expect("RESULT "))

    def close(self) -> None:
        if self.proc.stdin is not None:
            self.proc.stdin.close()
        try:
            self.proc.wait(10)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            self.proc.wait(10)


def run_ops(
    kind: str,
    endpoint: str,
    security: dict[str, str],
    ops: list[dict[str, Any]],
    o6: O6Worker | None = None,
) -> list:
    """Run ``ops`` with client ``kind`` ("asyncua" or "o6", the latter in ``o6``).
    ``security``: the client's certificate / key files (``cert``, ``key``, ``uri``)."""
    if kind == "asyncua":
        return asyncio.run(_asyncua(endpoint, security, ops))
    assert o6 is not None
    return o6.run(endpoint, security, ops)


def _code(exc: BaseException) -> int:
    code = getattr(exc, "code", None)
    if isinstance(code, int):
        return code
    from asyncua import ua

    return int(ua.StatusCodes.BadUnexpectedError)


async def _asyncua(endpoint: str, security: dict[str, str], ops: list[dict[str, Any]]) -> list:
    from asyncua import Client, ua

    out: list[dict[str, Any]] = []
    client: Any = None
    ns = 0

    def nid(s: str) -> Any:
        return ua.NodeId.from_string(f"ns={ns};{s}")

    vt = {
        "Double": ua.VariantType.Double,
        "Int32": ua.VariantType.Int32,
        "Boolean": ua.VariantType.Boolean,
        "String": ua.VariantType.String,
    }
    try:
        for op in ops:
            kind = op["op"]
            if kind == "connect":
                if client is not None:
                    await client.disconnect()
                    client = None
                client = Client(endpoint, timeout=10)
                if op.get("user") is not None:
                    client.set_user(op["user"])
                    client.set_password(op.get("password") or "")
                client.application_uri = security["uri"]
                if op["mode"] != "None":
                    await client.set_security_string(
                        f"Basic256Sha256,{op['mode']},{security['cert']},{security['key']}"
                    )
                try:
                    await client.connect()
                except Exception as exc:  # noqa: BLE001 - the status is the result
                    out.append({"status": _code(exc)})
                    client = None
                    continue
                ns = await client.get_namespace_index(NS_URI)
                out.append({"status": 0})
            elif client is None:
                out.append({"status": int(ua.StatusCodes.BadNotConnected)})
            elif kind == "read":
                try:
                    v = await client.get_node(nid(op["node"])).read_value()
                    out.append({"status": 0, "value": _plain(v)})
                except ua.UaStatusCodeError as exc:
                    out.append({"status": _code(exc)})
            elif kind == "browse":
                try:
                    kids = await client.get_node(nid(op["node"])).get_children()
                    names = [(await k.read_browse_name()).Name for k in kids]
                    out.append({"status": 0, "names": names})
                except ua.UaStatusCodeError as exc:
                    out.append({"status": _code(exc)})
            elif kind == "call":
                req = ua.CallMethodRequest()
                req.ObjectId = nid(op["object"])
                req.MethodId = nid(op["method"])
                req.InputArguments = [ua.Variant(v, vt[t]) for v, t in op["args"]]
                try:
                    res = await client.uaclient.call([req])
                except ua.UaStatusCodeError as exc:  # a service fault (access denied)
                    out.append({"status": _code(exc), "outputs": []})
                    continue
                r = res[0]
                out.append(
                    {
                        "status": int(r.StatusCode.value),
                        "outputs": [_plain(v.Value) for v in r.OutputArguments or []],
                    }
                )
            elif kind == "subscribe":
                changes: dict[str, list[Any]] = {n: [] for n in op["nodes"]}
                names = {}

                sub = await client.create_subscription(
                    op.get("interval_ms", 10), _Handler(changes, names)
                )
                nodes = []
                for n in op["nodes"]:
                    node = client.get_node(nid(n))
                    names[node.nodeid] = n
                    nodes.append(node)
                await sub.subscribe_data_change(nodes, sampling_interval=op.get("interval_ms", 10))
                await asyncio.sleep(op["seconds"])
                await sub.delete()
                out.append({"status": 0, "changes": changes})
            elif kind == "sleep":
                await asyncio.sleep(op["seconds"])
                out.append({"status": 0})
            elif kind == "wait_value":  # poll until the node reads the value (or the timeout)
                node = client.get_node(nid(op["node"]))
                for _ in range(int(op["timeout"] / 0.05) + 1):
                    v = _plain(await node.read_value())
                    if matches(v, op):
                        break
                    await asyncio.sleep(0.05)
                out.append({"status": 0, "value": v})
            else:
                raise ValueError(f"unknown op {kind!r}")
    finally:
        if client is not None:
            await client.disconnect()
    return out


class _Handler:
    def __init__(self, changes: dict[str, list[Any]], names: dict[Any, str]) -> None:
        self.changes, self.names = changes, names

    def datachange_notification(self, node: Any, val: Any, data: Any) -> None:
        self.changes[self.names[node.nodeid]].append(_plain(val))


def _plain(v: Any) -> Any:
    if isinstance(v, (bool, int, float, str)) or v is None:
        return v
    if hasattr(v, "UnitId"):  # EUInformation
        return {"UnitId": int(v.UnitId), "DisplayName": v.DisplayName.Text}
    if isinstance(v, (list, tuple)):
        return [_plain(x) for x in v]
    try:
        return float(v)
    except (TypeError, ValueError):
        return str(v)


def matches(v: Any, op: dict[str, Any]) -> bool:
    """``wait_value``: ``v`` is ``op["value"]`` (within ``op["tol"]``, element-wise for
    lists), or at least ``op["min"]``."""
    if "min" in op:
        return isinstance(v, (int, float)) and v >= op["min"]
    want, tol = op["value"], op.get("tol")
    if tol is None:
        return bool(v == want)
    if isinstance(want, list):
        return (
            isinstance(v, list)
            and len(v) == len(want)
            and all(abs(a - b) <= tol for a, b in zip(v, want, strict=True))
        )
    return isinstance(v, (int, float)) and abs(v - want) <= tol
