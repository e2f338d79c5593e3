"""A small CANopen SDO client (CiA 301 §7.2.4): expedited upload/download, segmented upload.

It is a pure state machine: :meth:`SdoClient.read` / :meth:`SdoClient.write` return the
8-byte request to send on ``0x600 + node``; :meth:`SdoClient.on_response` takes the 8 bytes
received on ``0x580 + node`` and returns what to do next (an :class:`SdoSend` of the next
segment request, an :class:`SdoDone` with the uploaded bytes, or an :class:`SdoFailed` with the
abort code). It does no I/O and reads no clock: the caller sends the frames, delivers the
responses and decides when a transfer has waited too long (then :meth:`SdoClient.timeout`
gives the abort request to send). So the same client serves a blocking setup and one transfer
per control cycle.

Every value the motion master writes is at most 4 bytes (expedited download); uploads of
more than 4 bytes (e.g. a device name) arrive segmented and are accepted up to
:data:`MAX_UPLOAD` bytes.

:data:`ABORT_CODES` is the table of CiA 301 abort codes; :func:`abort_text` renders one, and
:func:`object_name` writes an object address as ``0x1800:01``.
"""

from __future__ import annotations

import struct
from dataclasses import dataclass

__all__ = [
    "ABORT_CODES",
    "ABORT_OBJECT_MISSING",
    "ABORT_SUBINDEX_MISSING",
    "ABORT_NOT_MAPPABLE",
    "ABORT_VALUE_RANGE",
    "ABORT_TIMEOUT",
    "MAX_UPLOAD",
    "SdoClient",
    "SdoDone",
    "SdoFailed",
    "SdoSend",
    "abort_text",
    "object_name",
]

# CiA 301 v4.2, table 22 "SDO abort codes" (lower-case, as they appear in messages)
ABORT_CODES: dict[int, str] = {
    0x05030000: "toggle bit not alternated",
    0x05040000: "SDO protocol timed out",
    0x05040001: "client/server command specifier not valid or unknown",
    0x05040002: "invalid block size",
    0x05040003: "invalid sequence number",
    0x05040004: "CRC error",
    0x05040005: "out of memory",
    0x06010000: "unsupported access to an object",
    0x06010001: "attempt to read a write only object",
    0x06010002: "attempt to write a read only object",
    0x06020000: "object does not exist in the object dictionary",
    0x06040041: "object cannot be mapped to the PDO",
    0x06040042: "the number and length of the objects to be mapped would exceed the PDO length",
    0x06040043: "general parameter incompatibility reason",
    0x06040047: "general internal incompatibility in the device",
    0x06060000: "access failed due to a hardware error",
    0x06070010: "data type does not match, length of service parameter does not match",
    0x06070012: "data type does not match, length of service parameter too high",
    0x06070013: "data type does not match, length of service parameter too low",
    0x06090011: "sub-index does not exist",
    0x06090030: "value range of parameter exceeded",
    0x06090031: "value of parameter written too high",
    0x06090032: "value of parameter written too low",
    0x06090036: "maximum value is less than minimum value",
    0x060A0023: "resource not available: SDO connection",
    0x08000000: "general error",
    0x08000020: "data cannot be transferred or stored to the application",
    0x08000021: "data cannot be transferred or stored to the application because of local control",
    0x08000022: (
        "data cannot be transferred or stored to the application because of the present "
        "device state"
    ),
    0x08000023: "object dictionary dynamic generation fails or no object dictionary is present",
    0x08000024: "no data available",
}

ABORT_TOGGLE = 0x05030000
ABORT_TIMEOUT = 0x05040000
ABORT_COMMAND = 0x05040001
ABORT_OUT_OF_MEMORY = 0x05040005
ABORT_OBJECT_MISSING = 0x06020000
ABORT_NOT_MAPPABLE = 0x06040041
ABORT_SUBINDEX_MISSING = 0x06090011
ABORT_VALUE_RANGE = 0x06090030

MAX_UPLOAD = 1024  # [bytes] largest segmented upload accepted


def abort_text(code: int) -> str:
    """``0x06090030 (value range of parameter exceeded)``; unknown codes say so."""
    return f"0x{code:08X} ({ABORT_CODES.get(code, 'unknown abort code')})"


def object_name(index: int, subindex: int) -> str:
    """An object address as CiA 301 documents write it: ``0x1800:01``."""
    return f"0x{index:04X}:{subindex:02X}"


@dataclass(frozen=True, slots=True)
class SdoSend:
    """Send ``data`` (8 bytes) on the request COB-ID; the transfer goes on."""

    data: bytes


@dataclass(frozen=True, slots=True)
class SdoDone:
    """The transfer finished: ``data`` = the uploaded bytes (empty for a download)."""

    data: bytes


@dataclass(frozen=True, slots=True)
class SdoFailed:
    """The transfer ended with ``code`` (from the server's abort, or ours). ``send`` is an
    abort request to send to the server (when the client aborted), else empty."""

    code: int
    send: bytes = b""
    by_server: bool = True


