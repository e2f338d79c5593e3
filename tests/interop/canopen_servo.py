"""An independent CiA 301 / CiA 402 servo on raw CAN frames — a drive this project did not write.

``CanopenServo`` plays a third-party drive vendor's firmware on one ``can.BusABC`` (python-can's
``virtual`` interface in the tests). It is written from the standards (CiA 301 communication, CiA
402 drive profile, CiA 306 EDS) and from this docstring only; it imports nothing of
``motionplc`` and does not use the ``canopen`` library. Masters under test must find everything
they need in the standards, in the EDS the servo writes (``write_eds``) and in this text.

Objects (``write_eds`` lists exactly the objects of an instance; access in brackets)
--------------------------------------------------------------------------------------
Communication area (restored by NMT reset communication, reset node and ``reboot``)::

    0x1000      device type U32 [const] 0x00020192 (CiA 402, servo)
    0x1001      error register U8 [ro]: bit 0 generic, 1 current, 2 voltage, 3 temperature,
                4 communication (0x81xx/0x82xx), 5 profile (other 0x8xxx), 7 manufacturer (0xFFxx)
    0x1003      pre-defined error field ARRAY: sub 0 U8 [rw] number of errors (write 0 clears,
                anything else aborts 0x06090030), subs 1..8 U32 [ro], newest at sub 1
    0x1005      COB-ID SYNC U32 [rw], factory 0x80 (bit 30 "generate" and bit 29 are refused)
    0x1006      communication cycle period U32 [rw] in µs, factory 0; 0 or 100..1_000_000
                (absent with quirk has_1006=False)
    0x1008/9/A  device name, hardware and software version VISIBLE_STRING [const]
    0x100C      guard time U16 [rw] ms, 0x100D life time factor U8 [rw]
    0x1014      COB-ID EMCY U32 [ro] 0x80 + node
    0x1016      consumer heartbeat time ARRAY, subs 1..4 U32 [rw] (node << 16 | ms); two
                non-zero entries for one node abort 0x06040043
    0x1017      producer heartbeat time U16 [rw] ms, factory 0 (absent with heartbeat=False)
    0x1018      identity RECORD: 1 vendor-ID, 2 product code, 3 revision, 4 serial number [ro]
    0x1400+k    RPDO k+1 communication: 1 COB-ID U32, 2 transmission type U8 (0..240, 254, 255),
                5 event timer U16 ms (RPDO deadline: 0 = off)
    0x1600+k    RPDO k+1 mapping: sub 0 U8 count (0..8), subs 1..8 U32 entries
    0x1800+k    TPDO k+1 communication: 1 COB-ID, 2 transmission type (0..240, 252..255),
                3 inhibit time U16 (100 µs), 5 event timer U16 ms, 6 SYNC start value U8 (kept,
                not used); sub 4 does not exist
    0x1A00+k    TPDO k+1 mapping, as 0x1600+k

Manufacturer area::

    0x2000      command U32 [wo]: 1 = clear the error history; other values abort 0x06090030
    0x2001      device tag VISIBLE_STRING [rw], at most 32 bytes

Profile area (restored by reset node and ``reboot``)::

    0x603F      error code U16 [ro] (PDO-mappable unless quirk map_603f=False)
    0x6040      controlword U16 [rww]            0x6041 statusword U16 [ro]
    0x605A      quick stop option code I16 [rw], factory 2; allowed 0, 1, 2, 5, 6
    0x6060      modes of operation I8 [rw], factory 0; allowed 0 (none), 8 (CSP), 9 (CSV)
    0x6061      modes of operation display I8 [ro]
    0x6064      position actual value I32 [ro]   (position units)
    0x6065      following error window U32 [rw], factory 100000 (0xFFFFFFFF = off)
    0x6066      following error time-out U16 [rw] ms, factory 10
    0x6067      position window U32 [rw], factory 100 (statusword bit 10 in CSP)
    0x606C      velocity actual value I32 [ro]   (position units per second)
    0x607A      target position I32 [rww]        0x607E polarity U8 [rw] (bits 7 and 6 only)
    0x6085      quick stop deceleration U32 [rw] (position units / s^2), factory 1_000_000
    0x608F      position encoder resolution RECORD: 1 increments, 2 motor revolutions (U32, > 0)
    0x6091      gear ratio RECORD: 1 motor revolutions, 2 shaft revolutions (U32, > 0)
    0x6092      feed constant RECORD: 1 feed, 2 shaft revolutions (U32, > 0)
    0x60B1      velocity offset I32 [rww] (CSP velocity feed-forward, position units / s)
    0x60C2      interpolation time period RECORD: 1 value U8, 2 index I8 in -6..0; factory:
                the constructor's cycle_s (1, -3 for 1 ms), or (0, -3) if not representable
    0x60F4      following error actual value I32 [ro] (demand - actual, position units)
    0x60FF      target velocity I32 [rww] (CSV, position units / s)
    0x6502      supported drive modes U32 [ro] 0x180 (CSP, CSV; absent with has_6502=False),
                0x1A0 with quirk has_homing (HM too)

With quirk ``has_homing`` (homing mode, 0x6060 = 6)::

    0x607C      home offset I32 [rw], factory 0 (position units)
    0x6098      homing method I8 [rw], factory 37; allowed 17, 18, 35, 37
    0x6099      homing speeds ARRAY: 1 search for switch, 2 search for zero U32 [rw] (position
                units / s, > 0), factory 10000 / 1000
    0x609A      homing acceleration U32 [rw] (position units / s^2, > 0), factory 100000

With quirk ``has_touch_probe`` (touch probe 1; all PDO-mappable)::

    0x60B8      touch probe function U16 [rww]: bit 0 enable probe 1, bit 1 continuous (0 =
                first event), bits 2-3 trigger source (only 00 = probe 1 input; else abort
                0x06090030), bit 4 / 5 sample the positive / negative edge; bits 8..15 (probe 2)
                must be 0 (abort 0x06090030)
    0x60B9      touch probe status U16 [ro]: bit 0 probe 1 enabled, bit 1 positive edge value
                stored, bit 2 negative edge value stored
    0x60BA      touch probe 1 positive edge I32 [ro] (position units)
    0x60BB      touch probe 1 negative edge I32 [ro] (position units)

Scaling: internal increments = position units x (0x608F:1/0x608F:2) x (0x6091:1/0x6091:2) /
(0x6092:1/0x6092:2); factory 131072/1, 1/1, 131072/1 (one increment per position unit).
0x607E bit 7 inverts positions (0x607A, 0x6064, 0x60F4), bit 6 velocities (0x60FF, 0x606C,
0x60B1). Scaling and polarity cannot change in OPERATION ENABLED (abort 0x08000022).

Factory PDO layout (what a master usually does *not* want)::

    RPDO1 0x200+n valid,   type 255, 6040          TPDO1 0x180+n valid,   type 255, 6041
    RPDO2 0x300+n invalid, type 255, 6040 6060     TPDO2 0x280+n invalid, type 255, 6041 6061
    RPDO3 0x400+n invalid, type 255, 6040 607A     TPDO3 0x380+n invalid, type 255, 6041 6064
    RPDO4 0x500+n invalid, type 255, 6040 60FF     TPDO4 0x480+n invalid, type 255, 6041 606C

SDO abort codes
---------------
0x06020000 no such object; 0x06090011 no such sub-index; 0x06010001 read of a write-only
object; 0x06010002 write of a read-only/const object; 0x06070010 data length does not match the
type (also a string longer than its maximum, or a segmented download whose data differ from the
indicated size); 0x06090030 value outside the allowed values (including forbidden COB-IDs:
29-bit frames, the CiA 301 restricted IDs, a new CAN-ID on a valid PDO, and the quirks below);
0x06040041 object cannot be mapped (absent, not mappable, wrong direction (RPDO: writable
objects, TPDO: readable ones), or length not the type's); 0x06040042 mapping longer than 64
bits; 0x06040043 duplicate consumer heartbeat node; 0x08000022 not in this state (mapping while
the PDO is valid or the node is OPERATIONAL, a mapping entry while sub 0 is not 0, scaling or
polarity in OPERATION ENABLED); 0x05030000 toggle bit not alternated; 0x05040001 command
specifier not valid (block transfers, segments without a transfer).

Behaviour
---------
* NMT: power-on (the constructor), ``reboot()`` and reset node restore every object, reset
  communication the communication area; each sends boot-up ``0x700+n [00]`` and enters
  PRE-OPERATIONAL. SDO in PRE-OPERATIONAL and OPERATIONAL; PDOs only in OPERATIONAL; in STOPPED
  only NMT and heartbeat/node guarding; EMCY not in STOPPED. Leaving OPERATIONAL does not change
  the CiA 402 state (the last setpoint is held). The position survives resets (absolute encoder).
* SYNC (COB-ID 0x1005) — in this order: (1) the plant advances one communication cycle period
  T = 0x1006 if non-zero, else 0x60C2, else the constructor's ``cycle_s``; (2) supervision
  (heartbeat consumer, life guarding, RPDO deadline, fault reaction end); (3) in OPERATIONAL
  the TPDOs with type 1..240 go out on every n-th SYNC (type 0: when their data changed,
  type 252: sampled for an RTR); (4) the RPDOs received since the previous SYNC with type 0..240
  are applied (the last of each); in CSP the target 0x607A becomes the setpoint for the next
  period; (5) the mode display delay counts down; (6) the heartbeat goes out when due.
  So the TPDO after SYNC k shows the plant after it followed the setpoint applied at SYNC k-1.
  RPDOs with type 254/255 are applied when received. TPDOs with type 254/255 go out whenever
  their data change (after every frame handled, inhibit time respected) and on their event
  timer. A SYNC with more than one data byte sends EMCY 0x8240 (warning) and is ignored.
* RPDO shorter than its mapping: EMCY 0x8210 (warning), ignored; longer: EMCY 0x8220, the
  first bytes used. Values refused by the OD rules are dropped (counted in ``pdo_rejects``).
  An RPDO event timer (0x14xx:05) that runs out in OPERATION ENABLED after a first reception
  faults with 0x8250.
* Heartbeat producer 0x1017 (ms, on servo time). Consumer 0x1016: supervision of a node starts
  with its first heartbeat; a lapse faults with 0x8130. Node guarding: an RTR on 0x700+n is
  answered with the NMT state and a toggle bit (bit 7, starting at 0 after each reset) while
  0x1017 is 0 or absent; with 0x100C and 0x100D non-zero, once guarded, no guard RTR within
  0x100C x 0x100D ms faults with 0x8130.
* Faults: EMCY (0x80+n: code U16, 0x1001, five zero bytes), 0x603F, 0x1003, statusword; from
  OPERATION ENABLED / QUICK STOP ACTIVE through FAULT REACTION ACTIVE (braking at 0x6085) for
  ``fault_reaction_syncs`` SYNCs, else straight to FAULT. Fault reset (controlword bit 7 rising
  edge, in FAULT only): SWITCH ON DISABLED, 0x603F = 0, EMCY 0x0000. ``warn(code)`` sends an
  EMCY and sets statusword bit 7 and the class bit of 0x1001 without faulting;
  ``clear_warning()`` clears them and sends EMCY 0x0000.
* CiA 402 power state machine with the controlword masks of the standard (disable voltage
  ``cw & 0x82 == 0``, quick stop ``cw & 0x86 == 0x02``, shutdown ``cw & 0x87 == 0x06``, switch
  on ``cw & 0x8F == 0x07``, enable operation ``cw & 0x8F == 0x0F``); illegal commands change
  nothing. 0x0F in READY TO SWITCH ON switches on and enables in one step (quirk
  ``enable_from_ready``). Quick stop: brakes at 0x6085, then option 0..4 -> SWITCH ON DISABLED,
  5/6 stay in QUICK STOP ACTIVE (0x0F returns to OPERATION ENABLED). Statusword: 0x0250 SOD,
  0x0231 RTSO, 0x0233 SO, 0x0237 OE, 0x0217 QSA, 0x021F FRA, 0x0218 FAULT, plus bit 7 warning,
  bit 10 target reached (CSP: |0x607A - 0x6064| <= 0x6067), bit 12 (CSP: following the target,
  halt off), bit 13 following error (window exceeded at the last servo tick).
* Plant (internal increments, ``PlantParams``): in CSP the demand runs linearly from the last
  setpoint to the new one over T in ``substeps`` ticks; velocity command = kff x demand
  velocity (+ 0x60B1) + kp x (demand - actual), a first-order velocity loop (tau_v), speed
  limit v_max. A ramp of V per second settles at the following error (1 - kff) x V / kp.
  CSV: the velocity loop follows 0x60FF. Out of OPERATION ENABLED the motor stands (brake).
  Entering OPERATION ENABLED sets the demand to the actual position; the next SYNC takes
  0x607A, so a master sends the actual position as target before enabling. |demand - actual|
  above 0x6065 for longer than 0x6066 faults with 0x8611.
* Touch probe 1 (quirk ``has_touch_probe``): the probe 1 input is high while the shaft is on a
  mark, ``probe_marks[i] <= x <= probe_marks[i] + probe_width`` (internal increments, the
  shaft's place: homing does not move them). It is sampled against the motion of every servo
  tick; an edge stores the position where the shaft crossed the mark's border (the exact
  crossing of the tick's linear motion, in position units) in 0x60BA (rising) / 0x60BB
  (falling) and sets 0x60B9 bit 1 / 2, if sampling of that edge is enabled and (first-event
  mode) nothing is stored yet. Setting bit 0 (0 -> 1), or bit 4 / 5 (0 -> 1) while bit 0 is
  set, arms that edge again (its stored bit clears); bit 0 = 0 switches the probe off (0x60B9
  = 0).
* Homing mode (quirk ``has_homing``; 0x6060 = 6): in OPERATION ENABLED a rising edge of
  controlword bit 4 starts the method of 0x6098, bit 4 = 0 interrupts it (the motor stops at
  0x609A). Methods (CiA 402): 17 = negative limit switch (search negative at 0x6099:1 until
  the switch is active, then positive at 0x6099:2; the home position is where the switch
  becomes inactive), 18 = the same with the positive limit switch, mirrored; 35 and 37 = the
  current position is the home position. At the home position the motor stops (ramps at
  0x609A, then returns to it at 0x6099:2) and the position values are set so that the home
  position is 0x607C. Limit switches: ``limit_switches`` (negative, positive) in internal
  increments, active at and beyond that place (None = not fitted: homing on it fails).
  Statusword in homing mode: bit 13 homing error (a method without its switch, 0x6098 not
  set up), bit 12 homing attained, bit 10 target reached (attained, or not running:
  interrupted / not started; with an error once the motor stands).
* Modes: 0x6060 accepts 0, 8, 9 (and 6 with quirk ``has_homing``). After a write the old mode
  stays active and displayed (0x6061, TPDOs) for ``mode_display_delay`` SDO reads of 0x6061 or
  SYNCs, counted together.

Public API: ``CanopenServo(bus, node_id, *, quirks, vendor_id, product_code, revision, serial,
cycle_s, plant, position, device_name, probe_marks, probe_width, limit_switches)``;
``start(poll_s)``, ``stop()``, ``process_pending()``;
``write_eds(path)``; fault injection ``reboot()``, ``inject_fault(code)``, ``warn(code)``,
``clear_warning()``, ``stop_heartbeat(stopped)``; views ``nmt_state`` (``NmtState``), ``shaft``,
``cia402_state`` (``Cia402State``), ``statusword``, ``position`` / ``velocity`` (position units,
unrounded), ``mode_display``, ``error_code``, ``time_s``, ``sync_count``, ``mapping(kind, n)``,
``pdo_config(kind, n)`` (``PdoConfig``), ``od_value(index, sub)``, ``sdo_log``
(``SdoLogEntry``), ``malformed_frames``, ``pdo_rejects``. ``PlantParams`` sets the loop.

Quirks (``ServoQuirks``): see the field docs. Time: nothing reads a clock; servo time (integer
µs) advances only by SYNCs, so a run is a function of the frames received. Threads: ``start()``
runs a ``bus.recv`` loop in a thread (every frame in arrival order; a SYNC's TPDOs are sent
before the next frame is taken), ``stop()`` ends it; ``process_pending()`` handles the queued
frames in the caller's thread. All public methods and properties are thread-safe. The caller
owns the bus (the servo never shuts it down).
"""

