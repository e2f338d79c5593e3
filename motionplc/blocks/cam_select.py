"""MC_CamTableSelect (PLCopen Part 1, 3.4) and the cam's slave-limit check.

Selecting a cam is separate from engaging it (MC_CamIn) so that a new table can be prepared
while the old one runs. MC_CamTableSelect checks the table against the two axes and, when it
fits, outputs ``cam_table_id``: a frozen :class:`CamTableID` (the table and how MC_CamIn is to
use it) that MC_CamIn takes as its ``cam_table_id`` input. Nothing moves and no axis state
changes.

Checks at the rising edge of Execute (the first failing one gives ``error``, its ErrorID and
``error_text``; ``cam_table_id`` stays None):

* ``slave`` connected (INVALID_AXIS), ``master`` an Axis other than the slave
  (INVALID_MASTER);
* ``cam_table`` a :class:`~motionplc.planning.CamTable` (INVALID_CAM_TABLE; a CamTable is
  valid by construction: malformed point lists are refused when the table is built, see
  :mod:`motionplc.planning.cam`); ``execution_mode`` an ExecutionMode
  (INVALID_EXECUTION_MODE);
* ``periodic``: a table whose slope at its end differs from the slope at its start would make
  the slave's velocity step at every period: INVALID_CAM_TABLE (the figures in ``error_text``);
* the slave's limits: the exact extremes of the slave's velocity, acceleration and jerk over
  the table (:meth:`CamTable.slave_bounds`) with the master moving at its current set
  velocity, acceleration and jerk must lie within the slave's configured limits (asymmetric
  ``v_min`` / ``a_min`` respected; an infinite ``j_max`` is no jerk limit):
  SLAVE_LIMITS_EXCEEDED, ``error_text`` names the quantity, the cam's figure, the master's
  motion and the limit. A master at rest passes trivially; MC_CamIn checks again with its
  scalings and the master's motion when it engages.

Then ``done`` (in the same scan: the selection is immediate; both ExecutionModes behave alike
because selecting touches no axis: when a new table takes over is MC_CamIn's BufferMode).

Inputs (PLCopen names; defaults as CODESYS SM3_Basic ``MC_CamTableSelect``: Periodic,
MasterAbsolute and SlaveAbsolute TRUE): ``master``, ``slave``, ``cam_table``, ``execute``,
``periodic``, ``master_absolute`` (TRUE: the table's master coordinate is the master's
position; FALSE: relative to where the coupling starts), ``slave_absolute`` (likewise for the
slave), ``execution_mode``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from motionplc.blocks.axis import Axis, Handle
from motionplc.blocks.axis_config import AxisConfig
from motionplc.blocks.base import ExecuteFB, InputError, check_execution_mode
from motionplc.blocks.enums import ErrorID, ExecutionMode
from motionplc.blocks.motion import InputChecks
from motionplc.blocks.motion_queue import Status
from motionplc.planning.cam import CamTable

__all__ = ["CamTableID", "MC_CamTableSelect", "cam_limit_violation"]

# a cam exactly at a limit passes (rounding of the exact extremes)
_TOL = 1e-9


@dataclass(frozen=True, slots=True)
class CamTableID:
    """MC_CAM_ID: a selected cam table and how MC_CamIn uses it (immutable, hashable).

    ``table`` the CamTable; ``periodic`` the profile repeats (the slave advances by the table's
    lift each period); ``master_absolute`` / ``slave_absolute`` table coordinates are the
    axes' positions (True) or relative to where the coupling starts (False)."""

    table: CamTable
    periodic: bool = True
    master_absolute: bool = True
    slave_absolute: bool = True


def cam_limit_violation(
    table: CamTable,
    cfg: AxisConfig,
    master_v: float,
    master_a: float = 0.0,
    master_j: float = 0.0,
    *,
    master_scaling: float = 1.0,
    slave_scaling: float = 1.0,
    periodic: bool = False,
) -> str:
    """Why the cam exceeds the slave's limits (``cfg``) with the master at velocity
    ``master_v``, acceleration ``master_a`` and jerk ``master_j``; ``""`` when it fits.

    The table is read at x = master_scaling * master (+ offset) and the slave follows
    slave_scaling * y(x) (+ offset), so the master's derivatives are scaled by
    ``master_scaling`` and the slave's by ``slave_scaling`` (a negative one swaps the signs).
    Uses the exact signed extremes (:meth:`CamTable.slave_bounds`), the slave's asymmetric
    velocity / acceleration limits and its jerk limit (none when infinite); a tolerance of
    1e-9 relative lets a cam exactly at a limit pass."""
    ms, ss = master_scaling, slave_scaling
    b = table.slave_bounds(master_v * ms, master_a * ms, master_j * ms, periodic)
    lo_hi = [(b.v_min, b.v_max), (b.a_min, b.a_max), (b.j_min, b.j_max)]
    lo_hi = [(ss * lo, ss * hi) if ss >= 0 else (ss * hi, ss * lo) for lo, hi in lo_hi]
    limits = (
        ("velocity", -cfg.v_neg, cfg.v_max),
        ("acceleration", -cfg.a_neg, cfg.a_max),
        ("jerk", -cfg.j_max, cfg.j_max),
    )
    motion = f"master velocity {master_v:.6g}, acceleration {master_a:.6g}, jerk {master_j:.6g}"
    for (name, lim_lo, lim_hi), (lo, hi) in zip(limits, lo_hi, strict=True):
        if math.isinf(lim_hi):
            continue
        over = hi > lim_hi * (1 + _TOL) or lo < lim_lo * (1 + _TOL)
        if over:
            step = " (a step at a curvature or slope jump)" if math.isinf(hi - lo) else ""
            return (
                f"the cam needs a slave {name} in [{lo + 0.0:.6g}, {hi + 0.0:.6g}]{step} "
                f"at {motion}; "
                f"the slave {cfg.name!r} allows [{lim_lo:.6g}, {lim_hi:.6g}]"
            )
    return ""


