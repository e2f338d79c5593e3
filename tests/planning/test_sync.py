"""Multi-axis synchronisation (``plan_sync``): Ruckig 0.19.4 comparison, deterministic cases,
properties.

Random comparison (20,000 cases in total, Ruckig's ``random_3`` distributions per axis, see
``tests/planning/_cases.py``): ``Synchronization.Time`` with 3 and 6 axes,
``Synchronization.Phase`` (half the cases collinear: v0, a0, vf, af parallel to the move) and
``DurationDiscretization.Discrete`` with ``dt = 0.001``. A case fails when any check of
``tests/planning/_compare.py:sync_problems`` fails: every axis valid and at its target (limits
when it starts inside them, |jerk| <= j_max), all axes ending within 1e-9 s of each other,
durations a whole number of cycles, ``duration <= ruckig * (1 + 1e-9) + 1e-9``, and for phase
synchronisation the tool point on the straight line within 1e-9 of the move length.
``tools/compare_ruckig.py --sync time|phase|discrete --dofs N`` runs the same at any scale.
"""

from __future__ import annotations

import dataclasses
import math
import re
from collections.abc import Callable

import numpy as np
import pytest
from hypothesis import assume, given
from hypothesis import strategies as st

from motionplc.planning import (
    Limits,
    PlanningError,
    State,
    Trajectory,
    plan,
    plan_fixed_duration,
    plan_sync,
    plan_velocity,
)
from tests.planning import _strategies as strat
from tests.planning._cases import (
    Case,
    MultiCase,
    RuckigSyncAnswer,
    RuckigSyncOracle,
    generate_multi_cases,
)
from tests.planning._checks import check_profile
from tests.planning._checks import lims as lims_of
from tests.planning._compare import (
    END_SPREAD_TOL,
    SyncComparison,
    compare_sync_cases,
    cycle_error,
    line_deviation,
    sync_problems,
)
from tests.planning._strategies import hsettings

SEED = 4242
DT = 0.001
NO_ANSWER = RuckigSyncAnswer(None, "not compared")


@pytest.fixture(scope="module")
def sync_oracle() -> RuckigSyncOracle:
    rk = pytest.importorskip("ruckig")
    return RuckigSyncOracle(rk, DT)


def _multi(
    starts: list[State],
    targets: list[State],
    lims: list[Limits],
    sync: str = "time",
    dt: float | None = None,
    interface: list[str] | None = None,
) -> MultiCase:
    axes = tuple(
        Case.from_problem(s, t, lm) for s, t, lm in zip(starts, targets, lims, strict=True)
    )
    return MultiCase(axes, sync, dt, None if interface is None else tuple(interface))


def _plan(case: MultiCase) -> Trajectory:
    return plan_sync(
        case.starts(),
        case.targets(),
        case.limits(),
        sync=case.sync,
        dt=case.dt,
        interface=None if case.interface is None else list(case.interface),
    )


def _check(case: MultiCase, answer: RuckigSyncAnswer = NO_ANSWER) -> Trajectory:
    """Plan ``case`` and assert every check of ``sync_problems``; returns the trajectory."""
    traj = _plan(case)
    problems = sync_problems(traj, case, answer)
    assert not problems, case.code() + "\n# - " + "\n# - ".join(problems)
    return traj


def _check_supported(case: MultiCase) -> Trajectory:
    """``_check`` inside a hypothesis test: cases beyond the supported synchronised duration
    (MAX_SYNC_DURATION, 1e4 s; Ruckig stops at ~7.6e3 s) are rejected examples."""
    try:
        return _check(case)
    except PlanningError as exc:
        assume("beyond the supported" not in str(exc))
        raise


def _run(
    oracle: RuckigSyncOracle, summary: Callable[[str], None], cases: list[MultiCase]
) -> SyncComparison:
    res = compare_sync_cases(cases, oracle)
    summary(res.summary_line())
    assert res.cases == len(cases)
    assert not res.failures, res.failure_report(10)
    if all(c.sync != "none" for c in cases):
        assert res.max_spread <= END_SPREAD_TOL
    assert math.isnan(res.max_ratio) or res.max_ratio <= 1.0 + 2e-9
    return res


# -- random comparison with Ruckig (20,000 cases) --------------------------------------------
@pytest.mark.parametrize(("dofs", "n"), [(3, 8_000), (6, 3_000)])
def test_random_time_sync(
    sync_oracle: RuckigSyncOracle, summary: Callable[[str], None], dofs: int, n: int
) -> None:
    """Synchronization.Time: 8,000 3-axis and 3,000 6-axis cases."""
    cases = generate_multi_cases(n, SEED + dofs, dofs, sync="time")
    res = _run(sync_oracle, summary, cases)
    assert res.used == {"time": n}
    assert res.outside > 0  # Ruckig's distributions start some axes outside their limits


@pytest.mark.parametrize(("dofs", "n"), [(3, 3_000), (6, 1_500)])
def test_random_phase_sync(
    sync_oracle: RuckigSyncOracle, summary: Callable[[str], None], dofs: int, n: int
) -> None:
    """Synchronization.Phase: 3,000 3-axis and 1,500 6-axis cases, about half of them
    collinear. Where phase synchronisation is used the path stays on the line; elsewhere the
    trajectory is time-synchronised and says why."""
    cases = generate_multi_cases(n, SEED + 10 + dofs, dofs, sync="phase", collinear_fraction=0.5)
    n_collinear = sum(c.tag == "collinear" for c in cases)
    assert 0.4 * n < n_collinear < 0.6 * n
    res = _run(sync_oracle, summary, cases)
    assert res.max_line <= 1e-9
    assert sum(res.notes.values()) == res.used.get("time", 0)
    # measured: phase is used in ~2/3 (3 axes) / ~1/2 (6 axes) of the collinear cases; the
    # rest start outside a limit or would be slower than time synchronisation
    assert res.used.get("phase", 0) >= 0.3 * n_collinear


