"""Degenerate planner inputs (issue 11, finding 5): every input has a documented range that is
checked before solving; outside it a PlanningError names the input and the range; inside it the
planner returns a profile with a finite end or a PlanningError, never another exception."""

from __future__ import annotations

import itertools
import math

import pytest
from hypothesis import given
from hypothesis import strategies as st

from motionplc.errors import PlanningError
from motionplc.planning import (
    Limits,
    OnlineGenerator,
    State,
    Tracker,
    plan,
    plan_fixed_duration,
    plan_sync,
    plan_velocity,
)
from motionplc.planning.limits import LIMIT_MAX, LIMIT_MIN, STATE_MAX
from motionplc.planning.plan import MAX_DURATION
from tests.planning._strategies import hsettings

INF = math.inf
NAN = math.nan
LIM = Limits(v_max=1.0, a_max=2.0, j_max=20.0)
BAD_LIMIT_VALUES = [0.0, -1.0, 1e-300, 1e-100, 1e-16, 1e16, 1e300, NAN, "1", None, True]


@pytest.mark.parametrize("field", ["v_max", "a_max", "j_max"])
@pytest.mark.parametrize("value", BAD_LIMIT_VALUES)
def test_limit_outside_its_range_names_field_and_range(field: str, value: object) -> None:
    with pytest.raises(PlanningError, match=rf"Limits\.{field} .*1e-15, 1e\+15\]"):
        Limits(**{field: value})


@pytest.mark.parametrize("field", ["v_min", "a_min"])
@pytest.mark.parametrize("value", [0.0, 1.0, -1e-300, -1e300, NAN, "x"])
def test_minimum_outside_its_range(field: str, value: object) -> None:
    with pytest.raises(PlanningError, match=rf"Limits\.{field} .*-1e\+15, -1e-15\]"):
        Limits(v_max=1.0, a_max=1.0, j_max=1.0, **{field: value})


def test_limits_at_the_range_ends_are_accepted() -> None:
    lim = Limits(LIMIT_MIN, LIMIT_MAX, INF, v_min=-LIMIT_MAX, a_min=-LIMIT_MIN)
    assert lim.v_max == LIMIT_MIN and lim.a_min == -LIMIT_MIN


@pytest.mark.parametrize("value", [1e300, -1e13, INF, -INF, NAN, "0", None])
@pytest.mark.parametrize("where", ["start.p", "start.v", "start.a", "target.p", "target.v"])
def test_state_outside_its_range(where: str, value: object) -> None:
    obj, field = where.split(".")
    start, target = State(), State(0.5)
    kw = {field: value}
    if obj == "start":
        start = State(**{**{"p": 0.0, "v": 0.0, "a": 0.0}, **kw})
    else:
        target = State(**{**{"p": 0.5, "v": 0.0, "a": 0.0}, **kw})
    with pytest.raises(PlanningError, match=rf"{where} must be a finite number in \[-1e\+12"):
        plan(start, target, Limits(v_max=INF, a_max=INF, j_max=1.0))


def test_the_reported_cases() -> None:
    """The inputs of finding 5, each a PlanningError naming the input (before any solving)."""
    cases = [
        (lambda: plan(State(), State(1.0), Limits(1e-300, 1e-300, 1e-300)), "Limits.v_max"),
        (lambda: plan(State(), State(1.0), Limits(1e-100, 1e-100, 1e-100)), "Limits.v_max"),
        (lambda: plan(State(), State(1.0), Limits(1e-300, 1e300, 1e300)), "Limits.v_max"),
        (lambda: plan(State(), State(1.0), Limits(1.0, 1e-300, 1.0)), "Limits.a_max"),
        (lambda: plan_sync(None, [State()], [LIM]), "starts must be a sequence"),  # type: ignore[arg-type]
        (lambda: plan_sync([State()], None, [LIM]), "targets must be a sequence"),  # type: ignore[arg-type]
        (lambda: plan_sync([State()], [State()], LIM), "limits must be a sequence"),  # type: ignore[arg-type]
        (lambda: OnlineGenerator([LIM, LIM], 0.001, sync="bogus"), "sync must be one of"),
        (lambda: OnlineGenerator(LIM, 0.001, sync=None), "sync must be one of"),  # type: ignore[arg-type]
        (lambda: plan_velocity(State(), 1e300, Limits(a_max=1.0, j_max=1.0)), "v_target"),
        (lambda: plan_velocity(State(), INF, Limits(a_max=1.0, j_max=1.0)), "v_target"),
        (lambda: plan_velocity(State(), NAN, Limits(a_max=1.0, j_max=1.0)), "v_target"),
    ]
    for call, text in cases:
        with pytest.raises(PlanningError, match=text):
            call()


def test_plan_velocity_beyond_the_duration_envelope() -> None:
    """A velocity change that would last longer than MAX_DURATION (its end position would run
    away, once even to inf) is rejected; one just inside it plans with a finite end."""
    lim = Limits(a_max=1e-6, j_max=1.0)
    with pytest.raises(PlanningError, match="beyond the supported"):
        plan_velocity(State(), 1e3, lim)
    prof = plan_velocity(State(), 10.0, lim)
    assert prof.duration <= MAX_DURATION and math.isfinite(prof.end.p)
    assert prof.end.v == pytest.approx(10.0, rel=1e-12)


