"""What the ``vcan`` tests need: a real SocketCAN ``vcan0`` (FB_TEST_VCAN names another) and,
for the frames injected on the wire, Debian's can-utils. A missing piece is a skip with the
reason on a host without it and a failure inside ``tools/with-vcan`` (``WITH_VCAN=1``)."""

from __future__ import annotations

import os
import shutil
import socket

import pytest


def vcan_channel() -> str:
    return os.environ.get("FB_TEST_VCAN", "vcan0")


def vcan_missing(name: str | None = None) -> str | None:
    """None when ``name`` (default :func:`vcan_channel`) is a usable SocketCAN interface,
    else why not."""
    name = name or vcan_channel()
    if not hasattr(socket, "AF_CAN"):
        return "this Python has no socket.AF_CAN"
    try:
        s = socket.socket(socket.AF_CAN, socket.SOCK_RAW, socket.CAN_RAW)
    except OSError as exc:
        return f"AF_CAN sockets are unavailable here ({exc.strerror or exc})"
    try:
        s.bind((name,))
    except OSError as exc:
        return f"no {name} interface ({exc.strerror or exc}); tools/setup_vcan.sh creates it"
    finally:
        s.close()
    return None


def need_tools(*names: str) -> None:
    """Skip (fail inside with-vcan) unless every program of ``names`` is on PATH."""
    missing = [n for n in names if shutil.which(n) is None]
    if not missing:
        return
    reason = f"{', '.join(missing)} not found (Debian: apt-get install can-utils)"
    if os.environ.get("WITH_VCAN") == "1":
        pytest.fail(f"inside with-vcan but {reason}", pytrace=False)
    pytest.skip(reason)