from __future__ import annotations

import enum
import math
import threading
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import can

__all__ = [
    "CanopenServo",
    "Cia402State",
    "NmtState",
    "PdoConfig",
    "PlantParams",
    "SdoLogEntry",
    "ServoQuirks",
]

# CiA 301 data types
BOOLEAN = 0x01
INTEGER8 = 0x02
INTEGER16 = 0x03
INTEGER32 = 0x04
UNSIGNED8 = 0x05
UNSIGNED16 = 0x06
UNSIGNED32 = 0x07
VISIBLE_STRING = 0x09

_INT_TYPES: dict[int, tuple[int, bool]] = {
    BOOLEAN: (1, False),
    INTEGER8: (1, True),
    INTEGER16: (2, True),
    INTEGER32: (4, True),
    UNSIGNED8: (1, False),
    UNSIGNED16: (2, False),
    UNSIGNED32: (4, False),
}

# SDO abort codes
ABORT_TOGGLE = 0x05030000
ABORT_COMMAND = 0x05040001
ABORT_WRITE_ONLY = 0x06010001
ABORT_READ_ONLY = 0x06010002
ABORT_NO_OBJECT = 0x06020000
ABORT_NOT_MAPPABLE = 0x06040041
ABORT_MAP_LENGTH = 0x06040042
ABORT_INCOMPATIBLE = 0x06040043
ABORT_LENGTH = 0x06070010
ABORT_NO_SUBINDEX = 0x06090011
ABORT_RANGE = 0x06090030
ABORT_STATE = 0x08000022

_VAR, _ARRAY, _RECORD = 0x7, 0x8, 0x9
_PDO_INVALID = 0x80000000
_PDO_NO_RTR = 0x40000000
_PDO_29BIT = 0x20000000


class NmtState(enum.IntEnum):
    """NMT states with the state byte of heartbeat / node guarding."""

    INITIALISING = 0x00
    STOPPED = 0x04
    OPERATIONAL = 0x05
    PRE_OPERATIONAL = 0x7F


class Cia402State(enum.Enum):
    """CiA 402 power drive system states."""

    NOT_READY_TO_SWITCH_ON = "NOT READY TO SWITCH ON"
    SWITCH_ON_DISABLED = "SWITCH ON DISABLED"
    READY_TO_SWITCH_ON = "READY TO SWITCH ON"
    SWITCHED_ON = "SWITCHED ON"
    OPERATION_ENABLED = "OPERATION ENABLED"
    QUICK_STOP_ACTIVE = "QUICK STOP ACTIVE"
    FAULT_REACTION_ACTIVE = "FAULT REACTION ACTIVE"
    FAULT = "FAULT"


_S = Cia402State
_STATUS_BASE = {
    _S.NOT_READY_TO_SWITCH_ON: 0x0000,
    _S.SWITCH_ON_DISABLED: 0x0250,
    _S.READY_TO_SWITCH_ON: 0x0231,
    _S.SWITCHED_ON: 0x0233,
    _S.OPERATION_ENABLED: 0x0237,
    _S.QUICK_STOP_ACTIVE: 0x0217,
    _S.FAULT_REACTION_ACTIVE: 0x021F,
    _S.FAULT: 0x0218,
}

# (state, command) -> new state; the CiA 402 transition numbers in the comments.
_TRANSITIONS: dict[tuple[Cia402State, str], Cia402State] = {
    (_S.SWITCH_ON_DISABLED, "shutdown"): _S.READY_TO_SWITCH_ON,  # 2
    (_S.READY_TO_SWITCH_ON, "switch_on"): _S.SWITCHED_ON,  # 3
    (_S.READY_TO_SWITCH_ON, "disable_voltage"): _S.SWITCH_ON_DISABLED,  # 7
    (_S.READY_TO_SWITCH_ON, "quick_stop"): _S.SWITCH_ON_DISABLED,  # 7
    (_S.SWITCHED_ON, "enable_operation"): _S.OPERATION_ENABLED,  # 4
    (_S.SWITCHED_ON, "shutdown"): _S.READY_TO_SWITCH_ON,  # 6
    (_S.SWITCHED_ON, "disable_voltage"): _S.SWITCH_ON_DISABLED,  # 10
    (_S.SWITCHED_ON, "quick_stop"): _S.SWITCH_ON_DISABLED,  # 10
    (_S.OPERATION_ENABLED, "switch_on"): _S.SWITCHED_ON,  # 5
    (_S.OPERATION_ENABLED, "shutdown"): _S.READY_TO_SWITCH_ON,  # 8
    (_S.OPERATION_ENABLED, "disable_voltage"): _S.SWITCH_ON_DISABLED,  # 9
    (_S.OPERATION_ENABLED, "quick_stop"): _S.QUICK_STOP_ACTIVE,  # 11
    (_S.QUICK_STOP_ACTIVE, "disable_voltage"): _S.SWITCH_ON_DISABLED,  # 12
}


def _decode_command(cw: int) -> str | None:
    """The CiA 402 device control command of a controlword (fault reset handled apart)."""
    if cw & 0x82 == 0x00:
        return "disable_voltage"
    if cw & 0x86 == 0x02:
        return "quick_stop"
    if cw & 0x87 == 0x06:
        return "shutdown"
    if cw & 0x8F == 0x07:
        return "switch_on"
    if cw & 0x8F == 0x0F:
        return "enable_operation"
    return None


def _restricted_cob_id(can_id: int) -> bool:
    """CiA 301 restricted CAN-IDs, which no PDO or SYNC may use."""
    return (
        can_id == 0x000
        or 0x001 <= can_id <= 0x07F
        or 0x101 <= can_id <= 0x180
        or 0x581 <= can_id <= 0x5FF
        or 0x601 <= can_id <= 0x67F
        or 0x6E0 <= can_id <= 0x6FF
        or 0x701 <= can_id <= 0x7FF
    )


def _error_class_bits(code: int) -> int:
    """Error register (0x1001) class bit of an EMCY error code (without the generic bit)."""
    group = code >> 12
    if group == 0x2:
        return 0x02
    if group == 0x3:
        return 0x04
    if group == 0x4:
        return 0x08
    if code >> 8 in (0x81, 0x82):
        return 0x10
    if group == 0x8:
        return 0x20
    if code >> 8 == 0xFF:
        return 0x80
    return 0x00


def _interpolation_period(cycle_us: int) -> tuple[int, int]:
    """0x60C2 (value, index) for a period in µs: the coarsest exact value·10^index with value
    in 1..255 and index in -6..0, or (0, -3) when there is none."""
    for index in range(0, -7, -1):
        scale = 10 ** (index + 6)  # µs per unit
        if cycle_us % scale == 0 and 1 <= cycle_us // scale <= 255:
            return cycle_us // scale, index
    return 0, -3


