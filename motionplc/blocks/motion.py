"""Single-axis motion FBs: MC_MoveAbsolute/Relative/Additive, MC_MoveVelocity, MC_Halt,
MC_Stop and MC_Home.

Rules pinned for motionplc (spec 1.4 leaves them open):

* Acceleration, Deceleration or Jerk = 0 means "the axis' configured limit" (``a_max`` /
  ``j_max``; ``j_max = inf`` gives trapezoidal profiles). Input ranges (checked at Execute and
  at every ContinuousUpdate, before anything is planned; outside them the FB gives ``error``
  with the input's ErrorID and ``error_text`` names the input and the range; never a clamp).
  With T = 1e4 s (``axis.SUPPORTED_DURATION``), v_top / a_top the larger speed /
  acceleration limit of the axis and span = v_max + |v_min|:

  - Acceleration, Deceleration (moves, MC_MoveVelocity, MC_Halt, MC_Stop): 0 or
    [span / T, a_top] -- a velocity change over the whole speed range lasts at most T;
  - Jerk: 0 or [max(a_top / T, 4 span / T^2), j_max] (finite, also if j_max is inf);
  - Velocity of a move: [1e-6 v_top, v_top], and the move (distance / Velocity) must not last
    longer than T (else INVALID_VELOCITY when its target is resolved);
  - Position / Distance: finite, the target within +-1e12 (the planner's state range);
  - MC_MoveVelocity's Velocity: [-|v_min|, v_max] after Direction (0 and tiny values are fine:
    the velocity change is short).

  So 1e-300, 1e300, inf and NaN are refused wherever they would reach the planner.
* MC_MoveVelocity accepts Velocity in [-v_max, v_max] and applies Direction (negative Velocity
  x NEGATIVE = positive motion; CURRENT keeps the sign of the current set velocity; SHORTEST
  is an error).
* Software limits (linear axes): a move whose target lies beyond a limit is refused at
  Execute (TARGET_OUTSIDE_SW_LIMITS; the axis keeps doing what it did) unless the axis stands
  beyond that limit and the target lies back towards the allowed range; a velocity command
  heading out of a limit the axis stands at is refused (MOVE_BEYOND_SW_LIMIT). A motion that
  would cross a limit (MC_MoveVelocity, or a profile overshooting) brakes to rest exactly at
  the limit with the axis' own limits; the axis then goes to ErrorStop (SW_LIMIT) and MC_Reset
  brings it back to Standstill there (no re-trip; moving back is free).
* On modulo axes Position must be in [0, modulo); Direction picks the way (SHORTEST: a tie at
  half a period goes the positive way; CURRENT: the sign of the set velocity, SHORTEST at rest).
  Direction is ignored on linear axes.
* ContinuousUpdate (spec 2.3): only its value at the rising edge of Execute counts. If TRUE, the
  FB keeps applying changed inputs (position/distance, velocity, acceleration, deceleration,
  jerk, direction; not buffer_mode) while it is Busy and continuous_update stays TRUE; once it
  falls, updates stop for this command. An active command is re-planned from the current set
  state (jerk-limited, no acceleration jump), a queued one starts with the new values. Relative
  inputs refer to the initial condition (Distance counts from where the command started). An
  invalid updated input ends the command with Error (its input's ErrorID; the next queued
  command takes over at once, otherwise a controlled stop); no update after Done.
* MC_Power.enable_positive / enable_negative: a command that would move in a direction that is
  not enabled is refused (Error DIRECTION_NOT_ENABLED, the axis unaffected); a running one whose
  direction loses its enable ends with that Error and a controlled stop (see Axis).
"""

from __future__ import annotations

from operator import attrgetter
from typing import Any, ClassVar

from motionplc.blocks.axis import POSITION_MAX, VELOCITY_RATIO_MIN, Axis, Command, Handle
from motionplc.blocks.axis_config import AxisConfig
from motionplc.blocks.base import ExecuteFB, InputError, MotionFB, check_dynamic, check_number
from motionplc.blocks.enums import BufferMode, Direction, ErrorID


def _buffer_mode(value: Any) -> BufferMode:
    try:
        return BufferMode(value)
    except ValueError:
        raise InputError(
            ErrorID.INVALID_BUFFER_MODE, f"buffer_mode must be a BufferMode, got {value!r}"
        ) from None


