"""The axis (AXIS_REF): drive image, power, reset and errors, state machine glue, command
submission, the kernel step, 1-D moves and blending junctions.

FBs submit commands (:meth:`Axis.submit`) and follow them through a :class:`Handle`. The axis
is the single writer of the set values: every kernel step (:meth:`Axis.step`) resolves the
queue (Aborting / Buffered / Blending*), samples the active profile and advances the state
machine. Handle changes made by the kernel are seen by the FBs at their next call, one cycle
later, which makes FB outputs independent of the call order of FB instances.

The kernel's parts, each in its own module of ``motionplc.blocks``:

* ``axis_config``: :class:`AxisConfig` and the input envelope (``SUPPORTED_DURATION``, ...).
* ``axis_job``: :class:`Command` (an FB's request) and ``AxisJob`` (its profile chain).
* ``motion_queue``: ``MotionQueue`` (inbox, active job, queue, stops, pending updates),
  :class:`Handle`, :class:`Status`, ``junction_velocity``, ``ReplanBudget`` (axes and groups).
* ``homing``: the MC_Home procedure. ``sw_limits``: braking distances, stops at a limit.
* ``planner_guard``: every planner call of the kernels, counted (:func:`planner_calls`).
* ``axis_state``: the PLCopen state diagram (tables).
* ``_axis_core``: :class:`~motionplc.blocks._axis_core.AxisCore`, the base class holding the hot
  values and the per-cycle common case (``read_inputs`` with an ideal drive, ``step_write``,
  ``trace_cycle``), compiled with mypyc in the build (pure Python otherwise).

Every name importable from this module before the split still is (``__all__``).

Rules pinned here (the spec leaves them open):

* Profiles are planned from the current set state (p, v, a): a new motion never makes the
  acceleration jump (with a finite ``j_max``).
* A job that ends between two cycles hands the rest of the cycle to its successor, so "Done of
  block n" and "Active of block n+1" appear in the same cycle and no time is lost.
* Blending: the junction velocity (min / first / second / max of the two Velocity inputs) is
  passed at the first block's end position; the first block is (re)planned to reach it, from the
  moment the second block is queued. If it cannot be reached without reversal or overshoot (of
  either block), the highest reachable one is used (bisection) and reported as
  ``Handle.end_velocity``. A junction velocity above the first block's own Velocity is reached
  by cruising at its Velocity and accelerating just before its end (spec Appendix A, Ex. 6).
* A queued move's start profile is planned ahead of its hand-over, in a cycle without other
  planning (at most one profile per task cycle: :meth:`Axis.plan_ahead`), and the hand-over
  reuses it only if its planner inputs are bit-identical (:meth:`Axis._plan_memo`): axes
  handing over in the same cycle do not all plan at once, and the trace does not change.
* Blending after a MoveVelocity acts like Buffered with the velocity of the first block
  (``blend_after_continuous="previous"``) or is an error (``"error"``).
* Asymmetric axis limits (``AxisConfig.v_min`` / ``a_min``) are used as they are; the FB
  dynamic inputs only cap them (:meth:`Axis._limits`), they never widen them.
* MC_SetOverride's VelFactor ``f`` caps the velocity: a move plans with ``f * Velocity`` (and
  ``f`` times the blending junction speed), MoveVelocity with ``f * Velocity`` as its target. A
  change of ``f`` re-plans the running move from its set state in the next step (TwinCAT /
  CODESYS: the new velocity is reached with the move's acceleration and jerk), so the set values
  stay within the limits by construction -- the time scaling this replaces (``v = f x'``,
  ``a = f^2 x'' + f' x'``) exceeded a_max and j_max by differencing while ``f`` ramped. ``f = 0``
  brakes a move to standstill, where it waits Active. Stop, Halt, Home, couplings and the
  ErrorStop ramp are not scaled. AccFactor/JerkFactor scale the limits of what is planned later.
"""

from __future__ import annotations

import math
import struct
from collections.abc import Callable
from dataclasses import replace
from typing import TYPE_CHECKING, Any

from motionplc._fastinit import slot_setters
from motionplc.blocks._axis_core import AxisCore
from motionplc.blocks.axis_config import (
    AXIS_LIMIT_MAX,
    AXIS_LIMIT_MIN,
    OVERRIDE_MIN,
    POSITION_MAX,
    SUPPORTED_DURATION,
    VELOCITY_RATIO_MIN,
    AxisConfig,
)
from motionplc.blocks.axis_job import EVENTS, AxisJob, Command, sign
from motionplc.blocks.axis_state import Event, allowed, next_state
from motionplc.blocks.drive_errors import drive_error_kind
from motionplc.blocks.enums import AxisState, BufferMode, Direction, ErrorID
from motionplc.blocks.homing import (
    drive_home_step,
    finish_home,
    home_check,
    home_direction,
    prepare_home,
)
from motionplc.blocks.motion_queue import (
    Handle,
    MotionQueue,
    ReplanBudget,
    Status,
    junction_velocity,
)
from motionplc.blocks.planner_guard import guarded as _guarded
from motionplc.blocks.planner_guard import planner_calls
from motionplc.blocks.sw_limits import crossed_limit, limit_stop_profile, stop_distance, stop_speed
from motionplc.blocks.sync_job import SYNC_KINDS, SyncCommand
from motionplc.blocks.sync_job import keep_velocity as _keep_velocity
from motionplc.blocks.sync_job import prepare as _prepare_sync
from motionplc.blocks.sync_job import submit as _submit_sync
from motionplc.fieldbus.base import (
    Drive,
    DriveCommand,
    DriveFeedback,
    read_inputs_via_values,
    write_outputs_via_setpoint,
)
from motionplc.fieldbus.error_codes import describe
from motionplc.fieldbus.ideal import IdealDrive
from motionplc.planning import Limits, PlanningError, Profile, State, plan, plan_velocity

if TYPE_CHECKING:
    from collections import deque

    from motionplc.runtime.trace import Trace


# the kernel's planner calls look ``plan`` / ``plan_velocity`` up here (tests patch them here)
def _plan(start: State, target: State, limits: Limits) -> Profile:
    """``plan`` for the kernel (counted and guarded: :func:`~.planner_guard.guarded`)."""
    return _guarded(plan, start, target, limits)


def _plan_velocity(start: State, v_target: float, limits: Limits) -> Profile:
    """``plan_velocity`` for the kernel (counted and guarded)."""
    return _guarded(plan_velocity, start, v_target, limits)


_KEY = struct.Struct("<11d")
_MEMO_SIZE = 64

# the names importable from here before the kernel was split into modules (re-exported)
__all__ = [
    "AXIS_LIMIT_MAX",
    "AXIS_LIMIT_MIN",
    "OVERRIDE_MIN",
    "POSITION_MAX",
    "SUPPORTED_DURATION",
    "VELOCITY_RATIO_MIN",
    "Axis",
    "AxisConfig",
    "Command",
    "Handle",
    "ReplanBudget",
    "Status",
    "planner_calls",
]

_INF = math.inf
S = AxisState

_new = object.__new__
try:
    (_cp, _cv, _ca, _ce, _cr), _ = slot_setters(
        DriveCommand, ("position", "velocity", "acceleration", "enable", "fault_reset")
    )

    def _drive_command(p: float, v: float, a: float, enable: bool, reset: bool) -> DriveCommand:
        """``DriveCommand(p, v, a, enable, reset)``, built cheaply (once per axis and cycle)."""
        cmd = _new(DriveCommand)
        _cp(cmd, p)
        _cv(cmd, v)
        _ca(cmd, a)
        _ce(cmd, enable)
        _cr(cmd, reset)
        return cmd

except TypeError:  # DriveCommand changed: the normal constructor (slower, same values)
    _drive_command = DriveCommand  # type: ignore[assignment]


def _back_p(p: float, v: float, a: float, j: float, h: float) -> float:
    """The position ``h`` seconds earlier along a constant-jerk motion."""
    return p - h * (v - h * (0.5 * a - h * j / 6.0))


def _is_stop(job: AxisJob) -> bool:
    """An MC_Stop job (kept Busy when other motion is aborted)."""
    return job.kind == "stop"


def _clean(prof: Profile, s: float, p_limit: float, v_start: float) -> bool:
    """No overshoot past ``p_limit`` in direction ``s`` and no reversal (if not already)."""
    (pmin, pmax), (vmin, vmax), _ = prof.extrema()
    tol = 1e-9 * (1.0 + abs(p_limit))
    vtol = 1e-9 * (1.0 + abs(v_start))
    if s > 0.0:
        if pmax > p_limit + tol:
            return False
        return v_start < -vtol or vmin >= -vtol
    if pmin < p_limit - tol:
        return False
    return v_start > vtol or vmax <= vtol


def _fault_text(code: int, detail: str) -> str:
    """The reason of a drive fault: the code with its meaning, then the backend's detail;
    a detail that already names the code is the whole text (no repetition)."""
    name = f"0x{code:04X}"
    if name in detail:
        return detail
    head = f"drive fault {name} ({describe(code)})"
    return f"{head}: {detail}" if detail else head


