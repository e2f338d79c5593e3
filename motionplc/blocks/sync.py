"""Master/slave FBs (PLCopen Part 1 multi-axis blocks): MC_GearIn, MC_GearOut, MC_GearInPos,
MC_PhasingAbsolute, MC_PhasingRelative, MC_CamIn, MC_CamOut.

Each has a ``master`` and a ``slave`` input (Axis; ``slave`` is the FB's axis for the Execute
machinery: ``fb.axis is fb.slave``). The kernel side, its rules and guarantees are in
:mod:`motionplc.blocks.sync_job`. In short:

* MC_GearIn: a velocity ratio ``ratio_numerator / ratio_denominator``; the slave ramps
  jerk-limited (the FB's Acceleration / Deceleration / Jerk, 0 = the slave's limits) from any
  state to ratio x the master's velocity, never jumping in v or a; ``in_gear`` from then on,
  with the position locked (slave = c + ratio x master, zero error to rounding); the distance
  lost while synchronising is not caught up. A new GearIn changes the ratio the same way.
* MC_GearOut / MC_CamOut: the slave keeps its velocity (ContinuousMotion); Done at once; the
  coupling FB shows CommandAborted. Outside SynchronizedMotion: the state's ErrorID; in
  SynchronizedMotion without a coupling (an axes group): NOT_SYNCHRONIZED.
* MC_GearInPos: position gearing: once ``in_sync``, slave = slave_sync_position + ratio x
  (master - master_sync_position); ``start_sync`` while catching up. With
  ``master_start_distance`` the previous motion goes on until the master is within that
  distance before ``master_sync_position`` (in its direction of motion).
* MC_PhasingAbsolute / MC_PhasingRelative (Beckhoff / CODESYS names): shift the master position
  the slave sees (absolute: to ``phase_shift``; relative: by it, accumulating), jerk-limited
  with Velocity / Acceleration / Deceleration / Jerk; Done when the shift is made; the slave's
  state does not change; NOT_SYNCHRONIZED without a coupling; CommandAborted when the coupling
  ends first. Outputs ``absolute_phase_shift`` / ``covered_phase_shift``.
* MC_CamIn: ``cam_table_id`` from MC_CamTableSelect (its ``table``, ``periodic``,
  ``master_absolute``, ``slave_absolute``); table coordinate x = master_scaling x master +
  master_offset, slave = slave_offset + slave_scaling x y(x) (as MC_CamTableSelect's limit
  check reads them; relative master: x starts at
  the table's start where the coupling starts; relative slave or StartMode RELATIVE: the table
  is shifted to the slave's position). The slave is brought onto the table jerk-limited (every
  StartMode: motionplc never jumps), then ``in_sync``; ``end_of_profile`` is a one-scan pulse at
  each end of a period (either direction) or the end of a non-periodic table (the slave holds
  the table's last value there). The cam at the master's motion is checked against the slave's
  v/a/j limits at Execute (SLAVE_LIMITS_EXCEEDED, nothing moves) and supervised every cycle.

Input ranges (checked at Execute, ``error_text`` names the input and its range): ratio_numerator
an int in [-32768, 32767], ratio_denominator an int in [1, 65535] (INVALID_RATIO);
master_value_source a Source (COMMANDED_VALUE works like SET_VALUE); Acceleration,
Deceleration, Jerk, Velocity as for the moves (0 = the slave's limit); positions, distances and
offsets finite within +-1e12; scalings finite and non-zero with |scaling| in [1e-9, 1e9]
(INVALID_SCALING); master_start_distance >= 0.
"""

from __future__ import annotations

import math
from typing import Any

from motionplc.blocks.axis import POSITION_MAX, Axis, Handle
from motionplc.blocks.base import ExecuteFB, InputError, MotionFB, check_number
from motionplc.blocks.enums import BufferMode, ErrorID, Source, StartMode, SyncMode
from motionplc.blocks.motion import InputChecks, _MoveFB
from motionplc.blocks.motion_queue import Status
from motionplc.blocks.sync_job import PhaseHandle, SyncCommand, SyncHandle, request_phasing

__all__ = [
    "MC_CamIn",
    "MC_CamOut",
    "MC_GearIn",
    "MC_GearInPos",
    "MC_GearOut",
    "MC_PhasingAbsolute",
    "MC_PhasingRelative",
]

_INT_MIN, _INT_MAX, _UINT_MAX = -32768, 32767, 65535
_SCALE_MIN, _SCALE_MAX = 1e-9, 1e9