def _decel(fb: Any, axis: Axis) -> float:
    lo, hi = axis.cfg.acceleration_range()
    return check_dynamic("deceleration", fb.deceleration, ErrorID.INVALID_DECELERATION, lo, hi)


def _jerk(fb: Any, axis: Axis) -> float:
    lo, hi = axis.cfg.jerk_range()
    return check_dynamic("jerk", fb.jerk, ErrorID.INVALID_JERK, lo, hi)


def _dynamics(fb: Any, axis: Axis) -> tuple[float, float, float]:
    """Acceleration, Deceleration, Jerk: 0 (the axis' limit) or within the axis' ranges
    (``AxisConfig.acceleration_range`` / ``jerk_range``; asymmetric limits: the input caps
    each side, see ``Axis._limits``)."""
    return fb._in_acceleration(axis), _decel(fb, axis), _jerk(fb, axis)


def _position(name: str, value: Any, error_id: ErrorID) -> float:
    return check_number(name, value, error_id, -POSITION_MAX, POSITION_MAX)


class StaticAxis:
    """What the input checks of an FB read of its axis, without a running axis: the axis'
    configuration and its set velocity ``v`` (MC_MoveVelocity's Direction CURRENT takes its
    sign). Used to check inputs before anything runs (``motionplc.sequence_check``)."""

    __slots__ = ("cfg", "v")

    def __init__(self, cfg: AxisConfig, v: float = 0.0) -> None:
        self.cfg = cfg
        self.v = v


class InputChecks:
    """The input checks an FB makes at Execute, callable one input at a time.

    Each checked input ``pin`` has a method ``_in_<pin>(axis)`` returning the validated value
    or raising :class:`InputError`; the FB's own Execute path calls the very same methods (in
    the order the FB always checked them), so a check made before the run and the FB at
    Execute cannot disagree. Checks that depend on another input (MC_MoveVelocity's Velocity
    after Direction, a group's TransitionMode after BufferMode) read that input's current value
    and skip the dependent part while the other input is itself invalid.
    """

    INPUTS: ClassVar[tuple[str, ...]]

    def input_problems(self, axis: Any) -> dict[str, InputError]:
        """Every checked input on its own: input name -> its InputError (empty: all valid).

        ``axis``: an Axis, a :class:`StaticAxis` (single-axis FBs) or anything with the
        group's ``dim`` (group FBs)."""
        out: dict[str, InputError] = {}
        for pin in self.INPUTS:
            check = getattr(self, f"_in_{pin}", None)
            if check is None:
                continue
            try:
                check(axis)
            except InputError as exc:
                out[pin] = exc
        return out


class _ContinuousUpdate(InputChecks, MotionFB):
    """ContinuousUpdate for the motion FBs: ``_command`` builds the (validated) command from the
    current inputs; ``_CU_INPUTS`` are the inputs that are watched while Busy."""

    _CU_INPUTS: ClassVar[tuple[str, ...]] = ()
    _cu_get: ClassVar[Any] = staticmethod(lambda fb: ())

    def __init_subclass__(cls, **kw: Any) -> None:
        super().__init_subclass__(**kw)
        if cls._CU_INPUTS:
            cls._cu_get = staticmethod(attrgetter(*cls._CU_INPUTS))

    def __init__(self, name: str | None = None, **inputs: Any) -> None:
        self._cu = False  # ContinuousUpdate latched at Execute and still TRUE
        self._cu_values: Any = None
        super().__init__(name, **inputs)

    def _command(self, axis: Axis) -> Command:
        raise NotImplementedError

    def _start(self, axis: Axis) -> Handle:
        self._cu = False
        cmd = self._command(axis)
        self._cu = bool(self.continuous_update)
        self._cu_values = self._cu_get(self) if self._cu else None
        return axis.submit(cmd)

    def _continuous_update(self, h: Handle) -> None:
        if not self.continuous_update:
            self._cu = False  # no more updates for this command
            return
        values = self._cu_get(self)
        if values == self._cu_values:
            return
        self._cu_values = values
        axis = self.axis
        if axis is None:
            return
        try:
            cmd = self._command(axis)
        except InputError as exc:
            self.error_text = str(exc)
            axis.fail_command(h, exc.error_id)
            return
        axis.update(h, cmd)


