# ruff: noqa: N806 - the math names of the module docstring (V, A, J, U)
"""AXES_GROUP_REF: an axes group (PLCopen Part 4) with its path queue, look-ahead and kernel.

FBs submit :class:`GroupCommand` objects (:meth:`AxesGroup.submit`) and follow them through a
:class:`~motionplc.blocks.axis.Handle`, exactly like single-axis FBs. The group is the single
writer of its members' set values while it moves them; it steps after its member axes in the
motion kernel phase of their task (the axes keep supervising their drives: following error,
faults, communication).

Motion model (see :mod:`motionplc.planning.paths.pieces` and ``.lookahead``)
-------------------------------------------------------------------------
Every path move becomes one or more *pieces* (a line, an arc, a corner blend) chained end to
start. The group runs one time-optimal jerk-limited 1-D profile per piece on its parameter,
between *junction speeds* at which the path acceleration along the path is zero. Junction
speeds come from the look-ahead over everything queued (backward from rest at the end of the
queue: the group always stops in time when the queue runs dry; forward from the running
piece). Each piece's caps keep every member axis within its velocity, acceleration and jerk
limits (chain rule with per-axis bounds of the piece's derivatives). All profiles are planned
when a move is executed or queued (and the running piece is re-planned then, from its current
state, if its end speed can rise); the cycle only samples.

Pinned rules (Part 4 leaves them to the supplier)
-------------------------------------------------
BufferMode decides *when* a move takes over and the speed at the junction; TransitionMode the
*geometry* of the corner:

* **Aborting** while moving: the running motion brakes along its path (the fastest stop the
  limits allow; within the running piece if it fits, else at the end of the first piece where it
  does), then the new move starts from there. Queued moves are aborted.
* **Buffered**: the new move starts when the previous one is at rest at its end point
  (junction speed 0). TransitionMode must be TMNone.
* **Blending low / previous / next / high** with **TMNone**: the programmed corner is kept
  exactly; the path passes it at speed only where the path is smooth there (tangent and
  curvature continuous, e.g. collinear lines), at most at the BufferMode velocity (min / first /
  second / max of the two Velocity inputs); at a real corner it stops (any speed there would
  need an infinite acceleration).
* Blending with **TMCornerDistance** (parameter = distance d [m] from the corner along both
  moves), **TMMaxCornerDeviation** (parameter = the largest allowed distance between the
  programmed corner and the path [m]; the blend uses the whole tolerance unless half a move
  is shorter), **TMConstantVelocity** (parameter = the path speed [m/s] the blend is sized for:
  the blend is made large enough to be passed at that speed within the axis limits) and
  **TMStartVelocity** (parameter = the speed at which the blend starts; sized like
  TMConstantVelocity): the corner is replaced by a G2 (curvature-continuous) blend that never
  takes more than half of either move; the speed through the blend is the highest the axis
  limits allow on its curvature, capped by the BufferMode velocity. Corners deflecting more than
  179 degrees are exact stops. A move blended into a running piece can only take the part of it
  still ahead of where the group could stop; if nothing is left, the corner is an exact stop.
* The first move Done / the next move Active: when the group enters the blend (the blend belongs
  to the second move).
* MC_MoveDirect*: synchronised point-to-point (every axis ends together, jerk bisection); starts
  and ends at rest (blending modes act like Buffered).
* The passing-point moves (Hermite, B-spline): the time-optimal jerk-limited motion along the
  whole curve, from rest to rest (blending modes act like Buffered), planned at Execute.
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Sequence
from dataclasses import dataclass
from operator import attrgetter
from typing import TYPE_CHECKING, Any

from motionplc.blocks.axis import Axis
from motionplc.blocks.axis_job import sign
from motionplc.blocks.axis_state import Event as AxisEvent
from motionplc.blocks.axis_state import next_state as next_axis_state
from motionplc.blocks.enums import (
    AxisState,
    BufferMode,
    CircMode,
    ErrorID,
    GroupState,
    PathChoice,
    TransitionMode,
)
from motionplc.blocks.group_state import GroupEvent, allowed, group_error_for_state, next_state
from motionplc.blocks.motion_queue import Handle, MotionQueue, Status, junction_velocity
from motionplc.errors import PlanningError
from motionplc.planning import Limits, Profile, State, plan, plan_velocity
from motionplc.planning.paths.geometry import Arc, Line, _Circular
from motionplc.planning.paths.lookahead import (
    LINK_STATE,
    Chain,
    Link,
    max_speed_change,
    traverse_time,
)
from motionplc.planning.paths.pieces import (
    BlendPiece,
    CircularPiece,
    CurvePiece,
    LinePiece,
    Piece,
    RunPiece,
    SubPiece,
    path_caps,
    piece_for,
)

if TYPE_CHECKING:
    from motionplc.runtime.trace import Trace

_INF = math.inf
G = GroupState
S = AxisState
MAX_DEFLECTION = math.radians(179.0)
_SMOOTH = 1e-9  # [rad] a junction deflecting less (with equal curvature) is smooth
_BLEND_SCALES = (1.0, 0.5, 0.25, 0.0)  # corner distance shares tried when a blend is too late


@dataclass(frozen=True, slots=True)
class GroupConfig:
    """Static configuration of an axes group."""

    name: str
    queue_depth: int = 64  # moves waiting behind the running one (the look-ahead window)
    tolerance: float = 1e-4  # [m] corner deviation of G64 without P / TMMaxCornerDeviation 0
    v_share: float = 0.7  # share of the acceleration / jerk budget the curvature may use
    blend_share: float = 0.95  # the same on corner blends (passed near their top speed)
    blend_parts: int = 1  # a line-line blend is planned as this many parts (own speed caps)
    # consecutive pieces joined with equal curvature (blends and the lines and arcs they join)
    # whose speed caps differ by less than this factor run as one piece (RunPiece): one profile
    # through the joints, the acceleration carried over (1: never merged)
    merge_ratio: float = 0.8
    max_run: int = 256  # pieces per run at most
    # under TMMaxCornerDeviation (G64 P) a line-line corner blend is made smaller (1/4, 1/16)
    # or an exact stop where that passes the corner faster (see AxesGroup._corner_share): the
    # tolerance is a bound, not a size (off: the blend always uses the tolerance)
    corner_choice: bool = True
    task: str | None = None


@dataclass(frozen=True, slots=True)
class GroupCommand:
    """A group motion request as latched by an FB (inputs validated by the FB)."""

    kind: str  # linear | circular | direct | curve | halt | stop | interrupt
    mode: BufferMode = BufferMode.ABORTING
    position: tuple[float, ...] = ()  # end point (absolute) or distance (relative)
    relative: bool = False
    velocity: float = 0.0  # path speed (linear/circular), 0 = the axes' limits
    acceleration: float = 0.0  # path acceleration cap, 0 = the axes' limits
    deceleration: float = 0.0
    jerk: float = 0.0
    transition_mode: TransitionMode = TransitionMode.TM_NONE
    transition_parameter: float = 0.0
    circ_mode: CircMode = CircMode.BORDER
    aux_point: tuple[float, ...] = ()
    path_choice: PathChoice = PathChoice.COUNTER_CLOCKWISE
    points: tuple[tuple[float, ...], ...] = ()  # passing points (curve)
    segment: Any = None  # circular: a prebuilt arc / helix (Arc, Helix; G-code turns, helices)
    curve: str = "hermite"  # hermite | bspline


class _GJob:
    """A group command being executed or waiting (group-internal)."""

    __slots__ = ("cmd", "handle", "links", "end", "waiting", "started")

    def __init__(self, cmd: GroupCommand, handle: Handle) -> None:
        self.cmd = cmd
        self.handle = handle
        self.links: list[Link] = []
        self.end: tuple[float, ...] | None = None  # end point (known once its path is built)
        self.waiting = False
        self.started = False


class _Sampled:
    """A link's motion not given by a piece profile: the synchronised axes of MC_MoveDirect*
    (rest to rest)."""

    __slots__ = ("traj", "duration", "end")

    def __init__(self, traj: Any, end: tuple[float, ...]) -> None:
        self.traj = traj
        self.duration = float(traj.duration)
        self.end = end


def _g2_joint(pa: Piece, pb: Piece) -> bool:
    """The acceleration per squared path speed is continuous from ``pa`` into ``pb`` (both
    ends at zero path acceleration): a junction that can be passed at speed if tangent."""
    acc_a, acc_b = pa.accel_out(), pb.accel_in()
    scale = 1.0 + max(abs(x) for x in acc_a + acc_b)
    return max(abs(a - b) for a, b in zip(acc_a, acc_b, strict=True)) <= 1e-9 * scale


class AxesGroup:
    """AXES_GROUP_REF: member axes moved together along paths."""

    def __init__(self, config: GroupConfig, axes: Sequence[Axis] = ()) -> None:
        self.cfg = config
        self.name = config.name
        self.task_name = config.task
        self.axes: list[Axis] = []
        self.state = G.GROUP_DISABLED
        self.error_id = ErrorID.OK
        self.error_reason = ""
        self.fbs: list[Any] = []
        self._fb_counts: dict[str, int] = {}
        # the commands: the shared motion queue of axes and groups (inbox, the active job =
        # the owner of the running piece, the queue = the jobs behind it in path order, the
        # MC_GroupStop handles)
        self.mq: MotionQueue[_GJob] = MotionQueue()
        self._stop_job: _GJob | None = None
        self.chain = Chain()
        self._tau = 0.0  # time on links[0]'s profile
        self._running = False  # links[0] has started (its profile is being sampled)
        self._interrupted: list[Link] = []  # the rest of an interrupted path
        self._interrupt_jobs: list[_GJob] = []
        self.override = 1.0
        self._off = False  # a member was switched off during this motion: it is not written
        self._dropped: set[Axis] = set()  # those members (until the group is at rest)
        self.path_velocity = 0.0
        self.path_s = 0.0  # distance travelled along paths since the start
        self._blend_scale = 1.0  # share of the corner distance a join may use (see _connect)
        self._merges: list[tuple[int, Link, Link]] = []  # runs made by the join under way
        self._wait_inbox: Any = None  # the inbox whose waiting jobs were counted (submit)
        self._wait_seen = self._wait_n = 0
        self._wait_last: Any = None
        for ax in axes:
            self.add_axis(ax)

    # -- membership ------------------------------------------------------------------------
    @property
    def axis_names(self) -> tuple[str, ...]:
        return tuple(ax.name for ax in self.axes)

    @property
    def dim(self) -> int:
        return len(self.axes)

    def __repr__(self) -> str:
        return f"AxesGroup({self.name!r}, {self.state.name}, axes={list(self.axis_names)})"

    def add_axis(self, axis: Axis, index: int | None = None) -> ErrorID:
        """MC_AddAxisToGroup (GroupDisabled only, at rest)."""
        if not allowed(GroupEvent.ADMIN, self.state) or self.moving:
            return group_error_for_state(self.state)
        if not isinstance(axis, Axis) or axis in self.axes:
            return ErrorID.INVALID_GROUP_AXIS
        other = getattr(axis, "group", None)
        if other is not None and other is not self:
            return ErrorID.INVALID_GROUP_AXIS
        if axis.cfg.modulo is not None:
            return ErrorID.INVALID_GROUP_AXIS  # paths need linear axes
        if index is None or index >= len(self.axes):
            self.axes.append(axis)
        else:
            self.axes.insert(max(0, index), axis)
        axis.group = self  # type: ignore[attr-defined]
        return ErrorID.OK

    def remove_axis(self, axis: Axis) -> ErrorID:
        """MC_RemoveAxisFromGroup (GroupDisabled only, at rest)."""
        if not allowed(GroupEvent.ADMIN, self.state) or self.moving:
            return group_error_for_state(self.state)
        if axis not in self.axes:
            return ErrorID.INVALID_GROUP_AXIS
        self.axes.remove(axis)
        axis.group = None  # type: ignore[attr-defined]
        return ErrorID.OK

    def ungroup(self) -> ErrorID:
        """MC_UngroupAllAxes (GroupDisabled only, at rest)."""
        if not allowed(GroupEvent.ADMIN, self.state) or self.moving:
            return group_error_for_state(self.state)
        for ax in self.axes:
            ax.group = None  # type: ignore[attr-defined]
        self.axes.clear()
        return ErrorID.OK

    def register(self, fb: Any) -> str:
        """Called by an FB at its first call with this group; returns its trace name."""
        cls = type(fb).__name__
        n = self._fb_counts.get(cls, 0) + 1
        self._fb_counts[cls] = n
        self.fbs.append(fb)
        return f"{self.name}.{cls}{n}"

    # -- values ----------------------------------------------------------------------------
    def position(self) -> tuple[float, ...]:
        """Set position of the members (group coordinates = axis coordinates)."""
        return tuple(ax.p for ax in self.axes)

    def velocity(self) -> tuple[float, ...]:
        return tuple(ax.v for ax in self.axes)

    def actual_position(self) -> tuple[float, ...]:
        return tuple(ax.act_p for ax in self.axes)

    def actual_velocity(self) -> tuple[float, ...]:
        return tuple(ax.act_v for ax in self.axes)

    def _limits(self) -> tuple[list[float], list[float], list[float]]:
        vm = [min(ax.cfg.v_max, ax.cfg.v_neg) for ax in self.axes]
        am = [min(ax.cfg.a_max, ax.cfg.a_neg) for ax in self.axes]
        jm = [ax.cfg.j_max for ax in self.axes]
        return vm, am, jm

    @property
    def enabled(self) -> bool:
        """Not GroupDisabled, or still braking after MC_GroupDisable: the members take no
        single-axis motion commands."""
        return self.state is not G.GROUP_DISABLED or self.moving

    @property
    def moving(self) -> bool:
        return bool(self.chain.links) or self._running

    def trace_values(self) -> tuple[float, float]:
        return (float(self.state), self.path_velocity)

    # -- administration --------------------------------------------------------------------
    def _members_ready(self) -> str:
        for ax in self.axes:
            if ax.state is S.ERROR_STOP:
                return f"axis {ax.name!r} is in ErrorStop"
            if ax.state is S.DISABLED or not ax.power_request:
                return f"axis {ax.name!r} is not powered"
            if ax.state is not S.STANDSTILL and ax.state is not S.SYNCHRONIZED_MOTION:
                return f"axis {ax.name!r} is not in Standstill ({ax.state.name})"
        return ""

    def enable(self) -> Handle:
        """MC_GroupEnable."""
        h = Handle("group_enable")
        if not self.axes:
            h._finish(Status.ERROR, ErrorID.INVALID_GROUP_AXIS, "the group has no axes")
            return h
        if not allowed(GroupEvent.ENABLE, self.state):
            h._finish(Status.ERROR, group_error_for_state(self.state))
            return h
        if self.moving:
            h._finish(
                Status.ERROR,
                ErrorID.GROUP_AXIS_NOT_READY,
                "the group still brakes after MC_GroupDisable",
            )
            return h
        why = self._members_ready()
        if why:
            h._finish(Status.ERROR, ErrorID.GROUP_AXIS_NOT_READY, why)
            return h
        self.state = next_state(GroupEvent.ENABLE, self.state)
        h._finish(Status.DONE)
        return h

    def disable(self) -> Handle:
        """MC_GroupDisable: aborts group motion (members keep their set position)."""
        h = Handle("group_disable")
        if self.moving:
            # the motion is aborted with a controlled stop along the path (no velocity jump of
            # the powered members); the group is GroupDisabled at once and brakes to rest
            for job in self.mq.inbox:
                job.handle._finish(Status.ABORTED)
            self.mq.inbox.clear()
            for j in self._interrupt_jobs:
                j.handle._finish(Status.ABORTED)
            self._interrupted, self._interrupt_jobs = [], []
            self._path_stop(abort=True, status=Status.ABORTED)
            for st in self.mq.stops:
                st._finish(Status.ABORTED)
            self.mq.stops.clear()
            if self._stop_job is not None:
                self._stop_job.handle._finish(Status.ABORTED)
                self._stop_job = None
        else:
            self._abort_all(Status.ABORTED, ErrorID.OK)
            for ax in self.axes:
                if ax.state is S.SYNCHRONIZED_MOTION:
                    ax.state = next_axis_state(AxisEvent.GROUP_DONE, ax.state)
        self.state = next_state(GroupEvent.DISABLE, self.state)
        self.error_id = ErrorID.OK
        self.error_reason = ""
        h._finish(Status.DONE)
        return h

    def reset(self) -> Handle:
        """MC_GroupReset: GroupErrorStop -> GroupStandby once at rest and the members are
        ready (reset the axes first with MC_Reset); elsewhere no effect."""
        h = Handle("group_reset")
        if self.state is not G.GROUP_ERROR_STOP:
            h._finish(Status.DONE)
            return h
        if self.moving:
            h._finish(Status.ERROR, ErrorID.GROUP_STATE_ERROR_STOP, "the error stop is running")
            return h
        why = self._members_ready()
        if why:
            h._finish(Status.ERROR, ErrorID.GROUP_AXIS_NOT_READY, why)
            return h
        self.state = next_state(GroupEvent.RESET_DONE, self.state)
        self.error_id = ErrorID.OK
        self.error_reason = ""
        h._finish(Status.DONE)
        return h

    def set_override(self, factor: float) -> None:
        """MC_GroupSetOverride (validated by the FB): applies to moves planned from now on
        (their path velocity is scaled; running pieces keep their profile)."""
        self.override = factor

    # -- submission ------------------------------------------------------------------------
    def submit(self, cmd: GroupCommand) -> Handle:
        """Accept or reject a command; the kernel plans it in this cycle's step."""
        h = Handle(cmd.kind)
        event = GroupEvent.STOP if cmd.kind == "stop" else GroupEvent.MOTION
        state = self.state
        if not allowed(event, state):
            h._finish(Status.ERROR, group_error_for_state(state))
            return h
        if cmd.kind in ("linear", "circular", "direct", "curve"):
            n = len(self.axes)
            if len(cmd.position) != n:
                h._finish(
                    Status.ERROR,
                    ErrorID.INVALID_POSITION,
                    f"position must have {n} values (axes {list(self.axis_names)}), "
                    f"got {len(cmd.position)}",
                )
                return h
        job = _GJob(cmd, h)
        mq = self.mq
        busy = not mq.idle() or self.moving
        immediate = cmd.mode is BufferMode.ABORTING or cmd.kind in ("stop", "halt", "interrupt")
        if busy and not immediate:
            if len(mq.queue) + self._inbox_waiting() >= self.cfg.queue_depth:
                h._finish(Status.ERROR, ErrorID.QUEUE_FULL)
                return h
            job.waiting = True
        self.state = next_state(event, state)
        mq.admit(job)
        if cmd.kind == "stop":
            mq.stops.append(h)
        return h

    def _inbox_waiting(self) -> int:
        """The inbox's waiting jobs (MotionQueue.waiting_count without the queue), counted
        incrementally: submitting n moves in one cycle costs O(n), not O(n^2)."""
        inbox = self.mq.inbox
        seen = self._wait_seen
        if (
            inbox is not self._wait_inbox
            or len(inbox) < seen
            or (seen and inbox[seen - 1] is not self._wait_last)
        ):
            self._wait_inbox, seen, self._wait_n = inbox, 0, 0
        n = self._wait_n
        for job in inbox[seen:] if seen < len(inbox) else ():
            n += job.waiting
        self._wait_n, self._wait_seen = n, len(inbox)
        self._wait_last = inbox[-1] if inbox else None
        return n

    def continue_(self) -> Handle:
        """MC_GroupContinue: resume an interrupted path from where it stopped."""
        h = Handle("continue")
        if not self._interrupted:
            h._finish(Status.ERROR, ErrorID.NOT_INTERRUPTED, "nothing was interrupted")
            return h
        if not allowed(GroupEvent.MOTION, self.state) or self.moving:
            h._finish(Status.ERROR, group_error_for_state(self.state))
            return h
        self.state = next_state(GroupEvent.MOTION, self.state)
        links, jobs = self._interrupted, self._interrupt_jobs
        self._interrupted, self._interrupt_jobs = [], []
        self.chain.links = links
        self.mq.queue = deque(jobs)
        self._running = False
        self._tau = 0.0
        self._replan_from(0, 0.0, rest=True)
        h._finish(Status.DONE)
        return h

    # -- kernel ----------------------------------------------------------------------------
    def step(self, dt: float) -> None:
        """MOTION KERNEL of the group (after its member axes stepped): execute the inbox,
        advance along the path, write the members' set values. Fault barrier: no exception
        escapes; a failure puts the group in GroupErrorStop with a path stop."""
        try:
            self._step(dt)
        except Exception as exc:  # noqa: BLE001 - no kernel failure escapes the cycle
            self._kernel_failed(exc)

    def _step(self, dt: float) -> None:
        if self.state is G.GROUP_DISABLED:
            self.mq.inbox.clear()
            if self.chain.links:  # the stop of MC_GroupDisable
                self._note_dropped()
                self._advance(dt)
                if not self.chain.links:
                    self._settle_members(False)
            return
        self._supervise()
        if self.mq.inbox:
            self._process_inbox()
        if self.chain.links:
            self._advance(dt)
        else:
            self.path_velocity = 0.0
        self._settle()

    def _supervise(self) -> None:
        """A member axis in ErrorStop (or switched off) stops the group along the path."""
        self._note_dropped()
        if self.state is G.GROUP_ERROR_STOP:
            for ax in self.axes:
                self._take_over(ax)
            return
        for ax in self.axes:
            if ax.state is S.ERROR_STOP or ax.state is S.DISABLED:
                why = (
                    f"axis {ax.name!r}: {ax.axis_error.name} ({ax.axis_error_reason})"
                    if ax.state is S.ERROR_STOP
                    else f"axis {ax.name!r} was switched off"
                )
                self.raise_group_error(ErrorID.AXIS_ERROR_STOP, why)
                return

    def _note_dropped(self) -> None:
        """Members switched off while the group moves are not written again until the group
        is at rest (switched on meanwhile, they stand where they are)."""
        if not self.chain.links:
            self._dropped.clear()
        for ax in self.axes:
            if ax.state is S.DISABLED:
                self._dropped.add(ax)
        self._off = bool(self._dropped)

    def _take_over(self, ax: Axis) -> None:
        """While the group brakes along its path after an axis error, the faulted member
        follows the group's path stop instead of its own error ramp."""
        if self.moving and ax.state is S.ERROR_STOP and ax.active is not None:
            ax.active = None

    def raise_group_error(self, eid: ErrorID, reason: str) -> None:
        """GroupErrorStop: every command fails, the group brakes along its path."""
        if self.state is G.GROUP_ERROR_STOP:
            return
        self.error_id = eid
        self.error_reason = reason
        self.state = next_state(GroupEvent.ERROR, self.state)
        for job in self.mq.inbox:
            job.handle._finish(Status.ERROR, ErrorID.AXIS_ERROR_STOP, reason)
        self.mq.inbox.clear()
        for h in self.mq.stops:
            h._finish(Status.ERROR, ErrorID.AXIS_ERROR_STOP, reason)
        self.mq.stops.clear()
        self._drop_interrupted(Status.ERROR, ErrorID.AXIS_ERROR_STOP, reason)
        self._path_stop(abort=True, status=Status.ERROR, eid=ErrorID.AXIS_ERROR_STOP, reason=reason)
        for ax in self.axes:
            self._take_over(ax)

    def _kernel_failed(self, exc: Exception) -> None:
        reason = f"group kernel: {type(exc).__name__}: {exc}"
        try:
            if self.state is not G.GROUP_ERROR_STOP:
                self.raise_group_error(
                    ErrorID.PLANNING_FAILED
                    if isinstance(exc, PlanningError)
                    else ErrorID.INTERNAL_ERROR,
                    reason,
                )
                return
        except Exception:  # noqa: BLE001 - last line of defence: hold still
            pass
        self.chain.links = []
        self.mq.fail_all(ErrorID.INTERNAL_ERROR)
        self._running = False
        for ax in self.axes:
            ax.v = ax.a = ax.j = 0.0
        self.state = G.GROUP_ERROR_STOP
        self.error_reason = self.error_reason or reason

    def _drop_interrupted(
        self, status: Status, eid: ErrorID = ErrorID.OK, reason: str = ""
    ) -> None:
        """Forget an interrupted path; its commands end with ``status``."""
        for j in self._interrupt_jobs:
            j.handle._finish(status, eid, reason)
        self._interrupted, self._interrupt_jobs = [], []

    def _settle_members(self, moving: bool) -> None:
        """Members in SynchronizedMotion exactly while the group moves them."""
        for ax in self.axes:
            if ax.state is S.STANDSTILL and moving:
                ax.state = next_axis_state(AxisEvent.GROUP_MOTION, ax.state)
            elif ax.state is S.SYNCHRONIZED_MOTION and not self.chain.links:
                ax.state = next_axis_state(AxisEvent.GROUP_DONE, ax.state)

    def _settle(self) -> None:
        """State changes at the end of the group's step."""
        st = self.state
        moving = bool(self.chain.links)
        self._settle_members(moving and st is not G.GROUP_ERROR_STOP)
        if moving or self.mq.inbox:
            return
        if st is G.GROUP_MOVING:
            self.state = next_state(GroupEvent.MOTION_DONE, st)
        elif st is G.GROUP_STOPPING:
            stops = self.mq.stops
            for h in stops:
                if h.status is Status.ACTIVE:
                    h._finish(Status.DONE)
            if all(not h.hold for h in stops):
                stops.clear()
                self.state = next_state(GroupEvent.STOP_RELEASED, st)

    # -- inbox -----------------------------------------------------------------------------
    def _process_inbox(self) -> None:
        inbox = self.mq.take_inbox()
        for job in inbox:
            if job.handle.terminal:
                continue
            kind = job.cmd.kind
            if kind == "stop":
                self._drop_interrupted(Status.ABORTED)
                self._path_stop(abort=True, status=Status.ABORTED, dec=job.cmd.deceleration)
                job.handle.status = Status.ACTIVE
                continue
            if kind in ("halt", "interrupt"):
                keep = kind == "interrupt"
                if self._stop_job is not None:
                    # the brake of an earlier Halt / Interrupt runs: this command takes over
                    self._stop_job.handle._finish(Status.ABORTED)
                    self._stop_job = None
                interrupted = bool(self._interrupted or self._interrupt_jobs)
                if not keep:
                    self._drop_interrupted(Status.ABORTED)  # a Halt ends an interrupted path
                if not (keep and interrupted):  # (a second Interrupt: the brake runs on)
                    self._path_stop(
                        abort=not keep, status=Status.ABORTED, keep=keep, dec=job.cmd.deceleration
                    )
                job.handle.status = Status.ACTIVE
                self._stop_job = job
                continue
            if self._interrupted or self._interrupt_jobs:
                # a new move discards the interrupted path (MC_GroupContinue has nothing left)
                for j in self._interrupt_jobs:
                    j.handle._finish(Status.ABORTED)
                self._interrupted, self._interrupt_jobs = [], []
            if job.cmd.mode is BufferMode.ABORTING and self.moving:
                self._path_stop(abort=True, status=Status.ABORTED)
            try:
                self._append(job)
            except PlanningError as exc:
                job.handle._finish(Status.ERROR, ErrorID.PLANNING_FAILED, f"planner: {exc}")
            except _MoveError as exc:
                job.handle._finish(Status.ERROR, exc.error_id, str(exc))
        if self._stop_job is not None and not self.chain.links:
            self._stop_job.handle._finish(Status.DONE)
            self._stop_job = None

    # -- building paths --------------------------------------------------------------------
    def _base(self) -> tuple[float, ...]:
        """Where a move appended now starts: the end of the chain, or the set position."""
        links = self.chain.links
        if links:
            return _link_end(links[-1])
        return self.position()

    def _append(self, job: _GJob) -> None:
        cmd = job.cmd
        base = self._base()
        kind = cmd.kind
        target = (
            tuple(b + d for b, d in zip(base, cmd.position, strict=True))
            if cmd.relative
            else tuple(float(x) for x in cmd.position)
        )
        vm, am, jm = self._limits()
        if kind == "direct":
            self._check_limits(target, "position")
            traj = self._plan_direct(cmd, base, target)
            job.end = target
            lk = Link(_DUMMY, 1.0, 1.0, 1.0, 1.0, owner=job, last=True)
            lk.sampled = _Sampled(traj, target)
            job.links = [lk]
            self._connect(job, [lk])
            return
        pieces: list[tuple[Piece, Any]]  # (piece, the segment it was made from, if kept)
        if kind == "curve":
            path, end = self._curve(cmd, base)
            breaks = _curve_breaks(path)
            pieces = [
                (CurvePiece(path, a, b), None) for a, b in zip(breaks[:-1], breaks[1:], strict=True)
            ]
        elif kind in ("linear", "circular"):
            self._check_limits(target, "position")
            end = target
            gap = max(abs(a - b) for a, b in zip(base, target, strict=True))
            if kind == "linear" and gap <= 1e-12 * (1.0 + max(abs(x) for x in target)):
                # zero-length move: done at once, or when the group gets there
                job.end = target
                links = self.chain.links
                if links and cmd.mode is not BufferMode.ABORTING:
                    last = links[-1]
                    last.followers = [*(last.followers or ()), job]
                    return
                job.handle.status = Status.ACTIVE
                job.handle._finish(Status.DONE)
                return
            if kind == "linear":  # the closed-form piece, no numpy geometry
                pieces = [(LinePiece.between(base, target), None)]
            else:
                segs = self._arc_segments(cmd, base, target)
                self._check_path_limits(segs)
                pieces = [(piece_for(seg), seg) for seg in segs]
        else:  # pragma: no cover - submit() filters the kinds
            raise _MoveError(ErrorID.INTERNAL_ERROR, f"unknown move kind {kind!r}")
        vp = (cmd.velocity or _INF) * self.override
        ap, dp, jp = cmd.acceleration or _INF, cmd.deceleration or _INF, cmd.jerk or _INF
        links = [self._link(pc, job, vp, ap, dp, jp, vm, am, jm, seg) for pc, seg in pieces]
        for lk, nxt in zip(links[:-1], links[1:], strict=True):
            # C2 joints (B-spline knots) are passed at speed; the C1 joints of the seed-002
            # Hermite curve (a curvature jump) need rest there to keep the jerk limit
            lk.cap_out = _INF if _g2_joint(lk.piece, nxt.piece) else 0.0
        links[-1].last = True
        job.end = end
        job.links = links
        self._connect(job, links)

    def _link(
        self,
        pc: Piece,
        job: _GJob,
        vp: float,
        ap: float,
        dp: float,
        jp: float,
        vm: list[float],
        am: list[float],
        jm: list[float],
        seg: Any = None,
    ) -> Link:
        base = pc._base if isinstance(pc, SubPiece) else pc  # noqa: SLF001
        share = self.cfg.blend_share if isinstance(base, BlendPiece) else self.cfg.v_share
        V, A, J = path_caps(pc, vm, am, jm, vp, min(ap, dp), jp, share)
        Aa = A if ap == _INF else min(A, ap / pc.gmax)
        Ad = A if dp == _INF else min(A, dp / pc.gmax)
        A_acc, A_dec = max(A, Aa), max(A, Ad)
        A_acc = min(A_acc, Aa) if ap != _INF else A_acc
        A_dec = min(A_dec, Ad) if dp != _INF else A_dec
        return Link(
            pc,
            V,
            A_acc,
            A_dec,
            J,
            cap_out=_INF,
            owner=job,
            seg=seg,
            caps=(vp, ap, dp, jp),
            full_length=pc.length,
        )

    def _arc_segments(self, cmd: GroupCommand, base: tuple[float, ...], target: tuple[float, ...]):
        """The geometric segments of a circular move."""
        if cmd.segment is not None:  # prebuilt (any plane, turns, helix, n axes)
            seg = cmd.segment
            p0 = [float(v) for v in seg.start]
            tol = 1e-9 * (1.0 + max(abs(v) for v in base))
            if len(p0) != len(base) or max(abs(a - b) for a, b in zip(p0, base, strict=True)) > tol:
                raise _MoveError(
                    ErrorID.INVALID_CIRCLE, "segment: does not start where the move starts"
                )
            return [seg]
        aux = tuple(float(x) for x in cmd.aux_point)
        n = len(base)
        try:
            if cmd.circ_mode is CircMode.BORDER:
                if len(aux) != n:
                    raise _MoveError(ErrorID.INVALID_CIRCLE, f"aux_point must have {n} values")
                via = tuple(b + a for b, a in zip(base, aux, strict=True)) if cmd.relative else aux
                return [Arc.from_three_points(base, via, target)]
            cw = cmd.path_choice is PathChoice.CLOCKWISE
            normal = None
            if n == 3:
                normal = (0.0, 0.0, 1.0)
            if cmd.circ_mode is CircMode.CENTER:
                if len(aux) != n:
                    raise _MoveError(ErrorID.INVALID_CIRCLE, f"aux_point must have {n} values")
                c = tuple(b + a for b, a in zip(base, aux, strict=True)) if cmd.relative else aux
                if n == 2:
                    return [Arc.from_center(base, target, c, clockwise=cw)]
                return [Arc.from_center(base, target, c, normal=normal, clockwise=cw)]
            # RADIUS: aux_point[0] = radius (negative: the long way), arc in the XY plane
            if not aux:
                raise _MoveError(ErrorID.INVALID_CIRCLE, "aux_point[0] must hold the radius")
            r = aux[0]
            if n == 2:
                return [Arc.from_radius(base, target, abs(r), clockwise=cw, large=r < 0.0)]
            return [
                Arc.from_radius(base, target, abs(r), normal=normal, clockwise=cw, large=r < 0.0)
            ]
        except PlanningError as exc:  # the geometry's own verdict on validated inputs
            raise _MoveError(ErrorID.INVALID_CIRCLE, f"circle: {exc}") from None

    def _check_limits(self, p: Sequence[float], what: str) -> None:
        for ax, x in zip(self.axes, p, strict=True):
            hi, lo = ax.cfg.sw_limit_pos, ax.cfg.sw_limit_neg
            tol = 1e-12 * (1.0 + abs(x))
            if (hi is not None and x > hi + tol) or (lo is not None and x < lo - tol):
                raise _MoveError(
                    ErrorID.TARGET_OUTSIDE_SW_LIMITS,
                    f"{what}: axis {ax.name!r} at {x:.9g} outside its software limits [{lo}, {hi}]",
                )

    def _check_path_limits(self, segs: Sequence[Any]) -> None:
        import numpy as np

        for seg in segs:
            if isinstance(seg, Line):
                continue
            pts = seg.evaluate(np.linspace(0.0, seg.u_end, 257))
            for i, ax in enumerate(self.axes):
                hi, lo = ax.cfg.sw_limit_pos, ax.cfg.sw_limit_neg
                col = pts[:, i]
                if (hi is not None and col.max() > hi + 1e-9) or (
                    lo is not None and col.min() < lo - 1e-9
                ):
                    raise _MoveError(
                        ErrorID.TARGET_OUTSIDE_SW_LIMITS,
                        f"the path leaves the software limits of axis {ax.name!r} [{lo}, {hi}]",
                    )

    def _plan_direct(self, cmd: GroupCommand, base: tuple[float, ...], target: tuple[float, ...]):
        from motionplc.planning.sync import plan_sync

        lims = []
        for ax in self.axes:
            c = ax.cfg
            acc = cmd.acceleration or _INF
            lims.append(
                Limits(
                    v_max=min(cmd.velocity or _INF, c.v_max) * self.override,
                    a_max=min(acc, c.a_max),
                    j_max=min(cmd.jerk or _INF, c.j_max),
                    v_min=-min(cmd.velocity or _INF, c.v_neg) * self.override,
                    a_min=-min(cmd.deceleration or _INF, c.a_neg),
                )
            )
        starts = [State(b, 0.0, 0.0) for b in base]
        targets = [State(t, 0.0, 0.0) for t in target]
        return plan_sync(starts, targets, lims, sync="time")

    def _curve(self, cmd: GroupCommand, base: tuple[float, ...]):  # noqa: ANN202
        from motionplc.planning.paths import BSplinePath, HermitePath

        pts = [base] + [tuple(float(x) for x in p) for p in cmd.points]
        n = len(self.axes)
        for i, p in enumerate(pts[1:]):
            if len(p) != n:
                raise _MoveError(ErrorID.INVALID_POINTS, f"points[{i}] must have {n} values")
            self._check_limits(p, f"points[{i}]")
        try:
            path = HermitePath(pts) if cmd.curve == "hermite" else BSplinePath.interpolate(pts)
        except PlanningError as exc:
            raise _MoveError(ErrorID.INVALID_POINTS, f"points: {exc}") from None
        self._check_path_limits([path])
        return path, pts[-1]

    # -- connecting a move to the chain ----------------------------------------------------
    def _connect(self, job: _GJob, links: list[Link]) -> None:
        """Append a move's links (blending with the chain's end) and re-plan; all or nothing:
        if planning fails the chain is restored as it was (the group keeps running what it
        had) and the error propagates to the command."""
        saved = self._snapshot()
        fresh = list(links)
        fresh_fields = [_LINK_GET(lk) for lk in fresh]
        for scale in _BLEND_SCALES:
            self._blend_scale = scale
            try:
                self._connect_unchecked(job, links)
                self.chain.journal = None
                return
            except _TooLateError:
                pass
            except Exception:
                self._restore(saved)
                self.chain.journal = None
                raise
            finally:
                self._blend_scale = 1.0
            # the corner blend trimmed the piece before it so much that the junction speeds
            # fell below what the running piece is committed to (it could no longer slow down
            # in time: its successor's profile would overshoot its piece, the freeze-and-jump
            # of issue 25): undo and join again with a smaller blend, at last an exact corner
            # (which only adds path behind the old end of the chain: always consistent)
            self._restore(saved)
            for lk, vals in zip(fresh, fresh_fields, strict=True):
                for f, v in zip(_LINK_STATE, vals, strict=True):
                    setattr(lk, f, v)
            links[:] = fresh
        self.chain.journal = None  # pragma: no cover - the exact corner always fits
        raise PlanningError("the running motion cannot take the new move")  # pragma: no cover

    def _snapshot(self) -> tuple[int, Any, int]:
        """Start journalling the links a join changes (the undo costs what it touched)."""
        self.chain.journal = {}
        self._merges = []
        return len(self.chain.links), self.mq.active, len(self.mq.queue)

    def _restore(self, saved: tuple[int, Any, int]) -> None:
        n, active, nq = saved
        chain = self.chain
        chain.undo()
        links = chain.links
        for k, x, y in reversed(self._merges):
            links[k : k + 1] = [x, y]
        self._merges = []
        del links[n:]
        self.mq.active = active
        q = self.mq.queue
        while len(q) > nq:
            q.pop()

    def _connect_unchecked(self, job: _GJob, links: list[Link]) -> None:
        chain = self.chain
        prev = chain.links[-1] if chain.links else None
        if prev is not None:
            chain.touch(prev)  # (the join may change its end, piece and caps)
        cmd = job.cmd
        dirty = len(chain.links)
        if prev is not None and prev.sampled is None and links[0].sampled is None:
            blend = cmd.mode >= BufferMode.BLENDING_LOW
            if blend:
                dirty = self._join(prev, links, job)
            else:
                prev.cap_out = 0.0
        elif prev is not None:
            prev.cap_out = 0.0
        n_old = len(chain.links)
        for lk in links:
            chain.links.append(lk)
        self.mq.queue.append(job)
        links[-1].cap_out = 0.0
        if self.cfg.merge_ratio < 1.0:
            dirty = min(dirty, self._merge_runs(max(2, n_old - 3)))
        self._replan_from(dirty, 0.0, rest=not self._running)

    # -- runs: pieces merged into one profile ---------------------------------------------
    def _merge_runs(self, k: int) -> int:
        """Merge neighbours from link ``k`` on into runs where :meth:`_mergeable` (never the
        last link: the next move may still trim it for its blend); returns the lowest index
        changed (``len`` if none). Every merge is recorded for :meth:`_restore`."""
        links = self.chain.links
        low = len(links)
        while k + 2 < len(links):
            x, y = links[k], links[k + 1]
            run = self._merged(x, y) if self._mergeable(x, y) else None
            if run is not None:
                self._merges.append((k, x, y))
                links[k : k + 2] = [run]
                low = min(low, k)
            else:
                k += 1
        return low

    def _mergeable(self, x: Link, y: Link) -> bool:
        if x.cap_out <= 0.0 or x.sampled is not None or y.sampled is not None:
            return False
        if x.stopping or y.stopping or x.stale or y.stale:
            return False
        if x.profile is not None or y.profile is not None:
            return False
        if not (_runnable(x.piece) and _runnable(y.piece)):
            return False
        if abs(x.piece.g1 - 1.0) > 1e-9 or abs(y.piece.g0 - 1.0) > 1e-9:
            return False
        nx = len(x.members) if x.members is not None else 1
        ny = len(y.members) if y.members is not None else 1
        if nx + ny > self.cfg.max_run:
            return False
        return True

    def _merged(self, x: Link, y: Link) -> Link | None:
        """The run of ``x`` followed by ``y`` with the caps of its bounds (the maxima of the
        parts'), or None if that is too slow: below ``merge_ratio`` of the speed either
        piece could reach on its own between two joints at the run's speed."""
        piece = RunPiece([x.piece, y.piece])
        cx, cy = x.caps, y.caps
        vm, am, jm = self._limits()
        owner = x.members[0][2].owner if x.members is not None else x.owner
        try:
            run = self._link(piece, owner, *map(min, cx, cy), vm, am, jm)
        except PlanningError:
            return None
        r = self.cfg.merge_ratio
        ux, uy = x.piece.U, y.piece.U
        for lk, other in ((x, uy), (y, ux)):
            # (a sliver left between two blends is as fast as its neighbour, whatever its cap)
            if lk.piece.U > 1e-2 * other and run.V < r * lk.V:
                return None
        if x.cap_out < run.V:
            return None
        members = _members(x) + _members(y, x.piece.U)
        ends = piece.ends  # the members end exactly where the run's parts end
        if len(ends) == len(members):
            starts = (0.0, *ends[:-1])
            members = [(a, b, m) for a, b, (_, _, m) in zip(starts, ends, members, strict=True)]
        run.members = members
        run.cap_out = y.cap_out
        run.full_length = x.full_length + y.full_length
        return run

    def _junction_velocity(self, prev: Link, job: _GJob) -> float:
        v1 = (prev.owner.cmd.velocity or _INF) if prev.owner is not None else 0.0
        v2 = job.cmd.velocity or _INF
        return junction_velocity(job.cmd.mode, v1, v2) * self.override

    def _join(self, prev: Link, links: list[Link], job: _GJob) -> int:
        """Join ``links`` (a new move) to ``prev`` (the chain's last link) under a blending
        BufferMode: a blend piece for the corner, or the junction speed cap; returns the index
        from which the chain changed."""
        chain = self.chain
        first = links[0]
        vj = self._junction_velocity(prev, job)
        cmd = job.cmd
        pa, pb = prev.piece, first.piece
        ta, tb = pa.tangent_out(), pb.tangent_in()
        dot = max(-1.0, min(1.0, sum(a * b for a, b in zip(ta, tb, strict=True))))
        theta = math.acos(dot)
        g2 = _g2_joint(pa, pb)
        idx = len(chain.links) - 1
        tm = cmd.transition_mode
        if theta <= _SMOOTH and g2:
            prev.cap_out = vj  # a smooth junction: passed at the blending velocity
            return idx
        prev.cap_out = 0.0  # an exact corner unless a blend is made below
        if tm is TransitionMode.TM_NONE or theta > MAX_DEFLECTION:
            return idx
        lines = isinstance(pa, LinePiece) and isinstance(pb, LinePiece)
        seg_a, seg_b = prev.seg, first.seg
        if not lines:
            if seg_a is None and isinstance(pa, LinePiece):
                seg_a = Line(pa.start, pa.end)
            if seg_b is None and isinstance(pb, LinePiece):
                seg_b = Line(pb.start, pb.end)
        if (not lines and (seg_a is None or seg_b is None)) or prev.stopping:
            return idx
        # room: half of each move, and on the running piece only what lies ahead of the
        # point where it could still stop (with a margin)
        # (a move consumed by two blends keeps a sliver: pieces never vanish)
        room_a = min(0.5 * prev.full_length, pa.U * (1.0 - 1e-3))
        if idx == 0 and self._running:
            room_a = min(room_a, 0.9 * (pa.U - self._stop_point(prev)))
        room = min(room_a, 0.5 * pb.length)
        if room <= 1e-9 * (1.0 + pa.length + pb.length):
            return idx
        d = self._corner_distance(tm, cmd.transition_parameter, theta, ta, tb, seg_a, seg_b, room)
        d *= self._blend_scale
        if not d > 1e-12 * (1.0 + pa.length):
            return idx
        vm, am, jm = self._limits()
        parts: list[Piece]
        if lines:
            bp = BlendPiece(pa.end, ta, tb, d)
            if self.cfg.corner_choice and tm is TransitionMode.TM_MAX_CORNER_DEVIATION:
                share = self._corner_share(prev, first, bp, vj, vm, am, jm)
                if share == 0.0:
                    return idx  # the exact corner is faster (prev.cap_out is 0)
                if share != 1.0:
                    d *= share
                    bp = BlendPiece(pa.end, ta, tb, d)
            parts = bp.split(self.cfg.blend_parts)
        else:
            blend = self._bounded_blend(seg_a, seg_b, d, tm, cmd.transition_parameter)
            if blend is None:
                return idx
            d = blend.distance
            parts = [CurvePiece(blend)]
        ca, cb = prev.caps, first.caps
        blinks = []
        for part in parts:
            blink = self._link(
                part, job, vj, min(ca[1], cb[1]), min(ca[2], cb[2]), min(ca[3], cb[3]), vm, am, jm
            )
            blink.cap_out = _INF
            blink.full_length = 0.0
            blinks.append(blink)
        # trim the neighbours (their parameter keeps its origin at their start)
        self._replace_piece(prev, _trim_end(prev, pa.U - d), vm, am, jm)
        if prev.seg is not None:
            prev.seg = prev.seg.trim(0.0, prev.seg.u_end - d)
        self._replace_piece(first, _trim_start(first, d), vm, am, jm)
        if first.seg is not None:
            first.seg = first.seg.trim(d, first.seg.u_end)
        prev.cap_out = _INF
        if idx == 0 and self._running:
            prev.stale = True  # its running profile ends at the old end point
        links[0:0] = blinks
        return idx

    def _corner_share(
        self,
        prev: Link,
        first: Link,
        bp: BlendPiece,
        vj: float,
        vm: list[float],
        am: list[float],
        jm: list[float],
    ) -> float:
        """The share of the corner distance that passes a line-line corner fastest: 1, 1/4,
        1/16 of the blend, or 0 (an exact stop). Estimated over the halves of the two lines
        next to the corner (from and to the speed an exact stop reaches there, zero path
        acceleration at the joints, :func:`traverse_time`): under jerk limits a blend is
        passed slowly (its curvature changes fast), and a stop at the corner can be faster
        than the blend the tolerance allows. The blend's caps scale with its size (``b2`` as
        ``1/d``, ``b3`` as ``1/d^2``). A blend passed at least as fast as the lines reach
        next to an exact stop is always kept (fine segments: the speed is carried over many
        of them)."""
        la = min(0.5 * prev.full_length, prev.piece.U)
        lb = 0.5 * first.piece.U
        wa = min(prev.V, max_speed_change(0.0, la, prev.A_dec, prev.J))
        wb = min(first.V, max_speed_change(0.0, lb, first.A_acc, first.J))
        t_stop = traverse_time(wa, 0.0, la, prev.V, prev.A_dec, prev.J) + traverse_time(
            0.0, wb, lb, first.V, first.A_acc, first.J
        )
        ca, cb = prev.caps, first.caps
        a_prog = min(ca[1], cb[1], ca[2], cb[2])
        j_prog = min(ca[3], cb[3])
        best, share = t_stop, 0.0
        d = bp.distance
        for s in (1.0, 0.25, 0.0625):
            view = _ScaledBlend(bp, s)
            try:
                V, _, _ = path_caps(view, vm, am, jm, vj, a_prog, j_prog, self.cfg.blend_share)
            except PlanningError:
                continue
            w = V * bp.g0
            if s == 1.0 and w >= min(wa, wb):
                return 1.0  # the blend is passed as fast as an exact stop gets next to it
            t = (
                traverse_time(wa, w, la - s * d, prev.V, prev.A_dec, prev.J)
                + s * bp.U / V
                + traverse_time(w, wb, lb - s * d, first.V, first.A_acc, first.J)
            )
            if t < best * (1.0 - 1e-9):
                best, share = t, s
        return share

    def _bounded_blend(self, seg_a: Any, seg_b: Any, d: float, tm: TransitionMode, par: float):  # noqa: ANN202
        """The corner blend of two segments (one of them curved) with corner distance at most
        ``d``; under TMMaxCornerDeviation also its distance to the programmed *path* (not only
        to the corner point: at a tangent line-arc junction the blend cuts into the arc) is at
        most the tolerance (bisection on ``d``, the path sampled densely). None: no blend."""
        import numpy as np

        from motionplc.planning.paths.blend import CornerBlend

        if tm is not TransitionMode.TM_MAX_CORNER_DEVIATION:
            return CornerBlend(seg_a, seg_b, d)
        tol = par or self.cfg.tolerance
        la, lb = seg_a.u_end, seg_b.u_end

        def deviation(dd: float) -> tuple[float, Any]:
            # (a probe: the geometry without the arc-length table, built for the result only)
            cb = CornerBlend._probe(seg_a, seg_b, dd)  # noqa: SLF001
            q = cb.evaluate(np.linspace(0.0, cb.u_end, 65))
            pa = seg_a.evaluate(np.linspace(max(0.0, la - 1.5 * dd), la, 513))
            pb = seg_b.evaluate(np.linspace(0.0, min(lb, 1.5 * dd), 513))
            ref = np.concatenate([pa, pb])
            dim = ref.shape[1]
            if dim < 8:
                # per axis, 2-D arrays: the same sums in the same order as summing the 3-D
                # array over its last axis (numpy adds fewer than 8 terms one after the
                # other), without building the (65 x 1026 x dim) array
                d2 = np.subtract.outer(q[:, 0], ref[:, 0])
                d2 *= d2
                for k in range(1, dim):
                    dk = np.subtract.outer(q[:, k], ref[:, k])
                    dk *= dk
                    d2 += dk
            else:
                d2 = ((q[:, None, :] - ref[None, :, :]) ** 2).sum(axis=2)
            dist = np.sqrt(d2).min(axis=1)
            # the reference is sampled: a chord error of at most (spacing / 2)^2 / (2 R) is
            # ignored; the samples bound the distance from above
            return float(dist.max()), cb

        dev, _ = deviation(d)
        if dev <= tol:
            return CornerBlend(seg_a, seg_b, d)
        lo, hi, best = 0.0, d, None
        for _ in range(10):
            mid = 0.5 * (lo + hi)
            dev, _ = deviation(mid)
            if dev <= tol:
                lo, best = mid, mid
                if dev >= 0.9 * tol:
                    break
            else:
                hi = mid
        return None if best is None else CornerBlend(seg_a, seg_b, best)

    def _replace_piece(self, lk: Link, pc: Piece, vm, am, jm) -> None:  # noqa: ANN001
        vp, ap, dp, jp = lk.caps
        new = self._link(pc, lk.owner, vp, ap, dp, jp, vm, am, jm, lk.seg)
        lk.piece = pc
        lk.V, lk.A_acc, lk.A_dec, lk.J = new.V, new.A_acc, new.A_dec, new.J
        if not (self._running and self.chain.links and self.chain.links[0] is lk):
            lk.profile = None

    def _corner_distance(
        self,
        tm: TransitionMode,
        param: float,
        theta: float,
        ta: tuple[float, ...],
        tb: tuple[float, ...],
        seg_a: Any,
        seg_b: Any,
        room: float,
    ) -> float:
        """Corner distance d for the transition mode (capped at ``room``)."""
        lines = (seg_a is None or isinstance(seg_a, Line)) and (
            seg_b is None or isinstance(seg_b, Line)
        )
        if tm is TransitionMode.TM_CORNER_DISTANCE:
            return min(param, room)
        if tm is TransitionMode.TM_MAX_CORNER_DEVIATION:
            tol = param or self.cfg.tolerance
            if lines:
                s = math.sin(0.5 * theta)
                return min(2.0 * tol / s, room) if s > 0.0 else room
            from motionplc.planning.paths.blend import _solve_deviation

            a_part = seg_a.trim(max(0.0, seg_a.u_end - room), seg_a.u_end)
            b_part = seg_b.trim(0.0, min(seg_b.u_end, room))
            cb = _solve_deviation(a_part, b_part, tol, room, theta)
            return 0.0 if cb is None else cb.distance
        # TMConstantVelocity / TMStartVelocity: the blend passed at speed param
        v = param
        if v <= 0.0:
            return 0.0
        vm, am, jm = self._limits()
        probe = BlendPiece((0.0,) * len(ta), ta, tb, 1.0)
        V1, _, _ = path_caps(probe, vm, am, jm, _INF, _INF, _INF, self.cfg.v_share)
        # caps scale: curvature term ~ sqrt(d), jerk term ~ d^(2/3); V1 is the smaller of both
        d = max((v / V1) ** 2, (v / V1) ** 1.5)
        return min(d, room)

    # -- look-ahead and profiles -----------------------------------------------------------
    def _replan_from(self, dirty: int, w_start: float, rest: bool) -> None:
        """Recompute junction speeds after a change at links >= dirty and plan the profiles
        whose speeds changed (the running piece from its current state)."""
        chain = self.chain
        links = chain.links
        if not links:
            return
        # the forward pass redoes every link from the lowest one whose w_back changed or that
        # is new (a run merged at or after ``dirty`` starts with w_in = 0: a pass that skipped
        # it as unchanged left a junction whose speeds disagree)
        if rest or not self._running:
            low = min(chain.backward(dirty, 0), dirty)
            chain.forward(0, w_start, None if dirty == 0 else low)
            self._plan_near()
            return
        low = min(chain.backward(dirty, 0), dirty)
        lk0 = links[0]
        want = lk0.w_back
        if lk0.sampled is None and not lk0.stopping and (want != lk0.w_out or lk0.stale):
            chain.touch(lk0)
            lk0.w_out = self._replan_running(lk0, want)
            lk0.stale = False
            low = 1
            if lk0.w_out > want * (1.0 + 1e-9) and self._blend_scale > 0.0:
                # the running piece cannot slow down to the junction speed that is left
                raise _TooLateError
        chain.forward(1, lk0.w_out, max(low, 1))
        self._plan_near()

    def _plan_near(self) -> None:
        """Profiles are planned one piece ahead: the running (or next) piece and the one after
        it; the others when the piece before them starts (their speeds may still change with
        every move queued behind them)."""
        chain = self.chain
        for lk in chain.links[:2]:
            if lk.profile is None and lk.sampled is None:
                chain.touch(lk)
                lk.profile = _guard_plan(lk)

    def _state_on(self, lk: Link) -> State:
        prof = lk.profile
        assert prof is not None
        s = prof.at(self._tau)
        return State(s.p, s.v, s.a)

    def _stop_point(self, lk: Link) -> float:
        """Where the running piece would come to rest braking now (parameter)."""
        if lk.profile is None:
            return 0.0
        st = self._state_on(lk)
        try:
            prof = plan_velocity(
                st,
                0.0,
                Limits(v_max=_INF, a_max=lk.A_acc, j_max=lk.J, v_min=-_INF, a_min=-lk.A_dec),
            )
        except PlanningError:
            return lk.piece.U
        return max(st.p, prof.end.p)

    def _replan_running(self, lk: Link, want: float) -> float:
        """Re-plan the running piece from its current state to end speed ``want`` (or the
        highest reachable below it); returns the end speed in effect."""
        st = self._state_on(lk)
        pc = lk.piece
        U = pc.U
        a, J = st.a, lk.J
        # a conservative reachable end speed: first bring the acceleration to zero
        if J == _INF or a == 0.0:
            t1, v1, d1 = 0.0, st.v, 0.0
        else:
            t1 = abs(a) / J
            v1 = st.v + 0.5 * a * t1
            d1 = st.v * t1 + 0.5 * a * t1 * t1 - sign(a) * J * t1**3 / 6.0
        room = U - st.p - d1
        target = want / pc.g1
        if (room <= 0.0 or v1 < 0.0) and not lk.stale:
            return lk.w_out
        if target > v1 and room > 0.0:
            target = min(target, v1 + max_speed_change(v1, room * (1.0 - 1e-9), lk.A_acc, J))
        for tgt in (target, 0.0) if lk.stale else (target,):
            try:
                prof = plan(st, State(U, tgt, 0.0), lk.limits())
            except PlanningError:
                continue
            (_, pmax), (vmin, _), _ = prof.extrema()
            tol = 1e-9 * (1.0 + abs(U))
            if pmax > U + tol or vmin < -1e-9 * (1.0 + abs(tgt)):
                continue
            lk.profile = _Offset(prof, self._tau)
            return tgt * pc.g1
        if lk.stale:
            raise PlanningError("the running piece cannot end where the blend begins")
        return lk.w_out

    # -- stopping along the path -----------------------------------------------------------
    def _path_stop(
        self,
        abort: bool,
        status: Status,
        eid: ErrorID = ErrorID.OK,
        reason: str = "",
        keep: bool = False,
        dec: float = 0.0,
    ) -> None:
        """Brake along the path as fast as the limits allow (``dec``: a path deceleration
        cap). The commands whose motion is cut end with ``status`` (``abort``), or stay busy
        with the rest of the path kept for MC_GroupContinue (``keep``)."""
        chain = self.chain
        links = chain.links
        if not links:
            return
        if not self._running:  # nothing started yet: nothing to brake
            self._cut(links, [], keep, status, eid, reason)
            return
        lk0 = links[0]
        if lk0.sampled is not None:
            # synchronised / curve motion runs to its end (rest to rest); drop the rest
            self._cut(links[1:], [lk0], keep, status, eid, reason)
            return
        st = self._state_on(lk0)
        a_dec = lk0.A_dec if not dec else min(lk0.A_dec, dec / lk0.piece.gmax)
        lim = Limits(v_max=_INF, a_max=lk0.A_acc, j_max=lk0.J, v_min=-_INF, a_min=-a_dec)
        prof = plan_velocity(st, 0.0, lim)
        U = lk0.piece.U
        if prof.end.p <= U:  # the stop fits in the running piece
            u_stop = prof.end.p
            rest = links[1:]
            tail_left = keep and U - u_stop > 1e-12 * (1.0 + U)
            if tail_left:
                tail = Link(
                    SubPiece(lk0.piece, u_stop, U),
                    lk0.V,
                    lk0.A_acc,
                    lk0.A_dec,
                    lk0.J,
                    cap_out=lk0.cap_out,
                    owner=lk0.owner,
                    last=lk0.last,
                    caps=lk0.caps,
                )
                if lk0.members is not None:  # a run: the members still ahead, shifted
                    tail.members = [
                        (max(0.0, u0 - u_stop), u1 - u_stop, _event_link(m))
                        for u0, u1, m in lk0.members[lk0.m_next :]
                        if u1 > u_stop
                    ] or None
                    tail.owner = tail.members[0][2].owner if tail.members else None
                    tail.last = False
                rest = [tail, *rest]
            lk0.profile = _Offset(prof, self._tau)
            lk0.stopping = True
            lk0.w_out = 0.0
            lk0.cap_out = 0.0
            # (kept for MC_GroupContinue with nothing of the piece left: the stop ends where
            # the piece does, an exact corner, and its move is done there)
            lk0.last = lk0.last and not tail_left
            self._cut(rest, [lk0], keep, status, eid, reason)
            return
        # the stop runs over the next pieces: end it at the end of the first link m for which
        # the chain cut there leaves the running piece's profile valid
        m = 1
        while m < len(links) - 1:
            w_next = 0.0
            ok = True
            for k in range(m, 0, -1):
                nxt = links[k]
                if nxt.sampled is not None:
                    ok = False
                    break
                pc = nxt.piece
                x = max_speed_change(w_next / pc.g1, pc.U * (1.0 - 1e-9), nxt.A_dec, nxt.J)
                w_next = (w_next / pc.g1 + x) * pc.g0
                prev = links[k - 1]
                w_next = min(w_next, prev.V * prev.piece.g1, nxt.V * pc.g0)
                if k - 1 > 0:
                    w_next = min(w_next, prev.cap_out)
            if ok and w_next >= lk0.w_out:
                break
            m += 1
        keep_links = links[: m + 1]
        for lk in keep_links[1:]:
            lk.stopping = True
        keep_links[-1].cap_out = 0.0
        self._cut(links[m + 1 :], keep_links, keep, status, eid, reason)
        chain.backward(0, 1)
        chain.forward(1, lk0.w_out, None)
        self._plan_near()

    def _cut(
        self,
        rest: list[Link],
        kept: list[Link],
        keep: bool,
        status: Status,
        eid: ErrorID,
        reason: str,
    ) -> None:
        """The chain becomes ``kept`` (the stop); ``rest`` is dropped (its commands end with
        ``status``) or kept for MC_GroupContinue (``keep``: its commands stay busy)."""
        self.chain.links = kept
        if keep:  # only what a busy command still has to do can be resumed
            rest = [
                lk
                for lk in rest
                if any(o is not None and not o.handle.terminal for o in _owners(lk))
            ]
        kept_jobs = []
        for lk in kept:
            for o in _owners(lk):
                if o is not None and o not in kept_jobs:
                    kept_jobs.append(o)
        rest_jobs = []
        for lk in rest:
            for o in _owners(lk):
                if o is not None and o not in rest_jobs:
                    rest_jobs.append(o)
        mq = self.mq
        for job in mq.jobs():  # jobs without links left (none normally)
            if job not in kept_jobs and job not in rest_jobs and job not in mq.inbox:
                rest_jobs.append(job)
        if keep:
            self._interrupted = rest
            self._interrupt_jobs = rest_jobs
            stay = [j for j in kept_jobs if j not in rest_jobs]
            if mq.active is not None and mq.active not in stay:
                mq.active = None
            mq.queue = deque(j for j in stay if j is not mq.active)
            for lk in kept:
                if lk.owner in rest_jobs:
                    lk.last = False
                for _, _, m in lk.members or ():
                    if m.owner in rest_jobs:
                        m.last = False
            return
        for job in kept_jobs + rest_jobs:
            job.handle._finish(status, eid, reason)
        for lk in kept:
            lk.owner = None  # the stop belongs to nobody (a Halt is tracked separately)
            for _, _, m in lk.members or ():
                m.owner = None
        mq.active = None
        mq.queue.clear()

    def _abort_all(self, status: Status, eid: ErrorID) -> None:
        for job in self._interrupt_jobs:
            job.handle._finish(status, eid)
        self.mq.fail_all(eid, status)
        self.chain.links = []
        self._running = False
        self._tau = 0.0
        self._interrupted, self._interrupt_jobs = [], []
        if self._stop_job is not None:
            self._stop_job.handle._finish(status, eid)
            self._stop_job = None

    # -- stepping --------------------------------------------------------------------------
    def _advance(self, dt: float) -> None:
        links = self.chain.links
        lk = links[0]
        if not self._running:
            self._running = True
            self._tau = 0.0
            self._activate(lk)
        self._tau += dt
        while True:
            dur = _duration(lk)
            if self._tau < dur:
                break
            excess = self._tau - dur
            self._finish_link(lk)
            links.pop(0)
            if not links:
                self._running = False
                self._tau = 0.0
                self.path_velocity = 0.0
                for ax in self.axes:
                    if ax.state is not S.DISABLED and ax not in self._dropped:
                        ax.v = ax.a = ax.j = 0.0
                if self._stop_job is not None:
                    self._stop_job.handle._finish(Status.DONE)
                    self._stop_job = None
                return
            lk = links[0]
            self._tau = excess
            self._activate(lk)
        u = self._sample(lk, self._tau)
        if lk.members is not None:
            self._member_events(lk, u)

    def _activate(self, lk: Link) -> None:
        self._plan_near()  # this piece (planned ahead already) and the next one
        self._start_job(lk.owner)

    def _start_job(self, job: _GJob | None) -> None:
        """The move of the piece the group enters becomes Active."""
        if job is not None and not job.started:
            job.started = True
            if job.handle.status is Status.QUEUED:
                job.handle.status = Status.ACTIVE
            mq = self.mq
            if mq.queue and mq.queue[0] is job:
                mq.queue.popleft()
            mq.active = job

    def _finish_link(self, lk: Link) -> None:
        sampled = lk.sampled
        if sampled is not None:
            end = sampled.end
            vel = (0.0,) * len(end)
        else:
            prof = lk.profile
            assert prof is not None
            e = prof.end
            if lk.last and not lk.stopping and lk.owner is not None and lk.owner.end is not None:
                end = lk.owner.end
            elif e.p >= lk.piece.U:
                end = lk.piece.end
            else:
                end = lk.piece.point(e.p)
            d1 = lk.piece.at(e.p)[1]
            vel = tuple(x * e.v for x in d1)
        self.path_s += lk.piece.length if sampled is None else 0.0
        for ax, p, v in zip(self.axes, end, vel, strict=True):
            if ax.state is S.DISABLED or ax in self._dropped:
                continue
            ax.p = p
            ax.v = v
            ax.a = ax.j = 0.0
        if lk.members is not None:
            e = lk.profile.end
            self._member_events(lk, e.p if lk.stopping and e.p < lk.piece.U else _INF)
        self._end_jobs(lk)

    def _end_jobs(self, lk: Link) -> None:
        """The group has passed the end of ``lk``: its move is Done if it was its last piece,
        and so are the zero-length moves queued behind it."""
        if lk.last:
            job = lk.owner
            if job is not None:
                job.handle._finish(Status.DONE)  # type: ignore[attr-defined]
                mq = self.mq
                if mq.active is job:
                    mq.active = None
                else:
                    mq.remove(job)
        for job in lk.followers or ():  # zero-length moves queued behind this piece
            job.handle.status = Status.ACTIVE
            job.handle._finish(Status.DONE)

    def _member_events(self, lk: Link, u: float) -> None:
        """The pieces merged into the run ``lk`` whose end lies at or before ``u``: their moves
        end (and the next member's starts) as if they ran as pieces of their own."""
        mem = lk.members
        i = lk.m_next
        n = len(mem)
        while i < n and u >= mem[i][1]:
            self._end_jobs(mem[i][2])
            i += 1
            if i < n:
                self._start_job(mem[i][2].owner)
        lk.m_next = i

    def _sample(self, lk: Link, tau: float) -> float:
        """Write the members' set values at ``tau`` on ``lk``; returns the piece parameter."""
        sampled = lk.sampled
        axes = self.axes
        if sampled is not None:
            sp = 0.0
            for ax, prof in zip(axes, sampled.traj.profiles, strict=True):
                s = prof.at(tau)
                sp += s.v * s.v
                if ax.state is not S.DISABLED and ax not in self._dropped:  # switched off
                    ax.p, ax.v, ax.a, ax.j = s.p, s.v, s.a, s.j
            self.path_velocity = math.sqrt(sp)
            return 0.0
        prof = lk.profile
        assert prof is not None
        u, du, ddu, dddu = prof.at(tau)
        P, D1, D2, D3 = lk.piece.at(u)
        du2 = du * du
        sp = 0.0
        off = self._off
        for ax, p, d1, d2, d3 in zip(axes, P, D1, D2, D3, strict=True):
            v = d1 * du
            sp += v * v
            if off and ax in self._dropped:
                continue  # a member switched off is not moved (it follows its actual position)
            ax.p = p
            ax.v = v
            ax.a = d1 * ddu + d2 * du2
            ax.j = d1 * dddu + 3.0 * d2 * du * ddu + d3 * du2 * du
        self.path_velocity = math.sqrt(sp)
        return u

    # -- diagnostics -----------------------------------------------------------------------
    def emit_fb_edges(self, trace: Trace, cycle: int) -> None:
        for fb in self.fbs:
            if fb._dirty:
                bits = fb._get_outputs(fb)
                if bits != fb._traced_bits:
                    fb._emit_edges(trace, cycle, bits)
                else:
                    fb._dirty = False