@pytest.mark.parametrize(
    "kw",
    [{"dt": 0.0}, {"dt": 1e-300}, {"dt": 1e300}, {"dt": NAN}, {"dt": INF}, {"dt": "1"}],
)
def test_cycle_times(kw: dict[str, object]) -> None:
    with pytest.raises(PlanningError, match=r"dt must be a number of seconds in \[1e-09, 10000\]"):
        plan_sync([State()], [State(1.0)], [LIM], **kw)  # type: ignore[arg-type]
    with pytest.raises(PlanningError, match="dt must be"):
        OnlineGenerator(LIM, kw["dt"])  # type: ignore[arg-type]
    with pytest.raises(PlanningError, match="dt must be"):
        Tracker(LIM, kw["dt"])  # type: ignore[arg-type]


def test_generator_and_tracker_starts_are_validated() -> None:
    with pytest.raises(PlanningError, match=r"start\.v"):
        OnlineGenerator(LIM, 0.001, start=State(0.0, NAN))
    with pytest.raises(PlanningError, match=r"start\[1\]"):
        OnlineGenerator([LIM, LIM], 0.001, start=[State(), "x"])  # type: ignore[list-item]
    with pytest.raises(PlanningError, match="start must be a sequence"):
        OnlineGenerator([LIM, LIM], 0.001, start=3)  # type: ignore[arg-type]
    with pytest.raises(PlanningError, match=r"start\.p"):
        Tracker(LIM, 0.001, start=State(1e300))


@pytest.mark.parametrize("duration", [-1.0, 1e300, NAN, INF, "1"])
def test_fixed_duration_range(duration: object) -> None:
    with pytest.raises(PlanningError, match=r"T must be a number of seconds in \[0, 10000\]"):
        plan_fixed_duration(State(), State(1.0), LIM, duration)  # type: ignore[arg-type]


def _outcome(call: object) -> str:
    """'ok' (finite duration and end) or 'rejected' (PlanningError); anything else fails."""
    try:
        r = call()  # type: ignore[operator]
    except PlanningError:
        return "rejected"
    assert math.isfinite(r.duration)
    end = r.at(r.duration)
    samples = (end,) if hasattr(end, "p") else end
    assert all(math.isfinite(x) for s in samples for x in (s.p, s.v, s.a))
    return "ok"


def test_corners_of_the_envelope() -> None:
    """Every combination of limits at the range ends and 1, with states at 0, +-1 and the
    range ends: a profile with a finite end or a PlanningError (4,644 calls)."""
    vals = [LIMIT_MIN, 1.0, LIMIT_MAX]
    svals = [0.0, 1.0, -STATE_MAX, STATE_MAX]
    seen = {"ok": 0, "rejected": 0}
    for v, a, j in itertools.product(vals, vals, [*vals, INF]):
        lim = Limits(v, a, j)
        for p0, v0, pf in itertools.product(svals, svals, svals):
            s0 = State(p0, v0, 0.0)
            tg = State(pf)
            seen[_outcome(lambda s0=s0, tg=tg, lim=lim: plan(s0, tg, lim))] += 1
            seen[
                _outcome(lambda s0=s0, lim=lim: plan_velocity(s0, min(lim.v_max, STATE_MAX), lim))
            ] += 1
        seen[
            _outcome(
                lambda lim=lim: plan_sync([State(), State(1.0)], [State(1.0), State()], [lim, lim])
            )
        ] += 1  # noqa: E501
    assert seen["ok"] > 0 and seen["rejected"] > 0


_mag = st.floats(-15.0, 15.0).map(lambda e: 10.0**e)
_state = st.floats(-12.0, 12.0).map(lambda e: 10.0**e) | st.just(0.0)
_sign = st.sampled_from([1.0, -1.0])


@hsettings(300)
@given(
    v=_mag, a=_mag, j=_mag | st.just(INF), ratio=st.floats(0.1, 1.0),
    p0=_state, v0=_state, a0=_state, pf=_state, s=st.tuples(_sign, _sign, _sign, _sign),
)  # fmt: skip
def test_inside_the_envelope_only_profiles_or_planning_errors(
    v: float, a: float, j: float, ratio: float, p0: float, v0: float, a0: float, pf: float,
    s: tuple[float, float, float, float],
) -> None:  # fmt: skip
    lim = Limits(v, a, j, v_min=-max(v * ratio, LIMIT_MIN), a_min=-max(a * ratio, LIMIT_MIN))
    start = State(s[0] * p0, s[1] * v0, s[2] * a0)
    target = State(s[3] * pf)
    _outcome(lambda: plan(start, target, lim))
    _outcome(lambda: plan_velocity(start, s[1] * min(v0, v), lim))
    _outcome(lambda: plan_sync([start, State()], [target, State(1.0)], [lim, LIM]))
