"""The parameter table of MC_ReadParameter / MC_WriteParameter (PLCopen Part 1, Table 5) and
the number scheme of drive parameters.

PLCopen numbers 1-17 (0-999 reserved by PLCopen; 18-999 are refused):

====  ========================  ====  =====  =============================================
PN    name                      type  R/W    motionplc meaning
====  ========================  ====  =====  =============================================
1     CommandedPosition         REAL  R      the set position (wrapped on a modulo axis)
2     SWLimitPos                REAL  R/W    positive software limit (+inf: never set)
3     SWLimitNeg                REAL  R/W    negative software limit (-inf: never set)
4     EnableLimitPos            BOOL  R/W    the positive software limit is checked
5     EnableLimitNeg            BOOL  R/W    the negative software limit is checked
6     EnablePosLagMonitoring    BOOL  R/W    the following error is monitored
7     MaxPositionLag            REAL  R/W    following error limit (+inf: never set)
8     MaxVelocitySystem         REAL  R      the configured speed limit (``v_top``)
9     MaxVelocityAppl           REAL  R/W    the speed limit new commands use, <= PN 8
10    ActualVelocity            REAL  R      the actual velocity
11    CommandedVelocity         REAL  R      the set velocity
12    MaxAccelerationSystem     REAL  R      the configured ``a_max``
13    MaxAccelerationAppl       REAL  R/W    ``a_max`` new commands use, <= PN 12
14    MaxDecelerationSystem     REAL  R      the configured ``|a_min|`` (``a_neg``)
15    MaxDecelerationAppl       REAL  R/W    ``|a_min|`` new commands use, <= PN 14
16    MaxJerkSystem             REAL  R      the configured ``j_max`` (inf: none)
17    MaxJerkAppl               REAL  R/W    ``j_max`` new commands use, <= PN 16
====  ========================  ====  =====  =============================================

Rules pinned here:

* A write changes the axis' applied configuration (:meth:`Axis.apply_config`: a new frozen
  :class:`AxisConfig`, the kernel's hot copies refreshed); the configuration the axis was
  built with stays the *System values (``Axis.cfg_system``). What is planned or checked from
  then on uses the new values: a running move keeps its plan (as vendors do); the software
  limits and the following-error monitoring act from the next cycle; the FB input ranges of
  the motion FBs (Velocity, Acceleration, Deceleration, Jerk) follow the *Appl values. The
  software-limit supervision judges and brakes with the system dynamics (what the axis can
  do), so a move planned before a lower *Appl write still ends at a limit as planned; the
  ErrorStop ramp and MC_Stop / MC_Halt without their own inputs use the applied values.
* A limit switched off (PN 4/5/6 FALSE) keeps its value: reading PN 2/3/7 gives it, writing it
  stores it, and switching the check on again uses it. Switching a check on with no value ever
  set is refused (INVALID_PARAMETER_VALUE naming the PN to write first).
* motionplc's acceleration limits are per sign of the acceleration (``AxisConfig.a_max`` for
  a > 0, ``a_min`` for a < 0, as on a vertical axis). PN 12/13 (acceleration) are the
  positive side and PN 14/15 (deceleration) the negative side: on a move in the positive
  direction that is PLCopen's acceleration and deceleration exactly; moving negatively the
  two sides swap roles. Write both to one value for direction-independent limits.
* PN 9 caps both speed sides (``v_max`` and ``|v_min|``, each never above its system value).
* Ranges: PN 2/3 within +-1e12 and SWLimitNeg < SWLimitPos while both are checked; PN 7 in
  (0, 1e12]; PN 9/13/15/17 in [1e-6, the system value] (PN 17 also inf when PN 16 is inf).
  Anything else is INVALID_PARAMETER_VALUE with the range in the text; a read-only number is
  PARAMETER_READ_ONLY; a BOOL number with the REAL FBs (or the reverse) and an unknown number
  are INVALID_PARAMETER_NUMBER. Modulo axes have no software limits: PN 2-5 are refused there
  for writing (PN 4/5 read FALSE).

Drive parameters (vendor numbers, >= 0x10000; the scheme of CODESYS SoftMotion's
``MC_ReadParameter_SML`` / ``SMC_ParameterNumber_CoE``, positive, a number and its negation
mean the same parameter, so CODESYS' negative numbers work as they are):

* CANopen (CiA 402 over SDO): ``number = T * 0x1000000 + index * 0x100 + subindex``
  (index 0x1000-0xFFFF), e.g. ``0x606500`` = following error window 0x6065:00.
* Modbus (holding register): ``number = T * 0x1000000 + 0x10000 + address``, e.g.
  ``0x10300`` = register 0x0300.
* ``T`` (optional) gives the type: 1, 2, 4 = unsigned 8/16/32 bit, 0x41, 0x42, 0x44 = signed
  (0x40 + the size), 0x24 = IEEE 754 single (REAL32 / f32; a motionplc extension of the
  CODESYS lengths). With T = 0 the type comes from the drive's description (the EDS of a CAN
  drive, the register map of a Modbus drive); without one a CAN read takes the size the drive
  answers with (unsigned, as CODESYS does) and a write first uploads the object to learn its
  size (a negative value is written as two's complement); a Modbus register not in the map
  is one unsigned 16-bit register. On Modbus 1-byte types do not exist, 32-bit values
  take two registers in the map's word order.

Values are the drive's raw integers (no unit scaling); :func:`coe_parameter_number` and
:func:`modbus_parameter_number` build numbers.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Any

from motionplc.blocks.axis_config import AXIS_LIMIT_MIN, POSITION_MAX, AxisConfig
from motionplc.blocks.base import InputError
from motionplc.blocks.enums import ErrorID
from motionplc.fieldbus.base import DriveAddress

__all__ = [
    "DRIVE_NUMBER_MIN",
    "PARAMETERS",
    "AxisParameters",
    "ConfigTracker",
    "DriveAddress",
    "ParameterInfo",
    "check_number_kind",
    "check_write_value",
    "coe_parameter_number",
    "decode_drive_number",
    "modbus_parameter_number",
    "read_parameter",
    "write_parameter",
]

_INF = math.inf
DRIVE_NUMBER_MIN = 0x10000  # |numbers| from here on address drive parameters
# T -> (size, signed, real)
_TYPE_CODES = {1: (1, False, False), 2: (2, False, False), 4: (4, False, False)}
_TYPE_CODES.update({0x41: (1, True, False), 0x42: (2, True, False), 0x44: (4, True, False)})
_TYPE_CODES[0x24] = (4, True, True)


@dataclass(frozen=True, slots=True)
class ParameterInfo:
    """One PLCopen parameter number: its name, type (``"real"`` / ``"bool"``) and access."""

    number: int
    name: str
    kind: str
    writable: bool


PARAMETERS: dict[int, ParameterInfo] = {
    p.number: p
    for p in (
        ParameterInfo(1, "CommandedPosition", "real", False),
        ParameterInfo(2, "SWLimitPos", "real", True),
        ParameterInfo(3, "SWLimitNeg", "real", True),
        ParameterInfo(4, "EnableLimitPos", "bool", True),
        ParameterInfo(5, "EnableLimitNeg", "bool", True),
        ParameterInfo(6, "EnablePosLagMonitoring", "bool", True),
        ParameterInfo(7, "MaxPositionLag", "real", True),
        ParameterInfo(8, "MaxVelocitySystem", "real", False),
        ParameterInfo(9, "MaxVelocityAppl", "real", True),
        ParameterInfo(10, "ActualVelocity", "real", False),
        ParameterInfo(11, "CommandedVelocity", "real", False),
        ParameterInfo(12, "MaxAccelerationSystem", "real", False),
        ParameterInfo(13, "MaxAccelerationAppl", "real", True),
        ParameterInfo(14, "MaxDecelerationSystem", "real", False),
        ParameterInfo(15, "MaxDecelerationAppl", "real", True),
        ParameterInfo(16, "MaxJerkSystem", "real", False),
        ParameterInfo(17, "MaxJerkAppl", "real", True),
    )
}


# --------------------------------------------------------------------------- drive numbers
def _type_code(size: int, signed: bool, real: bool = False) -> int:
    if real:
        if size not in (0, 4):
            raise ValueError(f"a real (float32) parameter has size 4, got {size!r}")
        return 0x24
    if size == 0:
        if signed:
            raise ValueError("signed needs a size (1, 2 or 4)")
        return 0
    if size not in (1, 2, 4):
        raise ValueError(f"size must be 0 (from the drive's description), 1, 2 or 4, got {size!r}")
    return size | (0x40 if signed else 0)


def coe_parameter_number(
    index: int, subindex: int = 0, size: int = 0, signed: bool = False, real: bool = False
) -> int:
    """The parameter number of CANopen object ``index:subindex`` (index 0x1000-0xFFFF,
    subindex 0-255), with its type when given (see the module notes)."""
    if not (isinstance(index, int) and 0x1000 <= index <= 0xFFFF):
        raise ValueError(f"index must be an integer in 0x1000..0xFFFF, got {index!r}")
    if not (isinstance(subindex, int) and 0 <= subindex <= 0xFF):
        raise ValueError(f"subindex must be an integer in 0..255, got {subindex!r}")
    return _type_code(size, signed, real) * 0x1000000 + index * 0x100 + subindex


def modbus_parameter_number(
    address: int, size: int = 0, signed: bool = False, real: bool = False
) -> int:
    """The parameter number of Modbus holding register ``address`` (0-0xFFFF, a PDU
    address), with its type when given (size 2 or 4; see the module notes)."""
    if not (isinstance(address, int) and 0 <= address <= 0xFFFF):
        raise ValueError(f"address must be an integer in 0..0xFFFF, got {address!r}")
    if size == 1:
        raise ValueError("Modbus registers have no 1-byte type (size 2 or 4)")
    return _type_code(size, signed, real) * 0x1000000 + 0x10000 + address


def decode_drive_number(number: int) -> DriveAddress | None:
    """The drive address of a vendor number (None: not a valid drive parameter number)."""
    if isinstance(number, bool) or not isinstance(number, int):
        return None
    n = abs(number)
    if n < DRIVE_NUMBER_MIN:
        return None
    code, rest = divmod(n, 0x1000000)
    if code not in _TYPE_CODES and code != 0:
        return None
    size, signed, real = _TYPE_CODES.get(code, (0, False, False))
    if rest >= 0x100000:
        return DriveAddress("coe", rest >> 8, rest & 0xFF, size, signed, real)
    if rest >= 0x20000 or size == 1:
        return None
    return DriveAddress("modbus", rest - 0x10000, 0, size, signed, real)


# --------------------------------------------------------------------------- axis state
class AxisParameters:
    """What the parameter FBs remember of one axis beyond its configuration: the values of
    software limits and of the following-error limit while their check is switched off."""

    __slots__ = ("lag", "sw_neg", "sw_pos")

    def __init__(self, cfg: AxisConfig) -> None:
        self.sw_pos = cfg.sw_limit_pos
        self.sw_neg = cfg.sw_limit_neg
        self.lag = cfg.following_error_limit


def _state(axis: Any) -> AxisParameters:
    st = getattr(axis, "parameters", None)
    if st is None:
        st = AxisParameters(axis.cfg)
        if hasattr(axis, "parameters"):
            axis.parameters = st
    return st


def _system(axis: Any) -> AxisConfig:
    cfg: AxisConfig = getattr(axis, "cfg_system", None) or axis.cfg
    return cfg


def check_number_kind(number: Any, kind: str) -> ParameterInfo | DriveAddress:
    """The PLCopen parameter ``number`` for the FBs of type ``kind`` ("real" / "bool"), or
    the drive address of a vendor number; raises InputError INVALID_PARAMETER_NUMBER."""
    eid = ErrorID.INVALID_PARAMETER_NUMBER
    if isinstance(number, bool) or not isinstance(number, int):
        raise InputError(eid, f"parameter_number must be an integer, got {number!r}")
    info = PARAMETERS.get(number)
    if info is not None:
        if info.kind != kind:
            fb = (
                "MC_ReadBoolParameter / MC_WriteBoolParameter"
                if info.kind == "bool"
                else ("MC_ReadParameter / MC_WriteParameter")
            )
            raise InputError(
                eid, f"parameter {number} ({info.name}) is {info.kind.upper()}: use {fb}"
            )
        return info
    addr = decode_drive_number(number)
    if addr is not None:
        return addr
    raise InputError(
        eid,
        f"parameter_number {number} is not a parameter: PLCopen numbers 1..17, drive "
        f"parameters 0x10000 + register (Modbus) or index * 0x100 + subindex (CANopen), "
        f"see motionplc.blocks.axis_params",
    )


# --------------------------------------------------------------------------- read
def read_parameter(axis: Any, number: int) -> float | bool:
    """The value of PLCopen parameter ``number`` (1..17) of a running axis (its image of
    this cycle)."""
    cfg: AxisConfig = axis.cfg
    sys_cfg = _system(axis)
    st = _state(axis)
    if number == 1:
        return float(axis.wrap(axis.img_p))
    if number == 2:
        return _INF if st.sw_pos is None else st.sw_pos
    if number == 3:
        return -_INF if st.sw_neg is None else st.sw_neg
    if number == 4:
        return cfg.modulo is None and cfg.sw_limit_pos is not None
    if number == 5:
        return cfg.modulo is None and cfg.sw_limit_neg is not None
    if number == 6:
        return cfg.following_error_limit is not None
    if number == 7:
        return _INF if st.lag is None else st.lag
    if number == 8:
        return sys_cfg.v_top
    if number == 9:
        return cfg.v_top
    if number == 10:
        return float(axis.img_act_v)
    if number == 11:
        return float(axis.img_v)
    if number == 12:
        return sys_cfg.a_max
    if number == 13:
        return cfg.a_max
    if number == 14:
        return sys_cfg.a_neg
    if number == 15:
        return cfg.a_neg
    if number == 16:
        return sys_cfg.j_max
    if number == 17:
        return cfg.j_max
    raise InputError(ErrorID.INVALID_PARAMETER_NUMBER, f"parameter_number {number} unknown")


# --------------------------------------------------------------------------- write
def _bad(text: str) -> InputError:
    return InputError(ErrorID.INVALID_PARAMETER_VALUE, text)


def _real(info: ParameterInfo, value: Any, lo: float, hi: float, lo_open: bool = False) -> float:
    ok = isinstance(value, (int, float)) and not isinstance(value, bool)
    x = float(value) if ok else math.nan
    inside = (x > lo if lo_open else x >= lo) and x <= hi
    if not ok or math.isnan(x) or not inside or (math.isinf(x) and not math.isinf(hi)):
        rng = f"{'(' if lo_open else '['}{lo:g}, {hi:g}]"
        raise _bad(
            f"value of parameter {info.number} ({info.name}) must be in {rng}, got {value!r}"
        )
    return x


def check_write_value(axis: Any, number: int, value: Any) -> float | bool:
    """Validate ``value`` for writing PLCopen parameter ``number`` to ``axis`` (a running
    Axis or a StaticAxis: its configuration only); returns it (float or bool) or raises
    InputError (PARAMETER_READ_ONLY, INVALID_PARAMETER_NUMBER, INVALID_PARAMETER_VALUE)."""
    info = PARAMETERS[number]
    if not info.writable:
        raise InputError(
            ErrorID.PARAMETER_READ_ONLY, f"parameter {number} ({info.name}) is read-only"
        )
    cfg: AxisConfig = axis.cfg
    sys_cfg = _system(axis)
    if number in (2, 3, 4, 5) and cfg.modulo is not None:
        raise InputError(
            ErrorID.INVALID_PARAMETER_NUMBER,
            f"parameter {number} ({info.name}): a modulo axis has no software limits",
        )
    if info.kind == "bool":
        if not isinstance(value, (bool, int)) or isinstance(value, int) and value not in (0, 1):
            raise _bad(f"value of parameter {number} ({info.name}) must be a BOOL, got {value!r}")
        return bool(value)
    if number in (2, 3):
        return _real(info, value, -POSITION_MAX, POSITION_MAX)
    if number == 7:
        return _real(info, value, 0.0, POSITION_MAX, lo_open=True)
    top = {9: sys_cfg.v_top, 13: sys_cfg.a_max, 15: sys_cfg.a_neg, 17: sys_cfg.j_max}[number]
    return _real(info, value, AXIS_LIMIT_MIN, top)


def _config_after(axis: Any, number: int, x: float | bool) -> AxisConfig:
    """The applied configuration after writing ``x`` to ``number`` (validated)."""
    cfg: AxisConfig = axis.cfg
    sys_cfg = _system(axis)
    st = _state(axis)
    info = PARAMETERS[number]
    if number in (2, 4):
        value = st.sw_pos if number == 4 else float(x)
        on = bool(x) if number == 4 else cfg.sw_limit_pos is not None
        if on and value is None:
            raise _bad("EnableLimitPos (4): no SWLimitPos set, write parameter 2 first")
        if on and cfg.sw_limit_neg is not None and not value > cfg.sw_limit_neg:  # type: ignore[operator]
            raise _bad(
                f"parameter {number} ({info.name}): SWLimitPos {value:g} must be above the "
                f"checked SWLimitNeg {cfg.sw_limit_neg:g}"
            )
        return replace(cfg, sw_limit_pos=value if on else None)
    if number in (3, 5):
        value = st.sw_neg if number == 5 else float(x)
        on = bool(x) if number == 5 else cfg.sw_limit_neg is not None
        if on and value is None:
            raise _bad("EnableLimitNeg (5): no SWLimitNeg set, write parameter 3 first")
        if on and cfg.sw_limit_pos is not None and not value < cfg.sw_limit_pos:  # type: ignore[operator]
            raise _bad(
                f"parameter {number} ({info.name}): SWLimitNeg {value:g} must be below the "
                f"checked SWLimitPos {cfg.sw_limit_pos:g}"
            )
        return replace(cfg, sw_limit_neg=value if on else None)
    if number in (6, 7):
        value = st.lag if number == 6 else float(x)
        on = bool(x) if number == 6 else cfg.following_error_limit is not None
        if on and value is None:
            raise _bad("EnablePosLagMonitoring (6): no MaxPositionLag set, write parameter 7 first")
        return replace(cfg, following_error_limit=value if on else None)
    v = float(x)
    if number == 9:
        v_min = None if sys_cfg.v_min is None else -min(v, sys_cfg.v_neg)
        return replace(cfg, v_max=min(v, sys_cfg.v_max), v_min=v_min)
    if number == 13:
        a_neg = cfg.a_neg
        return replace(cfg, a_max=v, a_min=None if a_neg == v else -a_neg)
    if number == 15:
        return replace(cfg, a_min=None if v == cfg.a_max else -v)
    return replace(cfg, j_max=v)  # 17


def write_parameter(axis: Any, number: int, value: Any) -> None:
    """Write PLCopen parameter ``number`` of a running axis (validated as
    :func:`check_write_value`, then against the axis' other values); the axis' applied
    configuration is replaced (:meth:`Axis.apply_config`). Raises InputError."""
    x = check_write_value(axis, number, value)
    try:
        axis.apply_config(_config_after(axis, number, x))
    except ValueError as exc:  # AxisConfig's own checks (e.g. a limit combination)
        raise _bad(f"parameter {number} ({PARAMETERS[number].name}): {exc}") from None
    st = _state(axis)
    if number == 2:
        st.sw_pos = float(x)
    elif number == 3:
        st.sw_neg = float(x)
    elif number == 7:
        st.lag = float(x)


class ConfigTracker:
    """An axis' configuration through PLCopen parameter writes without a running axis (for
    the checks of a sequence before the run): :meth:`write` validates a write exactly as
    MC_WriteParameter does on a running axis (the same functions) and ``cfg`` is the applied
    configuration after it; ``cfg_system`` stays the configuration it started with."""

    __slots__ = ("cfg", "cfg_system", "name", "parameters")

    def __init__(self, cfg: AxisConfig) -> None:
        self.name = cfg.name
        self.cfg_system = cfg
        self.cfg = cfg
        self.parameters: AxisParameters | None = None

    def apply_config(self, config: AxisConfig) -> None:
        """Take the configuration a write produced (called by :func:`write_parameter`)."""
        self.cfg = config

    def write(self, number: int, value: Any) -> None:
        """Write PLCopen parameter ``number`` (1..17); raises InputError as the FB reports."""
        if number not in PARAMETERS:
            raise InputError(
                ErrorID.INVALID_PARAMETER_NUMBER, f"parameter_number {number} is not 1..17"
            )
        write_parameter(self, number, value)
