"""Administrative FBs: MC_Power, MC_Reset, MC_SetPosition, MC_SetOverride and the readers."""

from __future__ import annotations

from typing import Any, ClassVar

from motionplc.blocks.axis import OVERRIDE_MIN, POSITION_MAX, Axis, Command, Handle
from motionplc.blocks.base import (
    EnableFB,
    ExecuteFB,
    InputError,
    check_dynamic,
    check_execution_mode,
    check_number,
)
from motionplc.blocks.enums import AxisState, BufferMode, ErrorID, ExecutionMode, Source


class MC_Power(EnableFB):
    """Power stage on/off. ``status`` = the drive reports OPERATION ENABLED (input image).

    Enable rising in scan k: the drive gets the request in scan k's output phase and reports
    it in scan k+1, where the axis enters Standstill and ``status`` rises. Enable falling:
    Disabled at once, moving FBs show CommandAborted.
    """

    INPUTS = ("axis", "enable", "enable_positive", "enable_negative")
    OUTPUTS = ("status", "valid", "busy", "error")
    _UPDATE_MARKS_DIRTY = True

    def __init__(self, name: str | None = None, **inputs: Any) -> None:
        self.enable_positive = True
        self.enable_negative = True
        self.status = False
        self._powered: Axis | None = None
        super().__init__(name, **inputs)

    # the steady scan runs in __call__ (a subclass that changes _scan or _update: never)
    _power_inline: ClassVar[bool] = True

    def __init_subclass__(cls, **kw: Any) -> None:
        # before EnableFB's, which asks _steady_allowed
        cls._power_inline = cls._scan is MC_Power._scan and cls._update is MC_Power._update
        super().__init_subclass__(**kw)

    @classmethod
    def _steady_allowed(cls) -> bool:
        return cls._power_inline

    def __call__(self, **inputs: Any) -> Any:
        """One scan (see :meth:`FunctionBlock.__call__`). The steady scan of a long-lived FB
        (its axis registered, enabled and valid without error: ``_steady`` is its axis) runs
        :meth:`_scan`'s steps for that case here: the power request (``Axis.set_power``; with
        both directions enabled not called when the axis holds that very request already: it
        would change nothing), then ``status`` from the axis image."""
        if inputs:
            self._set_inputs(inputs)
        axis = self.axis
        if axis is not self._steady or not self.enable:
            return self._call_general()
        try:
            if self.enable_positive is True and self.enable_negative is True:
                # Axis.set_power is the only writer of these: power_request True and both
                # directions enabled (_feed_all) means the axis holds this very request
                if axis.power_request is not True or axis._feed_all is not True:
                    axis.set_power(True, True, True)
            else:
                axis.set_power(True, bool(self.enable_positive), bool(self.enable_negative))
            status = axis.img_enabled
            if status != self.status:
                self.status = status
                self._dirty = True
        except Exception as exc:  # noqa: BLE001 - no exception of an FB body escapes the cycle
            self._scan_failed(exc)
        return self

    def _scan(self) -> None:
        axis = self.axis
        if axis is not None:
            axis.set_power(
                bool(self.enable), bool(self.enable_positive), bool(self.enable_negative)
            )
        super()._scan()

    def _update(self, axis: Axis) -> None:
        status = axis.img_enabled
        if status != self.status:
            self.status = status
            self._dirty = True

    def _reset_values(self) -> None:
        self.status = False


class MC_Reset(ExecuteFB):
    """Leave ErrorStop: Standstill if the power is on (T4), else Disabled (T3).

    Outside ErrorStop it is a no-op that reports Done. Done comes when the ErrorStop ramp has
    ended and the drive has acknowledged the fault reset.
    """

    def _start(self, axis: Axis) -> Handle:
        return axis.request_reset()