_LINK_STATE = LINK_STATE
_LINK_GET = attrgetter(*_LINK_STATE)

_DUMMY = LinePiece((0.0,), (1.0,), 1.0)  # the piece of a link whose motion is sampled otherwise


class _ScaledBlend:
    """The bounds of a line-line blend scaled to ``share`` of its corner distance (for
    :func:`path_caps`)."""

    __slots__ = ("b1", "b2", "b3", "gmax")

    def __init__(self, bp: BlendPiece, share: float) -> None:
        self.b1 = bp.b1
        self.b2 = tuple(x / share for x in bp.b2)
        self.b3 = tuple(x / (share * share) for x in bp.b3)
        self.gmax = bp.gmax


class _TooLateError(Exception):
    """A join lowered a junction speed below what the running piece is committed to."""


class _MoveError(Exception):
    def __init__(self, error_id: ErrorID, text: str) -> None:
        super().__init__(text)
        self.error_id = error_id


class _Offset:
    """A profile planned from the state at time ``t0`` on the running piece: sampled in the
    piece's time (``at(t)`` = ``prof.at(t - t0)``)."""

    __slots__ = ("prof", "t0", "duration", "end")

    def __init__(self, prof: Profile, t0: float) -> None:
        self.prof = prof
        self.t0 = t0
        self.duration = t0 + prof.duration
        self.end = prof.end

    def at(self, t: float):  # noqa: ANN201 - Sample
        return self.prof.at(t - self.t0)


