"""MC_Jog: move the axis while a button is held, or one inching step per press.

PLCopen has no MC_Jog in Part 1; the block follows the vendors' (Beckhoff Tc2_MC2 MC_Jog,
CODESYS SMC_Jog): inputs ``jog_forward`` / ``jog_backward`` and a :class:`JogMode`.

Rules pinned here:

* Continuous modes (STANDARD_SLOW, STANDARD_FAST, CONTINUOUS): a rising edge of one button
  starts a velocity move in its direction (ContinuousMotion while it is held); releasing it
  brakes the axis jerk-limited (MC_Halt: DiscreteMotion, then Standstill); ``done`` when the
  axis is at rest. STANDARD_SLOW / STANDARD_FAST take the axis' jog velocities
  (YAML ``axes.<name>.jog_velocity_slow`` / ``jog_velocity_fast``, ``AxisConfig`` fields of the
  same names; default 10 % / 50 % of the speed limit of the direction); CONTINUOUS takes
  ``velocity``.
* Software limits (linear axes): jogging towards a configured limit is a move to the limit at
  the jog velocity (DiscreteMotion instead of ContinuousMotion), so the axis stops exactly at
  the limit (``done``, no axis error), like a move; standing at the limit, jogging further out
  is refused (Error MOVE_BEYOND_SW_LIMIT).
* Inching modes: each rising edge moves one step at ``velocity``: INCHING by ``position``,
  INCHING_MODULO to the next multiple of ``position`` in that direction (from a multiple: the
  one after). A press while the previous step still runs queues the step behind it (buffered,
  counted from its target), so the steps are exact. ``done`` at the end of the step (held while
  the button is held).
* Both buttons: a rising edge of one while the other is held gives Error INVALID_JOG_MODE, and a
  jog motion of this FB brakes (MC_Halt); the error stays until both are released.
* Switching directions without a gap (one button released and the other pressed in the same
  scan) starts the new jog while this FB is busy; once it shows Done / Error / CommandAborted,
  a press counts only after both buttons were released (Busy rises only with Execute, i.e.
  ``jog_forward OR jog_backward``, rising). The same holds for the both-buttons error.
* Outputs as an Execute FB whose Execute is ``jog_forward OR jog_backward`` (``execute`` mirrors
  it): busy while moving (also while braking after the release), active while the jog's command
  controls the axis, done / error / command_aborted held while a button is held, else for one
  scan. Another command taking over the axis gives CommandAborted.
* Acceleration, Deceleration, Jerk: 0 means the axis' limit (as the moves).
"""

from __future__ import annotations

import math
from typing import Any

from motionplc.blocks.axis import Axis, Command, Handle, Status
from motionplc.blocks.base import InputError, MotionFB, _failed, check_number
from motionplc.blocks.enums import BufferMode, Direction, ErrorID, JogMode
from motionplc.blocks.motion import POSITION_MAX, InputChecks, _MoveFB

__all__ = ["MC_Jog", "jog_velocity"]

_CONTINUOUS = (JogMode.STANDARD_SLOW, JogMode.STANDARD_FAST, JogMode.CONTINUOUS)
_FRACTION = {JogMode.STANDARD_SLOW: 0.1, JogMode.STANDARD_FAST: 0.5}


def jog_velocity(cfg: Any, mode: JogMode, s: float) -> float:
    """The jog speed of a STANDARD mode in direction ``s``: the axis' configured jog velocity
    (``AxisConfig.jog_velocity_slow`` / ``jog_velocity_fast``; MC_Jog refuses it if it is above
    the direction's speed limit) or 10 % / 50 % of the direction's speed limit."""
    key = "jog_velocity_slow" if mode is JogMode.STANDARD_SLOW else "jog_velocity_fast"
    v = getattr(cfg, key, None)
    if v is not None:
        return float(v)
    return _FRACTION[mode] * (cfg.v_max if s >= 0.0 else cfg.v_neg)


