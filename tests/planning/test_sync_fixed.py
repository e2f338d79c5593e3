"""Fixed-duration synchronisation in closed form (``motionplc.planning._fixed``, issue 15).

The closed-form families are checked against the seed 004 jerk bisection, kept as the oracle
(``plan_sync(..., method="bisection")`` and ``sync._solve_for(..., "bisection")``):

* per axis, on thousands of random single-axis problems (Ruckig's distributions with
  asymmetric limits, starts outside the limits and on braking boundaries, non-zero target
  velocity and acceleration) and random durations T >= t_min, blocked ones included: whenever
  the bisection finds a profile of duration T the direct method does too, both last T within
  the synchronisation tolerance, end on the target and hold the limits (checked by the
  independent checker of ``_checks``); the share the closed forms answer without the fallback
  is measured and bounded;
* for whole ``plan_sync`` calls: the same synchronised duration with both methods, every check
  of ``sync_problems`` (Ruckig's Synchronization.Time duration as the reference), for 3 and 6
  axes, asymmetric limits and a cycle time;
* hypothesis properties (an axis stretched to a rest-to-rest partner's duration) and the
  closed forms' own algebra (the quartic solver against numpy, rest to rest j = 32 d / T^3).
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
import pytest
from hypothesis import assume, given
from hypothesis import strategies as st

from motionplc.planning import Limits, PlanningError, State, _fixed, plan, plan_sync
from motionplc.planning import sync as sync_mod
from motionplc.planning.profile import Profile
from tests.planning import _strategies as strat
from tests.planning._cases import (
    Case,
    MultiCase,
    RuckigSyncAnswer,
    RuckigSyncOracle,
    case_start_inside,
    case_target_valid,
    draw_case,
    generate_multi_cases,
    iter_cases,
)
from tests.planning._checks import profile_problems
from tests.planning._compare import END_SPREAD_TOL, compare_sync_cases, sync_problems
from tests.planning._strategies import hsettings

SEED = 1515
NO_ANSWER = RuckigSyncAnswer(None, "not compared")
JERK_ONLY = Limits(v_max=10.0, a_max=10.0, j_max=1.0)


@pytest.fixture(scope="module")
def sync_oracle() -> RuckigSyncOracle:
    rk = pytest.importorskip("ruckig")
    return RuckigSyncOracle(rk, 0.001)


def _problems(prof: Profile, case: Case, duration: float) -> list[str]:
    """What is wrong with ``prof`` as a profile of ``case`` lasting ``duration`` (independent
    checker)."""
    probs = profile_problems(
        prof,
        case.start(),
        case.target(),
        case.limits(),
        start_inside=case_start_inside(case),
        jerk_within=True,
    )
    if abs(prof.duration - duration) > 1e-9:
        probs.append(f"duration {prof.duration!r} != {duration!r}")
    return probs


# -- per axis: direct against the bisection oracle -------------------------------------------
def _single_axis_sweep(n: int, seed: int) -> dict[str, int]:
    """``n`` random single-axis problems, each at a random duration T >= t_min (a quarter of
    them inside or at the ends of a blocked interval when the axis has one); asserts the
    agreement and returns the counts."""
    rng = np.random.default_rng(seed)
    stream = iter_cases(
        seed, outside_fraction=0.15, boundary_fraction=0.05, asymmetric_fraction=0.3
    )
    counts = {"solved": 0, "closed": 0, "fallback": 0, "blocked": 0, "neither": 0}
    for _ in range(n):
        case = next(stream)
        ax = sync_mod._make_axis(case.start(), case.target(), case.limits(), False, 0)
        ext = sync_mod._extremals(ax)
        durs = [t for t, _, _ in ext]
        t_min = durs[0]
        if len(durs) >= 3 and rng.random() < 0.25:
            k = int(rng.integers(3))
            T = (durs[1], 0.5 * (durs[1] + durs[2]), durs[2])[k]
        else:
            T = t_min * float(rng.uniform(1.0, 3.0)) + float(rng.exponential(0.05))
        if sync_mod._blocking_width(durs, T) > sync_mod._NARROW_BLOCK * max(1.0, T):
            counts["blocked"] += 1
            continue
        direct = sync_mod._solve_for(ax, T, ext, "direct")
        oracle = sync_mod._solve_for(ax, T, ext, "bisection")
        where = f"{case.code()}\n# T = {T!r}"
        if oracle is not None:
            assert direct is not None, f"bisection solves, direct does not:\n{where}"
        if direct is None:
            counts["neither"] += 1
            continue
        counts["solved"] += 1
        for name, r in (("direct", direct), ("bisection", oracle)):
            if r is None:
                continue
            prof = sync_mod._profile(ax, r[0], r[1])
            probs = _problems(prof, case, T + ax.t_pre)
            assert not probs, f"{name} ({r[1]}):\n{where}\n# - " + "\n# - ".join(probs)
        counts["fallback" if sync_mod.is_fallback_kind(direct[1]) else "closed"] += 1
    return counts


def test_direct_agrees_with_bisection_per_axis(summary: Callable[[str], None]) -> None:
    """3,000 random axes at random durations: the direct method solves every duration the
    bisection solves, both exactly (duration, end state, limits), and the closed forms answer
    at least 97 % of the axes that are not solved by an extremal profile or the scaling."""
    c = _single_axis_sweep(3000, SEED)
    slowed = c["closed"] + c["fallback"]
    summary(
        f"{c['solved']} solved ({c['closed']} closed form, {c['fallback']} fallback: "
        f"{100.0 * c['fallback'] / max(slowed, 1):.2f} %), {c['blocked']} blocked, "
        f"{c['neither']} unsolved by both"
    )
    assert c["solved"] > 2000
    assert c["neither"] <= 0.002 * c["solved"]
    assert c["fallback"] <= 0.03 * slowed


# -- whole plan_sync calls: both methods, Ruckig's duration as the reference -----------------
def _both(case: MultiCase, sync_oracle: RuckigSyncOracle) -> None:
    answer = sync_oracle.solve(case)
    direct = plan_sync(case.starts(), case.targets(), case.limits(), dt=case.dt)
    oracle = plan_sync(case.starts(), case.targets(), case.limits(), dt=case.dt, method="bisection")
    for name, traj in (("direct", direct), ("bisection", oracle)):
        probs = sync_problems(traj, case, answer)
        assert not probs, f"{name}:\n{case.code()}\n# - " + "\n# - ".join(probs)
    assert abs(direct.duration - oracle.duration) <= END_SPREAD_TOL, case.code()
    assert direct.independent_min_durations == oracle.independent_min_durations


@pytest.mark.parametrize(("dofs", "n", "dt"), [(3, 400, None), (6, 120, None), (3, 200, 0.001)])
def test_plan_sync_methods_agree(
    sync_oracle: RuckigSyncOracle, dofs: int, n: int, dt: float | None
) -> None:
    """Random Ruckig ``random_3`` cases (some axes start outside the limits): the same
    synchronised duration with both methods, never slower than Ruckig, every axis valid."""
    for case in generate_multi_cases(n, SEED + dofs + (7 if dt else 0), dofs, sync="time", dt=dt):
        _both(case, sync_oracle)


def test_plan_sync_asymmetric_against_ruckig(
    sync_oracle: RuckigSyncOracle, summary: Callable[[str], None]
) -> None:
    """400 3-axis cases with asymmetric limits (v_min != -v_max, a_min != -a_max), non-zero
    target states: Ruckig's Synchronization.Time duration (compare_sync_cases), and the
    bisection oracle's duration."""
    rng = np.random.default_rng(SEED + 99)
    cases: list[MultiCase] = []
    while len(cases) < 400:
        axes = tuple(draw_case(rng, asymmetric=True) for _ in range(3))
        if all(case_target_valid(c) for c in axes):
            cases.append(MultiCase(axes, "time"))
    res = compare_sync_cases(cases, sync_oracle)
    summary(res.summary_line())
    assert not res.failures, res.failure_report(5)
    assert res.max_ratio <= 1.0 + 2e-9
    for case in cases[:150]:
        _both(case, sync_oracle)


