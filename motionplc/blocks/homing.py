"""Homing (MC_Home) of one axis: the procedure, run by the axis kernel.

* No reference switch configured (``AxisConfig.home_switch`` None): set-position homing; the
  set position becomes the FB's Position at once, no motion (Done in the same kernel step).
* With a (virtual) reference switch at ``home_switch`` in drive coordinates: phase 1 searches
  it at ``home_velocity`` (default 10 % of the direction's speed limit) towards the switch, with
  the axis' own acceleration and jerk; phase 2, when the actual position passes the switch,
  brakes to rest; at rest the coordinates are shifted so that the switch is at Position.

* Homing by the drive (the drive has ``drive_homing``, e.g. a CiA 402 drive configured with
  a :class:`~motionplc.fieldbus.cia402.HomingSpec`): the drive runs its homing method
  (:meth:`~motionplc.fieldbus.base.Drive.start_homing`; over CAN: homing mode, bit 4, the
  statusword bits, back to CSP) while the axis' set values follow the drive's actual position
  (``home_phase`` 3..5, see :func:`drive_home_step`: the set velocity tracks the drive's
  motion within the axis' velocity and acceleration limits, a = 0: no following error
  alarm, no jump), the axis in Homing.
  The jump the drive makes in its position values when it sets the home position is taken
  into the axis' offset in that cycle (a coordinate shift, no motion); once the drive is back in its
  cyclic mode and the set velocity is 0 (phase 4) the axis takes the drive's position as its
  own (offset 0: the axis position at the home point is the drive's home offset), homed,
  Done. A drive that reports failure (CiA 402 bit 13, a time-out, an SDO abort) ends MC_Home
  with Error HOMING_FAILED and the axis goes to ErrorStop (HOMING_FAILED); one that cannot
  start gives the Error and the axis stays in Standstill. MC_Home's ``position`` is not
  used: the drive's home offset is the reference.

Homing is not scaled by the override. The axis stays in Homing until the end (T7).
The functions take the axis and its homing job (:class:`~motionplc.blocks.axis_job.AxisJob`,
``home_phase`` 1 / 2, ``target`` holding the search direction in phase 1).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

from motionplc.blocks.axis_job import AxisJob, Command, sign
from motionplc.blocks.axis_state import Event, next_state
from motionplc.blocks.enums import ErrorID
from motionplc.blocks.motion_queue import Status
from motionplc.blocks.planner_guard import guarded
from motionplc.planning import State, plan_velocity

if TYPE_CHECKING:
    from motionplc.blocks.axis import Axis

__all__ = ["drive_home_step", "finish_home", "home_check", "home_direction", "prepare_home"]


def prepare_home(axis: Axis, job: AxisJob) -> bool:
    """Start ``job``: False if it is done at once (set-position homing, the state is back to
    Standstill), True if the search motion was planned (phase 1) or the drive homes (phase
    3)."""
    if axis.drive.drive_homing is not None:
        return _start_drive_homing(axis, job)
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


def _start_drive_homing(axis: Axis, job: AxisJob) -> bool:
    err = axis.drive.start_homing()
    if err:
        job.handle._finish(Status.ERROR, ErrorID.HOMING_FAILED, err)
        axis.state = next_state(Event.HOME_DONE, axis.state)  # T7: back, nothing moved
        return False
    # a standing chain (never sampled: drive_home_step sets the set values)
    lim = axis._axis_limits(0.0, 0.0, 0.0)
    job.set_chain([guarded(plan_velocity, State(axis.p, 0.0, 0.0), 0.0, lim)])
    job.home_phase = 3
    axis.drive_homing_job = job
    axis._io_watch = True
    return True


def drive_home_step(axis: Axis, job: AxisJob, dt: float) -> None:
    """Every kernel step while the drive homes (see the module notes). ``home_phase`` 3: the
    set values track the drive; 4: the drive set its position values (it rests at the home
    position): brake to rest; 5: the drive is back in its cyclic mode: done at rest."""
    drive = axis.drive
    shift = drive.homing_shift
    if shift:
        # the drive set its position values: a coordinate shift of the axis, no motion
        drive.homing_shift = 0.0
        axis.offset -= shift
        axis.act_p -= shift
        axis.following_error += shift
        if job.home_phase == 3:
            # the drive rests at its home position: the set values take it exactly (this
            # step shifts the coordinates anyway)
            job.home_phase = 4
            axis.p = axis.act_p
            axis.v = axis.a = axis.j = 0.0
            return
    cfg = axis.cfg
    if job.home_phase == 3:
        # track the drive's motion within the axis' own limits: aim at where it will be at
        # the next step, approaching it on a braking curve
        e = axis.act_p + axis.act_v * dt - axis.p
        ae = abs(e)
        corr = min(ae / dt, math.sqrt(min(cfg.a_max, cfg.a_neg) * ae))
        v_target = min(cfg.v_max, max(-cfg.v_neg, axis.act_v + math.copysign(corr, e)))
    else:
        v_target = 0.0  # the drive rests (or follows the set values again): come to rest
    # towards v_target on a jerk-limited velocity profile within the axis' own limits, sampled
    # at the end of the step: set values that hold the limits and agree with each other (was
    # a velocity step of up to a_max * dt with the acceleration and jerk written as 0)
    prof = guarded(
        plan_velocity, State(axis.p, axis.v, axis.a), v_target, axis._axis_limits(0, 0, 0)
    )
    s = prof.at(dt)
    v = s.v
    if abs(v) < 1e-12 * cfg.v_max and s.a == 0.0:
        v = 0.0
    # (a profile shorter than the step ends at v_target: cruising at it for the rest)
    p = s.p + v * (dt - prof.duration) if dt > prof.duration else s.p
    axis.p, axis.v, axis.a, axis.j = p, v, s.a, s.j
    if job.home_phase < 5:
        result = drive.homing_result()
        if result is None:
            return
        if result:
            axis.drive_homing_job = None
            job.handle._finish(Status.ERROR, ErrorID.HOMING_FAILED, result)
            axis.raise_axis_error("HOMING_FAILED", f"homing by the drive failed: {result}")
            return
        job.home_phase = 5
    if v != 0.0:
        return
    axis.drive_homing_job = None
    axis._shift_to(Command(kind="setpos", position=axis.p - axis.offset))  # offset 0
    axis.homed = True
    job.handle._finish(Status.DONE)
    axis.mq.active = None
    axis._ahead = True
    if axis._activate_queued() is None:
        axis.state = next_state(Event.HOME_DONE, axis.state)  # T7