def _duration(lk: Link) -> float:
    sampled = lk.sampled
    if sampled is not None:
        return sampled.duration
    prof = lk.profile
    assert prof is not None
    return prof.duration


def _guard_plan(lk: Link) -> Profile:
    # (a PlanningError is the planner's verdict; anything else is a defect and reaches the
    # group's fault barrier as it is: INTERNAL_ERROR naming it, not PLANNING_FAILED)
    prof = lk.plan_rest()
    # a profile that leaves its piece (junction speeds it cannot join) would stand still at
    # the piece's end and jump: never run it
    (_, pmax), (vmin, _), _ = prof.extrema()
    U = lk.piece.U
    if pmax > U * (1.0 + 1e-9) or vmin < -1e-9 * (1.0 + prof.end.v):
        raise PlanningError(
            f"junction speeds {lk.w_in:.9g} -> {lk.w_out:.9g} m/s cannot be joined on a piece "
            f"of {U:.9g} (the profile reaches {pmax:.9g}, speed {vmin:.3g})"
        )
    return prof


def _link_end(lk: Link) -> tuple[float, ...]:
    sampled = lk.sampled
    if sampled is not None:
        return sampled.end
    if lk.stopping and lk.profile is not None and lk.profile.end.p < lk.piece.U:
        return lk.piece.point(lk.profile.end.p)
    if lk.last and lk.owner is not None and lk.owner.end is not None:
        return lk.owner.end
    return lk.piece.end