@pytest.mark.parametrize(("dofs", "n"), [(3, 3_000), (6, 1_500)])
def test_random_discrete_duration(
    sync_oracle: RuckigSyncOracle, summary: Callable[[str], None], dofs: int, n: int
) -> None:
    """DurationDiscretization.Discrete (dt = 1 ms, time synchronisation): every axis ends
    on a cycle, no later than Ruckig's."""
    cases = generate_multi_cases(n, SEED + 20 + dofs, dofs, sync="time", dt=DT)
    res = _run(sync_oracle, summary, cases)
    assert res.max_cycle <= 1e-9


def test_random_no_sync(sync_oracle: RuckigSyncOracle, summary: Callable[[str], None]) -> None:
    """Synchronization.No: 1,000 3-axis cases, each axis time-optimal on its own."""
    cases = generate_multi_cases(1_000, SEED + 30, 3, sync="none")
    res = _run(sync_oracle, summary, cases)
    assert res.used == {"none": 1_000}
    for case in cases[:200]:
        traj = _plan(case)
        for c, prof in zip(case.axes, traj.profiles, strict=True):
            assert prof.duration == pytest.approx(
                plan(c.start(), c.target(), c.limits()).duration, rel=1e-12, abs=1e-12
            )


def test_random_mixed_interfaces(
    sync_oracle: RuckigSyncOracle, summary: Callable[[str], None]
) -> None:
    """1,000 3-axis time-synchronised cases, each axis on the velocity interface with
    probability 1/3 (Ruckig's ``per_dof_control_interface``)."""
    rng = np.random.default_rng(SEED + 40)
    cases = [
        dataclasses.replace(
            c, interface=tuple("velocity" if rng.random() < 1 / 3 else "position" for _ in "xyz")
        )
        for c in generate_multi_cases(1_000, SEED + 40, 3)
    ]
    _run(sync_oracle, summary, cases)


# -- rest to rest: exact time scaling ----------------------------------------------------------
REST_LIMITS = [
    Limits(v_max=1.0, a_max=1.0, j_max=1.0),
    Limits(v_max=0.4, a_max=2.0, j_max=10.0),  # reaches v_max
    Limits(v_max=5.0, a_max=0.5, j_max=4.0, v_min=-3.0, a_min=-0.8),  # asymmetric
    Limits(v_max=3.0, a_max=6.0, j_max=0.5),  # jerk-limited only
]


@pytest.mark.parametrize("dt", [None, DT, 0.01])
def test_rest_to_rest_is_exact_time_scaling(
    sync_oracle: RuckigSyncOracle, dt: float | None
) -> None:
    """Rest-to-rest axes are slowed by scaling their limits (j/k^3, a/k^2, v/k): each axis'
    profile is its own time-optimal profile stretched by k = T / T_own -- the same segments,
    k times as long, with jerk / k^3."""
    starts = [State(0.0), State(1.0), State(-2.0), State(0.5)]
    targets = [State(2.0), State(-1.5), State(1.0), State(0.0)]
    case = _multi(starts, targets, REST_LIMITS, dt=dt)
    answer = sync_oracle.solve(case)
    traj = _check(case, answer)
    own = [plan(s, t, lm) for s, t, lm in zip(starts, targets, REST_LIMITS, strict=True)]
    t_own = max(p.duration for p in own)
    expected = t_own if dt is None else math.ceil(t_own / dt - 1e-9) * dt
    assert traj.duration == pytest.approx(expected, rel=1e-12, abs=1e-12)
    assert traj.duration == pytest.approx(answer.duration, rel=1e-12, abs=1e-12)
    for i, (mine, ref) in enumerate(zip(traj.profiles, own, strict=True)):
        assert mine.duration == pytest.approx(traj.duration, rel=0, abs=1e-12)
        k = traj.duration / ref.duration
        assert len(mine.segments) == len(ref.segments), (i, mine.segments, ref.segments)
        for a, b in zip(mine.segments, ref.segments, strict=True):
            assert a.duration == pytest.approx(k * b.duration, rel=1e-9, abs=1e-12), i
            assert a.jerk == pytest.approx(b.jerk / k**3, rel=1e-9, abs=1e-15), i
        # the stretched profile is the original one on a slower clock
        ts = np.linspace(0.0, ref.duration, 50)
        np.testing.assert_allclose(mine.sample(ts * k).p, ref.sample(ts).p, rtol=0, atol=1e-9)


