"""Parameter FBs: MC_ReadParameter, MC_ReadBoolParameter, MC_WriteParameter,
MC_WriteBoolParameter (PLCopen Part 1, 3.1 and Table 5), MC_ReadActualTorque and
MC_ReadAxisInfo.

The parameter numbers, their ranges and effects and the drive parameter number scheme are in
:mod:`motionplc.blocks.axis_params`. Pinned here:

* PLCopen numbers 1-17 are read from the axis' image of this cycle and written at once (the
  FB is Done in the scan of Execute) or, ``execution_mode`` QUEUED, once the axis has no
  motion command active or waiting (Busy meanwhile; mcQueued, like a Buffered command).
* Drive parameters (vendor numbers >= 0x10000) are transferred over the drive's bus (SDO on
  CANopen, holding registers on Modbus) while the cycle goes on: the FB is Busy until the
  drive has answered. MC_ReadParameter reads continuously while enabled (a new transfer as soon
  as one ends; ``valid`` from the first answer on, the value of the latest); MC_WriteParameter
  is Done when the drive has confirmed the write. An SDO abort, a Modbus exception or no
  answer within the bus' timeout is Error DRIVE_PARAMETER_FAILED with the abort code /
  exception in ``error_text``; a number the drive has not is INVALID_PARAMETER_NUMBER, a
  value its type cannot hold INVALID_PARAMETER_VALUE. A read FB's error clears by itself at
  the next successful transfer (it keeps trying, one transfer at a time).
* MC_ReadActualTorque: the drive's torque [N m, or N on a linear axis]: CiA 402 0x6077
  (per mille of the rated torque 0x6076) over SDO on CAN, a register on Modbus (both read
  continuously like a drive parameter), or the in-process drive's ``torque_model``
  (inertia * acceleration + friction from the actual motion, at once). A drive that reports
  no torque gives Error INVALID_AXIS naming what to configure.
* MC_ReadAxisInfo: the axis' and drive's flags of this cycle (see the class).

Inputs that need more than a plain value in sequences: none (``parameter_number`` is an
integer, ``value`` a number or BOOL, ``execution_mode`` an ExecutionMode).
"""

from __future__ import annotations

import math
from typing import Any

from motionplc.blocks.axis import Axis, Handle, Status
from motionplc.blocks.axis_params import (
    PARAMETERS,
    ParameterInfo,
    check_number_kind,
    check_write_value,
    decode_drive_number,
    read_parameter,
    write_parameter,
)
from motionplc.blocks.base import EnableFB, ExecuteFB, InputError, check_execution_mode
from motionplc.blocks.enums import ErrorID, ExecutionMode
from motionplc.blocks.motion import InputChecks
from motionplc.fieldbus.base import DriveAddress, ParameterError, ParameterTransfer
from motionplc.fieldbus.ideal import IdealDrive

__all__ = [
    "MC_ReadActualTorque",
    "MC_ReadAxisInfo",
    "MC_ReadBoolParameter",
    "MC_ReadParameter",
    "MC_WriteBoolParameter",
    "MC_WriteParameter",
]


def _start(axis: Axis, number: int, value: float | None) -> ParameterTransfer:
    """Start a drive parameter transfer; ParameterError -> InputError."""
    address = decode_drive_number(number)
    assert address is not None  # checked by check_number_kind
    try:
        return axis.drive.start_parameter(address, value)
    except ParameterError as exc:
        eid = ErrorID.INVALID_PARAMETER_VALUE
        if exc.number_error:
            eid = ErrorID.INVALID_PARAMETER_NUMBER
        elif exc.failed:
            eid = ErrorID.DRIVE_PARAMETER_FAILED
        raise InputError(eid, str(exc)) from None


def _failed(t: ParameterTransfer) -> InputError:
    return InputError(ErrorID.DRIVE_PARAMETER_FAILED, f"{t.label}: {t.error}")


def _comm(axis: Axis) -> None:
    if not axis.comm_ok:
        raise InputError(ErrorID.COMMUNICATION_LOST, f"axis {axis.name!r}: communication lost")


