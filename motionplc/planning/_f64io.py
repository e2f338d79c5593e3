"""Little-endian float64 I/O on bytes: ``librt.strings`` where it is installed, else this.

The batch planner's compiled rows (:mod:`motionplc.planning._batchrow`) read their inputs from
and write their segments to bytes with ``librt.strings``' ``read_f64_le`` / ``write_f64_le``
(mypyc turns them into inline C: no Python float per value). ``librt`` is a dependency where
CPython runs (it is mypyc's run-time library); this module is the plain-Python stand-in with
the same behaviour for an installation without it (``BytesWriter`` with ``getvalue``,
``truncate`` and ``len``; a ``ValueError`` for a negative index, an ``IndexError`` for a
read beyond the bytes), used only by the
pure-Python planning core.
"""

from __future__ import annotations

import struct

_F64 = struct.Struct("<d")


class BytesWriter:
    """A growing byte buffer (``librt.strings.BytesWriter``'s part used here)."""

    __slots__ = ("_buf",)

    def __init__(self) -> None:
        self._buf = bytearray()

    def getvalue(self) -> bytes:
        return bytes(self._buf)

    def truncate(self, size: int, /) -> None:
        if not 0 <= size <= len(self._buf):
            raise ValueError(f"size must be in [0, {len(self._buf)}], got {size}")
        del self._buf[size:]

    def __len__(self) -> int:
        return len(self._buf)


def write_f64_le(b: BytesWriter, n: float, /) -> None:
    """Append ``n`` as a little-endian IEEE double."""
    b._buf += _F64.pack(n)


def read_f64_le(b: bytes, index: int, /) -> float:
    """The little-endian IEEE double at byte ``index`` of ``b``."""
    if index < 0:
        raise ValueError("index must be non-negative")
    if index > len(b) - 8:
        raise IndexError(f"index {index} out of range for bytes of length {len(b)}")
    return float(_F64.unpack_from(b, index)[0])
