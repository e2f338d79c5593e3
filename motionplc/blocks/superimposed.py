"""Superimposed motion: MC_MoveSuperimposed, MC_HaltSuperimposed and the axis' superimposed layer.

The layer (:class:`SuperimposedLayer`, the axis attribute ``Axis.sup``; None on an axis without
superimposed motion, so the cycle of such an axis costs one attribute test) adds a 1-D motion
on top of whatever the axis does, whatever job runs underneath (a discrete move, a velocity
move, a halt, a synchronized slave), after that job was sampled:

* In every kernel step the layer first takes its contribution out of the set values
  (:meth:`SuperimposedLayer.lift`), so the kernel plans and samples the underlying motion alone;
  after the underlying job was sampled it adds its own contribution again
  (:meth:`SuperimposedLayer.apply`). Between cycles the set values are the SUM.
* Limits: the SUM of underlying and superimposed motion stays within the axis' v / a / j limits
  at every instant. The superimposed profile is planned (time-optimal, jerk-limited) in the
  headroom the underlying motion leaves over the time window the profile needs: with the
  underlying's extrema (velocity, acceleration, |jerk|, exactly per constant-jerk segment of its
  profile chain) over the window, the superimposed limits are ``v_max - max v_u``,
  ``|v_min| + min v_u``, ``a_max - max a_u``, ``|a_min| + min a_u``, ``j_max - max |j_u|``
  (capped by the FB's VelocityDiff / Acceleration / Deceleration / Jerk). The window is found
  by a monotone fixed point: plan with the headroom of [0, T], re-plan with the headroom of the
  new duration; a profile whose duration fits the window it was planned for is valid. If the
  underlying motion leaves no headroom now (e.g. it accelerates with the axis' own jerk), the
  superimposed move waits (Busy, no motion) and starts at the first segment boundary of the
  underlying profile from which it fits (at the latest when the underlying motion ends). So the
  underlying FB finishes in its own time, the superimposed one possibly later.
* What the headroom cannot foresee (documented limits of the guarantee): an underlying job
  whose future is not a profile chain (a synchronized slave following its master: its current
  velocity and acceleration are taken as constant), a change of the MC_SetOverride factor, and
  a new underlying job that takes over while the superimposed motion moves (a buffered
  successor: the superimposed profile is then re-planned from its current state in the new
  headroom; if there is none, with the axis' own limits).
* A superimposed move from Standstill acts like MC_MoveRelative: the axis goes to
  DiscreteMotion and back to Standstill at the end (C8); otherwise the state does not change.
* MC_Stop, an axis error and any aborting (non-superimposed) command abort it (CommandAborted):
  its current contribution (position, velocity, acceleration) folds into the set state the new
  motion is planned from, so nothing jumps. Non-aborting (buffered) commands leave it alone. A
  second MC_MoveSuperimposed aborts only the first and moves from the superimposed position
  reached (its Distance counts from there, as MC_MoveRelative from the set position).
* When it completes, the distance stays as a constant offset until the underlying job ends and
  then folds into the set position: the final position is exactly (in floating point) the
  underlying target + the superimposed distance. Without an underlying job it folds at once.
* MC_HaltSuperimposed brakes the superimposed motion to rest (jerk-limited, in the same
  headroom, capped by its Deceleration and Jerk); the underlying motion continues; the offset
  reached stays. The running MC_MoveSuperimposed shows CommandAborted.
* The superimposed motion runs in real time (MC_SetOverride does not scale it).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any

from motionplc.blocks.axis import Command, Handle, Status
from motionplc.blocks.axis_state import Event, next_state
from motionplc.blocks.base import InputError, MotionFB, check_dynamic, check_number
from motionplc.blocks.enums import AxisState, ErrorID
from motionplc.blocks.motion import POSITION_MAX, InputChecks, _decel, _jerk
from motionplc.blocks.planner_guard import guarded
from motionplc.planning import Limits, PlanningError, Profile, State, plan, plan_velocity

if TYPE_CHECKING:
    from motionplc.blocks.axis import Axis
    from motionplc.blocks.axis_job import AxisJob

__all__ = [
    "MC_HaltSuperimposed",
    "MC_MoveSuperimposed",
    "SuperimposedLayer",
    "headroom_limits",
    "plan_in_headroom",
    "submit_superimposed",
    "underlying_envelope",
]

S = AxisState
_INF = math.inf
# jobs whose future motion is their profile chain (the others: current state held)
_CHAIN_KINDS = frozenset(
    {"absolute", "relative", "additive", "velocity", "halt", "feedstop", "stop", "estop"}
)
# the states in which MC_MoveSuperimposed is accepted (plcopen.md 1.3)
_ACCEPTED = (
    S.STANDSTILL,
    S.DISCRETE_MOTION,
    S.CONTINUOUS_MOTION,
    S.SYNCHRONIZED_MOTION,
)
_MAX_CANDIDATES = 64
_MAX_ITER = 16


# -- the headroom the underlying motion leaves ----
def underlying_envelope(
    axis: Axis, job: AxisJob | None, tau0: float, f: float, t0: float, t1: float
) -> tuple[float, float, float, float, float]:
    """(v_lo, v_hi, a_lo, a_hi, |j|_max) of the underlying job over the real-time window
    [t0, t1] of the layer, exactly (per constant-jerk segment of its chain). ``tau0`` is the
    job's trajectory time at layer time 0, ``f`` its time scale (override factor or 1).

    No job: at rest (zeros). A job that is not a profile chain (synchronized motion, homing):
    the underlying set velocity and acceleration held constant (jerk 0)."""
    if job is None:
        return 0.0, 0.0, 0.0, 0.0, 0.0
    if job.kind not in _CHAIN_KINDS or not job.chain:
        v, a = axis.v, axis.a
        return v, v, a, a, 0.0
    ta = max(tau0 + f * t0, 0.0)
    tb = max(tau0 + f * t1, ta)
    vlo = alo = _INF
    vhi = ahi = -_INF
    jmax = 0.0
    off = 0.0
    for prof in job.chain:
        for k, seg in zip(prof.knots, prof.segments, strict=False):
            s0 = off + k.t
            if s0 >= tb:
                break
            s1 = s0 + seg.duration
            lo, hi = max(ta, s0), min(tb, s1)
            if hi < lo:
                continue
            j = k.j
            for tt in (lo - s0, hi - s0):
                v = k.v + tt * (k.a + 0.5 * tt * j)
                a = k.a + tt * j
                vlo, vhi = min(vlo, v), max(vhi, v)
                alo, ahi = min(alo, a), max(ahi, a)
            if j != 0.0:
                tz = -k.a / j
                if lo - s0 < tz < hi - s0:
                    v = k.v + tz * (k.a + 0.5 * tz * j)
                    vlo, vhi = min(vlo, v), max(vhi, v)
                if hi - lo > 1e-12 * (1.0 + abs(hi)):
                    jmax = max(jmax, abs(j))
        off += prof.duration
    if tb >= job.duration:  # past the chain: its end velocity goes on (MoveVelocity)
        ve = job.chain[-1].end.v
        vlo, vhi = min(vlo, ve), max(vhi, ve)
        alo, ahi = min(alo, 0.0), max(ahi, 0.0)
    if vlo == _INF:  # an empty window inside a zero-length chain
        e = job.chain[-1].end
        vlo = vhi = e.v
        alo = ahi = e.a
    return vlo * f, vhi * f, alo * f * f, ahi * f * f, jmax * f * f * f


def headroom_limits(
    axis: Axis,
    env: tuple[float, float, float, float, float],
    caps: tuple[float, float, float, float],
    s: float,
) -> Limits | None:
    """The limits of a superimposed profile moving in direction ``s`` on top of an underlying
    motion with the extrema ``env`` (see :func:`underlying_envelope`), capped by ``caps`` =
    (VelocityDiff, Acceleration, Deceleration, Jerk; inf = no cap). None if the underlying
    motion leaves no usable headroom in the direction of motion, in acceleration or in jerk."""
    cfg = axis.cfg
    vlo, vhi, alo, ahi, jabs = env
    vd, acc, dec, jerk = caps
    up, down = (acc, dec) if s >= 0.0 else (dec, acc)
    v_pos = min(vd, cfg.v_max - vhi)
    v_neg = min(vd, cfg.v_neg + vlo)
    a_pos = min(up, cfg.a_max - ahi)
    a_neg = min(down, cfg.a_neg + alo)
    j = min(jerk, cfg.j_max - jabs) if cfg.j_max != _INF else jerk
    tiny_v = 1e-9 * cfg.v_top
    tiny_a = 1e-9 * cfg.a_top
    v_used = v_pos if s >= 0.0 else v_neg
    if v_used <= tiny_v or a_pos <= tiny_a or a_neg <= tiny_a:
        return None
    if j != _INF and j <= 1e-9 * cfg.j_max:
        return None
    # the side the profile does not use (rest to rest, monotone) still needs a valid limit
    v_pos = max(v_pos, tiny_v)
    v_neg = max(v_neg, tiny_v)
    return Limits(v_max=v_pos, a_max=a_pos, j_max=j, v_min=-v_neg, a_min=-a_neg)


def _fallback_limits(axis: Axis, caps: tuple[float, float, float, float], s: float) -> Limits:
    cfg = axis.cfg
    vd, acc, dec, jerk = caps
    up, down = (acc, dec) if s >= 0.0 else (dec, acc)
    return Limits(
        v_max=min(vd, cfg.v_max),
        a_max=min(up, cfg.a_max),
        j_max=min(jerk, cfg.j_max),
        v_min=-min(vd, cfg.v_neg),
        a_min=-min(down, cfg.a_neg),
    )


def plan_in_headroom(
    axis: Axis,
    job: AxisJob | None,
    tau0: float,
    f: float,
    start: State,
    make: Any,
    caps: tuple[float, float, float, float],
    s: float,
    allow_delay: bool,
) -> tuple[float, Profile, Limits] | None:
    """(delay, profile, limits) of a superimposed profile that keeps the sum within the axis
    limits over its whole duration, or None if there is none.

    ``make(limits)`` plans the profile from ``start``. Candidate start times: now, then (if
    ``allow_delay``: the layer is at rest) every segment boundary of the underlying chain and
    its end. At each, the window [delay, delay + T] grows from the duration with the full caps
    (a lower bound) until a profile planned in the headroom of its window fits into it."""
    full = make(_fallback_limits(axis, caps, s))
    t_min = full.duration
    cands = [0.0]
    if allow_delay and job is not None and job.kind in _CHAIN_KINDS and job.chain and f > 0.0:
        off = 0.0
        marks: list[float] = []
        for prof in job.chain:
            marks.extend(off + k.t for k in prof.knots)
            off += prof.duration
        marks.append(job.duration)
        for m in marks:
            d = (m - tau0) / f
            if d > cands[-1] and len(cands) < _MAX_CANDIDATES:
                cands.append(d)
    for delay in cands:
        t_win = t_min
        for _ in range(_MAX_ITER):
            env = underlying_envelope(axis, job, tau0, f, delay, delay + t_win)
            lim = headroom_limits(axis, env, caps, s)
            if lim is None:
                break
            prof = make(lim)
            if prof.duration <= t_win * (1.0 + 1e-12) + 1e-12:
                return delay, prof, lim
            t_win = prof.duration
    return None


# -- the layer ----
class SuperimposedLayer:
    """The superimposed motion of one axis (``Axis.sup``; mutable, axis-internal).

    ``sp, sv, sa, sj``: its current contribution to the set values; ``up, uv, ua, uj``: the
    underlying set values of the last step; ``lifted``: the contribution is currently taken out
    of the axis' set values (inside the kernel step, between :meth:`lift` and :meth:`apply`).
    """

    __slots__ = (
        "handle",
        "halt",
        "cmd",
        "req",
        "prof",
        "lim",
        "t",
        "delay",
        "end_p",
        "target",
        "origin",
        "moving",
        "sp",
        "sv",
        "sa",
        "sj",
        "up",
        "uv",
        "ua",
        "uj",
        "sum_p",
        "lifted",
        "job",
        "chain",
    )

    def __init__(self, axis: Axis) -> None:
        self.handle: Handle | None = None  # the MC_MoveSuperimposed command running
        self.halt: Handle | None = None  # an MC_HaltSuperimposed braking it
        self.cmd: Command | None = None
        self.req: list[tuple[str, Command, Handle | None]] = []  # submitted, for the kernel
        self.prof: Profile | None = None
        self.lim: Limits | None = None
        self.t = 0.0
        self.delay = 0.0
        self.end_p = 0.0
        self.target = 0.0
        self.origin = 0.0
        self.moving = False  # a profile runs (or waits for headroom)
        self.sp = self.sv = self.sa = self.sj = 0.0
        self.up, self.uv, self.ua, self.uj = axis.p, axis.v, axis.a, axis.j
        self.sum_p = axis.p
        self.lifted = False
        self.job: Any = None
        self.chain: Any = None

    @property
    def done(self) -> bool:
        """No superimposed motion (a constant offset at most) and nothing requested."""
        return not self.moving and not self.req

    @property
    def covered(self) -> float:
        """CoveredDistance of the running command: the superimposed position since its start."""
        return self.sp - self.origin

    # -- the kernel step ----
    def lift(self, axis: Axis) -> None:
        """Kernel step start: the set values become the underlying ones (exactly those of the
        last step; shifted with the axis if MC_SetPosition moved it meanwhile)."""
        axis.p = self.up + (axis.p - self.sum_p)
        axis.v, axis.a, axis.j = self.uv, self.ua, self.uj
        self.lifted = True

    def apply(self, axis: Axis, dt: float) -> None:
        """After the underlying job was sampled: serve requests, advance, add the contribution."""
        self.t += dt
        job = axis.mq.active
        if (
            self.moving
            and self.prof is not None
            and job is not None
            and (job is not self.job or job.chain is not self.chain)
        ):
            # another underlying motion took over (the end of the old one, at rest, was part
            # of the headroom already)
            self._replan(axis, dt, job)
        if self.req:
            self._serve(axis, dt, job)
        if self.moving:
            self._sample(axis)
        self.up, self.uv, self.ua, self.uj = axis.p, axis.v, axis.a, axis.j
        p = axis.p = self.up + self.sp
        axis.v = self.uv + self.sv
        axis.a = self.ua + self.sa
        axis.j = self.uj + self.sj
        self.sum_p = p
        self.lifted = False
        if not self.moving and not self.req:
            if job is None:
                self._fold_idle(axis)
            elif job.kind == "velocity":  # never ends: the offset shifts the job (not exact)
                job.shift += self.sp
                axis.sup = None

    def _fold_idle(self, axis: Axis) -> None:
        """Done and no underlying job: the offset is part of the set position now."""
        axis.sup = None
        mq = axis.mq
        if axis.state is S.DISCRETE_MOTION and not mq.queue and not mq.inbox:
            axis.state = next_state(Event.DISCRETE_DONE, S.DISCRETE_MOTION)  # T9

    def fold_into_end(self, axis: Axis) -> None:
        """The underlying job ended (set values = its exact end state) while the layer holds a
        constant offset: the offset becomes part of the set position (exactly end + distance).

        Queued relative / additive moves count from the target before them, which moved by the
        offset: their targets move too (absolute targets stay where they are)."""
        d = self.sp
        axis.p += d
        act = axis.mq.active
        shifted = {act.target} if act is not None and act.target is not None else set()
        for q in axis.mq.queue:
            if q.kind in ("relative", "additive") and q.target is not None:
                shifted.add(q.target)
                q.target += d
                if q.base is not None:
                    q.base += d
        if axis.last_target is not None and axis.last_target in shifted:
            axis.last_target += d
        axis.sup = None
        self.lifted = False

    def end(
        self,
        axis: Axis,
        status: Status,
        error_id: ErrorID = ErrorID.OK,
        keep_requests: bool = False,
    ) -> None:
        """Aborted (MC_Stop, an aborting command, an axis error, power off): the contribution
        folds into the set values (if taken out), the layer goes, its commands end.

        ``keep_requests`` (an aborting command started): MC_MoveSuperimposed commands submitted
        in this cycle but not yet started stay and run on top of the new command (a fresh layer
        from the new set state)."""
        if self.lifted:
            axis.p += self.sp
            axis.v += self.sv
            axis.a += self.sa
            axis.j += self.sj
            self.lifted = False
        axis.sup = None
        for h in (self.handle, self.halt):
            if h is not None:
                h._finish(status, error_id)
        self.handle = self.halt = None
        reqs = [r for r in self.req if r[0] == "move"] if keep_requests else []
        for _, _, h in self.req:
            if h is not None and not reqs:
                h._finish(status, error_id)
        self.req = []
        if reqs:
            fresh = SuperimposedLayer(axis)
            fresh.req = reqs
            fresh.lifted = True  # inside the kernel step: the set values are the underlying
            axis.sup = fresh

    def fold(self, axis: Axis) -> tuple[float, float, float, float]:
        """An aborting command starts: the contribution into the set values, the layer detached
        (its commands end only when the new command started: :meth:`end`). Returns the set
        values before, for :meth:`unfold` if the new command cannot start."""
        before = (axis.p, axis.v, axis.a, axis.j)
        if self.lifted:
            axis.p += self.sp
            axis.v += self.sv
            axis.a += self.sa
            axis.j += self.sj
        axis.sup = None
        return before

    def unfold(self, axis: Axis, before: tuple[float, float, float, float]) -> None:
        """Undo :meth:`fold` (the aborting command could not be planned)."""
        axis.p, axis.v, axis.a, axis.j = before
        axis.sup = self

    # -- planning ----
    def _tau0(self, axis: Axis, job: AxisJob | None, dt: float) -> tuple[float, float]:
        if job is None:
            return 0.0, 1.0
        return job.tau - dt, 1.0  # trajectory time is real time (MC_SetOverride re-plans)

    def _caps(self, cmd: Command, axis: Axis) -> tuple[float, float, float, float]:
        return (
            cmd.velocity or _INF,
            cmd.acceleration or _INF,
            cmd.deceleration or _INF,
            cmd.jerk or axis.cfg.j_max,
        )

    def _plan(
        self, axis: Axis, job: AxisJob | None, dt: float, kind: str, cmd: Command
    ) -> tuple[float, Profile, Limits]:
        """Plan from the contribution at the end of the last step (layer time 0 = then)."""
        start = State(self.sp, self.sv, self.sa)
        tau0, f = self._tau0(axis, job, dt)
        caps = self._caps(cmd, axis)
        at_rest = self.sv == 0.0 and self.sa == 0.0
        if kind == "move":
            goal = State(self.target, 0.0, 0.0)
            s = 1.0 if self.target >= self.sp else -1.0

            def make(lim: Limits) -> Profile:
                return guarded(plan, start, goal, lim)

        else:
            s = 1.0 if self.sv >= 0.0 else -1.0  # the direction it moves while braking

            def make(lim: Limits) -> Profile:
                return guarded(plan_velocity, start, 0.0, lim)

        got = plan_in_headroom(axis, job, tau0, f, start, make, caps, s, at_rest)
        if got is None:
            if at_rest and kind == "move":
                raise PlanningError(
                    "no headroom: the underlying motion leaves no velocity, acceleration or "
                    "jerk reserve for the superimposed move (it runs at the axis' limits)"
                )
            lim = _fallback_limits(axis, caps, s)
            return 0.0, make(lim), lim
        return got

    def _start_profile(
        self, got: tuple[float, Profile, Limits], job: AxisJob | None, dt: float
    ) -> None:
        """Run ``got`` from layer time 0 = the end of the last step (this step samples dt)."""
        self.delay, self.prof, self.lim = got
        self.t = dt
        self.moving = True
        self.job = job
        self.chain = job.chain if job is not None else None

    def _serve(self, axis: Axis, dt: float, job: AxisJob | None) -> None:
        reqs, self.req = self.req, []
        for kind, cmd, h in reqs:
            if h is not None and h.terminal:
                continue
            if kind == "halt":
                self._serve_halt(axis, dt, job, cmd, h)
                continue
            # a new MoveSuperimposed (h) or a ContinuousUpdate of the running one (h None)
            if h is None:
                if self.handle is None or self.cmd is None or self.handle.terminal:
                    continue
                target = self.origin + cmd.position
                origin = self.origin
            else:
                target = self.sp + cmd.position
                origin = self.sp
            old_target, self.target = self.target, target
            try:
                got = self._plan(axis, job, dt, "move", cmd)
            except PlanningError as exc:
                self.target = old_target
                hh = h if h is not None else self.handle
                if hh is not None:
                    hh._finish(Status.ERROR, ErrorID.PLANNING_FAILED, f"planner: {exc}")
                if h is None and self.handle is not None:
                    self.handle = None
                self._after_refusal(axis)
                continue
            if h is not None:
                if self.handle is not None:
                    self.handle._finish(Status.ABORTED)  # a second one aborts only the first
                if self.halt is not None:
                    self.halt._finish(Status.ABORTED)
                    self.halt = None
                self.handle = h
                h.status = Status.ACTIVE
            self.cmd = cmd
            self.origin = origin
            self.end_p = target
            self._start_profile(got, job, dt)

    def _serve_halt(
        self, axis: Axis, dt: float, job: AxisJob | None, cmd: Command, h: Handle | None
    ) -> None:
        assert h is not None
        if not self.moving:  # nothing superimposed moves: done at once
            h._finish(Status.DONE)
            return
        if self.handle is not None:
            self.handle._finish(Status.ABORTED)
            self.handle = None
        if self.halt is not None:
            self.halt._finish(Status.ABORTED)
        self.halt = h
        h.status = Status.ACTIVE
        if self.sv == 0.0 and self.sa == 0.0:  # waiting for headroom, or at rest already
            self.moving = False
            self.prof = None
            self.sj = 0.0
            h._finish(Status.DONE)
            self.halt = None
            return
        try:
            got = self._plan(axis, job, dt, "halt", cmd)
        except PlanningError as exc:  # (the fallback limits always plan) keep moving
            h._finish(Status.ERROR, ErrorID.PLANNING_FAILED, f"planner: {exc}")
            self.halt = None
            return
        self.cmd = cmd
        self._start_profile(got, job, dt)
        self.end_p = got[1].end.p

    def _replan(self, axis: Axis, dt: float, job: AxisJob | None) -> None:
        cmd = self.cmd
        if cmd is None:
            return
        kind = "halt" if self.halt is not None else "move"
        try:
            got = self._plan(axis, job, dt, kind, cmd)
        except PlanningError:
            self.job, self.chain = job, job.chain if job is not None else None
            return  # (only a move at rest can fail: it keeps waiting for the old window)
        self._start_profile(got, job, dt)
        self.end_p = self.target if kind == "move" else got[1].end.p

    def _after_refusal(self, axis: Axis) -> None:
        """A superimposed move could not be planned: stop the layer if nothing else runs."""
        if self.handle is None and self.halt is None and not self.req:
            self.moving = False
            self.prof = None
            self.sv = self.sa = self.sj = 0.0

    def _sample(self, axis: Axis) -> None:
        prof = self.prof
        if prof is None:
            self.moving = False
            return
        tl = self.t - self.delay
        if tl <= 0.0:
            self.sj = 0.0
            return
        if tl >= prof.duration:
            # at rest: exactly the target of a move (the profile's end is integrated)
            self.sp = self.end_p
            self.sv = self.sa = self.sj = 0.0
            self.moving = False
            self.prof = None
            if self.halt is not None:
                self.halt._finish(Status.DONE)
                self.halt = None
            elif self.handle is not None:
                self.handle._finish(Status.DONE)
            self.handle = None
            return
        self.sp, self.sv, self.sa, self.sj = prof.at(tl)


def submit_superimposed(
    axis: Axis, kind: str, cmd: Command, handle: Handle | None = None
) -> Handle:
    """Program phase: MC_MoveSuperimposed (``kind`` "move"), its ContinuousUpdate ("update",
    with the running command's ``handle``) or MC_HaltSuperimposed ("halt"). Checked here (state,
    group, software limits); planned in this cycle's kernel step."""
    h = Handle("superimposed" if kind != "halt" else "halt_superimposed")
    group = axis.group
    if group is not None and group.enabled:
        h._finish(
            Status.ERROR,
            ErrorID.AXIS_IN_GROUP,
            f"axis {axis.name!r} belongs to the enabled group {group.name!r}",
        )
        return h
    state = axis.state
    if kind == "halt":
        if state in (S.DISABLED, S.ERROR_STOP):
            h._finish(Status.ERROR, ErrorID.for_state(state))
            return h
        sup = axis.sup
        if sup is None:
            h._finish(Status.DONE)  # nothing superimposed: done at once
            return h
        sup.req.append(("halt", cmd, h))
        return h
    if state not in _ACCEPTED:
        h._finish(Status.ERROR, ErrorID.for_state(state))
        return h
    sup = axis.sup
    if kind == "update":
        if sup is not None and handle is not None and sup.handle is handle:
            sup.req.append(("update", cmd, None))
        return handle if handle is not None else h
    err = _sw_refused(axis, cmd.position)
    if err:
        h._finish(Status.ERROR, ErrorID.TARGET_OUTSIDE_SW_LIMITS, err)
        return h
    if sup is None:
        sup = axis.sup = SuperimposedLayer(axis)
    sup.req.append(("move", cmd, h))
    if state is S.STANDSTILL:
        axis.state = next_state(Event.DISCRETE, state)  # T8: like MC_MoveRelative
    return h


