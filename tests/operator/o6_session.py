"""One OPC UA session with the o6 client (open62541): the operations of ``clients.py`` read as
JSON from stdin, the results printed as ``RESULT <json>`` (run in a subprocess by the tests)."""

from __future__ import annotations

import json
import logging
import sys
import threading
from typing import Any

NS_URI = "urn:motionplc:machine"
POLICY = "http://opcfoundation.org/UA/SecurityPolicy#"
BAD_NOT_CONNECTED = 0x808A0000


def _plain(v: Any) -> Any:
    if isinstance(v, (bool, str)) or v is None:
        return v
    if hasattr(v, "unitId"):  # EUInformation
        return {"UnitId": int(v.unitId), "DisplayName": str(v.displayName.text)}
    if isinstance(v, (list, tuple)):
        return [_plain(x) for x in v]
    try:
        import numpy as np

        if isinstance(v, np.ndarray):
            return [_plain(x) for x in v.tolist()]
        if isinstance(v, np.bool_):
            return bool(v)
        if isinstance(v, np.integer):
            return int(v)
    except ImportError:  # pragma: no cover
        pass
    if isinstance(v, int):
        return int(v)
    try:
        return float(v)
    except (TypeError, ValueError):
        return str(v)


def _code(exc: BaseException) -> int:
    code = getattr(exc, "code", None)
    try:
        return int(code)  # type: ignore[arg-type]
    except (TypeError, ValueError):
        return 0x80010000  # BadUnexpectedError


def main() -> int:
    """One job per line of stdin (a session), one ``RESULT`` line per job (the process stays:
    importing o6 takes seconds)."""
    logging.basicConfig(level=logging.ERROR)
    import o6

    print("READY", flush=True)  # noqa: T201
    for line in sys.stdin:
        if line.strip():
            print("RESULT " + json.dumps(session(o6, json.loads(line))), flush=True)  # noqa: T201
    return 0


def session(o6: Any, job: dict[str, Any]) -> list[dict[str, Any]]:
    endpoint, sec, ops = job["endpoint"], job["security"], job["ops"]
    client: Any = None
    ns = 0
    out: list[dict[str, Any]] = []
    kinds = {"Double": o6.Double, "Int32": o6.Int32, "Boolean": bool, "String": str}

    def nid(s: str) -> str:
        return f"ns={ns};{s}"

    try:
        for op in ops:
            k = op["op"]
            if k == "connect":
                if client is not None:
                    client.disconnect()
                    client = None
                kw: dict[str, Any] = {}
                if op.get("user") is not None:
                    kw.update(username=op["user"], password=op.get("password") or "")
                if op["mode"] != "None":
                    kw.update(
                        securityMode={"Sign": 2, "SignAndEncrypt": 3}[op["mode"]],
                        securityPolicy=POLICY + "Basic256Sha256",
                        certificate=sec["cert"],
                        privateKey=sec["key"],
                        applicationUri=sec["uri"],
                        trustList=[sec["server_cert"]],
                    )
                else:  # the certificate: to encrypt a password with the user token policy
                    kw.update(
                        securityMode=1,
                        certificate=sec["cert"],
                        privateKey=sec["key"],
                        applicationUri=sec["uri"],
                        allowNonePolicyPassword=False,
                    )
                client = o6.Client(endpoint, **kw)
                try:
                    client.connect()
                except o6.StatusCodeError as exc:
                    out.append({"status": _code(exc)})
                    client = None
                    continue
                uris = list(client.read("i=2255"))  # Server_NamespaceArray
                ns = uris.index(NS_URI)
                out.append({"status": 0})
            elif client is None:
                out.append({"status": BAD_NOT_CONNECTED})
            elif k == "read":
                try:
                    out.append({"status": 0, "value": _plain(client.read(nid(op["node"])))})
                except o6.StatusCodeError as exc:
                    out.append({"status": _code(exc)})
            elif k == "browse":
                try:
                    refs = client.browse(nid(op["node"]))
                    out.append({"status": 0, "names": [r.browseName.name for r in refs]})
                except o6.StatusCodeError as exc:
                    out.append({"status": _code(exc)})
            elif k == "call":
                args = [kinds[t](v) for v, t in op["args"]]
                try:
                    res = client.call(nid(op["object"]), nid(op["method"]), args)
                except o6.StatusCodeError as exc:  # a service fault (access denied)
                    out.append({"status": _code(exc), "outputs": []})
                    continue
                out.append({"status": int(res[0]), "outputs": [_plain(x) for x in res[1:]]})
            elif k == "subscribe":
                changes: dict[str, list[Any]] = {n: [] for n in op["nodes"]}
                lock = threading.Lock()
                iv = float(op.get("interval_ms", 10))
                sub = client.createSubscription(publishingInterval=iv)

                def make(name: str, seen: dict[str, list[Any]], lk: Any) -> Any:
                    def cb(item: Any, value: Any) -> None:
                        with lk:
                            seen[name].append(_plain(value))

                    return cb

                for n in op["nodes"]:
                    client.monitor(
                        nid(n), make(n, changes, lock), samplingInterval=iv, subscription=sub
                    )
                threading.Event().wait(op["seconds"])
                sub.delete()
                with lock:
                    out.append({"status": 0, "changes": changes})
            elif k == "sleep":
                threading.Event().wait(op["seconds"])
                out.append({"status": 0})
            elif k == "wait_value":  # poll until the node reads the value (or the timeout)
                ev = threading.Event()
                for _ in range(int(op["timeout"] / 0.05) + 1):
                    v = _plain(client.read(nid(op["node"])))
                    if matches(v, op):
                        break
                    ev.wait(0.05)
                out.append({"status": 0, "value": v})
            else:
                raise ValueError(f"unknown op {k!r}")
    finally:
        if client is not None:
            try:
                client.disconnect()
            except Exception:  # noqa: BLE001 - the results are already in
                pass
    return out


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


if __name__ == "__main__":
    raise SystemExit(main())
