"""CiA 402 power state machine: states, controlword/statusword codecs and transition tables.

Pure functions and tables, no I/O, never blocking. Both ends use them:

* the master (``canopen_drive``, ``modbus_drive``): :func:`decode_statusword` and
  :func:`next_controlword` pick one controlword per cycle to walk the drive towards a target
  state (one step per cycle, never a blocking loop);
* the virtual drives (``virtual_cia402``, ``virtual_modbus``): :func:`decode_command` and
  :func:`device_transition` implement the device side, :func:`statusword_bits` encodes the state.

Transition numbers in the comments and tables are those of CiA 402 (IEC 61800-7-201) figure
"state machine": 0/1 automatic power-up, 2..12 and 16 commanded, 13 fault, 14 fault reaction
done, 15 fault reset. Masks are those of CiA 402 (and ``canopen.profiles.p402.State402``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from enum import Enum, IntEnum

__all__ = [
    "CONTROLWORD_OE_HOLD",
    "CONTROLWORD_VALUE",
    "DEVICE_TRANSITIONS",
    "HOMING_METHODS",
    "MASTER_TABLE",
    "STATE_OF_BITS",
    "STATUSWORD_PATTERNS",
    "Cia402Command",
    "Cia402State",
    "HomingProcedure",
    "HomingSpec",
    "HomingSwitches",
    "OperationMode",
    "decode_command",
    "decode_statusword",
    "device_transition",
    "next_controlword",
    "statusword_bits",
]


class Cia402State(Enum):
    """CiA 402 power states (plus UNKNOWN for a statusword that matches no pattern)."""

    NOT_READY_TO_SWITCH_ON = "NOT READY TO SWITCH ON"
    SWITCH_ON_DISABLED = "SWITCH ON DISABLED"
    READY_TO_SWITCH_ON = "READY TO SWITCH ON"
    SWITCHED_ON = "SWITCHED ON"
    OPERATION_ENABLED = "OPERATION ENABLED"
    QUICK_STOP_ACTIVE = "QUICK STOP ACTIVE"
    FAULT_REACTION_ACTIVE = "FAULT REACTION ACTIVE"
    FAULT = "FAULT"
    UNKNOWN = "UNKNOWN"


class Cia402Command(Enum):
    """Device-side meaning of a controlword (bits 7, 3, 2, 1, 0)."""

    SHUTDOWN = "shutdown"
    SWITCH_ON = "switch on"
    ENABLE_OPERATION = "enable operation"  # also "switch on + enable operation" from RTSO
    DISABLE_VOLTAGE = "disable voltage"
    QUICK_STOP = "quick stop"
    FAULT_RESET = "fault reset"  # bit 7 rising edge
    NONE = "none"  # bit 7 held high, or no defined command


class OperationMode(IntEnum):
    """0x6060 / 0x6061 modes of operation."""

    PROFILE_POSITION = 1
    PROFILE_VELOCITY = 3
    PROFILE_TORQUE = 4
    HOMING = 6
    INTERPOLATED_POSITION = 7
    CYCLIC_SYNCHRONOUS_POSITION = 8
    CYCLIC_SYNCHRONOUS_VELOCITY = 9
    CYCLIC_SYNCHRONOUS_TORQUE = 10


# 0x6502 bit per mode (CiA 402): bit 0 PP, 2 PV, 3 PT, 5 HM, 6 IP, 7 CSP, 8 CSV, 9 CST.
SUPPORTED_MODE_BIT: dict[OperationMode, int] = {
    OperationMode.PROFILE_POSITION: 0,
    OperationMode.PROFILE_VELOCITY: 2,
    OperationMode.PROFILE_TORQUE: 3,
    OperationMode.HOMING: 5,
    OperationMode.INTERPOLATED_POSITION: 6,
    OperationMode.CYCLIC_SYNCHRONOUS_POSITION: 7,
    OperationMode.CYCLIC_SYNCHRONOUS_VELOCITY: 8,
    OperationMode.CYCLIC_SYNCHRONOUS_TORQUE: 9,
}

# Controlword bits
CW_SWITCH_ON = 0x0001
CW_ENABLE_VOLTAGE = 0x0002
CW_QUICK_STOP = 0x0004  # active low
CW_ENABLE_OPERATION = 0x0008
CW_FAULT_RESET = 0x0080
CW_HALT = 0x0100

# Statusword bits
SW_READY_TO_SWITCH_ON = 0x0001
SW_SWITCHED_ON = 0x0002
SW_OPERATION_ENABLED = 0x0004
SW_FAULT = 0x0008
SW_VOLTAGE_ENABLED = 0x0010
SW_QUICK_STOP = 0x0020  # active low
SW_SWITCH_ON_DISABLED = 0x0040
SW_WARNING = 0x0080
SW_REMOTE = 0x0200
SW_TARGET_REACHED = 0x0400
SW_INTERNAL_LIMIT = 0x0800
SW_DRIVE_FOLLOWS = 0x1000  # CSP/CSV/CST: drive follows the command value
SW_FOLLOWING_ERROR = 0x2000  # CSP/PP: following error

# (mask, value, state): decode order does not matter, the patterns are disjoint.
STATUSWORD_PATTERNS: tuple[tuple[int, int, Cia402State], ...] = (
    (0x4F, 0x00, Cia402State.NOT_READY_TO_SWITCH_ON),
    (0x4F, 0x40, Cia402State.SWITCH_ON_DISABLED),
    (0x6F, 0x21, Cia402State.READY_TO_SWITCH_ON),
    (0x6F, 0x23, Cia402State.SWITCHED_ON),
    (0x6F, 0x27, Cia402State.OPERATION_ENABLED),
    (0x6F, 0x07, Cia402State.QUICK_STOP_ACTIVE),
    (0x4F, 0x0F, Cia402State.FAULT_REACTION_ACTIVE),
    (0x4F, 0x08, Cia402State.FAULT),
)

# The state bits (0..6) a device reports in each state; bit 4 (voltage enabled) is set by the
# device when its DC link is up, bits 7, 9..15 are added by the device.
_STATE_BITS: dict[Cia402State, int] = {
    Cia402State.NOT_READY_TO_SWITCH_ON: 0x00,
    Cia402State.SWITCH_ON_DISABLED: 0x40,
    Cia402State.READY_TO_SWITCH_ON: 0x21,
    Cia402State.SWITCHED_ON: 0x23,
    Cia402State.OPERATION_ENABLED: 0x27,
    Cia402State.QUICK_STOP_ACTIVE: 0x07,
    Cia402State.FAULT_REACTION_ACTIVE: 0x0F,
    Cia402State.FAULT: 0x08,
    Cia402State.UNKNOWN: 0x00,
}


def _decode_state_bits(statusword: int) -> Cia402State:
    for mask, value, state in STATUSWORD_PATTERNS:
        if statusword & mask == value:
            return state
    return Cia402State.UNKNOWN


# every mask lies within 0x6F: the state of each value of bits 0..6 (per cycle: one index)
STATE_OF_BITS: tuple[Cia402State, ...] = tuple(_decode_state_bits(bits) for bits in range(0x80))
_DECODED = STATE_OF_BITS
assert all(mask & ~0x6F == 0 for mask, _, _ in STATUSWORD_PATTERNS)


def decode_statusword(statusword: int) -> Cia402State:
    """Power state encoded in a statusword (0x6041); UNKNOWN if no pattern matches
    (``STATE_OF_BITS[statusword & 0x6F]``)."""
    return _DECODED[statusword & 0x6F]


def statusword_bits(state: Cia402State) -> int:
    """The state bits (0x6F part) of a statusword for ``state`` (device side)."""
    return _STATE_BITS[state]


def decode_command(controlword: int, previous_controlword: int) -> Cia402Command:
    """Device-side decode of a controlword with the CiA 402 masks.

    Fault reset acts on the rising edge of bit 7 only; while bit 7 stays high no command is
    decoded (a held 0x80 must not re-trigger the reset).
    """
    if controlword & CW_FAULT_RESET:
        if not previous_controlword & CW_FAULT_RESET:
            return Cia402Command.FAULT_RESET
        return Cia402Command.NONE
    if controlword & 0x82 == 0x00:
        return Cia402Command.DISABLE_VOLTAGE
    if controlword & 0x86 == 0x02:
        return Cia402Command.QUICK_STOP
    if controlword & 0x87 == 0x06:
        return Cia402Command.SHUTDOWN
    if controlword & 0x8F == 0x07:
        return Cia402Command.SWITCH_ON
    # the masks above leave exactly cw & 0x8F == 0x0F
    return Cia402Command.ENABLE_OPERATION


_S = Cia402State
_C = Cia402Command

# Device side: (state, command) -> (next state, transition number). Pairs not listed leave
# the state unchanged (an illegal command is ignored). QUICK STOP ACTIVE -> OPERATION ENABLED
# (16) is allowed only for quick-stop option codes 5..8, see device_transition().
DEVICE_TRANSITIONS: dict[tuple[Cia402State, Cia402Command], tuple[Cia402State, int]] = {
    (_S.SWITCH_ON_DISABLED, _C.SHUTDOWN): (_S.READY_TO_SWITCH_ON, 2),
    (_S.READY_TO_SWITCH_ON, _C.SWITCH_ON): (_S.SWITCHED_ON, 3),
    # 3 + 4 in one step: many drives accept 0x0F in READY TO SWITCH ON
    (_S.READY_TO_SWITCH_ON, _C.ENABLE_OPERATION): (_S.OPERATION_ENABLED, 4),
    (_S.SWITCHED_ON, _C.ENABLE_OPERATION): (_S.OPERATION_ENABLED, 4),
    (_S.OPERATION_ENABLED, _C.SWITCH_ON): (_S.SWITCHED_ON, 5),  # disable operation
    (_S.SWITCHED_ON, _C.SHUTDOWN): (_S.READY_TO_SWITCH_ON, 6),
    (_S.READY_TO_SWITCH_ON, _C.DISABLE_VOLTAGE): (_S.SWITCH_ON_DISABLED, 7),
    (_S.READY_TO_SWITCH_ON, _C.QUICK_STOP): (_S.SWITCH_ON_DISABLED, 7),
    (_S.OPERATION_ENABLED, _C.SHUTDOWN): (_S.READY_TO_SWITCH_ON, 8),
    (_S.OPERATION_ENABLED, _C.DISABLE_VOLTAGE): (_S.SWITCH_ON_DISABLED, 9),
    (_S.SWITCHED_ON, _C.DISABLE_VOLTAGE): (_S.SWITCH_ON_DISABLED, 10),
    (_S.SWITCHED_ON, _C.QUICK_STOP): (_S.SWITCH_ON_DISABLED, 10),
    (_S.OPERATION_ENABLED, _C.QUICK_STOP): (_S.QUICK_STOP_ACTIVE, 11),
    (_S.QUICK_STOP_ACTIVE, _C.DISABLE_VOLTAGE): (_S.SWITCH_ON_DISABLED, 12),
    (_S.FAULT, _C.FAULT_RESET): (_S.SWITCH_ON_DISABLED, 15),
    (_S.QUICK_STOP_ACTIVE, _C.ENABLE_OPERATION): (_S.OPERATION_ENABLED, 16),
}


def device_transition(
    state: Cia402State, command: Cia402Command, quick_stop_option: int = 2
) -> tuple[Cia402State, int | None]:
    """Next device state for a decoded command: (state, transition number or None).

    Only commanded transitions are handled here; 0/1 (power-up), 12 after a finished quick
    stop with option 0..4, 13 (fault) and 14 (fault reaction done) are driven by the device.
    """
    hit = DEVICE_TRANSITIONS.get((state, command))
    if hit is None:
        return state, None
    if hit[1] == 16 and not 5 <= quick_stop_option <= 8:
        return state, None
    return hit


# Master side: (current state, target state) -> (controlword, transition number it requests;
# None = hold/wait). Targets are the states a master asks for: SWITCH ON DISABLED,
# READY TO SWITCH ON (MC_Power disabled), SWITCHED ON, OPERATION ENABLED, QUICK STOP ACTIVE.
# FAULT is handled by next_controlword() (edge-generated fault reset).
CONTROLWORD_VALUE: dict[Cia402Command, int] = {
    _C.SHUTDOWN: 0x06,
    _C.SWITCH_ON: 0x07,
    _C.ENABLE_OPERATION: 0x0F,
    _C.DISABLE_VOLTAGE: 0x00,
    _C.QUICK_STOP: 0x02,
    _C.FAULT_RESET: 0x80,
}

_TARGETS = (
    _S.SWITCH_ON_DISABLED,
    _S.READY_TO_SWITCH_ON,
    _S.SWITCHED_ON,
    _S.OPERATION_ENABLED,
    _S.QUICK_STOP_ACTIVE,
)


def _master_table() -> dict[tuple[Cia402State, Cia402State], tuple[int, int | None]]:
    sod, rtso, so, oe, qsa = _TARGETS
    t: dict[tuple[Cia402State, Cia402State], tuple[int, int | None]] = {}
    for target in _TARGETS:
        # states the master cannot leave by a command: wait with "disable voltage"
        t[(_S.NOT_READY_TO_SWITCH_ON, target)] = (0x00, None)  # 1 is automatic
        t[(_S.FAULT_REACTION_ACTIVE, target)] = (0x00, None)  # 14 is automatic
        t[(_S.UNKNOWN, target)] = (0x00, None)
        t[(_S.FAULT, target)] = (0x00, None)  # reset only on request, see next_controlword
        # leaving QUICK STOP ACTIVE: disable voltage (12), then the normal path
        t[(_S.QUICK_STOP_ACTIVE, target)] = (0x00, 12)
    t[(_S.QUICK_STOP_ACTIVE, qsa)] = (0x02, None)
    # -> SWITCH ON DISABLED
    t[(sod, sod)] = (0x00, None)
    t[(rtso, sod)] = (0x00, 7)
    t[(so, sod)] = (0x00, 10)
    t[(oe, sod)] = (0x00, 9)
    # -> READY TO SWITCH ON
    t[(sod, rtso)] = (0x06, 2)
    t[(rtso, rtso)] = (0x06, None)
    t[(so, rtso)] = (0x06, 6)
    t[(oe, rtso)] = (0x06, 8)
    # -> SWITCHED ON
    t[(sod, so)] = (0x06, 2)
    t[(rtso, so)] = (0x07, 3)
    t[(so, so)] = (0x07, None)
    t[(oe, so)] = (0x07, 5)
    # -> OPERATION ENABLED
    t[(sod, oe)] = (0x06, 2)
    t[(rtso, oe)] = (0x07, 3)
    t[(so, oe)] = (0x0F, 4)
    t[(oe, oe)] = (0x0F, None)
    # -> QUICK STOP ACTIVE (only reachable from OPERATION ENABLED; elsewhere 0x02 = 7/10)
    t[(sod, qsa)] = (0x02, None)
    t[(rtso, qsa)] = (0x02, 7)
    t[(so, qsa)] = (0x02, 10)
    t[(oe, qsa)] = (0x02, 11)
    return t


MASTER_TABLE: dict[tuple[Cia402State, Cia402State], tuple[int, int | None]] = _master_table()
TARGET_STATES: tuple[Cia402State, ...] = _TARGETS
_OE = Cia402State.OPERATION_ENABLED
_OE_HOLD = MASTER_TABLE[(_OE, _OE)][0]
# next_controlword(OPERATION_ENABLED, OPERATION_ENABLED, ...): the cyclic steady state
CONTROLWORD_OE_HOLD = _OE_HOLD


def next_controlword(
    state: Cia402State,
    target: Cia402State,
    previous_controlword: int = 0,
    fault_reset: bool = False,
) -> int:
    """One master step: the controlword to send this cycle to move ``state`` towards ``target``.

    In FAULT with ``fault_reset`` the master generates the rising edge of bit 7 the way a real
    master does: first 0x00, then 0x80, then 0x00 again (so that a fault that is still present
    gets a fresh edge two cycles later). Without ``fault_reset`` a faulted drive gets 0x00.
    """
    if state is _OE and target is _OE:
        return _OE_HOLD  # the cyclic steady state (MASTER_TABLE without hashing two enums)
    if target not in _TARGETS:
        raise ValueError(f"target must be one of {[s.name for s in _TARGETS]}, got {target.name}")
    if state is Cia402State.FAULT and fault_reset:
        return 0x80 if previous_controlword in (0x00, 0x06) else 0x00
    return MASTER_TABLE[(state, target)][0]


# ----------------------------------------------------------------------------- homing mode
# CiA 402 homing mode (0x6060 = 6): controlword bit 4 starts the procedure; statusword bit 10
# target reached, bit 12 homing attained, bit 13 homing error.
CW_HOMING_START = 0x0010
SW_HOMING_ATTAINED = 0x1000
SW_HOMING_ERROR = 0x2000

# the methods the virtual drive implements: 17..30 (limit / home switch, no index pulse),
# 33 / 34 (index pulse in the negative / positive direction), 35 and 37 (current position)
HOMING_METHODS: frozenset[int] = frozenset({*range(17, 31), 33, 34, 35, 37})

# methods 19..30: (home-switch edge "lo" / "hi", final approach direction, switch kind):
# kind +1 / -1 = a home switch active on the positive / negative side of the edge (19..22),
# 0 = a home cam [lo, hi] searched first in the direction of the limit switch named by the
# method (23..26 positive, 27..30 negative; reversed at that limit switch)
_SWITCH_METHODS: dict[int, tuple[str, int, int]] = {
    19: ("lo", -1, +1),  # positive home switch, falling edge (left of it, approached moving -)
    20: ("lo", +1, +1),  # positive home switch, rising edge
    21: ("hi", +1, -1),  # negative home switch, falling edge
    22: ("hi", -1, -1),  # negative home switch, rising edge
    23: ("lo", -1, 0),  # home cam with the positive limit switch: left edge, falling
    24: ("lo", +1, 0),  # left edge, rising
    25: ("hi", -1, 0),  # right edge, rising
    26: ("hi", +1, 0),  # right edge, falling
    27: ("hi", +1, 0),  # home cam with the negative limit switch: right edge, falling
    28: ("hi", -1, 0),  # right edge, rising
    29: ("lo", +1, 0),  # left edge, rising
    30: ("lo", -1, 0),  # left edge, falling
}


class HomingSwitches:
    """The virtual switches and encoder index of a drive, in drive increments (physical
    coordinates: they do not move when homing sets the position).

    ``negative_limit`` / ``positive_limit``: the limit switch is active at and beyond that
    position; ``home_switch``: (lo, hi), active for lo <= p <= hi (use -inf / inf for a
    switch active on a whole side: methods 19..22); ``index_pitch``: an index pulse at
    ``index_offset + k * index_pitch`` for every integer k. None = not fitted.
    """

    __slots__ = ("home_switch", "index_offset", "index_pitch", "negative_limit", "positive_limit")

    def __init__(
        self,
        *,
        negative_limit: float | None = None,
        positive_limit: float | None = None,
        home_switch: tuple[float, float] | None = None,
        index_pitch: float | None = None,
        index_offset: float = 0.0,
    ) -> None:
        if home_switch is not None:
            lo, hi = home_switch
            if not lo < hi:
                raise ValueError(f"home_switch (lo, hi) needs lo < hi, got {home_switch!r}")
        if negative_limit is not None and positive_limit is not None:
            if not negative_limit < positive_limit:
                raise ValueError(
                    f"negative_limit {negative_limit} must be below positive_limit {positive_limit}"
                )
        if index_pitch is not None and not index_pitch > 0:
            raise ValueError(f"index_pitch must be > 0, got {index_pitch!r}")
        self.negative_limit = negative_limit
        self.positive_limit = positive_limit
        self.home_switch = home_switch
        self.index_pitch = index_pitch
        self.index_offset = index_offset

    def state(self, kind: str, p: float) -> bool:
        """Level of switch ``kind`` ("nls", "pls", "hs") at position ``p``."""
        if kind == "nls":
            return self.negative_limit is not None and p <= self.negative_limit
        if kind == "pls":
            return self.positive_limit is not None and p >= self.positive_limit
        hs = self.home_switch
        return hs is not None and hs[0] <= p <= hs[1]

    def crossing(self, kind: str, want: bool, p0: float, p1: float) -> float | None:
        """The position where switch ``kind`` takes the level ``want`` moving from ``p0`` to
        ``p1`` (the first such switching point), None if it does not."""
        if p0 == p1:
            return None
        if kind == "index":
            pitch = self.index_pitch
            if pitch is None:
                return None
            off = self.index_offset
            if p1 > p0:
                k = math.floor((p0 - off) / pitch) + 1
                x = off + k * pitch
                return x if x <= p1 else None
            k = math.ceil((p0 - off) / pitch) - 1
            x = off + k * pitch
            return x if x >= p1 else None
        if kind == "nls":
            bounds = [] if self.negative_limit is None else [self.negative_limit]
        elif kind == "pls":
            bounds = [] if self.positive_limit is None else [self.positive_limit]
        else:
            bounds = [] if self.home_switch is None else list(self.home_switch)
        up = p1 > p0
        bounds = sorted(b for b in bounds if math.isfinite(b) and min(p0, p1) <= b <= max(p0, p1))
        if not up:
            bounds.reverse()
        level = self.state(kind, p0)
        for b in bounds:
            if b == p0:
                continue
            # the level just past b in the direction of motion
            eps = 1e-9 * (1.0 + abs(b))
            after = self.state(kind, b + eps if up else b - eps)
            if after != level:
                level = after
                if after == want:
                    return b
        return None


class HomingProcedure:
    """One run of a CiA 402 homing method on the device side (no I/O, no clock).

    The device calls :meth:`next_demand` before each cycle's plant step (the demand position
    at the end of the cycle: a velocity ramp with ``acceleration`` towards the phase's speed)
    and :meth:`observe` after it with the positions the motor went through (physical
    coordinates). The phases of a method: the searches of the method figure (fast
    ``speed_switch`` towards the switch, ``speed_zero`` on the final approach), then, once the
    final approach crosses the home edge (an edge found in the motor's sampled motion), a
    stop and a move back to the edge at ``speed_zero``. ``done`` with ``edge`` (the home
    position, physical) when the motor rests there; ``error`` (text) when a switch the method
    needs is not fitted or a limit switch is hit where the method does not expect one.
    """

    def __init__(
        self,
        method: int,
        switches: HomingSwitches,
        speed_switch: float,
        speed_zero: float,
        acceleration: float,
        demand: float,
        position: float,
    ) -> None:
        self.method = method
        self.sw = switches
        self.fast = float(speed_switch)
        self.slow = float(speed_zero)
        self.acc = float(acceleration)
        self.demand = float(demand)
        self.velocity = 0.0  # of the demand
        self.edge: float | None = None
        self.done = False
        self.error = ""
        self.reversed = False
        self.interrupted = False
        # phases: ("move", direction, speed, switch, level, final) or ("find", direction)
        self.phases: list[tuple] = []
        self.phase: tuple | None = None
        if method not in HOMING_METHODS:
            self._fail(f"homing method {method} is not supported")
            return
        if not (speed_switch > 0 and speed_zero > 0 and acceleration > 0):
            self._fail("homing speeds and acceleration must be > 0")
            return
        self._plan(position)
        self._next_phase()

    def _fail(self, text: str) -> None:
        self.error = text
        self.phase = ("brake",)

    def interrupt(self) -> None:
        """Controlword bit 4 fell (or halt): brake to rest, then the procedure ends (not
        attained, no error)."""
        self.interrupted = True
        self.phases = []
        self.edge = None
        self.phase = ("brake",)

    def _plan(self, p: float) -> None:
        m = self.method
        sw = self.sw
        add = self.phases.append
        if m in (35, 37):
            self.edge = p
            self.phases = [("settle",)]
            return
        if m in (33, 34):
            if sw.index_pitch is None:
                self._fail(f"homing method {m} needs the encoder index pulse (index_pitch)")
                return
            add(("move", -1 if m == 33 else +1, self.slow, "index", True, True))
            return
        if m in (17, 18):
            kind = "nls" if m == 17 else "pls"
            if (sw.negative_limit if m == 17 else sw.positive_limit) is None:
                self._fail(
                    f"homing method {m} needs the {'negative' if m == 17 else 'positive'}"
                    " limit switch"
                )
                return
            r = -1 if m == 17 else +1
            if not sw.state(kind, p):
                add(("move", r, self.fast, kind, True, False))
            add(("move", -r, self.slow, kind, False, True))
            return
        edge, d_final, region = _SWITCH_METHODS[m]
        if sw.home_switch is None:
            self._fail(f"homing method {m} needs the home switch")
            return
        exit_ = (edge == "lo" and d_final < 0) or (edge == "hi" and d_final > 0)
        active = sw.state("hs", p)
        if region != 0:  # a switch active on one side (19..22)
            if exit_:
                if not active:
                    add(("move", region, self.fast, "hs", True, False))
                add(("move", d_final, self.slow, "hs", False, True))
            else:
                if active:
                    add(("move", -d_final, self.fast, "hs", False, False))
                add(("move", d_final, self.slow, "hs", True, True))
            return
        start = +1 if m <= 26 else -1
        if start > 0 and sw.positive_limit is None or start < 0 and sw.negative_limit is None:
            side = "positive" if start > 0 else "negative"
            self._fail(f"homing method {m} needs the {side} limit switch")
            return
        if not active:
            add(("find", start))
        if exit_:
            add(("move", d_final, self.slow, "hs", False, True))
        else:
            add(("move", -d_final, self.fast, "hs", False, False))
            add(("move", d_final, self.slow, "hs", True, True))

    def _next_phase(self) -> None:
        if self.error:
            return
        if self.phases:
            self.phase = self.phases.pop(0)
        elif self.edge is not None:
            self.phase = ("return",)

    def _target_velocity(self) -> float:
        ph = self.phase
        if ph is None:
            return 0.0
        kind = ph[0]
        if kind == "move":
            return ph[1] * ph[2]
        if kind == "find":
            return ph[1] * self.fast
        if kind == "return":
            assert self.edge is not None
            dist = self.edge - self.demand
            v = min(self.slow, math.sqrt(2.0 * self.acc * abs(dist)))
            return math.copysign(v, dist)
        return 0.0  # brake, settle

    def next_demand(self, dt: float) -> float:
        """The demand position at the end of the next cycle of length ``dt``."""
        if self.done:
            return self.demand
        vt = self._target_velocity()
        dv = self.acc * dt
        v0 = self.velocity
        v1 = vt if abs(vt - v0) <= dv else v0 + math.copysign(dv, vt - v0)
        d = self.demand + 0.5 * (v0 + v1) * dt
        ph = self.phase
        if ph is not None and ph[0] == "return":
            assert self.edge is not None
            if (self.edge - d) * (self.edge - self.demand) <= 0.0 or abs(self.edge - d) < 1e-6:
                d, v1 = self.edge, 0.0  # arrived
                self.phase = ("settle",)
        self.demand = d
        self.velocity = v1
        if ph is not None and ph[0] == "brake" and v1 == 0.0:
            if self.error or self.interrupted:
                self.phase = None
            else:
                self._next_phase()
        return d

    def observe(self, samples: list[float], velocity: float) -> None:
        """The positions the motor went through in the cycle (first: at its start) and its
        velocity at the end: switch edges, limit switches, arrival at the home position."""
        ph = self.phase
        if ph is None or self.done:
            return
        kind = ph[0]
        p1 = samples[-1]
        if kind in ("move", "find"):
            d = ph[1]
            for i in range(len(samples) - 1):
                a, b = samples[i], samples[i + 1]
                # a limit switch in the direction of motion that the phase does not look for
                lim = "pls" if d > 0 else "nls"
                hit_limit = self.sw.crossing(lim, True, a, b) is not None or (
                    self.sw.state(lim, b) and (b - a) * d > 0
                )
                if kind == "find":
                    if self.sw.crossing("hs", True, a, b) is not None:
                        self._next_phase()
                        return
                    if hit_limit:
                        if self.reversed:
                            self._fail("home switch not found between the limit switches")
                            return
                        self.reversed = True
                        self.phase = ("find", -d)
                        return
                    continue
                _, _, _, switch, level, final = ph
                x = self.sw.crossing(switch, level, a, b)
                if x is not None:
                    if final:
                        self.edge = x
                        self.phases = []
                        self.phase = ("brake",)
                    else:
                        self._next_phase()
                    return
                if hit_limit and switch not in ("nls", "pls"):
                    self._fail(
                        f"{'positive' if d > 0 else 'negative'} limit switch reached while "
                        f"searching ({'home switch' if switch == 'hs' else 'index pulse'} "
                        "not found)"
                    )
                    return
        elif kind == "settle":
            assert self.edge is not None
            if abs(p1 - self.edge) <= 1.0 and abs(velocity) <= 1000.0:
                self.done = True


def _finite(name: str, value: object, lo: float, hi: float, lo_open: bool = False) -> float:
    ok = isinstance(value, (int, float)) and not isinstance(value, bool)
    x = float(value) if ok else math.nan  # type: ignore[arg-type]
    if not (math.isfinite(x) and (x > lo if lo_open else x >= lo) and x <= hi):
        rng = f"{'(' if lo_open else '['}{lo:g}, {hi:g}]"
        raise ValueError(f"homing.{name} must be a finite number in {rng}, got {value!r}")
    return x


@dataclass(frozen=True, slots=True)
class HomingSpec:
    """Homing by the drive (CiA 402 homing mode) of one axis, SI units (m or rad).

    ``method`` goes to 0x6098 (the CiA 402 methods 1..37, or a manufacturer's negative one;
    motionplc's virtual drive implements :data:`HOMING_METHODS`), ``speed_switch`` /
    ``speed_zero`` [m/s] to 0x6099:01 / :02, ``acceleration`` [m/s²] to 0x609A, ``offset``
    [m] to 0x607C: the axis position at the home position afterwards. ``timeout`` [s]: the
    procedure must be attained within it (else HOMING_FAILED).
    """

    method: int
    speed_switch: float
    speed_zero: float
    acceleration: float
    offset: float = 0.0
    timeout: float = 60.0

    def __post_init__(self) -> None:
        m = self.method
        if isinstance(m, bool) or not isinstance(m, int) or not -128 <= m <= 127 or m == 0:
            raise ValueError(
                f"homing.method must be a CiA 402 homing method (1..37, or a manufacturer's "
                f"-128..-1), got {m!r}"
            )
        _finite("speed_switch", self.speed_switch, 0.0, 1e9, lo_open=True)
        _finite("speed_zero", self.speed_zero, 0.0, 1e9, lo_open=True)
        _finite("acceleration", self.acceleration, 0.0, 1e12, lo_open=True)
        _finite("offset", self.offset, -1e12, 1e12)
        _finite("timeout", self.timeout, 0.0, 3600.0, lo_open=True)
