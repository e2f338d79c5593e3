"""Homing (MC_Home) of one axis: the procedure, run by the axis kernel.

* No reference switch configured (``AxisConfig.home_switch`` None): set-position homing; the
  set position becomes the FB's Position at once, no motion (Done in the same kernel step).
* With a (virtual) reference switch at ``home_switch`` in drive coordinates: phase 1 searches
  it at ``home_velocity`` (default 10 % of the direction's speed limit) towards the switch, with
  the axis' own acceleration and jerk; phase 2, when the actual position passes the switch,
  brakes to rest; at rest the coordinates are shifted so that the switch is at Position.

Homing is not scaled by the override. The axis stays in Homing until the end (T7).
The functions take the axis and its homing job (:class:`~motionplc.blocks.axis_job.AxisJob`,
``home_phase`` 1 / 2, ``target`` holding the search direction in phase 1).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from motionplc.blocks.axis_job import AxisJob, Command, sign
from motionplc.blocks.axis_state import Event, next_state
from motionplc.blocks.motion_queue import Status
from motionplc.blocks.planner_guard import guarded
from motionplc.planning import State, plan_velocity

if TYPE_CHECKING:
    from motionplc.blocks.axis import Axis

__all__ = ["finish_home", "home_check", "home_direction", "prepare_home"]


def prepare_home(axis: Axis, job: AxisJob) -> bool:
    """Start ``job``: False if it is done at once (set-position homing, the state is back to
    Standstill), True if the search motion was planned (phase 1)."""
    sw = axis.cfg.home_switch
    if sw is None:  # set-position homing: no motion
        axis._abort_motion()
        axis._shift_to(Command(kind="setpos", position=job.cmd.position))
        axis.homed = True
        job.handle._finish(Status.DONE)
        axis.state = next_state(Event.HOME_DONE, axis.state)  # T7
        return False
    drive_p = axis.p - axis.offset
    s = sign(sw - drive_p) or 1.0
    vh = axis.cfg.home_velocity or 0.1 * axis._v_side(s)
    lim = axis._axis_limits(0.0, 0.0, 0.0)
    job.set_chain([guarded(plan_velocity, State(axis.p, axis.v, axis.a), s * vh, lim)])
    job.home_phase = 1
    job.target = s  # search direction
    return True


def home_check(axis: Axis, job: AxisJob) -> None:
    """Every step while homing: in phase 1, once the actual position reaches the switch, brake
    to rest (phase 2; the position is set at standstill)."""
    sw = axis.cfg.home_switch
    assert sw is not None
    s = job.target or 1.0
    if job.home_phase == 1 and s * (axis.act_p - axis.offset - sw) >= 0.0:
        job.home_phase = 2  # switch reached: stop (the position is set at standstill)
        lim = axis._axis_limits(0.0, 0.0, 0.0)
        job.set_chain([guarded(plan_velocity, State(axis.p, axis.v, axis.a), 0.0, lim)])


def finish_home(axis: Axis, job: AxisJob) -> None:
    """At rest after the switch: shift the coordinates so that the switch is at the FB's
    Position; the axis is homed, the command Done."""
    sw = axis.cfg.home_switch
    assert sw is not None
    # the switch is at job.cmd.position: shift so that this holds at standstill
    axis._shift_to(Command(kind="setpos", position=job.cmd.position + (axis.p - axis.offset - sw)))
    axis.homed = True
    job.handle._finish(Status.DONE)


def home_direction(axis: Axis, job: AxisJob, base: float | None) -> float:
    """Direction (+1 / -1, 0 = none or not known) of the homing ``job`` from position ``base``
    (for the feed enables)."""
    if job.home_phase == 1:  # searching: job.target holds the search direction
        return sign(job.target or 0.0)
    sw = axis.cfg.home_switch
    if sw is None or base is None or job.home_phase:
        return 0.0
    return sign(sw - (base - axis.offset)) or 1.0