# -- Ruckig's known 3-DoF examples (test_target.cpp, "known") --------------------------------
# (p0, v0, a0, pf, vf, af, v_max, a_max, j_max), one tuple of 3 per quantity; Ruckig's duration
_KNOWN = [
    (
        ((-5.54640573838539, -2.34195463203842, 5.10070661762967),
         (0.824843228617216, -1.03863337183304, -0.749451523227729),
         (-0.119403564898501, 0.923861820607788, 3.04022341347259),
         (-1.58293112753888, 0.383405919465141, 5.79349604610299),
         (-1.59453676324393, 0.0, -0.0693173526513803),
         (-0.664429703711622, 0.0, 0.0),
         (12.9892953062198, 3.74169932927481, 1.42398447457303),
         (4.2162106624246, 10.2906731766853, 2.1869079548297),
         (8.03496976453435, 0.200684346397485 - 1.0e-14, 0.0848503482861296)),
        1921.0797627836,
    ),
    (
        ((-6.49539540831446, 6.14883133273172, -2.02636240900911),
         (-1.14327601654428, 0.00991019970085593, -1.00932863927626),
         (-1.73501068960131, -0.584885092422228, 0.0),
         (4.4676187540058, 2.93367894961155, -0.646008452514058),
         (-0.544559915133859, 0.298517792372943, 1.6058847848484),
         (-1.31832055647831, 0.0, 0.0),
         (8.65978706670502, 5.94921088330542, 10.7652253566829),
         (3.40137210377608, 4.04166318018487, 10.8617860610581),
         (10.9542353113865, 3.11056302676629, 0.798055744482636 + 9e-12)),
        4.6277455678,
    ),
    (
        ((7.06378251402596, -2.4834697862831, -0.843847405371359),
         (0.436985859305842, 0.0708113515655622, -0.751266816040307),
         (-0.80835350359544, 0.0, -0.355284934641626),
         (4.40606827118048, -2.84629921001043, -2.91829890043522),
         (0.555084596169823, 0.0, -1.24631524923535),
         (0.463000173872542, 0.0, 0.0),
         (7.97399137456765, 2.68591430972239, 9.54987666746364),
         (5.44679859206862, 7.61752909348119, 0.473482772614085),
         (7.88958080921515, 5.26855927512131, 0.764061581326592 - 1e-14)),
        8.8739464323,
    ),
    (
        ((-7.962737259350095, 0.0, 0.0),
         (-0.8844863500141733, 0.0, 0.0),
         (2.252932547031004, 0.0, 0.0),
         (-3.547368989678775, 0.0, 0.0),
         (0.0, 0.0, 0.0),
         (0.217242176687843, 0.0, 0.0),
         (0.1241065584614779, 1.0, 1.0),
         (1.808598147153279, 1.0, 1.0),
         (2.516849090900998 - 3e-15, 1.0, 1.0)),
        38.3409477609,
    ),
    (
        ((-4.180150148354134, 1.030371049895473, -2.660154279239869),
         (1.673805463302308, -1.435796222257198, 0.9711306630275642),
         (1.412175048500792, 1.892262449040863, -1.128847905860926),
         (2.079913937916431, 1.839862681333277, 2.341421542126605),
         (0.7537566830764975, 0.0, 0.02507782261105568),
         (-0.8610296259045267, -0.07876324073516261, 0.0),
         (1.863775561344568, 0.4357836109021987, 6.260907804906162),
         (9.49223908896113, 9.002562577262177, 1.119142029086944),
         (8.689575453772798, 0.09322235504216797, 0.1594452521517275 + 3e-15)),
        1135.0135089249,
    ),
    (
        ((-4.490717417930574, 3.467236624628543, -0.7545929089757601),
         (0.1839756723363622, -0.4356283320280516, 0.7490399525818022),
         (-1.057769973808928, 0.0, -2.368645439140517),
         (-4.928244836531066, -4.821780824003112, -8.20567952461017),
         (0.1097319156272965, -0.9272874846270881, 0.0),
         (0.03089046366221739, -0.9744054582899561, 0.0),
         (6.144314006624488, 2.93258338415229, 0.1820021269527196),
         (5.199401036221791, 1.848176490768948, 11.11168017805234),
         (9.940940357283978, 10.46997753899755, 0.08166297169205029)),
        7295.4375633935,
    ),
    (
        ((0.0, 0.0, 0.0), (0.0, 0.0, 0.0), (0.0, 0.0, 0.0),
         (400.0, 4000.0, 40000.0), (0.0, 0.0, 0.0), (0.0, 0.0, 0.0),
         (1800.0, 18000.0, 180000.0), (20000.0, 200000.0, 2000000.0),
         (200000.0, 2000000.0, 20000000.0)),
        0.4119588818,
    ),
]  # fmt: skip


@pytest.mark.parametrize(("values", "duration"), _KNOWN, ids=[f"{d:g}s" for _, d in _KNOWN])
def test_ruckig_known_examples(
    sync_oracle: RuckigSyncOracle,
    values: tuple[tuple[float, float, float], ...],
    duration: float,
) -> None:
    """Ruckig's hard 3-DoF time-synchronisation examples (durations up to 7295 s)."""
    p0, v0, a0, pf, vf, af, vm, am, jm = values
    axes = tuple(
        Case(p0[i], v0[i], a0[i], pf[i], vf[i], af[i], vm[i], am[i], jm[i]) for i in range(3)
    )
    case = MultiCase(axes)
    answer = sync_oracle.solve(case)
    assert answer.duration == pytest.approx(duration, rel=1e-10, abs=1e-10)
    traj = _check(case, answer)
    assert traj.duration == pytest.approx(answer.duration, rel=1e-9, abs=1e-9)


# -- blocked interval --------------------------------------------------------------------------
# One axis moving at v = 1 that must pass p = 0.75 at v = 1 again, 1.5 further on (the
# blocked-interval example of Ruckig's paper and README), with a_max = j_max = 1:
# * up to T2 it can go forward all the time, dipping to a lower velocity: the slowest such
#   profile brakes from 1 to 1 - s^2 and accelerates back (two jerk-only velocity changes of
#   2s each, no cruise), covering 2 (2 - s^2) s = 1.5: s^3 - 2s + 0.75 = 0 and T2 = 4s;
# * it cannot brake to a stop within 1.5, so any longer profile overshoots the target,
#   comes back and passes it again: the fastest one takes T3 = 3 + sqrt(3) (Ruckig agrees);
# * durations in (T2, T3) are blocked.
BLOCK_START = State(p=-0.75, v=1.0, a=0.0)
BLOCK_TARGET = State(p=0.75, v=1.0, a=0.0)
BLOCK_LIMITS = Limits(v_max=2.0, a_max=1.0, j_max=1.0)
_S = float(min(r.real for r in np.roots([1.0, 0.0, -2.0, 0.75]) if r.real > 0 and not r.imag))
BLOCK_T2 = 4.0 * _S  # 1.6371161...
BLOCK_T3 = 3.0 + math.sqrt(3.0)  # 4.7320508...
JERK_ONLY = Limits(v_max=10.0, a_max=10.0, j_max=1.0)


def _rest_move_lasting(t: float) -> State:
    """Target of a rest-to-rest move from 0 that takes t under JERK_ONLY (jerk-only profile:
    t = 4 (d / (2 j))^(1/3))."""
    return State(p=2.0 * (t / 4.0) ** 3)


