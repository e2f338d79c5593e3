"""Kestrel KD-40: a CSP servo drive with a Modbus TCP interface (a drive motionplc did not write).

This module is a test peer. It is written from the Modbus application protocol specification
(V1.1b3), the Modbus messaging on TCP/IP implementation guide (V1.0b) and CiA 402, from the socket
up, without pymodbus and without motionplc's own fieldbus code, the way a third-party drive's
firmware would be. What follows is its "user manual".

Connection
==========
* Modbus TCP server on ``host:port`` (127.0.0.1; port 0 picks a free port, see ``.port``), up to
  ``max_connections`` clients at once (8 by default; a further client is accepted and closed at
  once). Requests are answered in the order they arrive on each connection; frames may arrive
  split over several TCP segments or several in one segment.
* MBAP header: transaction id (echoed), protocol id (must be 0: a frame with another protocol id
  is ignored, no answer), length (unit id + PDU, 2..254: any other length closes the connection,
  because the stream cannot be resynchronised), unit id.
* Unit id: the drive answers its own unit id (``unit_id``, default 1) only. A request for any
  other unit id (0 and 0xFF included) is answered with exception **0x0B** (gateway target device
  failed to respond), as a gateway in front of a serial line would; with
  ``foreign_unit="ignore"`` it gets no answer at all.

Function codes
==============
======  ===============================  =================================================
code    function                         limits
======  ===============================  =================================================
0x03    read holding registers           1..125 registers
0x04    read input registers             1..125 registers
0x06    write single register            16-bit registers only
0x10    write multiple registers (16)    1..123 registers, byte count = 2 x quantity
======  ===============================  =================================================

Any other function code (0x17 read/write multiple included) is answered with exception 0x01.

Exception codes
===============
* **0x01** ILLEGAL FUNCTION: function code not in the table above.
* **0x02** ILLEGAL DATA ADDRESS: a register outside the areas below; a write to a reserved
  (unassigned) address; a write that covers only one half of a 32-bit value (32-bit values are
  written as a whole, in one 0x10 request).
* **0x03** ILLEGAL DATA VALUE: a quantity out of range (read > 125, write > 123, 0), a byte count
  that is not 2 x quantity or does not match the data sent, a PDU of the wrong length.
* **0x04** SERVER DEVICE FAILURE: the write is refused by the drive: a read-only register, or a
  value outside the register's range (see the tables). A refused 0x10 write changes nothing
  (all registers are checked before any is written).
* **0x0B**: foreign unit id (see above).

Checks are made in this order: function code, quantity / length, address, value.

Data types and word order
=========================
Bytes within a register are big endian (Modbus). 32-bit values (``u32``, ``i32``, ``f32`` =
IEEE 754 single precision) take two registers, **low word first** (at the lower address), e.g.
0x12345678 is stored as 0x5678, 0x1234. Positions are in encoder counts (``inc``), velocities
in counts per second (``inc/s``).

Register map
============
Input registers (function 0x04, read only). Readable area: 0x1000..0x10FF (unassigned
addresses read 0) and 0x1F00..0x1F07.

=========  ====  ==========================================================================
address    type  meaning
=========  ====  ==========================================================================
0x1000     i32   position actual value [inc] (CiA 402 0x6064)
0x1002     f32   velocity actual value [inc/s] (0x606C)
0x1004     u16   statusword (0x6041)
0x1005     i16   modes of operation display (0x6061): always 8 (CSP)
0x1006     i32   following error actual value [inc] (0x60F4): demand - actual
0x1008     u16   error code (0x603F): 0 = no fault
0x1009     u16   life-sign echo: the last value written to 0x2006
0x1F00     u16   vendor id 0x4B53
0x1F01     u16   device profile 402
0x1F02     u32   product code 0x00000040 (KD-40)
0x1F04     u32   firmware version 0x00010203 (1.2.3)
0x1F06     u32   word-order probe 0x12345678 (reads 0x5678, 0x1234)
=========  ====  ==========================================================================

Holding registers (function 0x03 read, 0x06 / 0x10 write). Readable area: 0x2000..0x20FF and
0x3000..0x30FF (unassigned addresses read 0 and refuse writes with 0x02).

=========  ====  ====  ===============================================  ========================
address    type  rw    meaning                                          range (else 0x04)
=========  ====  ====  ===============================================  ========================
0x2000     i32   rw    target position [inc] (0x607A)                   any
0x2002     f32   rw    velocity feed-forward [inc/s] (0x60B1)           finite
0x2004     u16   rw    controlword (0x6040); **a write runs one cycle**  any
0x2005     i16   rw    modes of operation (0x6060)                      8 only (CSP)
0x2006     u16   rw    life sign (echoed at input 0x1009)               any
0x3000     u32   rw    following error window [inc] (0x6065)            any; 0xFFFFFFFF = off
0x3002     u16   rw    following error time-out [ms] (0x6066)           any
0x3003     u16   rw    watchdog time [ms]; 0 = off                      any
0x3004     u32   rw    cycle time [us]                                  250..100000
0x3006     u16   rw    position loop lag time constant [us]            100..65535
0x3007     i16   rw    quick stop option code (0x605A)                  0, 1, 2, 5, 6
0x3008     f32   rw    maximum velocity [inc/s]                         > 0, finite
0x3010     u16   ro    boot counter (1 after the first power-up)
0x3011     u16   ro    faults since power-up
=========  ====  ====  ===============================================  ========================

Factory settings: window 10000 inc, time-out 20 ms, watchdog 100 ms, cycle time 4000 us, lag
time constant 8000 us, quick stop option 2, maximum velocity 1 000 000 inc/s (``FACTORY``; the
constructor's ``factory`` overrides single entries).

Time
====
The drive has no clock of its own: its time advances by one cycle time (0x3004) **each time the
controlword (0x2004) is written**, alone (0x06) or within a 0x10 write (all registers of that
write are stored first, then the cycle runs). A master writes the controlword once per cycle, so
the drive runs in lockstep with it and every run is reproducible. ``advance(seconds)`` lets time
pass without a controlword write (whole cycles: the plant moves on, the watchdog counts), as wall
time would while a master is silent.

One cycle: (1) a fault reaction started in the previous cycle ends (FAULT REACTION ACTIVE ->
FAULT), a finished quick stop with option 0..2 ends (QUICK STOP ACTIVE -> SWITCH ON DISABLED);
(2) the controlword is decoded (transitions below; fault reset on its rising edge 0->1 of bit 7);
(3) the plant moves one cycle; (4) following error and watchdog are checked.

Drive behaviour (CiA 402)
=========================
Power state machine, statusword values (bit 4 voltage enabled and bit 9 remote are always set):

=========================  ==========  ==================================================
state                      statusword  left by
=========================  ==========  ==================================================
SWITCH ON DISABLED         0x0250      shutdown (cw & 0x87 == 0x06) -> READY (2)
READY TO SWITCH ON         0x0231      switch on (0x07) -> SWITCHED ON (3); switch on +
                                       enable (0x0F) -> OPERATION ENABLED (3+4); disable
                                       voltage (cw & 0x82 == 0) or quick stop (cw & 0x86 ==
                                       0x02) -> SWITCH ON DISABLED (7)
SWITCHED ON                0x0233      enable operation (cw & 0x8F == 0x0F) -> (4);
                                       shutdown -> READY (6); disable voltage / quick stop
                                       -> SWITCH ON DISABLED (10)
OPERATION ENABLED          0x0237      disable operation (cw & 0x8F == 0x07) -> SWITCHED ON
                                       (5); shutdown -> READY (8); disable voltage ->
                                       SWITCH ON DISABLED (9); quick stop -> QUICK STOP
                                       ACTIVE (11)
QUICK STOP ACTIVE          0x0217      disable voltage -> SWITCH ON DISABLED (12); option
                                       0..2: by itself once stopped (12); option 5, 6:
                                       enable operation -> OPERATION ENABLED (16)
FAULT REACTION ACTIVE      0x021F      by itself after one cycle -> FAULT (14)
FAULT                      0x0218      rising edge of bit 7 -> SWITCH ON DISABLED (15)
=========================  ==========  ==================================================

The drive starts in SWITCH ON DISABLED (transitions 0 and 1 happen at power-up). In OPERATION
ENABLED bit 12 ("drive follows the command value") is set; bit 13 (following error) is set
while |following error| > window; bit 11 (internal limit) while the velocity is limited.

CSP only: in OPERATION ENABLED the drive takes the target position of each cycle as its demand;
the plant moves by the velocity feed-forward and follows the rest with a first-order lag (time
constant tau = 0x3006), its speed limited to 0x3008 (T = cycle time)::

    step = ff * T + (demand - actual - ff * T) * (1 - exp(-T / tau)),   |step| <= v_max * T

so a ramp of slope v is followed with the constant error v T (1 - a) / a, a = 1 - exp(-T / tau),
without feed-forward, and with none when the feed-forward equals v.

Out of OPERATION ENABLED the motor holds its position (demand = actual, following error 0); in
QUICK STOP ACTIVE and FAULT REACTION ACTIVE the demand is frozen at the position where the stop
began (the plant has no inertia: it stops within the cycle). The position is kept over a reboot
(absolute encoder).

Faults (error code, then FAULT REACTION ACTIVE -> FAULT):

* **0x8611** following error: |demand - actual| > window for longer than the time-out
  (accumulated over cycles, in OPERATION ENABLED);
* **0x8130** watchdog: no controlword write for longer than the watchdog time (armed by the first
  controlword write after power-up; not while in fault);
* any code given to ``inject_fault``.

A fault reset clears the error code; the first fault wins while a fault is pending.

Test API (thread-safe)
======================
``start()`` / ``stop()`` (also a context manager), ``port``; ``inject_fault(code)``,
``drop_connections()``, ``stall(n)`` (the next n requests are discarded unprocessed, as if lost:
the client times out), ``reboot()`` (factory parameters, SWITCH ON DISABLED, registers cleared,
boot counter + 1, connections dropped), ``advance(seconds)``; views ``state``, ``statusword``,
``position`` (counts, float), ``velocity``, ``target_position``, ``controlword``, ``error_code``,
``time``, ``parameters`` (a copy), ``requests_by_function`` (a ``Counter`` of the function codes of
every well-formed frame received, stalled and refused ones included), ``connection_count``.
"""

