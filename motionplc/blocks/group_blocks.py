"""PLCopen Part 4 function blocks for axes groups.

Same calling convention and output rules as the single-axis FBs (:mod:`motionplc.blocks.base`):
``fb(axes_group=g, execute=True, position=(x, y, z), velocity=0.5)`` updates the inputs, runs
one scan and returns the FB; outputs are attributes; Execute/Done/Busy/Active/CommandAborted/
Error semantics as in spec 2.1. The AxesGroup input is ``axes_group``.

Inputs (checked at Execute; outside their range the FB gives ``error`` with the input's ErrorID
and ``error_text`` naming the input and the range, never a clamp):

* ``position`` / ``distance`` / ``end_point`` / ``aux_point``: one finite number per group axis,
  within +-1e12 (MC_MoveCircular* RADIUS mode: ``aux_point[0]`` = the radius, negative for the
  long arc); the target must lie within the members' software limits (else
  TARGET_OUTSIDE_SW_LIMITS; arcs and curves: the whole path).
* ``velocity``: the path speed [m/s], in (0, 1e9] (MC_MoveDirect*: a cap of every axis' speed);
  ``acceleration``, ``deceleration``, ``jerk``: 0 (the axes' limits) or in (0, 1e12] (path
  values).
* ``buffer_mode``: a BufferMode; ``transition_mode``: a TransitionMode; with ABORTING or
  BUFFERED only TM_NONE; ``transition_parameter``: >= 0 and finite (TM_CORNER_DISTANCE and the
  velocity modes need > 0; TM_MAX_CORNER_DEVIATION 0 = the group's default tolerance).
* ``points`` (passing points): a sequence of at least one point, one value per axis each.

The meaning of every BufferMode x TransitionMode combination is documented in
:mod:`motionplc.blocks.group`.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

from motionplc.blocks.axis import Axis, Handle, Status
from motionplc.blocks.base import EnableFB, ExecuteFB, InputError, MotionFB, _failed, check_number
from motionplc.blocks.enums import (
    BufferMode,
    CircMode,
    ErrorID,
    GroupState,
    PathChoice,
    TransitionMode,
)
from motionplc.blocks.group import AxesGroup, GroupCommand
from motionplc.blocks.motion import InputChecks

POSITION_MAX = 1e12
_DYN_MAX = 1e12


class _GroupMixin:
    """Registration with the group and the AxesGroup input (instead of Axis)."""

    axes_group: AxesGroup | None
    _registered: Any
    name: str | None

    def __call__(self, **inputs: Any) -> Any:
        if inputs:
            if not self._input_set.issuperset(inputs):  # type: ignore[attr-defined]
                self._set_inputs(inputs)  # type: ignore[attr-defined]
            self.__dict__.update(inputs)
        group = self.axes_group
        if group is not self._registered and group is not None:
            if not isinstance(group, AxesGroup):
                raise TypeError(
                    f"{type(self).__name__}: axes_group must be an AxesGroup, got {group!r}"
                )
            trace_name = group.register(self)
            if self.name is None:
                self.name = trace_name
            self._registered = group
        try:
            self._scan()  # type: ignore[attr-defined]
        except Exception as exc:  # noqa: BLE001 - no exception of an FB body escapes the cycle
            self._scan_failed(exc)  # type: ignore[attr-defined]
        return self


class _GroupExecute(_GroupMixin, ExecuteFB):
    INPUTS = ("axes_group", "execute")

    def __init__(self, name: str | None = None, **inputs: Any) -> None:
        self.axes_group = None
        super().__init__(name, **inputs)

    def _start_checked(self) -> Handle:
        group = self.axes_group
        self.error_text = ""
        if group is None:
            self.error_text = "axes_group input is not connected"
            return _failed(ErrorID.INVALID_GROUP)
        try:
            return self._start_group(group)
        except InputError as exc:
            self.error_text = str(exc)
            return _failed(exc.error_id, str(exc))

    def _start_group(self, group: AxesGroup) -> Handle:
        raise NotImplementedError

    def _start(self, axis: Axis) -> Handle:  # pragma: no cover - groups use _start_group
        raise NotImplementedError


class _GroupMotion(_GroupMixin, MotionFB):
    INPUTS = ("axes_group", "execute")

    def __init__(self, name: str | None = None, **inputs: Any) -> None:
        self.axes_group = None
        super().__init__(name, **inputs)

    _start_checked = _GroupExecute._start_checked

    def _start_group(self, group: AxesGroup) -> Handle:
        raise NotImplementedError

    def _start(self, axis: Axis) -> Handle:  # pragma: no cover
        raise NotImplementedError


class _GroupEnable(_GroupMixin, EnableFB):
    INPUTS = ("axes_group", "enable")

    def __init__(self, name: str | None = None, **inputs: Any) -> None:
        self.axes_group = None
        super().__init__(name, **inputs)

    def _scan(self) -> None:
        self.axis = self.axes_group  # type: ignore[assignment] - EnableFB checks self.axis
        super()._scan()


def _done(error_id: ErrorID = ErrorID.OK, reason: str = "") -> Handle:
    h = Handle("admin")
    if error_id is ErrorID.OK:
        h._finish(Status.DONE)
    else:
        h._finish(Status.ERROR, error_id, reason)
    return h


def _point(name: str, value: Any, n: int, error_id: ErrorID) -> tuple[float, ...]:
    if isinstance(value, (str, bytes)) or not isinstance(value, Sequence):
        if isinstance(value, dict):
            raise InputError(error_id, f"{name} must be a sequence of {n} numbers, got a dict")
        raise InputError(error_id, f"{name} must be a sequence of {n} numbers, got {value!r}")
    if len(value) != n:
        raise InputError(error_id, f"{name} must have {n} values (one per axis), got {len(value)}")
    return tuple(
        check_number(f"{name}[{i}]", x, error_id, -POSITION_MAX, POSITION_MAX)
        for i, x in enumerate(value)
    )


def _velocity(fb: Any) -> float:
    return check_number("velocity", fb.velocity, ErrorID.INVALID_VELOCITY, 0.0, 1e9, lo_open=True)


def _dyn(name: str, value: Any, error_id: ErrorID) -> float:
    x = check_number(name, value, error_id, 0.0, _DYN_MAX)
    return x


def _mode(value: Any) -> BufferMode:
    try:
        return BufferMode(value)
    except ValueError:
        raise InputError(
            ErrorID.INVALID_BUFFER_MODE, f"buffer_mode must be a BufferMode, got {value!r}"
        ) from None


def _tm(fb: Any) -> TransitionMode:
    try:
        return TransitionMode(fb.transition_mode)
    except ValueError:
        raise InputError(
            ErrorID.INVALID_TRANSITION_MODE,
            f"transition_mode must be a TransitionMode (0..4), got {fb.transition_mode!r}",
        ) from None


def _tm_par(fb: Any) -> float:
    return check_number(
        "transition_parameter", fb.transition_parameter, ErrorID.INVALID_TRANSITION_MODE, 0.0, 1e12
    )


def _tm_needs_blending(tm: TransitionMode, mode: BufferMode) -> None:
    if tm is not TransitionMode.TM_NONE and mode < BufferMode.BLENDING_LOW:
        raise InputError(
            ErrorID.INVALID_TRANSITION_MODE,
            f"transition_mode {tm.name} needs a blending buffer_mode, got {mode.name} "
            "(ABORTING and BUFFERED take TM_NONE)",
        )


def _tm_par_positive(fb: Any, tm: TransitionMode, par: float) -> None:
    if (
        tm
        in (
            TransitionMode.TM_CORNER_DISTANCE,
            TransitionMode.TM_CONSTANT_VELOCITY,
            TransitionMode.TM_START_VELOCITY,
        )
        and not par > 0.0
    ):
        raise InputError(
            ErrorID.INVALID_TRANSITION_MODE,
            f"transition_parameter must be > 0 for {tm.name}, got {fb.transition_parameter!r}",
        )


def _transition(fb: Any, mode: BufferMode) -> tuple[TransitionMode, float]:
    tm = _tm(fb)
    par = _tm_par(fb)
    _tm_needs_blending(tm, mode)
    _tm_par_positive(fb, tm, par)
    return tm, par


# ----------------------------------------------------------------------------- administration
class MC_AddAxisToGroup(_GroupExecute):
    """Add ``axis`` to the group (GroupDisabled only); ``index``: its place (default last)."""

    INPUTS = ("axes_group", "execute", "axis", "index")

    def __init__(self, name: str | None = None, **inputs: Any) -> None:
        self.index = None
        super().__init__(name, **inputs)
        self.axis = inputs.get("axis")

    def _start_group(self, group: AxesGroup) -> Handle:
        if not isinstance(self.axis, Axis):
            raise InputError(ErrorID.INVALID_GROUP_AXIS, f"axis must be an Axis, got {self.axis!r}")
        return _done(group.add_axis(self.axis, self.index))


class MC_RemoveAxisFromGroup(_GroupExecute):
    """Remove ``axis`` from the group (GroupDisabled only)."""

    INPUTS = ("axes_group", "execute", "axis")

    def __init__(self, name: str | None = None, **inputs: Any) -> None:
        super().__init__(name, **inputs)
        self.axis = inputs.get("axis")

    def _start_group(self, group: AxesGroup) -> Handle:
        if not isinstance(self.axis, Axis):
            raise InputError(ErrorID.INVALID_GROUP_AXIS, f"axis must be an Axis, got {self.axis!r}")
        return _done(group.remove_axis(self.axis))


class MC_UngroupAllAxes(_GroupExecute):
    """Remove every axis from the group (GroupDisabled only)."""

    def _start_group(self, group: AxesGroup) -> Handle:
        return _done(group.ungroup())


class MC_GroupEnable(_GroupExecute):
    """GroupDisabled -> GroupStandby (every member powered and in Standstill)."""

    def _start_group(self, group: AxesGroup) -> Handle:
        return group.enable()


class MC_GroupDisable(_GroupExecute):
    """Any state -> GroupDisabled; group motion is aborted."""

    def _start_group(self, group: AxesGroup) -> Handle:
        return group.disable()


class MC_GroupReset(_GroupExecute):
    """GroupErrorStop -> GroupStandby (at rest, members reset and ready); elsewhere no effect."""

    def _start_group(self, group: AxesGroup) -> Handle:
        return group.reset()


class MC_GroupReadStatus(_GroupEnable):
    """One boolean per group state, plus the motion flags of the path."""

    _FLAGS = {
        GroupState.GROUP_DISABLED: "group_disabled",
        GroupState.GROUP_STANDBY: "group_standby",
        GroupState.GROUP_HOMING: "group_homing",
        GroupState.GROUP_MOVING: "group_moving",
        GroupState.GROUP_STOPPING: "group_stopping",
        GroupState.GROUP_ERROR_STOP: "group_error_stop",
    }

    def __init__(self, name: str | None = None, **inputs: Any) -> None:
        self.state: GroupState | None = None
        self.path_velocity = 0.0
        for f in self._FLAGS.values():
            setattr(self, f, False)
        super().__init__(name, **inputs)

    def _update(self, group: Any) -> None:
        st = group.state
        self.path_velocity = group.path_velocity
        self.state = st
        for s, f in self._FLAGS.items():
            setattr(self, f, s is st)

    def _reset_values(self) -> None:
        self.state = None
        self.path_velocity = 0.0
        for f in self._FLAGS.values():
            setattr(self, f, False)


class MC_GroupReadError(_GroupEnable):
    """The group's error (``group_error_id``, ``group_error_text``)."""

    def __init__(self, name: str | None = None, **inputs: Any) -> None:
        self.group_error_id = ErrorID.OK
        self.group_error_text = ""
        super().__init__(name, **inputs)

    def _update(self, group: Any) -> None:
        self.group_error_id = group.error_id
        self.group_error_text = group.error_reason

    def _reset_values(self) -> None:
        self.group_error_id = ErrorID.OK
        self.group_error_text = ""