class _MoveFB(_ContinuousUpdate):
    """Common pins of the discrete moves."""

    OUTPUTS = ("busy", "active", "done", "command_aborted", "error")
    _BUSY_HOOK_UNTRACED = True  # _busy_outputs only updates end_velocity (not traced)

    def __init__(self, name: str | None = None, **inputs: Any) -> None:
        self.continuous_update = False
        self.velocity = 0.0
        self.acceleration = 0.0
        self.deceleration = 0.0
        self.jerk = 0.0
        self.buffer_mode = BufferMode.ABORTING
        self.end_velocity = 0.0  # effective velocity at the end position (blending)
        super().__init__(name, **inputs)

    # the fast paths with _busy_outputs inline in __call__ (a subclass that changes the scan or
    # its hooks: ExecuteFB's)
    _move_inline: ClassVar[bool] = True

    def __init_subclass__(cls, **kw: Any) -> None:
        super().__init_subclass__(**kw)
        cls._move_inline = (
            cls._inline_scan
            and not cls._hook_before
            and cls._busy_outputs is _MoveFB._busy_outputs
            and not cls._busy_traced
        )

    def __call__(self, **inputs: Any) -> Any:
        """One scan (see :meth:`ExecuteFB.__call__`): its fast paths (no Execute edge; idle, or
        still in the same busy state), with :meth:`_busy_outputs` inline."""
        if inputs:
            self._set_inputs(inputs)
        if self.axis is not self._registered or not self._move_inline:
            return ExecuteFB.__call__(self)
        try:
            ex = self.execute
            prev = self._prev_execute  # a bool
            if ex is prev or (ex is not True and ex is not False and bool(ex) is prev):
                h = self._handle
                if h is None:
                    return self
                if h.status is self._busy_status:
                    if self._cu:
                        self._continuous_update(h)
                    self.end_velocity = h.end_velocity
                    return self
            self._scan()
        except Exception as exc:  # noqa: BLE001 - no exception of an FB body escapes the cycle
            self._scan_failed(exc)
        return self

    def _terminal_outputs(self, h: Handle) -> None:
        self.end_velocity = h.end_velocity

    def _busy_outputs(self, h: Handle) -> None:
        if self._cu:
            self._continuous_update(h)
        self.end_velocity = h.end_velocity

    def _in_velocity(self, axis: Any) -> float:
        # Velocity caps the speed of both directions (each within its own axis limit)
        v_lo, v_top = axis.cfg.velocity_range()
        v = check_number(
            "velocity", self.velocity, ErrorID.INVALID_VELOCITY, 0.0, v_top, lo_open=True
        )
        if v < v_lo:
            raise InputError(
                ErrorID.INVALID_VELOCITY,
                f"velocity must be a finite number in (0, {v_top:g}] and at least {v_lo:g} "
                f"({VELOCITY_RATIO_MIN:g} x the axis' speed limit), got {self.velocity!r}",
            )
        return v

    def _in_acceleration(self, axis: Any) -> float:
        lo, hi = axis.cfg.acceleration_range()
        return check_dynamic(
            "acceleration", self.acceleration, ErrorID.INVALID_ACCELERATION, lo, hi
        )

    def _in_deceleration(self, axis: Any) -> float:
        return _decel(self, axis)

    def _in_jerk(self, axis: Any) -> float:
        return _jerk(self, axis)

    def _in_buffer_mode(self, axis: Any) -> BufferMode:
        return _buffer_mode(self.buffer_mode)

    def _move_command(
        self, axis: Axis, kind: str, position: float, direction: Direction
    ) -> Command:
        v = self._in_velocity(axis)
        acc, dec, jerk = _dynamics(self, axis)
        mode = _buffer_mode(self.buffer_mode)
        return Command(
            kind=kind,
            mode=mode,
            position=position,
            velocity=v,
            acceleration=acc,
            deceleration=dec,
            jerk=jerk,
            direction=direction,
        )


class MC_MoveAbsolute(_MoveFB):
    """Move to an absolute position; ends at v = 0 unless a blending command follows."""

    INPUTS = (
        "axis",
        "execute",
        "continuous_update",
        "position",
        "velocity",
        "acceleration",
        "deceleration",
        "jerk",
        "direction",
        "buffer_mode",
    )

    _CU_INPUTS = ("position", "velocity", "acceleration", "deceleration", "jerk", "direction")

    def __init__(self, name: str | None = None, **inputs: Any) -> None:
        self.position = 0.0
        self.direction = Direction.SHORTEST
        super().__init__(name, **inputs)

    def _in_position(self, axis: Any) -> float:
        m = axis.cfg.modulo
        if m is None:
            return _position("position", self.position, ErrorID.INVALID_POSITION)
        pos = check_number("position", self.position, ErrorID.INVALID_POSITION, 0.0, m)
        if pos >= m:
            raise InputError(
                ErrorID.INVALID_POSITION, f"position must be in [0, {m:g}) on a modulo axis"
            )
        return pos

    def _in_direction(self, axis: Any) -> Direction:
        if not isinstance(self.direction, Direction):
            raise InputError(
                ErrorID.INVALID_DIRECTION, f"direction must be a Direction, got {self.direction!r}"
            )
        return self.direction

    def _command(self, axis: Axis) -> Command:
        pos = self._in_position(axis)
        return self._move_command(axis, "absolute", pos, self._in_direction(axis))