def test_blocked_interval_exists() -> None:
    t_min = plan(BLOCK_START, BLOCK_TARGET, BLOCK_LIMITS).duration
    assert t_min < 1.5 < BLOCK_T2 < BLOCK_T3
    inside = np.linspace(BLOCK_T2, BLOCK_T3, 41)[1:-1]
    for T in inside:
        assert plan_fixed_duration(BLOCK_START, BLOCK_TARGET, BLOCK_LIMITS, float(T)) is None, T
    assert plan_fixed_duration(BLOCK_START, BLOCK_TARGET, BLOCK_LIMITS, 0.9 * t_min) is None


@pytest.mark.parametrize(
    "t",
    [1.45, 1.5, 1.55, 1.6, BLOCK_T2 - 1e-6, BLOCK_T2, BLOCK_T3, BLOCK_T3 + 1e-6]
    + [BLOCK_T3 + 0.003, 4.735, 4.738, 4.75, 6.0, 20.0],
)
def test_fixed_duration_outside_blocked_interval(t: float) -> None:
    """Every duration >= t_min outside (T2, T3) has a profile of exactly that duration."""
    prof = plan_fixed_duration(BLOCK_START, BLOCK_TARGET, BLOCK_LIMITS, t)
    assert prof is not None, f"plan_fixed_duration({BLOCK_START}, {BLOCK_TARGET}, ..., {t!r})"
    assert prof.duration == pytest.approx(t, rel=0, abs=1e-9)
    check_profile(prof, BLOCK_START, BLOCK_TARGET, BLOCK_LIMITS, jerk_within=True)


@pytest.mark.parametrize("t_other", [1.45, 1.55, 1.62, 2.0, 3.0, 4.5, 4.735, 6.0])
def test_sync_skips_blocked_interval(sync_oracle: RuckigSyncOracle, t_other: float) -> None:
    """Synchronised with a rest-to-rest axis whose own minimum is ``t_other``: the duration is
    ``t_other`` unless that is blocked for the first axis, then the blocked interval's end."""
    starts = [BLOCK_START, State()]
    targets = [BLOCK_TARGET, _rest_move_lasting(t_other)]
    lims = [BLOCK_LIMITS, JERK_ONLY]
    assert plan(starts[1], targets[1], lims[1]).duration == pytest.approx(t_other, rel=1e-12)
    case = _multi(starts, targets, lims)
    answer = sync_oracle.solve(case)
    expected = BLOCK_T3 if BLOCK_T2 < t_other < BLOCK_T3 else t_other
    assert answer.duration == pytest.approx(expected, rel=1e-12)
    traj = _check(case, answer)
    assert traj.duration == pytest.approx(expected, rel=1e-9)
    if BLOCK_T2 < t_other < BLOCK_T3:  # the chosen duration is not inside the blocked interval
        assert traj.duration >= BLOCK_T3 - 1e-9
        fixed = plan_fixed_duration(BLOCK_START, BLOCK_TARGET, BLOCK_LIMITS, t_other)
        assert fixed is None


# -- mixed interfaces: seed 004's milling example ---------------------------------------------
FEED = Limits(v_max=0.5, a_max=2.0, j_max=20.0)  # m/s, m/s^2, m/s^3
SPINDLE = Limits(v_max=400.0, a_max=50.0, j_max=200.0)  # rad/s, ...


def test_milling_feed_axes_arrive_with_the_spindle(sync_oracle: RuckigSyncOracle) -> None:
    """x and y reach their positions at their feed velocities exactly when the spindle
    (velocity interface, the slowest axis) reaches cutting speed; the spindle's run-up is
    time-optimal, both feed axes are slowed (no limit reached: seed 004's 'F8' shape)."""
    starts = [State(0.0), State(0.0), State(0.0)]
    targets = [State(0.2, 0.05, 0.0), State(0.1, 0.03, 0.0), State(0.0, 300.0, 0.0)]
    lims = [FEED, FEED, SPINDLE]
    iface = ["position", "position", "velocity"]
    case = _multi(starts, targets, lims, interface=iface)
    answer = sync_oracle.solve(case)
    traj = _check(case, answer)
    run_up = plan_velocity(starts[2], 300.0, SPINDLE).duration
    assert run_up == pytest.approx(300.0 / 50.0 + 50.0 / 200.0, rel=1e-12)  # 6.25 s
    assert traj.duration == pytest.approx(run_up, rel=1e-12)
    assert traj.duration == pytest.approx(answer.duration, rel=1e-12)
    assert traj.independent_min_durations[2] == pytest.approx(run_up, rel=1e-12)
    assert max(traj.independent_min_durations[:2]) < 0.2 * run_up
    for prof, target in zip(traj.profiles, targets, strict=True):
        end = prof.end
        assert prof.duration == pytest.approx(run_up, abs=1e-9)
        assert (end.v, end.a) == pytest.approx((target.v, target.a), abs=1e-9)
    for prof, target in zip(traj.profiles[:2], targets[:2], strict=True):
        assert prof.end.p == pytest.approx(target.p, abs=1e-9)
        _, (v_lo, v_hi), (a_lo, a_hi) = prof.extrema()
        assert -FEED.v_max < v_lo and v_hi < FEED.v_max
        assert -FEED.a_max < a_lo and a_hi < FEED.a_max
        assert all(abs(s.jerk) < FEED.j_max for s in prof.segments)