from __future__ import annotations

import enum
import math
import selectors
import socket
import struct
import threading
from collections import Counter
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Literal

__all__ = ["FACTORY", "DriveState", "ModbusServo"]

# Modbus exception codes
ILLEGAL_FUNCTION = 0x01
ILLEGAL_DATA_ADDRESS = 0x02
ILLEGAL_DATA_VALUE = 0x03
SERVER_DEVICE_FAILURE = 0x04
GATEWAY_TARGET_FAILED = 0x0B

MAX_READ = 125
MAX_WRITE = 123

ERROR_FOLLOWING = 0x8611
ERROR_WATCHDOG = 0x8130
FE_WINDOW_OFF = 0xFFFFFFFF

FACTORY: Mapping[str, float] = {
    "following_error_window": 10000,
    "following_error_timeout_ms": 20,
    "watchdog_ms": 100,
    "cycle_time_us": 4000,
    "lag_time_constant_us": 8000,
    "quick_stop_option": 2,
    "max_velocity": 1.0e6,
}


class DriveState(enum.Enum):
    """CiA 402 power states; the value is the statusword this drive shows in that state."""

    SWITCH_ON_DISABLED = 0x0250
    READY_TO_SWITCH_ON = 0x0231
    SWITCHED_ON = 0x0233
    OPERATION_ENABLED = 0x0237
    QUICK_STOP_ACTIVE = 0x0217
    FAULT_REACTION_ACTIVE = 0x021F
    FAULT = 0x0218