class MC_GroupReadActualPosition(_GroupEnable):
    """Actual positions of the members (``position``, a tuple in group axis order)."""

    def __init__(self, name: str | None = None, **inputs: Any) -> None:
        self.position: tuple[float, ...] = ()
        super().__init__(name, **inputs)

    def _update(self, group: Any) -> None:
        self.position = group.actual_position()

    def _reset_values(self) -> None:
        self.position = ()


class MC_GroupReadActualVelocity(_GroupEnable):
    """Actual velocities of the members (``velocity``) and the path speed (``path_velocity``)."""

    def __init__(self, name: str | None = None, **inputs: Any) -> None:
        self.velocity: tuple[float, ...] = ()
        self.path_velocity = 0.0
        super().__init__(name, **inputs)

    def _update(self, group: Any) -> None:
        v = group.actual_velocity()
        self.velocity = v
        self.path_velocity = math.sqrt(sum(x * x for x in v))

    def _reset_values(self) -> None:
        self.velocity = ()
        self.path_velocity = 0.0


class MC_GroupSetOverride(InputChecks, _GroupEnable):
    """Velocity factor in [0.001, 1] for the path speed of moves planned while enabled
    (``enabled`` output; the running piece keeps its profile)."""

    INPUTS = ("axes_group", "enable", "vel_factor")
    OUTPUTS = ("enabled", "busy", "error")

    def __init__(self, name: str | None = None, **inputs: Any) -> None:
        self.vel_factor = 1.0
        self.enabled = False
        super().__init__(name, **inputs)

    def _in_vel_factor(self, group: Any) -> float:
        return check_number("vel_factor", self.vel_factor, ErrorID.INVALID_OVERRIDE, 1e-3, 1.0)

    def _update(self, group: Any) -> None:
        f = self._in_vel_factor(group)
        group.set_override(f)
        self.enabled = True

    def _reset_values(self) -> None:
        self.enabled = False


