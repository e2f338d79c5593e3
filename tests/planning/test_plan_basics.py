"""Deterministic cases of the single-axis planner: known durations, edge cases, bad input."""

from __future__ import annotations

import dataclasses
import itertools
import math
from collections.abc import Callable

import numpy as np
import pytest

from motionplc.planning import Limits, PlanningError, Profile, State, plan, plan_velocity
from tests.planning._cases import Case, RuckigOracle, case_start_inside, case_target_valid
from tests.planning._checks import check_profile, state_is_inside

INF = math.inf
NAN = math.nan
DOC_LIMITS = Limits(v_max=1.8, a_max=1.2, j_max=1.0)
ORIGIN = State(0.0, 0.0, 0.0)


def _plan_case(case: Case) -> Profile:
    prof = plan(case.start(), case.target(), case.limits())
    check_profile(
        prof, case.start(), case.target(), case.limits(), start_inside=case_start_inside(case)
    )
    return prof


def _ruckig(oracle: RuckigOracle, case: Case, *, velocity: bool = False) -> float:
    ans = oracle.solve(case, velocity_interface=velocity)
    assert ans.duration is not None, f"ruckig rejected {case}: {ans.error}"
    return ans.duration


def _assert_not_slower(ours: float, theirs: float, case: Case | str) -> None:
    assert ours <= theirs * (1.0 + 1e-9) + 1e-9, f"{ours!r} > ruckig {theirs!r} for {case}"


def _assert_same_duration(ours: float, theirs: float, case: Case | str) -> None:
    """Ruckig is time-optimal for one DoF: a valid profile is neither slower nor faster."""
    assert ours == pytest.approx(theirs, rel=1e-9, abs=1e-12), f"ruckig {theirs!r}: {case}"


# -- documented / published durations --------------------------------------------------------
def test_doc_example(oracle: RuckigOracle) -> None:
    target = State(p=6.0, v=0.0, a=0.0)
    prof = plan(ORIGIN, target, DOC_LIMITS)
    check_profile(prof, ORIGIN, target, DOC_LIMITS)
    # jerk 1.2 s, const accel 0.3 s, jerk 1.2 s to 1.8/s (2.43 covered), twice; 1.14 at 1.8/s
    assert prof.duration == pytest.approx(5.4 + 1.14 / 1.8, rel=1e-12)
    case = Case(0.0, 0.0, 0.0, 6.0, 0.0, 0.0, 1.8, 1.2, 1.0)
    _assert_same_duration(prof.duration, _ruckig(oracle, case), case)
    assert [s.jerk for s in prof.segments] == [1.0, 0.0, -1.0, 0.0, -1.0, 0.0, 1.0]


def test_ruckig_unit_case(oracle: RuckigOracle) -> None:
    """Ruckig's test_target.cpp 'at-time-single-dof': 0 -> 1 with v = a = j = 1 is 3.1748 s."""
    lim = Limits(v_max=1.0, a_max=1.0, j_max=1.0)
    target = State(1.0, 0.0, 0.0)
    prof = plan(ORIGIN, target, lim)
    check_profile(prof, ORIGIN, target, lim)
    # four jerk phases of tau with 2 j tau^3 = 1: T = 4 * 2^(-1/3) = 2^(5/3)
    exact = 2.0 ** (5.0 / 3.0)
    assert prof.duration == pytest.approx(3.1748, abs=1e-4)
    assert abs(prof.duration - exact) < 1e-9
    r = _ruckig(oracle, Case(0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 1.0, 1.0, 1.0))
    assert abs(r - exact) < 1e-9
    # half-way in time is half-way in distance (Ruckig checks 0.5 at 3.1748 / 2)
    assert prof.at(prof.duration / 2).p == pytest.approx(0.5, abs=1e-12)