# -- hypothesis: an axis stretched to a rest-to-rest partner's duration ----------------------
def _rest_move_lasting(t: float) -> State:
    """Target from rest at 0 taking t under JERK_ONLY (t = 4 (d / (2 j))^(1/3))."""
    return State(p=2.0 * (t / 4.0) ** 3)


@hsettings(200)
@given(
    problem=st.one_of(strat.inside_problems(), strat.outside_problems()),
    stretch=st.floats(1.0, 4.0),
)
def test_stretched_axis_property(problem: tuple[State, State, Limits], stretch: float) -> None:
    """Any axis (inside or outside its limits) synchronised with a rest-to-rest axis lasting
    ``stretch`` x its minimum: both methods give the same duration (or both skip to the same
    end of a blocked interval), every axis valid and at its target."""
    start, target, lim = problem
    try:
        t_min = plan(start, target, lim).duration
    except PlanningError as exc:  # limits far too small for the state: refused alike by both
        assume("beyond the supported" not in str(exc))
        raise
    t_other = max(stretch * t_min, 1e-3)
    assume(t_other < 2e3)
    starts = [start, State()]
    targets = [target, _rest_move_lasting(t_other)]
    lims = [lim, JERK_ONLY]
    case = MultiCase(
        tuple(Case.from_problem(s, t, lm) for s, t, lm in zip(starts, targets, lims, strict=True)),
        "time",
    )
    try:
        direct = plan_sync(starts, targets, lims)
    except PlanningError as exc:
        assume("beyond the supported" not in str(exc))
        raise
    oracle = plan_sync(starts, targets, lims, method="bisection")
    for traj in (direct, oracle):
        probs = sync_problems(traj, case, NO_ANSWER)
        assert not probs, case.code() + "\n# - " + "\n# - ".join(probs)
    assert direct.duration == pytest.approx(oracle.duration, rel=0, abs=END_SPREAD_TOL)
    assert direct.duration >= t_other - 1e-9