# ----------------------------------------------------------------------------------- motion
class _GroupMove(InputChecks, _GroupMotion):
    """Common pins of the path moves."""

    INPUTS = (
        "axes_group",
        "execute",
        "velocity",
        "acceleration",
        "deceleration",
        "jerk",
        "buffer_mode",
        "transition_mode",
        "transition_parameter",
    )

    def __init__(self, name: str | None = None, **inputs: Any) -> None:
        self.velocity = 0.0
        self.acceleration = 0.0
        self.deceleration = 0.0
        self.jerk = 0.0
        self.buffer_mode = BufferMode.ABORTING
        self.transition_mode = TransitionMode.TM_NONE
        self.transition_parameter = 0.0
        super().__init__(name, **inputs)

    # the input checks, one input at a time (InputChecks); _common makes them in its order
    def _in_buffer_mode(self, group: Any) -> BufferMode:
        return _mode(self.buffer_mode)

    def _in_transition_mode(self, group: Any) -> TransitionMode:
        tm = _tm(self)
        try:
            mode = _mode(self.buffer_mode)
        except InputError:
            return tm  # (buffer_mode's own problem)
        _tm_needs_blending(tm, mode)
        return tm

    def _in_transition_parameter(self, group: Any) -> float:
        par = _tm_par(self)
        try:
            tm = _tm(self)
        except InputError:
            return par  # (transition_mode's own problem)
        _tm_par_positive(self, tm, par)
        return par

    def _in_velocity(self, group: Any) -> float:
        return _velocity(self)

    def _in_acceleration(self, group: Any) -> float:
        return _dyn("acceleration", self.acceleration, ErrorID.INVALID_ACCELERATION)

    def _in_deceleration(self, group: Any) -> float:
        return _dyn("deceleration", self.deceleration, ErrorID.INVALID_DECELERATION)

    def _in_jerk(self, group: Any) -> float:
        return _dyn("jerk", self.jerk, ErrorID.INVALID_JERK)

    def _common(self) -> dict[str, Any]:
        mode = _mode(self.buffer_mode)
        tm, par = _transition(self, mode)
        return {
            "mode": mode,
            "velocity": self._in_velocity(None),
            "acceleration": self._in_acceleration(None),
            "deceleration": self._in_deceleration(None),
            "jerk": self._in_jerk(None),
            "transition_mode": tm,
            "transition_parameter": par,
        }


