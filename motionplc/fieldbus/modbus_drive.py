"""CiA 402 drives over Modbus TCP, master side, driven by a register map; the cycle never blocks
on I/O.

:class:`ModbusDrive` implements :class:`~motionplc.fieldbus.base.Drive` over a
:class:`~motionplc.fieldbus.modbus_link.ModbusLink` (a non-blocking socket; PDUs by pymodbus).
Where the drive keeps its objects, their types, word order and scale and which function codes
to use come from its register map (:class:`~motionplc.fieldbus.modbus_regmap.RegisterMap`,
``ModbusDriveConfig.register_map``: a shipped map's name, a file or a RegisterMap; default
``motionplc-v1``, the map of our own virtual drive):

* :meth:`ModbusDrive.open` (setup path, may raise :class:`FieldbusError`, every wait bounded by
  ``timeout``): connect (loopback by default); read and check the map's identification
  registers, if it has any (a mismatch, e.g. of the word-order probe, refuses to enable); write
  ``mode_of_operation`` = 8 (CSP) if mapped (a drive without mode registers is assumed to run
  CSP); write the setup parameters the map has and the configuration gives (``cycle_time``
  always, ``following_error_window``, ``following_error_timeout``, ``watchdog``); read the status
  once. A failure names the request and the register
  (``setup failed: FC16 write 0x0300+2 (following_error_window): Modbus exception 0x02 ...``).
* cyclic exchange: :meth:`write_outputs` sends the map's requests of one cycle together: the
  writes of the command registers (FC 16 per group of registers without gaps, or FC 06 per
  register) and the reads of the status registers (FC 03 / FC 04, grouped), or one FC 23 with
  ``exchange: fc23``; their answers are taken in by the next :meth:`read_inputs` (one cycle of
  transport delay, as on CAN). The command image: controlword, target position, mode 8, target
  velocity (velocity feed-forward, else 0), target torque 0 and the life sign, each only if
  mapped. Freshness: with ``life_sign`` and ``life_sign_echo`` mapped, the echo must equal the
  last life sign sent; without, an answer to this cycle's reads is fresh.

How long the cycle waits for an answer depends on the clock (:meth:`ModbusDrive.bind_clock`,
called by the runtime):

* real time: never. :meth:`read_inputs` takes what has arrived (the latest process image); an
  exchange still unanswered holds the next one back (one exchange in flight per drive) and is
  counted; after ``timeout_cycles = ceil(timeout / cycle_time)`` cycles without an answer the
  axis gets COMM_TIMEOUT and the connection is re-opened (without blocking). An answer later
  than the next cycle is still used, and counted in ``late_replies``. Other axes keep their
  cycle whatever this drive does.
* simulated clock with an in-process virtual server as ``peer`` (lockstep): the cycle waits
  until the server has answered or *parked* the request (an injected response delay runs on the
  simulated clock, see :class:`~motionplc.fieldbus.virtual_modbus.VirtualModbusServer`), so
  every run is bit-reproducible: the same timeouts in the same cycles on any host load. Its
  waits (also connect and setup) are bounded by at least 5 s of wall time, a guard against a
  peer that is gone, never reached while it runs.
* simulated clock with any other server: the cycle waits for the answers at most ``timeout``
  seconds (wall clock); no answer by then is COMM_TIMEOUT at once.

Failures as values (nothing raises in the cycle):

==========================  =======  =======  ==========================================
condition                   fault    comm_ok  error_code
==========================  =======  =======  ==========================================
drive FAULT / FRA           True     True     error_code register (e.g. 0x8611, 0x8100);
                                              0 when the map has none
no answer (timeout)         False    False    0x8130, kind "timeout"; latched until an
                                              answer comes; the connection is re-opened
exception response c        False    False    0xFF00 | c, kind "exception", the detail
                                              names the request (``FC16 write 0x2000+4:
                                              Modbus exception 0x02 (ILLEGAL_ADDRESS)``);
                                              DEVICE_BUSY is re-sent once
setpoint out of range of    False    False    0x6320, kind "" (COMMUNICATION_LOST), the
its register                                  detail names the register; nothing is sent
disconnected / refused /    False    False    0x8130, kind "disconnected", latched until
reset / malformed stream                      MC_Reset (reconnects every
                                              ``reconnect_every`` cycles)
stale life sign echo        -        -        stale=True
==========================  =======  =======  ==========================================

A fault reset (MC_Reset) re-opens a connection that timed out and is reported as
``reset_pending`` until the drive is out of FAULT with communication OK, or ``reset_timeout``
has passed. The fault reset after a reconnection (the connection was lost: a drive reboot
drops it) first runs the setup of :meth:`ModbusDrive.open` again — identification, mode, setup
parameters — so a power-cycled drive is never enabled with its factory parameters; a failure
keeps the axis disconnected with the located reason. That setup waits for its answers (a few
requests, each bounded by ``timeout``), also in real time: it runs once per such reset, with
the axis in ErrorStop at rest (counted in ``reconfigurations``).
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from pymodbus.constants import ExcCodes
from pymodbus.pdu import ExceptionResponse, ModbusPDU
from pymodbus.pdu.register_message import (
    ReadHoldingRegistersRequest,
    ReadInputRegistersRequest,
    ReadWriteMultipleRegistersRequest,
    WriteMultipleRegistersRequest,
    WriteSingleRegisterRequest,
)

from motionplc.fieldbus.base import (
    MAX_QUEUED_PARAMETERS,
    Drive,
    DriveAddress,
    DriveCommand,
    DriveFeedback,
    FieldbusError,
    ParameterError,
    ParameterTransfer,
    reset_in_progress,
)
from motionplc.fieldbus.cia402 import (
    Cia402State,
    OperationMode,
    decode_statusword,
    next_controlword,
)
from motionplc.fieldbus.modbus_link import ModbusLink, Reply
from motionplc.fieldbus.modbus_map import WordOrder
from motionplc.fieldbus.modbus_regmap import (
    CMD_CONTROLWORD,
    CMD_LIFE_SIGN,
    CMD_MODE,
    CMD_POSITION,
    CMD_TORQUE,
    CMD_VELOCITY,
    COMMAND_KEYS,
    DEFAULT_MAP,
    STATUS_KEYS,
    Codec,
    RegisterMap,
    RegisterValueError,
    Request,
    decode_value,
    encode_value,
    load_register_map,
    read_requests,
)
from motionplc.fieldbus.scaling import Scaling

__all__ = ["ModbusDrive", "ModbusDriveConfig", "ModbusStatus"]

CSP = int(OperationMode.CYCLIC_SYNCHRONOUS_POSITION)
CODE_NO_RESPONSE = 0x8130
CODE_EXCEPTION_BASE = 0xFF00
CODE_OUT_OF_RANGE = 0x6320  # CiA 301 "parameter error": a setpoint its register cannot hold
_POLL = 0.001  # [s] slice of a bounded wait (simulated clock only)
# [s] wall-clock bound of one wait on an in-process lockstep peer: its answers and timeouts run
# on the simulated clock, so this only guards against a peer that is gone; generous, so that a
# loaded host (the peer's thread not scheduled for a while) changes nothing in a run
_LOCKSTEP_WALL = 5.0


@dataclass(frozen=True, slots=True)
class ModbusDriveConfig:
    """One Modbus TCP axis (SI units except where named).

    ``register_map``: a :class:`RegisterMap`, the name of a shipped map or a path (loaded in
    ``__post_init__``, so the field always holds a RegisterMap afterwards). ``word_order``
    overrides the map's default word order (entries with their own keep it); None: the map's.
    The setup parameters (``following_error_window`` [m], ``following_error_timeout`` [s],
    ``watchdog`` [s], 0 = off) are written when given (None: not written) and need their
    register in the map, as ``velocity_feed_forward`` needs ``target_velocity``.
    """

    port: int
    host: str = "127.0.0.1"
    device_id: int = 1
    counts_per_unit: float = 1.0e6  # drive position units per m (or rad)
    offset_counts: int = 0
    word_order: WordOrder | None = None
    cycle_time: float = 0.004  # [s] -> cycle_time register
    # [s] answer deadline: ceil(timeout / cycle_time) cycles of the task's clock; on the
    # simulated clock without a lockstep peer, the wall-clock bound of one wait
    timeout: float = 0.1
    register_map: RegisterMap | str | Path = DEFAULT_MAP
    following_error_window: float | None = None  # [m]
    following_error_timeout: float | None = None  # [s]
    watchdog: float | None = None  # [s], 0 = off
    velocity_feed_forward: bool = False  # send target_velocity (CSP: velocity offset)
    # requests of one cycle on the wire at once: 1 (default) sends each after the answer to
    # the previous one, as servers that take one transaction at a time need (pymodbus' own
    # server drops a second frame that arrives in the same TCP segment); more for servers
    # that queue requests
    requests_in_flight: int = 1
    reconnect_every: int = 10  # cycles between reconnect attempts
    reset_timeout: float = 0.05  # [s] a fault reset (MC_Reset) that has not succeeded by then fails
    # MC_ReadActualTorque: the holding register of the actual torque (i16, per mille of the
    # rated torque; None: 0x0208 TORQUE_ACTUAL with the motionplc-v1 map, else none) and the
    # rated torque [N m, or N] it refers to (None: not configured, the torque is refused)
    torque_register: int | None = None
    rated_torque: float | None = None

    def __post_init__(self) -> None:
        if not 0 < self.port < 65536:
            raise ValueError(f"port must be in 1..65535, got {self.port}")
        if not 0 <= self.device_id <= 255:
            raise ValueError(f"device_id must be in 0..255, got {self.device_id}")
        if self.word_order not in (None, "big", "little"):
            raise ValueError(
                f"word_order must be 'big', 'little' or None (the map's), got {self.word_order!r}"
            )
        if not (self.timeout > 0 and math.isfinite(self.timeout)):
            raise ValueError(f"timeout must be a finite number of seconds > 0, got {self.timeout}")
        if not (self.cycle_time > 0 and math.isfinite(self.cycle_time)):
            raise ValueError(
                f"cycle_time must be a finite number of seconds > 0, got {self.cycle_time}"
            )
        if self.reconnect_every < 1:
            raise ValueError("reconnect_every must be >= 1")
        if not 1 <= self.requests_in_flight <= 16:
            raise ValueError(f"requests_in_flight must be in 1..16, got {self.requests_in_flight}")
        rmap = self.register_map
        if not isinstance(rmap, RegisterMap):
            if not isinstance(rmap, (str, Path)):
                raise ValueError(
                    "register_map must be a RegisterMap, a shipped map's name or a path, "
                    f"got {type(rmap).__name__}"
                )
            rmap = load_register_map(rmap)
            object.__setattr__(self, "register_map", rmap)
        for key, value, lo in (
            ("following_error_window", self.following_error_window, 0.0),
            ("following_error_timeout", self.following_error_timeout, 0.0),
            ("watchdog", self.watchdog, -1.0),
        ):
            if value is None:
                continue
            if not (math.isfinite(value) and value > lo):
                allowed = "> 0" if lo == 0.0 else ">= 0"
                raise ValueError(f"{key} must be a finite number {allowed}, got {value}")
            if key not in rmap:
                raise ValueError(
                    f"{key} is given but the register map {rmap.name!r} has no {key} register"
                )
        if self.torque_register is not None and not (
            isinstance(self.torque_register, int) and 0 <= self.torque_register <= 0xFFFF
        ):
            raise ValueError(
                f"torque_register must be a register address in 0..0xFFFF, got "
                f"{self.torque_register!r}"
            )
        if self.rated_torque is not None and not (
            isinstance(self.rated_torque, (int, float)) and 0 < self.rated_torque < math.inf
        ):
            raise ValueError(f"rated_torque must be a finite number > 0, got {self.rated_torque!r}")
        if self.velocity_feed_forward and "target_velocity" not in rmap:
            raise ValueError(
                f"velocity_feed_forward needs a target_velocity register; the register map "
                f"{rmap.name!r} has none"
            )

    @property
    def timeout_cycles(self) -> int:
        """Cycles without an answer after which the drive reports COMM_TIMEOUT (>= 1)."""
        return max(1, math.ceil(self.timeout / self.cycle_time - 1e-9))

    @property
    def map(self) -> RegisterMap:
        """The register map with this drive's word order applied."""
        assert isinstance(self.register_map, RegisterMap)
        return self.register_map.with_word_order(self.word_order)