class _SlaveFB:
    """``slave`` is the FB's axis (the Execute machinery's ``axis``)."""

    axis: Axis | None

    @property
    def slave(self) -> Axis | None:
        """The slave axis (the FB's axis)."""
        return self.axis

    @slave.setter
    def slave(self, value: Axis | None) -> None:
        self.axis = value


def _check_master(fb: Any, axis: Any) -> Axis:
    m = fb.master
    if not isinstance(m, Axis) or m is axis:
        raise InputError(
            ErrorID.INVALID_MASTER,
            f"master must be an Axis other than the slave, got {m!r}",
        )
    return m


def _int_input(name: str, value: Any, lo: int, hi: int) -> int:
    if isinstance(value, bool) or not isinstance(value, int) or not lo <= value <= hi:
        raise InputError(
            ErrorID.INVALID_RATIO, f"{name} must be an integer in [{lo}, {hi}], got {value!r}"
        )
    return value


def _pos(name: str, value: Any, eid: ErrorID = ErrorID.INVALID_POSITION) -> float:
    return check_number(name, value, eid, -POSITION_MAX, POSITION_MAX)


def _source(value: Any) -> Source:
    if not isinstance(value, Source):
        raise InputError(
            ErrorID.INVALID_MASTER,
            f"master_value_source must be a Source (SET_VALUE / ACTUAL_VALUE), got {value!r}",
        )
    return value


class _SyncFB(_SlaveFB, InputChecks, MotionFB):
    """Common pins of the coupling FBs."""

    def __init__(self, name: str | None = None, **inputs: Any) -> None:
        self.master: Axis | None = None
        self.master_value_source = Source.SET_VALUE
        self.buffer_mode = BufferMode.ABORTING
        super().__init__(name, **inputs)

    def _in_master(self, axis: Any) -> Axis:
        return _check_master(self, axis)

    def _in_master_value_source(self, axis: Any) -> Source:
        return _source(self.master_value_source)

    _in_buffer_mode = _MoveFB._in_buffer_mode


class MC_GearIn(_SyncFB):
    """Velocity gearing ratio_numerator / ratio_denominator to the master (see the module
    docstring): ``in_gear`` once synchronised; the slave is in SynchronizedMotion."""

    INPUTS = (
        "master",
        "slave",
        "execute",
        "ratio_numerator",
        "ratio_denominator",
        "master_value_source",
        "acceleration",
        "deceleration",
        "jerk",
        "buffer_mode",
    )
    OUTPUTS = ("busy", "active", "in_gear", "command_aborted", "error")
    _BUSY_HOOK_UNTRACED = True  # _busy_outputs sets _dirty itself

    def __init__(self, name: str | None = None, **inputs: Any) -> None:
        self.ratio_numerator = 1
        self.ratio_denominator = 1
        self.acceleration = 0.0
        self.deceleration = 0.0
        self.jerk = 0.0
        self.in_gear = False
        super().__init__(name, **inputs)

    def _in_ratio_numerator(self, axis: Any) -> int:
        return _int_input("ratio_numerator", self.ratio_numerator, _INT_MIN, _INT_MAX)

    def _in_ratio_denominator(self, axis: Any) -> int:
        return _int_input("ratio_denominator", self.ratio_denominator, 1, _UINT_MAX)

    _in_acceleration = _MoveFB._in_acceleration
    _in_deceleration = _MoveFB._in_deceleration
    _in_jerk = _MoveFB._in_jerk

    def _start(self, axis: Axis) -> Handle:
        master = self._in_master(axis)
        num = self._in_ratio_numerator(axis)
        den = self._in_ratio_denominator(axis)
        src = self._in_master_value_source(axis)
        acc, dec, jerk = (
            self._in_acceleration(axis),
            self._in_deceleration(axis),
            self._in_jerk(axis),
        )
        mode = self._in_buffer_mode(axis)
        return axis.submit(
            SyncCommand(
                kind="gear",
                mode=mode,
                acceleration=acc,
                deceleration=dec,
                jerk=jerk,
                master=master,
                ratio=num / den,
                source=src,
            )
        )

    def _clear(self) -> None:
        super()._clear()
        self.in_gear = False

    def _terminal_outputs(self, h: Handle) -> None:
        self.in_gear = False

    def _busy_outputs(self, h: Handle) -> None:
        ig = h.in_target and self.active
        if ig != self.in_gear:
            self.in_gear = ig
            self._dirty = True