def test_mixed_interface_velocity_axis_slowed(sync_oracle: RuckigSyncOracle) -> None:
    """A faster velocity-interface axis with a non-zero target acceleration is slowed to the
    position axis' duration (Ruckig: 2.6955537 s). Found by the mixed-interface sweep."""
    case = _multi(
        [
            State(p=1.2242760999434918, v=0.0, a=-0.11214745560951274),
            State(p=1.1081529474737548, v=-1.2986881149873408, a=0.34597783804245225),
        ],
        [
            State(p=-1.1877221305310903, v=0.0, a=-0.542466434940846),
            State(p=3.674966831530215, v=-0.4907184661980538, a=1.0542425216005868),
        ],
        [
            Limits(v_max=13.453110004578217, a_max=8.833571696140506, j_max=4.479932918077565),
            Limits(v_max=11.121953518686524, a_max=10.737825502688958, j_max=3.5167383534076184),
        ],
        interface=["position", "velocity"],
    )
    answer = sync_oracle.solve(case)
    assert answer.duration is not None
    traj = _check(case, answer)
    assert traj.duration == pytest.approx(answer.duration, rel=1e-9)


@pytest.mark.parametrize(
    ("vf", "af", "a0"), [(0.5, 0.0, 0.0), (0.5, 0.2, 0.0), (0.0, 0.2, 0.0), (0.5, -0.2, 0.3)]
)
def test_velocity_axis_with_position_axis(
    sync_oracle: RuckigSyncOracle, vf: float, af: float, a0: float
) -> None:
    """A quick velocity-interface axis ends with the slow position axis, its target p unused."""
    lim = Limits(v_max=1.0, a_max=1.0, j_max=1.0)
    case = _multi(
        [State(0.0), State(0.0, 0.0, a0)],
        [State(10.0), State(123.0, vf, af)],
        [lim, lim],
        interface=["position", "velocity"],
    )
    answer = sync_oracle.solve(case)
    traj = _check(case, answer)
    assert traj.duration == pytest.approx(plan(State(), State(10.0), lim).duration, rel=1e-9)


# -- sync="none", phase, discrete --------------------------------------------------------------
def test_sync_none_is_independent() -> None:
    starts = [State(0.0, 0.5, 0.1), State(1.0), State(-2.0, -0.3)]
    targets = [State(3.0), State(1.5, 0.2), State(2.0)]
    lims = REST_LIMITS[:3]
    traj = plan_sync(starts, targets, lims, sync="none")
    assert traj.sync == "none" and traj.note == ""
    own = [plan(s, t, lm).duration for s, t, lm in zip(starts, targets, lims, strict=True)]
    assert [p.duration for p in traj.profiles] == pytest.approx(own, rel=1e-12)
    assert list(traj.independent_min_durations) == pytest.approx(own, rel=1e-12)
    assert traj.duration == pytest.approx(max(own), rel=1e-12)
    assert len({round(d, 6) for d in own}) == 3  # really different
    for prof, s, t, lm in zip(traj.profiles, starts, targets, lims, strict=True):
        check_profile(prof, s, t, lm)
    # past its end an axis holds its target state (with its target velocity)
    at_end = traj.at(traj.duration)
    for smp, t in zip(at_end, targets, strict=True):
        assert smp.v == pytest.approx(t.v, abs=1e-9)


def test_phase_sync_of_collinear_move_is_a_straight_line(sync_oracle: RuckigSyncOracle) -> None:
    u = np.array([1.0, 2.0, -2.0]) / 3.0
    p0 = np.array([0.5, -1.0, 2.0])
    length = 3.0
    starts = [State(float(p), float(0.4 * x), float(-0.2 * x)) for p, x in zip(p0, u, strict=True)]
    targets = [
        State(float(p + length * x), float(0.1 * x), 0.0) for p, x in zip(p0, u, strict=True)
    ]
    lims = [Limits(v_max=1.0, a_max=2.0, j_max=5.0)] * 3
    case = _multi(starts, targets, lims, sync="phase")
    answer = sync_oracle.solve(case)
    traj = _check(case, answer)
    assert traj.sync == "phase" and traj.note == ""
    assert line_deviation(traj, starts, targets) <= 1e-12
    time_traj = plan_sync(starts, targets, lims, sync="time")
    assert traj.duration <= time_traj.duration * (1 + 1e-9) + 1e-9
    # scaled copies: the same segment durations, jerks in proportion to the direction
    ref = traj.profiles[0]
    for prof, x in zip(traj.profiles, u, strict=True):
        assert [s.duration for s in prof.segments] == pytest.approx(
            [s.duration for s in ref.segments], rel=1e-12, abs=1e-15
        )
        assert [s.jerk for s in prof.segments] == pytest.approx(
            [s.jerk * x / u[0] for s in ref.segments], rel=1e-12, abs=1e-15
        )


def test_phase_sync_falls_back_to_time_for_non_collinear_input() -> None:
    starts = [State(0.0, 0.5), State(0.0, 0.0)]  # start velocity not along the move
    targets = [State(1.0), State(1.0)]
    lims = [Limits(v_max=1.0, a_max=1.0, j_max=1.0)] * 2
    traj = plan_sync(starts, targets, lims, sync="phase")
    assert traj.sync == "time"
    assert "collinear" in traj.note and "velocit" in traj.note
    same = plan_sync(starts, targets, lims, sync="time")
    assert traj.duration == same.duration
    assert [p.segments for p in traj.profiles] == [p.segments for p in same.profiles]


def test_phase_sync_of_rest_to_rest_move_is_as_fast_as_time_sync() -> None:
    """Equal limits on every axis: the axis moving farthest limits both the line and time
    synchronisation, so the straight line costs nothing."""
    starts = [State(0.0), State(1.0), State(2.0)]
    targets = [State(1.0), State(-1.0), State(2.5)]
    lims = [REST_LIMITS[1]] * 3
    phase = plan_sync(starts, targets, lims, sync="phase")
    time_ = plan_sync(starts, targets, lims, sync="time")
    assert phase.sync == "phase"
    assert phase.duration == pytest.approx(time_.duration, rel=1e-9)
    assert line_deviation(phase, starts, targets) <= 1e-12