class _Reader(EnableFB):
    """An Enable FB whose value may come from a transfer: ``_read`` returns True when the
    value is valid, False while the first transfer is still running (Busy, not Valid)."""

    def __init__(self, name: str | None = None, **inputs: Any) -> None:
        self._transfer: ParameterTransfer | None = None
        self._key: Any = None
        self._have = False  # a value was read (valid while enabled)
        super().__init__(name, **inputs)

    def _scan(self) -> None:
        self._dirty = True
        if not self.enable:
            self.valid = self.busy = self.error = False
            self.error_id = ErrorID.OK
            self.error_text = ""
            self._transfer = None
            self._have = False
            self._reset_values()
            return
        axis = self.axis
        try:
            if axis is None:
                raise InputError(ErrorID.INVALID_AXIS, "axis input is not connected")
            ready = self._read(axis)
        except InputError as exc:
            self.busy = True
            self.valid = False
            self.error = True
            self.error_id = exc.error_id
            self.error_text = str(exc)
            self._have = False
            self._reset_values()
            return
        self.busy = True
        self.valid = ready
        self.error = False
        self.error_id = ErrorID.OK
        self.error_text = ""

    def _read(self, axis: Axis) -> bool:
        """Compute the value (subclasses); True: valid, False: not yet (Busy)."""
        raise NotImplementedError

    def _update(self, axis: Axis) -> None:
        self._read(axis)  # not used: _scan calls _read (kept for EnableFB's interface)

    def _transferred(self, key: Any, start: Any) -> float | None:
        """Keep a transfer running for ``key`` (a new one when the key changes or the last
        one ended): the latest value read, None while there is none yet; raises InputError
        when a transfer failed (the next scan tries again)."""
        if key != self._key:
            self._key = key
            self._transfer = None
            self._have = False
        t = self._transfer
        if t is None:
            t = self._transfer = start()
        if t.busy:
            return self._last if self._have else None
        self._transfer = None
        if t.error:
            raise _failed(t)
        self._last = t.value
        self._have = True
        self._transfer = start()  # the next read starts at once
        return t.value

    _last = math.nan


class MC_ReadParameter(_Reader, InputChecks):
    """Read parameter ``parameter_number`` (REAL) continuously while ``enable`` is TRUE:
    PLCopen numbers 1-17 from the axis of this cycle, drive parameters (vendor numbers) over
    the bus (Busy until the first answer). ``value``: the value; ``valid``, ``busy``,
    ``error``, ``error_id`` as for every Enable FB."""

    INPUTS = ("axis", "enable", "parameter_number")
    _KIND = "real"

    def __init__(self, name: str | None = None, **inputs: Any) -> None:
        self.parameter_number = 0
        self.value: Any = 0.0
        super().__init__(name, **inputs)

    def _in_parameter_number(self, axis: Any) -> ParameterInfo | DriveAddress:
        return check_number_kind(self.parameter_number, self._KIND)

    def _convert(self, x: float) -> Any:
        return float(x)

    def _read(self, axis: Axis) -> bool:
        info = self._in_parameter_number(axis)
        number = self.parameter_number
        if isinstance(info, ParameterInfo):
            self._key = None
            self._transfer = None
            self.value = self._convert(read_parameter(axis, number))
            return True
        _comm(axis)
        x = self._transferred(number, lambda: _start(axis, number, None))
        if x is None:
            return False
        self.value = self._convert(x)
        return True

    def _reset_values(self) -> None:
        self.value = self._convert(0.0)


class MC_ReadBoolParameter(MC_ReadParameter):
    """As MC_ReadParameter for BOOL parameters (PN 4, 5, 6; a drive parameter is TRUE when
    its value is not 0)."""

    _KIND = "bool"

    def __init__(self, name: str | None = None, **inputs: Any) -> None:
        super().__init__(name, **inputs)
        self.value = False

    def _convert(self, x: float) -> Any:
        return bool(x)