class _OutFB(_SlaveFB, InputChecks, ExecuteFB):
    """MC_GearOut / MC_CamOut: disengage; the slave keeps its velocity."""

    INPUTS = ("slave", "execute")
    OUTPUTS = ("busy", "done", "error")

    def _start(self, axis: Axis) -> Handle:
        return axis.submit(SyncCommand(kind="syncout"))


class MC_GearOut(_OutFB):
    """Disengage the slave from its coupling: it keeps its velocity (ContinuousMotion)."""


class MC_CamOut(_OutFB):
    """Disengage the slave from its cam: it keeps its velocity (ContinuousMotion)."""


class MC_GearInPos(_SyncFB):
    """Position gearing from a sync point (see the module docstring): ``start_sync`` while the
    slave catches up, ``in_sync`` once slave = slave_sync_position + ratio x (master -
    master_sync_position)."""

    INPUTS = (
        "master",
        "slave",
        "execute",
        "ratio_numerator",
        "ratio_denominator",
        "master_sync_position",
        "slave_sync_position",
        "sync_mode",
        "master_start_distance",
        "master_value_source",
        "velocity",
        "acceleration",
        "deceleration",
        "jerk",
        "buffer_mode",
    )
    OUTPUTS = ("busy", "active", "start_sync", "in_sync", "command_aborted", "error")
    _BUSY_HOOK_UNTRACED = True

    def __init__(self, name: str | None = None, **inputs: Any) -> None:
        self.ratio_numerator = 1
        self.ratio_denominator = 1
        self.master_sync_position = 0.0
        self.slave_sync_position = 0.0
        self.sync_mode = SyncMode.SHORTEST
        self.master_start_distance = 0.0
        self.velocity = 0.0
        self.acceleration = 0.0
        self.deceleration = 0.0
        self.jerk = 0.0
        self.start_sync = False
        self.in_sync = False
        super().__init__(name, **inputs)

    _in_ratio_numerator = MC_GearIn._in_ratio_numerator
    _in_ratio_denominator = MC_GearIn._in_ratio_denominator
    _in_acceleration = _MoveFB._in_acceleration
    _in_deceleration = _MoveFB._in_deceleration
    _in_jerk = _MoveFB._in_jerk

    def _in_velocity(self, axis: Any) -> float:
        if self.velocity == 0.0:
            return 0.0  # the slave's limit
        return _MoveFB._in_velocity(self, axis)  # type: ignore[arg-type]

    def _in_master_sync_position(self, axis: Any) -> float:
        return _pos("master_sync_position", self.master_sync_position)

    def _in_slave_sync_position(self, axis: Any) -> float:
        return _pos("slave_sync_position", self.slave_sync_position)

    def _in_master_start_distance(self, axis: Any) -> float:
        return check_number(
            "master_start_distance",
            self.master_start_distance,
            ErrorID.INVALID_DISTANCE,
            0.0,
            POSITION_MAX,
        )

    def _in_sync_mode(self, axis: Any) -> SyncMode:
        if not isinstance(self.sync_mode, SyncMode):
            raise InputError(
                ErrorID.INVALID_SYNC_MODE, f"sync_mode must be a SyncMode, got {self.sync_mode!r}"
            )
        return self.sync_mode

    def _start(self, axis: Axis) -> Handle:
        master = self._in_master(axis)
        num = self._in_ratio_numerator(axis)
        den = self._in_ratio_denominator(axis)
        return axis.submit(
            SyncCommand(
                kind="gearpos",
                mode=self._in_buffer_mode(axis),
                velocity=self._in_velocity(axis),
                acceleration=self._in_acceleration(axis),
                deceleration=self._in_deceleration(axis),
                jerk=self._in_jerk(axis),
                master=master,
                ratio=num / den,
                source=self._in_master_value_source(axis),
                master_sync=self._in_master_sync_position(axis),
                slave_sync=self._in_slave_sync_position(axis),
                start_distance=self._in_master_start_distance(axis),
                sync_mode=self._in_sync_mode(axis),
            )
        )

    def _clear(self) -> None:
        super()._clear()
        self.in_sync = self.start_sync = False

    def _terminal_outputs(self, h: Handle) -> None:
        self.in_sync = self.start_sync = False

    def _busy_outputs(self, h: Handle) -> None:
        ins = h.in_target and self.active
        ss = isinstance(h, SyncHandle) and h.start_sync and self.active
        if ins != self.in_sync or ss != self.start_sync:
            self.in_sync, self.start_sync = ins, ss
            self._dirty = True