# -- the closed forms' own algebra -----------------------------------------------------------
@hsettings(300)
@given(
    roots=st.lists(st.floats(-50.0, 50.0), min_size=2, max_size=4),
    pair=st.tuples(st.floats(-20.0, 20.0), st.floats(0.1, 20.0)),
)
def test_quartic_real_roots_against_numpy(roots: list[float], pair: tuple[float, float]) -> None:
    """The quartic built from its roots (four real, or two real and a complex pair): the
    Ferrari solver returns the real ones (numpy.roots as the independent peer), apart from
    near-double roots, which it may resolve only to sqrt(eps)."""
    if len(roots) == 4:
        coeffs = np.poly(roots)
        want = sorted(roots)
    else:
        re, im = pair
        coeffs = np.poly([roots[0], roots[1], complex(re, im), complex(re, -im)]).real
        want = sorted(roots[:2])
    got = _fixed.quartic_real_roots(*(float(c) for c in coeffs[1:]))
    scale = 1.0 + max(abs(x) for x in want)
    gaps = [b - a for a, b in zip(want, want[1:], strict=False)]
    if gaps and min(gaps) < 1e-3 * scale:
        return  # clustered roots: only the verification of the caller decides there
    peer = sorted(float(r.real) for r in np.roots(coeffs) if abs(r.imag) <= 1e-7 * scale)
    assert len(got) == len(want) == len(peer), (got, want, peer)
    for g, w, p in zip(got, want, peer, strict=True):
        assert g == pytest.approx(w, abs=1e-7 * scale)
        assert g == pytest.approx(p, abs=1e-6 * scale)