# Single DoFs taken from Ruckig's test_target_known.cpp (multi-DoF cases split into DoFs; the
# published durations are for the synchronised motion, so each is compared with Ruckig 1-DoF).
# fmt: off
KNOWN_CASES = [
    Case(0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 1.0, 1.0, 2.0),
    Case(0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.6, 1.0, 2.0),
    Case(0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.4, 1.0, 2.0),
    Case(0.0, 0.3, 0.0, 1.0, 0.0, 0.0, 1.0, 1.0, 2.0),
    Case(0.0, 0.3, 0.0, 1.0, 0.0, 0.0, 0.6, 1.0, 2.0),
    Case(0.0, 0.0, 0.0, -1.0, 0.0, 0.0, 0.6, 1.0, 2.0),
    Case(0.0, 0.2, 0.0, -1.0, 0.0, 0.0, 10.0, 10.0, 2.0),
    Case(-1.0, 0.2, 0.0, 1.0, 0.0, 0.0, 0.4, 1.0, 2.0),
    Case(0.3888899206957 - 10e-14, 0.2231429352410215, -0.2987593916455,
         0.5, 0.0, 0.0,
         3.0, 0.5, 0.2),
    Case(-5.54640573838539, 0.824843228617216, -0.119403564898501,
         -1.58293112753888, -1.59453676324393, -0.664429703711622,
         12.9892953062198, 4.2162106624246, 8.03496976453435),
    Case(-2.34195463203842, -1.03863337183304, 0.923861820607788,
         0.383405919465141, 0.0, 0.0,
         3.74169932927481, 10.2906731766853, 0.200684346397485 - 1.0e-14),
    Case(5.10070661762967, -0.749451523227729, 3.04022341347259,
         5.79349604610299, -0.0693173526513803, 0.0,
         1.42398447457303, 2.1869079548297, 0.0848503482861296),
    Case(-6.49539540831446, -1.14327601654428, -1.73501068960131,
         4.4676187540058, -0.544559915133859, -1.31832055647831,
         8.65978706670502, 3.40137210377608, 10.9542353113865),
    Case(6.14883133273172, 0.00991019970085593, -0.584885092422228,
         2.93367894961155, 0.298517792372943, 0.0,
         5.94921088330542, 4.04166318018487, 3.11056302676629),
    Case(-2.02636240900911, -1.00932863927626, 0.0,
         -0.646008452514058, 1.6058847848484, 0.0,
         10.7652253566829, 10.8617860610581, 0.798055744482636 + 9e-12),
    Case(7.06378251402596, 0.436985859305842, -0.80835350359544,
         4.40606827118048, 0.555084596169823, 0.463000173872542,
         7.97399137456765, 5.44679859206862, 7.88958080921515),
    Case(-0.843847405371359, -0.751266816040307, -0.355284934641626,
         -2.91829890043522, -1.24631524923535, 0.0,
         9.54987666746364, 0.473482772614085, 0.764061581326592 - 1e-14),
    Case(-7.962737259350095, -0.8844863500141733, 2.252932547031004,
         -3.547368989678775, 0.0, 0.217242176687843,
         0.1241065584614779, 1.808598147153279, 2.516849090900998 - 3e-15),
    Case(-4.180150148354134, 1.673805463302308, 1.412175048500792,
         2.079913937916431, 0.7537566830764975, -0.8610296259045267,
         1.863775561344568, 9.49223908896113, 8.689575453772798),
    Case(1.030371049895473, -1.435796222257198, 1.892262449040863,
         1.839862681333277, 0.0, -0.07876324073516261,
         0.4357836109021987, 9.002562577262177, 0.09322235504216797),
    Case(-2.660154279239869, 0.9711306630275642, -1.128847905860926,
         2.341421542126605, 0.02507782261105568, 0.0,
         6.260907804906162, 1.119142029086944, 0.1594452521517275 + 3e-15),
    Case(-0.7545929089757601, 0.7490399525818022, -2.368645439140517,
         -8.20567952461017, 0.0, 0.0,
         0.1820021269527196, 11.11168017805234, 0.08166297169205029),
    Case(0.01073568005271233, 0.05656281587106524, -5.348847133445708,
         0.0698, 0.0, 0.0,
         1.0, 7.0, 1000.0),
    Case(-0.7002627264230739, 1.011281770884991, -3.400994300842285,
         0.6283, 0.0, 0.0,
         1.0, 7.0, 1000.0),
    Case(0.0001215, 0.00405, 0.09, 0.1421083333333333087, 0.37, 0.5, 1.0, 0.5, 1.0),
    Case(0.0, 0.0, 0.0, 400.0, 0.0, 0.0, 1800.0, 20000.0, 200000.0),
    Case(0.0, 0.0, 0.0, 40000.0, 0.0, 0.0, 180000.0, 2000000.0, 20000000.0),
    Case(0.02853333333333339, 0.6800000000000006, 7.999999999999993,
         0.0, 0.0, 0.0,
         1.0, 10.0, 100.0 + 1e-14),
    Case(-0.05598571695553641, -0.03425673149926184, -2.720000000000001,
         -0.0534691276550293, 0.0, 0.0,
         0.8500000000000001, 4.25, 85.00000000000001),
    Case(-0.534847776106059, -0.8169926404190487, 1.440254448401435,
         -0.6224863891601563, 0.0, 0.0,
         0.8500000000000001, 4.25, 85.00000000000001),
    Case(0.3736320740840176, -0.60486324450823, -0.4953501898933239,
         0.233562911156468, 0.0, 0.0,
         10.01369296498101, 14.72621077848741, 7.770133554060553,
         v_min=-1.94898305867544, a_min=-0.6829625196960336),
    Case(-0.01919986582215404, -0.3858205249368821, 0.1889847091893647,
         1.297187158009963, 1.160424379732321, 0.4552736879206988,
         14.64378197125325, 0.4552736879216988, 12.15045820314999),
    Case(-19.93333333333424, 10.0, 0.0, 20.0, 10.0, 0.0, 10.0, 15.0, 15.0),
    Case(-0.4983333333333563, 0.25, 0.0, 0.5, 0.25, 0.0, 10.0, 15.0, 5.0),
    Case(0.0, 0.0, 0.0, 0.2, 0.0, 0.0, 10.0, 15.0, 2.0),
    Case(3.62255615705579, -0.06422550797049381, 0.0,
         3.587689540855463, -0.06423623454575711, 0.0,
         0.06423623454575711, 0.261799388, 100.0),
    Case(1.675754445058354, -0.006910864193129071, 0.0,
         1.671344092861895, -0.007006078877926925, 0.0,
         0.007006078877926925, 0.043633231, 100.0),
    Case(2.181127634157466, 0.1207111377965507, -0.3999999999978001,
         2.271916653384632, 0.1187909578397501, 0.0,
         0.1187909578397501, 0.4, 100.0),
    Case(0.1174161453909641, -3.662950284795513e-09, 1.350015487635199e-07,
         0.117416145324707, 0.0, 0.0,
         0.002, 0.01, 0.18),
    Case(0.3003863125814782, 0.01325125623820627, -0.4883877683641483,
         0.3006260070800781, 0.0, 0.0,
         0.002, 0.01, 0.18),
    Case(0.0, 1.0, -2.0, 1.0, 0.5, 0.0, 0.8, 2.0, 5.0),
    Case(1300.0, 1200.0, 0.0, 1400.0, 0.0, 0.0, 800.0, 40000.0, 200000.0),
]
# fmt: on