@pytest.mark.parametrize("dt", [0.001, 0.004, 0.01, 0.25])
def test_discrete_duration_is_whole_cycles(sync_oracle: RuckigSyncOracle, dt: float) -> None:
    starts = [State(0.0, 0.5, 0.1), State(1.0), State(-2.0, -0.3)]
    targets = [State(3.0, 0.2), State(1.5, 0.2, -0.1), State(2.0)]
    lims = REST_LIMITS[:3]
    cont = plan_sync(starts, targets, lims)
    case = _multi(starts, targets, lims, dt=dt)
    traj = _check(case)
    n = round(traj.duration / dt)
    assert cycle_error(traj.duration, dt) <= 1e-9
    assert n == math.ceil(cont.duration / dt - 1e-9)  # nothing blocked here: the next cycle
    if dt == DT:
        answer = sync_oracle.solve(case)
        assert traj.duration == pytest.approx(answer.duration, abs=1e-9)


# -- bad input ---------------------------------------------------------------------------------
_S3 = [State(0.0), State(1.0), State(2.0)]
_T3 = [State(1.0), State(2.0), State(3.0)]
_L3 = [Limits(v_max=1.0, a_max=1.0, j_max=1.0)] * 3


@pytest.mark.parametrize(
    ("kwargs", "field"),
    [
        ({"starts": _S3[:2]}, "starts"),
        ({"targets": _T3[:2]}, "targets"),
        ({"limits": _L3[:1]}, "limits"),
        ({"starts": [], "targets": [], "limits": []}, "axis"),
        ({"sync": "fast"}, "sync"),
        ({"sync": None}, "sync"),
        ({"dt": 0.0}, "dt"),
        ({"dt": -0.001}, "dt"),
        ({"dt": math.nan}, "dt"),
        ({"dt": math.inf}, "dt"),
        ({"dt": True}, "dt"),
        ({"interface": ["position", "torque", "position"]}, "interface[1]"),
        ({"interface": ["position"]}, "interface"),
        ({"targets": [State(1.0), State(math.nan), State(3.0)]}, "targets[1]"),
        ({"starts": [State(0.0), State(1.0), State(2.0, math.inf)]}, "starts[2]"),
        ({"targets": [State(1.0), State(2.0, 5.0), State(3.0)]}, "targets[1]"),
    ],
)
def test_bad_input_names_the_field(kwargs: dict[str, object], field: str) -> None:
    args: dict[str, object] = {"starts": _S3, "targets": _T3, "limits": _L3}
    args.update(kwargs)
    with pytest.raises(PlanningError, match=re.escape(field)):
        plan_sync(**args)  # type: ignore[arg-type]
    assert issubclass(PlanningError, ValueError)


# -- properties ----------------------------------------------------------------------------------
@hsettings(300)
@given(
    strat.multi_problems(),
    st.sampled_from(["time", "phase", "none"]),
    st.sampled_from([None, 0.001, 0.01]),
)
def test_sync_properties(problem: strat.MultiProblem, sync: str, dt: float | None) -> None:
    """Random axes inside their limits: a valid synchronised trajectory (all checks of
    ``sync_problems`` but Ruckig's duration), each axis' independent minimum duration is its
    own ``plan`` duration and the time-synchronised duration is at least the largest."""
    starts, targets, lims = problem
    traj = _check_supported(_multi(starts, targets, lims, sync=sync, dt=dt))
    own = [plan(s, t, lm).duration for s, t, lm in zip(starts, targets, lims, strict=True)]
    assert list(traj.independent_min_durations) == pytest.approx(own, rel=1e-9, abs=1e-12)
    if sync != "none":
        assert traj.duration >= max(own) - 1e-9


@hsettings(200)
@given(strat.multi_problems(rest=True), st.sampled_from([None, 0.001]))
def test_rest_to_rest_properties(problem: strat.MultiProblem, dt: float | None) -> None:
    """Rest to rest nothing is blocked: the duration is the slowest axis' minimum (rounded up
    to a cycle), and every axis' profile is its own optimal profile, time-stretched."""
    starts, targets, lims = problem
    traj = _check_supported(_multi(starts, targets, lims, dt=dt))
    own = [plan(s, t, lm) for s, t, lm in zip(starts, targets, lims, strict=True)]
    t_max = max(p.duration for p in own)
    expected = t_max if dt is None else math.ceil(t_max / dt - 1e-9) * dt
    assert traj.duration == pytest.approx(expected, rel=1e-12, abs=1e-12)
    for mine, ref in zip(traj.profiles, own, strict=True):
        if ref.duration == 0.0:
            continue
        k = traj.duration / ref.duration
        ts = np.linspace(0.0, ref.duration, 20)
        scale = max(1.0, *(abs(x) for x in ref.extrema()[0]))
        np.testing.assert_allclose(
            mine.sample(ts * k).p, ref.sample(ts).p, rtol=0, atol=1e-9 * scale
        )


def _line_limits(lims: list[Limits], u: list[float]) -> Limits:
    """The limits of every axis projected onto the direction u (the most restrictive)."""
    v_hi = a_hi = j = math.inf
    v_lo = a_lo = -math.inf
    for lm, x in zip(lims, u, strict=True):
        if x == 0.0:
            continue
        v_min, v_max, a_min, a_max, j_max = lims_of(lm)
        hv, lv = (v_max / x, v_min / x) if x > 0 else (v_min / x, v_max / x)
        ha, la = (a_max / x, a_min / x) if x > 0 else (a_min / x, a_max / x)
        v_hi, v_lo, a_hi, a_lo = min(v_hi, hv), max(v_lo, lv), min(a_hi, ha), max(a_lo, la)
        j = min(j, j_max / abs(x))
    return Limits(v_max=v_hi, a_max=a_hi, j_max=j, v_min=v_lo, a_min=a_lo)


