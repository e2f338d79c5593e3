"""The settings of the OPC UA server (the ``opcua:`` block) and the users' password hashes.

Passwords are stored as ``scrypt$N$r$p$SALT$HASH`` (hashlib.scrypt, base64 salt and hash);
:func:`hash_password` makes one (``python -m motionplc.operator.passwd``), :func:`check_password`
compares in constant time.
"""

from __future__ import annotations

import base64
import hashlib
import hmac
import os
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import TYPE_CHECKING, Any

from motionplc.schema.opcua import OPCUA, POLICIES, SECURITY_MODES

if TYPE_CHECKING:
    from motionplc.config import Checker, YamlMap

__all__ = [
    "HmiSettings",
    "OpcUaSettings",
    "check_password",
    "hash_password",
    "parse_hmi",
    "parse_opcua",
]

_N, _R, _P = 2**14, 8, 1


def hash_password(password: str, *, salt: bytes | None = None) -> str:
    """``scrypt$N$r$p$SALT$HASH`` of ``password`` (a random 16-byte salt unless given)."""
    if not isinstance(password, str) or not password:
        raise ValueError("the password must be a non-empty string")
    salt = os.urandom(16) if salt is None else salt
    h = hashlib.scrypt(password.encode(), salt=salt, n=_N, r=_R, p=_P, dklen=32)
    b64 = base64.b64encode
    return f"scrypt${_N}${_R}${_P}${b64(salt).decode()}${b64(h).decode()}"


def check_password(password: str, stored: str) -> bool:
    """Whether ``password`` matches the ``scrypt$...`` hash ``stored`` (constant time)."""
    try:
        kind, n, r, p, salt, h = stored.split("$")
        if kind != "scrypt":
            return False
        want = base64.b64decode(h)
        got = hashlib.scrypt(
            password.encode(),
            salt=base64.b64decode(salt),
            n=int(n),
            r=int(r),
            p=int(p),
            maxmem=2**26,
            dklen=len(want),
        )
    except (ValueError, TypeError):
        return False
    return hmac.compare_digest(got, want)


@dataclass(frozen=True, slots=True)
class OpcUaSettings:
    """The OPC UA server's settings (defaults: the schema's). Paths are absolute."""

    host: str = "127.0.0.1"
    port: int = 4840
    security: tuple[str, ...] = ("Sign", "SignAndEncrypt")
    policy: str = "Basic256Sha256"
    certificate: str | None = None
    private_key: str | None = None
    certificate_dir: str = field(
        default_factory=lambda: str(Path.home() / ".local" / "state" / "motionplc" / "opcua")
    )
    anonymous: bool = True
    users: tuple[tuple[str, str], ...] = ()  # (name, password hash)
    publish_interval: float = 0.01
    program_start: str = "auto"

    def with_(self, **changes: Any) -> OpcUaSettings:
        return replace(self, **changes)

    def user_hash(self, name: str) -> str | None:
        return next((h for n, h in self.users if n == name), None)


@dataclass(frozen=True, slots=True)
class HmiSettings:
    """The web HMI's settings (the ``hmi:`` block; defaults: the schema's). ``users``: the
    operators who may log in (name, password hash); without its own ``users`` the block takes
    those of ``opcua:``."""

    host: str = "127.0.0.1"
    port: int = 8480
    users: tuple[tuple[str, str], ...] = ()
    anonymous: bool = True
    interval: float = 0.05

    def with_(self, **changes: Any) -> HmiSettings:
        return replace(self, **changes)

    def user_hash(self, name: str) -> str | None:
        return next((h for n, h in self.users if n == name), None)


def _users(c: Checker, m: YamlMap, path: str) -> tuple[tuple[str, str], ...]:
    um = c.mapping(m["users"], m.line_of("users"), f"{path}.users")
    users = []
    for name, body in (um or {}).items():
        if not c.name(um, name, f"{path}.users"):
            continue
        bm = c.mapping(body, um.line_of(name), f"{path}.users.{name}", {"password_hash": True})
        if bm is None:
            continue
        h = c.string(bm, "password_hash", f"{path}.users.{name}")
        if h is None:
            continue
        parts = h.split("$")
        if len(parts) != 6 or parts[0] != "scrypt" or not all(p.isdigit() for p in parts[1:4]):
            c.error(
                bm.line_of("password_hash"),
                f"{path}.users.{name}.password_hash",
                "not a password hash",
                "scrypt$N$r$p$SALT$HASH from python -m motionplc.operator.passwd",
            )
            continue
        users.append((str(name), h))
    return tuple(users)


def parse_hmi(c: Checker, top: YamlMap, opcua: OpcUaSettings | None = None) -> HmiSettings | None:
    """The ``hmi:`` block checked against its schema (errors go to ``c``); its users default
    to those of ``opcua`` (the parsed ``opcua:`` block)."""
    from motionplc.schema.opcua import HMI

    m = c.mapping(top["hmi"], top.line_of("hmi"), "hmi", HMI.table())
    if m is None:
        return None
    keys = {k.name: k.node for k in HMI.keys}
    out: dict[str, Any] = {}
    for name in ("host", "port", "anonymous", "interval"):
        if name in m and m[name] is not None:
            v = c.field(m, name, "hmi", keys[name])
            if v is not None:
                out[name] = v
    if m.get("users") is not None:
        out["users"] = _users(c, m, "hmi")
    elif opcua is not None:
        out["users"] = opcua.users
    return HmiSettings(**out)


def parse_opcua(c: Checker, top: YamlMap, config_path: str) -> OpcUaSettings | None:
    """The ``opcua:`` block checked against its schema (errors go to ``c``)."""
    m = c.mapping(top["opcua"], top.line_of("opcua"), "opcua", OPCUA.table())
    if m is None:
        return None
    keys = {k.name: k.node for k in OPCUA.keys}
    base = Path(config_path).resolve().parent
    out: dict[str, Any] = {}
    for name in ("host", "port", "policy", "anonymous", "publish_interval", "program_start"):
        if name in m and m[name] is not None:
            v = c.field(m, name, "opcua", keys[name])
            if v is not None:
                out[name] = v
    for name in ("certificate", "private_key", "certificate_dir"):
        v = c.string(m, name, "opcua")
        if v is not None:
            out[name] = str((base / Path(v).expanduser()).resolve())
    if ("certificate" in out) != ("private_key" in out):
        c.error(m.line, "opcua", "certificate and private_key go together", "both or neither")
    if m.get("security") is not None:
        sl = m["security"]
        if (
            not isinstance(sl, list)
            or not sl
            or not all(isinstance(x, str) and x in SECURITY_MODES for x in sl)
        ):
            c.error(
                m.line_of("security"),
                "opcua.security",
                f"got {sl!r}",
                "a list of " + ", ".join(SECURITY_MODES),
            )
        else:
            out["security"] = tuple(dict.fromkeys(sl))
    if m.get("users") is not None:
        out["users"] = _users(c, m, "opcua")
    assert POLICIES  # (the schema's choices are checked by c.field)
    return OpcUaSettings(**out)