@hsettings(100)
@given(d=strat.magnitudes, t=strat.magnitudes, sign=st.sampled_from((1.0, -1.0)))
def test_none_free_jerk_rest_to_rest(d: float, t: float, sign: float) -> None:
    """Rest to rest the quartic's root is j = 32 d / T^3: ramps T/4, T/2, T/4 (peak
    accelerations 8 d / T^2 up to 1e4, where the verification's absolute end-acceleration
    tolerance of 1e-10 is above the rounding of j T)."""
    assume(8.0 * d / t**2 <= 1e4)
    j = 32.0 * sign * d / t**3
    ph = _fixed.none_free_jerk(
        0.0, 0.0, sign * d, 0.0, 0.0, math.inf, -math.inf, math.inf, -math.inf, abs(j) * 2.0, t
    )
    assert ph is not None
    assert [x[0] for x in ph] == pytest.approx([0.25 * t, 0.5 * t, 0.25 * t], rel=1e-9)
    assert [x[1] for x in ph] == pytest.approx([j, -j, j], rel=1e-9)
    # a jerk limit below the needed jerk: no such profile
    assert (
        _fixed.none_free_jerk(
            0.0,
            0.0,
            sign * d,
            0.0,
            0.0,
            math.inf,
            -math.inf,
            math.inf,
            -math.inf,
            abs(j) * 0.99,
            t,
        )
        is None
    )


def test_method_is_checked() -> None:
    with pytest.raises(PlanningError, match="method must be 'direct' or 'bisection', got 'x'"):
        plan_sync([State()], [State(1.0)], [JERK_ONLY], method="x")


def test_fallback_kinds() -> None:
    """The benchmark's fallback count: closed forms are not fallbacks, bisections and scans
    are."""
    for kind in ("none-j", "vel-j-down", "acc0_acc1-j", "none+scaled", "vel", "ramp+j", "hold"):
        assert not sync_mod.is_fallback_kind(kind), kind
    for kind in (
        "none+j",
        "vel-down+v",
        "acc0+a+",
        "cruise-sync",
        "udud",
        "free-then-amin",
        "none+family-j",
        "monotone-free-plateau",
        "none+j+phase",
    ):
        assert sync_mod.is_fallback_kind(kind), kind


# -- blocked intervals: both methods skip the same durations ---------------------------------
BLOCK_START = State(p=-0.75, v=1.0, a=0.0)
BLOCK_TARGET = State(p=0.75, v=1.0, a=0.0)
BLOCK_LIMITS = Limits(v_max=2.0, a_max=1.0, j_max=1.0)
BLOCK_T3 = 3.0 + math.sqrt(3.0)  # the blocked interval is (1.6371..., 4.7320...)


@pytest.mark.parametrize("t_other", [1.45, 1.55, 1.62, 2.0, 3.0, 4.5, 4.735, 6.0, 10.0])
def test_blocked_interval_both_methods(t_other: float) -> None:
    """An axis at a moving target (blocked between 1.637 s and 4.732 s) with a rest-to-rest
    partner lasting ``t_other``: both methods end at t_other, or at the blocked interval's end
    when t_other is inside it, with valid profiles."""
    starts = [BLOCK_START, State()]
    targets = [BLOCK_TARGET, _rest_move_lasting(t_other)]
    lims = [BLOCK_LIMITS, JERK_ONLY]
    case = MultiCase(
        tuple(Case.from_problem(s, t, lm) for s, t, lm in zip(starts, targets, lims, strict=True)),
        "time",
    )
    expected = BLOCK_T3 if 1.6371 < t_other < BLOCK_T3 else t_other
    for method in ("direct", "bisection"):
        traj = plan_sync(starts, targets, lims, method=method)
        probs = sync_problems(traj, case, NO_ANSWER)
        assert not probs, f"{method}: " + "; ".join(probs)
        assert traj.duration == pytest.approx(expected, rel=1e-9), method