class MC_MoveLinearAbsolute(_GroupMove):
    """A straight line to ``position`` (absolute, one value per group axis)."""

    INPUTS = (*_GroupMove.INPUTS, "position")
    _KIND = "linear"
    _RELATIVE = False
    _TARGET = "position"

    def __init__(self, name: str | None = None, **inputs: Any) -> None:
        setattr(self, self._TARGET, ())
        super().__init__(name, **inputs)

    def _in_position(self, group: Any) -> tuple[float, ...]:
        return _point(
            self._TARGET, getattr(self, self._TARGET), group.dim, ErrorID.INVALID_POSITION
        )

    _in_distance = _in_position

    def _start_group(self, group: AxesGroup) -> Handle:
        common = self._common()
        target = self._in_position(group)
        return group.submit(
            GroupCommand(kind=self._KIND, position=target, relative=self._RELATIVE, **common)
        )


class MC_MoveLinearRelative(MC_MoveLinearAbsolute):
    """A straight line over ``distance`` (from the end of the previous move)."""

    INPUTS = (*_GroupMove.INPUTS, "distance")
    _RELATIVE = True
    _TARGET = "distance"


class MC_MoveDirectAbsolute(MC_MoveLinearAbsolute):
    """Synchronised point-to-point to ``position`` (every axis arrives together; the path in
    between is not a line). ``velocity`` caps every axis' speed; starts and ends at rest."""

    _KIND = "direct"

    def _common(self) -> dict[str, Any]:
        out = super()._common()
        return out