def _flag(name: str, value: Any) -> bool:
    if not isinstance(value, (bool, int)) or isinstance(value, int) and value not in (0, 1):
        raise InputError(ErrorID.INVALID_CAM_TABLE, f"{name} must be a BOOL, got {value!r}")
    return bool(value)


class MC_CamTableSelect(InputChecks, ExecuteFB):
    """Select a cam table for a master/slave pair (see the module docstring): ``done`` with
    ``cam_table_id`` (a :class:`CamTableID`) when the table fits, else ``error`` with
    INVALID_AXIS / INVALID_MASTER / INVALID_CAM_TABLE / INVALID_EXECUTION_MODE /
    SLAVE_LIMITS_EXCEEDED. ``slave`` is the FB's axis (``fb.axis is fb.slave``)."""

    INPUTS = (
        "master",
        "slave",
        "execute",
        "cam_table",
        "periodic",
        "master_absolute",
        "slave_absolute",
        "execution_mode",
    )
    OUTPUTS = ("busy", "done", "error")

    def __init__(self, name: str | None = None, **inputs: Any) -> None:
        self.master: Axis | None = None
        self.cam_table: Any = None
        self.periodic = True
        self.master_absolute = True
        self.slave_absolute = True
        self.execution_mode = ExecutionMode.IMMEDIATELY
        self.cam_table_id: CamTableID | None = None
        self._selected: CamTableID | None = None
        super().__init__(name, **inputs)

    @property
    def slave(self) -> Axis | None:
        """The slave axis (the FB's axis)."""
        return self.axis

    @slave.setter
    def slave(self, value: Axis | None) -> None:
        self.axis = value

    # -- input checks (also before the run: motionplc validate) ----------------------------
    def _in_cam_table(self, axis: Any) -> CamTable:
        tab = self.cam_table
        if not isinstance(tab, CamTable):
            raise InputError(
                ErrorID.INVALID_CAM_TABLE,
                f"cam_table must be a CamTable (motionplc.planning.CamTable), got {tab!r}",
            )
        return tab

    def _in_periodic(self, axis: Any) -> bool:
        periodic = _flag("periodic", self.periodic)
        tab = self.cam_table
        if periodic and isinstance(tab, CamTable):
            gap = tab.periodic_gaps().slope
            if abs(gap) > 1e-9 * (1.0 + tab.peak_slope):
                raise InputError(
                    ErrorID.INVALID_CAM_TABLE,
                    f"periodic: the cam's slope is {tab.at(tab.master_end)[1]:.6g} at its end "
                    f"but {tab.at(tab.master_start)[1]:.6g} at its start: the slave's velocity "
                    "would step every period (give both ends the same slope, e.g. "
                    "CamTable(..., periodic=True), or select it non-periodic)",
                )
        return periodic

    def _in_master_absolute(self, axis: Any) -> bool:
        return _flag("master_absolute", self.master_absolute)

    def _in_slave_absolute(self, axis: Any) -> bool:
        return _flag("slave_absolute", self.slave_absolute)

    def _in_execution_mode(self, axis: Any) -> ExecutionMode:
        return check_execution_mode(self.execution_mode)

    # -- execution -------------------------------------------------------------------------
    def _start(self, axis: Axis) -> Handle:
        self.cam_table_id = None
        master = self.master
        if not isinstance(master, Axis) or master is axis:
            raise InputError(
                ErrorID.INVALID_MASTER,
                f"master must be an Axis other than the slave, got {master!r}",
            )
        tab = self._in_cam_table(axis)
        periodic = self._in_periodic(axis)
        cam_id = CamTableID(
            tab, periodic, self._in_master_absolute(axis), self._in_slave_absolute(axis)
        )
        self._in_execution_mode(axis)
        why = cam_limit_violation(
            tab, axis.cfg, master.img_v, master.img_a, master.j, periodic=periodic
        )
        if why:
            raise InputError(ErrorID.SLAVE_LIMITS_EXCEEDED, why)
        self._selected = cam_id
        h = Handle("camselect")
        h._finish(Status.DONE)
        return h

    def _terminal_outputs(self, h: Handle) -> None:
        if h.status is Status.DONE:
            self.cam_table_id = self._selected