class MC_SetPosition(ExecuteFB):
    """Shift the coordinate system (set and actual position alike; no motion, no state change).

    ``relative``: add ``position`` to the current position. ``execution_mode`` QUEUED applies it
    when the queued motion before it is done.
    """

    INPUTS = ("axis", "execute", "position", "relative", "execution_mode")

    def __init__(self, name: str | None = None, **inputs: Any) -> None:
        self.position = 0.0
        self.relative = False
        self.execution_mode = ExecutionMode.IMMEDIATELY
        super().__init__(name, **inputs)

    def _start(self, axis: Axis) -> Handle:
        pos = check_number(
            "position", self.position, ErrorID.INVALID_POSITION, -POSITION_MAX, POSITION_MAX
        )
        mode = check_execution_mode(self.execution_mode)
        bm = BufferMode.ABORTING if mode is ExecutionMode.IMMEDIATELY else BufferMode.BUFFERED
        return axis.submit(
            Command(kind="setpos", mode=bm, position=pos, relative=bool(self.relative))
        )


class MC_SetOverride(EnableFB):
    """Velocity/acceleration/jerk override factors (``enabled`` instead of ``valid``).

    vel_factor 0 (stops the axis without leaving its motion state) or in [1e-3, 1]
    (``axis.OVERRIDE_MIN``); acc_factor and jerk_factor in [1e-3, 1]. A bad factor (also NaN,
    inf, 1e-300) gives ``error`` (INVALID_OVERRIDE, the range in ``error_text``) and leaves the
    factors unchanged. The factors stay in force after Enable falls.
    """

    INPUTS = ("axis", "enable", "vel_factor", "acc_factor", "jerk_factor")
    OUTPUTS = ("enabled", "busy", "error")

    def __init__(self, name: str | None = None, **inputs: Any) -> None:
        self.vel_factor = 1.0
        self.acc_factor = 1.0
        self.jerk_factor = 1.0
        self.enabled = False
        super().__init__(name, **inputs)

    def _update(self, axis: Axis) -> None:
        eid = ErrorID.INVALID_OVERRIDE
        vf = check_dynamic("vel_factor", self.vel_factor, eid, OVERRIDE_MIN, 1.0)
        af = check_number("acc_factor", self.acc_factor, eid, OVERRIDE_MIN, 1.0)
        jf = check_number("jerk_factor", self.jerk_factor, eid, OVERRIDE_MIN, 1.0)
        axis.set_override(vf, af, jf)  # a re-plan that fails ends the move, not this FB
        self.enabled = True

    def _scan(self) -> None:
        super()._scan()
        self.valid = False  # this FB reports ``enabled``
        if not self.error and self.enable:
            self.enabled = True

    def _reset_values(self) -> None:
        self.enabled = False


def _check_comm(axis: Axis) -> None:
    if not axis.comm_ok:
        raise InputError(ErrorID.COMMUNICATION_LOST, f"axis {axis.name!r}: communication lost")


class MC_ReadStatus(EnableFB):
    """One boolean per axis state (from the axis image of this scan)."""

    OUTPUTS = ("valid", "busy", "error")
    _FLAGS = {
        AxisState.ERROR_STOP: "error_stop",
        AxisState.DISABLED: "disabled",
        AxisState.STOPPING: "stopping",
        AxisState.STANDSTILL: "standstill",
        AxisState.HOMING: "homing",
        AxisState.DISCRETE_MOTION: "discrete_motion",
        AxisState.CONTINUOUS_MOTION: "continuous_motion",
        AxisState.SYNCHRONIZED_MOTION: "synchronized_motion",
    }

    def __init__(self, name: str | None = None, **inputs: Any) -> None:
        self.state: AxisState | None = None
        for f in self._FLAGS.values():
            setattr(self, f, False)
        super().__init__(name, **inputs)

    # the unchanged-state scan runs in __call__ (a subclass that changes _update: never)
    _status_inline: ClassVar[bool] = True

    def __init_subclass__(cls, **kw: Any) -> None:
        # before EnableFB's, which asks _steady_allowed
        cls._status_inline = cls._update is MC_ReadStatus._update
        super().__init_subclass__(**kw)

    @classmethod
    def _steady_allowed(cls) -> bool:
        return cls._inline_scan and cls._status_inline and not cls._values_traced

    def __call__(self, **inputs: Any) -> Any:
        """One scan (see :meth:`FunctionBlock.__call__`). The steady scan of a long-lived FB
        whose axis is still in the state it shows returns here: nothing to write."""
        if inputs:
            self._set_inputs(inputs)
        axis = self.axis
        if axis is self._steady and self.enable and axis.img_state is self.state:
            return self
        return EnableFB.__call__(self)

    def _update(self, axis: Axis) -> None:
        st = axis.img_state
        if st is self.state:
            return
        self.state = st
        for s, f in self._FLAGS.items():
            setattr(self, f, s is st)

    def _reset_values(self) -> None:
        self.state = None
        for f in self._FLAGS.values():
            setattr(self, f, False)