class MC_MoveDirectRelative(MC_MoveDirectAbsolute):
    """:class:`MC_MoveDirectAbsolute` over ``distance``."""

    INPUTS = (*_GroupMove.INPUTS, "distance")
    _RELATIVE = True
    _TARGET = "distance"


class MC_MoveCircularAbsolute(_GroupMove):
    """An arc to ``end_point``: CircMode BORDER (``aux_point`` on the arc), CENTER
    (``aux_point`` = the centre, ``path_choice`` the sense; in 3-D the arc lies in a plane
    parallel to XY) or RADIUS (``aux_point[0]`` = the radius, negative: the arc longer than half
    a circle; in the XY plane)."""

    INPUTS = (*_GroupMove.INPUTS, "circ_mode", "aux_point", "end_point", "path_choice")
    _RELATIVE = False

    def __init__(self, name: str | None = None, **inputs: Any) -> None:
        self.circ_mode = CircMode.BORDER
        self.aux_point: Any = ()
        self.end_point: Any = ()
        self.path_choice = PathChoice.COUNTER_CLOCKWISE
        super().__init__(name, **inputs)

    def _in_circ_mode(self, group: Any) -> CircMode:
        try:
            return CircMode(self.circ_mode)
        except ValueError:
            raise InputError(
                ErrorID.INVALID_CIRCLE, f"circ_mode must be a CircMode, got {self.circ_mode!r}"
            ) from None

    def _in_path_choice(self, group: Any) -> PathChoice:
        try:
            return PathChoice(self.path_choice)
        except ValueError:
            raise InputError(
                ErrorID.INVALID_CIRCLE,
                f"path_choice must be a PathChoice, got {self.path_choice!r}",
            ) from None

    def _in_end_point(self, group: Any) -> tuple[float, ...]:
        return _point("end_point", self.end_point, group.dim, ErrorID.INVALID_POSITION)

    def _in_aux_point(self, group: Any) -> tuple[float, ...]:
        try:
            circ = self._in_circ_mode(group)
        except InputError:
            circ = CircMode.BORDER  # (circ_mode's own problem): a point is checked
        if circ is CircMode.RADIUS:
            aux = self.aux_point
            if not isinstance(aux, Sequence) or not aux:
                raise InputError(ErrorID.INVALID_CIRCLE, "aux_point[0] must hold the radius")
            r = check_number(
                "aux_point[0]", aux[0], ErrorID.INVALID_CIRCLE, -POSITION_MAX, POSITION_MAX
            )
            if r == 0.0:
                raise InputError(ErrorID.INVALID_CIRCLE, "aux_point[0] (the radius) must not be 0")
            return (r,)
        return _point("aux_point", self.aux_point, group.dim, ErrorID.INVALID_CIRCLE)

    def _start_group(self, group: AxesGroup) -> Handle:
        common = self._common()
        circ = self._in_circ_mode(group)
        choice = self._in_path_choice(group)
        end = self._in_end_point(group)
        auxp = self._in_aux_point(group)
        return group.submit(
            GroupCommand(
                kind="circular",
                position=end,
                relative=self._RELATIVE,
                circ_mode=circ,
                aux_point=auxp,
                path_choice=choice,
                **common,
            )
        )


class MC_MoveCircularRelative(MC_MoveCircularAbsolute):
    """:class:`MC_MoveCircularAbsolute` with ``end_point`` and ``aux_point`` relative to the
    start point (the end of the previous move)."""

    _RELATIVE = True


class MC_MovePassingPoints(_GroupMove):
    """Through ``points`` (from where the previous move ends) on the seed-002 Hermite curve,
    the time-optimal jerk-limited motion along it, from rest to rest."""

    INPUTS = (*_GroupMove.INPUTS, "points")
    _CURVE = "hermite"

    def __init__(self, name: str | None = None, **inputs: Any) -> None:
        self.points: Any = ()
        super().__init__(name, **inputs)

    def _common(self) -> dict[str, Any]:
        if not self.velocity:
            self.velocity = 1e9  # not given: the axes' limits
        return super()._common()

    def _in_velocity(self, group: Any) -> float:
        if not self.velocity:
            return 1e9  # not given: the axes' limits
        return _velocity(self)

    def _in_points(self, group: Any) -> tuple[tuple[float, ...], ...]:
        pts = self.points
        if isinstance(pts, (str, bytes)) or not isinstance(pts, Sequence) or not pts:
            raise InputError(ErrorID.INVALID_POINTS, "points must be a non-empty list of points")
        return tuple(
            _point(f"points[{i}]", p, group.dim, ErrorID.INVALID_POINTS) for i, p in enumerate(pts)
        )

    def _start_group(self, group: AxesGroup) -> Handle:
        common = self._common()
        points = self._in_points(group)
        return group.submit(
            GroupCommand(
                kind="curve",
                position=points[-1],
                points=points,
                curve=self._CURVE,
                **common,
            )
        )