class _Command(enum.Enum):
    SHUTDOWN = "shutdown"
    SWITCH_ON = "switch on"
    ENABLE_OPERATION = "enable operation"
    DISABLE_VOLTAGE = "disable voltage"
    QUICK_STOP = "quick stop"


def _decode_command(cw: int) -> _Command | None:
    """The device control command in a controlword (CiA 402 masks; the masks are disjoint)."""
    if cw & 0x82 == 0x00:
        return _Command.DISABLE_VOLTAGE
    if cw & 0x86 == 0x02:
        return _Command.QUICK_STOP
    if cw & 0x87 == 0x06:
        return _Command.SHUTDOWN
    if cw & 0x8F == 0x07:
        return _Command.SWITCH_ON
    if cw & 0x8F == 0x0F:
        return _Command.ENABLE_OPERATION
    return None


_S = DriveState
_C = _Command
# (state, command) -> (next state, CiA 402 transition number). QUICK STOP ACTIVE -> OPERATION
# ENABLED (16) is allowed only with quick stop option 5..8 (checked in the code).
_TRANSITIONS: Mapping[tuple[DriveState, _Command], tuple[DriveState, str]] = {
    (_S.SWITCH_ON_DISABLED, _C.SHUTDOWN): (_S.READY_TO_SWITCH_ON, "2"),
    (_S.READY_TO_SWITCH_ON, _C.SWITCH_ON): (_S.SWITCHED_ON, "3"),
    (_S.READY_TO_SWITCH_ON, _C.ENABLE_OPERATION): (_S.OPERATION_ENABLED, "3+4"),
    (_S.READY_TO_SWITCH_ON, _C.DISABLE_VOLTAGE): (_S.SWITCH_ON_DISABLED, "7"),
    (_S.READY_TO_SWITCH_ON, _C.QUICK_STOP): (_S.SWITCH_ON_DISABLED, "7"),
    (_S.SWITCHED_ON, _C.ENABLE_OPERATION): (_S.OPERATION_ENABLED, "4"),
    (_S.SWITCHED_ON, _C.SHUTDOWN): (_S.READY_TO_SWITCH_ON, "6"),
    (_S.SWITCHED_ON, _C.DISABLE_VOLTAGE): (_S.SWITCH_ON_DISABLED, "10"),
    (_S.SWITCHED_ON, _C.QUICK_STOP): (_S.SWITCH_ON_DISABLED, "10"),
    (_S.OPERATION_ENABLED, _C.SWITCH_ON): (_S.SWITCHED_ON, "5"),
    (_S.OPERATION_ENABLED, _C.SHUTDOWN): (_S.READY_TO_SWITCH_ON, "8"),
    (_S.OPERATION_ENABLED, _C.DISABLE_VOLTAGE): (_S.SWITCH_ON_DISABLED, "9"),
    (_S.OPERATION_ENABLED, _C.QUICK_STOP): (_S.QUICK_STOP_ACTIVE, "11"),
    (_S.QUICK_STOP_ACTIVE, _C.DISABLE_VOLTAGE): (_S.SWITCH_ON_DISABLED, "12"),
    (_S.QUICK_STOP_ACTIVE, _C.ENABLE_OPERATION): (_S.OPERATION_ENABLED, "16"),
}


@dataclass(frozen=True, slots=True)
class _Reg:
    """One value in a register table: name, first address, type, writable, value check."""

    name: str
    address: int
    type: Literal["u16", "i16", "u32", "i32", "f32"]
    writable: bool = False
    valid: Callable[[float], bool] = lambda v: True

    @property
    def size(self) -> int:
        return 1 if self.type in ("u16", "i16") else 2


