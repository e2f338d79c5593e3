"""Fast encode/decode of a canopen ``PdoMap`` in the cyclic path.

The PDO layout comes from canopen (the map's variables, offsets, lengths and object types);
this only compiles it into one ``struct.Struct`` so that a cycle does one ``pack``/``unpack``
per PDO instead of one ``PdoVariable.raw`` round trip (with its logging and per-variable
encoding) per mapped object. Maps with bit-level (non byte-aligned) entries keep canopen's own
``PdoVariable.raw`` path.
"""

from __future__ import annotations

import struct
from collections.abc import Sequence
from typing import Any

__all__ = ["PdoCodec"]


class PdoCodec:
    """One compiled PDO layout: ``keys`` are the (index, subindex) of the mapped objects."""

    def __init__(self, pdo_map: Any) -> None:
        self.pdo_map = pdo_map
        self.keys: tuple[tuple[int, int], ...] = tuple((v.index, v.subindex) for v in pdo_map.map)
        self.length = (pdo_map.length + 7) // 8
        fmt = "<"
        pos = 0
        aligned = True
        for var in pdo_map.map:
            od_struct = var.od.STRUCT_TYPES.get(var.od.data_type)
            if (
                od_struct is None
                or var.offset % 8
                or var.length != 8 * od_struct.size
                or var.offset // 8 < pos
            ):
                aligned = False
                break
            gap = var.offset // 8 - pos
            if gap:
                fmt += f"{gap}x"
            fmt += od_struct.format.lstrip("<>=!@")
            pos = var.offset // 8 + od_struct.size
        self._struct = struct.Struct(fmt) if aligned else None
        if self._struct is not None and self._struct.size != self.length:
            self._struct = None
        # the compiled layout's own pack (values as arguments), None for canopen's path
        self.struct_pack = self._struct.pack if self._struct is not None else None
        self.struct_unpack = self._struct.unpack if self._struct is not None else None

    def pack(self, values: Sequence[int]) -> bytes:
        """Bytes of the PDO for ``values`` in map order."""
        if self._struct is not None:
            return self._struct.pack(*values)
        for var, value in zip(self.pdo_map.map, values, strict=True):
            var.raw = value
        return bytes(self.pdo_map.data)

    def unpack(self, data: bytes | bytearray) -> tuple[int, ...] | None:
        """Values in map order, or None if the frame length does not match the map."""
        if len(data) != self.length:
            return None
        if self._struct is not None:
            return self._struct.unpack(data)
        self.pdo_map.data = bytearray(data)  # canopen's variables decode the map's data
        return tuple(var.raw for var in self.pdo_map.map)

    def transmit(self, values: Sequence[int]) -> None:
        """Set the map's data and send it once (``PdoMap.transmit``)."""
        self.pdo_map.data = bytearray(self.pack(values))
        self.pdo_map.transmit()
