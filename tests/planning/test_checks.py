"""The checker itself: hand-built profiles that break one rule each must be caught."""

from __future__ import annotations

import pytest

from motionplc.planning import Limits, Profile, State
from tests.planning._checks import check_profile, profile_problems, state_is_inside

LIM = Limits(v_max=1.8, a_max=1.2, j_max=1.0)
START = State(0.0, 0.0, 0.0)
TARGET = State(6.0, 0.0, 0.0)
# the time-optimal doc example: 0 -> 6 with v = 1.8, a = 1.2, j = 1
CRUISE = 1.14 / 1.8
GOOD = [(1.2, 1.0), (0.3, 0.0), (1.2, -1.0), (CRUISE, 0.0), (1.2, -1.0), (0.3, 0.0), (1.2, 1.0)]


def _problems(phases: list[tuple[float, ...]], **kw: object) -> list[str]:
    return profile_problems(Profile(START, phases), START, TARGET, LIM, **kw)  # type: ignore[arg-type]


def test_valid_profile_passes() -> None:
    assert _problems(GOOD) == []
    check_profile(Profile(START, GOOD), START, TARGET, LIM)


def test_wrong_end_position_is_caught() -> None:
    bad = list(GOOD)
    bad[3] = (CRUISE + 1e-6, 0.0)
    assert any("end p" in p for p in _problems(bad))
    with pytest.raises(AssertionError, match="end p"):
        check_profile(Profile(START, bad), START, TARGET, LIM)


def test_wrong_end_velocity_and_acceleration_are_caught() -> None:
    bad = [*GOOD[:-1], (1.2 - 1e-3, 1.0)]  # v off by ~5e-7, a by 1e-3
    probs = _problems(bad)
    assert any("end v" in p for p in probs) and any("end a" in p for p in probs)


def test_jerk_outside_the_set_is_caught() -> None:
    bad = list(GOOD)
    bad[0] = (1.2, 1.0 + 1e-9)
    assert any("not in {-j_max, 0, +j_max}" in p for p in _problems(bad))


def test_velocity_over_the_limit_is_caught() -> None:
    lim = Limits(v_max=1.7, a_max=1.2, j_max=1.0)
    probs = profile_problems(Profile(START, GOOD), START, TARGET, lim)
    assert any("v_max" in p for p in probs)
    # ...but not checked from a start outside the limits until the state is back inside
    assert not state_is_inside(State(0.0, 2.0, 0.0), lim)


def test_acceleration_over_the_limit_is_caught() -> None:
    lim = Limits(v_max=1.8, a_max=1.1, j_max=1.0)
    assert any("a_max" in p for p in profile_problems(Profile(START, GOOD), START, TARGET, lim))


def test_jump_is_caught_for_finite_jerk() -> None:
    bad = list(GOOD)
    bad[3] = (CRUISE, 0.0, 0.0, 1.8 + 1e-6)  # re-sets v at the cruise knot
    assert any("v jumps" in p for p in _problems(bad))


def test_wrong_start_is_caught() -> None:
    probs = profile_problems(Profile(State(0.0, 0.1, 0.0), GOOD), START, TARGET, LIM)
    assert any("starts at v" in p for p in probs)


def test_zero_length_segment_is_not_a_segment() -> None:
    # Profile drops empty phases, so the checker never sees them
    assert _problems([(0.0, 1.0), *GOOD]) == []


def test_inside_definition() -> None:
    assert state_is_inside(State(0.0, 1.8, 0.0), LIM)
    assert state_is_inside(State(0.0, 1.8 - 0.5, 1.0), LIM)  # brakes to exactly v_max
    assert not state_is_inside(State(0.0, 1.8 - 0.49, 1.0), LIM)  # overshoot inevitable
    assert not state_is_inside(State(0.0, 0.0, 1.3), LIM)
    assert not state_is_inside(State(0.0, -1.9, 0.0), LIM)
