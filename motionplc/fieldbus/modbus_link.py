"""One Modbus TCP connection that never blocks the cycle: MBAP framing on a non-blocking socket,
PDUs encoded and decoded by pymodbus.

The cyclic master (:class:`~motionplc.fieldbus.modbus_drive.ModbusDrive`) sends a request in
one cycle and collects the answer in a later one with :meth:`ModbusLink.receive`, which only
reads what the kernel already holds. Blocking waits exist for the setup path and the simulated
clock (:meth:`ModbusLink.wait_readable`, :meth:`ModbusLink.transact`), always bounded by a
timeout.

Nothing here raises on I/O: a lost connection (EOF, reset, refused, broken pipe) sets
``connected = False`` and ``error`` (the reason), and malformed frames from the wire (a wrong
protocol id, an impossible length, a PDU pymodbus cannot decode) are counted in ``malformed``
and skipped; a stream whose framing is lost (length field out of range) is closed, since the
next frame boundary cannot be found.
"""

from __future__ import annotations

import errno
import select
import socket
from dataclasses import dataclass

from pymodbus.pdu import ModbusPDU
from pymodbus.pdu.decoders import DecodePDU

__all__ = ["MAX_ADU", "ModbusLink", "Reply"]

MAX_ADU = 260  # MBAP (7) + the largest PDU (253)
_MBAP = 7


@dataclass(frozen=True, slots=True)
class Reply:
    """One response frame: its transaction id, unit id and decoded PDU (None: undecodable)."""

    tid: int
    unit: int
    pdu: ModbusPDU | None


class ModbusLink:
    """A client connection to one Modbus TCP server (host, port)."""

    def __init__(self, host: str, port: int) -> None:
        self.host = host
        self.port = port
        self.sock: socket.socket | None = None
        self.connected = False
        self.connecting = False
        self.error = ""
        self.malformed = 0  # frames skipped: bad protocol id, undecodable PDU
        self._buf = bytearray()
        self._tid = 0
        self._decoder = DecodePDU(is_server=False)

    # ------------------------------------------------------------ connection
    def _fail(self, reason: str) -> None:
        self.error = reason
        self.close()

    def start_connect(self) -> None:
        """Begin a non-blocking connect; :meth:`poll_connect` tells when it is done."""
        self.close()
        self.error = ""
        try:  # IPv4 or IPv6 (host: '::1'), by the address the host resolves to
            family, _, _, _, address = socket.getaddrinfo(
                self.host, self.port, type=socket.SOCK_STREAM
            )[0]
            sock = socket.socket(family, socket.SOCK_STREAM)
            sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
            sock.setblocking(False)
        except OSError as exc:
            self.error = f"socket: {exc.strerror or exc}"
            return
        self.sock = sock
        rc = sock.connect_ex(address)
        if rc == 0:
            self.connected = True
        elif rc in (errno.EINPROGRESS, errno.EWOULDBLOCK, errno.EALREADY):
            self.connecting = True
        else:
            self._fail(f"connect to {self.host}:{self.port}: {errno.errorcode.get(rc, rc)}")

    def poll_connect(self, timeout: float = 0.0) -> bool:
        """True once connected; waits at most ``timeout`` seconds (0: just look)."""
        if self.connected:
            return True
        if not self.connecting or self.sock is None:
            return False
        try:
            _, writable, _ = select.select([], [self.sock], [], max(0.0, timeout))
        except (OSError, ValueError) as exc:
            self._fail(f"connect: {exc}")
            return False
        if not writable:
            return False
        rc = self.sock.getsockopt(socket.SOL_SOCKET, socket.SO_ERROR)
        self.connecting = False
        if rc != 0:
            self._fail(f"connect to {self.host}:{self.port}: {errno.errorcode.get(rc, rc)}")
            return False
        self.connected = True
        return True

    def connect(self, timeout: float) -> bool:
        """Connect, waiting at most ``timeout`` seconds."""
        self.start_connect()
        return self.poll_connect(timeout)

    def close(self) -> None:
        """Drop the connection and everything buffered (idempotent)."""
        if self.sock is not None:
            try:
                self.sock.close()
            except OSError:
                pass
        self.sock = None
        self.connected = False
        self.connecting = False
        self._buf.clear()

    # -------------------------------------------------------------- traffic
    def send(self, pdu: ModbusPDU, unit: int) -> int | None:
        """Send one request; returns its transaction id, or None when the connection is lost
        (``error`` says why). A frame the kernel cannot take whole at once is a lost link:
        a Modbus ADU is at most 260 bytes, far below any socket buffer."""
        if not self.connected or self.sock is None:
            return None
        self._tid = self._tid % 0xFFFF + 1
        body = pdu.function_code.to_bytes(1, "big") + pdu.encode()
        frame = (
            self._tid.to_bytes(2, "big")
            + b"\x00\x00"
            + (len(body) + 1).to_bytes(2, "big")
            + unit.to_bytes(1, "big")
            + body
        )
        try:
            n = self.sock.send(frame)
        except BlockingIOError:
            n = 0
        except OSError as exc:
            self._fail(f"send: {exc.strerror or exc}")
            return None
        if n != len(frame):
            self._fail(f"send: socket buffer full ({n} of {len(frame)} bytes)")
            return None
        return self._tid

    def receive(self) -> list[Reply]:
        """Every complete response frame the kernel holds now (never blocks)."""
        if not self.connected or self.sock is None:
            return []
        while True:
            try:
                chunk = self.sock.recv(65536)
            except (BlockingIOError, InterruptedError):
                break
            except OSError as exc:
                replies = self._frames()
                self._fail(f"receive: {exc.strerror or exc}")
                return replies
            if not chunk:
                replies = self._frames()
                self._fail("connection closed by the drive")
                return replies
            self._buf += chunk
            if len(chunk) < 65536:
                break
        return self._frames()

    def _frames(self) -> list[Reply]:
        out: list[Reply] = []
        buf = self._buf
        while len(buf) >= _MBAP:
            tid = int.from_bytes(buf[0:2], "big")
            pid = int.from_bytes(buf[2:4], "big")
            length = int.from_bytes(buf[4:6], "big")
            if pid != 0 or not 2 <= length <= MAX_ADU - 6:
                # framing lost: the next frame boundary cannot be found in this stream
                self.malformed += 1
                self._fail(f"malformed frame (protocol id {pid}, length {length})")
                return out
            end = 6 + length
            if len(buf) < end:
                break
            unit = buf[6]
            pdu = self._decoder.decode(bytes(buf[_MBAP:end]))
            if pdu is None:
                self.malformed += 1
            out.append(Reply(tid, unit, pdu))
            del buf[:end]
        return out

    def wait_readable(self, timeout: float) -> bool:
        """Wait at most ``timeout`` seconds for data (or a closed connection) to read."""
        if not self.connected or self.sock is None:
            return False
        try:
            readable, _, _ = select.select([self.sock], [], [], max(0.0, timeout))
        except (OSError, ValueError):
            return False
        return bool(readable)