@dataclass(frozen=True, slots=True)
class ServoQuirks:
    """Standard-conforming behaviours a real drive may have; the factory default is the plain one.

    Fields:
        mode_display_delay: after 0x6060 is written the old mode stays active and displayed for
            this many SDO reads of 0x6061 or SYNCs (counted together); 0..1000.
        has_6502: False = no 0x6502 (SDO abort 0x06020000, not in the EDS).
        has_1006: False = no 0x1006 (the cycle period comes from 0x60C2).
        heartbeat: False = no 0x1017 at all: a node-guarding-only drive.
        tpdo_bit30_required: TPDO COB-IDs must have bit 30 (no RTR) set; writing one without it
            aborts 0x06090030; factory TPDO COB-IDs carry it.
        map_603f: False = 0x603F is not PDO-mappable (abort 0x06040041, PDOMapping=0 in the EDS).
        rpdo_bit30: factory RPDO COB-IDs read with (the reserved) bit 30 set.
        enable_from_ready: controlword 0x0F in READY TO SWITCH ON goes to OPERATION ENABLED in
            one step (False: to SWITCHED ON only, the next 0x0F enables).
        fault_reaction_syncs: SYNCs spent in FAULT REACTION ACTIVE when a fault hits a powered
            drive (0..1000; 0 = straight to FAULT).
        has_touch_probe: touch probe 1 (0x60B8..0x60BB, see the module notes).
        has_homing: homing mode 6 (0x607C, 0x6098, 0x6099, 0x609A, see the module notes).
    """

    mode_display_delay: int = 0
    has_6502: bool = True
    has_1006: bool = True
    heartbeat: bool = True
    tpdo_bit30_required: bool = False
    map_603f: bool = True
    rpdo_bit30: bool = False
    enable_from_ready: bool = True
    fault_reaction_syncs: int = 1
    has_touch_probe: bool = False
    has_homing: bool = False

    def __post_init__(self) -> None:
        for name in ("mode_display_delay", "fault_reaction_syncs"):
            value = getattr(self, name)
            if not isinstance(value, int) or isinstance(value, bool) or not 0 <= value <= 1000:
                raise ValueError(f"ServoQuirks.{name} must be an int in [0, 1000], got {value!r}")


@dataclass(frozen=True, slots=True)
class PlantParams:
    """The servo's position/velocity loop, in internal increments and seconds.

    ``kp`` position gain [1/s] in (0, 1e5]; ``kff`` velocity feed-forward share in [0, 1];
    ``tau_v`` velocity loop time constant [s] in [1e-6, 10]; ``substeps`` servo ticks per
    communication cycle in [1, 1000]; ``v_max`` speed limit [increments/s] > 0 (inf = none).
    A CSP ramp of V increments/s settles at the following error (1 - kff) * V / kp.
    """

    kp: float = 200.0
    kff: float = 0.8
    tau_v: float = 0.001
    substeps: int = 8
    v_max: float = math.inf

    def __post_init__(self) -> None:
        checks = (
            ("kp", 0.0 < self.kp <= 1e5, "(0, 1e5]"),
            ("kff", 0.0 <= self.kff <= 1.0, "[0, 1]"),
            ("tau_v", 1e-6 <= self.tau_v <= 10.0, "[1e-6, 10]"),
            (
                "substeps",
                isinstance(self.substeps, int) and 1 <= self.substeps <= 1000,
                "[1, 1000]",
            ),
            ("v_max", self.v_max > 0.0, "(0, inf]"),
        )
        for name, ok, allowed in checks:
            if not ok:
                raise ValueError(
                    f"PlantParams.{name} must be in {allowed}, got {getattr(self, name)!r}"
                )


@dataclass(frozen=True, slots=True)
class SdoLogEntry:
    """One SDO request the servo finished: ``op`` "upload" or "download", the data moved (the
    downloaded bytes even when refused), and the abort code it answered or None."""

    op: str
    index: int
    subindex: int
    data: bytes
    abort_code: int | None


@dataclass(frozen=True, slots=True)
class PdoConfig:
    """A PDO's configuration: raw COB-ID entry (sub 1), valid flag, CAN-ID, transmission type,
    and the mapped objects as (index, subindex, bits)."""

    cob_id_entry: int
    valid: bool
    can_id: int
    trans_type: int
    mapping: tuple[tuple[int, int, int], ...]


class _AbortError(Exception):
    def __init__(self, code: int) -> None:
        super().__init__(f"SDO abort 0x{code:08X}")
        self.code = code


class _Entry:
    __slots__ = (
        "name",
        "dtype",
        "access",
        "pdo",
        "default",
        "value",
        "low",
        "high",
        "maxlen",
        "node_rel",
    )

    def __init__(
        self,
        name: str,
        dtype: int,
        access: str,
        default: int | bytes,
        *,
        pdo: bool = False,
        low: int | None = None,
        high: int | None = None,
        maxlen: int = 0,
        node_rel: bool = False,
    ) -> None:
        self.name = name
        self.dtype = dtype
        self.access = access
        self.pdo = pdo
        self.default = default
        self.value = default
        self.low = low
        self.high = high
        self.maxlen = maxlen
        self.node_rel = node_rel

    @property
    def readable(self) -> bool:
        return self.access != "wo"

    @property
    def writable(self) -> bool:
        return self.access in ("rw", "wo", "rww", "rwr")

    @property
    def bits(self) -> int:
        return _INT_TYPES[self.dtype][0] * 8 if self.dtype in _INT_TYPES else 0

    def encode(self, value: int | bytes) -> bytes:
        if self.dtype in _INT_TYPES:
            size, signed = _INT_TYPES[self.dtype]
            assert isinstance(value, int)
            return value.to_bytes(size, "little", signed=signed)
        assert isinstance(value, bytes)
        return value

    def decode(self, data: bytes) -> int | bytes:
        if self.dtype in _INT_TYPES:
            size, signed = _INT_TYPES[self.dtype]
            if len(data) != size:
                raise _AbortError(ABORT_LENGTH)
            return int.from_bytes(data, "little", signed=signed)
        if len(data) > self.maxlen:
            raise _AbortError(ABORT_LENGTH)
        return bytes(data)


class _Object:
    __slots__ = ("index", "name", "otype", "entries", "area")

    def __init__(self, index: int, name: str, otype: int, entries: dict[int, _Entry]) -> None:
        self.index = index
        self.name = name
        self.otype = otype
        self.entries = entries
        self.area = "comm" if index < 0x2000 else "app"


class _Pdo:
    """Run-time state of one PDO (not part of the object dictionary)."""

    __slots__ = ("count", "last_sent", "last_time_us", "pending", "latched", "sample", "rx_time")

    def __init__(self) -> None:
        self.count = 0
        self.last_sent: bytes | None = None
        self.last_time_us: int | None = None
        self.pending = False
        self.latched: bytes | None = None
        self.sample: bytes | None = None
        self.rx_time: int | None = None


class _Download:
    __slots__ = ("index", "sub", "size", "buf", "toggle")

    def __init__(self, index: int, sub: int, size: int | None) -> None:
        self.index = index
        self.sub = sub
        self.size = size
        self.buf = bytearray()
        self.toggle = 0


class _Upload:
    __slots__ = ("index", "sub", "data", "pos", "toggle")

    def __init__(self, index: int, sub: int, data: bytes) -> None:
        self.index = index
        self.sub = sub
        self.data = data
        self.pos = 0
        self.toggle = 0


_MODES_ALLOWED = (0, 8, 9)
_QUICK_STOP_OPTIONS = (0, 1, 2, 5, 6)
_SUPPORTED_MODES = 0x180  # bit 7 CSP, bit 8 CSV


