"""Checks that a planned :class:`~motionplc.planning.Profile` is a valid time-optimal-style profile.

:func:`profile_problems` returns a list of human-readable problems (empty when the profile is
fine) so that sweeps can collect failures; :func:`check_profile` asserts that list is empty.

Tolerances (absolute unless stated):

* end state vs target: p within ``P_TOL * max(1, |p|)`` (``P_TOL`` = 1e-8), |p| being the
  largest position magnitude of start, target and profile (``prof.extrema()``): a profile
  that swings 1e8 away cannot end closer than an ulp of 1e8, so a purely absolute 1e-8 is
  unattainable there; for the usual |p| <= 1 it is absolute.
  v within ``V_TOL`` = 1e-8, a within ``A_TOL`` = 1e-10 (absolute);
* velocity / acceleration limits: ``LIMIT_TOL`` = 1e-9, checked with ``prof.extrema()`` over
  the whole profile when the start is inside the limits (see :func:`state_is_inside`), and
  from the first knot that is inside the limits on when it is not;
* segment jerk in {-j_max, 0, +j_max} within ``JERK_RTOL * j_max`` (1e-12) for finite j_max,
  exactly 0 for infinite j_max; with ``jerk_within=True`` (synchronised axes, whose jerk limit
  was lowered) only |jerk| <= j_max * (1 + ``JERK_RTOL``);
* continuity at every joint: each segment is integrated from its knot and compared with the
  next knot (and the last one with ``prof.end``) within ``JOINT_TOL * max(1, |value|)``
  (1e-9); p always, v unless j_max and a_max are both infinite, a when j_max is finite.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

from motionplc.planning import Limits, Profile, State
from tests.planning._cases import Case, start_is_inside

P_TOL = 1e-8
V_TOL = 1e-8
A_TOL = 1e-10
LIMIT_TOL = 1e-9
JERK_RTOL = 1e-12
JOINT_TOL = 1e-9
START_TOL = 1e-12


def lims(lim: Limits) -> tuple[float, float, float, float, float]:
    """(v_min, v_max, a_min, a_max, j_max) as floats."""
    v_min = -lim.v_max if lim.v_min is None else lim.v_min
    a_min = -lim.a_max if lim.a_min is None else lim.a_min
    return float(v_min), float(lim.v_max), float(a_min), float(lim.a_max), float(lim.j_max)


def state_is_inside(state: State, lim: Limits, tol: float = 0.0) -> bool:
    """Start inside the limits: v_min <= v <= v_max, a_min <= a <= a_max and
    ``v + a*|a|/(2 j_max)`` (the velocity where a braking jerk brings a to 0) in [v_min, v_max].
    """
    v_min, v_max, a_min, a_max, j_max = lims(lim)
    return start_is_inside(
        state.v, state.a, v_min - tol, v_max + tol, a_min - tol, a_max + tol, j_max
    )


def _integrate(p: float, v: float, a: float, j: float, t: float) -> tuple[float, float, float]:
    return (
        p + t * (v + t * (0.5 * a + t * j / 6.0)),
        v + t * (a + 0.5 * t * j),
        a + t * j,
    )


def _close(x: float, y: float, tol: float) -> bool:
    return abs(x - y) <= tol * max(1.0, abs(x), abs(y))


def own_extrema(
    prof: Profile, first: int = 0
) -> tuple[tuple[float, float], tuple[float, float]] | None:
    """((v_min, v_max), (a_min, a_max)) over segments ``first..`` computed from the knots.

    Independent of ``Profile.extrema`` (used to cross-check it). ``None`` if no segment.
    """
    knots = prof.knots
    segs = prof.segments
    if first >= len(segs):
        return None
    vs: list[float] = [prof.end.v]  # the end may follow a jump (infinite jerk/acceleration)
    as_: list[float] = [prof.end.a]
    for k, s in zip(knots[first:], segs[first:], strict=True):
        _, v1, a1 = _integrate(k.p, k.v, k.a, s.jerk, s.duration)
        vs += [k.v, v1]
        as_ += [k.a, a1]
        if s.jerk != 0.0:
            tz = -k.a / s.jerk
            if 0.0 < tz < s.duration:
                vs.append(k.v + tz * (k.a + 0.5 * tz * s.jerk))
    return (min(vs), max(vs)), (min(as_), max(as_))


def position_scale(start: State, target: State, p_lo: float, p_hi: float) -> float:
    """max(1, |p|) over start, target and every position the profile passes through."""
    return max(1.0, abs(start.p), abs(target.p), abs(p_lo), abs(p_hi))


def _finite(*xs: float) -> bool:
    return all(math.isfinite(x) for x in xs)


def profile_problems(
    prof: Profile,
    start: State,
    target: State,
    lim: Limits,
    *,
    start_inside: bool = True,
    check_target_p: bool = True,
    check_limits: bool = True,
    jerk_within: bool = False,
) -> list[str]:
    """Everything wrong with ``prof`` as a plan from ``start`` to ``target`` under ``lim``.

    ``check_target_p=False`` skips the end position (velocity interface);
    ``check_limits=False`` skips the velocity/acceleration limits (velocity interface with a
    target that cannot be reached inside them, which ``plan_velocity`` accepts);
    ``jerk_within=True`` accepts any jerk of magnitude up to j_max (synchronised axes).
    """
    problems: list[str] = []
    v_min, v_max, a_min, a_max, j_max = lims(lim)
    j_inf = math.isinf(j_max)
    a_cont = not j_inf  # acceleration continuous
    v_cont = not (j_inf and math.isinf(a_max))  # velocity continuous

    dur = prof.duration
    if not isinstance(dur, float) or not math.isfinite(dur) or dur < 0.0:
        return [f"duration is {dur!r}"]

    segs: Sequence = prof.segments
    knots: Sequence = prof.knots
    if len(knots) != len(segs):
        problems.append(f"{len(knots)} knots for {len(segs)} segments")
        return problems

    # -- segments: durations, jerks, total -------------------------------------------------
    total = 0.0
    for i, s in enumerate(segs):
        if not _finite(s.duration, s.jerk):
            problems.append(f"segment {i} is not finite: {s}")
            continue
        if not s.duration > 0.0:
            problems.append(f"segment {i} has non-positive duration {s.duration!r}")
        total += s.duration
        if j_inf:
            if s.jerk != 0.0:
                problems.append(f"segment {i} jerk {s.jerk!r} != 0 with infinite j_max")
        elif jerk_within:
            if abs(s.jerk) > j_max * (1.0 + JERK_RTOL):
                problems.append(f"segment {i} jerk {s.jerk!r} beyond j_max={j_max!r}")
        elif min(abs(s.jerk - j_max), abs(s.jerk), abs(s.jerk + j_max)) > JERK_RTOL * j_max:
            problems.append(f"segment {i} jerk {s.jerk!r} not in {{-j_max, 0, +j_max}}")
    if segs and not _close(total, dur, 1e-12):
        problems.append(f"segment durations sum to {total!r}, duration is {dur!r}")

    # -- knots: times, finiteness, continuity ---------------------------------------------
    end = prof.end
    if not _finite(end.p, end.v, end.a):
        problems.append(f"end state is not finite: {end}")
    t_expected = 0.0
    for i, (k, s) in enumerate(zip(knots, segs, strict=True)):
        if not _finite(k.t, k.p, k.v, k.a, k.j):
            problems.append(f"knot {i} is not finite: {k}")
            return problems
        if not _close(k.t, t_expected, 1e-12):
            problems.append(f"knot {i} at t={k.t!r}, expected {t_expected!r}")
        if k.j != s.jerk:
            problems.append(f"knot {i} jerk {k.j!r} != segment jerk {s.jerk!r}")
        t_expected += s.duration
        p1, v1, a1 = _integrate(k.p, k.v, k.a, s.jerk, s.duration)
        nxt = knots[i + 1] if i + 1 < len(knots) else end
        where = f"joint after segment {i}" if i + 1 < len(knots) else "end"
        if not _close(p1, nxt.p, JOINT_TOL):
            problems.append(f"p jumps at {where}: {p1!r} -> {nxt.p!r}")
        if v_cont and not _close(v1, nxt.v, JOINT_TOL):
            problems.append(f"v jumps at {where}: {v1!r} -> {nxt.v!r}")
        if a_cont and not _close(a1, nxt.a, JOINT_TOL):
            problems.append(f"a jumps at {where}: {a1!r} -> {nxt.a!r}")

    # -- start: the first knot is the start state (up to allowed jumps) -------------------
    first = knots[0] if knots else end
    if not _close(first.p, start.p, START_TOL):
        problems.append(f"profile starts at p={first.p!r}, start.p={start.p!r}")
    if v_cont and not _close(first.v, start.v, START_TOL):
        problems.append(f"profile starts at v={first.v!r}, start.v={start.v!r}")
    if a_cont and not _close(first.a, start.a, START_TOL):
        problems.append(f"profile starts at a={first.a!r}, start.a={start.a!r}")

    # -- end state vs target ----------------------------------------------------------------
    (p_lo, p_hi), (v_lo, v_hi), _ = prof.extrema()
    p_scale = position_scale(start, target, p_lo, p_hi)
    if check_target_p and not abs(end.p - target.p) <= P_TOL * p_scale:
        problems.append(f"end p={end.p!r} != target p={target.p!r} (err {end.p - target.p:.3g})")
    # (plus the rounding of double arithmetic on the largest velocity of the profile: a brake
    # from far outside the limits can swing v by 1e7 m/s and back)
    if not abs(end.v - target.v) <= V_TOL + 1e-14 * max(abs(v_lo), abs(v_hi)):
        problems.append(f"end v={end.v!r} != target v={target.v!r} (err {end.v - target.v:.3g})")
    if not abs(end.a - target.a) <= A_TOL:
        problems.append(f"end a={end.a!r} != target a={target.a!r} (err {end.a - target.a:.3g})")

    # -- limits --------------------------------------------------------------------------
    if not check_limits:
        pass
    elif start_inside:
        (_, _), (pv_lo, pv_hi), (pa_lo, pa_hi) = prof.extrema()
        own = own_extrema(prof)
        if own is not None:
            (ov_lo, ov_hi), (oa_lo, oa_hi) = own
            for name, x, y in (
                ("v_min", pv_lo, ov_lo),
                ("v_max", pv_hi, ov_hi),
                ("a_min", pa_lo, oa_lo),
                ("a_max", pa_hi, oa_hi),
            ):
                if not _close(x, y, 1e-9):
                    problems.append(f"Profile.extrema() {name} {x!r} != recomputed {y!r}")
        problems += _limit_problems(pv_lo, pv_hi, pa_lo, pa_hi, lim, "")
    else:
        # limits hold from the first knot (or the end) that is inside the limits on
        idx = next(
            (
                i
                for i, k in enumerate(knots)
                if state_is_inside(State(k.p, k.v, k.a), lim, LIMIT_TOL)
            ),
            len(knots),
        )
        own = own_extrema(prof, idx)
        if own is not None:
            (ov_lo, ov_hi), (oa_lo, oa_hi) = own
            t_in = knots[idx].t
            problems += _limit_problems(ov_lo, ov_hi, oa_lo, oa_hi, lim, f" after t={t_in!r}")
    return problems


def _limit_problems(
    v_lo: float, v_hi: float, a_lo: float, a_hi: float, lim: Limits, when: str
) -> list[str]:
    v_min, v_max, a_min, a_max, _ = lims(lim)
    out = []
    if v_hi > v_max + LIMIT_TOL:
        out.append(f"v reaches {v_hi!r} > v_max={v_max!r}{when}")
    if v_lo < v_min - LIMIT_TOL:
        out.append(f"v reaches {v_lo!r} < v_min={v_min!r}{when}")
    if a_hi > a_max + LIMIT_TOL:
        out.append(f"a reaches {a_hi!r} > a_max={a_max!r}{when}")
    if a_lo < a_min - LIMIT_TOL:
        out.append(f"a reaches {a_lo!r} < a_min={a_min!r}{when}")
    return out


def describe(start: State, target: State, lim: Limits) -> str:
    """A pasteable ``plan(...)`` call for the inputs."""
    return Case.from_problem(start, target, lim).code()


def check_profile(
    prof: Profile,
    start: State,
    target: State,
    lim: Limits,
    *,
    start_inside: bool = True,
    check_target_p: bool = True,
    check_limits: bool = True,
    jerk_within: bool = False,
) -> None:
    """Assert that ``prof`` is a valid plan from ``start`` to ``target`` (see module docs)."""
    problems = profile_problems(
        prof,
        start,
        target,
        lim,
        start_inside=start_inside,
        check_target_p=check_target_p,
        check_limits=check_limits,
        jerk_within=jerk_within,
    )
    if problems:
        raise AssertionError(
            "invalid profile for\n  "
            + describe(start, target, lim)
            + f"\n  {prof!r}\n  - "
            + "\n  - ".join(problems)
        )