@pytest.mark.parametrize("case", KNOWN_CASES, ids=lambda c: f"{c.pf}:{c.v_max:.3g}")
def test_ruckig_known_cases(case: Case, oracle: RuckigOracle) -> None:
    assert case_target_valid(case)
    prof = _plan_case(case)
    r = _ruckig(oracle, case)
    if case_start_inside(case):
        _assert_same_duration(prof.duration, r, case)
    else:  # both brake first; ours may only be faster
        _assert_not_slower(prof.duration, r, case)


def test_ruckig_published_outside_durations() -> None:
    """Durations published in Ruckig's tests for 1-DoF starts outside the limits."""
    fast = Case(1300.0, 1200.0, 0.0, 1400.0, 0.0, 0.0, 800.0, 40000.0, 200000.0)
    assert not case_start_inside(fast)
    assert _plan_case(fast).duration <= 0.167347456888558 * (1 + 1e-9)
    assert _plan_case(fast).duration == pytest.approx(0.167347, rel=1e-5)
    brake = Case(0.0, 1.0, -2.0, 1.0, 0.5, 0.0, 0.8, 2.0, 5.0)
    assert not case_start_inside(brake)
    assert _plan_case(brake).duration == pytest.approx(1.6041, rel=1e-4)


# -- geometry edge cases ---------------------------------------------------------------------
def test_negative_distance_mirrors_positive() -> None:
    pos = plan(ORIGIN, State(6.0, 0.0, 0.0), DOC_LIMITS)
    neg = plan(ORIGIN, State(-6.0, 0.0, 0.0), DOC_LIMITS)
    check_profile(neg, ORIGIN, State(-6.0, 0.0, 0.0), DOC_LIMITS)
    assert neg.duration == pytest.approx(pos.duration, rel=1e-12)
    ts = np.linspace(0.0, pos.duration, 97)
    a, b = pos.sample(ts), neg.sample(ts)
    for x, y in zip(a, b, strict=True):
        np.testing.assert_allclose(y, -x, rtol=0, atol=1e-12)


def test_identical_start_and_target_takes_no_time() -> None:
    for s in (ORIGIN, State(2.5, 0.7, 0.0), State(-1.0, -0.4, 0.3)):
        prof = plan(s, s, DOC_LIMITS)
        assert prof.duration == 0.0
        assert prof.end == s
        assert prof.at(0.0)[:3] == (s.p, s.v, s.a)
        check_profile(prof, s, s, DOC_LIMITS)


@pytest.mark.parametrize(
    ("v0", "vf", "a0", "af"),
    [
        (0.5, -0.5, 0.0, 0.0),
        (0.3, 0.6, 0.0, 0.0),
        (-1.0, 1.0, 0.2, -0.1),
        (1.8, 1.8, 0.0, 0.0),
        (0.5, 0.5, 0.3, 0.0),
        (-1.2, 0.0, 0.0, 0.0),
    ],
)
def test_zero_distance_with_velocity(
    v0: float, vf: float, a0: float, af: float, oracle: RuckigOracle
) -> None:
    """Same position, different velocities: the axis must move away and come back."""
    case = Case(1.0, v0, a0, 1.0, vf, af, 1.8, 1.2, 1.0)
    prof = _plan_case(case)
    r = _ruckig(oracle, case)
    if (v0, a0) == (vf, af):  # already there; Ruckig 0.19.4 answers 8.4 s for v0 = vf = v_max
        assert prof.duration == 0.0
        _assert_not_slower(prof.duration, r, case)
    else:
        assert prof.duration > 0.0
        _assert_same_duration(prof.duration, r, case)


@pytest.mark.parametrize("d", [1e-9, -1e-9, 1e-12, 2e-15, 3e-6])
def test_very_short_move(d: float, oracle: RuckigOracle) -> None:
    lim = Limits(v_max=1.0, a_max=1.0, j_max=1.0)
    target = State(d, 0.0, 0.0)
    prof = plan(ORIGIN, target, lim)
    check_profile(prof, ORIGIN, target, lim)
    exact = 4.0 * (abs(d) / 2.0) ** (1.0 / 3.0)  # 2 j tau^3 = |d|, T = 4 tau
    assert prof.duration == pytest.approx(exact, rel=1e-6)
    assert prof.end.p == pytest.approx(d, rel=1e-6, abs=1e-22)
    case = Case(0.0, 0.0, 0.0, d, 0.0, 0.0, 1.0, 1.0, 1.0)
    r = _ruckig(oracle, case)
    if abs(d) >= 1e-12:  # Ruckig returns 0 s below its position precision (1e-17: 0 s)
        assert prof.duration == pytest.approx(r, rel=1e-6)


@pytest.mark.parametrize("d", [1e-15, 1e-17, -1e-300])
def test_differences_below_a_femtometre_count_as_arrived(d: float) -> None:
    """A start within 1e-15 (or a few ulp) of the target is there: re-planning from a profile's
    own end state must not chase rounding errors with extra phases or loops."""
    lim = Limits(v_max=1.0, a_max=1.0, j_max=1.0)
    prof = plan(ORIGIN, State(d, 0.0, 0.0), lim)
    assert prof.duration == 0.0
    assert prof.kind == "arrived"


def test_very_short_move_near_large_position() -> None:
    start = State(1000.0, 0.0, 0.0)
    target = State(1000.0 + 1e-9, 0.0, 0.0)
    prof = plan(start, target, DOC_LIMITS)
    check_profile(prof, start, target, DOC_LIMITS)
    assert prof.duration < 1e-2


RATIOS = (1e-3, 1.0, 1e3)