def _encode(value: float, kind: str) -> tuple[int, ...]:
    """Registers of a value, low word first for 32-bit types."""
    if kind == "u16":
        return (int(value) & 0xFFFF,)
    if kind == "i16":
        return (int(value) & 0xFFFF,)
    if kind == "f32":
        raw = struct.unpack(">I", struct.pack(">f", value))[0]
    else:
        raw = int(value) & 0xFFFFFFFF
    return (raw & 0xFFFF, raw >> 16)


def _decode(regs: tuple[int, ...], kind: str) -> float:
    """Value of the registers of one entry (low word first for 32-bit types)."""
    if kind == "u16":
        return regs[0]
    if kind == "i16":
        return regs[0] - 0x10000 if regs[0] & 0x8000 else regs[0]
    raw = regs[0] | (regs[1] << 16)
    if kind == "u32":
        return raw
    if kind == "i32":
        return raw - 0x100000000 if raw & 0x80000000 else raw
    return struct.unpack(">f", struct.pack(">I", raw))[0]


def _wrap_i32(value: float) -> int:
    return ((int(round(value)) + 0x80000000) & 0xFFFFFFFF) - 0x80000000


_HOLDING_REGS = (
    _Reg("target_position", 0x2000, "i32", True),
    _Reg("velocity_feed_forward", 0x2002, "f32", True, math.isfinite),
    _Reg("controlword", 0x2004, "u16", True),
    _Reg("mode_of_operation", 0x2005, "i16", True, lambda v: v == 8),
    _Reg("life_sign", 0x2006, "u16", True),
    _Reg("following_error_window", 0x3000, "u32", True),
    _Reg("following_error_timeout_ms", 0x3002, "u16", True),
    _Reg("watchdog_ms", 0x3003, "u16", True),
    _Reg("cycle_time_us", 0x3004, "u32", True, lambda v: 250 <= v <= 100_000),
    _Reg("lag_time_constant_us", 0x3006, "u16", True, lambda v: v >= 100),
    _Reg("quick_stop_option", 0x3007, "i16", True, lambda v: v in (0, 1, 2, 5, 6)),
    _Reg("max_velocity", 0x3008, "f32", True, lambda v: math.isfinite(v) and v > 0),
    _Reg("boot_count", 0x3010, "u16"),
    _Reg("fault_count", 0x3011, "u16"),
)
_INPUT_REGS = (
    _Reg("position_actual", 0x1000, "i32"),
    _Reg("velocity_actual", 0x1002, "f32"),
    _Reg("statusword", 0x1004, "u16"),
    _Reg("mode_display", 0x1005, "i16"),
    _Reg("following_error", 0x1006, "i32"),
    _Reg("error_code", 0x1008, "u16"),
    _Reg("life_sign_echo", 0x1009, "u16"),
    _Reg("vendor_id", 0x1F00, "u16"),
    _Reg("device_profile", 0x1F01, "u16"),
    _Reg("product_code", 0x1F02, "u32"),
    _Reg("firmware_version", 0x1F04, "u32"),
    _Reg("word_order_probe", 0x1F06, "u32"),
)
_HOLDING_AREAS = ((0x2000, 0x20FF), (0x3000, 0x30FF))
_INPUT_AREAS = ((0x1000, 0x10FF), (0x1F00, 0x1F07))
_IDENTIFICATION = {
    "vendor_id": 0x4B53,
    "device_profile": 402,
    "product_code": 0x00000040,
    "firmware_version": 0x00010203,
    "word_order_probe": 0x12345678,
}
_PARAMETER_NAMES = tuple(FACTORY)


def _index(regs: tuple[_Reg, ...]) -> dict[int, tuple[_Reg, int]]:
    """address -> (entry, word index within the entry)."""
    out: dict[int, tuple[_Reg, int]] = {}
    for reg in regs:
        for i in range(reg.size):
            out[reg.address + i] = (reg, i)
    return out


_HOLDING = _index(_HOLDING_REGS)
_INPUT = _index(_INPUT_REGS)
_PARAM_REGS = {r.name: r for r in _HOLDING_REGS if r.name in FACTORY}


def _in_areas(address: int, areas: tuple[tuple[int, int], ...]) -> bool:
    return any(lo <= address <= hi for lo, hi in areas)


class _ModbusError(Exception):
    """A request refused with a Modbus exception code."""

    def __init__(self, code: int) -> None:
        super().__init__(code)
        self.code = code