class MC_MoveRelative(_MoveFB):
    """Move by a distance from the set position at execution (from the previous target when
    buffered)."""

    INPUTS = (
        "axis",
        "execute",
        "continuous_update",
        "distance",
        "velocity",
        "acceleration",
        "deceleration",
        "jerk",
        "buffer_mode",
    )
    _KIND = "relative"
    _CU_INPUTS = ("distance", "velocity", "acceleration", "deceleration", "jerk")

    def __init__(self, name: str | None = None, **inputs: Any) -> None:
        self.distance = 0.0
        super().__init__(name, **inputs)

    def _in_distance(self, axis: Any) -> float:
        return _position("distance", self.distance, ErrorID.INVALID_DISTANCE)

    def _command(self, axis: Axis) -> Command:
        d = self._in_distance(axis)
        return self._move_command(axis, self._KIND, d, Direction.POSITIVE)


class MC_MoveAdditive(MC_MoveRelative):
    """Add a distance to the last commanded target (in DiscreteMotion), else to the set
    position."""

    _KIND = "additive"


class MC_MoveVelocity(_ContinuousUpdate):
    """Endless motion at a velocity; ``in_velocity`` once the set velocity reaches it."""

    INPUTS = (
        "axis",
        "execute",
        "continuous_update",
        "velocity",
        "acceleration",
        "deceleration",
        "jerk",
        "direction",
        "buffer_mode",
    )
    OUTPUTS = ("busy", "active", "in_velocity", "command_aborted", "error")
    _BUSY_HOOK_UNTRACED = True  # _busy_outputs sets _dirty when in_velocity changes
    _CU_INPUTS = ("velocity", "acceleration", "deceleration", "jerk", "direction")

    def __init__(self, name: str | None = None, **inputs: Any) -> None:
        self.continuous_update = False
        self.velocity = 0.0
        self.acceleration = 0.0
        self.deceleration = 0.0
        self.jerk = 0.0
        self.direction = Direction.POSITIVE
        self.buffer_mode = BufferMode.ABORTING
        self.in_velocity = False
        super().__init__(name, **inputs)

    def _in_velocity(self, axis: Any) -> float:
        """The signed set velocity after Direction, within the axis limits of its direction
        (the direction's own check is :meth:`_in_direction`; while Direction is invalid only
        the range of both directions is checked here)."""
        cfg = axis.cfg
        vm = max(cfg.v_max, cfg.v_neg)
        v = check_number("velocity", self.velocity, ErrorID.INVALID_VELOCITY, -vm, vm)
        d = self.direction
        if d is Direction.POSITIVE:
            pass
        elif d is Direction.NEGATIVE:
            v = -v
        elif d is Direction.CURRENT:
            v = abs(v) * (-1.0 if axis.v < 0.0 else 1.0)
        else:
            return v
        if not -cfg.v_neg <= v <= cfg.v_max:  # asymmetric limits: the direction's own one
            raise InputError(
                ErrorID.INVALID_VELOCITY,
                f"velocity {v!r} in direction {d.name} outside the axis limits "
                f"[{-cfg.v_neg:g}, {cfg.v_max:g}]",
            )
        return v

    def _in_direction(self, axis: Any) -> Direction:
        d = self.direction
        if d not in (Direction.POSITIVE, Direction.NEGATIVE, Direction.CURRENT):
            raise InputError(
                ErrorID.INVALID_DIRECTION,
                f"direction must be POSITIVE, NEGATIVE or CURRENT for MC_MoveVelocity, got {d!r}",
            )
        return d

    _in_acceleration = _MoveFB._in_acceleration
    _in_deceleration = _MoveFB._in_deceleration
    _in_jerk = _MoveFB._in_jerk
    _in_buffer_mode = _MoveFB._in_buffer_mode

    def _command(self, axis: Axis) -> Command:
        cfg = axis.cfg
        vm = max(cfg.v_max, cfg.v_neg)
        check_number("velocity", self.velocity, ErrorID.INVALID_VELOCITY, -vm, vm)
        self._in_direction(axis)
        v = self._in_velocity(axis)
        acc, dec, jerk = _dynamics(self, axis)
        return Command(
            kind="velocity",
            mode=_buffer_mode(self.buffer_mode),
            velocity=v,
            acceleration=acc,
            deceleration=dec,
            jerk=jerk,
        )

    def _clear(self) -> None:
        super()._clear()
        self.in_velocity = False

    def _terminal_outputs(self, h: Handle) -> None:
        self.in_velocity = False

    def _busy_outputs(self, h: Handle) -> None:
        if self._cu:
            self._continuous_update(h)
        iv = h.in_target and self.active
        if iv != self.in_velocity:
            self.in_velocity = iv
            self._dirty = True