@dataclass(frozen=True, slots=True)
class ModbusStatus:
    """The status registers of one answer, in the drive's units (None: not in the map)."""

    statusword: int
    mode_display: int | None
    position: int | float
    velocity: int | float | None
    following_error: int | float | None
    error_code: int | None
    life_sign_echo: int | None


assert (
    tuple(ModbusStatus.__slots__)
    == (  # type: ignore[attr-defined]
        "statusword",
        "mode_display",
        "position",
        "velocity",
        "following_error",
        "error_code",
        "life_sign_echo",
    )
    and len(STATUS_KEYS) == 7
)


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
    reads_left: int  # read answers still to come (the status is taken when all are in)
    status: list[Any]  # the status image being filled
    queue: list[Request] = field(default_factory=list)  # still to send, in order
    blocks: dict[int, list[int]] = field(default_factory=dict)  # id(request) -> registers
    pending: dict[int, Request] = field(default_factory=dict)  # tid -> request
    pdus: dict[int, ModbusPDU] = field(default_factory=dict)  # tid -> what was sent
    read_failed: bool = False
    busy_retried: bool = False
    parked_due: float | None = None  # lockstep: the peer holds it until this simulated time
    peer_seq: int = 0  # lockstep: the peer's request count before this exchange was sent


class _ParamOp:
    """A drive parameter transfer riding in a cycle's exchange (after its cyclic requests):
    one read (FC 03) or write (FC 16 / FC 06) of ``count`` registers of type ``kind``. A read
    finishes with the decoded value times ``factor``, a write with ``written``."""

    __slots__ = (
        "count",
        "factor",
        "function",
        "kind",
        "label",
        "order",
        "pdu",
        "transfer",
        "written",
    )

    def __init__(self, pdu: ModbusPDU, label: str, kind: str, order: WordOrder, count: int) -> None:
        self.function = 0  # not a cyclic request: _pump sends ``pdu`` as it is
        self.pdu = pdu
        self.label = label
        self.kind = kind
        self.order = order
        self.count = count
        self.factor = 1.0
        self.written = 0.0
        self.transfer = ParameterTransfer(label)