@hsettings(200)
@given(strat.collinear_problems(), st.booleans())
def test_collinear_phase_properties(problem: strat.MultiProblem, rest: bool) -> None:
    """Collinear moves: where phase synchronisation is used the path is on the line. Rest to
    rest it is used exactly when the line profile under the projected limits (the most
    restrictive axis for each of v, a, j) is no slower than time synchronisation."""
    starts, targets, lims = problem
    if rest:
        starts = [State(s.p) for s in starts]
        targets = [State(t.p) for t in targets]
    traj = _check_supported(_multi(starts, targets, lims, sync="phase"))
    if traj.sync == "phase":
        assert line_deviation(traj, starts, targets) <= 1e-9
    else:
        assert traj.note
    if rest:
        d = [t.p - s.p for s, t in zip(starts, targets, strict=True)]
        length = math.sqrt(sum(x * x for x in d))
        t_line = plan(State(), State(length), _line_limits(lims, [x / length for x in d])).duration
        t_time = plan_sync(starts, targets, lims, sync="time").duration
        if t_line <= t_time * (1 - 1e-7):
            pytest.fail(f"the line profile ({t_line!r} s) is faster than time sync {t_time!r}")
        elif t_line <= t_time * (1 + 1e-12):
            assert traj.sync == "phase", traj.note
            assert traj.duration == pytest.approx(t_time, rel=1e-9, abs=1e-12)
        elif t_line > t_time * (1 + 1e-7):
            assert traj.sync == "time" and "longer" in traj.note, traj.note


# -- axes that do not move ---------------------------------------------------------------------
@pytest.mark.parametrize("other", [1.0, 0.015625, 1e-3, 100.0])
@pytest.mark.parametrize("sync", ["time", "phase"])
def test_axis_at_rest_on_its_target_waits(other: float, sync: str) -> None:
    """An axis already at rest on its target holds still while the other one moves."""
    lim = Limits(v_max=1.0, a_max=1.0, j_max=1.0)
    starts, targets = [State(5.0), State(0.0)], [State(5.0), State(other)]
    traj = _check(_multi(starts, targets, [lim, lim], sync=sync))
    assert traj.duration == pytest.approx(plan(starts[1], targets[1], lim).duration, rel=1e-9)
    still = traj.sample(np.linspace(0.0, traj.duration, 101))
    assert np.all(still.p[0] == 5.0) or np.abs(still.p[0] - 5.0).max() <= 1e-12


def test_zero_distance_from_rest_to_a_velocity() -> None:
    """From rest to a moving target state at the same position: not a zero-length profile
    (Ruckig: 4.2042575780 s). Found by test_sync_properties."""
    lim = Limits(v_max=1.0, a_max=1.0, j_max=1.0)
    start, target = State(3.0), State(3.0, 0.3)
    check_profile(plan(start, target, lim), start, target, lim)
    start, target = State(0.0), State(0.0, -1.0)
    prof = plan(start, target, lim)
    check_profile(prof, start, target, lim)
    assert prof.duration == pytest.approx(4.204257578045853, rel=1e-9)
    traj = _check(_multi([State(0.0, -1.0), start], [State(0.0, -1.0), target], [lim, lim]))
    assert traj.duration >= prof.duration - 1e-9


@pytest.mark.parametrize("d", [1.1754943508222875e-38, 1e-300, 5e-324, 1e-30])
def test_tiny_rest_to_rest_distance(d: float) -> None:
    """Found by test_rest_to_rest_properties: sub-1e-30 distances raised 'no time-optimal
    profile found'."""
    lim = Limits(v_max=1.0, a_max=1.0, j_max=1.0)
    prof = plan(State(0.0), State(d), lim)
    check_profile(prof, State(0.0), State(d), lim)


def test_slowing_an_axis_that_starts_at_its_acceleration_limit(
    sync_oracle: RuckigSyncOracle,
) -> None:
    """Found by re-planning a synchronised group mid-motion (test_otg): axis 0 (at a_min,
    heading for v_min) cannot be stretched from 53.2545 s to 53.5001 s, so the group took
    64.41 s. Ruckig: 53.50011757793531 s."""
    lims = [
        Limits(
            v_max=10.0**1.25,
            a_max=10.0**-0.5,
            j_max=10.0**-1.5,
            v_min=-17.78279410038923,
            a_min=-0.31622776601683794,
        ),
        Limits(v_max=10.0**0.25, a_max=1.0, j_max=0.1, v_min=-13.33521432163324, a_min=-1.0),
    ]
    starts = [
        State(p=652.7922715935051, v=-4.148970205260042, a=-0.31622776601683794),
        State(p=95.63815752350388, v=1.7782794100389228, a=0.0),
    ]
    targets = [State(p=1.0, v=-17.78279410038923), State(p=1.0, v=-13.33521432163324)]
    fixed = plan_fixed_duration(starts[0], targets[0], lims[0], 53.50011757793532)
    assert fixed is not None
    case = _multi(starts, targets, lims)
    answer = sync_oracle.solve(case)
    traj = _check(case, answer)
    assert traj.duration == pytest.approx(answer.duration, rel=1e-9)


def test_sweep_failure_fixed_duration_gap(sync_oracle: RuckigSyncOracle) -> None:
    """Found by ``tools/compare_ruckig.py --sync time --dofs 3 --seed 7`` (1 of 40,000, also
    with --sync discrete): the third axis takes 4.2 s and 4.3 s but not 4.23 s or the 4.2348 s
    of the second axis -- 'no common duration found'. Ruckig: 4.234822549534073 s."""
    starts = [
        State(p=-4.031305011141628, v=-0.15237971160159225, a=1.8566393105328975),
        State(p=-0.3463320381609333, v=0.7666271794863102, a=-0.31125761426833015),
    ]
    targets = [
        State(p=0.5257118885189559, v=0.3252063166666088, a=0.0),
        State(p=0.8817582513508193, v=0.0, a=-0.05160150687461862),
    ]
    lims = [
        Limits(v_max=13.977805503023436, a_max=0.9492725718822553, j_max=3.094974032722264),
        Limits(v_max=13.48138343337871, a_max=10.78813116616918, j_max=0.1714669066215505),
    ]
    for t in (4.2, 4.23, 4.234822549534073, 4.3):
        prof = plan_fixed_duration(starts[1], targets[1], lims[1], t)
        assert prof is not None, t
        assert prof.duration == pytest.approx(t, abs=1e-9)
    for dt in (None, DT):
        case = _multi(starts, targets, lims, dt=dt)
        answer = sync_oracle.solve(case)
        traj = _check(case, answer)
        assert traj.duration == pytest.approx(answer.duration, rel=1e-9, abs=1e-9)