def _curve_breaks(path: Any) -> list[float]:
    """Section boundaries of a passing-point curve: the Hermite sections (integer parameter
    values) or the B-spline's distinct knots."""
    knots = getattr(path, "knots", None)
    if knots is not None:
        out: list[float] = []
        for k in knots:
            k = float(k)
            if not out or k > out[-1]:
                out.append(k)
        return out
    return [float(i) for i in range(int(round(path.u_end)) + 1)]


def _trim_end(lk: Link, u1: float) -> Piece:
    pc = lk.piece
    if isinstance(pc, LinePiece):
        return pc.trimmed(0.0, u1)
    seg = lk.seg
    if isinstance(seg, _Circular):
        return piece_for(seg.trim(0.0, u1))
    return SubPiece(pc, 0.0, u1)


def _trim_start(lk: Link, u0: float) -> Piece:
    pc = lk.piece
    if isinstance(pc, LinePiece):
        out = pc.trimmed(u0, pc.U)
        return out
    seg = lk.seg
    if isinstance(seg, _Circular):
        return piece_for(seg.trim(u0, seg.u_end))
    return SubPiece(pc, u0, pc.U)


def _runnable(pc: Piece) -> bool:
    """Pieces a run may hold: arc-length parameter at both ends, G2 joints."""
    if isinstance(pc, SubPiece):
        pc = pc._base  # noqa: SLF001
    return isinstance(pc, (LinePiece, CircularPiece, BlendPiece, RunPiece))


def _members(lk: Link, offset: float = 0.0) -> list[tuple[float, float, Link]]:
    if lk.members is None:
        return [(offset, offset + lk.piece.U, lk)]
    return [(u0 + offset, u1 + offset, m) for u0, u1, m in lk.members]


def _owners(lk: Link) -> list[Any]:
    """The moves a link's motion still belongs to (the members of a run not passed yet)."""
    if lk.members is None:
        return [lk.owner]
    return [m.owner for _, _, m in lk.members[lk.m_next :]]


def _event_link(m: Link) -> Link:
    """A copy of a run member's bookkeeping (move, last piece, followers)."""
    return Link(m.piece, 1.0, 1.0, 1.0, 1.0, owner=m.owner, last=m.last, followers=m.followers)