class ModbusServo:
    """A Kestrel KD-40 CSP servo with a Modbus TCP server on its own thread (see the module doc).

    Guarantees: every request is handled under one lock, so the test API (``inject_fault``,
    views, ...) may be used from any thread at any time; the drive's behaviour depends only on
    the sequence of requests and ``advance`` calls, never on wall-clock time.
    """

    def __init__(
        self,
        host: str = "127.0.0.1",
        port: int = 0,
        unit_id: int = 1,
        *,
        foreign_unit: Literal["exception", "ignore"] = "exception",
        max_connections: int = 8,
        factory: Mapping[str, float] | None = None,
    ) -> None:
        if not isinstance(unit_id, int) or not 1 <= unit_id <= 247:
            raise ValueError(f"unit_id must be an integer in 1..247, got {unit_id!r}")
        if foreign_unit not in ("exception", "ignore"):
            raise ValueError(f"foreign_unit must be 'exception' or 'ignore', got {foreign_unit!r}")
        if not isinstance(port, int) or not 0 <= port <= 65535:
            raise ValueError(f"port must be an integer in 0..65535, got {port!r}")
        if not isinstance(max_connections, int) or max_connections < 1:
            raise ValueError(f"max_connections must be an integer >= 1, got {max_connections!r}")
        self._host = host
        self._requested_port = port
        self._unit_id = unit_id
        self._foreign_unit = foreign_unit
        self._max_connections = max_connections
        self._factory = dict(FACTORY)
        for name, value in (factory or {}).items():
            reg = _PARAM_REGS.get(name)
            if reg is None:
                raise ValueError(f"factory: unknown parameter {name!r}; known: {_PARAMETER_NAMES}")
            if not self._fits(reg, value):
                raise ValueError(f"factory: {name}={value!r} is outside the register's range")
            self._factory[name] = value

        self._lock = threading.RLock()
        self._requests: Counter[int] = Counter()
        self._stall = 0
        self._boot_count = 0
        self._fault_count = 0
        self._position = 0.0
        self._power_up()

        self._listener: socket.socket | None = None
        self._port: int | None = None
        self._thread: threading.Thread | None = None
        self._selector: selectors.BaseSelector | None = None
        self._wake_r: socket.socket | None = None
        self._wake_w: socket.socket | None = None
        self._conns: dict[socket.socket, bytearray] = {}
        self._jobs: list[tuple[str, threading.Event]] = []
        self._stopping = False

    # ------------------------------------------------------------------ drive state
    def _power_up(self) -> None:
        """Power-on state (transitions 0, 1): factory parameters, registers cleared."""
        self._params: dict[str, float] = dict(self._factory)
        self._state = DriveState.SWITCH_ON_DISABLED
        self._error_code = 0
        self._controlword = 0
        self._target = 0
        self._feed_forward = 0.0
        self._mode = 8
        self._life_sign = 0
        self._velocity = 0.0
        self._demand = self._position
        self._limited = False
        self._time_us = 0
        self._fe_time_us = 0
        self._watchdog_armed = False
        self._watchdog_us = 0
        self._quick_stop_done = False
        self._boot_count = (self._boot_count + 1) & 0xFFFF
        self._fault_count = 0

    @staticmethod
    def _fits(reg: _Reg, value: float) -> bool:
        ranges = {"u16": (0, 0xFFFF), "i16": (-0x8000, 0x7FFF), "u32": (0, 0xFFFFFFFF)}
        ranges["i32"] = (-0x80000000, 0x7FFFFFFF)
        if reg.type == "f32":
            if not isinstance(value, int | float) or not math.isfinite(value):
                return False
            if abs(value) > 3.4e38:
                return False
        else:
            lo, hi = ranges[reg.type]
            if isinstance(value, bool) or not isinstance(value, int) or not lo <= value <= hi:
                return False
        return bool(reg.valid(value))

    def _fault(self, code: int) -> None:
        if self._state in (DriveState.FAULT, DriveState.FAULT_REACTION_ACTIVE):
            return
        self._state = DriveState.FAULT_REACTION_ACTIVE
        self._error_code = code
        self._demand = self._position
        self._fault_count = (self._fault_count + 1) & 0xFFFF

    def _cycle(self, controlword: int | None) -> None:
        """One drive cycle (see "Time" in the module doc); ``None``: no controlword written."""
        cycle_us = int(self._params["cycle_time_us"])
        dt = cycle_us * 1e-6
        self._time_us += cycle_us
        # (1) reactions started in the previous cycle end
        if self._state is DriveState.FAULT_REACTION_ACTIVE:
            self._state = DriveState.FAULT  # 14
        elif (
            self._state is DriveState.QUICK_STOP_ACTIVE
            and self._quick_stop_done
            and self._params["quick_stop_option"] <= 4
        ):
            self._state = DriveState.SWITCH_ON_DISABLED  # 12
        # (2) the controlword
        if controlword is not None:
            self._apply_controlword(controlword)
            self._watchdog_us = 0
            self._watchdog_armed = True
        else:
            self._watchdog_us += cycle_us
        # (3) the plant
        self._step_plant(dt)
        # (4) monitoring
        self._monitor(cycle_us)

    def _apply_controlword(self, cw: int) -> None:
        rising_reset = bool(cw & 0x80) and not self._controlword & 0x80
        self._controlword = cw
        if self._state is DriveState.FAULT:
            if rising_reset:  # 15
                self._state = DriveState.SWITCH_ON_DISABLED
                self._error_code = 0
                self._fe_time_us = 0
                self._demand = self._position
            return
        if self._state is DriveState.FAULT_REACTION_ACTIVE:
            return
        command = _decode_command(cw)
        if command is None:
            return
        nxt = _TRANSITIONS.get((self._state, command))
        if nxt is None:
            return
        state, _number = nxt
        if (
            self._state is DriveState.QUICK_STOP_ACTIVE
            and state is DriveState.OPERATION_ENABLED
            and self._params["quick_stop_option"] <= 4
        ):
            return
        if state is DriveState.QUICK_STOP_ACTIVE:
            self._demand = self._position
            self._quick_stop_done = False
        if state is DriveState.OPERATION_ENABLED:
            self._fe_time_us = 0
        self._state = state

    def _step_plant(self, dt: float) -> None:
        state = self._state
        self._limited = False
        if state is DriveState.OPERATION_ENABLED:
            self._demand = float(self._target)
            feed_forward = self._feed_forward
        elif state in (DriveState.QUICK_STOP_ACTIVE, DriveState.FAULT_REACTION_ACTIVE):
            feed_forward = 0.0  # demand frozen where the stop began
        else:
            self._demand = self._position
            self._velocity = 0.0
            return
        tau = self._params["lag_time_constant_us"] * 1e-6
        ahead = feed_forward * dt
        step = ahead + (self._demand - self._position - ahead) * (1.0 - math.exp(-dt / tau))
        limit = self._params["max_velocity"] * dt
        if abs(step) > limit:
            step = math.copysign(limit, step)
            self._limited = True
        self._position += step
        self._velocity = step / dt
        if state is DriveState.QUICK_STOP_ACTIVE and abs(self._demand - self._position) < 0.5:
            self._quick_stop_done = True

    def _monitor(self, cycle_us: int) -> None:
        window = self._params["following_error_window"]
        if self._state is DriveState.OPERATION_ENABLED and window != FE_WINDOW_OFF:
            if abs(self._demand - self._position) > window:
                self._fe_time_us += cycle_us
                if self._fe_time_us > self._params["following_error_timeout_ms"] * 1000:
                    self._fault(ERROR_FOLLOWING)
            else:
                self._fe_time_us = 0
        watchdog_us = self._params["watchdog_ms"] * 1000
        if self._watchdog_armed and watchdog_us > 0 and self._watchdog_us > watchdog_us:
            self._fault(ERROR_WATCHDOG)

    def _statusword(self) -> int:
        sw = self._state.value
        if self._state is DriveState.OPERATION_ENABLED:
            sw |= 1 << 12
            if (
                self._params["following_error_window"] != FE_WINDOW_OFF
                and abs(self._demand - self._position) > self._params["following_error_window"]
            ):
                sw |= 1 << 13
        if self._limited:
            sw |= 1 << 11
        return sw

    def _value(self, name: str) -> float:
        """Current value of a register entry by name."""
        if name in self._params:
            return self._params[name]
        if name in _IDENTIFICATION:
            return _IDENTIFICATION[name]
        values: dict[str, Callable[[], float]] = {
            "target_position": lambda: self._target,
            "velocity_feed_forward": lambda: self._feed_forward,
            "controlword": lambda: self._controlword,
            "mode_of_operation": lambda: self._mode,
            "life_sign": lambda: self._life_sign,
            "boot_count": lambda: self._boot_count,
            "fault_count": lambda: self._fault_count,
            "position_actual": lambda: _wrap_i32(self._position),
            "velocity_actual": lambda: self._velocity,
            "statusword": self._statusword,
            "mode_display": lambda: self._mode,
            "following_error": lambda: _wrap_i32(self._demand - self._position),
            "error_code": lambda: self._error_code,
            "life_sign_echo": lambda: self._life_sign,
        }
        return values[name]()

    def _store(self, name: str, value: float) -> None:
        if name in self._params:
            self._params[name] = value
        elif name == "target_position":
            self._target = int(value)
        elif name == "velocity_feed_forward":
            self._feed_forward = float(value)
        elif name == "mode_of_operation":
            self._mode = int(value)
        elif name == "life_sign":
            self._life_sign = int(value)
        else:  # pragma: no cover - the table and this code disagree
            raise AssertionError(name)

    # ------------------------------------------------------------------ protocol
    def _read(self, pdu: bytes, table: dict[int, tuple[_Reg, int]], areas: tuple) -> bytes:
        if len(pdu) != 5:
            raise _ModbusError(ILLEGAL_DATA_VALUE)
        start, count = struct.unpack(">HH", pdu[1:5])
        if not 1 <= count <= MAX_READ:
            raise _ModbusError(ILLEGAL_DATA_VALUE)
        if start + count > 0x10000:
            raise _ModbusError(ILLEGAL_DATA_ADDRESS)
        words = []
        cache: dict[str, tuple[int, ...]] = {}
        for address in range(start, start + count):
            if not _in_areas(address, areas):
                raise _ModbusError(ILLEGAL_DATA_ADDRESS)
            entry = table.get(address)
            if entry is None:
                words.append(0)
                continue
            reg, i = entry
            if reg.name not in cache:
                cache[reg.name] = _encode(self._value(reg.name), reg.type)
            words.append(cache[reg.name][i])
        return bytes([pdu[0], 2 * count]) + struct.pack(f">{count}H", *words)

    def _write(self, start: int, words: tuple[int, ...]) -> None:
        """Check, then store a write to the holding table; run a cycle if the controlword is in."""
        end = start + len(words)
        if end > 0x10000:
            raise _ModbusError(ILLEGAL_DATA_ADDRESS)
        touched: dict[str, _Reg] = {}
        for address in range(start, end):
            entry = _HOLDING.get(address)
            if entry is None:
                raise _ModbusError(ILLEGAL_DATA_ADDRESS)
            reg, _ = entry
            if reg.address < start or reg.address + reg.size > end:
                raise _ModbusError(ILLEGAL_DATA_ADDRESS)  # one half of a 32-bit value
            touched[reg.name] = reg
        new: dict[str, float] = {}
        for name, reg in touched.items():
            if not reg.writable:
                raise _ModbusError(SERVER_DEVICE_FAILURE)
            off = reg.address - start
            value = _decode(words[off : off + reg.size], reg.type)
            if not reg.valid(value):
                raise _ModbusError(SERVER_DEVICE_FAILURE)
            new[name] = value
        controlword = new.pop("controlword", None)
        for name, value in new.items():
            self._store(name, value)
        if controlword is not None:
            self._cycle(int(controlword))

    def _handle_pdu(self, pdu: bytes) -> bytes:
        """The response PDU to a request PDU (our unit id)."""
        fc = pdu[0]
        try:
            if fc == 0x03:
                return self._read(pdu, _HOLDING, _HOLDING_AREAS)
            if fc == 0x04:
                return self._read(pdu, _INPUT, _INPUT_AREAS)
            if fc == 0x06:
                if len(pdu) != 5:
                    raise _ModbusError(ILLEGAL_DATA_VALUE)
                address, value = struct.unpack(">HH", pdu[1:5])
                self._write(address, (value,))
                return pdu
            if fc == 0x10:
                if len(pdu) < 6:
                    raise _ModbusError(ILLEGAL_DATA_VALUE)
                start, count, nbytes = struct.unpack(">HHB", pdu[1:6])
                if not 1 <= count <= MAX_WRITE or nbytes != 2 * count or len(pdu) != 6 + nbytes:
                    raise _ModbusError(ILLEGAL_DATA_VALUE)
                self._write(start, struct.unpack(f">{count}H", pdu[6:]))
                return pdu[:5]
            raise _ModbusError(ILLEGAL_FUNCTION)
        except _ModbusError as exc:
            return bytes([(fc | 0x80) & 0xFF, exc.code])

    def _handle_frame(self, frame: bytes) -> bytes | None:
        """The response ADU to one request ADU, or None for no answer."""
        tid, proto, _length, unit = struct.unpack(">HHHB", frame[:7])
        pdu = frame[7:]
        if proto != 0:
            return None
        with self._lock:
            self._requests[pdu[0]] += 1
            if self._stall > 0:
                self._stall -= 1
                return None
            if unit != self._unit_id:
                if self._foreign_unit == "ignore":
                    return None
                answer = bytes([(pdu[0] | 0x80) & 0xFF, GATEWAY_TARGET_FAILED])
            else:
                answer = self._handle_pdu(pdu)
        return struct.pack(">HHHB", tid, 0, len(answer) + 1, unit) + answer

    # ------------------------------------------------------------------ server thread
    def start(self) -> ModbusServo:
        """Bind, listen and start the server thread; returns once clients can connect."""
        if self._thread is not None:
            raise RuntimeError("ModbusServo already started")
        listener = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
        listener.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        listener.bind((self._host, self._requested_port))
        listener.listen(16)
        listener.setblocking(False)
        self._listener = listener
        self._port = listener.getsockname()[1]
        self._wake_r, self._wake_w = socket.socketpair()
        self._wake_r.setblocking(False)
        self._selector = selectors.DefaultSelector()
        self._selector.register(listener, selectors.EVENT_READ, "listen")
        self._selector.register(self._wake_r, selectors.EVENT_READ, "wake")
        self._stopping = False
        self._thread = threading.Thread(target=self._serve, name="ModbusServo", daemon=True)
        self._thread.start()
        return self

    def stop(self) -> None:
        """Close every connection and the listener, and end the thread."""
        thread = self._thread
        if thread is None:
            return
        self._stopping = True
        self._wake()
        thread.join(5.0)
        self._thread = None

    def __enter__(self) -> ModbusServo:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.stop()

    @property
    def port(self) -> int:
        """The TCP port the server listens on (after ``start``)."""
        if self._port is None:
            raise RuntimeError("ModbusServo not started")
        return self._port

    @property
    def unit_id(self) -> int:
        return self._unit_id

    def _wake(self) -> None:
        if self._wake_w is not None:
            try:
                self._wake_w.send(b"x")
            except OSError:
                pass

    def _run_job(self, job: str) -> None:
        """Have the server thread do ``job`` and wait for it (or do it at once when stopped)."""
        if self._thread is None or threading.current_thread() is self._thread:
            if job == "drop":
                self._close_all()
            return
        done = threading.Event()
        with self._lock:
            self._jobs.append((job, done))
        self._wake()
        done.wait(5.0)

    def _close_all(self) -> None:
        for conn in list(self._conns):
            self._close(conn)

    def _close(self, conn: socket.socket) -> None:
        self._conns.pop(conn, None)
        if self._selector is not None:
            try:
                self._selector.unregister(conn)
            except (KeyError, ValueError):
                pass
        try:
            conn.close()
        except OSError:
            pass

    def _serve(self) -> None:
        sel = self._selector
        assert sel is not None
        try:
            while not self._stopping:
                for key, _mask in sel.select(timeout=0.5):
                    if key.data == "listen":
                        self._accept()
                    elif key.data == "wake":
                        self._drain_wake()
                    else:
                        self._receive(key.fileobj)  # type: ignore[arg-type]
        finally:
            self._close_all()
            for s in (self._listener, self._wake_r, self._wake_w):
                if s is not None:
                    s.close()
            sel.close()
            with self._lock:
                jobs, self._jobs = self._jobs, []
            for _job, done in jobs:
                done.set()

    def _drain_wake(self) -> None:
        assert self._wake_r is not None
        try:
            while self._wake_r.recv(256):
                pass
        except BlockingIOError:
            pass
        with self._lock:
            jobs, self._jobs = self._jobs, []
        for job, done in jobs:
            if job == "drop":
                self._close_all()
            done.set()

    def _accept(self) -> None:
        assert self._listener is not None and self._selector is not None
        try:
            conn, _addr = self._listener.accept()
        except (BlockingIOError, OSError):
            return
        if len(self._conns) >= self._max_connections:
            conn.close()
            return
        conn.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        conn.settimeout(2.0)
        self._conns[conn] = bytearray()
        self._selector.register(conn, selectors.EVENT_READ, "conn")

    def _receive(self, conn: socket.socket) -> None:
        try:
            data = conn.recv(4096)
        except OSError:
            data = b""
        if not data:
            self._close(conn)
            return
        buf = self._conns[conn]
        buf += data
        while len(buf) >= 6:
            length = struct.unpack(">H", buf[4:6])[0]
            if not 2 <= length <= 254:
                self._close(conn)  # cannot resynchronise the stream
                return
            if len(buf) < 6 + length:
                break
            frame = bytes(buf[: 6 + length])
            del buf[: 6 + length]
            answer = self._handle_frame(frame)
            if answer is not None:
                try:
                    conn.sendall(answer)
                except OSError:
                    self._close(conn)
                    return

    # ------------------------------------------------------------------ test API
    def inject_fault(self, code: int) -> None:
        """Raise a drive fault with error code ``code`` (1..0xFFFF): FAULT REACTION ACTIVE now,
        FAULT at the next cycle. Ignored while a fault is pending (the first fault wins)."""
        if isinstance(code, bool) or not isinstance(code, int) or not 1 <= code <= 0xFFFF:
            raise ValueError(f"fault code must be an integer in 1..0xFFFF, got {code!r}")
        with self._lock:
            self._fault(code)

    def drop_connections(self) -> None:
        """Close every client connection (the listener stays open); returns when they are closed."""
        self._run_job("drop")

    def stall(self, n_requests: int) -> None:
        """Discard the next ``n_requests`` requests unprocessed, without an answer."""
        if isinstance(n_requests, bool) or not isinstance(n_requests, int) or n_requests < 0:
            raise ValueError(f"n_requests must be an integer >= 0, got {n_requests!r}")
        with self._lock:
            self._stall = n_requests

    def reboot(self) -> None:
        """Power cycle: factory parameters, SWITCH ON DISABLED, registers cleared, boot counter
        + 1, pending stalls cancelled, connections dropped. The position is kept."""
        with self._lock:
            self._power_up()
            self._stall = 0
        self.drop_connections()

    def advance(self, seconds: float) -> int:
        """Let ``seconds`` of time pass without a controlword write, in whole cycles (rounded
        down); returns the number of cycles run."""
        if not isinstance(seconds, int | float) or not math.isfinite(seconds) or seconds < 0:
            raise ValueError(f"seconds must be a finite number >= 0, got {seconds!r}")
        with self._lock:
            n = int(seconds * 1e6 / self._params["cycle_time_us"] + 1e-9)
            for _ in range(n):
                self._cycle(None)
        return n

    @property
    def state(self) -> DriveState:
        with self._lock:
            return self._state

    @property
    def statusword(self) -> int:
        with self._lock:
            return self._statusword()

    @property
    def position(self) -> float:
        """Actual position [counts] (the register shows it rounded)."""
        with self._lock:
            return self._position

    @property
    def velocity(self) -> float:
        with self._lock:
            return self._velocity

    @property
    def target_position(self) -> int:
        with self._lock:
            return self._target

    @property
    def controlword(self) -> int:
        with self._lock:
            return self._controlword

    @property
    def error_code(self) -> int:
        with self._lock:
            return self._error_code

    @property
    def time(self) -> float:
        """The drive's time [s] since power-up (cycles and ``advance``)."""
        with self._lock:
            return self._time_us * 1e-6

    @property
    def parameters(self) -> dict[str, float]:
        """Current parameters by name (register units, see ``FACTORY``); a copy."""
        with self._lock:
            return dict(self._params)

    @property
    def requests_by_function(self) -> Counter[int]:
        """Function codes of the frames received so far; a copy."""
        with self._lock:
            return Counter(self._requests)

    @property
    def connection_count(self) -> int:
        return len(self._conns)

    def __repr__(self) -> str:
        return f"ModbusServo(port={self._port}, unit_id={self._unit_id}, state={self._state.name})"