class MC_WriteParameter(ExecuteFB, InputChecks):
    """Write ``value`` to parameter ``parameter_number`` (REAL) at the rising edge of
    ``execute``: PLCopen numbers (the writable ones of Table 5; read-only ones are refused with
    PARAMETER_READ_ONLY, values out of range with INVALID_PARAMETER_VALUE naming the range) are
    applied to the axis at once (Done in this scan) or, ``execution_mode`` QUEUED, once its
    motion commands are done; drive parameters are Done when the drive confirmed the write."""

    INPUTS = ("axis", "execute", "parameter_number", "value", "execution_mode")
    _KIND = "real"

    def __init__(self, name: str | None = None, **inputs: Any) -> None:
        self.parameter_number = 0
        self.value: Any = 0.0
        self.execution_mode = ExecutionMode.IMMEDIATELY
        self._job: tuple[Handle, Axis, int, Any, ParameterTransfer | None] | None = None
        super().__init__(name, **inputs)

    # -- input checks (also before the run: motionplc validate) ----------------------------
    def _in_parameter_number(self, axis: Any) -> ParameterInfo | DriveAddress:
        return check_number_kind(self.parameter_number, self._KIND)

    def _in_value(self, axis: Any) -> Any:
        try:
            info = check_number_kind(self.parameter_number, self._KIND)
        except InputError:
            return self.value  # reported for parameter_number
        if isinstance(info, ParameterInfo):
            return check_write_value(axis, info.number, self._value_in())
        v = self._value_in()
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
            raise InputError(
                ErrorID.INVALID_PARAMETER_VALUE,
                f"value of drive parameter {self.parameter_number:#x} must be a finite number, "
                f"got {v!r}",
            )
        return v

    def _value_in(self) -> Any:
        return self.value

    def _in_execution_mode(self, axis: Any) -> ExecutionMode:
        return check_execution_mode(self.execution_mode)

    # -- execution ---------------------------------------------------------------------------
    def _start(self, axis: Axis) -> Handle:
        self._job = None
        info = self._in_parameter_number(axis)
        value = self._in_value(axis)
        mode = self._in_execution_mode(axis)
        h = Handle("parameter")
        number = info.number if isinstance(info, ParameterInfo) else self.parameter_number
        self._job = (h, axis, number, value, None)
        if mode is ExecutionMode.IMMEDIATELY or axis.mq.idle():
            self._apply()
        return h

    def _apply(self) -> None:
        """Apply the write (PLCopen) or start it (drive); errors end the handle."""
        assert self._job is not None
        h, axis, number, value, _ = self._job
        try:
            if number in PARAMETERS:
                write_parameter(axis, number, value)
                h._finish(Status.DONE)
                self._job = None
            else:
                if not axis.comm_ok:
                    raise InputError(
                        ErrorID.COMMUNICATION_LOST, f"axis {axis.name!r}: communication lost"
                    )
                t = _start(axis, number, float(value))
                self._job = (h, axis, number, value, t)
                h.status = Status.ACTIVE
        except InputError as exc:
            self.error_text = str(exc)
            h._finish(Status.ERROR, exc.error_id, str(exc))
            self._job = None

    def _scan(self) -> None:
        job = self._job
        if job is not None:
            h, axis, _, _, t = job
            if h.terminal:
                self._job = None
            elif t is None:
                if axis.mq.idle():  # QUEUED: the motion before it is done
                    self._apply()
            elif not t.busy:
                self._job = None
                if t.error:
                    exc = _failed(t)
                    h._finish(Status.ERROR, exc.error_id, str(exc))
                else:
                    h._finish(Status.DONE)
        super()._scan()


class MC_WriteBoolParameter(MC_WriteParameter):
    """As MC_WriteParameter for BOOL parameters (PN 4, 5, 6; a drive parameter gets 1 or
    0)."""

    _KIND = "bool"

    def __init__(self, name: str | None = None, **inputs: Any) -> None:
        super().__init__(name, **inputs)
        if "value" not in inputs:
            self.value = False

    def _in_value(self, axis: Any) -> Any:
        v = self.value
        if not isinstance(v, bool) and not (isinstance(v, int) and v in (0, 1)):
            raise InputError(ErrorID.INVALID_PARAMETER_VALUE, f"value must be a BOOL, got {v!r}")
        try:
            info = check_number_kind(self.parameter_number, self._KIND)
        except InputError:
            return bool(v)
        if isinstance(info, ParameterInfo):
            return check_write_value(axis, info.number, bool(v))
        return 1.0 if v else 0.0


