"""motionplc's planner against Ruckig 0.19.4 (1 DoF, no synchronisation) on random cases.

Ruckig is time-optimal for a single DoF, so on every case it solves our profile must be valid
and no slower: ``ours <= ruckig * (1 + 1e-9) + 1e-9``. See ``tests/planning/_compare.py``.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import pytest
from hypothesis import given

from motionplc.planning import Limits, PlanningError, State, plan
from tests.planning._cases import Case, RuckigOracle, generate_cases
from tests.planning._compare import compare_cases
from tests.planning._strategies import hsettings, inside_problems

pytest.importorskip("ruckig")

SEED = 42


def _run(
    oracle: RuckigOracle,
    summary: Callable[[str], None],
    cases: list[Case],
    *,
    velocity: bool = False,
) -> None:
    res = compare_cases(cases, oracle, velocity=velocity)
    summary(res.summary_line())
    assert res.cases == len(cases)
    assert not res.failures, res.failure_report(10)
    assert res.max_ratio <= 1.0 + 1e-9 or math.isnan(res.max_ratio)


def test_random_nonzero_states(oracle: RuckigOracle, summary: Callable[[str], None]) -> None:
    """20,000 cases with v0, a0, vf, af all non-zero (Ruckig's distributions, seed 42).

    Inputs Ruckig rejects are kept: rejecting them too is fine, planning them must be valid.
    """
    cases = generate_cases(20_000, SEED, nonzero=True, redraw_invalid=False)
    assert all(c.v0 and c.a0 and c.vf and c.af for c in cases)
    _run(oracle, summary, cases)


def test_random_start_outside_limits(oracle: RuckigOracle, summary: Callable[[str], None]) -> None:
    """2,000 cases whose start is outside the limits (|v0| up to 2x v_max, |a0| up to 2x
    a_max, or an inevitable overshoot); targets Ruckig accepts."""
    cases = generate_cases(2_000, SEED + 1, outside_fraction=1.0, oracle=oracle)
    assert all(c.tag.startswith("outside") for c in cases)
    _run(oracle, summary, cases)


def test_random_start_on_braking_boundary(
    oracle: RuckigOracle, summary: Callable[[str], None]
) -> None:
    """2,000 cases cruising at a velocity limit with a residual acceleration 1e-9..1 x a_max
    towards it, on the braking boundary v0 = v_lim - a0|a0|/(2 j_max) (inside or outside by
    an ulp after rounding); targets Ruckig accepts."""
    cases = generate_cases(2_000, SEED + 5, boundary_fraction=1.0, oracle=oracle)
    assert all(c.tag == "boundary" for c in cases)
    _run(oracle, summary, cases)


def test_random_second_order(oracle: RuckigOracle, summary: Callable[[str], None]) -> None:
    """2,000 second-order cases (j_max = inf, zero accelerations), 10 % starting outside."""
    cases = generate_cases(2_000, SEED + 2, order=2, outside_fraction=0.1, oracle=oracle)
    _run(oracle, summary, cases)


def test_random_asymmetric_limits(oracle: RuckigOracle, summary: Callable[[str], None]) -> None:
    """2,000 cases with v_min != -v_max and a_min != -a_max."""
    cases = generate_cases(2_000, SEED + 3, asymmetric_fraction=1.0, oracle=oracle)
    _run(oracle, summary, cases)


def test_random_velocity_interface(oracle: RuckigOracle, summary: Callable[[str], None]) -> None:
    """2,000 ``plan_velocity`` cases against Ruckig's velocity control interface."""
    cases = generate_cases(2_000, SEED + 4, outside_fraction=0.1, oracle=oracle)
    _run(oracle, summary, cases, velocity=True)


@hsettings(300)
@given(inside_problems())
def test_never_slower_than_ruckig(problem: tuple[State, State, Limits]) -> None:
    import ruckig

    start, target, lim = problem
    case = Case.from_problem(start, target, lim)
    answer = RuckigOracle(ruckig).solve(case)
    try:
        ours = plan(start, target, lim).duration
    except PlanningError:
        assert answer.duration is None, f"ruckig found {answer.duration!r} s"
        return
    if answer.duration is not None:
        assert ours <= answer.duration * (1 + 1e-9) + 1e-9, (ours, answer.duration)