class MC_MoveBSpline(MC_MovePassingPoints):
    """Through ``points`` on the interpolating cubic B-spline (C2)."""

    _CURVE = "bspline"


class MC_GroupHalt(InputChecks, _GroupMotion):
    """Brake along the path to rest (the fastest stop the limits allow; ``deceleration`` caps
    the path deceleration); the queued moves are aborted. GroupMoving until at rest."""

    INPUTS = ("axes_group", "execute", "deceleration", "jerk", "buffer_mode")

    def __init__(self, name: str | None = None, **inputs: Any) -> None:
        self.deceleration = 0.0
        self.jerk = 0.0
        self.buffer_mode = BufferMode.ABORTING
        super().__init__(name, **inputs)

    def _in_deceleration(self, group: Any) -> float:
        return _dyn("deceleration", self.deceleration, ErrorID.INVALID_DECELERATION)

    def _in_buffer_mode(self, group: Any) -> BufferMode:
        return _mode(self.buffer_mode)

    def _start_group(self, group: AxesGroup) -> Handle:
        dec = self._in_deceleration(group)
        self._in_buffer_mode(group)
        return group.submit(GroupCommand(kind="halt", deceleration=dec))


class MC_GroupInterrupt(MC_GroupHalt):
    """Brake along the path to rest and keep the rest of the path and the queue: the
    interrupted moves stay Busy until MC_GroupContinue resumes them."""

    INPUTS = ("axes_group", "execute", "deceleration", "jerk")

    def _start_group(self, group: AxesGroup) -> Handle:
        dec = self._in_deceleration(group)
        return group.submit(GroupCommand(kind="interrupt", deceleration=dec))


class MC_GroupContinue(_GroupExecute):
    """Resume an interrupted path from where it stopped (Error NOT_INTERRUPTED otherwise)."""

    def _start_group(self, group: AxesGroup) -> Handle:
        return group.continue_()


class MC_GroupStop(InputChecks, _GroupMotion):
    """Stop along the path; the group stays GroupStopping while ``execute`` is TRUE, then
    GroupStandby. Every move is aborted."""

    INPUTS = ("axes_group", "execute", "deceleration", "jerk")
    OUTPUTS = ("busy", "done", "command_aborted", "error")
    _BUSY_HOOK_UNTRACED = True

    def __init__(self, name: str | None = None, **inputs: Any) -> None:
        self.deceleration = 0.0
        self.jerk = 0.0
        super().__init__(name, **inputs)

    _in_deceleration = MC_GroupHalt._in_deceleration

    def _start_group(self, group: AxesGroup) -> Handle:
        dec = self._in_deceleration(group)
        return group.submit(GroupCommand(kind="stop", deceleration=dec))

    def _before_outputs(self, execute: bool) -> None:
        if self._handle is not None:
            self._handle.hold = execute

    def _busy_outputs(self, h: Handle) -> None:
        self.active = False


__all__ = [
    "MC_AddAxisToGroup",
    "MC_GroupContinue",
    "MC_GroupDisable",
    "MC_GroupEnable",
    "MC_GroupHalt",
    "MC_GroupInterrupt",
    "MC_GroupReadActualPosition",
    "MC_GroupReadActualVelocity",
    "MC_GroupReadError",
    "MC_GroupReadStatus",
    "MC_GroupReset",
    "MC_GroupSetOverride",
    "MC_GroupStop",
    "MC_MoveBSpline",
    "MC_MoveCircularAbsolute",
    "MC_MoveCircularRelative",
    "MC_MoveDirectAbsolute",
    "MC_MoveDirectRelative",
    "MC_MoveLinearAbsolute",
    "MC_MoveLinearRelative",
    "MC_MovePassingPoints",
    "MC_RemoveAxisFromGroup",
    "MC_UngroupAllAxes",
]