def _sw_refused(axis: Axis, distance: float) -> str:
    """Why the end position (the underlying target + the superimposed target) lies beyond a
    software limit (refused at Execute, as a move's target), "" if it does not."""
    cfg = axis.cfg
    if cfg.modulo is not None or (cfg.sw_limit_pos is None and cfg.sw_limit_neg is None):
        return ""
    job = axis.mq.active
    sup = axis.sup
    base = axis.p
    if job is not None and job.target is not None and job.cmd.is_move:
        base = job.target
        if sup is not None:
            base += sup.sp
    elif job is not None and job.kind == "velocity":
        return ""  # a velocity move is braked at the limit anyway
    target = base + distance
    hi, lo = cfg.sw_limit_pos, cfg.sw_limit_neg
    if (hi is not None and target > hi and target > axis.p) or (
        lo is not None and target < lo and target < axis.p
    ):
        return f"end position {target:.9g} outside the software limits [{lo}, {hi}]"
    return ""


# -- the FBs ----
class _SuperimposedFB(InputChecks, MotionFB):
    """No Active output: the superimposed FBs run in parallel to the FB controlling the axis
    (spec FB table: Busy, Done, CommandAborted, Error, ErrorID), so A4 (one Active FB per axis)
    holds without exceptions."""

    OUTPUTS = ("busy", "done", "command_aborted", "error")

    def _busy_outputs(self, h: Handle) -> None:
        self.active = False  # not an output of these FBs

    def _in_deceleration(self, axis: Any) -> float:
        return _decel(self, axis)

    def _in_jerk(self, axis: Any) -> float:
        return _jerk(self, axis)