@pytest.mark.parametrize(("v_max", "a_max", "j_max"), list(itertools.product(RATIOS, repeat=3)))
def test_limit_ratios(v_max: float, a_max: float, j_max: float, oracle: RuckigOracle) -> None:
    # velocities on the scale a unit move reaches, so that the excursions stay near unit size
    vs = min(v_max, math.sqrt(a_max), j_max ** (1 / 3))
    for case in (
        Case(0.0, 0.0, 0.0, 1.0, 0.0, 0.0, v_max, a_max, j_max),
        Case(0.5, -0.5 * vs, 0.0, -0.5, 0.3 * vs, 0.0, v_max, a_max, j_max),
        Case(0.0, 0.2 * vs, 0.0, 1e-3, 0.2 * vs, 0.0, v_max, a_max, j_max),
        Case(0.0, 0.0, 0.0, 1e3, 0.0, 0.0, v_max, a_max, j_max),
    ):
        prof = _plan_case(case)
        _assert_same_duration(prof.duration, _ruckig(oracle, case), case)


@pytest.mark.parametrize(
    "case",
    [
        # v_max/a_max = 1e6 with v0 = -v_max/2: the axis swings ~1.25e8 away to move by 1;
        # double precision cannot meet 1e-8 at that scale and Ruckig fails too
        *(Case(0.5, -500.0, 0.0, -0.5, 300.0, 0.0, 1000.0, 1e-3, j) for j in RATIOS),
        # swings ~1e7 away and back; Ruckig: 30811.449923621658 s
        Case(0.0, -500.0, 0.0, 0.0, -1000.0, 0.0, INF, 0.1, 10**0.5),
        Case(0.0, 500.0, 0.0, 0.0, 1000.0, 0.0, 1e4, 0.1, 10**0.5),
    ],
    ids=str,
)
def test_ill_conditioned_is_valid_or_rejected(case: Case, oracle: RuckigOracle) -> None:
    """Huge excursions: a PlanningError is acceptable where Ruckig fails too; a wrong profile
    never is."""
    try:
        prof = plan(case.start(), case.target(), case.limits())
    except PlanningError:
        assert oracle.solve(case).duration is None
        return
    check_profile(prof, case.start(), case.target(), case.limits())


# -- infinite limits -------------------------------------------------------------------------
@pytest.mark.parametrize(
    "case",
    [
        Case(0.0, 0.0, 0.0, 1.0, 0.0, 0.0, INF, 1.0, 1.0),
        Case(0.0, 0.5, 0.2, 3.0, -0.5, 0.1, INF, 1.0, 1.0),
        Case(0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 1.0, INF, 1.0),
        Case(0.0, 0.5, 0.2, 3.0, -0.5, 0.1, 1.0, INF, 1.0),
        Case(0.0, 0.0, 0.0, 1.0, 0.0, 0.0, INF, INF, 1.0),
        Case(0.0, 0.5, 0.2, -3.0, 0.5, 0.1, INF, INF, 2.0),
    ],
    ids=str,
)
def test_infinite_velocity_or_acceleration_limit(case: Case, oracle: RuckigOracle) -> None:
    prof = _plan_case(case)
    _assert_same_duration(prof.duration, _ruckig(oracle, case), case)


@pytest.mark.parametrize(
    "case",
    [
        Case(0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 1.0, 1.0, INF),  # Ruckig test_target_known: 3.0 s for
        Case(0.0, 0.0, 0.0, 0.3, 0.0, 0.0, 1.0, 1.0, INF),  # 3 DoFs, 2.0 s for this one
        Case(-2.0, 0.5, 0.0, 1.0, -0.2, 0.0, 1.0, 2.0, INF),
        Case(0.0, 0.9, 0.0, 0.0, -0.9, 0.0, 1.0, 0.5, INF),
        Case(0.0, -0.3, 0.0, -4.0, 0.0, 0.0, 2.0, 0.7, INF, v_min=-0.5, a_min=-0.2),
        Case(0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 1.0, INF, INF),
        Case(0.0, 0.0, 0.0, -2.5, 0.0, 0.0, 1.0, INF, INF, v_min=-0.5),
    ],
    ids=str,
)
def test_infinite_jerk_gives_trapezoid(case: Case, oracle: RuckigOracle) -> None:
    """j_max = inf: second order (trapezoidal velocity), all jerks 0, accelerations may jump.

    Ruckig's second-order planner ignores the accelerations (its output has a = a_max at t=0
    whatever current_acceleration says), so these cases use a0 = af = 0.
    """
    prof = _plan_case(case)
    assert all(s.jerk == 0.0 for s in prof.segments)
    _assert_same_duration(prof.duration, _ruckig(oracle, case), case)


def test_first_order_zero_distance_jumps_to_target_velocity() -> None:
    """a_max = j_max = inf: the velocity may jump; at the target position only the jump
    from v0 to vf = 0 is left (found by test_plan_properties.test_infinite_limits)."""
    lim = Limits(v_max=1.0, a_max=INF, j_max=INF)
    for v0 in (-1.0, 0.4):
        start, target = State(0.0, v0, 0.0), State(0.0, 0.0, 0.0)
        prof = plan(start, target, lim)
        check_profile(prof, start, target, lim)
        assert prof.duration == 0.0


def test_infinite_jerk_known_duration() -> None:
    lim = Limits(v_max=1.0, a_max=1.0, j_max=INF)
    prof = plan(ORIGIN, State(1.0, 0.0, 0.0), lim)
    assert prof.duration == pytest.approx(2.0, rel=1e-12)  # triangle: 1 s up, 1 s down
    prof = plan(ORIGIN, State(3.0, 0.0, 0.0), lim)
    assert prof.duration == pytest.approx(4.0, rel=1e-12)  # 1 s up, 2 s cruise, 1 s down


def test_infinite_jerk_rejects_target_acceleration() -> None:
    with pytest.raises(PlanningError, match=r"target\.a"):
        plan(ORIGIN, State(1.0, 0.0, 0.5), Limits(v_max=1.0, a_max=1.0, j_max=INF))


