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

from enum import Enum, IntEnum

__all__ = [
    "CONTROLWORD_VALUE",
    "DEVICE_TRANSITIONS",
    "MASTER_TABLE",
    "STATUSWORD_PATTERNS",
    "Cia402Command",
    "Cia402State",
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


def decode_statusword(statusword: int) -> Cia402State:
    """Power state encoded in a statusword (0x6041); UNKNOWN if no pattern matches."""
    for mask, value, state in STATUSWORD_PATTERNS:
        if statusword & mask == value:
            return state
    return Cia402State.UNKNOWN


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
    if target not in _TARGETS:
        raise ValueError(f"target must be one of {[s.name for s in _TARGETS]}, got {target.name}")
    if state is Cia402State.FAULT and fault_reset:
        return 0x80 if previous_controlword in (0x00, 0x06) else 0x00
    return MASTER_TABLE[(state, target)][0]