class MC_MoveSuperimposed(_SuperimposedFB):
    """A relative move added to whatever the axis does (PLCopen MC_MoveSuperimposed).

    ``distance`` is added to the ongoing motion without interrupting it; the underlying FB
    finishes in its own time and ends at its target + ``distance`` (exactly). From Standstill it
    acts like MC_MoveRelative (DiscreteMotion, then Standstill). ``velocity_diff``,
    ``acceleration``, ``deceleration`` and ``jerk`` cap the superimposed profile (0: no cap);
    the profile is planned in the headroom the underlying motion leaves, so the sum stays within
    the axis' limits (see the module docstring). ``covered_distance``: the superimposed distance
    covered so far. Another aborting command, MC_Stop or an axis error abort it (CommandAborted);
    buffered commands leave it alone; a second MC_MoveSuperimposed aborts only the first.
    ContinuousUpdate (latched at Execute): a changed distance / dynamics re-plans the running
    superimposed profile from its current state (the distance still counts from its start).
    Errors: the end position beyond a software limit (TARGET_OUTSIDE_SW_LIMITS, at Execute); an
    underlying motion that never leaves headroom in the direction of the correction (e.g. a
    velocity move at the axis' speed limit): PLANNING_FAILED, ``error_text`` says why.
    No Active output (it runs beside the FB that controls the axis).
    """

    INPUTS = (
        "axis",
        "execute",
        "continuous_update",
        "distance",
        "velocity_diff",
        "acceleration",
        "deceleration",
        "jerk",
    )
    _CU = ("distance", "velocity_diff", "acceleration", "deceleration", "jerk")

    def __init__(self, name: str | None = None, **inputs: Any) -> None:
        self.continuous_update = False
        self.distance = 0.0
        self.velocity_diff = 0.0
        self.acceleration = 0.0
        self.deceleration = 0.0
        self.jerk = 0.0
        self.covered_distance = 0.0
        self._cu = False
        self._cu_values: tuple[Any, ...] = ()
        super().__init__(name, **inputs)

    def _in_distance(self, axis: Any) -> float:
        return check_number(
            "distance", self.distance, ErrorID.INVALID_DISTANCE, -POSITION_MAX, POSITION_MAX
        )

    def _in_velocity_diff(self, axis: Any) -> float:
        v_top = axis.cfg.v_top
        return check_dynamic(
            "velocity_diff",
            self.velocity_diff,
            ErrorID.INVALID_VELOCITY,
            axis.cfg.velocity_range()[0],
            v_top,
        )

    def _in_acceleration(self, axis: Any) -> float:
        lo, hi = axis.cfg.acceleration_range()
        return check_dynamic(
            "acceleration", self.acceleration, ErrorID.INVALID_ACCELERATION, lo, hi
        )

    def _command(self, axis: Any) -> Command:
        d = self._in_distance(axis)
        vd = self._in_velocity_diff(axis)
        return Command(
            kind="superimposed",
            position=d,
            velocity=vd,
            acceleration=self._in_acceleration(axis),
            deceleration=self._in_deceleration(axis),
            jerk=self._in_jerk(axis),
        )

    def _start(self, axis: Axis) -> Handle:
        self._cu = False
        self.covered_distance = 0.0
        cmd = self._command(axis)
        self._cu = bool(self.continuous_update)
        self._cu_values = tuple(getattr(self, n) for n in self._CU)
        return submit_superimposed(axis, "move", cmd)

    def _busy_outputs(self, h: Handle) -> None:
        self.active = False
        axis = self.axis
        if axis is None:
            return
        sup = axis.sup
        if sup is not None and sup.handle is h:
            self.covered_distance = sup.covered
        if self._cu:
            if not self.continuous_update:
                self._cu = False
                return
            values = tuple(getattr(self, n) for n in self._CU)
            if values != self._cu_values:
                self._cu_values = values
                try:
                    cmd = self._command(axis)
                except InputError as exc:
                    self.error_text = str(exc)
                    return  # the running superimposed move keeps its last valid inputs
                submit_superimposed(axis, "update", cmd, h)

    def _terminal_outputs(self, h: Handle) -> None:
        if h.status is Status.DONE:
            self.covered_distance = float(self.distance)


class MC_HaltSuperimposed(_SuperimposedFB):
    """Brakes the superimposed motion of the axis to rest (jerk-limited; ``deceleration`` /
    ``jerk`` cap the brake, 0: the axis' limits in the headroom the underlying motion leaves);
    the underlying motion continues and the superimposed offset reached stays. Done when the
    superimposed motion is at rest (at once if there is none); the running
    MC_MoveSuperimposed shows CommandAborted. No state change; Error in Disabled / ErrorStop."""

    INPUTS = ("axis", "execute", "deceleration", "jerk")

    def __init__(self, name: str | None = None, **inputs: Any) -> None:
        self.deceleration = 0.0
        self.jerk = 0.0
        super().__init__(name, **inputs)

    def _start(self, axis: Axis) -> Handle:
        dec, jerk = self._in_deceleration(axis), self._in_jerk(axis)
        cmd = Command(kind="halt_superimposed", acceleration=dec, deceleration=dec, jerk=jerk)
        return submit_superimposed(axis, "halt", cmd)