# -- asymmetric limits -----------------------------------------------------------------------
ASYM = dict(v_max=2.0, a_max=1.5, j_max=3.0, v_min=-0.5, a_min=-0.3)


@pytest.mark.parametrize(
    ("p0", "v0", "a0", "pf", "vf", "af"),
    [
        (0.0, 0.0, 0.0, 5.0, 0.0, 0.0),
        (0.0, 0.0, 0.0, -5.0, 0.0, 0.0),
        (1.0, 1.0, 0.5, -2.0, -0.4, 0.1),
        (1.0, -0.4, 0.1, 3.0, 1.5, -0.2),
        (0.0, 1.9, -0.1, 0.0, -0.5, 0.0),
    ],
)
def test_asymmetric_limits(
    p0: float, v0: float, a0: float, pf: float, vf: float, af: float, oracle: RuckigOracle
) -> None:
    case = Case(p0, v0, a0, pf, vf, af, **ASYM)
    assert case_start_inside(case)
    prof = _plan_case(case)
    _assert_same_duration(prof.duration, _ruckig(oracle, case), case)
    # the mirrored problem with reversed limits takes exactly as long
    lim = case.limits()
    mirrored = plan(State(-p0, -v0, -a0), State(-pf, -vf, -af), lim.reversed())
    check_profile(mirrored, State(-p0, -v0, -a0), State(-pf, -vf, -af), lim.reversed())
    assert mirrored.duration == pytest.approx(prof.duration, rel=1e-9)


# -- cruising at the velocity limit ----------------------------------------------------------
@pytest.mark.parametrize("a0", [0.0, 1e-2, 1e-4, 1e-6, 1e-7, 1e-8, 1e-9, 1e-12])
@pytest.mark.parametrize("where", ["on the braking boundary", "at v_max", "1e-12 below v_max"])
@pytest.mark.parametrize("sign", [1.0, -1.0])
def test_cruising_at_the_velocity_limit(
    a0: float, where: str, sign: float, oracle: RuckigOracle
) -> None:
    """A controller cruising at v_max with a residual acceleration (rounding, noise).

    On the braking boundary v0 = v_max - a0^2/(2 j_max) the start is exactly inside; at
    v_max with a tiny a0 it is inside after rounding (a0^2/2 < ulp) or just outside.
    """
    v0 = {
        "on the braking boundary": 1.0 - a0 * a0 / 2.0,
        "at v_max": 1.0,
        "1e-12 below v_max": 1.0 - 1e-12,
    }[where]
    for pf, vf in ((2.0, 0.0), (5.0, 0.5), (2.0, -0.5)):
        case = Case(0.0, sign * v0, sign * a0, sign * pf, sign * vf, 0.0, 1.0, 1.0, 1.0)
        prof = _plan_case(case)
        _assert_not_slower(prof.duration, _ruckig(oracle, case), case)


# Inputs on which the planner failed during development (hypothesis / random exploration),
# each with Ruckig 0.19.4's duration in the comment.
# fmt: off
REGRESSIONS = [
    # start on the lower braking boundary v0 + a0|a0|/(2 j) = v_min (118.17166666666668 s)
    Case(0.0, 0.49, -1.0, 0.0, 1.0, 0.0, 1.0, 1.0, 1.0, v_min=-0.01, a_min=-1.0),
    # at v_min with a tiny negative acceleration (11.549999999999999 s)
    Case(0.0, -0.09999999999998438, -1.768159505474458e-07, 0.0, 1.0, 0.0,
         1.0, 1.0, 1.0, v_min=-0.1, a_min=-10.0),
    # near v_max with a tiny positive acceleration (9.358951370488958 s)
    Case(-0.40146505879147565, 0.0967439134972167, 1.3118877929692966e-05,
         0.4579807689626768, 0.08692414837464939, 0.024695034647224848,
         0.09674391349857311, 0.02494508316545727, 63.44094036132212),
    # (64.39906580884492 s)
    Case(-1.0884015600726096, 0.10719046145182896, 0.001547161552399818,
         2.383067168603554, 0.000620689231133712, 0.0013175156596254558,
         0.10719046327617483, 0.0017386946786568927, 656.0457918866028,
         v_min=-0.11406133703845252, a_min=-0.0018595634880921598),
    # (55.66794396146492 s)
    Case(-1.3650109451641528, 0.013523645271222469, 6.320762783291297e-06,
         -0.8811952893602039, -0.011228268987652876, 0.0003665102632313948,
         0.01352364527143727, 0.001138693610751164, 92.9977926769376),
    # (4.349209806006247 s)
    Case(0.0, 1.3837252947545942, 6.175106017803462e-05, 3.6332654768686217,
         0.2870412530511209, 0.0, 1.3837252952247139, 9.305268713554664, 4.055555357213369),
    # start one ulp above v_max, target far below (66.0 s)
    Case(0.0, 1.0000000000000002, 0.0, 0.0, -10.0, 0.0, 1.0, 1.0, 1.0, v_min=-10.0, a_min=-1.0),
    # target a = 1e-8 at v = v_min, the way there passes v_max: v reached 10.000000004761905
    # (42.00000002 s)
    Case(0.0, -10.0, 0.0, 0.0, -10.0, 1e-08, 10.0, 1.0, 1.0),
]
# fmt: on


@pytest.mark.parametrize("case", REGRESSIONS, ids=str)
def test_regressions(case: Case, oracle: RuckigOracle) -> None:
    prof = _plan_case(case)
    _assert_not_slower(prof.duration, _ruckig(oracle, case), case)