class CanopenServo:
    """A CiA 402 servo node on ``bus`` (see the module docstring for everything it does).

    Args:
        bus: its own python-can bus (e.g. ``can.Bus(interface="virtual", channel=ch)``).
        node_id: 1..127.
        quirks: behaviours of this drive model.
        vendor_id, product_code, revision, serial: 0x1018 subs 1..4 (U32).
        cycle_s: communication cycle period (1e-5..1 s): the factory 0x60C2 when it can be
            written as value·10^index (value 1..255, index -6..0), and the period used when
            0x1006 and 0x60C2 are both 0.
        plant: the position/velocity loop.
        position: initial position actual value in position units (the shaft's place at power-on).
        device_name: 0x1008.

    Power-on happens in the constructor: boot-up message, PRE-OPERATIONAL, SWITCH ON DISABLED.
    """

    def __init__(
        self,
        bus: can.BusABC,
        node_id: int,
        *,
        quirks: ServoQuirks | None = None,
        vendor_id: int = 0x00000C5E,
        product_code: int = 0x00402A01,
        revision: int = 0x00010003,
        serial: int = 0x00001234,
        cycle_s: float = 0.001,
        plant: PlantParams | None = None,
        position: float = 0.0,
        device_name: str = "CS-402 servo drive",
        probe_marks: tuple[float, ...] = (),
        probe_width: float = 100.0,
        limit_switches: tuple[float | None, float | None] = (None, None),
    ) -> None:
        if not isinstance(node_id, int) or not 1 <= node_id <= 127:
            raise ValueError(f"node_id must be an int in [1, 127], got {node_id!r}")
        for name, value in (
            ("vendor_id", vendor_id),
            ("product_code", product_code),
            ("revision", revision),
            ("serial", serial),
        ):
            if not isinstance(value, int) or not 0 <= value <= 0xFFFFFFFF:
                raise ValueError(f"{name} must be an int in [0, 0xFFFFFFFF], got {value!r}")
        if not 1e-5 <= cycle_s <= 1.0:
            raise ValueError(f"cycle_s must be in [1e-5, 1.0] s, got {cycle_s!r}")
        if not math.isfinite(position) or abs(position) > 2**31 - 1:
            raise ValueError(f"position must be finite within ±(2**31 - 1), got {position!r}")
        name_bytes = device_name.encode("ascii")
        if not 1 <= len(name_bytes) <= 64:
            raise ValueError("device_name must be 1..64 ASCII characters")
        self._bus = bus
        self._node_id = node_id
        self._quirks = quirks if quirks is not None else ServoQuirks()
        self._plant = plant if plant is not None else PlantParams()
        self._identity = (vendor_id, product_code, revision, serial)
        self._default_cycle_us = max(1, round(cycle_s * 1e6))
        self._device_name = name_bytes
        self._lock = threading.RLock()
        self._thread: threading.Thread | None = None
        self._stop_event = threading.Event()
        self._thread_error: BaseException | None = None
        self._od: dict[int, _Object] = {}
        self._build_od()
        # live state
        self._t_us = 0
        self._nmt = NmtState.INITIALISING
        self._state = _S.NOT_READY_TO_SWITCH_ON
        self._x = 0.0  # actual position [inc]
        self._v = 0.0  # actual velocity [inc/s]
        self._d0 = 0.0  # demand at the start of the current period [inc]
        self._d1 = 0.0  # demand at its end [inc]
        self._demand = 0.0  # demand at the present servo time [inc]
        self._v_cmd_ff = 0.0
        self._fe_exceeded = False
        self._fe_time_us = 0
        self._error_code = 0
        self._error_register = 0
        self._warning_code = 0
        self._history: list[int] = []
        self._cw_prev = 0
        self._mode_active = 0
        self._mode_delay = 0
        self._fault_syncs_left = 0
        self._qs_from_fault = False
        self._hb_next_us: int | None = None
        self._hb_stopped = False
        self._guard_toggle = 0
        self._guard_last_us: int | None = None
        self._consumer_last: dict[int, int] = {}
        self._rpdos = [_Pdo() for _ in range(4)]
        self._tpdos = [_Pdo() for _ in range(4)]
        self._sdo_xfer: _Download | _Upload | None = None
        self._sdo_log: list[SdoLogEntry] = []
        self._malformed = 0
        self._pdo_rejects = 0
        self._sync_count = 0
        if not probe_width > 0.0:
            raise ValueError(f"probe_width must be > 0, got {probe_width!r}")
        self._probe_marks = tuple(sorted(float(m) for m in probe_marks))
        self._probe_width = float(probe_width)
        self._limits = limit_switches
        # homing: position values = (x + shift) in position units; the procedure's state
        self._shift = 0.0
        self._hm_phase = ""  # "" idle | search | zero | stop | back | error | attained
        self._hm_home = 0.0  # home position found [inc]
        self._hm_interrupted = False
        self._hm_side = -1
        self._x = self._pu_to_inc(position)
        self._power_on()

    # ------------------------------------------------------------------ object dictionary
    def _add(
        self, index: int, name: str, otype: int, entries: dict[int, _Entry]
    ) -> dict[int, _Entry]:
        self._od[index] = _Object(index, name, otype, entries)
        return entries

    def _var(
        self, index: int, name: str, dtype: int, access: str, default: int | bytes, **kw: Any
    ) -> None:
        self._add(index, name, _VAR, {0: _Entry(name, dtype, access, default, **kw)})

    def _record(self, index: int, name: str, subs: dict[int, _Entry], otype: int = _RECORD) -> None:
        top = max(subs)
        entries = {0: _Entry("Highest sub-index supported", UNSIGNED8, "const", top)}
        entries.update(subs)
        self._add(index, name, otype, entries)

    def _build_od(self) -> None:
        q = self._quirks
        n = self._node_id
        ip_value, ip_index = _interpolation_period(self._default_cycle_us)
        U8, U16, U32, I8, I16, I32 = (
            UNSIGNED8,
            UNSIGNED16,
            UNSIGNED32,
            INTEGER8,
            INTEGER16,
            INTEGER32,
        )
        self._var(0x1000, "Device type", U32, "const", 0x00020192)
        self._var(0x1001, "Error register", U8, "ro", 0, pdo=True)
        hist = {0: _Entry("Number of errors", U8, "rw", 0, low=0, high=0)}
        for k in range(1, 9):
            hist[k] = _Entry(f"Standard error field {k}", U32, "ro", 0)
        self._add(0x1003, "Pre-defined error field", _ARRAY, hist)
        self._var(0x1005, "COB-ID SYNC", U32, "rw", 0x80)
        if q.has_1006:
            self._var(0x1006, "Communication cycle period", U32, "rw", 0)
        self._var(0x1008, "Manufacturer device name", VISIBLE_STRING, "const", self._device_name,
                  maxlen=len(self._device_name))  # fmt: skip
        self._var(0x1009, "Manufacturer hardware version", VISIBLE_STRING, "const", b"HW 2.1",
                  maxlen=6)  # fmt: skip
        self._var(0x100A, "Manufacturer software version", VISIBLE_STRING, "const",
                  b"FW 1.4.7 (CiA 402)", maxlen=18)  # fmt: skip
        self._var(0x100C, "Guard time", U16, "rw", 0)
        self._var(0x100D, "Life time factor", U8, "rw", 0)
        self._var(0x1014, "COB-ID EMCY", U32, "ro", 0x80 + n, node_rel=True)
        cons = {0: _Entry("Highest sub-index supported", U8, "ro", 4)}
        for k in range(1, 5):
            cons[k] = _Entry(f"Consumer heartbeat time {k}", U32, "rw", 0)
        self._add(0x1016, "Consumer heartbeat time", _ARRAY, cons)
        if q.heartbeat:
            self._var(0x1017, "Producer heartbeat time", U16, "rw", 0)
        self._record(
            0x1018,
            "Identity object",
            {
                k + 1: _Entry(name, U32, "ro", value)
                for k, (name, value) in enumerate(
                    zip(
                        ("Vendor-ID", "Product code", "Revision number", "Serial number"),
                        self._identity,
                        strict=True,
                    )
                )
            },
        )
        rpdo_maps = ([0x60400010], [0x60400010, 0x60600008], [0x60400010, 0x607A0020],
                     [0x60400010, 0x60FF0020])  # fmt: skip
        tpdo_maps = ([0x60410010], [0x60410010, 0x60610008], [0x60410010, 0x60640020],
                     [0x60410010, 0x606C0020])  # fmt: skip
        for k in range(4):
            cob = 0x200 + 0x100 * k + n
            if k:
                cob |= _PDO_INVALID
            if q.rpdo_bit30:
                cob |= _PDO_NO_RTR
            self._record(
                0x1400 + k,
                f"RPDO {k + 1} communication parameter",
                {
                    1: _Entry("COB-ID used by RPDO", U32, "rw", cob, node_rel=True),
                    2: _Entry("Transmission type", U8, "rw", 255),
                    5: _Entry("Event timer", U16, "rw", 0),
                },
            )
            self._mapping_record(0x1600 + k, f"RPDO {k + 1} mapping parameter", rpdo_maps[k])
            cob = 0x180 + 0x100 * k + n
            if k:
                cob |= _PDO_INVALID
            if q.tpdo_bit30_required:
                cob |= _PDO_NO_RTR
            self._record(
                0x1800 + k,
                f"TPDO {k + 1} communication parameter",
                {
                    1: _Entry("COB-ID used by TPDO", U32, "rw", cob, node_rel=True),
                    2: _Entry("Transmission type", U8, "rw", 255),
                    3: _Entry("Inhibit time", U16, "rw", 0),
                    5: _Entry("Event timer", U16, "rw", 0),
                    6: _Entry("SYNC start value", U8, "rw", 0, low=0, high=240),
                },
            )
            self._mapping_record(0x1A00 + k, f"TPDO {k + 1} mapping parameter", tpdo_maps[k])
        self._var(0x2000, "Manufacturer command", U32, "wo", 0)
        self._var(0x2001, "Device tag", VISIBLE_STRING, "rw", b"axis", maxlen=32)
        self._var(0x603F, "Error code", U16, "ro", 0, pdo=q.map_603f)
        self._var(0x6040, "Controlword", U16, "rww", 0, pdo=True)
        self._var(0x6041, "Statusword", U16, "ro", 0, pdo=True)
        self._var(0x605A, "Quick stop option code", I16, "rw", 2)
        self._var(0x6060, "Modes of operation", I8, "rw", 0, pdo=True)
        self._var(0x6061, "Modes of operation display", I8, "ro", 0, pdo=True)
        self._var(0x6064, "Position actual value", I32, "ro", 0, pdo=True)
        self._var(0x6065, "Following error window", U32, "rw", 100000, pdo=True)
        self._var(0x6066, "Following error time out", U16, "rw", 10)
        self._var(0x6067, "Position window", U32, "rw", 100)
        self._var(0x606C, "Velocity actual value", I32, "ro", 0, pdo=True)
        self._var(0x607A, "Target position", I32, "rww", 0, pdo=True)
        self._var(0x607E, "Polarity", U8, "rw", 0)
        self._var(0x6085, "Quick stop deceleration", U32, "rw", 1_000_000, low=1)
        for index, name, names, defaults in (
            (0x608F, "Position encoder resolution", ("Encoder increments", "Motor revolutions"),
             (131072, 1)),
            (0x6091, "Gear ratio", ("Motor revolutions", "Shaft revolutions"), (1, 1)),
            (0x6092, "Feed constant", ("Feed", "Shaft revolutions"), (131072, 1)),
        ):  # fmt: skip
            self._record(
                index,
                name,
                {k + 1: _Entry(names[k], U32, "rw", defaults[k], low=1) for k in range(2)},
            )
        self._var(0x60B1, "Velocity offset", I32, "rww", 0, pdo=True)
        self._record(
            0x60C2,
            "Interpolation time period",
            {
                1: _Entry("Interpolation time period value", U8, "rw", ip_value),
                2: _Entry("Interpolation time index", I8, "rw", ip_index, low=-6, high=0),
            },
        )
        self._var(0x60F4, "Following error actual value", I32, "ro", 0, pdo=True)
        self._var(0x60FF, "Target velocity", I32, "rww", 0, pdo=True)
        if q.has_6502:
            modes = _SUPPORTED_MODES | (0x20 if q.has_homing else 0)
            self._var(0x6502, "Supported drive modes", U32, "ro", modes, pdo=True)
        if q.has_homing:
            self._var(0x607C, "Home offset", I32, "rw", 0)
            self._var(0x6098, "Homing method", I8, "rw", 37)
            speeds = {0: _Entry("Highest sub-index supported", U8, "const", 2)}
            speeds[1] = _Entry("Speed during search for switch", U32, "rw", 10000, low=1)
            speeds[2] = _Entry("Speed during search for zero", U32, "rw", 1000, low=1)
            self._add(0x6099, "Homing speeds", _ARRAY, speeds)
            self._var(0x609A, "Homing acceleration", U32, "rw", 100000, low=1)
        if q.has_touch_probe:
            self._var(0x60B8, "Touch probe function", U16, "rww", 0, pdo=True)
            self._var(0x60B9, "Touch probe status", U16, "ro", 0, pdo=True)
            self._var(0x60BA, "Touch probe pos1 pos value", I32, "ro", 0, pdo=True)
            self._var(0x60BB, "Touch probe pos1 neg value", I32, "ro", 0, pdo=True)

    def _mapping_record(self, index: int, name: str, entries: list[int]) -> None:
        subs = {0: _Entry("Number of mapped objects", UNSIGNED8, "rw", len(entries))}
        for k in range(1, 9):
            value = entries[k - 1] if k <= len(entries) else 0
            subs[k] = _Entry(f"Mapped object {k}", UNSIGNED32, "rw", value)
        self._add(index, name, _RECORD, subs)

    def _entry(self, index: int, sub: int) -> _Entry:
        obj = self._od.get(index)
        if obj is None:
            raise _AbortError(ABORT_NO_OBJECT)
        entry = obj.entries.get(sub)
        if entry is None:
            raise _AbortError(ABORT_NO_SUBINDEX)
        return entry

    def _raw(self, index: int, sub: int = 0) -> int:
        value = self._od[index].entries[sub].value
        assert isinstance(value, int)
        return value

    def _factory(self, area: str | None) -> None:
        for obj in self._od.values():
            if area is None or obj.area == area:
                for entry in obj.entries.values():
                    entry.value = entry.default

    # ------------------------------------------------------------------ scaling
    def _factor(self) -> float:
        r = self._raw
        return (
            (r(0x608F, 1) / r(0x608F, 2))
            * (r(0x6091, 1) / r(0x6091, 2))
            / (r(0x6092, 1) / r(0x6092, 2))
        )

    def _pos_sign(self) -> float:
        return -1.0 if self._raw(0x607E) & 0x80 else 1.0

    def _vel_sign(self) -> float:
        return -1.0 if self._raw(0x607E) & 0x40 else 1.0

    def _pu_to_inc(self, pu: float) -> float:
        return self._pos_sign() * pu * self._factor() - self._shift

    def _inc_to_pu(self, inc: float) -> float:
        return self._pos_sign() * (inc + self._shift) / self._factor()

    def _cycle_us(self) -> int:
        if self._quirks.has_1006 and self._raw(0x1006):
            return self._raw(0x1006)
        value, index = self._raw(0x60C2, 1), self._raw(0x60C2, 2)
        if value:
            return max(1, round(value * 10.0 ** (index + 6)))
        return self._default_cycle_us

    @staticmethod
    def _clamp_i32(value: float) -> int:
        return max(-(2**31), min(2**31 - 1, math.floor(value + 0.5)))

    # ------------------------------------------------------------------ live values
    def _statusword(self) -> int:
        sw = _STATUS_BASE[self._state]
        if self._warning_code:
            sw |= 0x0080
        if self._state is _S.OPERATION_ENABLED and self._mode_active == 8:
            halt = bool(self._raw(0x6040) & 0x0100)
            if not halt:
                sw |= 0x1000
            window = self._raw(0x6067)
            if abs(self._raw(0x607A) - self._clamp_i32(self._inc_to_pu(self._x))) <= window:
                sw |= 0x0400
        if self._state is _S.OPERATION_ENABLED and self._mode_active == 6:
            phase = self._hm_phase
            if phase == "attained":
                sw |= 0x1400
            elif phase == "error":
                sw |= 0x2000 | (0x0400 if self._v == 0.0 else 0)
            elif phase == "" or self._hm_interrupted:
                sw |= 0x0400
        if self._fe_exceeded and self._state in (
            _S.OPERATION_ENABLED,
            _S.QUICK_STOP_ACTIVE,
            _S.FAULT_REACTION_ACTIVE,
            _S.FAULT,
        ):
            sw |= 0x2000
        return sw

    def _read_value(self, index: int, sub: int) -> int | bytes:
        if index == 0x6041:
            return self._statusword()
        if index == 0x6064:
            return self._clamp_i32(self._inc_to_pu(self._x))
        if index == 0x606C:
            return self._clamp_i32(self._vel_sign() * self._v / self._factor())
        if index == 0x60F4:
            return self._clamp_i32(self._inc_to_pu(self._demand) - self._inc_to_pu(self._x))
        if index == 0x6061:
            return self._mode_active
        if index == 0x60B9:
            return self._probe_status()
        if index == 0x603F:
            return self._error_code
        if index == 0x1001:
            return self._register()
        if index == 0x1003:
            if sub == 0:
                return len(self._history)
            return self._history[sub - 1] if sub <= len(self._history) else 0
        return self._od[index].entries[sub].value

    def _register(self) -> int:
        return self._error_register | _error_class_bits(self._warning_code)

    # ------------------------------------------------------------------ writes (SDO and PDO)
    def _write(self, index: int, sub: int, data: bytes, *, via_pdo: bool = False) -> None:
        """Check and store one value; raises _AbortError with the SDO abort code on refusal."""
        entry = self._entry(index, sub)
        if not entry.writable:
            raise _AbortError(ABORT_READ_ONLY)
        value = entry.decode(data)
        if isinstance(value, int):
            if entry.low is not None and value < entry.low:
                raise _AbortError(ABORT_RANGE)
            if entry.high is not None and value > entry.high:
                raise _AbortError(ABORT_RANGE)
        hook = self._write_hooks.get(index & 0xFF00 if 0x1400 <= index < 0x1C00 else index)
        if hook is not None:
            hook(self, index, sub, value)
        else:
            entry.value = value

    def _w_error_history(self, index: int, sub: int, value: int) -> None:
        self._history.clear()

    def _w_sync_cob(self, index: int, sub: int, value: int) -> None:
        if value & (_PDO_NO_RTR | _PDO_29BIT) or value & 0x1FFFF800:
            raise _AbortError(ABORT_RANGE)
        can_id = value & 0x7FF
        if _restricted_cob_id(can_id) and can_id != 0x080:
            raise _AbortError(ABORT_RANGE)
        self._od[index].entries[sub].value = value

    def _w_cycle_period(self, index: int, sub: int, value: int) -> None:
        if value and not 100 <= value <= 1_000_000:
            raise _AbortError(ABORT_RANGE)
        self._od[index].entries[sub].value = value

    def _w_consumer(self, index: int, sub: int, value: int) -> None:
        node, ms = (value >> 16) & 0xFF, value & 0xFFFF
        if value >> 24:
            raise _AbortError(ABORT_RANGE)
        if ms and node:
            for k, entry in self._od[0x1016].entries.items():
                other = entry.value
                assert isinstance(other, int)
                if k and k != sub and (other >> 16) & 0xFF == node and other & 0xFFFF:
                    raise _AbortError(ABORT_INCOMPATIBLE)
        self._od[index].entries[sub].value = value
        self._consumer_last.clear()

    def _w_heartbeat(self, index: int, sub: int, value: int) -> None:
        self._od[index].entries[sub].value = value
        self._hb_next_us = self._t_us + value * 1000 if value else None

    def _w_command(self, index: int, sub: int, value: int) -> None:
        if value != 1:
            raise _AbortError(ABORT_RANGE)
        self._history.clear()

    def _w_pdo_comm(self, index: int, sub: int, value: int) -> None:
        is_tx = index >= 0x1800
        k = index & 0xFF
        if k > 3:
            raise _AbortError(ABORT_NO_OBJECT)
        entries = self._od[index].entries
        if sub == 1:
            if value & _PDO_29BIT or value & 0x1FFFF800:
                raise _AbortError(ABORT_RANGE)
            if is_tx and self._quirks.tpdo_bit30_required and not value & _PDO_NO_RTR:
                raise _AbortError(ABORT_RANGE)
            can_id = value & 0x7FF
            old = entries[1].value
            assert isinstance(old, int)
            if _restricted_cob_id(can_id):
                raise _AbortError(ABORT_RANGE)
            if not value & _PDO_INVALID:
                if not old & _PDO_INVALID and (old & 0x7FF) != can_id:
                    raise _AbortError(ABORT_RANGE)
            entries[1].value = value
            pdo = (self._tpdos if is_tx else self._rpdos)[k]
            pdo.__init__()
            return
        if sub == 2:
            allowed = (0 <= value <= 240) or value in (
                (252, 253, 254, 255) if is_tx else (254, 255)
            )
            if not allowed:
                raise _AbortError(ABORT_RANGE)
        entries[sub].value = value
        (self._tpdos if is_tx else self._rpdos)[k].__init__()

    def _w_pdo_map(self, index: int, sub: int, value: int) -> None:
        is_tx = index >= 0x1A00
        k = index & 0xFF
        comm = self._raw((0x1800 if is_tx else 0x1400) + k, 1)
        if self._nmt is NmtState.OPERATIONAL or not comm & _PDO_INVALID:
            raise _AbortError(ABORT_STATE)
        entries = self._od[index].entries
        if sub == 0:
            if value > 8:
                raise _AbortError(ABORT_RANGE)
            bits = 0
            for s in range(1, value + 1):
                raw = entries[s].value
                assert isinstance(raw, int)
                if raw == 0:
                    raise _AbortError(ABORT_NOT_MAPPABLE)
                bits += self._check_map_entry(raw, is_tx)
            if bits > 64:
                raise _AbortError(ABORT_MAP_LENGTH)
        else:
            if self._raw(index, 0) != 0:
                raise _AbortError(ABORT_STATE)
            if value:
                self._check_map_entry(value, is_tx)
        entries[sub].value = value

    def _check_map_entry(self, raw: int, is_tx: bool) -> int:
        index, sub, bits = raw >> 16, (raw >> 8) & 0xFF, raw & 0xFF
        obj = self._od.get(index)
        entry = obj.entries.get(sub) if obj is not None else None
        if entry is None or not entry.pdo or entry.bits != bits:
            raise _AbortError(ABORT_NOT_MAPPABLE)
        if (is_tx and not entry.readable) or (not is_tx and not entry.writable):
            raise _AbortError(ABORT_NOT_MAPPABLE)
        return bits

    def _w_controlword(self, index: int, sub: int, value: int) -> None:
        self._od[index].entries[sub].value = value
        self._apply_controlword(value)

    def _w_mode(self, index: int, sub: int, value: int) -> None:
        if value not in _MODES_ALLOWED and not (value == 6 and self._quirks.has_homing):
            raise _AbortError(ABORT_RANGE)
        entry = self._od[index].entries[sub]
        requested, entry.value = entry.value, value
        if value == self._mode_active:
            self._mode_delay = 0
        elif value == requested and self._mode_delay > 0:
            pass  # the same mode again (e.g. an RPDO every cycle): the delay runs on
        elif self._quirks.mode_display_delay == 0:
            self._activate_mode(value)
        else:
            self._mode_delay = self._quirks.mode_display_delay

    def _w_homing_method(self, index: int, sub: int, value: int) -> None:
        if value not in (17, 18, 35, 37):
            raise _AbortError(ABORT_RANGE)
        self._od[index].entries[sub].value = value

    def _w_probe_function(self, index: int, sub: int, value: int) -> None:
        if value & 0xFF00 or (value & 0x01 and value & 0x0C):
            raise _AbortError(ABORT_RANGE)  # probe 2, or a trigger source other than input 1
        entry = self._od[index].entries[sub]
        old, entry.value = entry.value, value
        status = self._od[0x60B9].entries[0]
        if not value & 0x01:
            status.value = 0
            return
        stored = status.value & 0x06
        switched_on = not old & 0x01
        if value & 0x10 and (switched_on or not old & 0x10):
            stored &= ~0x02
        if value & 0x20 and (switched_on or not old & 0x20):
            stored &= ~0x04
        status.value = 0x01 | stored

    def _w_quick_stop_option(self, index: int, sub: int, value: int) -> None:
        if value not in _QUICK_STOP_OPTIONS:
            raise _AbortError(ABORT_RANGE)
        self._od[index].entries[sub].value = value

    def _w_polarity(self, index: int, sub: int, value: int) -> None:
        if value & ~0xC0:
            raise _AbortError(ABORT_RANGE)
        self._w_scaling(index, sub, value)

    def _w_scaling(self, index: int, sub: int, value: int) -> None:
        if self._state is _S.OPERATION_ENABLED:
            raise _AbortError(ABORT_STATE)
        self._od[index].entries[sub].value = value

    _write_hooks: dict[int, Callable[[CanopenServo, int, int, int], None]] = {
        0x1003: _w_error_history,
        0x1005: _w_sync_cob,
        0x1006: _w_cycle_period,
        0x1016: _w_consumer,
        0x1017: _w_heartbeat,
        0x1400: _w_pdo_comm,
        0x1600: _w_pdo_map,
        0x1800: _w_pdo_comm,
        0x1A00: _w_pdo_map,
        0x2000: _w_command,
        0x6040: _w_controlword,
        0x605A: _w_quick_stop_option,
        0x6060: _w_mode,
        0x607E: _w_polarity,
        0x608F: _w_scaling,
        0x6091: _w_scaling,
        0x6092: _w_scaling,
        0x6098: _w_homing_method,
        0x60B8: _w_probe_function,
    }

    # ------------------------------------------------------------------ CiA 402
    def _apply_controlword(self, cw: int) -> None:
        rising = bool(cw & 0x80) and not self._cw_prev & 0x80
        if self._quirks.has_homing and self._mode_active == 6:
            start = bool(cw & 0x10) and not self._cw_prev & 0x10
            if start and self._state is _S.OPERATION_ENABLED and cw & 0x0F == 0x0F:
                self._homing_start()
            elif not cw & 0x10 and self._hm_phase in ("search", "zero", "stop", "back"):
                self._hm_interrupted = True
                self._hm_phase = "stop"
        self._cw_prev = cw
        state = self._state
        if state is _S.FAULT:
            if rising:
                self._fault_reset()
            return
        if state is _S.FAULT_REACTION_ACTIVE:
            return
        command = _decode_command(cw)
        if command is None:
            return
        new = _TRANSITIONS.get((state, command))
        if state is _S.READY_TO_SWITCH_ON and command == "enable_operation":
            new = _S.OPERATION_ENABLED if self._quirks.enable_from_ready else _S.SWITCHED_ON
        if (
            state is _S.QUICK_STOP_ACTIVE
            and command == "enable_operation"
            and self._raw(0x605A) >= 5
        ):
            new = _S.OPERATION_ENABLED  # 16
        if new is not None:
            self._set_state(new)

    def _set_state(self, new: Cia402State) -> None:
        old = self._state
        self._state = new
        if new is _S.OPERATION_ENABLED and old is not _S.OPERATION_ENABLED:
            self._d0 = self._d1 = self._demand = self._x
            self._fe_time_us = 0
            self._fe_exceeded = False
        if new not in (
            _S.OPERATION_ENABLED,
            _S.QUICK_STOP_ACTIVE,
            _S.FAULT_REACTION_ACTIVE,
        ):
            self._v = 0.0
            self._d0 = self._d1 = self._demand = self._x

    def _activate_mode(self, mode: int) -> None:
        self._mode_delay = 0
        if mode != self._mode_active:
            self._mode_active = mode
            self._hm_phase = ""
            self._hm_interrupted = False
            self._d0 = self._d1 = self._demand = self._x

    def _mode_tick(self) -> None:
        if self._mode_delay > 0:
            self._mode_delay -= 1
            if self._mode_delay == 0:
                self._activate_mode(self._raw(0x6060))

    def _raise_fault(self, code: int) -> None:
        self._error_code = code
        self._error_register |= 0x01 | _error_class_bits(code)
        self._history.insert(0, code)
        del self._history[8:]
        if self._state in (_S.OPERATION_ENABLED, _S.QUICK_STOP_ACTIVE):
            if self._quirks.fault_reaction_syncs:
                self._state = _S.FAULT_REACTION_ACTIVE
                self._fault_syncs_left = self._quirks.fault_reaction_syncs
            else:
                self._set_state(_S.FAULT)
        elif self._state is not _S.FAULT_REACTION_ACTIVE:
            self._set_state(_S.FAULT)
        self._send_emcy(code, self._register())

    def _fault_reset(self) -> None:
        self._error_code = 0
        self._error_register = 0
        self._fe_exceeded = False
        self._fe_time_us = 0
        self._set_state(_S.SWITCH_ON_DISABLED)
        self._send_emcy(0x0000, self._register())

    # ------------------------------------------------------------------ plant
    def _advance(self, dt_us: int) -> None:
        p = self._plant
        m = p.substeps
        h = dt_us * 1e-6 / m
        alpha = 1.0 - math.exp(-h / p.tau_v)
        state = self._state
        factor = self._factor()
        window = self._raw(0x6065)
        timeout_us = self._raw(0x6066) * 1000
        mode = self._mode_active
        if state is _S.OPERATION_ENABLED and mode == 6:
            self._homing_advance(dt_us)
            return
        if state is _S.OPERATION_ENABLED and mode in (8, 9):
            csp = mode == 8
            if csp:
                v_ff = (self._d1 - self._d0) / (dt_us * 1e-6)
                v_ff += self._vel_sign() * self._raw(0x60B1) * factor
            else:
                v_target = self._vel_sign() * self._raw(0x60FF) * factor
            for i in range(1, m + 1):
                if csp:
                    d = self._d0 + (self._d1 - self._d0) * (i - 1) / m
                    v_cmd = p.kff * v_ff + p.kp * (d - self._x)
                    d = self._d0 + (self._d1 - self._d0) * i / m
                    self._demand = d
                else:
                    v_cmd = v_target
                self._v += (v_cmd - self._v) * alpha
                self._v = max(-p.v_max, min(p.v_max, self._v))
                x0 = self._x
                self._x += self._v * h
                self._probe_sample(x0, self._x)
                if not csp:
                    continue
                exceeded = window != 0xFFFFFFFF and abs(d - self._x) / factor > window
                self._fe_exceeded = exceeded
                if exceeded:
                    self._fe_time_us += round(h * 1e6)
                    if self._fe_time_us > timeout_us:
                        self._raise_fault(0x8611)
                        break
                else:
                    self._fe_time_us = 0
            if not csp:
                self._d0 = self._d1 = self._demand = self._x
        elif state in (_S.QUICK_STOP_ACTIVE, _S.FAULT_REACTION_ACTIVE) or (
            state is _S.OPERATION_ENABLED
        ):
            dec = self._raw(0x6085) * factor
            for _ in range(m):
                step = dec * h
                self._v = 0.0 if abs(self._v) <= step else self._v - math.copysign(step, self._v)
                x0 = self._x
                self._x += self._v * h
                self._probe_sample(x0, self._x)
            if state is not _S.OPERATION_ENABLED or self._v == 0.0:
                self._d0 = self._d1 = self._demand = self._x

    # ------------------------------------------------------------------ touch probe
    def _probe_high(self, x: float) -> bool:
        w = self._probe_width
        return any(m <= x <= m + w for m in self._probe_marks)

    def _probe_status(self) -> int:
        if not self._quirks.has_touch_probe:
            return 0
        return self._raw(0x60B9)

    def _probe_sample(self, x0: float, x1: float) -> None:
        """One servo tick moved the shaft from x0 to x1 (linearly): store probe 1 edges."""
        if not self._quirks.has_touch_probe or x0 == x1:
            return
        function = self._raw(0x60B8)
        if not function & 0x01:
            return
        status = self._od[0x60B9].entries[0]
        lo, hi = min(x0, x1), max(x0, x1)
        borders = sorted(
            b
            for m in self._probe_marks
            for b in (m, m + self._probe_width)
            if lo < b <= hi or (lo <= b < hi and x1 < x0)
        )
        if x1 < x0:
            borders.reverse()
        level = self._probe_high(x0)
        for b in borders:
            after = self._probe_high(b + (1e-6 if x1 > x0 else -1e-6))
            if after == level:
                continue
            level = after
            bit, index, sample = (0x02, 0x60BA, 0x10) if after else (0x04, 0x60BB, 0x20)
            if not function & sample:
                continue
            if status.value & bit and not function & 0x02:
                continue  # first event mode: the first value stays
            self._od[index].entries[0].value = self._clamp_i32(self._inc_to_pu(b))
            status.value |= bit

    # ------------------------------------------------------------------ homing
    def _limit_active(self, side: int, x: float) -> bool:
        place = self._limits[0 if side < 0 else 1]
        if place is None:
            return False
        return x <= place if side < 0 else x >= place

    def _homing_start(self) -> None:
        self._hm_interrupted = False
        method = self._raw(0x6098)
        if method in (35, 37):
            self._hm_home = self._x
            self._homing_attained()
            return
        side = -1 if method == 17 else 1
        if self._limits[0 if side < 0 else 1] is None:
            self._hm_phase = "error"
            return
        self._hm_side = side
        self._hm_phase = "zero" if self._limit_active(side, self._x) else "search"

    def _homing_attained(self) -> None:
        """The motor rests at the home position: it becomes 0x607C."""
        self._v = 0.0
        self._x = self._hm_home
        offset_inc = self._pos_sign() * self._raw(0x607C) * self._factor()
        self._shift = offset_inc - self._x
        self._d0 = self._d1 = self._demand = self._x
        self._hm_phase = "attained"

    def _homing_advance(self, dt_us: int) -> None:
        """One communication cycle of the homing procedure (velocity profile at 0x609A)."""
        m = self._plant.substeps
        h = dt_us * 1e-6 / m
        factor = self._factor()
        acc = self._raw(0x609A) * factor
        fast = self._raw(0x6099, 1) * factor
        slow = self._raw(0x6099, 2) * factor
        for _ in range(m):
            phase = self._hm_phase
            if phase == "search":
                v_goal = self._hm_side * fast
            elif phase == "zero":
                v_goal = -self._hm_side * slow
            elif phase == "back":
                dist = self._hm_home - self._x
                v_goal = math.copysign(min(slow, math.sqrt(2.0 * acc * abs(dist))), dist)
            else:
                v_goal = 0.0
            dv = acc * h
            self._v = (
                v_goal
                if abs(v_goal - self._v) <= dv
                else self._v + math.copysign(dv, v_goal - self._v)
            )
            x0 = self._x
            self._x += self._v * h
            self._probe_sample(x0, self._x)
            if phase == "search" and self._limit_active(self._hm_side, self._x):
                self._hm_phase = "zero"
            elif phase == "zero" and not self._limit_active(self._hm_side, self._x):
                place = self._limits[0 if self._hm_side < 0 else 1]
                assert place is not None
                self._hm_home = place  # the switch's border: where it became inactive
                self._hm_phase = "stop"
            elif phase == "stop" and self._v == 0.0:
                self._hm_phase = "" if self._hm_interrupted else "back"
            elif phase == "back" and (
                abs(self._hm_home - self._x) <= 1e-9 * (1.0 + abs(self._x))
                or (self._hm_home - x0) * (self._hm_home - self._x) <= 0.0
            ):
                self._homing_attained()
        self._d0 = self._d1 = self._demand = self._x

    # ------------------------------------------------------------------ frames out
    def _send(self, can_id: int, data: bytes, *, remote: bool = False) -> None:
        msg = can.Message(
            arbitration_id=can_id, data=data, is_extended_id=False, is_remote_frame=remote
        )
        self._bus.send(msg)

    def _send_emcy(self, code: int, register: int) -> None:
        if self._nmt in (NmtState.PRE_OPERATIONAL, NmtState.OPERATIONAL):
            data = code.to_bytes(2, "little") + bytes([register & 0xFF]) + bytes(5)
            self._send(self._raw(0x1014) & 0x7FF, data)

    def _send_heartbeat(self) -> None:
        if not self._hb_stopped:
            self._send(0x700 + self._node_id, bytes([int(self._nmt)]))

    # ------------------------------------------------------------------ NMT
    def _power_on(self) -> None:
        self._factory(None)
        self._history.clear()
        self._error_code = 0
        self._error_register = 0
        self._warning_code = 0
        self._cw_prev = 0
        self._mode_active = 0
        self._mode_delay = 0
        self._v = 0.0
        self._fe_exceeded = False
        self._fe_time_us = 0
        self._state = _S.NOT_READY_TO_SWITCH_ON
        self._set_state(_S.SWITCH_ON_DISABLED)  # transitions 0 and 1
        self._reset_communication()

    def _reset_communication(self) -> None:
        self._factory("comm")
        self._nmt = NmtState.INITIALISING
        self._rpdos = [_Pdo() for _ in range(4)]
        self._tpdos = [_Pdo() for _ in range(4)]
        self._sdo_xfer = None
        self._guard_toggle = 0
        self._guard_last_us = None
        self._consumer_last.clear()
        self._hb_next_us = None
        self._send(0x700 + self._node_id, b"\x00")  # boot-up
        self._nmt = NmtState.PRE_OPERATIONAL

    def _on_nmt(self, data: bytes) -> None:
        if len(data) != 2:
            self._malformed += 1
            return
        cmd, node = data[0], data[1]
        if node not in (0, self._node_id):
            return
        if cmd == 0x01:
            if self._nmt is not NmtState.OPERATIONAL:
                self._nmt = NmtState.OPERATIONAL
                for pdo in self._rpdos + self._tpdos:
                    pdo.__init__()
        elif cmd == 0x02:
            self._nmt = NmtState.STOPPED
            self._sdo_xfer = None
        elif cmd == 0x80:
            self._nmt = NmtState.PRE_OPERATIONAL
        elif cmd == 0x81:
            self._power_on()
        elif cmd == 0x82:
            self._reset_communication()

    def _on_guard_rtr(self) -> None:
        if self._quirks.heartbeat and self._raw(0x1017):
            return
        self._guard_last_us = self._t_us
        if self._hb_stopped:
            return
        self._send(0x700 + self._node_id, bytes([int(self._nmt) | (self._guard_toggle << 7)]))
        self._guard_toggle ^= 1

    def _on_heartbeat(self, node: int, data: bytes) -> None:
        if len(data) != 1:
            return
        for k in range(1, 5):
            value = self._raw(0x1016, k)
            if (value >> 16) & 0xFF == node and value & 0xFFFF:
                self._consumer_last[node] = self._t_us

    def _supervise(self) -> None:
        for k in range(1, 5):
            value = self._raw(0x1016, k)
            node, ms = (value >> 16) & 0xFF, value & 0xFFFF
            last = self._consumer_last.get(node)
            if ms and last is not None and self._t_us - last > ms * 1000:
                del self._consumer_last[node]
                self._raise_fault(0x8130)
        guard, factor = self._raw(0x100C), self._raw(0x100D)
        if guard and factor and self._guard_last_us is not None:
            if self._t_us - self._guard_last_us > guard * factor * 1000:
                self._guard_last_us = None
                self._raise_fault(0x8130)
        if self._nmt is NmtState.OPERATIONAL and self._state is _S.OPERATION_ENABLED:
            for k, pdo in enumerate(self._rpdos):
                timer = self._raw(0x1400 + k, 5)
                if timer and pdo.rx_time is not None and self._t_us - pdo.rx_time > timer * 1000:
                    pdo.rx_time = None
                    self._raise_fault(0x8250)

    # ------------------------------------------------------------------ PDOs
    def _mapping(self, base: int, k: int) -> list[tuple[int, int, int]]:
        count = self._raw(base + k, 0)
        out = []
        for s in range(1, count + 1):
            raw = self._raw(base + k, s)
            out.append((raw >> 16, (raw >> 8) & 0xFF, raw & 0xFF))
        return out

    def _tpdo_payload(self, k: int) -> bytes:
        data = bytearray()
        for index, sub, _bits in self._mapping(0x1A00, k):
            entry = self._od[index].entries[sub]
            data += entry.encode(self._read_value(index, sub))
        return bytes(data)

    def _tpdo_valid(self, k: int) -> bool:
        return not self._raw(0x1800 + k, 1) & _PDO_INVALID

    def _send_tpdo(self, k: int, payload: bytes) -> None:
        pdo = self._tpdos[k]
        self._send(self._raw(0x1800 + k, 1) & 0x7FF, payload)
        pdo.last_sent = payload
        pdo.last_time_us = self._t_us
        pdo.pending = False

    def _event_tpdos(self, *, at_sync: bool) -> None:
        if self._nmt is not NmtState.OPERATIONAL:
            return
        for k, pdo in enumerate(self._tpdos):
            if not self._tpdo_valid(k) or self._raw(0x1800 + k, 2) < 254:
                continue
            payload = self._tpdo_payload(k)
            inhibit_us = self._raw(0x1800 + k, 3) * 100
            timer_us = self._raw(0x1800 + k, 5) * 1000
            since = None if pdo.last_time_us is None else self._t_us - pdo.last_time_us
            due = payload != pdo.last_sent or pdo.pending
            if at_sync and timer_us and since is not None and since >= timer_us:
                due = True
            if not due:
                continue
            if inhibit_us and since is not None and since < inhibit_us:
                pdo.pending = True
                continue
            self._send_tpdo(k, payload)

    def _on_rpdo(self, k: int, msg: can.Message) -> None:
        if msg.is_remote_frame:
            return
        mapping = self._mapping(0x1600, k)
        length = sum(bits for _i, _s, bits in mapping) // 8
        data = bytes(msg.data)
        if len(data) < length:
            self._send_emcy(0x8210, self._register() | 0x10)
            return
        if len(data) > length:
            self._send_emcy(0x8220, self._register() | 0x10)
            data = data[:length]
        pdo = self._rpdos[k]
        pdo.rx_time = self._t_us
        if self._raw(0x1400 + k, 2) <= 240:
            pdo.latched = data
        else:
            self._apply_rpdo(k, data)

    def _apply_rpdo(self, k: int, data: bytes) -> None:
        pos = 0
        for index, sub, bits in self._mapping(0x1600, k):
            chunk = data[pos : pos + bits // 8]
            pos += bits // 8
            try:
                self._write(index, sub, chunk, via_pdo=True)
            except _AbortError:
                self._pdo_rejects += 1

    def _on_sync(self, data: bytes) -> None:
        if len(data) > 1:
            self._send_emcy(0x8240, self._register() | 0x10)
            return
        self._sync_count += 1
        dt_us = self._cycle_us()
        # (1) the plant runs the period that ends with this SYNC
        self._advance(dt_us)
        self._t_us += dt_us
        # (2) supervision
        if self._state is _S.FAULT_REACTION_ACTIVE:
            self._fault_syncs_left -= 1
            if self._fault_syncs_left <= 0:
                self._set_state(_S.FAULT)
        if self._state is _S.QUICK_STOP_ACTIVE and self._v == 0.0 and self._raw(0x605A) <= 4:
            self._set_state(_S.SWITCH_ON_DISABLED)  # 12
        self._supervise()
        operational = self._nmt is NmtState.OPERATIONAL
        # (3) synchronous TPDOs
        if operational:
            for k, pdo in enumerate(self._tpdos):
                if not self._tpdo_valid(k):
                    continue
                ttype = self._raw(0x1800 + k, 2)
                if 1 <= ttype <= 240:
                    pdo.count += 1
                    if pdo.count >= ttype:
                        pdo.count = 0
                        self._send_tpdo(k, self._tpdo_payload(k))
                elif ttype == 0:
                    payload = self._tpdo_payload(k)
                    if payload != pdo.last_sent:
                        self._send_tpdo(k, payload)
                elif ttype == 252:
                    pdo.sample = self._tpdo_payload(k)
            self._event_tpdos(at_sync=True)
        # (4) latched RPDOs, then the CSP setpoint for the next period
        if operational:
            for k, pdo in enumerate(self._rpdos):
                if pdo.latched is not None:
                    data, pdo.latched = pdo.latched, None
                    self._apply_rpdo(k, data)
        if self._state is _S.OPERATION_ENABLED and self._mode_active == 8:
            self._d0 = self._d1
            if not self._raw(0x6040) & 0x0100:
                self._d1 = self._pu_to_inc(self._raw(0x607A))
        # (5) mode display delay
        self._mode_tick()
        # (6) heartbeat
        if self._hb_next_us is not None and self._t_us >= self._hb_next_us:
            self._send_heartbeat()
            period = self._raw(0x1017) * 1000
            while self._hb_next_us <= self._t_us:
                self._hb_next_us += period

    # ------------------------------------------------------------------ SDO server
    def _sdo_respond(self, data: bytes) -> None:
        self._send(0x580 + self._node_id, data.ljust(8, b"\x00"))

    def _sdo_abort(self, index: int, sub: int, code: int) -> None:
        self._sdo_xfer = None
        self._sdo_respond(bytes([0x80, index & 0xFF, index >> 8, sub]) + code.to_bytes(4, "little"))

    def _log(self, op: str, index: int, sub: int, data: bytes, code: int | None) -> None:
        self._sdo_log.append(SdoLogEntry(op, index, sub, bytes(data), code))

    def _on_sdo(self, data: bytes) -> None:
        if len(data) != 8:
            self._malformed += 1
            return
        cmd = data[0]
        ccs = cmd >> 5
        index, sub = data[1] | data[2] << 8, data[3]
        if ccs == 4:  # abort from the client
            self._sdo_xfer = None
            return
        if ccs == 1:
            self._sdo_initiate_download(cmd, index, sub, data)
        elif ccs == 0:
            self._sdo_download_segment(cmd, data)
        elif ccs == 2:
            self._sdo_initiate_upload(index, sub)
        elif ccs == 3:
            self._sdo_upload_segment(cmd)
        else:
            self._sdo_abort(index, sub, ABORT_COMMAND)

    def _check_writable(self, index: int, sub: int) -> _Entry:
        entry = self._entry(index, sub)
        if not entry.writable:
            raise _AbortError(ABORT_READ_ONLY)
        return entry

    def _sdo_initiate_download(self, cmd: int, index: int, sub: int, data: bytes) -> None:
        self._sdo_xfer = None
        expedited, sized = bool(cmd & 0x02), bool(cmd & 0x01)
        if expedited:
            payload = data[4 : 8 - ((cmd >> 2) & 3)] if sized else data[4:8]
            try:
                entry = self._check_writable(index, sub)
                if not sized and entry.dtype in _INT_TYPES:
                    payload = payload[: entry.bits // 8]
                self._write(index, sub, payload)
            except _AbortError as abort:
                self._log("download", index, sub, payload, abort.code)
                self._sdo_abort(index, sub, abort.code)
                return
            self._log("download", index, sub, payload, None)
            self._sdo_respond(bytes([0x60, index & 0xFF, index >> 8, sub]))
            return
        size = int.from_bytes(data[4:8], "little") if sized else None
        try:
            entry = self._check_writable(index, sub)
            if size is not None:
                if entry.dtype in _INT_TYPES and size != entry.bits // 8:
                    raise _AbortError(ABORT_LENGTH)
                if entry.dtype == VISIBLE_STRING and size > entry.maxlen:
                    raise _AbortError(ABORT_LENGTH)
        except _AbortError as abort:
            self._log("download", index, sub, b"", abort.code)
            self._sdo_abort(index, sub, abort.code)
            return
        self._sdo_xfer = _Download(index, sub, size)
        self._sdo_respond(bytes([0x60, index & 0xFF, index >> 8, sub]))

    def _sdo_download_segment(self, cmd: int, data: bytes) -> None:
        xfer = self._sdo_xfer
        if not isinstance(xfer, _Download):
            self._sdo_abort(0, 0, ABORT_COMMAND)
            return
        toggle = (cmd >> 4) & 1
        if toggle != xfer.toggle:
            self._log("download", xfer.index, xfer.sub, bytes(xfer.buf), ABORT_TOGGLE)
            self._sdo_abort(xfer.index, xfer.sub, ABORT_TOGGLE)
            return
        unused = (cmd >> 1) & 7
        xfer.buf += data[1 : 8 - unused]
        xfer.toggle ^= 1
        if not cmd & 0x01:
            self._sdo_respond(bytes([0x20 | toggle << 4]))
            return
        self._sdo_xfer = None
        payload = bytes(xfer.buf)
        try:
            if xfer.size is not None and len(payload) != xfer.size:
                raise _AbortError(ABORT_LENGTH)
            self._write(xfer.index, xfer.sub, payload)
        except _AbortError as abort:
            self._log("download", xfer.index, xfer.sub, payload, abort.code)
            self._sdo_abort(xfer.index, xfer.sub, abort.code)
            return
        self._log("download", xfer.index, xfer.sub, payload, None)
        self._sdo_respond(bytes([0x20 | toggle << 4]))

    def _sdo_initiate_upload(self, index: int, sub: int) -> None:
        self._sdo_xfer = None
        try:
            entry = self._entry(index, sub)
            if not entry.readable:
                raise _AbortError(ABORT_WRITE_ONLY)
            payload = entry.encode(self._read_value(index, sub))
        except _AbortError as abort:
            self._log("upload", index, sub, b"", abort.code)
            self._sdo_abort(index, sub, abort.code)
            return
        if index == 0x6061 and sub == 0:
            self._mode_tick()
        head = bytes([index & 0xFF, index >> 8, sub])
        if 1 <= len(payload) <= 4:
            self._log("upload", index, sub, payload, None)
            self._sdo_respond(bytes([0x43 | (4 - len(payload)) << 2]) + head + payload)
            return
        self._sdo_xfer = _Upload(index, sub, payload)
        self._sdo_respond(bytes([0x41]) + head + len(payload).to_bytes(4, "little"))

    def _sdo_upload_segment(self, cmd: int) -> None:
        xfer = self._sdo_xfer
        if not isinstance(xfer, _Upload):
            self._sdo_abort(0, 0, ABORT_COMMAND)
            return
        toggle = (cmd >> 4) & 1
        if toggle != xfer.toggle:
            self._log("upload", xfer.index, xfer.sub, b"", ABORT_TOGGLE)
            self._sdo_abort(xfer.index, xfer.sub, ABORT_TOGGLE)
            return
        chunk = xfer.data[xfer.pos : xfer.pos + 7]
        xfer.pos += len(chunk)
        xfer.toggle ^= 1
        last = xfer.pos >= len(xfer.data)
        self._sdo_respond(bytes([toggle << 4 | (7 - len(chunk)) << 1 | int(last)]) + chunk)
        if last:
            self._sdo_xfer = None
            self._log("upload", xfer.index, xfer.sub, xfer.data, None)

    # ------------------------------------------------------------------ dispatch
    def _handle(self, msg: can.Message) -> None:
        if msg.is_error_frame or msg.is_extended_id or msg.is_fd or msg.dlc > 8:
            self._malformed += 1
            return
        can_id = msg.arbitration_id
        data = bytes(msg.data)
        nmt = self._nmt
        n = self._node_id
        if can_id == 0x000:
            if not msg.is_remote_frame:
                self._on_nmt(data)
        elif can_id == 0x700 + n:
            if msg.is_remote_frame and nmt is not NmtState.INITIALISING:
                self._on_guard_rtr()
        elif 0x701 <= can_id <= 0x77F:
            if not msg.is_remote_frame:
                self._on_heartbeat(can_id - 0x700, data)
        elif can_id == self._raw(0x1005) & 0x7FF and not msg.is_remote_frame:
            if nmt in (NmtState.PRE_OPERATIONAL, NmtState.OPERATIONAL, NmtState.STOPPED):
                self._on_sync(data)
        elif can_id == 0x600 + n:
            if nmt in (NmtState.PRE_OPERATIONAL, NmtState.OPERATIONAL) and not msg.is_remote_frame:
                self._on_sdo(data)
        elif nmt is NmtState.OPERATIONAL:
            for k in range(4):
                cob = self._raw(0x1400 + k, 1)
                if not cob & _PDO_INVALID and cob & 0x7FF == can_id:
                    self._on_rpdo(k, msg)
                    break
                cob = self._raw(0x1800 + k, 1)
                if (
                    msg.is_remote_frame
                    and not cob & _PDO_INVALID
                    and not cob & _PDO_NO_RTR
                    and cob & 0x7FF == can_id
                ):
                    ttype = self._raw(0x1800 + k, 2)
                    sample = self._tpdos[k].sample
                    payload = sample if ttype == 252 and sample is not None else None
                    self._send_tpdo(k, payload or self._tpdo_payload(k))
                    break
        self._event_tpdos(at_sync=False)

    # ------------------------------------------------------------------ public API
    @property
    def node_id(self) -> int:
        """The node-ID (1..127)."""
        return self._node_id

    @property
    def quirks(self) -> ServoQuirks:
        """The drive model's quirks."""
        return self._quirks

    def process_pending(self) -> int:
        """Handle every frame already queued on the bus in the caller's thread; returns how many.

        Raises RuntimeError while the servo's own thread runs (``start``)."""
        if self._thread is not None:
            raise RuntimeError("process_pending() while the servo thread runs; call stop() first")
        count = 0
        while (msg := self._bus.recv(timeout=0)) is not None:
            with self._lock:
                self._handle(msg)
            count += 1
        return count

    def start(self, poll_s: float = 0.02) -> None:
        """Run the servo in its own daemon thread until ``stop()``."""
        if self._thread is not None:
            raise RuntimeError("the servo thread already runs")
        if not 1e-4 <= poll_s <= 1.0:
            raise ValueError(f"poll_s must be in [1e-4, 1.0] s, got {poll_s!r}")
        self._stop_event.clear()
        self._thread_error = None
        self._thread = threading.Thread(
            target=self._run, args=(poll_s,), name=f"canopen-servo-{self._node_id}", daemon=True
        )
        self._thread.start()

    def _run(self, poll_s: float) -> None:
        try:
            while not self._stop_event.is_set():
                msg = self._bus.recv(timeout=poll_s)
                if msg is not None:
                    with self._lock:
                        self._handle(msg)
        except BaseException as exc:  # noqa: BLE001 - reported by stop()
            self._thread_error = exc

    def stop(self) -> None:
        """Stop the thread started by ``start()``; re-raises (as RuntimeError) what ended it."""
        thread = self._thread
        if thread is None:
            return
        self._stop_event.set()
        thread.join(timeout=5.0)
        self._thread = None
        if self._thread_error is not None:
            error, self._thread_error = self._thread_error, None
            raise RuntimeError(f"servo thread failed: {error!r}") from error

    def reboot(self) -> None:
        """Power cycle: every object to its factory value, SWITCH ON DISABLED, boot-up message,
        PRE-OPERATIONAL. The shaft (position) stays where it is."""
        with self._lock:
            self._power_on()

    def inject_fault(self, code: int) -> None:
        """Raise a drive fault with EMCY error ``code`` (0x0001..0xFFFF)."""
        if not isinstance(code, int) or not 0x0001 <= code <= 0xFFFF:
            raise ValueError(f"code must be an int in [0x0001, 0xFFFF], got {code!r}")
        with self._lock:
            self._raise_fault(code)
            self._event_tpdos(at_sync=False)

    def warn(self, code: int) -> None:
        """Send a warning EMCY ``code`` (0x0001..0xFFFF): statusword bit 7 and the class bit of
        0x1001 set, no fault."""
        if not isinstance(code, int) or not 0x0001 <= code <= 0xFFFF:
            raise ValueError(f"code must be an int in [0x0001, 0xFFFF], got {code!r}")
        with self._lock:
            self._warning_code = code
            self._send_emcy(code, self._register())
            self._event_tpdos(at_sync=False)

    def clear_warning(self) -> None:
        """End the warning: statusword bit 7 clear, EMCY 0x0000."""
        with self._lock:
            if self._warning_code:
                self._warning_code = 0
                self._send_emcy(0x0000, self._register())
                self._event_tpdos(at_sync=False)

    def stop_heartbeat(self, stopped: bool = True) -> None:
        """Silence (True) or resume (False) heartbeats and node-guarding answers."""
        with self._lock:
            self._hb_stopped = bool(stopped)

    def write_eds(self, path: str | Path) -> Path:
        """Write this instance's EDS (CiA 306) to ``path``; returns the path."""
        with self._lock:
            text = self._eds_text()
        out = Path(path)
        out.write_text(text, encoding="ascii")
        return out

    def od_value(self, index: int, subindex: int = 0) -> int | bytes:
        """The value an SDO upload would return now (without side effects); KeyError if absent."""
        with self._lock:
            try:
                self._entry(index, subindex)
            except _AbortError as abort:
                raise KeyError(f"0x{index:04X}:{subindex} absent (0x{abort.code:08X})") from None
            return self._read_value(index, subindex)

    def mapping(self, kind: str, n: int) -> tuple[tuple[int, int, int], ...]:
        """The objects PDO ``n`` (1..4) of ``kind`` ("rpdo" or "tpdo") maps: (index, sub, bits)."""
        return self.pdo_config(kind, n).mapping

    def pdo_config(self, kind: str, n: int) -> PdoConfig:
        """The configuration of PDO ``n`` (1..4) of ``kind`` ("rpdo" or "tpdo")."""
        if kind not in ("rpdo", "tpdo"):
            raise ValueError(f"kind must be 'rpdo' or 'tpdo', got {kind!r}")
        if not isinstance(n, int) or not 1 <= n <= 4:
            raise ValueError(f"n must be an int in [1, 4], got {n!r}")
        comm, mapping = (0x1400, 0x1600) if kind == "rpdo" else (0x1800, 0x1A00)
        with self._lock:
            cob = self._raw(comm + n - 1, 1)
            return PdoConfig(
                cob_id_entry=cob,
                valid=not cob & _PDO_INVALID,
                can_id=cob & 0x7FF,
                trans_type=self._raw(comm + n - 1, 2),
                mapping=tuple(self._mapping(mapping, n - 1)),
            )

    @property
    def nmt_state(self) -> NmtState:
        """The NMT state."""
        with self._lock:
            return self._nmt

    @property
    def cia402_state(self) -> Cia402State:
        """The CiA 402 power state."""
        with self._lock:
            return self._state

    @property
    def statusword(self) -> int:
        """0x6041 now."""
        with self._lock:
            return self._statusword()

    @property
    def position(self) -> float:
        """Actual position in position units (unrounded)."""
        with self._lock:
            return self._inc_to_pu(self._x)

    @property
    def shaft(self) -> float:
        """The shaft's place in internal increments (where the marks and limit switches are;
        homing does not change it)."""
        with self._lock:
            return self._x

    @property
    def velocity(self) -> float:
        """Actual velocity in position units per second (unrounded, 0x607E bit 6 applied)."""
        with self._lock:
            return self._vel_sign() * self._v / self._factor()

    @property
    def mode_display(self) -> int:
        """The active mode of operation (what 0x6061 shows)."""
        with self._lock:
            return self._mode_active

    @property
    def error_code(self) -> int:
        """0x603F now."""
        with self._lock:
            return self._error_code

    @property
    def time_s(self) -> float:
        """Servo time [s]: the sum of the cycle periods of the SYNCs received."""
        with self._lock:
            return self._t_us * 1e-6

    @property
    def sync_count(self) -> int:
        """SYNCs received and processed."""
        with self._lock:
            return self._sync_count

    @property
    def sdo_log(self) -> tuple[SdoLogEntry, ...]:
        """Every SDO request finished so far, oldest first."""
        with self._lock:
            return tuple(self._sdo_log)

    @property
    def malformed_frames(self) -> int:
        """Frames dropped as malformed (error/FD/extended frames, bad NMT or SDO length)."""
        with self._lock:
            return self._malformed

    @property
    def pdo_rejects(self) -> int:
        """RPDO values dropped by the object dictionary's rules."""
        with self._lock:
            return self._pdo_rejects

    # ------------------------------------------------------------------ EDS
    def _eds_text(self) -> str:
        n = self._node_id
        vendor, product, revision, _serial = self._identity
        lines = [
            "[FileInfo]",
            f"FileName=cs_servo_{n}.eds",
            "FileVersion=1",
            "FileRevision=0",
            "EDSVersion=4.0",
            "Description=CS-402 servo drive (independent CiA 402 test peer)",
            "CreationTime=12:00PM",
            "CreationDate=01-01-2025",
            "CreatedBy=CS",
            "",
            "[DeviceInfo]",
            "VendorName=CS Drives",
            f"VendorNumber=0x{vendor:08X}",
            f"ProductName={self._device_name.decode('ascii')}",
            f"ProductNumber=0x{product:08X}",
            f"RevisionNumber=0x{revision:08X}",
            "OrderCode=CS-402-01",
        ]
        for rate in (10, 20, 50, 125, 250, 500, 800, 1000):
            lines.append(f"BaudRate_{rate}={int(rate >= 125)}")
        lines += [
            "SimpleBootUpMaster=0",
            "SimpleBootUpSlave=1",
            "Granularity=8",
            "DynamicChannelsSupported=0",
            "GroupMessaging=0",
            "NrOfRXPDO=4",
            "NrOfTXPDO=4",
            "LSS_Supported=0",
            "",
            "[DummyUsage]",
        ]
        lines += [f"Dummy{k:04d}=0" for k in range(1, 8)]
        lines += ["", "[Comments]", "Lines=0", ""]
        mandatory = [i for i in (0x1000, 0x1001, 0x1018) if i in self._od]
        optional = [i for i in sorted(self._od) if i not in mandatory and not 0x2000 <= i < 0x6000]
        manufacturer = [i for i in sorted(self._od) if 0x2000 <= i < 0x6000]
        for title, group in (
            ("MandatoryObjects", mandatory),
            ("OptionalObjects", optional),
            ("ManufacturerObjects", manufacturer),
        ):
            lines.append(f"[{title}]")
            lines.append(f"SupportedObjects={len(group)}")
            lines += [f"{k}=0x{index:04X}" for k, index in enumerate(group, 1)]
            lines.append("")
        for index in sorted(self._od):
            obj = self._od[index]
            if obj.otype == _VAR:
                lines.append(f"[{index:04X}]")
                lines += self._eds_entry(obj.name, obj.entries[0], _VAR)
            else:
                lines += [
                    f"[{index:04X}]",
                    f"ParameterName={obj.name}",
                    f"ObjectType=0x{obj.otype:X}",
                    f"SubNumber={len(obj.entries)}",
                    "",
                ]
                for sub, entry in sorted(obj.entries.items()):
                    lines.append(f"[{index:04X}sub{sub:X}]")
                    lines += self._eds_entry(entry.name, entry, _VAR)
        return "\n".join(lines) + "\n"

    def _eds_entry(self, name: str, entry: _Entry, otype: int) -> list[str]:
        out = [
            f"ParameterName={name}",
            f"ObjectType=0x{otype:X}",
            f"DataType=0x{entry.dtype:04X}",
            f"AccessType={entry.access}",
        ]
        default = entry.default
        if isinstance(default, bytes):
            out.append(f"DefaultValue={default.decode('ascii')}")
        elif entry.node_rel:
            out.append(f"DefaultValue=$NODEID+0x{default - self._node_id:X}")
        elif entry.dtype in (INTEGER8, INTEGER16, INTEGER32):
            out.append(f"DefaultValue={default}")
        else:
            out.append(f"DefaultValue=0x{default:X}")
        if entry.low is not None:
            out.append(f"LowLimit={entry.low}")
        if entry.high is not None:
            out.append(f"HighLimit={entry.high}")
        out.append(f"PDOMapping={int(entry.pdo)}")
        out.append("")
        return out