def test_one_axis_sync_equals_plan_near_an_accelerating_target() -> None:
    """Found by re-planning a group mid-motion (test_otg): near a target at v_max with a > 0
    the state has an 'inevitable overshoot' (v + a^2/(2 j) > v_max), yet it reaches the target
    first. ``plan`` knows (0.1874 s, the rest of the original profile); ``plan_sync`` braked
    first (7.31 s, like Ruckig), so the group re-plan took 7.31 s instead of 0.1875 s."""
    lim = Limits(v_max=1.0, a_max=1.0, j_max=1.0)
    start = State(p=-0.17055250748267714, v=0.8225901216255916, a=0.8923720373601371)
    target = State(p=0.0, v=1.0, a=1.0)
    single = plan(start, target, lim)
    check_profile(single, start, target, lim, start_inside=False)
    assert single.duration < 0.19
    traj = plan_sync([start], [target], [lim])
    assert traj.independent_min_durations[0] == pytest.approx(single.duration, rel=1e-9)
    assert traj.duration == pytest.approx(single.duration, rel=1e-9)


# -- fixed-duration shapes found by PLANNING_THOROUGH hypothesis runs ---------------------------
_FOUND: list[tuple[str, list[State], list[State], list[Limits], float | None, str]] = [
    (
        # axis 1 takes Ruckig's step-2 profile: a free acceleration plateau, then a_min
        "free-then-amin",
        [State(0.0, 0.0019764235376052985, -0.5), State(0.0, 0.02421118833566415, -0.5)],
        [State(0.0, 0.0019764235376052985, 0.5), State(0.0, -0.028225798646424792, -0.75)],
        [
            Limits(1.0, 1.0, 10.0**1.5),
            Limits(10.0**-1.5, 1.0, 10.0**1.5),
        ],
        None,
        "free-then-amin",
    ),
    (
        # axis 1: both ramps down with a lowered jerk around a free plateau
        "monotone",
        [State(0.0, 0.0019764235376052985, -0.5), State(0.0, 0.02421118833566415, -0.5)],
        [State(0.0, 0.0019764235376052985, 0.5), State(0.0, -0.02482882069116579, -0.75)],
        [
            Limits(1.0, 1.0, 10.0**1.5),
            Limits(10.0**-1.5, 1.0, 10.0**1.5),
        ],
        None,
        "monotone-free-plateau",
    ),
    (
        # axis 1 starts exactly on its brake boundary toward v_min: no lower jerk, no lower
        # a_min or v_min keeps it safe; a lower a_max alone stretches it to the cycle
        "one-sided",
        [State(0.0, -1.0, 0.0), State(0.0, 1.24999998875, -4.743416487880861)],
        [State(0.0, -1.0, 0.0), State(0.0, -5.0, 0.0)],
        [Limits(1.0, 1.0, 1.0), Limits(10.0, 10.0, 1.0)],
        0.001,
        "vel+a+",
    ),
]


@pytest.mark.parametrize(
    ("starts", "targets", "lims", "dt", "kind"),
    [c[1:] for c in _FOUND],
    ids=[c[0] for c in _FOUND],
)
def test_found_fixed_duration_shapes(
    sync_oracle: RuckigSyncOracle,
    starts: list[State],
    targets: list[State],
    lims: list[Limits],
    dt: float | None,
    kind: str,
) -> None:
    case = _multi(starts, targets, lims, dt=dt)
    answer = sync_oracle.solve(case)
    traj = _check(case, answer)  # the default method (closed forms first) may find another
    assert traj.duration == pytest.approx(answer.duration, rel=1e-9, abs=1e-9)
    # the fallback of the bisection method still needs and finds this shape
    old = plan_sync(case.starts(), case.targets(), case.limits(), dt=dt, method="bisection")
    assert not sync_problems(old, case, answer)
    assert old.profiles[1].kind == kind
    assert old.duration == pytest.approx(traj.duration, rel=0, abs=END_SPREAD_TOL)


def test_replanned_cruise_of_a_long_stretch() -> None:
    """Axis 0 (time-optimal 21 s) is stretched to the other axis' 5177 s by cruising at
    1.96 mm/s; re-planned from its state 5 us later, the cruise velocity must be solved with
    the exact values the phases carry (a distance error of 2.4e-8 m otherwise). Ruckig fails
    this case in its step 2."""
    starts = [State(0.0, 100.0, 0.0), State(0.0, -71.66619641959169, 0.0)]
    targets = [State(0.0, -99.94909241391409, 1.0090350448414473), State(0.0, 10.0**1.125)]
    lims = [
        Limits(100.0, 10.0**0.00390625, 10.0, a_min=-10.090350448414473),
        Limits(10.0**1.125, 10.0**-1.28125, 1.0, v_min=-133.3521432163324),
    ]
    old = _check(_multi(starts, targets, lims))
    t = 1e-9 * old.duration
    mids = [State(s.p, s.v, s.a) for s in old.at(t)]
    new = _check(_multi(mids, targets, lims))
    assert new.duration == pytest.approx(old.duration - t, abs=1e-9)
    # a cruise at a free velocity: solved in closed form (cruise-vp) or by the scan
    assert new.profiles[0].kind in ("cruise-vp", "cruise-sync")