# -- start outside the limits ------------------------------------------------------------------
@pytest.mark.parametrize(
    "case",
    [
        Case(0.0, 2.0, 0.0, 1.0, 0.0, 0.0, 1.0, 1.0, 1.0),  # |v0| > v_max
        Case(0.0, -3.6, 0.5, -8.0, 0.0, 0.0, 1.8, 1.2, 1.0),
        Case(0.0, 0.0, 2.4, 1.0, 0.0, 0.0, 1.8, 1.2, 1.0),  # a0 > a_max
        Case(0.0, 0.0, -2.4, -1.0, 0.3, 0.0, 1.8, 1.2, 1.0),
        Case(0.0, 1.5, 1.1, 4.0, 0.0, 0.0, 1.8, 1.2, 1.0),  # overshoot is inevitable
        Case(0.0, 3.0, 2.0, 0.0, 0.0, 0.0, 1.8, 1.2, 1.0),  # everything at once
        Case(0.0, 2.6, 0.0, 2.0, 0.0, 0.0, 2.0, 1.5, 3.0, v_min=-0.5, a_min=-0.3),
        Case(0.0, -0.8, -0.5, 2.0, 0.0, 0.0, 2.0, 1.5, 3.0, v_min=-0.5, a_min=-0.3),
        Case(0.0, 3.0, 0.0, 2.0, 0.0, 0.0, 1.0, 1.0, INF),  # second order
        Case(0.0, -3.0, 0.0, 2.0, 0.5, 0.0, 1.0, 1.0, INF),
    ],
    ids=str,
)
def test_start_outside_limits(case: Case, oracle: RuckigOracle) -> None:
    assert not case_start_inside(case)
    prof = _plan_case(case)
    _assert_not_slower(prof.duration, _ruckig(oracle, case), case)


# -- Profile queries -------------------------------------------------------------------------
@pytest.fixture(scope="module")
def doc_profile() -> Profile:
    return plan(State(0.5, 0.3, -0.2), State(6.0, 0.4, 0.1), DOC_LIMITS)


def test_at_clamps_to_start_and_end(doc_profile: Profile) -> None:
    prof = doc_profile
    for t in (-1e9, -1.0, -1e-12, 0.0):
        s = prof.at(t)
        assert (s.p, s.v, s.a) == (0.5, 0.3, -0.2)
        assert s.j == prof.segments[0].jerk
    for t in (prof.duration, prof.duration + 1e-12, prof.duration + 10.0, 1e9):
        s = prof.at(t)
        assert (s.p, s.v, s.a, s.j) == (prof.end.p, prof.end.v, prof.end.a, 0.0)
    assert prof.at(-math.inf) == prof.at(0.0)
    assert prof.at(math.inf) == prof.at(prof.duration)


def test_at_matches_knots(doc_profile: Profile) -> None:
    for k in doc_profile.knots:
        s = doc_profile.at(k.t)
        assert s.p == pytest.approx(k.p, abs=1e-12)
        assert s.v == pytest.approx(k.v, abs=1e-12)
        assert s.a == pytest.approx(k.a, abs=1e-12)
        assert s.j == k.j


def test_sample_equals_at(doc_profile: Profile) -> None:
    prof = doc_profile
    knot_ts = [k.t for k in prof.knots]
    ts = np.concatenate(
        [np.linspace(-1.0, prof.duration + 1.0, 2001), knot_ts, [prof.duration, 0.0]]
    )
    got = prof.sample(ts)
    assert all(isinstance(x, np.ndarray) and x.shape == ts.shape for x in got)
    want = np.array([prof.at(float(t)) for t in ts])
    for i, name in enumerate(("p", "v", "a", "j")):
        np.testing.assert_allclose(getattr(got, name), want[:, i], rtol=0, atol=1e-12)
    lst = prof.sample([0.1, 0.2])  # plain sequences work too
    assert lst.p.shape == (2,)


def test_sample_of_zero_duration_profile() -> None:
    s = State(1.0, 0.0, 0.0)
    prof = plan(s, s, DOC_LIMITS)
    got = prof.sample(np.array([-1.0, 0.0, 1.0]))
    np.testing.assert_array_equal(got.p, [1.0, 1.0, 1.0])
    np.testing.assert_array_equal(got.j, [0.0, 0.0, 0.0])


def test_extrema_of_doc_example() -> None:
    prof = plan(ORIGIN, State(6.0, 0.0, 0.0), DOC_LIMITS)
    (p_lo, p_hi), (v_lo, v_hi), (a_lo, a_hi) = prof.extrema()
    assert (p_lo, v_lo) == (0.0, 0.0)
    assert p_hi == pytest.approx(6.0, abs=1e-12)
    assert v_hi == pytest.approx(1.8, abs=1e-12)
    assert (a_lo, a_hi) == (pytest.approx(-1.2, abs=1e-12), pytest.approx(1.2, abs=1e-12))


def test_extrema_includes_interior_position_extremum() -> None:
    # moving forward first, then back: the position peak is inside a segment
    prof = plan(ORIGIN, State(-1.0, 0.0, 0.0), Limits(v_max=2.0, a_max=2.0, j_max=2.0))
    check_profile(prof, ORIGIN, State(-1.0, 0.0, 0.0), Limits(2.0, 2.0, 2.0))
    prof = plan(State(0.0, 1.0, 0.0), State(0.0, 0.0, 0.0), Limits(2.0, 2.0, 2.0))
    (p_lo, p_hi), _, _ = prof.extrema()
    ps = prof.sample(np.linspace(0.0, prof.duration, 20001)).p
    assert p_hi == pytest.approx(ps.max(), abs=1e-8)
    assert p_hi >= ps.max() - 1e-15
    assert p_lo == pytest.approx(min(ps.min(), 0.0), abs=1e-12)