class _PhasingFB(_SlaveFB, InputChecks, MotionFB):
    """Common pins of MC_PhasingAbsolute / MC_PhasingRelative."""

    INPUTS = (
        "master",
        "slave",
        "execute",
        "phase_shift",
        "velocity",
        "acceleration",
        "deceleration",
        "jerk",
        "buffer_mode",
    )
    _RELATIVE = False
    PARALLEL = True  # Active beside the coupling FB (spec 2.1: parallel FBs)

    def __init__(self, name: str | None = None, **inputs: Any) -> None:
        self.master: Axis | None = None
        self.phase_shift = 0.0
        self.velocity = 0.0
        self.acceleration = 0.0
        self.deceleration = 0.0
        self.jerk = 0.0
        self.buffer_mode = BufferMode.ABORTING
        self.absolute_phase_shift = 0.0
        self.covered_phase_shift = 0.0
        super().__init__(name, **inputs)

    def _in_master(self, axis: Any) -> Axis:
        return _check_master(self, axis)

    def _in_phase_shift(self, axis: Any) -> float:
        return _pos("phase_shift", self.phase_shift, ErrorID.INVALID_DISTANCE)

    # Velocity, Acceleration, Deceleration, Jerk are the shift's: a motion of the master (as
    # the slave sees it), so in the master's units and within the master's ranges (0 = the
    # master's limit); before the master is known (a sequence's static check) any positive
    # finite value passes
    def _dyn_check(self, axis: Any, check: Any) -> float:
        m = self.master
        if isinstance(m, Axis):
            return float(check(self, m))
        return float(check(self, _AnyRange()))

    def _in_velocity(self, axis: Any) -> float:
        if self.velocity == 0.0:
            return 0.0  # the master's limit
        return self._dyn_check(axis, _MoveFB._in_velocity)

    def _in_acceleration(self, axis: Any) -> float:
        return self._dyn_check(axis, _MoveFB._in_acceleration)

    def _in_deceleration(self, axis: Any) -> float:
        return self._dyn_check(axis, _MoveFB._in_deceleration)

    def _in_jerk(self, axis: Any) -> float:
        return self._dyn_check(axis, _MoveFB._in_jerk)

    _in_buffer_mode = _MoveFB._in_buffer_mode

    def _start(self, axis: Axis) -> Handle:
        master = self._in_master(axis)
        shift = self._in_phase_shift(axis)
        v = self._in_velocity(axis)
        acc, dec, jerk = (
            self._in_acceleration(axis),
            self._in_deceleration(axis),
            self._in_jerk(axis),
        )
        self._in_buffer_mode(axis)
        h = request_phasing(axis, shift, self._RELATIVE, v, acc, dec, jerk)
        if isinstance(h, PhaseHandle) and h.coupling is not None:
            job = axis.mq.active
            if job is not None and getattr(job, "master", master) is not master:
                h._finish(
                    Status.ERROR,
                    ErrorID.INVALID_MASTER,
                    "master is not the master of the slave's coupling",
                )
        return h

    def _outputs(self, h: Handle) -> None:
        if isinstance(h, PhaseHandle):
            self.absolute_phase_shift = h.phase
            self.covered_phase_shift = h.covered

    def _terminal_outputs(self, h: Handle) -> None:
        self._outputs(h)

    def _busy_outputs(self, h: Handle) -> None:
        self._outputs(h)


class _AnyRange:
    """A stand-in axis whose ranges are all positive finite numbers (the shift's dynamics
    checked before the master is known)."""

    class cfg:  # noqa: N801 - mimics Axis.cfg
        @staticmethod
        def velocity_range() -> tuple[float, float]:
            return 0.0, math.inf

        @staticmethod
        def acceleration_range() -> tuple[float, float]:
            return 0.0, math.inf

        @staticmethod
        def jerk_range() -> tuple[float, float]:
            return 0.0, math.inf


class MC_PhasingAbsolute(_PhasingFB):
    """Shift the master position the slave sees to ``phase_shift`` (jerk-limited); Done when
    reached; ``absolute_phase_shift`` is the shift now."""


class MC_PhasingRelative(_PhasingFB):
    """Shift the master position the slave sees by ``phase_shift`` more (shifts accumulate);
    ``covered_phase_shift`` is what this command has shifted so far."""

    _RELATIVE = True