class MC_Halt(InputChecks, MotionFB):
    """Stop for normal operation (DiscreteMotion until v = 0); can be aborted."""

    INPUTS = ("axis", "execute", "deceleration", "jerk", "buffer_mode")

    def __init__(self, name: str | None = None, **inputs: Any) -> None:
        self.deceleration = 0.0
        self.jerk = 0.0
        self.buffer_mode = BufferMode.ABORTING
        super().__init__(name, **inputs)

    _in_deceleration = _MoveFB._in_deceleration
    _in_jerk = _MoveFB._in_jerk
    _in_buffer_mode = _MoveFB._in_buffer_mode

    def _start(self, axis: Axis) -> Handle:
        dec, jerk = self._in_deceleration(axis), self._in_jerk(axis)
        return axis.submit(
            Command(kind="halt", mode=self._in_buffer_mode(axis), deceleration=dec, jerk=jerk)
        )


class MC_Stop(InputChecks, MotionFB):
    """Controlled stop; the axis stays in Stopping while ``execute`` is TRUE.

    Aborted only by switching the power off. Has no ``active`` output (always FALSE).
    """

    INPUTS = ("axis", "execute", "deceleration", "jerk")
    OUTPUTS = ("busy", "done", "command_aborted", "error")
    _BUSY_HOOK_UNTRACED = True  # active is not an output of MC_Stop

    def __init__(self, name: str | None = None, **inputs: Any) -> None:
        self.deceleration = 0.0
        self.jerk = 0.0
        super().__init__(name, **inputs)

    _in_deceleration = _MoveFB._in_deceleration
    _in_jerk = _MoveFB._in_jerk

    def _start(self, axis: Axis) -> Handle:
        dec, jerk = self._in_deceleration(axis), self._in_jerk(axis)
        return axis.submit(Command(kind="stop", deceleration=dec, jerk=jerk))

    def _before_outputs(self, execute: bool) -> None:
        if self._handle is not None:
            self._handle.hold = execute

    def _busy_outputs(self, h: Handle) -> None:
        self.active = False


class MC_Home(InputChecks, MotionFB):
    """Homing: set-position homing (no reference switch configured) or a homing move to the
    axis' virtual reference switch, then the switch position becomes ``position``."""

    INPUTS = ("axis", "execute", "position", "buffer_mode")

    def __init__(self, name: str | None = None, **inputs: Any) -> None:
        self.position = 0.0
        self.buffer_mode = BufferMode.ABORTING
        super().__init__(name, **inputs)

    def _in_position(self, axis: Any) -> float:
        pos = _position("position", self.position, ErrorID.INVALID_POSITION)
        m = axis.cfg.modulo
        if m is not None and not 0.0 <= pos < m:
            raise InputError(
                ErrorID.INVALID_POSITION, f"position must be in [0, {m:g}) on a modulo axis"
            )
        return pos

    _in_buffer_mode = _MoveFB._in_buffer_mode

    def _start(self, axis: Axis) -> Handle:
        pos = self._in_position(axis)
        return axis.submit(Command(kind="home", mode=self._in_buffer_mode(axis), position=pos))


__all__ = [
    "InputChecks",
    "MC_Halt",
    "MC_Home",
    "MC_MoveAbsolute",
    "MC_MoveAdditive",
    "MC_MoveRelative",
    "MC_MoveVelocity",
    "MC_Stop",
    "StaticAxis",
]