class Axis(AxisCore):
    """AXIS_REF: one axis with its drive, state machine, command queue and set values.

    The per-cycle common case (``read_inputs``, ``step_write``, ``trace_cycle``) and the hot
    attributes are those of :class:`~motionplc.blocks._axis_core.AxisCore` (compiled)."""

    def __init__(self, config: AxisConfig, drive: Drive) -> None:
        self.cfg = config
        self.name = config.name
        # hot-path copies of the (frozen) configuration
        self._modulo = config.modulo
        self._fe_limit = config.following_error_limit
        self._sw_pos = config.sw_limit_pos
        self._sw_neg = config.sw_limit_neg
        self._sw_check = config.modulo is None and (
            config.sw_limit_pos is not None or config.sw_limit_neg is not None
        )
        # the configuration as built: the *System values of MC_ReadParameter (PN 8, 12, 14,
        # 16), never changed; ``cfg`` is the applied one (MC_WriteParameter, apply_config)
        self.cfg_system = config
        self.parameters: Any = None  # MC_Read/WriteParameter state (motionplc.blocks.params)
        # the software-limit supervision's configuration: the applied limits with the system
        # dynamics (what the axis can physically brake with; the same object until a write)
        self._safe_cfg = config
        self.drive = drive
        # the in-process fast path (see motionplc.fieldbus.ideal): exactly an IdealDrive
        self._ideal: IdealDrive | None = drive if type(drive) is IdealDrive else None
        # a drive whose write_outputs(t, command) is write_setpoint(t, the command's fields)
        # (fieldbus.base.write_outputs_via_setpoint): AxisCore.step_write calls that with
        # the values write_outputs would put in the command, without building it
        # ... and one whose read_inputs(t) is DriveFeedback(*read_values(t))
        # (fieldbus.base.read_inputs_via_values): AxisCore.read_inputs takes the values
        self._read_values: Callable[[float], tuple[Any, ...]] | None = (
            drive.read_values  # type: ignore[attr-defined]
            if type(drive).read_inputs is read_inputs_via_values
            else None
        )
        self._write_setpoint: Callable[..., None] | None = (
            drive.write_setpoint  # type: ignore[attr-defined]
            if type(drive).write_outputs is write_outputs_via_setpoint
            else None
        )
        self.task_name: str | None = None
        self.group: Any = None  # the axes group (AxesGroup) this axis belongs to, if any
        self.fbs: list[Any] = []
        self._fb_counts: dict[str, int] = {}
        self.state = S.DISABLED
        # set values (axis coordinates; unwrapped on modulo axes)
        self.p = 0.0
        self.v = 0.0
        self.a = 0.0
        self.j = 0.0
        self.offset = 0.0  # axis position = drive position + offset
        # feedback
        self.act_p = 0.0
        self.act_v = 0.0
        self.act_a = 0.0  # derived from actual velocity differences (drives report none)
        self._act_t = 0.0  # time of the last fresh velocity sample
        self.act_v_prev = 0.0  # the actual velocity of the sample before
        self.following_error = 0.0
        self.drive_enabled = False
        self.drive_fault = False
        self.comm_ok = True
        # the drive's warning (DriveFeedback.warning, e.g. a warning EMCY): "" = none; each
        # change is kept for the trace (events "<axis>.drive" / "warning: <text>")
        self.drive_warning = ""
        self.warnings_seen: list[tuple[float, str]] = []  # (time, text), the last 64
        self._warning_edges: list[tuple[str, bool]] = []
        self._was_enabled = False
        self._sent_p = 0.0
        # requests
        self.power_request = False
        self.enable_positive = True
        self.enable_negative = True
        self._feed_all = True  # both directions enabled (the common case: no checks)
        self._reset_handle: Handle | None = None
        self._reset_pulse = False
        self._reset_sent = False
        # errors
        self.axis_error = ErrorID.OK
        self.axis_error_reason = ""
        self._why = ""  # why the last command was refused (the FB's error_text)
        # command queue
        self.mq: MotionQueue[AxisJob] = MotionQueue()  # inbox, active job, queue, stops, updates
        self.last_target: float | None = None
        # profiles planned ahead (exact planner inputs -> the immutable profile planned from
        # them): a queued move's start profile is planned in a quiet cycle before the hand-over
        self._memo: dict[bytes, Profile] = {}
        self._ahead = False  # the queue or the active chain changed: look again (plan_ahead)
        # blending re-plan of the running move, due since a successor was queued (the job
        # it is for); served within the runtime's per-cycle budget (None: no budget)
        self._junction_due: AxisJob | None = None
        self.replan_budget: ReplanBudget | None = None
        # MC_SetOverride's factors (velocity, acceleration, jerk)
        self.override = (1.0, 1.0, 1.0)
        self._override_due = False  # a new VelFactor: re-plan the running move (step)
        self._paused: AxisJob | None = None  # the move VelFactor 0 holds at rest (Active)
        # image for read FBs (refreshed in the input phase)
        self.img_state = S.DISABLED
        self.img_p = 0.0
        self.img_v = 0.0
        self.img_a = 0.0
        self.img_act_p = 0.0
        self.img_act_v = 0.0
        self.img_act_a = 0.0
        self.img_act_v_prev = 0.0
        self.img_error = ErrorID.OK
        self.img_enabled = False
        self.img_homed = False
        self.homed = False
        # touch probes armed by MC_TouchProbe: probe input -> its job (motionplc.blocks.probe)
        self.probe_jobs: dict[int, Any] = {}
        # superimposed motion (motionplc.blocks.superimposed.SuperimposedLayer), None: none
        self.sup: Any = None
        # homing by the drive in progress (motionplc.blocks.homing); _io_watch: a probe or
        # drive homing to look after in READ INPUTS (one test per cycle otherwise)
        self.drive_homing_job: AxisJob | None = None
        self._io_watch = False
        # the limit supervision (guard_limits): the set positions one and two steps before
        # the last one and the lengths of the steps to them (None: no history yet), the last
        self._lg_hist: tuple[float, float, float, float] | None = None
        self._lg_last = 0.0
        self._lg_after_group: tuple[float, float, float, float, float] | None = None
        self._lg_off = 0.0  # the coordinate offset of that history

    def apply_config(self, config: AxisConfig) -> None:
        """Replace the applied configuration (MC_WriteParameter) and refresh the kernel's
        hot copies of it. Takes effect for what is planned and checked from now on (a running
        move keeps its plan; the software-limit and following-error supervision use the new
        values from the next step). The name and the modulo period cannot change."""
        if config.name != self.name or config.modulo != self.cfg.modulo:
            raise ValueError(
                f"axis {self.name!r}: apply_config cannot change the name or the modulo period"
            )
        self.cfg = config
        self._fe_limit = config.following_error_limit
        self._sw_pos = config.sw_limit_pos
        self._sw_neg = config.sw_limit_neg
        self._sw_check = config.modulo is None and (
            config.sw_limit_pos is not None or config.sw_limit_neg is not None
        )
        # a running move planned before a lower *Appl write brakes at a limit with the
        # system dynamics it was planned with (never judged by, or stopped with, less)
        sys_cfg = self.cfg_system
        self._safe_cfg = (
            sys_cfg
            if (sys_cfg.sw_limit_pos, sys_cfg.sw_limit_neg)
            == (config.sw_limit_pos, config.sw_limit_neg)
            else replace(
                sys_cfg, sw_limit_pos=config.sw_limit_pos, sw_limit_neg=config.sw_limit_neg
            )
        )

    # -- the command queue (public attributes kept for FBs, runtime, tests) -------------------
    @property
    def active(self) -> AxisJob | None:
        """The job controlling the axis (None: none)."""
        return self.mq.active

    @active.setter
    def active(self, job: AxisJob | None) -> None:
        self.mq.active = job

    @property
    def queue(self) -> deque[AxisJob]:
        """The jobs waiting behind the active one, in order."""
        return self.mq.queue

    # -- helpers ---------------------------------------------------------------------------
    def __repr__(self) -> str:
        return f"Axis({self.name!r}, {self.state.name}, p={self.p:.6g}, v={self.v:.6g})"

    def register(self, fb: Any) -> str:
        """Called by an FB at its first call with this axis; returns its trace name."""
        cls = type(fb).__name__
        n = self._fb_counts.get(cls, 0) + 1
        self._fb_counts[cls] = n
        self.fbs.append(fb)
        return f"{self.name}.{cls}{n}"

    def wrap(self, p: float) -> float:
        """Position as reported (in [0, modulo) on a modulo axis)."""
        m = self.cfg.modulo
        if m is None:
            return p
        w = p % m
        return 0.0 if w >= m else w

    @property
    def position(self) -> float:
        """Set position (wrapped on modulo axes)."""
        return self.wrap(self.p)

    @property
    def actual_position(self) -> float:
        """Actual position (wrapped on modulo axes)."""
        return self.wrap(self.act_p)

    def trace_values(self) -> tuple[float, ...]:
        """One trace row part, in the order of ``runtime.trace.AXIS_FIELDS``."""
        if self._modulo is None:
            p, ap = self.p, self.act_p
        else:
            p, ap = self.wrap(self.p), self.wrap(self.act_p)
        # the state as a plain float: numpy converts an IntEnum member much more slowly
        return (p, self.v, self.a, self.j, ap, self.act_v, self.following_error, float(self.state))

    def open(self) -> None:
        """Open the drive and take its position as the initial set position."""
        self.drive.open()
        fb = self.drive.read_inputs(0.0)
        self.p = self.act_p = self._sent_p = fb.position + self.offset
        self._refresh_image()

    def close(self) -> None:
        """Close the drive."""
        self.drive.close()

    # -- touch probe ---------------------------------------------------------------------------
    def probe_arm(self, probe: int, rising: bool, job: Any, accept: Any = None) -> str:
        """Arm the drive's touch probe ``probe`` for ``job`` (a previous job on that probe is
        aborted: ``job_aborted()``); returns "" or why the drive refused. While a probe is
        armed the axis takes the drive's object path (an in-process drive scans its motion
        in ``write_outputs``); each READ INPUTS then hands a latched edge to ``job.latched``."""
        old = self.probe_jobs.pop(probe, None)
        if old is not None:
            old.job_aborted()
        err = self.drive.arm_probe(probe, rising, accept)
        if err:
            self._probe_released()
            return err
        self.probe_jobs[probe] = job
        self._ideal = None
        self._io_watch = True
        return ""

    def probe_disarm(self, probe: int, job: Any) -> bool:
        """MC_AbortTrigger: disarm ``probe`` if ``job`` holds it (True), else False."""
        if self.probe_jobs.get(probe) is not job:
            return False
        del self.probe_jobs[probe]
        self.drive.disarm_probe(probe)
        self._probe_released()
        return True

    def _probe_released(self) -> None:
        if not self.probe_jobs and type(self.drive) is IdealDrive:
            self._ideal = self.drive  # the in-process fast path again
        self._io_watch = bool(self.probe_jobs) or self.drive_homing_job is not None

    def _watch_io(self) -> None:
        """READ INPUTS while a probe is armed or the drive homes: latched edges to their
        jobs; a drive homing whose MC_Home ended otherwise (MC_Stop, an axis error) is
        cancelled on the drive."""
        if self.probe_jobs:
            self._poll_probes()
        job = self.drive_homing_job
        if job is not None and job.handle.terminal:
            self.drive_homing_job = None
            self.drive.cancel_homing()
        self._io_watch = bool(self.probe_jobs) or self.drive_homing_job is not None

    def _poll_probes(self) -> None:
        for probe, job in list(self.probe_jobs.items()):
            result = self.drive.read_probe(probe)
            if result is not None:
                del self.probe_jobs[probe]
                job.latched(result)
        if not self.probe_jobs:
            self._probe_released()

    # -- input phase -----------------------------------------------------------------------
    def _read_inputs_general(self, t: float) -> None:
        """READ INPUTS through a drive's feedback object (``AxisCore.read_inputs`` runs the
        healthy in-process ideal drive's case itself, with the same steps in the same order)."""
        self._apply_feedback_general(t, self.drive.read_inputs(t))

    def _apply_feedback_general(self, t: float, fb: DriveFeedback) -> None:
        """READ INPUTS of the drive's feedback ``fb`` of this cycle (``AxisCore.read_inputs``
        runs the case of a drive with communication and without fault itself, with the same
        steps in the same order: ``AxisCore._apply_feedback``)."""
        act_p = fb.position + self.offset
        act_v = fb.velocity
        enabled = fb.enabled
        fault = fb.fault
        comm_ok = fb.comm_ok
        dt_act = t - self._act_t
        if dt_act > 0.0 and not fb.stale:  # actual acceleration: backward difference
            self.act_v_prev = self.act_v
            self.act_a = (act_v - self.act_v) / dt_act
            self._act_t = t
        self.act_p = act_p
        self.act_v = act_v
        self.drive_enabled = enabled
        self.drive_fault = fault
        self.comm_ok = comm_ok
        if fb.warning != self.drive_warning:
            self._drive_warning_changed(t, fb.warning)
        self.following_error = self._sent_p - act_p if enabled else 0.0
        state = self.state
        if state is not S.ERROR_STOP and (not comm_ok or fault or not enabled):
            if not comm_ok:
                self.raise_axis_error(drive_error_kind(fb), fb.detail or "communication lost")
            elif fault:
                self.raise_axis_error(drive_error_kind(fb), _fault_text(fb.error_code, fb.detail))
            elif state is not S.DISABLED and self.power_request and self._was_enabled:
                self.raise_axis_error("POWER_LOST", "drive left OPERATION ENABLED")
        self._was_enabled = enabled
        if self._io_watch:
            self._watch_io()
        if self._reset_handle is not None and self._reset_sent and not fb.reset_pending:
            self._try_finish_reset(fault, comm_ok)
        state = self.state
        if state is S.DISABLED:
            if self.power_request and enabled and not fault:
                state = self.state = next_state(Event.POWER_ON_READY, S.DISABLED)  # T5
            self._resync()
        # image for the read FBs of this scan (inlined _refresh_image: runs every cycle)
        self.img_state = state
        self.img_p = self.p
        self.img_v = self.v
        self.img_a = self.a
        self.img_act_p = act_p
        self.img_act_v = act_v
        self.img_act_a = self.act_a
        self.img_act_v_prev = self.act_v_prev
        self.img_error = self.axis_error
        self.img_enabled = enabled
        self.img_homed = self.homed

    def _refresh_image(self) -> None:
        self.img_state = self.state
        self.img_p = self.p
        self.img_v = self.v
        self.img_a = self.a
        self.img_act_p = self.act_p
        self.img_act_v = self.act_v
        self.img_act_a = self.act_a
        self.img_act_v_prev = self.act_v_prev
        self.img_error = self.axis_error
        self.img_enabled = self.drive_enabled
        self.img_homed = self.homed

    # -- errors and reset ------------------------------------------------------------------
    def raise_axis_error(self, kind: str, reason: str) -> None:
        """T1: axis error -> ErrorStop, controlled stop, every pending command fails."""
        eid = ErrorID[kind]
        if self.state is S.ERROR_STOP and self.axis_error is not ErrorID.OK:
            return
        self.axis_error = eid
        self.axis_error_reason = reason
        prev = self.state
        self.state = next_state(Event.AXIS_ERROR, prev)
        self._fail_all(ErrorID.AXIS_ERROR_STOP)
        if prev is not S.DISABLED:
            self._start_ramp("estop", 0.0, 0.0, self.cfg.j_max)

    def _fail_all(self, eid: ErrorID, status: Status = Status.ERROR) -> None:
        self.mq.fail_all(eid, status)
        if self.sup is not None:
            self.sup.end(self, status, eid)
        self.last_target = None

    def request_reset(self) -> Handle:
        """MC_Reset: ErrorStop -> Standstill (power on) or Disabled (power off)."""
        h = Handle("reset")
        if self.state is not S.ERROR_STOP:
            h._finish(Status.DONE)  # vendor-specific: a no-op outside ErrorStop
            return h
        if self._reset_handle is not None:
            self._reset_handle._finish(Status.ABORTED)
        self._reset_handle = h
        self._reset_pulse = True
        self._reset_sent = False
        h.status = Status.ACTIVE
        return h

    def _try_finish_reset(self, fault: bool, comm_ok: bool) -> None:
        h = self._reset_handle
        assert h is not None
        if not comm_ok or fault:
            h._finish(
                Status.ERROR, ErrorID.COMMUNICATION_LOST if not comm_ok else ErrorID.DRIVE_FAULT
            )
            self._reset_handle = None
            return
        if self.mq.active is not None:  # ErrorStop ramp still running: wait for standstill
            return
        group = self.group
        if group is not None and group.moving:  # its group still brakes it along the path
            return
        self.axis_error = ErrorID.OK
        self.axis_error_reason = ""
        if self.power_request and self.drive_enabled:
            self.state = next_state(Event.RESET_ENABLED, self.state)  # T4
            self.v = self.a = self.j = 0.0
        else:
            self.state = next_state(Event.RESET_DISABLED, self.state)  # T3
            self._resync()
        h._finish(Status.DONE)
        self._reset_handle = None

    # -- power -----------------------------------------------------------------------------
    def set_power(
        self, enable: bool, enable_positive: bool = True, enable_negative: bool = True
    ) -> None:
        """MC_Power: request the power stage on/off (T2 immediately on switch-off)."""
        self.power_request = enable
        self.enable_positive = enable_positive
        self.enable_negative = enable_negative
        self._feed_all = enable_positive and enable_negative
        if not enable and self.state not in (S.DISABLED, S.ERROR_STOP):
            self.state = next_state(Event.POWER_OFF, self.state)  # T2
            self._fail_all(ErrorID.OK, Status.ABORTED)
            self._resync()

    # -- override --------------------------------------------------------------------------
    def set_override(self, vel: float, acc: float, jerk: float) -> None:
        """MC_SetOverride (validated by the FB): factors for velocity / acceleration / jerk.

        VelFactor caps the velocity of every move and MoveVelocity (``f * Velocity``, and the
        blending junctions): a change re-plans the running move from its set state in this
        cycle's step (:meth:`_apply_override`), with the axis' acceleration and jerk, so the
        new velocity is reached within the limits (0: the move brakes to standstill and waits,
        still Active). AccFactor/JerkFactor scale the limits of what is planned from then on
        (a re-plan for a new VelFactor included)."""
        if (vel, acc, jerk) == self.override:
            return
        old_vel = self.override[0]
        self.override = (vel, acc, jerk)
        if vel != old_vel:
            self._override_due = True

    def _tau_state(self) -> State:
        """The set state a new (or re-planned) job starts from."""
        return State(self.p, self.v, self.a)

    def _apply_override(self) -> None:
        """A new VelFactor (:meth:`set_override`): re-plan the running move or MoveVelocity
        from the set state with the new velocity cap (what the axis plans from now on has it
        anyway). Stops, homing, couplings and ramps are not scaled. If the re-plan fails, the
        command ends with Error PLANNING_FAILED and the axis stops within its limits."""
        self._override_due = False
        job = self.mq.active
        if job is None or job.no_override or job.sync or job.handle.terminal:
            return
        kind = job.kind
        if kind != "velocity" and not job.cmd.is_move:
            return
        try:
            if kind == "velocity":
                self._prepare_velocity(job, self._tau_state())
                job.handle.in_target = job.handle.in_target and job.duration <= 0.0
            else:
                self._prepare_move(job, self._tau_state())
            job.dir = self._direction_of(job, self.p)
            self._ahead = True
        except PlanningError as exc:
            why = f"planner (override {self.override[0]:g}): {exc}"
            self.axis_error_reason = why
            self._fail_command(job.handle, ErrorID.PLANNING_FAILED, why)

    # -- submission (program phase) --------------------------------------------------------
    def submit(self, cmd: Command) -> Handle:
        """Accept or reject a command; the kernel executes it in this cycle's step."""
        h = Handle(cmd.kind)
        group = self.group
        if group is not None and group.enabled:  # a member of an enabled axes group
            h._finish(
                Status.ERROR,
                ErrorID.AXIS_IN_GROUP,
                f"axis {self.name!r} belongs to the enabled group {group.name!r} "
                "(disable the group first)",
            )
            return h
        if cmd.kind in SYNC_KINDS and isinstance(cmd, SyncCommand):
            return _submit_sync(self, cmd)  # gear / cam couplings: motionplc.blocks.sync_job
        if cmd.kind == "setpos":
            job = AxisJob(cmd, h)
            if cmd.mode is BufferMode.ABORTING or (self.mq.active is None and not self.mq.queue):
                self._shift_to(cmd)  # MC_SetPosition mcImmediately: no motion, no state change
                h._finish(Status.DONE)
            else:
                self.mq.queue.append(job)
            return h
        event = EVENTS[cmd.kind]
        state = self.state
        if not allowed(event, state):
            h._finish(Status.ERROR, ErrorID.for_state(state))
            return h
        job = AxisJob(cmd, h)
        mq = self.mq
        idle = mq.idle()
        immediate = cmd.mode is BufferMode.ABORTING or cmd.kind == "stop" or idle
        if not immediate:
            tail = mq.tail()
            if (
                cmd.mode >= BufferMode.BLENDING_LOW
                and tail is not None
                and tail.kind == "velocity"
                and self.cfg.blend_after_continuous == "error"
            ):
                h._finish(Status.ERROR, ErrorID.BLENDING_NOT_SUPPORTED_BY_PREVIOUS)
                return h
            if mq.full(self.cfg.queue_depth):
                h._finish(Status.ERROR, ErrorID.QUEUE_FULL)
                return h
        # resolve the target now when its base is known (set position or predecessor's target)
        if cmd.is_move:
            base: float | None
            if immediate:
                base = self.p
                if (
                    cmd.kind == "additive"
                    and state is S.DISCRETE_MOTION
                    and self.last_target is not None
                ):
                    base = self.last_target
            else:
                tail = mq.tail()
                base = (
                    tail.target
                    if tail is not None and tail.kind in ("absolute", "relative", "additive")
                    else None
                )
            if base is not None:
                err = self._resolve(job, base)
                if err is not ErrorID.OK:
                    h._finish(Status.ERROR, err, self._why)
                    return h
        elif immediate and cmd.kind == "velocity" and self._sw_check:
            if self._velocity_blocked(job):
                h._finish(Status.ERROR, ErrorID.MOVE_BEYOND_SW_LIMIT, self._why)
                return h
        if not self._feed_all:
            d = self._direction_of(job, self.p if immediate else job.base)
            if not self._dir_enabled(d):
                h._finish(Status.ERROR, ErrorID.DIRECTION_NOT_ENABLED)
                return h
        if immediate:
            self.state = next_state(event, state)
        else:
            job.waiting = True
        mq.admit(job)
        if cmd.is_move and job.target is not None:
            self.last_target = job.target
        if cmd.kind == "stop":
            mq.stops.append(h)
        return h

    def _resolve(self, job: AxisJob, base: float) -> ErrorID:
        """Target of a discrete move from its base position; checks the software limits."""
        cmd = job.cmd
        if cmd.kind == "absolute":
            target = cmd.position
            m = self.cfg.modulo
            if m is not None:
                r = (cmd.position - base) % m
                fwd = base + r
                back = base - ((m - r) % m)
                d = cmd.direction
                if d is Direction.CURRENT:
                    d = (
                        Direction.POSITIVE
                        if self.v > 0.0
                        else (Direction.NEGATIVE if self.v < 0.0 else Direction.SHORTEST)
                    )
                if d is Direction.POSITIVE:
                    target = fwd
                elif d is Direction.NEGATIVE:
                    target = back
                else:  # shortest way; a tie (half a period) goes the positive way
                    target = fwd if r <= 0.5 * m else back
        else:
            target = base + cmd.position
        if not -POSITION_MAX <= target <= POSITION_MAX:
            self._why = (
                f"target {target!r} outside the supported positions "
                f"[{-POSITION_MAX:g}, {POSITION_MAX:g}]"
            )
            return ErrorID.INVALID_POSITION
        if self.cfg.modulo is None:
            hi, lo = self.cfg.sw_limit_pos, self.cfg.sw_limit_neg
            # beyond a limit, a target further out than the start is refused; one between the
            # start and the limit (moving back) is accepted
            if (hi is not None and target > hi and target > base) or (
                lo is not None and target < lo and target < base
            ):
                self._why = (
                    f"target {target:.9g} outside the software limits [{lo}, {hi}] "
                    f"(moving from {base:.9g})"
                )
                return ErrorID.TARGET_OUTSIDE_SW_LIMITS
        # the move must fit into the supported duration at its Velocity input
        v = cmd.velocity
        if abs(target - base) > v * SUPPORTED_DURATION:
            self._why = (
                f"velocity {v:.6g} too low for the distance {abs(target - base):.6g}: the move "
                f"would last more than the supported {SUPPORTED_DURATION:g} s"
            )
            return ErrorID.INVALID_VELOCITY
        job.target = target
        job.base = base
        return ErrorID.OK

    def _at_limit(self, s: float) -> float | None:
        """The software limit in direction ``s`` if the set position is at or beyond it."""
        if not self._sw_check or s == 0.0:
            return None
        limit = self._sw_pos if s > 0.0 else self._sw_neg
        if limit is None or s * self.p < s * limit - 1e-9 * (1.0 + abs(limit)):
            return None
        return limit

    def _velocity_blocked(self, job: AxisJob) -> bool:
        """A velocity command heading out of a software limit the axis stands at or beyond;
        if so, ``_why`` says why (Error MOVE_BEYOND_SW_LIMIT)."""
        s = sign(job.cmd.velocity)
        limit = self._at_limit(s)
        if limit is None:
            return False
        self._why = (
            f"the axis is at the software limit {limit:.9g} (set position {self.p:.9g}): "
            f"velocity {job.cmd.velocity:.6g} would move it further out"
        )
        return True

    def _shift_to(self, cmd: Command) -> None:
        """MC_SetPosition: shift the coordinate system (set and actual by the same amount)."""
        d = cmd.position if cmd.relative else cmd.position - self.p
        self.offset += d
        self.p += d
        self.act_p += d
        self._sent_p += d
        if self.last_target is not None:
            self.last_target += d
        for job in self.mq.jobs():
            job.shift += d
            if job.target is not None:
                job.target += d
            if job.base is not None:
                job.base += d

    # -- motion kernel ---------------------------------------------------------------------
    def step(self, dt: float) -> None:
        """MOTION KERNEL: execute the inbox, advance the active job by ``dt``, supervise.

        Fault barrier: no exception escapes. A failure while starting a command ends that
        command with Error (PLANNING_FAILED for the planner's PlanningError, INTERNAL_ERROR
        naming any other exception: a defect; the axis keeps its motion); any other failure
        inside the kernel puts the axis in ErrorStop (PLANNING_FAILED for a planner failure,
        INTERNAL_ERROR otherwise; the reason in ``axis_error_reason``) with a controlled stop
        using the axis' own limits, which runs from this very cycle when the failure came
        before the set position moved (the set values never stand still for a cycle while the
        velocity says otherwise).
        """
        p0, v0, a0, j0, off0 = self.p, self.v, self.a, self.j, self.offset
        try:
            sup = self.sup
            if sup is not None:  # the set values become the underlying ones (superimposed.py)
                sup.lift(self)
            mq = self.mq
            if mq.inbox:
                self._process_inbox()
                self._ahead = True
            if mq.pending:
                self._apply_pending()
                self._ahead = True
            if self._override_due:
                self._apply_override()
            if self._junction_due is not None:
                self._serve_junction()
            state = self.state
            if state is S.DISABLED:
                self._resync()
                self._lg_hist = None  # the limit supervision starts afresh at power-on
                return
            job = mq.active
            if not self._feed_all and job is not None and not self._dir_enabled(job.dir):
                self._feed_stop()
                job = mq.active
            sw = self._sw_check
            if sw:
                p0, v0, a0 = self.p, self.v, self.a
                if self.sup is not None:  # the sum before this step
                    p0, v0, a0 = p0 + self.sup.sp, v0 + self.sup.sv, a0 + self.sup.sa
            if job is None:
                self.v = self.a = self.j = 0.0
            else:
                self._advance(job, dt, dt)
            if sup is not None:  # superimposed motion: its contribution, then the guard
                if self.sup is not None:
                    self.sup.apply(self, dt)
                if sw:
                    self._sw_guard(p0, v0, a0, dt)
            elif sw and job is not None:
                self._sw_guard(p0, v0, a0, dt)
            state = self.state
            if state is S.STOPPING and mq.active is None:
                if all(not h.hold for h in mq.stops):
                    mq.stops.clear()
                    state = self.state = next_state(Event.STOP_RELEASED, S.STOPPING)  # T19
            if state is not S.ERROR_STOP:
                lim = self._fe_limit
                if lim is not None and abs(self.following_error) > lim:
                    self.raise_axis_error(
                        "FOLLOWING_ERROR",
                        f"following error {self.following_error:.6g} exceeds {lim:.6g}",
                    )
                elif sw:
                    # last resort (the braking of _sw_guard keeps moves inside): the set
                    # position went further out beyond a limit (e.g. after MC_SetPosition
                    # during motion); standing beyond a limit, or moving back, is allowed
                    hi, lo = self._sw_pos, self._sw_neg
                    p = self.p
                    if (hi is not None and p > hi + 1e-9 * (1.0 + abs(hi)) and p > p0) or (
                        lo is not None and p < lo - 1e-9 * (1.0 + abs(lo)) and p < p0
                    ):
                        self.raise_axis_error(
                            "SW_LIMIT",
                            f"set position {p:.9g} moving beyond the software limits [{lo}, {hi}]",
                        )
            group = self.group
            if group is None or not group.moving:
                self.guard_limits(dt, p0, v0, a0, j0, off0)
            else:  # a moving group's member: after the group's step (Runtime._run_tick)
                self._lg_after_group = (p0, v0, a0, j0, off0)
        except Exception as exc:  # noqa: BLE001 - no kernel failure escapes the cycle
            self._kernel_failed(exc)
            if self.p == p0:
                self._stop_now(dt)

    def _stop_now(self, dt: float) -> None:
        """After :meth:`_kernel_failed` in a step that had not moved the set position: its
        stop ramp (planned from the set state of the last cycle) takes this cycle's step."""
        job = self.mq.active
        if job is None or job.kind != "estop" or job.tau != 0.0:
            return
        try:
            self._advance(job, dt, dt)
        except Exception:  # noqa: BLE001 - last line of defence: hold still
            self.mq.active = None
            self.v = self.a = self.j = 0.0

    # -- limit supervision -------------------------------------------------------------------
    def guard_after_group(self, dt: float) -> None:
        """:meth:`guard_limits` of a moving group's member, after the group wrote its set
        values: beyond its limits the member reports SET_VALUE_LIMIT (ErrorStop) in this
        cycle and its group brakes along the path from the next (the group's own stop)."""
        prev = self._lg_after_group
        if prev is not None:
            self._lg_after_group = None
            self.guard_limits(dt, *prev, revert=False)

    def guard_limits(
        self,
        dt: float,
        p0: float,
        v0: float,
        a0: float,
        j0: float,
        off0: float,
        revert: bool = True,
    ) -> bool:
        """The one supervision of every set value the kernel writes for this axis (moves,
        couplings, superimposed motion, ramps; a moving group's members after the group's
        step): the new set state against the axis' system limits (``cfg_system``; asymmetric
        sides as configured), both as the kernel's own v / a / j and *by differencing the set
        positions* (the last three steps and this one: what the drive receives). Within them
        (to rounding): True. Beyond: the set values go back to the previous set state (which
        passed), the axis reports it in this very step and stops within its limits from there
        (a coupling ends with Error SLAVE_LIMITS_EXCEEDED and the slave's controlled stop; any
        other motion: ErrorStop SET_VALUE_LIMIT and its error ramp), and this step's set value
        is the stop's first. Not supervised: ErrorStop (its ramp starts from where the error
        found the axis), homing (the set values follow the drive), Disabled; a coupling on
        the master's actual values is held to the kernel's v / a only (the differenced
        acceleration and jerk of measured positions are their quantisation noise). A
        coordinate shift (MC_SetPosition, homing) is taken out of the history; steps of
        different lengths (ticks skipped after an overrun) are divided differences."""
        p = self.p
        hist = self._lg_hist
        last = self._lg_last
        # MC_SetPosition, homing: the coordinates moved, not the axis - in the program phase
        # (before this step: p0 has it) or in the step (a queued one): all in today's
        shift_in = self.offset - off0
        shift = shift_in + (off0 - self._lg_off)
        self._lg_off = self.offset
        if shift != 0.0:
            p0 += shift_in
            last += shift
            if hist is not None:
                hist = (hist[0] + shift, hist[1] + shift, hist[2], hist[3])
        if hist is None or last != p0:
            # (first step, or steps of the compiled fast path in between: that samples a
            # planned profile) the history from the kernel's state, for velocity only
            p1, p2 = _back_p(p0, v0, a0, j0, dt), _back_p(p0, v0, a0, j0, 2.0 * dt)
            h0 = h1 = dt
            fresh = False
        else:
            p1, p2, h0, h1 = hist
            fresh = True
        self._lg_hist = (p0, p1, dt, h0)
        self._lg_last = p
        state = self.state
        if state is S.ERROR_STOP or state is S.HOMING or state is S.DISABLED:
            return True
        cfg = self.cfg_system
        v, a, j = self.v, self.a, self.j
        scale = 1.0 + abs(p) + abs(p0)
        why = ""
        # divided differences of the set positions (the steps may differ: skipped ticks)
        vd = (p - p0) / dt
        v_hi, v_lo = cfg.v_max * (1 + 1e-9) + 1e-12, -cfg.v_neg * (1 + 1e-9) - 1e-12
        tv = 4e-16 * scale / dt
        if not (v_lo - tv <= vd <= v_hi + tv) or not (v_lo <= v <= v_hi):
            why = f"v {v:.6g} (differenced {vd:.6g}) beyond [{-cfg.v_neg:.6g}, {cfg.v_max:.6g}]"
        job = self.mq.active
        actual = job is not None and getattr(job, "actual", False)
        if not why:
            vd0 = (p0 - p1) / h0
            ad = 2.0 * (vd - vd0) / (dt + h0)
            a_hi, a_lo = cfg.a_max * (1 + 1e-9) + 1e-9, -cfg.a_neg * (1 + 1e-9) - 1e-9
            ta = 8e-16 * scale / (dt * min(dt, h0))
            ok_d = not fresh or actual or a_lo - ta <= ad <= a_hi + ta
            if not ok_d or not (a_lo <= a <= a_hi):
                why = f"a {a:.6g} (differenced {ad:.6g}) beyond [{-cfg.a_neg:.6g}, {cfg.a_max:.6g}]"
            elif math.isfinite(cfg.j_max):
                ad0 = 2.0 * (vd0 - (p1 - p2) / h1) / (h0 + h1)
                jd = 3.0 * (ad - ad0) / (dt + h0 + h1)
                j_hi = cfg.j_max * (1 + 1e-6) + 1e-9
                hm = min(dt, h0, h1)
                tj = 16e-16 * scale / (hm * hm * hm)
                if (fresh and not actual and abs(jd) > j_hi + tj) or abs(j) > j_hi:
                    why = f"j {j:.6g} (differenced {jd:.6g}) beyond +-{cfg.j_max:.6g}"
        if not why:
            return True
        return self._limit_exceeded(job, why, dt, p0, v0, a0, revert)

    def _limit_exceeded(
        self,
        job: AxisJob | None,
        why: str,
        dt: float,
        p0: float,
        v0: float,
        a0: float,
        revert: bool,
    ) -> bool:
        """guard_limits found ``why``: report it and stop within the limits (see there)."""
        reason = f"set value beyond the axis' limits: {why}"
        if not revert:
            self.raise_axis_error("SET_VALUE_LIMIT", reason)
            return False
        self.p, self.v, self.a, self.j = p0, v0, a0, 0.0
        if job is not None and job.sync and not job.handle.terminal:
            self._fail_command(job.handle, ErrorID.SLAVE_LIMITS_EXCEEDED, reason)
            if self.mq.active is None and (v0 != 0.0 or a0 != 0.0):
                self._start_ramp("feedstop", 0.0, 0.0, self.cfg.j_max)
        else:
            self.raise_axis_error("SET_VALUE_LIMIT", reason)
        act = self.mq.active
        if act is not None:
            self._advance(act, dt, dt)
        self._lg_last = self.p
        return False

    def _kernel_failed(self, exc: Exception) -> None:
        """A failure inside the kernel: ErrorStop with a controlled stop (or, if even the
        stop cannot be planned, the set values hold still where they are)."""
        kind = "PLANNING_FAILED" if isinstance(exc, PlanningError) else "INTERNAL_ERROR"
        reason = f"motion kernel: {type(exc).__name__}: {exc}"
        if not (math.isfinite(self.p) and math.isfinite(self.v) and math.isfinite(self.a)):
            self.p = self._sent_p if math.isfinite(self._sent_p) else self.act_p
            self.v = self.a = self.j = 0.0
        try:
            if self.state is S.ERROR_STOP and self.axis_error is not ErrorID.OK:
                self.axis_error_reason += f"; then {reason}"
                self._fail_all(ErrorID.AXIS_ERROR_STOP)
                self._start_ramp("estop", 0.0, 0.0, self.cfg.j_max)
            else:
                self.raise_axis_error(kind, reason)
        except Exception:  # noqa: BLE001 - last line of defence: hold still
            self.mq.active = None
            self.v = self.a = self.j = 0.0
            if self.state is not S.ERROR_STOP:
                self.state = S.ERROR_STOP
                self.axis_error = ErrorID[kind]
                self.axis_error_reason = reason

    # -- software limits ---------------------------------------------------------------------
    def _sw_guard(self, p0: float, v0: float, a0: float, dt: float) -> None:
        """Keep the motion inside the software limits: if braking from the new set state could
        no longer stop at a limit, the axis instead brakes from the previous set state (which
        could) to rest exactly AT the limit (jerk-limited, the axis' own limits), goes to
        ErrorStop with SW_LIMIT and the running command ends with Error SW_LIMIT. Beyond a limit
        (MC_SetPosition, a reset out there), moving further out is stopped the same way as fast
        as possible; moving back is free."""
        job = self.mq.active
        if job is not None and job.kind == "swstop":
            return
        hit = crossed_limit(self._safe_cfg, p0, self.p, self.v, self.a)
        if hit is not None:
            self._limit_stop(hit[0], hit[1], p0, v0, a0, dt)

    def _limit_stop(
        self, s: float, limit: float, p0: float, v0: float, a0: float, dt: float
    ) -> None:
        """The step went too far towards ``limit``: back to the previous set state and brake
        from there to rest at the limit (:func:`~.sw_limits.limit_stop_profile`), else stop as
        fast as possible; ErrorStop SW_LIMIT, the running command ends with Error SW_LIMIT.
        The brake uses the system dynamics (``cfg_system``) with the applied limits."""
        cfg = self._safe_cfg
        reason = f"software limit {limit:.9g} reached (set position {p0:.9g}, velocity {v0:.6g})"
        prof = limit_stop_profile(cfg, s, limit, p0, v0, a0)
        act = self.mq.active
        if act is not None:
            act.handle._finish(Status.ERROR, ErrorID.SW_LIMIT, reason)
        if prof is None:  # stop as fast as possible from where the axis is
            if self.state is S.ERROR_STOP:
                self._start_ramp("estop", 0.0, 0.0, cfg.j_max)
            else:
                self.raise_axis_error("SW_LIMIT", reason)
            return
        self.p, self.v, self.a = p0, v0, a0
        if self.state is not S.ERROR_STOP:
            self.raise_axis_error("SW_LIMIT", reason)
        else:
            self._fail_all(ErrorID.AXIS_ERROR_STOP)
        job = AxisJob(Command(kind="halt"), Handle("swstop"))
        job.kind = "swstop"
        job.no_override = True
        job.set_chain([prof])
        job.rest_target = limit
        self.mq.active = job
        self._advance(job, dt, dt)

    def _process_inbox(self) -> None:
        inbox = self.mq.take_inbox()
        failed = False
        for job in inbox:
            if job.handle.terminal:
                continue
            kind = job.kind
            if kind == "stop":
                if self.sup is not None:  # MC_Stop aborts the superimposed motion too
                    self.sup.end(self, Status.ABORTED)
                self._abort_motion()
                job.handle.status = Status.ACTIVE
                self._start_job_ramp(job, job.cmd.deceleration, job.cmd.jerk)
                continue
            if job.cmd.mode is BufferMode.ABORTING or self.mq.active is None:
                if not self._start(job, immediate=True):
                    failed = True
                continue
            self.mq.queue.append(job)
            if len(self.mq.queue) == 1 and job.cmd.mode >= BufferMode.BLENDING_LOW:
                act = self.mq.active
                if act is not None and act.cmd.is_move and not act.handle.terminal:
                    self._junction_due = act
        if failed:
            self._state_after_failed_start()

    def _state_after_failed_start(self) -> None:
        """A command accepted at submission (which set the state at once) could not be planned:
        the axis keeps its motion, so the state follows what actually runs (no DiscreteMotion
        without a motion)."""
        act = self.mq.active
        st = self.state
        if st not in (S.DISCRETE_MOTION, S.CONTINUOUS_MOTION, S.SYNCHRONIZED_MOTION):
            return
        if act is None:
            if not self.mq.queue and not self.mq.inbox and self.sup is None:
                self.state = S.STANDSTILL
        elif act.sync:
            self.state = S.SYNCHRONIZED_MOTION
        elif act.kind == "velocity":
            self.state = S.CONTINUOUS_MOTION
        elif act.kind in ("absolute", "relative", "additive", "halt", "feedstop"):
            self.state = S.DISCRETE_MOTION

    def _serve_junction(self) -> None:
        """Re-plan the running move to the junction with its newly queued blending successor,
        now if the runtime's budget of such re-plans in this cycle allows, else in a later
        cycle (then from the set state of that cycle; the move runs on meanwhile)."""
        act = self._junction_due
        queue = self.mq.queue
        if (
            act is not self.mq.active
            or act is None
            or act.handle.terminal
            or not queue
            or queue[0].cmd.mode < BufferMode.BLENDING_LOW
        ):
            self._junction_due = None  # handed over, aborted or stopped meanwhile
            return
        budget = self.replan_budget
        if budget is not None:
            if budget.left <= 0:
                return
            budget.left -= 1
        self._junction_due = None
        self._replan_active()

    def _abort_motion(self) -> None:
        self.mq.abort_motion(keep=_is_stop)

    def _start(self, job: AxisJob, immediate: bool) -> bool:
        """Plan ``job`` from the current set state; abort the old motion only on success."""
        kind = job.kind
        sup = self.sup
        folded = None
        if sup is not None and immediate and job.cmd.mode is BufferMode.ABORTING:
            folded = sup.fold(self)  # an aborting command: planned from the sum
        try:
            if kind == "halt":
                self._prepare_ramp(job, 0.0, job.cmd.deceleration, job.cmd.jerk)
            elif kind == "velocity":
                self._prepare_velocity(job, self._tau_state())
            elif kind == "home":
                ok = prepare_home(self, job)
                if not ok:
                    return True
            elif kind in SYNC_KINDS:
                if not _prepare_sync(self, job):
                    return False
            else:
                if job.target is None:
                    err = self._resolve(job, self.p)
                    if err is not ErrorID.OK:
                        job.handle._finish(Status.ERROR, err, self._why)
                        return False
                self._prepare_move(job, self._tau_state())
        except Exception as exc:  # noqa: BLE001 - keep the old motion, fail the new FB:
            # PLANNING_FAILED for the planner's verdict, INTERNAL_ERROR naming a defect
            if isinstance(exc, PlanningError):
                eid, why = ErrorID.PLANNING_FAILED, f"planner: {exc}"
            else:
                eid, why = ErrorID.INTERNAL_ERROR, f"internal error: {type(exc).__name__}: {exc}"
            job.handle._finish(Status.ERROR, eid, why)
            self.axis_error_reason = why
            if folded is not None:
                sup.unfold(self, folded)
            return False
        if folded is not None:
            sup.end(self, Status.ABORTED, keep_requests=True)  # aborted with the old motion
        if immediate:
            self._abort_motion()
        self.mq.active = job
        job.handle.status = Status.ACTIVE
        job.dir = self._direction_of(job, self.p)
        return True

    def _prepare_ramp(self, job: AxisJob, v_target: float, dec: float, jerk: float) -> None:
        lim = self._axis_limits(dec, dec, jerk)
        job.set_chain([_plan_velocity(State(self.p, self.v, self.a), v_target, lim)])

    def _start_job_ramp(self, job: AxisJob, dec: float, jerk: float) -> None:
        self._prepare_ramp(job, 0.0, dec, jerk)
        self.mq.active = job

    def _start_ramp(self, kind: str, v_target: float, dec: float, jerk: float) -> None:
        job = AxisJob(Command(kind="halt"), Handle(kind))
        job.kind = kind
        job.no_override = True
        try:
            self._prepare_ramp(job, v_target, dec, jerk)
        except PlanningError as exc:
            # the axis' own limits always give a ramp for a valid set state; if not (a defect),
            # the set values hold still rather than keep moving
            self.axis_error_reason += f"; {kind} ramp not planned ({exc}): holding still"
            self.mq.active = None
            self.v = self.a = self.j = 0.0
            return
        self.mq.active = job

    def _axis_limits(self, acc: float, dec: float, jerk: float, v: float | None = None) -> Limits:
        """Limits of a ramp (Halt, Stop, ErrorStop, homing): ``max(acc, dec)`` caps both
        acceleration signs (0: the axis' own ``a_max`` / ``|a_min|``), ``v`` both speeds."""
        cfg = self.cfg
        af, jf = self.override[1], self.override[2]
        cap = max(acc, dec) or _INF
        jerk = (jerk or cfg.j_max) * jf
        vv = _INF if v is None else v
        return Limits(
            v_max=min(vv, cfg.v_max),
            a_max=min(cap, cfg.a_max) * af,
            j_max=jerk,
            v_min=-min(vv, cfg.v_neg),
            a_min=-min(cap, cfg.a_neg) * af,
        )

    def _limits(self, v: float, acc: float, dec: float, jerk: float, s: float) -> Limits:
        """Planner limits of a move in direction ``s`` (``acc`` / ``dec`` from :meth:`_dyn`).

        The FB inputs cap the axis' own (possibly asymmetric) limits, never widen them:

        * Velocity ``v`` caps the speed of both directions, but never above the axis' limit of
          the direction (``v_max`` for v > 0, ``|v_min|`` for v < 0).
        * Acceleration caps the acceleration that raises |v| in direction ``s``, Deceleration
          the one that lowers it; each never above the axis' limit of the sign of that
          acceleration (``a_max`` for a > 0, ``|a_min|`` for a < 0). Moving positively,
          Acceleration caps ``a_max`` and Deceleration ``|a_min|``; moving negatively, the
          other way round. 0 (not given) means the axis' limit.
        * MC_SetOverride's AccFactor scales both acceleration sides after the capping.
        """
        cfg = self.cfg
        af = self.override[1]
        up, down = (acc, dec) if s >= 0.0 else (dec, acc)  # caps of a > 0, of a < 0
        return Limits(
            v_max=min(v, cfg.v_max),
            a_max=min(up, cfg.a_max) * af,
            j_max=jerk,
            v_min=-min(v, cfg.v_neg),
            a_min=-min(down, cfg.a_neg) * af,
        )

    def _v_side(self, s: float) -> float:
        """The axis' speed limit in direction ``s``."""
        return self.cfg.v_max if s >= 0.0 else self.cfg.v_neg

    def _dyn(self, cmd: Command) -> tuple[float, float, float]:
        """FB Acceleration / Deceleration caps (inf if not given, unscaled) and the jerk."""
        jf = self.override[2]
        return (
            cmd.acceleration or _INF,
            cmd.deceleration or _INF,
            (cmd.jerk or self.cfg.j_max) * jf,
        )

    def _prepare_velocity(self, job: AxisJob, start: State) -> None:
        acc, dec, jerk = self._dyn(job.cmd)
        v0 = start.v
        # raising |v| uses Acceleration, lowering it Deceleration (judged at the start); each
        # capped by the axis' limit of that acceleration sign, then scaled by AccFactor
        a_pos = acc if v0 >= 0.0 else dec
        a_neg = acc if v0 <= 0.0 else dec
        cfg = self.cfg
        af = self.override[1]
        lim = Limits(
            v_max=cfg.v_max,
            a_max=min(a_pos, cfg.a_max) * af,
            j_max=jerk,
            v_min=-cfg.v_neg,
            a_min=-min(a_neg, cfg.a_neg) * af,
        )
        # VelFactor scales the commanded velocity (0: the axis stands, in ContinuousMotion)
        job.set_chain([_plan_velocity(start, job.cmd.velocity * self.override[0], lim)])

    # -- discrete moves and blending -------------------------------------------------------
    def _successor_junction(self, job: AxisJob) -> tuple[float, AxisJob | None]:
        """Requested junction speed |v| between ``job`` and a blending successor."""
        if not self.mq.queue:
            return 0.0, None
        nxt = self.mq.queue[0]
        mode = nxt.cmd.mode
        if mode < BufferMode.BLENDING_LOW or not job.cmd.is_move:
            return 0.0, None
        v1 = job.cmd.velocity
        v2 = (
            abs(nxt.cmd.velocity)
            if nxt.kind in ("absolute", "relative", "additive", "velocity")
            else 0.0
        )
        if nxt.kind not in ("absolute", "relative", "additive", "velocity", "halt"):
            return 0.0, None
        return junction_velocity(mode, v1, v2) * self.override[0], nxt  # VelFactor caps it

    def _plan_memo(self, start: State, target: State, lim: Limits) -> Profile:
        """``plan(start, target, lim)``, reusing a profile planned ahead from the very same
        inputs (bit for bit; the planner is a pure function and profiles are immutable)."""
        vals = (start.p, start.v, start.a, target.p, target.v, target.a)
        vals += (lim.v_max, lim.a_max, lim.j_max, lim.v_min, lim.a_min)
        if any(type(x) is not float for x in vals):
            return _plan(start, target, lim)
        key = _KEY.pack(*vals)
        memo = self._memo
        prof = memo.get(key)
        if prof is None:
            prof = _plan(start, target, lim)
            if len(memo) >= _MEMO_SIZE:
                memo.clear()
            memo[key] = prof
        return prof

    def plan_ahead(self) -> bool:
        """Plan the start profile of the queued move ahead of its hand-over (called by the
        runtime in a cycle without other planning; True if a profile was planned).

        At the hand-over the successor is planned from the active move's end state (exactly
        :meth:`AxisJob.end_state`) to rest, unless a blending successor is queued behind it by
        then. That profile is computed here already and kept in :attr:`_memo`, keyed by the
        exact planner inputs: the hand-over takes it only if its inputs are bit-identical, so
        the trace cannot change (any later change, e.g. an override or ContinuousUpdate,
        just misses and plans as before).
        """
        self._ahead = False
        act = self.mq.active
        queue = self.mq.queue
        if (
            act is None
            or len(queue) != 1
            or self.mq.inbox
            or self.mq.pending
            or not act.cmd.is_move
            or act.handle.terminal
        ):
            return False
        nxt = queue[0]
        target = nxt.target
        if not nxt.cmd.is_move or target is None or not act.chain:
            return False
        start = act.end_state()  # the set state at the hand-over (_finish_job, _tau_state)
        v_end = sign(target - start.p) * 0.0  # _prepare_move without a successor: vj = 0
        n0 = planner_calls()
        try:  # the same call as _move_chain's
            acc, dec, jerk = self._dyn(nxt.cmd)
            s = sign(target - start.p) or sign(v_end) or 1.0
            v = min(nxt.cmd.velocity, self._v_side(s)) * self.override[0]
            if abs(v_end) <= v:
                lim = self._limits(v, acc, dec, jerk, s)
                self._plan_memo(start, State(target, v_end, 0.0), lim)
        except Exception:  # only an optimisation: the hand-over plans (and reports) it again
            pass
        return planner_calls() != n0

    def _move_chain(self, cmd: Command, start: State, target: float, v_end: float) -> list[Profile]:
        acc, dec, jerk = self._dyn(cmd)
        s = sign(target - start.p) or sign(v_end) or 1.0
        v = min(cmd.velocity, self._v_side(s)) * self.override[0]  # VelFactor caps it
        if abs(v_end) <= v:
            lim = self._limits(v, acc, dec, jerk, s)
            return [self._plan_memo(start, State(target, v_end, 0.0), lim)]
        vj = abs(v_end)
        lim_hi = self._limits(vj, acc, dec, jerk, s)
        ramp = _plan_velocity(State(0.0, s * v, 0.0), v_end, lim_hi)
        p_mid = target - ramp.end.p
        if s * (p_mid - start.p) > 0.0:
            first = _plan(start, State(p_mid, s * v, 0.0), self._limits(v, acc, dec, jerk, s))
            if _clean(first, s, p_mid, start.v):
                e = first.end
                return [first, _plan_velocity(State(e.p, e.v, e.a), v_end, lim_hi)]
        return [_plan(start, State(target, v_end, 0.0), lim_hi)]

    def _junction_chain(
        self, job: AxisJob, start: State, s: float, vj: float
    ) -> list[Profile] | None:
        """The chain of ``job`` to junction speed ``vj`` if it has no reversal or overshoot,
        else None. (The successor's side is settled before: :meth:`_prepare_move` caps the
        junction speed at the successor's stopping speed.)"""
        target = job.target
        assert target is not None
        chain = self._move_chain(job.cmd, start, target, s * vj)
        v0 = start.v
        for prof in chain:
            if not _clean(prof, s, target, v0):
                return None
            v0 = prof.end.v
        return chain

    def _prepare_move(self, job: AxisJob, start: State, keep_rest: bool = False) -> None:
        """Plan ``job`` from ``start`` to its target, through the junction speed to a blending
        successor (the highest reachable one without reversal or overshoot).

        ``keep_rest``: ``job`` runs already (its chain, planned by this method, brings it to
        rest at its target) and only its successor changed; if the junction speed comes out
        0, the running chain is kept instead of re-planning the same motion from ``start``
        (re-planning from a state on a profile gives that profile again, issue 3 rule 4).
        """
        target = job.target
        assert target is not None
        if self.override[0] == 0.0:  # VelFactor 0: brake to standstill and wait there
            self._pause(job, start)
            return
        if self._paused is job:
            self._paused = None
        v_req, nxt = self._successor_junction(job)
        vj = 0.0
        chain: list[Profile] | None = None
        s = sign(target - start.p)
        if s != 0.0:
            v_req = min(v_req, self._v_side(s))  # the junction within the direction's limit
        if nxt is not None and v_req > 0.0 and s != 0.0:
            p2: float | None = None
            s2 = s
            if nxt.cmd.is_move:
                if nxt.target is None:
                    self._resolve(nxt, target)
                p2 = nxt.target
                s2 = sign(p2 - target) if p2 is not None else 0.0
            elif nxt.kind == "velocity":
                s2 = sign(nxt.cmd.velocity)
            if s2 == s and p2 is not None:
                # the successor must stop within its distance: cap the junction speed there
                # at once (closed form) instead of searching for it
                acc, dec, jerk = self._dyn(nxt.cmd)
                lim2 = self._limits(nxt.cmd.velocity, acc, dec, jerk, s)
                brake = -lim2.a_min if s > 0.0 else lim2.a_max
                room = s * (p2 - target)
                cap = stop_speed(room, brake, lim2.j_max)
                tol = 1e-12 * (1.0 + abs(p2))
                while cap > 0.0 and stop_distance(cap, brake, lim2.j_max) > room + tol:
                    cap = math.nextafter(cap, 0.0) * (1.0 - 1e-15)
                v_req = min(v_req, cap)
            if s2 == s and v_req > 0.0:
                chain = self._junction_chain(job, start, s, v_req)
                if chain is not None:
                    vj = v_req
                else:
                    lo, hi = 0.0, v_req
                    for _ in range(30):
                        mid = 0.5 * (lo + hi)
                        c = self._junction_chain(job, start, s, mid)
                        if c is not None:
                            lo, chain = mid, c
                        else:
                            hi = mid
                        if hi - lo <= 1e-9 * v_req:
                            break
                    vj = lo
        if chain is None:  # no junction speed (or only 0 reachable): plan to rest
            if keep_rest and job.rest_target == target and job.shift == 0.0:
                return
            chain = self._move_chain(job.cmd, start, target, s * vj)
        job.set_chain(chain)
        job.handle.end_velocity = s * vj
        if vj == 0.0:
            job.rest_target = target

    def _pause(self, job: AxisJob, start: State) -> None:
        """VelFactor 0 on a move: a ramp from ``start`` to standstill (the move's Deceleration
        and jerk, the axis' limits); the move stays Active there until the factor rises
        (:meth:`_apply_override` re-plans it to its target)."""
        acc, dec, jerk = self._dyn(job.cmd)
        s = sign(start.v) or 1.0
        lim = self._limits(self._v_side(s), acc, dec, jerk, s)
        job.set_chain([_plan_velocity(start, 0.0, lim)])
        job.handle.end_velocity = 0.0
        self._paused = job

    def _replan_active(self) -> None:
        job = self.mq.active
        assert job is not None
        try:
            self._prepare_move(job, self._tau_state(), keep_rest=True)
        except PlanningError as exc:
            self.axis_error_reason = f"planner (blending ignored): {exc}"

    # -- stepping --------------------------------------------------------------------------
    def _advance(self, job: AxisJob, dt: float, ftau: float) -> None:
        """Advance ``job`` by the trajectory time ``ftau`` of the real step ``dt`` (the kernel
        passes ``dt``: MC_SetOverride re-plans instead of scaling time) and sample the set
        values; a job ending inside the step hands the rest of the step to its successor."""
        inc = ftau
        tau = job.tau = job.tau + inc
        if job.kind == "velocity" and self.mq.queue and tau - inc > job.duration:
            # cruising at its velocity since before this step, now taken over by a buffered
            # job: it ends at the current set state, the successor runs for this step only
            job.shift += job.chain[-1].end.v * (tau - inc - job.duration)
            tau = job.tau = job.duration + inc
        if tau < job.duration and job.single is not None and job.kind != "home":
            # fast path: a one-profile job still running
            p, self.v, self.a, self.j = job.single.at(tau)
            self.p = p + job.shift
            return
        if job.home_phase >= 3:  # homing by the drive: the set values follow it
            drive_home_step(self, job, dt)
            return
        while True:
            tau = job.tau
            if (
                tau < job.duration
                or (job.kind == "velocity" and not self.mq.queue)
                or job is self._paused
            ):
                if job.kind == "velocity" and tau >= job.duration:
                    job.handle.in_target = True
                break
            # job finished inside this step
            if job.kind == "home" and job.home_phase == 1:
                break  # still searching the switch at constant velocity
            excess = tau - job.duration
            end = job.end_state()
            self._ahead = True
            nxt = self._finish_job(job)  # sets p (shifted by homing / queued SetPosition)
            if nxt is None:
                self.mq.active = None
                self.a = self.j = 0.0
                self.v = end.v if job.kind == "velocity" else 0.0
                if end.v != 0.0 and job.kind == "velocity":
                    self.mq.active = job
                return
            job = nxt
            job.tau = excess
        if job is self._paused and job.tau >= job.duration:  # VelFactor 0: at rest, waiting
            self.p, self.v, self.a, self.j = job.end_state().p, 0.0, 0.0, 0.0
            return
        self.p, self.v, self.a, self.j = job.sample(job.tau)
        if job.kind == "home":
            home_check(self, job)

    def _finish_job(self, job: AxisJob) -> AxisJob | None:
        """``job`` reached its end: report, then activate the next queued job (if any)."""
        h = job.handle
        kind = job.kind
        end = job.end_state()
        self.p, self.v, self.a = end.p, end.v, end.a
        sup = self.sup
        if sup is not None and sup.done:  # a completed superimposed distance folds in
            sup.fold_into_end(self)
        self.mq.active = None
        if kind == "velocity":
            h._finish(Status.ABORTED)  # taken over by a buffered command at InVelocity
        elif kind == "stop":
            for sh in self.mq.stops:
                sh._finish(Status.DONE)
            return None
        elif kind in ("estop", "swstop"):
            return None
        elif kind == "home":
            finish_home(self, job)
        else:
            h._finish(Status.DONE)
        nxt = self._activate_queued()
        if nxt is not None:
            return nxt
        if job.sync:  # no buffered successor of a coupling could start: keep the velocity
            return _keep_velocity(self)
        if kind == "home" or (kind == "feedstop" and self.state is S.HOMING):
            self.state = next_state(Event.HOME_DONE, self.state)  # T7
        elif self.state is S.DISCRETE_MOTION and self.sup is None:
            self.state = next_state(Event.DISCRETE_DONE, self.state)  # T9
        return None

    def _activate_queued(self) -> AxisJob | None:
        """Start the first startable queued job from the current set state (None: none)."""
        mq = self.mq
        while (nxt := mq.pop_next()) is not None:
            if nxt.kind == "setpos":
                self._shift_to(nxt.cmd)
                nxt.handle._finish(Status.DONE)
                continue
            event = EVENTS[nxt.kind]
            if not allowed(event, self.state):
                nxt.handle._finish(Status.ERROR, ErrorID.for_state(self.state))
                continue
            if nxt.cmd.is_move and nxt.target is None:
                err = self._resolve(nxt, self.p)
                if err is not ErrorID.OK:  # FB runtime error: the next one takes over (2.4)
                    nxt.handle._finish(Status.ERROR, err, self._why)
                    continue
            if nxt.kind == "velocity" and self._sw_check and self._velocity_blocked(nxt):
                nxt.handle._finish(Status.ERROR, ErrorID.MOVE_BEYOND_SW_LIMIT, self._why)
                continue
            if not self._feed_all and not self._dir_enabled(self._direction_of(nxt, self.p)):
                nxt.handle._finish(Status.ERROR, ErrorID.DIRECTION_NOT_ENABLED)
                continue
            if self._start(nxt, immediate=False):
                self.state = next_state(event, self.state)
                if self.mq.active is nxt:
                    return nxt
                continue  # homing by set position finished at once
        return None

    # -- feed enables (MC_Power.EnablePositive / EnableNegative) -----------------------------
    def _direction_of(self, job: AxisJob, base: float | None) -> float:
        """Direction (+1 / -1, 0 = none or not known yet) in which ``job`` moves from ``base``."""
        kind = job.kind
        if kind == "velocity":
            return sign(job.cmd.velocity)
        if kind in ("absolute", "relative", "additive"):
            if job.target is None or base is None:
                return 0.0
            return sign(job.target - base)
        if kind == "home":
            return home_direction(self, job, base)
        return 0.0  # halt, stop and the internal ramps only brake

    def _dir_enabled(self, d: float) -> bool:
        return d == 0.0 or (self.enable_positive if d > 0.0 else self.enable_negative)

    def _feed_stop(self) -> None:
        """The running command moves in a direction that is no longer enabled: it and the
        queued ones end with Error DIRECTION_NOT_ENABLED; controlled stop with the axis' limits
        (DiscreteMotion, like MC_Halt; from Homing the axis stays Homing until standstill)."""
        eid = ErrorID.DIRECTION_NOT_ENABLED
        if self.sup is not None:
            self.sup.end(self, Status.ABORTED)
        self.mq.abort_motion(status=Status.ERROR, error_id=eid)
        self.last_target = None
        if self.state in (S.CONTINUOUS_MOTION, S.SYNCHRONIZED_MOTION):
            self.state = next_state(Event.DISCRETE, self.state)
        self._start_ramp("feedstop", 0.0, 0.0, self.cfg.j_max)

    # -- ContinuousUpdate ----------------------------------------------------------------------
    def update(self, handle: Handle, cmd: Command) -> None:
        """ContinuousUpdate: new (validated) inputs for the busy command of ``handle``.

        Applied in this cycle's kernel step (so FB outputs stay independent of the call order):
        an active command is re-planned from the current set state (position, velocity and
        acceleration: jerk-limited, no jump); a queued one takes the new values when it starts.
        Relative inputs refer to the initial condition: the target of MoveRelative/Additive is
        the base it was resolved from (at Execute, or the predecessor's target) plus the new
        distance. BufferMode is not updated. If the new values cannot be used (software limit,
        direction not enabled) the command ends with Error as in :meth:`fail_command`.
        """
        self.mq.pending.append((handle, cmd))

    def fail_command(self, handle: Handle, error_id: ErrorID) -> None:
        """End a busy command with Error in this cycle's kernel step (e.g. an invalid
        ContinuousUpdate input).

        A queued command is removed. An active one: the next queued command takes over from the
        current set state at once (spec 2.4); without one the axis stops with its own limits
        (DiscreteMotion until standstill, like MC_Halt).
        """
        self.mq.pending.append((handle, error_id))

    def _apply_pending(self) -> None:
        pending = self.mq.take_pending()
        for handle, what in pending:
            if isinstance(what, Command):
                self._apply_update(handle, what)
            else:
                self._fail_command(handle, what)

    def _apply_update(self, handle: Handle, cmd: Command) -> ErrorID:
        if handle.status >= Status.DONE:
            return ErrorID.OK
        job = self.mq.find(handle)
        if job is None or job.kind != cmd.kind:
            return ErrorID.OK
        old_cmd, old_target, old_base = job.cmd, job.target, job.base
        job.cmd = Command(
            kind=cmd.kind,
            mode=old_cmd.mode,
            position=cmd.position,
            velocity=cmd.velocity,
            acceleration=cmd.acceleration,
            deceleration=cmd.deceleration,
            jerk=cmd.jerk,
            direction=cmd.direction,
        )
        if job.cmd.is_move and old_base is not None:
            err = self._resolve(job, old_base)
            if err is not ErrorID.OK:
                job.cmd, job.target, job.base = old_cmd, old_target, old_base
                self._fail_command(handle, err, self._why)
                return err
            if self.last_target is not None and self.last_target == old_target:
                self.last_target = job.target
        if (
            job is self.mq.active
            and job.kind == "velocity"
            and self._sw_check
            and self._velocity_blocked(job)
        ):
            self._fail_command(handle, ErrorID.MOVE_BEYOND_SW_LIMIT, self._why)
            return ErrorID.MOVE_BEYOND_SW_LIMIT
        if not self._feed_all:
            d = self._direction_of(job, self.p if job is self.mq.active else job.base)
            if not self._dir_enabled(d):
                self._fail_command(handle, ErrorID.DIRECTION_NOT_ENABLED)
                return ErrorID.DIRECTION_NOT_ENABLED
        try:
            if job is self.mq.active:
                if job.kind == "velocity":
                    self._prepare_velocity(job, self._tau_state())
                    # InVelocity stays only if the axis is at the (new) velocity already
                    job.handle.in_target = job.handle.in_target and job.duration <= 0.0
                elif job.cmd.is_move:
                    self._prepare_move(job, self._tau_state())
                job.dir = self._direction_of(job, self.p)
            elif self.mq.queue and job is self.mq.queue[0]:
                act = self.mq.active
                if act is not None and act.cmd.is_move and not act.handle.terminal:
                    if job.cmd.mode >= BufferMode.BLENDING_LOW:
                        self._prepare_move(act, self._tau_state(), keep_rest=True)  # new junction
        except Exception as exc:  # noqa: BLE001 - PLANNING_FAILED or INTERNAL_ERROR (a defect)
            if isinstance(exc, PlanningError):
                eid, why = ErrorID.PLANNING_FAILED, f"planner: {exc}"
            else:
                eid, why = ErrorID.INTERNAL_ERROR, f"internal error: {type(exc).__name__}: {exc}"
            self.axis_error_reason = f"{why} (continuous update)"
            self._fail_command(handle, eid, why)
            return eid
        return ErrorID.OK

    def _fail_command(self, handle: Handle, error_id: ErrorID, reason: str = "") -> None:
        if handle.status >= Status.DONE:
            return
        job = self.mq.find(handle)
        handle._finish(Status.ERROR, error_id, reason)
        if job is None:
            return
        if job is not self.mq.active:
            self.mq.remove(job)
            return
        self.mq.active = None
        if self.sup is not None:  # the controlled stop ends the superimposed motion too
            self.sup.end(self, Status.ABORTED)
        if self.state in (S.CONTINUOUS_MOTION, S.SYNCHRONIZED_MOTION):
            self.state = next_state(Event.DISCRETE, self.state)
        if self.state is S.DISCRETE_MOTION and self._activate_queued() is not None:
            return
        if self.state in (S.DISCRETE_MOTION, S.HOMING):
            self._start_ramp("feedstop", 0.0, 0.0, self.cfg.j_max)

    # -- output phase ----------------------------------------------------------------------
    def write_outputs(self, t: float) -> None:
        """WRITE OUTPUTS: setpoints and power/reset requests to the drive."""
        reset = self._reset_pulse
        if reset:
            self._reset_pulse = False
            self._reset_sent = True
        self._sent_p = self.p
        self.drive.write_outputs(
            t, _drive_command(self.p - self.offset, self.v, self.a, self.power_request, reset)
        )

    # -- diagnostics -----------------------------------------------------------------------
    def _drive_warning_changed(self, t: float, text: str) -> None:
        if self.drive_warning:
            self._warning_edges.append((self.drive_warning, False))
        if text:
            self._warning_edges.append((text, True))
            self.warnings_seen.append((t, text))
            del self.warnings_seen[:-64]
        self.drive_warning = text

    def emit_fb_edges(self, trace: Trace, cycle: int) -> None:
        """Record FB output edges in the trace (called by the runtime once per cycle), and
        the drive's warnings as events ``<axis>.drive`` / ``warning: <text>`` (True when it
        appears, False when it goes)."""
        if self._warning_edges:
            for text, on in self._warning_edges:
                trace.event(cycle, f"{self.name}.drive", f"warning: {text}", on)
            self._warning_edges.clear()
        for fb in self.fbs:
            if fb._dirty:  # only FBs whose scan may have changed a traced output
                bits = fb._get_outputs(fb)
                if bits != fb._traced_bits:
                    fb._emit_edges(trace, cycle, bits)
                else:
                    fb._dirty = False