class MC_ReadActualTorque(_Reader):
    """The actual torque (signed; N m, or N on a linear axis) while ``enable`` is TRUE:
    ``torque``. From the drive over its bus (0x6077 x 0x6076 on CAN, a register on Modbus;
    Busy until the first answer, then refreshed continuously) or from the in-process drive's
    torque model (inertia * actual acceleration + friction at the actual velocity). A drive
    that reports none: Error INVALID_AXIS, the text says what to configure."""

    def __init__(self, name: str | None = None, **inputs: Any) -> None:
        self.torque = 0.0
        super().__init__(name, **inputs)

    def _read(self, axis: Axis) -> bool:
        _comm(axis)
        drive = axis.drive
        model = drive.torque_model
        if model is not None:
            self.torque = model.torque(axis.img_act_v, axis.img_act_a)
            return True

        def start() -> ParameterTransfer:
            try:
                t = drive.start_torque_read()
            except ParameterError as exc:
                eid = ErrorID.DRIVE_PARAMETER_FAILED if exc.failed else ErrorID.INVALID_AXIS
                raise InputError(eid, str(exc)) from None
            if t is None:
                raise InputError(
                    ErrorID.INVALID_AXIS,
                    f"drive {drive.name!r} of axis {axis.name!r} reports no torque (an "
                    f"in-process drive needs a torque_model)",
                )
            return t

        x = self._transferred("torque", start)
        if x is None:
            return False
        self.torque = x
        return True

    def _reset_values(self) -> None:
        self.torque = 0.0


def simulated(drive: Any) -> bool:
    """True for a drive simulated in this process: the ideal drive, or a bus drive whose
    other end is an in-process virtual drive (a lockstep peer)."""
    if isinstance(drive, IdealDrive):
        return True
    if getattr(drive, "peer", None) is not None:
        return True
    master = getattr(drive, "master", None)
    return getattr(master, "peer", None) is not None


class MC_ReadAxisInfo(EnableFB):
    """The axis' information flags of this cycle while ``enable`` is TRUE:

    * ``home_abs_switch``: the (virtual) reference switch is on: the actual drive position at
      or above ``AxisConfig.home_switch`` (FALSE without a switch);
    * ``limit_switch_pos`` / ``limit_switch_neg``: hardware limit switches (motionplc has
      none: FALSE; the software limits are MC_ReadBoolParameter 4/5);
    * ``simulation``: the drive is simulated in this process (ideal drive, or a virtual drive
      as the bus peer);
    * ``communication_ready``: the drive's communication is good;
    * ``ready_for_power_on``: communication good, the drive not in FAULT and the axis not in
      ErrorStop (MC_Power could enable it);
    * ``power_on``: the drive reports OPERATION ENABLED;
    * ``is_homed``: MC_Home succeeded (the reference is known);
    * ``axis_warning``: the drive reports a warning (e.g. a warning EMCY).
    """

    _FLAGS = (
        "home_abs_switch",
        "limit_switch_pos",
        "limit_switch_neg",
        "simulation",
        "communication_ready",
        "ready_for_power_on",
        "power_on",
        "is_homed",
        "axis_warning",
    )

    def __init__(self, name: str | None = None, **inputs: Any) -> None:
        for f in self._FLAGS:
            setattr(self, f, False)
        super().__init__(name, **inputs)

    def _update(self, axis: Axis) -> None:
        from motionplc.blocks.enums import AxisState

        sw = axis.cfg.home_switch
        comm = bool(axis.comm_ok)
        self.home_abs_switch = sw is not None and axis.img_act_p - axis.offset >= sw
        self.limit_switch_pos = False
        self.limit_switch_neg = False
        self.simulation = simulated(axis.drive)
        self.communication_ready = comm
        self.ready_for_power_on = (
            comm and not axis.drive_fault and axis.img_state is not AxisState.ERROR_STOP
        )
        self.power_on = bool(axis.img_enabled)
        self.is_homed = bool(axis.img_homed)
        self.axis_warning = bool(axis.drive_warning)

    def _reset_values(self) -> None:
        for f in self._FLAGS:
            setattr(self, f, False)
