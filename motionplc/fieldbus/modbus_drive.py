"""CiA 402 drives over Modbus TCP, master side, register map v1; the cycle never blocks on I/O.

:class:`ModbusDrive` implements :class:`~motionplc.fieldbus.base.Drive` over a
:class:`~motionplc.fieldbus.modbus_link.ModbusLink` (a non-blocking socket; PDUs by pymodbus):

* :meth:`ModbusDrive.open` (setup path, may raise :class:`FieldbusError`, every wait bounded by
  ``timeout``): connect (loopback by default), check MAP_VERSION, DEVICE_PROFILE and the
  WORD_ORDER_PROBE (a word-order mismatch refuses to enable), write the parameters
  (CYCLE_TIME_US, following-error window/time-out, WATCHDOG_MS);
* cyclic exchange, ``exchange="fc23"`` (default): :meth:`write_outputs` sends one FC23 per axis
  and cycle (write the command block, read the status block); its answer is taken in by the
  next :meth:`read_inputs` (one cycle of transport delay, as on CAN). ``exchange="split"``:
  FC16 of the command block and FC03 of the status block, sent together.

How long the cycle waits for an answer depends on the clock (:meth:`ModbusDrive.bind_clock`,
called by the runtime):

* real time: never. :meth:`read_inputs` takes what has arrived (the latest process image); an
  exchange still unanswered holds the next one back (one request in flight per drive) and is
  counted; after ``timeout_cycles = ceil(timeout / cycle_time)`` cycles without an answer the
  axis gets COMM_TIMEOUT and the connection is re-opened (without blocking). An answer later
  than the next cycle is still used, and counted in ``late_replies``. Other axes keep their
  cycle whatever this drive does.
* simulated clock with an in-process virtual server as ``peer`` (lockstep): the cycle waits
  until the server has answered or *parked* the request (an injected response delay runs on the
  simulated clock, see :class:`~motionplc.fieldbus.virtual_modbus.VirtualModbusServer`), so
  every run is bit-reproducible: the same timeouts in the same cycles on any host load.
* simulated clock with any other server: the cycle waits for the answer at most ``timeout``
  seconds (wall clock); no answer by then is COMM_TIMEOUT at once.

Failures as values (nothing raises in the cycle):

==========================  =======  =======  ==========================================
condition                   fault    comm_ok  error_code
==========================  =======  =======  ==========================================
drive FAULT / FRA           True     True     ERROR_CODE register (e.g. 0x8611, 0x8100)
no answer (timeout)         False    False    0x8130, kind "timeout"; latched until an
                                              answer comes; the connection is re-opened
exception response c        False    False    0xFF00 | c, kind "exception" (DEVICE_BUSY
                                              is re-sent once)
disconnected / refused /    False    False    0x8130, kind "disconnected", latched until
reset / malformed stream                      MC_Reset (reconnects every
                                              ``reconnect_every`` cycles)
stale LIFE_SIGN_ECHO        -        -        stale=True
==========================  =======  =======  ==========================================

A fault reset (MC_Reset) re-opens a connection that timed out and is reported as
``reset_pending`` until the drive is out of FAULT with communication OK, or ``reset_timeout``
has passed.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

from pymodbus.constants import ExcCodes
from pymodbus.pdu import ExceptionResponse, ModbusPDU
from pymodbus.pdu.register_message import (
    ReadHoldingRegistersRequest,
    ReadWriteMultipleRegistersRequest,
    WriteMultipleRegistersRequest,
)

from motionplc.fieldbus.base import (
    Drive,
    DriveCommand,
    DriveFeedback,
    FieldbusError,
    reset_in_progress,
)
from motionplc.fieldbus.cia402 import (
    Cia402State,
    OperationMode,
    decode_statusword,
    next_controlword,
)
from motionplc.fieldbus.modbus_link import ModbusLink, Reply
from motionplc.fieldbus.modbus_map import (
    BY_NAME,
    CMD_BASE,
    DEVICE_PROFILE_VALUE,
    ID_BASE,
    ID_COUNT,
    MAP_VERSION_VALUE,
    STATUS_BASE,
    STATUS_COUNT,
    WORD_ORDER_PROBE_VALUE,
    CommandBlock,
    StatusBlock,
    WordOrder,
    decode_fields,
    encode_fields,
)
from motionplc.fieldbus.scaling import Scaling

__all__ = ["ModbusDrive", "ModbusDriveConfig"]

CSP = int(OperationMode.CYCLIC_SYNCHRONOUS_POSITION)
CODE_NO_RESPONSE = 0x8130
CODE_EXCEPTION_BASE = 0xFF00
_POLL = 0.001  # [s] slice of a bounded wait (simulated clock only)


@dataclass(frozen=True, slots=True)
class ModbusDriveConfig:
    """One Modbus TCP axis (SI units except where named)."""

    port: int
    host: str = "127.0.0.1"
    device_id: int = 1
    counts_per_unit: float = 1.0e6
    offset_counts: int = 0
    word_order: WordOrder = "big"
    cycle_time: float = 0.004  # [s] -> CYCLE_TIME_US
    # [s] answer deadline: ceil(timeout / cycle_time) cycles of the task's clock; on the
    # simulated clock without a lockstep peer, the wall-clock bound of one wait
    timeout: float = 0.1
    exchange: str = "fc23"  # "fc23" or "split"
    following_error_window: float | None = None  # [m] -> FOLLOWING_ERROR_WINDOW
    following_error_timeout: float | None = None  # [s] -> FOLLOWING_ERROR_TIMEOUT_MS
    watchdog: float = 0.0  # [s] -> WATCHDOG_MS, 0 = off
    velocity_feed_forward: bool = False  # send TARGET_VELOCITY (CSP: velocity offset)
    reconnect_every: int = 10  # cycles between reconnect attempts
    reset_timeout: float = 0.05  # [s] a fault reset (MC_Reset) that has not succeeded by then fails

    def __post_init__(self) -> None:
        if not 0 < self.port < 65536:
            raise ValueError(f"port must be in 1..65535, got {self.port}")
        if not 0 <= self.device_id <= 255:
            raise ValueError(f"device_id must be in 0..255, got {self.device_id}")
        if self.word_order not in ("big", "little"):
            raise ValueError(f"word_order must be 'big' or 'little', got {self.word_order!r}")
        if self.exchange not in ("fc23", "split"):
            raise ValueError(f"exchange must be 'fc23' or 'split', got {self.exchange!r}")
        if not (self.timeout > 0 and math.isfinite(self.timeout)):
            raise ValueError(f"timeout must be a finite number of seconds > 0, got {self.timeout}")
        if not (self.cycle_time > 0 and math.isfinite(self.cycle_time)):
            raise ValueError(
                f"cycle_time must be a finite number of seconds > 0, got {self.cycle_time}"
            )
        if self.reconnect_every < 1:
            raise ValueError("reconnect_every must be >= 1")

    @property
    def timeout_cycles(self) -> int:
        """Cycles without an answer after which the drive reports COMM_TIMEOUT (>= 1)."""
        return max(1, math.ceil(self.timeout / self.cycle_time - 1e-9))


class _RequestError(Exception):
    def __init__(self, code: int, detail: str, kind: str) -> None:
        super().__init__(detail)
        self.code = code
        self.detail = detail
        self.kind = kind  # DriveFeedback.kind: "timeout", "exception" or "disconnected"


@dataclass(slots=True)
class _Exchange:
    """The requests of one cycle still waiting for their answers."""

    life_sign: int
    sent_tick: int
    pending: dict[int, str] = field(default_factory=dict)  # tid -> "fc23" | "write" | "read"
    requests: dict[int, ModbusPDU] = field(default_factory=dict)
    busy_retried: bool = False
    parked_due: float | None = None  # lockstep: the peer holds it until this simulated time
    peer_seq: int = 0  # lockstep: the peer's request count before this exchange was sent


def _exception_detail(code: int) -> str:
    name = ExcCodes(code).name if code in iter(ExcCodes) else "?"
    return f"Modbus exception 0x{code:02X} ({name})"


class ModbusDrive(Drive):
    """One CiA 402 axis behind a Modbus TCP server with register map v1."""

    def __init__(self, name: str, config: ModbusDriveConfig, *, peer: Any = None) -> None:
        self.name = name
        self.config = config
        # LockstepPeer stepped after each write (in-process virtual server); when it can tell
        # which requests it holds back (``parked_due``), the simulated cycle waits exactly
        self.peer = peer
        self._parks = peer if callable(getattr(peer, "parked_due", None)) else None
        self.scaling = Scaling(config.counts_per_unit, config.offset_counts)
        self.link = ModbusLink(config.host, config.port)
        self.realtime = False
        self._opened = False
        self.status: StatusBlock | None = None
        self.controlword = 0
        self.life_sign = 0
        self._fresh = False
        self._failure: tuple[int, str, str] | None = None  # (code, detail, kind) this cycle
        self._timed_out = ""  # no answer for timeout_cycles: latched until an answer comes
        self._disconnected = ""  # latched until a fault reset after reconnecting
        self._cycles_since_attempt = 0
        self._exchange: _Exchange | None = None
        self._tick = 0  # cycles seen (read_inputs calls)
        self._last_step_t = -math.inf  # simulated time of the last peer step
        self.requests = 0
        self._reset_until: float | None = None  # fault reset in progress until this time
        # statistics
        self.late_replies = 0  # answers taken in after the cycle that was due
        self.held_cycles = 0  # cycles whose setpoint was not sent (previous one unanswered)
        self.timeouts = 0  # COMM_TIMEOUTs (exchanges abandoned)
        self.unexpected_replies = 0  # answers to no request in flight (ignored)

    def bind_clock(self, realtime: bool) -> None:
        """Real time: never wait for an answer inside the cycle (see the module docstring)."""
        self.realtime = bool(realtime)

    # ----------------------------------------------------------------- setup
    def open(self) -> None:
        cfg = self.config
        if not self.link.connect(cfg.timeout):
            reason = self.link.error or f"no answer within {cfg.timeout} s"
            self.link.close()
            raise FieldbusError(f"{self.name}: cannot connect to {cfg.host}:{cfg.port}: {reason}")
        try:
            ident = decode_fields(ID_BASE, self._read(ID_BASE, ID_COUNT), cfg.word_order)
            if ident["MAP_VERSION"] != MAP_VERSION_VALUE:
                raise FieldbusError(f"{self.name}: register map version {ident['MAP_VERSION']}")
            if ident["DEVICE_PROFILE"] != DEVICE_PROFILE_VALUE:
                raise FieldbusError(f"{self.name}: device profile {ident['DEVICE_PROFILE']}")
            if ident["WORD_ORDER_PROBE"] != WORD_ORDER_PROBE_VALUE:
                raise FieldbusError(
                    f"{self.name}: word-order probe reads 0x{ident['WORD_ORDER_PROBE']:08X}, "
                    f"expected 0x{WORD_ORDER_PROBE_VALUE:08X} with word_order={cfg.word_order!r}"
                    " (refusing to enable)"
                )
            params: dict[str, int] = {"CYCLE_TIME_US": round(cfg.cycle_time * 1e6)}
            if cfg.following_error_window is not None:
                params["FOLLOWING_ERROR_WINDOW"] = min(
                    0xFFFFFFFE, round(abs(cfg.following_error_window * cfg.counts_per_unit))
                )
            if cfg.following_error_timeout is not None:
                params["FOLLOWING_ERROR_TIMEOUT_MS"] = round(cfg.following_error_timeout * 1000)
            params["WATCHDOG_MS"] = round(cfg.watchdog * 1000)
            for name, value in params.items():
                f = BY_NAME[name]
                self._write(
                    f.address, encode_fields(f.address, f.size, {name: value}, cfg.word_order)
                )
            self.status = StatusBlock.decode(self._read(STATUS_BASE, STATUS_COUNT), cfg.word_order)
        except _RequestError as exc:
            self.link.close()
            raise FieldbusError(f"{self.name}: setup failed: {exc.detail}") from exc
        except FieldbusError:
            self.link.close()
            raise
        self._fresh = True
        self._opened = True

    def _transact(self, pdu: ModbusPDU) -> ModbusPDU:
        """Setup path: one request and its answer, bounded by the timeout (BUSY re-sent once)."""
        for attempt in range(2):
            self.requests += 1
            tid = self.link.send(pdu, self.config.device_id)
            if tid is None:
                raise _RequestError(CODE_NO_RESPONSE, self.link.error, "disconnected")
            reply: Reply | None = None
            for _ in range(8):  # unrelated frames are skipped; each wait is bounded
                if not self.link.wait_readable(self.config.timeout):
                    break
                reply = next((r for r in self.link.receive() if r.tid == tid), None)
                if reply is not None or not self.link.connected:
                    break
            if reply is None:
                self.link.close()
                if self.link.error:
                    raise _RequestError(CODE_NO_RESPONSE, self.link.error, "disconnected")
                raise _RequestError(
                    CODE_NO_RESPONSE, f"no response within {self.config.timeout} s", "timeout"
                )
            rr = reply.pdu
            if rr is None:
                raise _RequestError(CODE_NO_RESPONSE, "undecodable response", "exception")
            if isinstance(rr, ExceptionResponse):
                code = int(rr.exception_code)
                if code == ExcCodes.DEVICE_BUSY and attempt == 0:
                    continue
                raise _RequestError(
                    CODE_EXCEPTION_BASE | code, _exception_detail(code), "exception"
                )
            return rr
        raise AssertionError("unreachable")

    def _read(self, address: int, count: int) -> list[int]:
        rr = self._transact(ReadHoldingRegistersRequest(address=address, count=count))
        return list(rr.registers)

    def _write(self, address: int, values: list[int]) -> None:
        self._transact(WriteMultipleRegistersRequest(address=address, registers=values))

    # ------------------------------------------------------------- answers
    def _take(self, replies: list[Reply]) -> None:
        """Apply the answers that belong to the exchange in flight."""
        ex = self._exchange
        for reply in replies:
            kind = ex.pending.pop(reply.tid, None) if ex is not None else None
            if ex is None or kind is None:
                self.unexpected_replies += 1
                continue
            rr = reply.pdu
            if rr is None or (
                not isinstance(rr, ExceptionResponse)
                and rr.function_code != ex.requests[reply.tid].function_code
            ):
                self._failure = (CODE_NO_RESPONSE, "malformed response", "exception")
                continue
            if isinstance(rr, ExceptionResponse):
                code = int(rr.exception_code)
                if code == ExcCodes.DEVICE_BUSY and not ex.busy_retried:
                    ex.busy_retried = True  # BUSY: send the same request once more
                    self._send(ex, ex.requests[reply.tid], kind)
                    continue
                self._failure = (CODE_EXCEPTION_BASE | code, _exception_detail(code), "exception")
                continue
            if kind in ("fc23", "read"):
                regs = list(rr.registers)
                if len(regs) != STATUS_COUNT:
                    self._failure = (CODE_NO_RESPONSE, f"{len(regs)} status registers", "exception")
                    continue
                self.status = StatusBlock.decode(regs, self.config.word_order)
                self._fresh = True
        if ex is not None and not ex.pending:
            self._timed_out = ""
            if self._tick - ex.sent_tick > 1:
                self.late_replies += 1
            self._exchange = None

    def _link_lost(self) -> None:
        if self._opened and not self.link.connected and not self.link.connecting:
            if not self._disconnected:
                self._disconnected = self.link.error or "connection lost"
            self._exchange = None

    def _collect(self) -> None:
        """Take in the answers that have arrived (never blocks)."""
        self._take(self.link.receive())
        self._link_lost()

    def _abandon(self) -> None:
        """Give up the exchange in flight: re-open the connection so that its answer, if it
        ever comes, cannot be taken for the answer to a later request."""
        self._exchange = None
        self.link.close()
        self._start_connect()

    def _start_connect(self) -> None:
        self._cycles_since_attempt = 0
        self.link.start_connect()
        if not self.realtime:
            self.link.poll_connect(self.config.timeout)

    def _wait_settled(self) -> None:
        """Simulated clock: wait until the exchange is answered, parked by the lockstep peer, or
        (without one) the timeout has passed; bounded by ``timeout`` of wall time."""
        cfg = self.config
        ex = self._exchange
        if self._parks is not None:
            for _ in range(max(1, math.ceil(cfg.timeout / _POLL))):
                if self._exchange is None or not self.link.connected:
                    return
                due = self._parks.parked_due(cfg.device_id, ex.peer_seq)
                if due is not None:
                    ex.parked_due = due
                    return
                if self.link.wait_readable(_POLL):
                    self._collect()
        else:
            for _ in range(8):  # unrelated frames are skipped; each wait is bounded
                if self._exchange is None or not self.link.connected:
                    return
                if not self.link.wait_readable(cfg.timeout):
                    break
                self._collect()
        if self._exchange is not None and self.link.connected:
            self._time_out(f"no response within {cfg.timeout} s")

    def _time_out(self, detail: str) -> None:
        self.timeouts += 1
        self._timed_out = detail
        self._abandon()

    # ----------------------------------------------------------------- cycle
    def read_inputs(self, t: float) -> DriveFeedback:
        self._tick += 1
        if self._opened:
            ex = self._exchange
            if ex is not None and ex.parked_due is not None and ex.parked_due <= self._last_step_t:
                # lockstep: the peer released the parked answer at its last step; take it in
                for _ in range(max(1, math.ceil(self.config.timeout / _POLL))):
                    if self._exchange is None or not self.link.connected:
                        break
                    if self.link.wait_readable(_POLL):
                        self._collect()
            self._collect()
            ex = self._exchange
            if ex is not None and self._tick - ex.sent_tick > self.config.timeout_cycles:
                self._time_out(
                    f"no response for {self.config.timeout_cycles} cycles ({self.config.timeout} s)"
                )
        st = self.status
        fresh = self._fresh
        self._fresh = False
        if st is None:
            return DriveFeedback(0.0, 0.0, False, comm_ok=False, detail="not opened", stale=True)
        state = decode_statusword(st.statusword)
        fault = state in (Cia402State.FAULT, Cia402State.FAULT_REACTION_ACTIVE)
        comm_ok, error_code, detail, kind = True, 0, "", ""
        if fault:
            error_code = st.error_code
            detail = f"drive fault 0x{st.error_code:04X} ({state.value})"
        if self._disconnected or not self._opened:
            comm_ok, error_code, kind = False, CODE_NO_RESPONSE, "disconnected"
            detail = "not opened" if not self._opened else self._disconnected
            if self._opened and self.link.connected:
                detail += " (reconnected; reset required)"
        elif self._failure is not None:
            comm_ok, (error_code, detail, kind) = False, self._failure
        elif self._timed_out:
            comm_ok, error_code, detail, kind = False, CODE_NO_RESPONSE, self._timed_out, "timeout"
        if fresh and st.life_sign_echo != self.life_sign and self.config.exchange == "fc23":
            fresh = False  # the drive has not seen our last command
        enabled = state is Cia402State.OPERATION_ENABLED and comm_ok
        self._reset_until = reset_in_progress(self._reset_until, t, comm_ok and not fault)
        reset_pending = self._reset_until is not None
        return DriveFeedback(
            position=self.scaling.position_to_si(st.position),
            velocity=self.scaling.velocity_to_si(st.velocity),
            enabled=enabled,
            fault=fault,
            error_code=error_code,
            comm_ok=comm_ok,
            detail=detail,
            stale=not fresh,
            kind=kind,
            reset_pending=reset_pending,
        )

    def _send(self, ex: _Exchange, pdu: ModbusPDU, kind: str) -> bool:
        self.requests += 1
        tid = self.link.send(pdu, self.config.device_id)
        if tid is None:
            return False
        ex.pending[tid] = kind
        ex.requests[tid] = pdu
        return True

    def _connected(self, reset: bool) -> bool:
        """Keep the connection up (reconnect attempts every ``reconnect_every`` cycles, at once
        on a fault reset); True when it is usable in this cycle."""
        link = self.link
        if link.connecting:
            link.poll_connect(0.0 if self.realtime else self.config.timeout)
            if not link.connected and not link.connecting:
                self._link_lost()
        if link.connected:
            return True
        self._cycles_since_attempt += 1
        if reset or self._cycles_since_attempt >= self.config.reconnect_every:
            self._start_connect()
        return link.connected

    def write_outputs(self, t: float, command: DriveCommand) -> None:
        if not self._opened:
            return
        self._failure = None
        cfg = self.config
        reset = command.fault_reset
        if reset:
            self._reset_until = t + cfg.reset_timeout  # reported as reset_pending
            if self._timed_out and self._exchange is not None:
                self._abandon()  # resynchronise at once
        if not self._connected(reset):
            self._step_peer(t)
            return
        if self._disconnected and reset:
            self._disconnected = ""  # explicit reset after reconnecting
        if self._exchange is not None:
            self.held_cycles += 1  # the previous exchange is still unanswered
            self._step_peer(t)
            return
        st = self.status
        state = decode_statusword(st.statusword) if st is not None else Cia402State.UNKNOWN
        if self._disconnected:
            state = Cia402State.UNKNOWN  # -> controlword 0x00 until reset
        target = Cia402State.OPERATION_ENABLED if command.enable else Cia402State.READY_TO_SWITCH_ON
        resetting = self._reset_until is not None
        cw = next_controlword(state, target, self.controlword, resetting)
        self.controlword = cw
        if state is Cia402State.OPERATION_ENABLED and command.enable:
            position = self.scaling.position_to_counts(command.position)
            velocity = (
                self.scaling.velocity_to_counts(command.velocity)
                if cfg.velocity_feed_forward
                else 0
            )
        else:
            position = st.position if st is not None else 0
            velocity = 0
        self.life_sign = (self.life_sign + 1) & 0xFFFF
        block = CommandBlock(cw, CSP, position, velocity, 0, self.life_sign).encode(cfg.word_order)
        ex = _Exchange(self.life_sign, self._tick)
        if self._parks is not None:
            ex.peer_seq = self._parks.request_count(cfg.device_id)
        self._exchange = ex
        if cfg.exchange == "fc23":
            ok = self._send(
                ex,
                ReadWriteMultipleRegistersRequest(
                    read_address=STATUS_BASE,
                    read_count=STATUS_COUNT,
                    write_address=CMD_BASE,
                    write_registers=block,
                ),
                "fc23",
            )
        else:
            ok = self._send(
                ex, WriteMultipleRegistersRequest(address=CMD_BASE, registers=block), "write"
            ) and self._send(
                ex, ReadHoldingRegistersRequest(address=STATUS_BASE, count=STATUS_COUNT), "read"
            )
        if not ok:
            self._link_lost()
        elif not self.realtime:
            self._wait_settled()
        self._step_peer(t)

    def _step_peer(self, t: float) -> None:
        if self.peer is not None:
            self.peer.step(t)
            self._last_step_t = t

    def close(self) -> None:
        self.link.close()
        self._opened = False