class SdoClient:
    """One SDO channel of one node (the default server channel ``0x600/0x580 + node``).

    At most one transfer is in progress (:attr:`busy`). Guarantees: every response is
    answered by exactly one of :class:`SdoSend`, :class:`SdoDone`, :class:`SdoFailed` (or
    None when no transfer is in progress: an unsolicited frame); a response whose
    multiplexer (index, sub-index) differs from the request's, or with an unknown command
    specifier, ends the transfer with abort 0x05040001; a segment with the wrong toggle bit
    ends it with 0x05030000; an upload longer than :data:`MAX_UPLOAD` with 0x05040005.
    """

    def __init__(self, node_id: int) -> None:
        if not 1 <= node_id <= 127:
            raise ValueError(f"node_id must be in 1..127, got {node_id}")
        self.node_id = node_id
        self.request_cob_id = 0x600 + node_id
        self.response_cob_id = 0x580 + node_id
        self._op: str | None = None  # "read", "write", "segments"
        self._index = 0
        self._subindex = 0
        self._toggle = 0
        self._size: int | None = None
        self._buffer = bytearray()

    @property
    def busy(self) -> bool:
        return self._op is not None

    @property
    def address(self) -> tuple[int, int]:
        """(index, sub-index) of the transfer in progress (or the last one)."""
        return self._index, self._subindex

    def _start(self, op: str, index: int, subindex: int) -> None:
        if not 0 <= index <= 0xFFFF or not 0 <= subindex <= 0xFF:
            raise ValueError(f"SDO address {index:#x}:{subindex:#x} out of range")
        self._op = op
        self._index = index
        self._subindex = subindex
        self._toggle = 0
        self._size = None
        self._buffer = bytearray()

    def read(self, index: int, subindex: int) -> bytes:
        """Start an upload of ``index:subindex``; returns the initiate request."""
        self._start("read", index, subindex)
        return struct.pack("<BHB4x", 0x40, index, subindex)

    def write(self, index: int, subindex: int, data: bytes) -> bytes:
        """Start an expedited download of 1..4 bytes; returns the initiate request."""
        n = len(data)
        if not 1 <= n <= 4:
            raise ValueError(f"expedited download carries 1..4 bytes, got {n}")
        self._start("write", index, subindex)
        command = 0x23 | ((4 - n) << 2)  # expedited, size indicated
        return struct.pack("<BHB", command, index, subindex) + bytes(data) + bytes(4 - n)

    def abort_request(self, code: int) -> bytes:
        """The abort frame for the transfer in progress (it is ended)."""
        frame = struct.pack("<BHBL", 0x80, self._index, self._subindex, code)
        self._op = None
        return frame

    def timeout(self) -> SdoFailed:
        """The caller gave up waiting: end the transfer with abort 0x05040000."""
        return SdoFailed(ABORT_TIMEOUT, self.abort_request(ABORT_TIMEOUT), by_server=False)

    def cancel(self) -> None:
        """Forget the transfer in progress (no frame sent)."""
        self._op = None

    def _fail(self, code: int) -> SdoFailed:
        return SdoFailed(code, self.abort_request(code), by_server=False)

    def on_response(self, data: bytes | bytearray) -> SdoSend | SdoDone | SdoFailed | None:
        """Handle one 8-byte response frame (see the class notes)."""
        op = self._op
        if op is None:
            return None
        if len(data) != 8:
            return self._fail(ABORT_COMMAND)
        scs = data[0] >> 5
        if scs == 4:  # abort transfer
            index, subindex, code = struct.unpack_from("<HBL", data, 1)
            if (index, subindex) != (self._index, self._subindex):
                return self._fail(ABORT_COMMAND)
            self._op = None
            return SdoFailed(code)
        if op == "segments":
            return self._on_segment(data)
        index, subindex = struct.unpack_from("<HB", data, 1)
        if (index, subindex) != (self._index, self._subindex):
            return self._fail(ABORT_COMMAND)
        if op == "write":
            if scs != 3:
                return self._fail(ABORT_COMMAND)
            self._op = None
            return SdoDone(b"")
        if scs != 2:  # initiate upload response
            return self._fail(ABORT_COMMAND)
        expedited = data[0] & 0x02
        size_indicated = data[0] & 0x01
        if expedited:
            n = 4 - ((data[0] >> 2) & 0x03) if size_indicated else 4
            self._op = None
            return SdoDone(bytes(data[4 : 4 + n]))
        self._size = struct.unpack_from("<L", data, 4)[0] if size_indicated else None
        if self._size is not None and self._size > MAX_UPLOAD:
            return self._fail(ABORT_OUT_OF_MEMORY)
        self._op = "segments"
        return SdoSend(self._segment_request())

    def _segment_request(self) -> bytes:
        return bytes([0x60 | (self._toggle << 4)]) + bytes(7)

    def _on_segment(self, data: bytes | bytearray) -> SdoSend | SdoDone | SdoFailed:
        if data[0] >> 5 != 0:  # upload segment response
            return self._fail(ABORT_COMMAND)
        if (data[0] >> 4) & 1 != self._toggle:
            return self._fail(ABORT_TOGGLE)
        n = 7 - ((data[0] >> 1) & 0x07)
        self._buffer += data[1 : 1 + n]
        if len(self._buffer) > MAX_UPLOAD:
            return self._fail(ABORT_OUT_OF_MEMORY)
        if data[0] & 0x01:  # no more segments
            self._op = None
            out = bytes(self._buffer)
            if self._size is not None:
                out = out[: self._size]
            return SdoDone(out)
        self._toggle ^= 1
        return SdoSend(self._segment_request())