class MC_Jog(InputChecks, MotionFB):
    """Jog an axis with two buttons (see the module docstring for the rules)."""

    INPUTS = (
        "axis",
        "jog_forward",
        "jog_backward",
        "mode",
        "position",
        "velocity",
        "acceleration",
        "deceleration",
        "jerk",
    )

    def __init__(self, name: str | None = None, **inputs: Any) -> None:
        self.jog_forward = False
        self.jog_backward = False
        self.mode = JogMode.STANDARD_SLOW
        self.position = 0.0  # inching distance
        self.velocity = 0.0
        self.acceleration = 0.0
        self.deceleration = 0.0
        self.jerk = 0.0
        self._pf = False
        self._pb = False
        self._running = False  # a continuous jog of this FB runs (halt on release)
        self._dir = 0.0
        self._inch: Handle | None = None  # the last inching step
        self._inch_target = 0.0
        self._dec = 0.0
        self._jrk = 0.0
        super().__init__(name, **inputs)

    # -- input checks ----
    def _in_mode(self, axis: Any) -> JogMode:
        if not isinstance(self.mode, JogMode):
            raise InputError(
                ErrorID.INVALID_JOG_MODE,
                f"mode must be a JogMode ({', '.join(m.name for m in JogMode)}), got {self.mode!r}",
            )
        return self.mode

    def _in_velocity(self, axis: Any) -> float:
        if not isinstance(self.mode, JogMode) or self.mode in _FRACTION:
            return 0.0  # the axis' jog velocities (or the mode is itself invalid)
        return _MoveFB._in_velocity(self, axis)  # type: ignore[arg-type]

    def _in_position(self, axis: Any) -> float:
        if not (isinstance(self.mode, JogMode) and self.mode not in _CONTINUOUS):
            return 0.0  # only the inching modes use it
        x = check_number(
            "position", self.position, ErrorID.INVALID_DISTANCE, 0.0, POSITION_MAX, lo_open=True
        )
        m = axis.cfg.modulo
        if m is not None and self.mode is JogMode.INCHING_MODULO and x > m:
            raise InputError(
                ErrorID.INVALID_DISTANCE,
                f"position (the inching step) must be in (0, {m:g}] on this modulo axis",
            )
        return x

    _in_acceleration = _MoveFB._in_acceleration
    _in_deceleration = _MoveFB._in_deceleration
    _in_jerk = _MoveFB._in_jerk

    # -- commands ----
    def _jog_command(self, axis: Axis, s: float) -> Command:
        mode = self._in_mode(axis)
        v = self._in_velocity(axis)
        dist = self._in_position(axis)
        acc = self._in_acceleration(axis)
        dec = self._in_deceleration(axis)
        jerk = self._in_jerk(axis)
        self._dec, self._jrk = dec, jerk
        cfg = axis.cfg
        side = cfg.v_max if s > 0.0 else cfg.v_neg
        if mode in _FRACTION:
            v = jog_velocity(cfg, mode, s)
            if v > side:
                key = "jog_velocity_slow" if mode is JogMode.STANDARD_SLOW else "jog_velocity_fast"
                raise InputError(
                    ErrorID.INVALID_VELOCITY,
                    f"the axis' {key} {v:g} is above its speed limit {side:g} of the jog "
                    "direction (lowered by MC_WriteParameter?)",
                )
        elif v > side:
            raise InputError(
                ErrorID.INVALID_VELOCITY,
                f"velocity {v:g} above the axis' speed limit {side:g} of the jog direction",
            )
        dyn = {"acceleration": acc, "deceleration": dec, "jerk": jerk}
        if mode in _CONTINUOUS:
            limit = cfg.sw_limit_pos if s > 0.0 else cfg.sw_limit_neg
            if cfg.modulo is None and limit is not None:
                if s * axis.p >= s * limit - 1e-9 * (1.0 + abs(limit)):
                    raise InputError(
                        ErrorID.MOVE_BEYOND_SW_LIMIT,
                        f"the axis is at the software limit {limit:.9g}: jogging "
                        f"{'forward' if s > 0 else 'backward'} would move it further out",
                    )
                return Command(kind="absolute", position=limit, velocity=v, **dyn)
            return Command(kind="velocity", velocity=s * v, **dyn)
        # inching: from the previous step's target while it still runs (queued behind it)
        prev = self._inch
        chained = prev is not None and not prev.terminal
        base = self._inch_target if chained else axis.p
        mode_b = BufferMode.BUFFERED if chained else BufferMode.ABORTING
        if mode is JogMode.INCHING:
            self._inch_target = base + s * dist
            return Command(kind="relative", mode=mode_b, position=s * dist, velocity=v, **dyn)
        q = base / dist
        tol = 1e-9 * (1.0 + abs(q))
        k = math.floor(q + tol) + 1 if s > 0.0 else math.ceil(q - tol) - 1
        target = k * dist
        self._inch_target = target
        m = cfg.modulo
        if m is not None:  # absolute positions are in [0, modulo) there
            pos = target % m
            pos = 0.0 if pos >= m else pos
            d = Direction.POSITIVE if s > 0.0 else Direction.NEGATIVE
            return Command(
                kind="absolute", mode=mode_b, position=pos, velocity=v, direction=d, **dyn
            )
        return Command(kind="absolute", mode=mode_b, position=target, velocity=v, **dyn)

    def _start(self, axis: Axis) -> Handle:
        s = 1.0 if self.jog_forward else -1.0
        cmd = self._jog_command(axis, s)
        h = axis.submit(cmd)
        self._dir = s
        self._running = self._in_mode(axis) in _CONTINUOUS
        if not self._running:
            self._inch = h
        return h

    def _halt(self, axis: Axis) -> Handle:
        return axis.submit(Command(kind="halt", deceleration=self._dec, jerk=self._jrk))

    # -- the scan ----
    def _scan(self) -> None:
        fwd, bwd = bool(self.jog_forward), bool(self.jog_backward)
        rise_f, rise_b = fwd and not self._pf, bwd and not self._pb
        self._pf, self._pb = fwd, bwd
        ex = fwd or bwd
        rising = ex and not self._prev_execute
        self.execute = ex
        self._dirty = True
        axis = self.axis
        h = self._handle
        busy = h is not None and not h.terminal
        if (rise_f or rise_b) and fwd and bwd:
            if busy or rising:
                if self._running and axis is not None and busy:
                    self._halt(axis)  # the jog's own motion brakes
                self._running = False
                self._handle = _failed(
                    ErrorID.INVALID_JOG_MODE, "jog_forward and jog_backward both TRUE"
                )
                self.error_text = "jog_forward and jog_backward both TRUE"
                self._seen = False
        elif (rise_f or rise_b) and (busy or rising):
            self._handle = self._start_checked()
            self._seen = False
        elif self._running and not (fwd if self._dir > 0.0 else bwd):
            self._running = False  # released: brake
            if busy and axis is not None:
                self._handle = self._halt(axis)
        self._prev_execute = ex
        h = self._handle
        self._busy_status = None
        if h is None:
            self._clear()
            return
        st = h.status
        if st >= Status.DONE:
            self._running = False
            if ex or not self._seen:
                self._seen = True
                self.busy = self.active = False
                self.done = st is Status.DONE
                self.error = st is Status.ERROR
                self.command_aborted = st is Status.ABORTED
                self.error_id = h.error_id if self.error else ErrorID.OK
                if self.error and h.reason:
                    self.error_text = h.reason
            else:
                self._handle = None
                self._clear()
        else:
            self.busy = True
            self.active = st is Status.ACTIVE
            self.done = self.error = self.command_aborted = False
            self.error_id = ErrorID.OK