def _exception_detail(code: int) -> str:
    name = ExcCodes(code).name if code in iter(ExcCodes) else "?"
    return f"Modbus exception 0x{code:02X} ({name})"


def _read_pdu(req: Request) -> ModbusPDU:
    """The FC 03/04 request reading ``req``'s registers (the read part of an FC 23)."""
    if req.function == 4:
        return ReadInputRegistersRequest(address=req.address, count=req.count)
    return ReadHoldingRegistersRequest(address=req.address, count=req.count)


def _write_pdu(req: Request, registers: list[int]) -> ModbusPDU:
    if req.function == 23:
        return ReadWriteMultipleRegistersRequest(
            read_address=req.address,
            read_count=req.count,
            write_address=req.write_address,
            write_registers=registers,
        )
    if req.function == 6:
        return WriteSingleRegisterRequest(address=req.address, registers=registers)
    return WriteMultipleRegistersRequest(address=req.address, registers=registers)


class ModbusDrive(Drive):
    """One CiA 402 axis behind a Modbus TCP server, laid out by its register map."""

    def __init__(self, name: str, config: ModbusDriveConfig, *, peer: Any = None) -> None:
        self.name = name
        self.config = config
        self.map: RegisterMap = config.map
        self.codec: Codec = self.map.codec()
        # LockstepPeer stepped after each write (in-process virtual server); when it can tell
        # which requests it holds back (``parked_due``), the simulated cycle waits exactly
        self.peer = peer
        self._parks = peer if callable(getattr(peer, "parked_due", None)) else None
        self.scaling = Scaling(config.counts_per_unit, config.offset_counts)
        self.link = ModbusLink(config.host, config.port)
        self.realtime = False
        self._opened = False
        self.status: ModbusStatus | None = None
        self.controlword = 0
        self.life_sign = 0
        self._echo = "life_sign_echo" in self.map
        self._read_pdus = {id(r): _read_pdu(r) for r in self.codec.requests if r.function in (3, 4)}
        self._image: list[Any] = [0] * len(COMMAND_KEYS)
        self._image[CMD_MODE] = CSP
        self._image[CMD_TORQUE] = 0
        self._velocity = 0.0  # [units/s] from positions when the map has no velocity_actual
        self._status_tick = 0
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
        self.reconfigurations = 0  # setups repeated on a reset after a reconnection
        # drive parameter transfers waiting for a cycle's exchange (one rides in each)
        self._param_ops: deque[_ParamOp] = deque()

    def bind_clock(self, realtime: bool) -> None:
        """Real time: never wait for an answer inside the cycle (see the module docstring).
        An in-process server (``peer``) then runs its drives' watchdog on a stall-proof time
        (``virtual_device.StallClock``)."""
        self.realtime = bool(realtime)
        if self.realtime and self.peer is not None and hasattr(self.peer, "make_stall_proof"):
            self.peer.make_stall_proof(self.config.cycle_time)

    def _wall_bound(self) -> float:
        """[s] wall-clock bound of one blocking wait (connect, a setup request): ``timeout``,
        at least ``_LOCKSTEP_WALL`` with an in-process lockstep peer on the simulated clock
        (whose answers never depend on the host's load)."""
        if self._parks is not None and not self.realtime:
            return max(self.config.timeout, _LOCKSTEP_WALL)
        return self.config.timeout

    # ----------------------------------------------------------------- setup
    def open(self) -> None:
        """Connect, identify, write the mode and the setup parameters, read the status once
        (see the module docstring); raises :class:`FieldbusError` naming what failed."""
        cfg = self.config
        if not self.link.connect(self._wall_bound()):
            reason = self.link.error or f"no answer within {self._wall_bound()} s"
            self.link.close()
            raise FieldbusError(f"{self.name}: cannot connect to {cfg.host}:{cfg.port}: {reason}")
        try:
            self._configure()
            image: list[Any] = [None] * len(STATUS_KEYS)
            for req in self.codec.reads:
                rr = self._transact(_read_pdu(req), f"{req.label} ({', '.join(req.keys)})")
                req.decode(self._registers(rr, req), image)
            self._set_status(image, 0)
        except RegisterValueError as exc:
            self.link.close()
            raise FieldbusError(f"{self.name}: setup failed: {exc}") from exc
        except _RequestError as exc:
            self.link.close()
            raise FieldbusError(f"{self.name}: setup failed: {exc.detail}") from exc
        except FieldbusError:
            self.link.close()
            raise
        self._fresh = True
        self._opened = True

    def _configure(self) -> None:
        """Identification, mode and setup parameters (blocking, each request bounded by the
        timeout): at :meth:`open`, and again on the fault reset after a reconnection (the
        drive may have been power-cycled and be back at its factory parameters)."""
        cfg = self.config
        self._identify()
        if "mode_of_operation" in self.map:
            self._write_register("mode_of_operation", CSP)
        params: list[tuple[str, float]] = [("cycle_time", cfg.cycle_time)]
        if cfg.following_error_window is not None:
            window = abs(cfg.following_error_window * cfg.counts_per_unit)
            params.append(("following_error_window", window))
        if cfg.following_error_timeout is not None:
            params.append(("following_error_timeout", cfg.following_error_timeout))
        if cfg.watchdog is not None:
            params.append(("watchdog", cfg.watchdog))
        for key, value in params:
            if key in self.map:
                self._write_register(key, value)

    def _reconfigure(self) -> bool:
        """The fault reset after a reconnection: configure the drive again before it is used;
        False (the connection closed, the reason latched) when that fails."""
        try:
            self._configure()
        except (_RequestError, RegisterValueError, FieldbusError) as exc:
            detail = exc.detail if isinstance(exc, _RequestError) else str(exc)
            self._disconnected = f"re-configuration after reconnecting failed: {detail}"
            self.link.close()
            return False
        self.reconfigurations += 1
        return True

    def _identify(self) -> None:
        """Read the map's identification registers and compare each with its value."""
        ident = self.map.identification
        if not ident:
            return
        image: list[Any] = [None] * len(ident)
        index = {id(e): i for i, e in enumerate(ident)}
        for req in read_requests(self.map, ident, lambda e: index[id(e)]):
            what = f"{req.label} (identification: {', '.join(req.keys)})"
            req.decode(self._registers(self._transact(_read_pdu(req), what), req), image)
        for e, value in zip(ident, image, strict=True):
            if value == e.expect:
                continue
            if e.type == "f32":
                shown, expected = f"{value!r}", f"{e.expect!r}"
            else:
                digits = 4 if e.size == 1 else 8
                shown = f"{value} (0x{value & (16**digits - 1):0{digits}X})"
                expected = f"{e.expect} (0x{e.expect & (16**digits - 1):0{digits}X})"
            where = f"0x{e.wire:04X}" + (" (input)" if e.table == "input" else "")
            order = f" with word_order={self.map.order_of(e)!r}" if e.size == 2 else ""
            raise FieldbusError(
                f"{self.name}: identification {e.name} at {where} reads {shown}, expected "
                f"{expected}{order} (register map {self.map.name!r}; refusing to enable)"
            )

    def _write_register(self, key: str, value: float) -> None:
        """Setup path: write one register of the map (FC 16 or FC 06)."""
        r = self.map.get(key)
        assert r is not None
        regs = self.map.encode(key, value)
        fc = self.map.write_function
        if fc == 6:
            pdu: ModbusPDU = WriteSingleRegisterRequest(address=r.wire, registers=regs)
            label = f"FC06 write 0x{r.wire:04X} ({key})"
        else:
            pdu = WriteMultipleRegistersRequest(address=r.wire, registers=regs)
            label = f"FC16 write 0x{r.wire:04X}+{len(regs)} ({key})"
        self._transact(pdu, label)

    def _registers(self, rr: ModbusPDU, req: Request) -> list[int]:
        regs = list(rr.registers)
        if len(regs) != req.count:
            raise _RequestError(
                CODE_NO_RESPONSE,
                f"{req.label}: {len(regs)} registers in the answer, expected {req.count}",
                "exception",
            )
        return regs

    def _wait_setup_answer(self, seq: int | None) -> bool:
        """Setup path: wait for something to read; False on no answer. With a lockstep peer
        (``seq``: its request count before the request) a request it parks is no answer at
        once: the simulated clock stands still during a blocking setup, so the answer could
        only come after the timeout; the wall-clock bound guards against a peer that is gone."""
        if seq is None or self.realtime:
            return self.link.wait_readable(self.config.timeout)
        assert self._parks is not None
        for _ in range(max(1, math.ceil(self._wall_bound() / _POLL))):
            if self.link.wait_readable(_POLL):
                return True
            if not self.link.connected:
                return False
            if self._parks.parked_due(self.config.device_id, seq) is not None:
                return False
        return False

    def _transact(self, pdu: ModbusPDU, what: str) -> ModbusPDU:
        """Setup path: one request and its answer, bounded by the timeout (BUSY re-sent once);
        errors name the request (``what``)."""
        for attempt in range(2):
            self.requests += 1
            seq = None if self._parks is None else self._parks.request_count(self.config.device_id)
            tid = self.link.send(pdu, self.config.device_id)
            if tid is None:
                raise _RequestError(CODE_NO_RESPONSE, f"{what}: {self.link.error}", "disconnected")
            reply: Reply | None = None
            for _ in range(8):  # unrelated frames are skipped; each wait is bounded
                if not self._wait_setup_answer(seq):
                    break
                reply = next((r for r in self.link.receive() if r.tid == tid), None)
                if reply is not None or not self.link.connected:
                    break
            if reply is None:
                self.link.close()
                if self.link.error:
                    raise _RequestError(
                        CODE_NO_RESPONSE, f"{what}: {self.link.error}", "disconnected"
                    )
                raise _RequestError(
                    CODE_NO_RESPONSE,
                    f"{what}: no response within {self.config.timeout} s",
                    "timeout",
                )
            rr = reply.pdu
            if rr is None:
                raise _RequestError(CODE_NO_RESPONSE, f"{what}: undecodable response", "exception")
            if isinstance(rr, ExceptionResponse):
                code = int(rr.exception_code)
                if code == ExcCodes.DEVICE_BUSY and attempt == 0:
                    continue
                raise _RequestError(
                    CODE_EXCEPTION_BASE | code, f"{what}: {_exception_detail(code)}", "exception"
                )
            if rr.function_code != pdu.function_code:
                raise _RequestError(
                    CODE_NO_RESPONSE,
                    f"{what}: answer of function {rr.function_code}",
                    "exception",
                )
            return rr
        raise AssertionError("unreachable")

    # ------------------------------------------------------------- answers
    def _set_status(self, image: list[Any], tick: int) -> None:
        """Take a complete status image in (answer to the exchange sent at ``tick``)."""
        prev = self.status
        st = ModbusStatus(*image)
        if st.velocity is None and prev is not None and tick > self._status_tick:
            # no velocity register: the difference of the last two positions
            dt = (tick - self._status_tick) * self.config.cycle_time
            self._velocity = (st.position - prev.position) / dt
        self.status = st
        self._status_tick = tick
        self._fresh = True

    def _take(self, replies: list[Reply]) -> None:
        """Apply the answers that belong to the exchange in flight."""
        ex = self._exchange
        for reply in replies:
            req = ex.pending.pop(reply.tid, None) if ex is not None else None
            if ex is None or req is None:
                self.unexpected_replies += 1
                continue
            if type(req) is _ParamOp:
                self._param_reply(req, reply)
                continue
            reads = req.function in (3, 4, 23)
            rr = reply.pdu
            if rr is None or (
                not isinstance(rr, ExceptionResponse)
                and rr.function_code != ex.pdus[reply.tid].function_code
            ):
                self._failure = (CODE_NO_RESPONSE, f"{req.label}: malformed response", "exception")
                ex.read_failed |= reads
                continue
            if isinstance(rr, ExceptionResponse):
                code = int(rr.exception_code)
                if code == ExcCodes.DEVICE_BUSY and not ex.busy_retried:
                    ex.busy_retried = True  # BUSY: send the same request once more
                    self._send(ex, ex.pdus[reply.tid], req)
                    continue
                detail = f"{req.label}: {_exception_detail(code)}"
                self._failure = (CODE_EXCEPTION_BASE | code, detail, "exception")
                ex.read_failed |= reads
                continue
            if reads:
                regs = list(rr.registers)
                if len(regs) != req.count:
                    detail = f"{req.label}: {len(regs)} registers in the answer"
                    self._failure = (CODE_NO_RESPONSE, detail, "exception")
                    ex.read_failed = True
                    continue
                req.decode(regs, ex.status)
                ex.reads_left -= 1
                if ex.reads_left == 0 and not ex.read_failed:
                    self._set_status(ex.status, ex.sent_tick)
        if ex is not None and ex is self._exchange and ex.queue:
            if not self._pump(ex):
                self._link_lost()
                return
        if ex is not None and not ex.pending and not ex.queue:
            self._timed_out = ""
            if self._tick - ex.sent_tick > 1:
                self.late_replies += 1
            self._exchange = None

    def _link_lost(self) -> None:
        if self._opened and not self.link.connected and not self.link.connecting:
            if not self._disconnected:
                self._disconnected = self.link.error or "connection lost"
            self._drop_params(self._disconnected)
            self._exchange = None

    def _drop_params(self, why: str) -> None:
        """The exchange in flight is given up: its parameter transfer fails."""
        ex = self._exchange
        if ex is not None:
            for req in [*ex.pending.values(), *ex.queue]:
                if type(req) is _ParamOp:
                    req.transfer.fail(f"{self.name}: {req.label}: {why}")

    def _collect(self) -> None:
        """Take in the answers that have arrived (never blocks)."""
        self._take(self.link.receive())
        self._link_lost()

    def _abandon(self) -> None:
        """Give up the exchange in flight: re-open the connection so that its answer, if it
        ever comes, cannot be taken for the answer to a later request."""
        self._drop_params(self._timed_out or "no response")
        self._exchange = None
        self.link.close()
        self._start_connect()

    def _start_connect(self) -> None:
        self._cycles_since_attempt = 0
        self.link.start_connect()
        if not self.realtime:
            self.link.poll_connect(self._wall_bound())

    def _wait_settled(self) -> None:
        """Simulated clock: wait until the exchange is answered, parked by the lockstep peer, or
        (without one) the timeout has passed; bounded by ``timeout`` of wall time."""
        cfg = self.config
        if self._parks is not None:
            if self._settle_lockstep():
                return
        else:
            for _ in range(8 + 2 * len(self.codec.requests)):  # each wait is bounded
                if self._exchange is None or not self.link.connected:
                    return
                if not self.link.wait_readable(cfg.timeout):
                    break
                self._collect()
        if self._exchange is not None and self.link.connected:
            self._time_out(f"no response within {cfg.timeout} s")

    def _settle_lockstep(self) -> bool:
        """Lockstep: take answers in until the exchange is done or the peer holds one of its
        requests (parked until a later simulated time); True then, False when ``timeout`` (at
        least ``_LOCKSTEP_WALL``) of wall time per request has passed without either."""
        cfg = self.config
        bound = self._wall_bound()
        for _ in range(len(self.codec.requests) * max(1, math.ceil(bound / _POLL))):
            ex = self._exchange
            if ex is None or not self.link.connected:
                return True
            if ex.parked_due is None:
                ex.parked_due = self._parks.parked_due(cfg.device_id, ex.peer_seq)
            if ex.parked_due is not None and ex.parked_due > self._last_step_t:
                return True  # the peer releases it at a later step
            if self.link.wait_readable(_POLL):
                self._collect()
        return False

    def _time_out(self, detail: str) -> None:
        ex = self._exchange
        if ex is not None and (ex.pending or ex.queue):
            req = next(iter(ex.pending.values())) if ex.pending else ex.queue[0]
            detail = f"{req.label}: {detail}"
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
                # (and the rest of the exchange, unless the peer parks that too)
                self._settle_lockstep()
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
        state = decode_statusword(st.statusword & 0xFFFF)
        fault = state in (Cia402State.FAULT, Cia402State.FAULT_REACTION_ACTIVE)
        comm_ok, error_code, detail, kind = True, 0, "", ""
        if fault:
            if st.error_code is None:
                detail = f"drive fault ({state.value}; the register map has no error_code)"
            else:
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
        if fresh and self._echo and st.life_sign_echo != self.life_sign:
            fresh = False  # the drive has not seen our last command
        enabled = state is Cia402State.OPERATION_ENABLED and comm_ok
        self._reset_until = reset_in_progress(self._reset_until, t, comm_ok and not fault)
        reset_pending = self._reset_until is not None
        velocity = st.velocity if st.velocity is not None else self._velocity
        return DriveFeedback(
            position=self.scaling.position_to_si(st.position),  # type: ignore[arg-type]
            velocity=self.scaling.velocity_to_si(velocity),  # type: ignore[arg-type]
            enabled=enabled,
            fault=fault,
            error_code=error_code,
            comm_ok=comm_ok,
            detail=detail,
            stale=not fresh,
            kind=kind,
            reset_pending=reset_pending,
        )

    def _pump(self, ex: _Exchange) -> bool:
        """Send the exchange's next requests, up to ``requests_in_flight`` on the wire; False
        when the connection is lost."""
        if self._parks is not None and not ex.pending:
            # lockstep: what the peer parks from now on belongs to these requests
            ex.peer_seq = self._parks.request_count(self.config.device_id)
            ex.parked_due = None
        while ex.queue and len(ex.pending) < self.config.requests_in_flight:
            req = ex.queue.pop(0)
            fn = req.function
            if fn in (3, 4):
                pdu = self._read_pdus[id(req)]
            elif fn:
                pdu = _write_pdu(req, ex.blocks[id(req)])
            else:  # a drive parameter transfer (_ParamOp)
                pdu = req.pdu  # type: ignore[attr-defined]
            if not self._send(ex, pdu, req):
                return False
        return True

    def _send(self, ex: _Exchange, pdu: ModbusPDU, req: Request) -> bool:
        self.requests += 1
        tid = self.link.send(pdu, self.config.device_id)
        if tid is None:
            return False
        ex.pending[tid] = req
        ex.pdus[tid] = pdu
        return True

    def _connected(self, reset: bool) -> bool:
        """Keep the connection up (reconnect attempts every ``reconnect_every`` cycles, at once
        on a fault reset); True when it is usable in this cycle."""
        link = self.link
        if link.connecting:
            link.poll_connect(0.0 if self.realtime else self._wall_bound())
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
            # explicit reset after reconnecting: the drive may have rebooted, set it up again
            if not self._reconfigure():
                self._step_peer(t)
                return
            self._disconnected = ""
        if self._exchange is not None:
            self.held_cycles += 1  # the previous exchange is still unanswered
            self._step_peer(t)
            return
        st = self.status
        state = decode_statusword(st.statusword & 0xFFFF) if st is not None else Cia402State.UNKNOWN
        if self._disconnected:
            state = Cia402State.UNKNOWN  # -> controlword 0x00 until reset
        target = Cia402State.OPERATION_ENABLED if command.enable else Cia402State.READY_TO_SWITCH_ON
        resetting = self._reset_until is not None
        cw = next_controlword(state, target, self.controlword, resetting)
        image = self._image
        if state is Cia402State.OPERATION_ENABLED and command.enable:
            image[CMD_POSITION] = command.position * cfg.counts_per_unit + cfg.offset_counts
            image[CMD_VELOCITY] = (
                command.velocity * cfg.counts_per_unit if cfg.velocity_feed_forward else 0
            )
        else:
            image[CMD_POSITION] = st.position if st is not None else 0
            image[CMD_VELOCITY] = 0
        life_sign = (self.life_sign + 1) & 0xFFFF
        image[CMD_CONTROLWORD] = cw
        image[CMD_LIFE_SIGN] = life_sign
        try:
            blocks = self.codec.encode(image)
        except RegisterValueError as exc:
            self._failure = (CODE_OUT_OF_RANGE, f"setpoint not sent: {exc}", "")
            self._step_peer(t)
            return
        self.controlword = cw
        self.life_sign = life_sign
        ex = _Exchange(life_sign, self._tick, len(self.codec.reads), [None] * len(STATUS_KEYS))
        ex.queue = list(self.codec.requests)
        if self._param_ops:
            ex.queue.append(self._param_ops.popleft())  # type: ignore[arg-type]
        ex.blocks = {id(r): b for r, b in zip(self.codec.writes, blocks, strict=True)}
        self._exchange = ex
        if not self._pump(ex):
            self._link_lost()
        elif not self.realtime:
            self._wait_settled()
        self._step_peer(t)

    # ------------------------------------------------------- drive parameters
    def _check_queue(self) -> None:
        if len(self._param_ops) >= MAX_QUEUED_PARAMETERS:
            raise ParameterError(
                f"{self.name}: {len(self._param_ops)} parameter transfers already queued",
                failed=True,
            )

    def _register_type(self, address: DriveAddress) -> tuple[str, WordOrder]:
        """(type, word order) of a parameter: its number's type, else the map's holding
        register at that address, else one u16 register."""
        reg = next(
            (r for r in self.map.registers if r.wire == address.index and r.table == "holding"),
            None,
        )
        order = self.map.word_order if reg is None else self.map.order_of(reg)
        if address.real:
            return "f32", order
        if address.size:
            return ("i" if address.signed else "u") + str(8 * address.size), order
        return ("u16" if reg is None else reg.type), order

    def _param_op(self, address: int, kind: str, order: WordOrder, value: float | None) -> _ParamOp:
        count = 2 if kind in ("u32", "i32", "f32") else 1
        if value is None:
            pdu: ModbusPDU = ReadHoldingRegistersRequest(address=address, count=count)
            label = f"FC03 read 0x{address:04X}+{count} ({kind})"
        else:
            regs = encode_value(value, kind, order)
            if count == 1 and self.map.write_function == 6:
                pdu = WriteSingleRegisterRequest(address=address, registers=regs)
                label = f"FC06 write 0x{address:04X} ({kind})"
            else:
                pdu = WriteMultipleRegistersRequest(address=address, registers=regs)
                label = f"FC16 write 0x{address:04X}+{count} ({kind})"
        op = _ParamOp(pdu, label, kind, order, count)
        if value is not None:
            op.written = float(value)
        return op

    def start_parameter(
        self, address: DriveAddress, value: float | None = None
    ) -> ParameterTransfer:
        """Read or write holding registers (the raw register value in its type; the type
        from the number, else from the register map, else u16), carried in the next cycle's
        exchange after its cyclic requests (never blocking; on the simulated clock the cycle
        waits for the answer as for the cyclic ones). A Modbus exception fails the transfer
        (the exception code in its text) without touching the axis' communication state."""
        self._check_queue()
        if address.bus != "modbus":
            raise ParameterError(
                f"{self.name}: {address.describe()} is not a Modbus register "
                "(0x10000 + the register address on a Modbus drive)",
                number_error=True,
            )
        kind, order = self._register_type(address)
        if value is not None:
            if kind != "f32" and math.isfinite(value) and value != int(value):
                raise ParameterError(
                    f"{self.name}: register 0x{address.index:04X} ({kind}) takes an integer, "
                    f"got {value!r}"
                )
            try:
                encode_value(value, kind, order)
            except RegisterValueError as exc:
                raise ParameterError(
                    f"{self.name}: register 0x{address.index:04X} ({kind}): {exc}"
                ) from None
        op = self._param_op(address.index, kind, order, value)
        self._param_ops.append(op)
        return op.transfer

    def _param_reply(self, op: _ParamOp, reply: Reply) -> None:
        rr = reply.pdu
        where = f"{self.name}: {op.label}"
        if rr is None:
            op.transfer.fail(f"{where}: malformed response")
        elif isinstance(rr, ExceptionResponse):
            op.transfer.fail(f"{where}: {_exception_detail(int(rr.exception_code))}")
        elif rr.function_code != op.pdu.function_code:
            op.transfer.fail(f"{where}: answer of function {rr.function_code}")
        elif op.pdu.function_code == 3:
            regs = list(rr.registers)
            if len(regs) != op.count:
                op.transfer.fail(f"{where}: {len(regs)} registers in the answer")
            else:
                op.transfer.finish(float(decode_value(regs, op.kind, op.order)) * op.factor)
        else:
            op.transfer.finish(op.written)

    def start_torque_read(self) -> ParameterTransfer | None:
        """The actual torque: the torque register (i16, per mille of ``rated_torque``) read
        in the next exchange; None when the drive has no torque register."""
        self._check_queue()
        cfg = self.config
        reg = cfg.torque_register
        if reg is None and self.map.name == "motionplc-v1":
            reg = 0x0208  # TORQUE_ACTUAL of map v1 (read through by the status block)
        if reg is None:
            return None
        if cfg.rated_torque is None:
            raise ParameterError(
                f"{self.name}: the torque register 0x{reg:04X} is in per mille of the rated "
                "torque: configure rated_torque"
            )
        op = self._param_op(reg, "i16", self.map.word_order, None)
        op.factor = cfg.rated_torque / 1000.0
        op.transfer.label = f"torque {op.label}"
        self._param_ops.append(op)
        return op.transfer

    def _step_peer(self, t: float) -> None:
        if self.peer is not None:
            self.peer.step(t)
            self._last_step_t = t

    def close(self) -> None:
        self.link.close()
        self._opened = False
