"""Per-cycle conformance invariants (spec notes section 11, groups A, B, C and H).

Installed by ``Runtime(check_invariants=True)``; raises :class:`InvariantError` (an
``AssertionError``) naming the cycle, the FB or axis and the rule.

* A1-A5: FB output exclusivity (every FB instance that was called with an axis).
* B: Execute/Done timing: terminal outputs are held while Execute is TRUE, reset in the scan
  Execute falls, shown exactly one scan after a pulse; done/error/command_aborted only rise from
  busy (or at the edge that started the command); busy only rises at a rising edge.
* C: the axis state changes only along the diagram's arrows (at most two per cycle: an input
  phase event plus a program/kernel one); set values: v_min <= v <= v_max, a_min <= a <= a_max
  (the axis' own, possibly asymmetric, limits; MC_SetOverride included), no position jump,
  v continuous within a_max * dt (|a_min| * dt downwards), a continuous within j_max * dt for
  finite j_max; zero velocity in Standstill and Disabled. SynchronizedMotion
  slaves are held to the same limits; a locked coupling (InGear / InSync) satisfies its law
  (``sync_job.check_coupling``: slave = law(master seen) to rounding).
* H: tasks of a tick ran in (priority, declaration) order; virtual time t = k * cycle; in
  virtual time without injected overruns all latencies are 0.
* D (the trace cannot lie): every axis' set values, sampled at the cycles of its task, are
  checked by differencing (:class:`SetValueChecker`; rules and tolerances below): the
  differenced positions hold v_min/v_max, a_min/a_max and j_max, position, velocity and
  acceleration agree with each other, and the jerk column holds j_max.

Group D: the differencing rules and their tolerances
----------------------------------------------------
The set values are samples ``p_k, v_k, a_k, j_k`` at times ``t_k`` (the cycles in which the
axis' task ran: the spacing ``h`` is the task period, more after skipped ticks) of one motion
``p(t)``. A motion that holds the limits has ``v = p'`` in ``[v_min, v_max]``, ``a = p''`` in
``[a_min, a_max]`` (``v`` continuous) and, with a finite ``j_max = J``, ``|p'''| <= J`` (``a``
continuous, the jerk piecewise continuous). Then, exactly, with no discretisation allowance:

* D1 ``(p1 - p0) / h`` is the mean of ``v`` over the cycle: in ``[v_min, v_max]``.
* D2 ``2 p[t0, t1, t2]`` (the second divided difference; ``(p2 - 2 p1 + p0) / h^2`` at a
  uniform spacing) is a weighted mean of ``a`` (the linear B-spline on the three samples,
  unit mass): in ``[a_min, a_max]``.
* D3 ``6 p[t0, .., t3]`` (``(p3 - 3 p2 + 3 p1 - p0) / h^3``) is a weighted mean of the jerk
  (the quadratic B-spline): ``|.| <= J``; for finite ``J`` only (without a jerk limit the
  acceleration may step).
* D4 ``(v1 - v0) / h`` is the mean of ``a``: in ``[a_min, a_max]``; ``(a1 - a0) / h`` the mean
  of the jerk: ``|.| <= J``; the jerk column itself: ``|j| <= J``.
* K1 (the position agrees with velocity and acceleration):
  ``E = p1 - p0 - h (v0 + v1) / 2 + h^2 (a1 - a0) / 12`` vanishes on a cubic; on any motion it
  is ``int K(u) j(t1 - u) du`` with the Peano kernel ``K(u) = u^2/2 - h u/2 + h^2/12`` on
  ``[0, h]``, ``int |K| = h^3 / (18 sqrt 3)``: ``|E| <= J h^3 / (18 sqrt 3)`` (= J h^3 / 31.18).
  Without a jerk limit: ``p1 - p0 - h (v0 + v1) / 2 = int (h/2 - s) a(t0 + s) ds``, a kernel of
  zero mean and ``int |.| = h^2/4``, so ``|.| <= (a_max + |a_min|) h^2 / 8``.
* K2 (the velocity agrees with the acceleration; finite ``J``):
  ``v1 - v0 - h (a0 + a1) / 2 = int (h/2 - s) j(t0 + s) ds``, ``|.| <= J h^2 / 4``.
* The jerk column is checked for its range only (D4). It is a point sample of a piecewise
  constant signal: the jerk may switch several times between two samples (phases shorter than
  a cycle are common: short moves, small velocity changes, knots on the sample grid), so no rule
  ties ``j0, j1`` to ``a1 - a0`` exactly (``|a1 - a0 - h (j0 + j1)/2| <= J h`` holds for at most
  one switch per cycle and was broken by correct profiles in the suite). The jerk *limit* is
  verified on the positions (D3) and on the acceleration column (D4), which is what matters.

At 1 kHz and ``J = 40 m/s^3`` K1 allows 1.3e-9 m: a set position that stands still while the
velocity column says 7.7 mm/s misses it by 7.7e-6 m in one cycle. Floating point adds the
rounding of the samples, and nothing else is allowed: a position carries at most ``32 eps``
times its scale, the largest |position| the axis has had since the window started and at least
1 (m or rad: positions are computed from exact values -- knots, centres, radii, angles, a
master's position -- of that size in a few roundings; arcs, blends and couplings included), a
velocity ``32 eps`` times the largest of |v| and the speed limits, an acceleration ``32 eps``
times the largest of |a| and the acceleration limits; the divided differences propagate these
bounds exactly (``8 rho / h^3`` in D3 at a uniform spacing: 5.7e-5 m/s^3 at 1 kHz and a scale of
1 m). The limits get a relative ``1e-9`` on top (the planners' own accuracy, as in
the C rules). The differencing window restarts (no rule spans the break) where the kernel
breaks continuity by design: Disabled, a coordinate shift (MC_SetPosition, homing). No rule is
widened for MC_SetOverride (it re-plans the running move within the limits; its time scaling,
``a = f^2 x'' + f' x'``, needed 4x here before issue 31).

:func:`check_set_values` applies the same rules to a recorded sequence (arrays of one axis'
set values), e.g. a trace read back from a file.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any, NamedTuple

from motionplc.blocks.axis_state import EDGES
from motionplc.blocks.base import EnableFB, ExecuteFB
from motionplc.blocks.enums import AxisState
from motionplc.blocks.sync_job import check_coupling

if TYPE_CHECKING:
    from motionplc.runtime.runtime import Runtime

S = AxisState
_EDGES2 = frozenset(EDGES | {(a, c) for (a, b) in EDGES for (b2, c) in EDGES if b == b2})


class InvariantError(AssertionError):
    """A conformance invariant failed."""


def _fail(cycle: int, who: str, rule: str, detail: str) -> None:
    raise InvariantError(f"cycle {cycle}: {who}: {rule}: {detail}")


# -- D: set values checked by differencing (module docstring, "Group D") ------------------------
_RND = 32.0 * 2.220446049250313e-16  # rounding of one set value, relative to its scale
_RTOL = 1e-9  # relative allowance on a limit (the planners' accuracy)
_K1 = 1.0 / (18.0 * math.sqrt(3.0))  # int |K| / h^3 of the Peano kernel of rule K1


class SetValueLimits(NamedTuple):
    """One axis' limits for group D: ``v_min <= v <= v_max``, ``a_min <= a <= a_max``,
    ``|j| <= j_max`` (``v_min``, ``a_min`` negative; ``j_max`` may be inf)."""

    v_max: float
    v_min: float
    a_max: float
    a_min: float
    j_max: float = math.inf

    @classmethod
    def of(cls, cfg: Any) -> SetValueLimits:
        """The limits of an :class:`~motionplc.blocks.axis.AxisConfig` (asymmetric ones too)."""
        return cls(cfg.v_max, -cfg.v_neg, cfg.a_max, -cfg.a_neg, cfg.j_max)


class SetValueViolation(NamedTuple):
    """A failed group-D rule: the sample index (or cycle), the rule, the value found, the
    bound it had to hold (after the allowances) and a readable detail."""

    index: int
    rule: str
    value: float
    bound: float
    detail: str


def _over(x: float, lo: float, hi: float, e: float) -> float:
    """How far ``x`` lies outside ``[lo - e, hi + e]`` (0.0 inside)."""
    if x > hi + e:
        return x - hi - e
    if x < lo - e:
        return lo - e - x
    return 0.0


class SetValueChecker:
    """Group D for one axis: :meth:`feed` takes one sample of the set values after the other
    and returns the first rule it breaks (None if it holds). :meth:`reset` starts a new window
    (no rule spans it). Stateful, plain floats (it runs in every checked cycle)."""

    __slots__ = ("_a", "_d1", "_d2", "_e1", "_e2", "_j", "_n", "_p", "_scale", "_t", "_v")

    def __init__(self) -> None:
        self.reset()

    def reset(self) -> None:
        self._n = 0  # samples in the window (capped at 4)
        self._t = [0.0, 0.0, 0.0]  # times of the last three samples (oldest first)
        self._p = self._v = self._a = self._j = 0.0  # the last sample
        self._d1 = self._e1 = 0.0  # last first difference (x 1!) and its rounding bound
        self._d2 = self._e2 = 0.0  # last second divided difference (x 2!) and its bound
        self._scale = [0.0, 0.0, 0.0]  # largest |p|, |v|, |a| in the window

    def feed(
        self, t: float, p: float, v: float, a: float, j: float, lim: SetValueLimits, widen: float
    ) -> tuple[str, float, float, str] | None:
        """Check the sample at time ``t`` against the window; ``widen`` (>= 1) scales the limits
        (a running override ramp). Returns the first broken rule as ``(rule, value, bound,
        detail)`` (``bound`` with its allowances), or None."""
        sc = self._scale
        sc[0] = max(sc[0], abs(p))
        sc[1] = max(sc[1], abs(v))
        sc[2] = max(sc[2], abs(a))
        n = self._n
        tt = self._t
        t0, p0, v0, a0 = tt[2], self._p, self._v, self._a
        span2, span3 = t - tt[1], t - tt[0]  # back to the second and third sample before
        self._p, self._v, self._a, self._j = p, v, a, j
        tt[0], tt[1], tt[2] = tt[1], tt[2], t
        self._n = min(n + 1, 4)
        if n == 0:
            return None
        h = t - t0
        # rounding scales: at least 1 (m or rad) for positions, the limits for v and a
        rp = _RND * max(sc[0], 1.0)
        rv = _RND * max(sc[1], lim.v_max, -lim.v_min)
        ra = _RND * max(sc[2], lim.a_max, -lim.a_min)
        # the divided differences (x k!) and their rounding bounds, then the window moves on
        d1 = (p - p0) / h
        e1 = 2.0 * rp / h
        d2 = e2 = d3 = e3 = 0.0
        if n >= 2:
            d2 = 2.0 * (d1 - self._d1) / span2
            e2 = 2.0 * (e1 + self._e1) / span2
            if n >= 3:
                d3 = 3.0 * (d2 - self._d2) / span3
                e3 = 3.0 * (e2 + self._e2) / span3
        self._d1, self._e1, self._d2, self._e2 = d1, e1, d2, e2
        w = widen * (1.0 + _RTOL)
        vmax, vmin, amax, amin, jm = lim
        vmax, vmin, amax, amin, jm = w * vmax, w * vmin, w * amax, w * amin, w * jm
        finite_j = jm < math.inf
        # D1: the mean velocity over the cycle
        if _over(d1, vmin, vmax, e1):
            return "D1 dp/dt", d1, (vmax if d1 > 0 else vmin), f"(p1 - p0)/h = {d1!r}"
        # K1: the position agrees with the velocity and acceleration columns
        if finite_j:
            err = p - p0 - h * (0.5 * (v0 + v)) + h * h * (a - a0) / 12.0
            tol = jm * h * h * h * _K1
        else:
            err = p - p0 - h * (0.5 * (v0 + v))
            tol = (amax - amin) * h * h / 8.0
        tol += 2.0 * rp + 2.0 * h * rv + h * h * ra
        if abs(err) > tol:
            return "K1 p~v,a", err, tol, f"p1 - p0 - h (v0 + v1)/2 + h^2 (a1 - a0)/12 = {err!r}"
        # D4: the velocity and acceleration columns' own differences, the jerk column
        dv = (v - v0) / h
        if _over(dv, amin, amax, 2.0 * rv / h):
            return "D4 dv/dt", dv, (amax if dv > 0 else amin), f"(v1 - v0)/h = {dv!r}"
        if finite_j:
            da = (a - a0) / h
            if _over(da, -jm, jm, 2.0 * ra / h):
                return "D4 da/dt", da, (jm if da > 0 else -jm), f"(a1 - a0)/h = {da!r}"
            if abs(j) > jm:
                return "D4 j", j, (jm if j > 0 else -jm), f"jerk column {j!r}"
            # K2: the velocity agrees with the acceleration
            err = v - v0 - h * (0.5 * (a0 + a))
            tol = jm * h * h / 4.0 + 2.0 * rv + 2.0 * h * ra
            if abs(err) > tol:
                return "K2 v~a", err, tol, f"v1 - v0 - h (a0 + a1)/2 = {err!r}"
        # D2: twice the second divided difference, a weighted mean of the acceleration
        if n >= 2 and _over(d2, amin, amax, e2):
            return "D2 d2p/dt2", d2, (amax if d2 > 0 else amin), f"2 p[t0,t1,t2] = {d2!r}"
        # D3: six times the third divided difference, a weighted mean of the jerk
        if n >= 3 and finite_j and _over(d3, -jm, jm, e3):
            return "D3 d3p/dt3", d3, (jm if d3 > 0 else -jm), f"6 p[t0..t3] = {d3!r}"
        return None


def check_set_values(
    t: Sequence[float],
    p: Sequence[float],
    v: Sequence[float],
    a: Sequence[float],
    j: Sequence[float],
    limits: SetValueLimits,
    *,
    first: bool = False,
) -> list[SetValueViolation]:
    """Group D on a recorded sequence of one axis' set values (sample times ``t`` increasing,
    e.g. the columns of a trace): every sample that breaks a rule (``first``: only the first
    one). The window runs over the whole sequence: cut it where continuity ends by design
    (power off, a coordinate shift)."""
    n = len(t)
    if not (len(p) == len(v) == len(a) == len(j) == n):
        raise ValueError("t, p, v, a, j must have the same length")
    chk = SetValueChecker()
    out: list[SetValueViolation] = []
    for k in range(n):
        bad = chk.feed(float(t[k]), float(p[k]), float(v[k]), float(a[k]), float(j[k]), limits, 1.0)
        if bad is not None:
            rule, value, bound, detail = bad
            out.append(SetValueViolation(k, rule, value, bound, detail))
            if first:
                break
    return out


def describe(rule: str, value: float, bound: float, detail: str) -> str:
    """One line for a broken group-D rule: the rule, the value, the bound and the ratio."""
    ratio = abs(value / bound) if bound else math.inf
    return f"{rule}: {detail}, bound {bound!r} ({ratio:.4g}x)"


class InvariantChecker:
    """Stateful per-cycle checker (history per FB and axis)."""

    def __init__(self) -> None:
        self._fb_prev: dict[int, tuple[bool, bool, bool, bool, bool]] = {}
        self._ax_prev: dict[str, tuple[Any, ...]] = {}
        self._periods: dict[str, float] = {}  # axis -> period of its task
        self._tasks: dict[str, Any] | None = None  # axis -> its task (group D)
        # axis -> [its group-D checker, the offset of its window]
        self._diff: dict[str, list[Any]] = {}
        self.cycles_checked = 0

    def __call__(self, rt: Runtime, cycle: int) -> None:
        self.cycles_checked += 1
        self._check_h(rt, cycle)
        for ax in rt.axes.values():
            active = []
            for fb in ax.fbs:
                if isinstance(fb, ExecuteFB):
                    self._check_execute(fb, cycle)
                    if fb.active and not getattr(fb, "PARALLEL", False):
                        active.append(fb.name)  # parallel FBs (phasing) beside the active one
                elif isinstance(fb, EnableFB):
                    valid = fb.valid or getattr(fb, "enabled", False)
                    if valid and fb.error:
                        _fail(cycle, str(fb.name), "A3", "valid and error both TRUE")
            if len(active) > 1:
                _fail(cycle, ax.name, "A4", f"more than one active FB: {active}")
            self._check_axis(rt, ax, cycle)
            self._check_diff(rt, ax, cycle)
            if ax.state is S.SYNCHRONIZED_MOTION and ax.active is not None and ax.active.sync:
                why = check_coupling(ax)  # InGear / InSync: the coupling law holds
                if why is not None:
                    _fail(cycle, ax.name, "C-sync", why)
        for g in getattr(rt, "groups", {}).values():
            for fb in g.fbs:
                if isinstance(fb, ExecuteFB):
                    self._check_execute(fb, cycle)
                elif isinstance(fb, EnableFB):
                    valid = fb.valid or getattr(fb, "enabled", False)
                    if valid and fb.error:
                        _fail(cycle, str(fb.name), "A3", "valid and error both TRUE")

    # -- A and B -----------------------------------------------------------------------------
    def _check_execute(self, fb: ExecuteFB, cycle: int) -> None:
        name = str(fb.name)
        ex = bool(fb.execute)
        busy, done, err, ab = fb.busy, fb.done, fb.error, fb.command_aborted
        n = busy + done + err + ab
        if ex and n != 1:
            _fail(cycle, name, "A1", f"execute TRUE and {n} of busy/done/error/aborted TRUE")
        if not ex and n > 1:
            _fail(cycle, name, "A1", f"execute FALSE and {n} of busy/done/error/aborted TRUE")
        if fb.active + done + err + ab > 1:
            _fail(cycle, name, "A2", "more than one of active/done/error/command_aborted")
        if done and err:
            _fail(cycle, name, "A5", "done and error")
        if err and getattr(fb, "in_velocity", False):
            _fail(cycle, name, "A5", "in_velocity and error")
        prev = self._fb_prev.get(id(fb))
        self._fb_prev[id(fb)] = (ex, busy, done, err, ab)
        if prev is None:
            return
        pex, pbusy, pdone, perr, pab = prev
        rising = ex and not pex
        for label, was, now in (("done", pdone, done), ("error", perr, err), ("aborted", pab, ab)):
            if was and now and not ex and not rising:
                _fail(cycle, name, "B1/B2", f"{label} still TRUE with execute FALSE")
            if now and not was and not (pbusy or rising):
                _fail(cycle, name, "B", f"{label} rose without busy or a rising edge")
        if busy and not pbusy and not rising:
            _fail(cycle, name, "B", "busy rose without a rising edge of execute")

    # -- C -----------------------------------------------------------------------------------
    def _period(self, rt: Runtime, ax: Any) -> float:
        period = self._periods.get(ax.name)
        if period is None:
            period = next((t.period for t in rt.tasks if t.name == ax.task_name), rt.cycle)
            self._periods[ax.name] = period
        return period

    def _check_axis(self, rt: Runtime, ax: Any, cycle: int) -> None:
        # the system limits: a move started before MC_WriteParameter lowered the applied
        # (*Appl) ones keeps its plan (as the vendors do)
        cfg = getattr(ax, "cfg_system", ax.cfg)
        state = ax.state
        cur = (state, ax.p, ax.v, ax.a, ax.offset, cycle)
        prev = self._ax_prev.get(ax.name)
        self._ax_prev[ax.name] = cur
        who = f"axis {ax.name}"
        v_neg, a_neg = cfg.v_neg, cfg.a_neg  # |v_min|, |a_min| (v_max, a_max if symmetric)
        tol_v = 1e-9 * min(cfg.v_max, v_neg) + 1e-12
        if state in (S.STANDSTILL, S.DISABLED) and abs(ax.v) > tol_v:
            _fail(cycle, who, "C", f"velocity {ax.v!r} in {state.name}")
        if ax.v > cfg.v_max * (1 + 1e-9) + 1e-12:
            _fail(cycle, who, "C", f"v = {ax.v!r} > v_max {cfg.v_max}")
        if -ax.v > v_neg * (1 + 1e-9) + 1e-12:
            _fail(cycle, who, "C", f"v = {ax.v!r} < v_min {-v_neg}")
        if ax.a > cfg.a_max * (1 + 1e-9) + 1e-9:
            _fail(cycle, who, "C", f"a = {ax.a!r} > a_max {cfg.a_max}")
        if -ax.a > a_neg * (1 + 1e-9) + 1e-9:
            _fail(cycle, who, "C", f"a = {ax.a!r} < a_min {-a_neg}")
        if prev is None:
            return
        pstate, pp, pv, pa, poff, pcycle = prev
        if (pstate, state) not in _EDGES2:
            _fail(cycle, who, "C", f"transition {pstate.name} -> {state.name} not in the diagram")
        if S.DISABLED in (state, pstate) or poff != ax.offset:
            return  # power off / coordinate shift: no continuity requirement
        dt = rt.cycle * (cycle - pcycle)  # ticks may have been skipped after an overrun
        # the set values change once per cycle of the axis' task (its period may be several
        # base ticks): the change since the last check spans up to one task period
        dt = max(dt, self._period(rt, ax))
        amax = max(cfg.a_max, a_neg)
        dp_max = max(abs(pv), abs(ax.v)) * dt + amax * dt * dt + 1e-9 * (1 + abs(ax.p))
        if abs(ax.p - pp) > dp_max:
            _fail(cycle, who, "C", f"position jump {ax.p - pp!r} > {dp_max!r}")
        dv = ax.v - pv
        dv_max = (cfg.a_max if dv >= 0.0 else a_neg) * dt * (1 + 1e-6) + 1e-9
        if abs(dv) > dv_max:
            _fail(cycle, who, "C", f"velocity jump {dv!r} > {dv_max!r}")
        if math.isfinite(cfg.j_max):
            da_max = cfg.j_max * dt * (1 + 1e-6) + 1e-6 * amax
            if abs(ax.a - pa) > da_max:
                _fail(cycle, who, "C", f"acceleration jump {ax.a - pa!r} > {da_max!r}")

    # -- D -----------------------------------------------------------------------------------
    def _check_diff(self, rt: Runtime, ax: Any, cycle: int) -> None:
        tasks = self._tasks
        if tasks is None:
            tasks = self._tasks = {a.name: t for t in rt.tasks for a in t.axes}
        task = tasks.get(ax.name)
        if task is None or task.last_tick != cycle:
            return  # its task did not run in this tick: the set values did not change
        d = self._diff.get(ax.name)
        if d is None:
            d = self._diff[ax.name] = [SetValueChecker(), ax.offset]
        chk: SetValueChecker = d[0]
        if ax.state is S.DISABLED or d[1] != ax.offset:
            chk.reset()  # power off / coordinate shift: a new window
            d[1] = ax.offset
            if ax.state is S.DISABLED:
                return
        cfg = getattr(ax, "cfg_system", ax.cfg)
        bad = chk.feed(cycle * rt.cycle, ax.p, ax.v, ax.a, ax.j, SetValueLimits.of(cfg), 1.0)
        if bad is not None:
            self._d_failed(cycle, f"axis {ax.name}", describe(*bad) + f" [{ax.state.name}]")

    def _d_failed(self, cycle: int, who: str, detail: str) -> None:
        """A group-D rule broke: InvariantError. (tests/conftest.py replaces this for the tests
        it lists in KNOWN_DEFECTS, each naming a kernel defect being fixed elsewhere: it
        records the failures, and fails the test if none occurred.)"""
        _fail(cycle, who, "D", detail)

    # -- H -----------------------------------------------------------------------------------
    def _check_h(self, rt: Runtime, cycle: int) -> None:
        order = [t for t in rt.tasks if t.name in rt.last_due]
        expect = [t.name for t in sorted(order, key=lambda t: t.sort_key)]
        if rt.last_due != expect:
            _fail(cycle, "scheduler", "H2", f"ran {rt.last_due}, expected {expect}")
        if not rt.clock.realtime:
            t = rt.trace.last("t")
            if t != cycle * rt.cycle:
                _fail(cycle, "scheduler", "H1", f"virtual time {t!r} != {cycle} * cycle")
            for task in rt.tasks:
                if task.overruns == 0 and task.lat_max_ns != 0:
                    _fail(cycle, task.name, "H6", "non-zero latency in virtual time")