def test_profile_is_immutable(doc_profile: Profile) -> None:
    prof = doc_profile
    with pytest.raises(AttributeError):
        prof.duration = 1.0  # type: ignore[misc]
    with pytest.raises(AttributeError):
        prof.something_new = 1  # type: ignore[attr-defined]
    with pytest.raises(AttributeError):
        del prof.duration
    with pytest.raises(AttributeError):
        prof.segments = ()  # type: ignore[misc]
    assert isinstance(prof.segments, tuple) and isinstance(prof.knots, tuple)
    with pytest.raises(dataclasses.FrozenInstanceError):
        prof.end.p = 0.0  # type: ignore[misc]
    with pytest.raises(dataclasses.FrozenInstanceError):
        DOC_LIMITS.v_max = 2.0  # type: ignore[misc]


# -- bad input ---------------------------------------------------------------------------------
UNIT_TARGET = State(1.0, 0.0, 0.0)


def _plan_with(
    start: State = ORIGIN, target: State = UNIT_TARGET, **lim: float
) -> Callable[[], Profile]:
    def call() -> Profile:
        limits = dict(v_max=1.8, a_max=1.2, j_max=1.0)
        limits.update(lim)
        return plan(start, target, Limits(**limits))

    return call


BAD_INPUTS: list[tuple[str, Callable[[], object], str]] = [
    ("zero v_max", _plan_with(v_max=0.0), "v_max"),
    ("negative v_max", _plan_with(v_max=-1.0), "v_max"),
    ("nan v_max", _plan_with(v_max=NAN), "v_max"),
    ("zero a_max", _plan_with(a_max=0.0), "a_max"),
    ("negative j_max", _plan_with(j_max=-2.0), "j_max"),
    ("-inf j_max", _plan_with(j_max=-INF), "j_max"),
    ("string a_max", _plan_with(a_max="1.0"), "a_max"),  # type: ignore[arg-type]
    ("v_min >= 0", _plan_with(v_min=0.5), "v_min"),
    ("v_min == 0", _plan_with(v_min=0.0), "v_min"),
    ("a_min >= 0", _plan_with(a_min=0.1), "a_min"),
    ("a_min finite, a_max inf", _plan_with(a_max=INF, a_min=-1.0), "a_m"),
    ("all limits infinite", _plan_with(v_max=INF, a_max=INF, j_max=INF), "limits"),
    ("nan start.p", _plan_with(start=State(NAN, 0.0, 0.0)), r"start\.p"),
    ("nan start.v", _plan_with(start=State(0.0, NAN, 0.0)), r"start\.v"),
    ("nan start.a", _plan_with(start=State(0.0, 0.0, NAN)), r"start\.a"),
    ("inf start.p", _plan_with(start=State(INF, 0.0, 0.0)), r"start\.p"),
    ("inf target.p", _plan_with(target=State(INF, 0.0, 0.0)), r"target\.p"),
    ("-inf target.p", _plan_with(target=State(-INF, 0.0, 0.0)), r"target\.p"),
    ("nan target.v", _plan_with(target=State(0.0, NAN, 0.0)), r"target\.v"),
    ("target.v > v_max", _plan_with(target=State(1.0, 1.9, 0.0)), r"target\.v"),
    ("target.v < v_min", _plan_with(target=State(1.0, -0.6, 0.0), v_min=-0.5), r"target\.v"),
    ("target.a > a_max", _plan_with(target=State(1.0, 0.0, 1.3)), r"target\.a"),
    ("target.a < a_min", _plan_with(target=State(1.0, 0.0, -1.3)), r"target\.a"),
    ("v=v_max, a<0", _plan_with(target=State(1.0, 1.8, -0.5)), r"target"),
    ("v=v_min, a>0", _plan_with(target=State(1.0, -1.8, 0.5)), r"target"),
    ("v near v_max, a<<0", _plan_with(target=State(1.0, 1.5, -1.2)), r"target"),
    ("start not a State", lambda: plan((0.0, 0.0, 0.0), ORIGIN, DOC_LIMITS), "start"),  # type: ignore[arg-type]
    ("limits not Limits", lambda: plan(ORIGIN, ORIGIN, (1.0, 1.0, 1.0)), "limits"),  # type: ignore[arg-type]
    ("velocity: v_target > v_max", lambda: plan_velocity(ORIGIN, 2.0, DOC_LIMITS), "v_target"),
    ("velocity: nan v_target", lambda: plan_velocity(ORIGIN, NAN, DOC_LIMITS), "v_target"),
    (
        "velocity: a_target < a_min",
        lambda: plan_velocity(ORIGIN, 0.0, DOC_LIMITS, a_target=-2.0),
        "a_target",
    ),
    (
        "velocity: nan start.a",
        lambda: plan_velocity(State(0.0, 0.0, NAN), 0.0, DOC_LIMITS),
        r"start\.a",
    ),
]


def test_planning_error_is_value_error() -> None:
    assert issubclass(PlanningError, ValueError)
    with pytest.raises(ValueError):
        _plan_with(v_max=-1.0)()


@pytest.mark.parametrize(("what", "call", "field"), BAD_INPUTS, ids=[b[0] for b in BAD_INPUTS])
def test_bad_input_raises_planning_error(what: str, call: Callable[[], object], field: str) -> None:
    with pytest.raises(PlanningError, match=field) as info:
        call()
    msg = str(info.value)
    # the message also states the allowed range or requirement, not just the field name
    assert any(w in msg for w in ("must", "allowed", "range", "needs", "cannot", "[", "(")), msg


def test_bad_limit_message_names_the_range() -> None:
    with pytest.raises(PlanningError, match=r"v_max.*\(0, inf\]"):
        Limits(v_max=-1.0)
    with pytest.raises(PlanningError, match=r"target\.v.*1\.8"):
        plan(ORIGIN, State(1.0, 2.5, 0.0), DOC_LIMITS)