def _scaling(name: str, value: Any) -> float:
    ok = isinstance(value, (int, float)) and not isinstance(value, bool)
    x = float(value) if ok else math.nan
    if not (math.isfinite(x) and _SCALE_MIN <= abs(x) <= _SCALE_MAX):
        raise InputError(
            ErrorID.INVALID_SCALING,
            f"{name} must be a finite number with |{name}| in [{_SCALE_MIN:g}, {_SCALE_MAX:g}], "
            f"got {value!r}",
        )
    return x


class MC_CamIn(_SyncFB):
    """Electronic cam: the slave follows the cam table of ``cam_table_id`` over the master (see
    the module docstring); ``in_sync`` once on the table, ``end_of_profile`` pulses."""

    INPUTS = (
        "master",
        "slave",
        "execute",
        "cam_table_id",
        "master_offset",
        "slave_offset",
        "master_scaling",
        "slave_scaling",
        "master_start_distance",
        "master_sync_position",
        "start_mode",
        "master_value_source",
        "buffer_mode",
    )
    OUTPUTS = ("busy", "active", "in_sync", "end_of_profile", "command_aborted", "error")
    _BUSY_HOOK_UNTRACED = True

    def __init__(self, name: str | None = None, **inputs: Any) -> None:
        self.cam_table_id: Any = None
        self.master_offset = 0.0
        self.slave_offset = 0.0
        self.master_scaling = 1.0
        self.slave_scaling = 1.0
        self.master_start_distance = 0.0
        self.master_sync_position = 0.0
        self.start_mode = StartMode.ABSOLUTE
        self.in_sync = False
        self.end_of_profile = False
        self._eop_seen = 0
        super().__init__(name, **inputs)

    def _in_cam_table_id(self, axis: Any) -> Any:
        cam = self.cam_table_id
        tab = getattr(cam, "table", None)
        if tab is None or not all(
            hasattr(cam, a) for a in ("periodic", "master_absolute", "slave_absolute")
        ):
            raise InputError(
                ErrorID.INVALID_CAM_TABLE,
                f"cam_table_id must be the CamTableID of MC_CamTableSelect, got {cam!r}",
            )
        if not all(hasattr(tab, a) for a in ("at", "slave_peaks", "master_start", "master_end")):
            raise InputError(ErrorID.INVALID_CAM_TABLE, f"not a cam table: {tab!r}")
        return cam

    def _in_master_offset(self, axis: Any) -> float:
        return _pos("master_offset", self.master_offset)

    def _in_slave_offset(self, axis: Any) -> float:
        return _pos("slave_offset", self.slave_offset)

    def _in_master_scaling(self, axis: Any) -> float:
        return _scaling("master_scaling", self.master_scaling)

    def _in_slave_scaling(self, axis: Any) -> float:
        return _scaling("slave_scaling", self.slave_scaling)

    _in_master_start_distance = MC_GearInPos._in_master_start_distance
    _in_master_sync_position = MC_GearInPos._in_master_sync_position

    def _in_start_mode(self, axis: Any) -> StartMode:
        if not isinstance(self.start_mode, StartMode):
            raise InputError(
                ErrorID.INVALID_SYNC_MODE,
                f"start_mode must be a StartMode, got {self.start_mode!r}",
            )
        return self.start_mode

    def _start(self, axis: Axis) -> Handle:
        master = self._in_master(axis)
        self._eop_seen = 0
        return axis.submit(
            SyncCommand(
                kind="cam",
                mode=self._in_buffer_mode(axis),
                master=master,
                source=self._in_master_value_source(axis),
                cam=self._in_cam_table_id(axis),
                master_offset=self._in_master_offset(axis),
                slave_offset=self._in_slave_offset(axis),
                master_scaling=self._in_master_scaling(axis),
                slave_scaling=self._in_slave_scaling(axis),
                start_distance=self._in_master_start_distance(axis),
                master_sync=self._in_master_sync_position(axis),
                start_mode=self._in_start_mode(axis),
            )
        )

    def _clear(self) -> None:
        super()._clear()
        self.in_sync = self.end_of_profile = False

    def _terminal_outputs(self, h: Handle) -> None:
        self.in_sync = False
        self._eop(h)

    def _eop(self, h: Handle) -> None:
        n = h.eop if isinstance(h, SyncHandle) else 0
        eop = n != self._eop_seen
        self._eop_seen = n
        if eop != self.end_of_profile:
            self.end_of_profile = eop
            self._dirty = True

    def _busy_outputs(self, h: Handle) -> None:
        ins = h.in_target and self.active
        if ins != self.in_sync:
            self.in_sync = ins
            self._dirty = True
        self._eop(h)