class MC_ReadActualPosition(EnableFB):
    """Actual position (wrapped on modulo axes)."""

    def __init__(self, name: str | None = None, **inputs: Any) -> None:
        self.position = 0.0
        super().__init__(name, **inputs)

    def _update(self, axis: Axis) -> None:
        _check_comm(axis)
        self.position = axis.wrap(axis.img_act_p)

    def _reset_values(self) -> None:
        self.position = 0.0


class MC_ReadActualVelocity(EnableFB):
    """Actual velocity (signed)."""

    def __init__(self, name: str | None = None, **inputs: Any) -> None:
        self.velocity = 0.0
        super().__init__(name, **inputs)

    def _update(self, axis: Axis) -> None:
        _check_comm(axis)
        self.velocity = axis.img_act_v

    def _reset_values(self) -> None:
        self.velocity = 0.0


class MC_ReadAxisError(EnableFB):
    """The axis error (not FB errors): ``axis_error_id`` and a readable ``axis_error_reason``."""

    def __init__(self, name: str | None = None, **inputs: Any) -> None:
        self.axis_error_id = ErrorID.OK
        self.axis_error_reason = ""
        super().__init__(name, **inputs)

    def _update(self, axis: Axis) -> None:
        self.axis_error_id = axis.img_error
        self.axis_error_reason = axis.axis_error_reason if axis.img_error else ""

    def _reset_values(self) -> None:
        self.axis_error_id = ErrorID.OK
        self.axis_error_reason = ""


class MC_ReadMotionState(EnableFB):
    """Motion flags of the set values (``source`` COMMANDED/SET) or of the actual values.

    ACTUAL_VALUE uses the actual velocity and the actual acceleration; drives report no
    acceleration, so the axis derives it from the actual velocities of consecutive fresh
    samples (backward difference, one cycle behind the set acceleration on an ideal drive);
    accelerating/decelerating say whether |v| grew or shrank over that sample interval. The
    window for actual values (vendor specific in the spec) is ``acc_window`` [u/s^2]
    (0 = automatic: 1e-6 * a_max) for constant_velocity and 1e-9 u/s for the direction flags.
    """

    INPUTS = ("axis", "enable", "source", "acc_window")
    _EPS = 1e-9

    def __init__(self, name: str | None = None, **inputs: Any) -> None:
        self.source = Source.SET_VALUE
        self.acc_window = 0.0
        self.constant_velocity = False
        self.accelerating = False
        self.decelerating = False
        self.direction_positive = False
        self.direction_negative = False
        super().__init__(name, **inputs)

    def _update(self, axis: Axis) -> None:
        if not isinstance(self.source, Source):
            raise InputError(
                ErrorID.INVALID_EXECUTION_MODE, f"source must be a Source, got {self.source!r}"
            )
        eps = self._EPS
        if self.source is Source.ACTUAL_VALUE:
            _check_comm(axis)
            win = check_number(
                "acc_window",
                self.acc_window,
                ErrorID.INVALID_ACCELERATION,
                0.0,
                max(axis.cfg.a_max, axis.cfg.a_neg),
            )
            v = axis.img_act_v
            a = axis.img_act_a
            const = abs(a) <= (win or 1e-6 * axis.cfg.a_max)
            # over the last sample interval: did |v| grow or shrink (also across v = 0)?
            dspeed = abs(v) - abs(axis.img_act_v_prev)
            self.constant_velocity = const
            self.accelerating = not const and dspeed > 0.0
            self.decelerating = not const and dspeed < 0.0
        else:
            v = axis.img_v
            a = axis.img_a
            const = abs(a) <= eps
            self.constant_velocity = const
            self.accelerating = not const and (a * v > 0.0 or abs(v) <= eps)
            self.decelerating = not const and a * v < 0.0
        self.direction_positive = v > eps
        self.direction_negative = v < -eps

    def _reset_values(self) -> None:
        self.constant_velocity = self.accelerating = self.decelerating = False
        self.direction_positive = self.direction_negative = False