def test_target_on_the_limits_is_fine() -> None:
    """Boundary targets are valid: v = v_max with a = 0, and v = v_max - a^2/(2j) with a > 0."""
    for target in (
        State(5.0, 1.8, 0.0),
        State(5.0, -1.8, 0.0),
        State(5.0, 1.8 - 0.5**2 / 2.0, 0.5),
        State(5.0, 0.0, 1.2),
        State(-5.0, 0.0, -1.2),
    ):
        check_profile(plan(ORIGIN, target, DOC_LIMITS), ORIGIN, target, DOC_LIMITS)


# -- velocity interface ------------------------------------------------------------------------
VELOCITY_CASES = [
    (State(0.0, 0.3, 0.1), -0.5, 0.0, DOC_LIMITS),
    (State(0.0, 0.0, 0.0), 1.8, 0.0, DOC_LIMITS),
    (State(0.0, 1.8, 0.0), -1.8, 0.0, DOC_LIMITS),
    (State(2.0, -0.4, 1.0), 0.5, -0.3, DOC_LIMITS),
    (State(0.0, 0.5, 0.0), 0.5, 0.0, DOC_LIMITS),
    (State(0.0, 0.5, 0.8), 0.5, 0.0, DOC_LIMITS),  # same velocity, must lose the acceleration
    (State(0.0, 0.0, 0.0), 0.0, 0.7, DOC_LIMITS),
    (State(0.0, 0.0, 0.0), 1.0, 0.0, Limits(v_max=2.0, a_max=1.5, j_max=3.0, a_min=-0.3)),
    (State(0.0, 1.0, 0.0), -1.0, 0.0, Limits(v_max=2.0, a_max=1.5, j_max=3.0, a_min=-0.3)),
    (State(0.0, 0.0, 0.0), 1.0, 0.0, Limits(v_max=2.0, a_max=INF, j_max=3.0)),
    (State(0.0, 3.0, 0.0), 1.0, 0.0, DOC_LIMITS),  # start beyond v_max
    (State(0.0, 0.0, 2.5), 1.0, 0.0, DOC_LIMITS),  # start beyond a_max
    (State(0.0, 0.0, -2.5), 1.0, 0.0, DOC_LIMITS),
]


@pytest.mark.parametrize(("start", "vf", "af", "lim"), VELOCITY_CASES)
def test_plan_velocity(
    start: State, vf: float, af: float, lim: Limits, oracle: RuckigOracle
) -> None:
    prof = plan_velocity(start, v_target=vf, limits=lim, a_target=af)
    case = Case.from_problem(start, State(0.0, vf, af), lim)
    inside = state_is_inside(start, lim)
    check_profile(
        prof,
        start,
        State(0.0, vf, af),
        lim,
        start_inside=inside,
        check_target_p=False,
        check_limits=case_target_valid(case),
    )
    r = _ruckig(oracle, case, velocity=True)
    if inside:
        _assert_same_duration(prof.duration, r, case.code_velocity())
    else:
        _assert_not_slower(prof.duration, r, case.code_velocity())


def test_plan_velocity_known_duration() -> None:
    # 0 -> 1.8 with a_max 1.2, j 1: 1.2 s jerk, 0.3 s at a_max, 1.2 s jerk
    prof = plan_velocity(ORIGIN, 1.8, DOC_LIMITS)
    assert prof.duration == pytest.approx(2.7, rel=1e-12)
    assert prof.end.p == pytest.approx(1.8 * 2.7 / 2.0, rel=1e-12)
    assert prof.end.v == pytest.approx(1.8, abs=1e-12)


def test_plan_velocity_infinite_jerk() -> None:
    lim = Limits(v_max=2.0, a_max=1.0, j_max=INF)
    prof = plan_velocity(State(0.0, 0.5, 0.0), 1.5, lim)
    assert prof.duration == pytest.approx(1.0, rel=1e-12)
    assert prof.end.v == pytest.approx(1.5, abs=1e-12)
    assert all(s.jerk == 0.0 for s in prof.segments)


def test_second_order_shape_needing_a_peak_below_the_start_velocity_is_rejected() -> None:
    """Found by hypothesis: v0 = vf = -100, the target 1e-7 ahead (positive). The shape that
    peaks at max(|v0|, |vf|) in the negative direction would need its peak a rounding below
    that (1e-12 relative): it was clamped to a zero-duration profile missing the target by
    1e-7. The answer is the loop over +100 m/s (4000 s)."""
    lim = Limits(v_max=math.inf, a_max=0.1, j_max=math.inf)
    for d, t in ((1e-7, 4000.0), (-1e-7, 0.0)):
        prof = plan(State(0.0, -100.0, 0.0), State(d, -100.0, 0.0), lim)
        check_profile(prof, State(0.0, -100.0, 0.0), State(d, -100.0, 0.0), lim)
        assert prof.duration == pytest.approx(t, abs=1e-8)


def test_velocity_brake_from_far_outside_ends_within_double_precision() -> None:
    """Found by hypothesis: a0 = 3 a_min with j_max = 0.1 brakes for 11,247 s and swings v to
    -1.4e7 m/s and back over 270,486 s; the end velocity is exact to 3e-8 m/s, ten ulp of the
    swing (the profile check allows 1e-14 of the largest |v| on top of its 1e-8)."""
    start = State(0.0, -1.0, -1687.0239755710472)
    lim = Limits(1.0, 10.0**1.75, 0.1, v_min=-1.0, a_min=-562.341325190349)
    prof = plan_velocity(start, -1.0, lim)
    check_profile(prof, start, State(0.0, -1.0, 0.0), lim, start_inside=False, check_target_p=False)
    _, (v_lo, _), _ = prof.extrema()
    assert v_lo < -1e7 and abs(prof.end.v + 1.0) <= 1e-14 * abs(v_lo)
