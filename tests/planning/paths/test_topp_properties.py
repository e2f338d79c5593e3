"""Property tests: random spline paths and limits (hypothesis)."""

from __future__ import annotations

import math

import numpy as np
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from motionplc.planning import Limits, State, plan
from motionplc.planning.paths import plan_path
from tests.planning.paths._topp_checks import worst_ratios
from tests.planning.paths._topp_paths import FuncPath


def _poly_path(coef: np.ndarray) -> FuncPath:
    """p(u) = sum_k c_k u^k on [0, 1] (cubic per axis: any shape a short spline piece has)."""
    c = np.asarray(coef)  # (4, dim)
    P = [np.polynomial.polynomial.Polynomial(c[:, d]) for d in range(c.shape[1])]

    def f(k):
        return lambda u: np.stack([p.deriv(k)(u) if k else p(u) for p in P], axis=1)

    return FuncPath([f(0), f(1), f(2), f(3)], 1.0, c.shape[1])


paths = st.integers(1, 3).flatmap(
    lambda dim: st.lists(
        st.floats(-2.0, 2.0, allow_nan=False), min_size=4 * dim, max_size=4 * dim
    ).map(lambda xs, dim=dim: np.array(xs).reshape(4, dim))
)
limit = st.floats(0.2, 5.0)


def _reference_time(p: FuncPath, vm: float, am: float, jm: float | None) -> float:
    """A simple feasible motion: a 1-D profile of u with constant limits chosen so that every
    axis stays within its limits (each term of the chain rule gets its share)."""
    u = np.linspace(0, 1, 4001)
    g1, g2, g3 = (np.abs(p.evaluate(u, k)).max() for k in (1, 2, 3))
    if jm is None:
        sig = min(vm / g1, math.sqrt(am / (2 * g2)) if g2 > 0 else math.inf)
        acc = am / (2 * g1)
        return plan(State(0.0), State(1.0), Limits(v_max=sig, a_max=acc)).duration
    sig = min(
        vm / g1,
        math.sqrt(am / (2 * g2)) if g2 > 0 else math.inf,
        (jm / (3 * g3)) ** (1 / 3) if g3 > 0 else math.inf,
    )
    acc = min(am / (2 * g1), jm / (3 * 3 * g2 * sig) if g2 > 0 else math.inf)
    jrk = jm / (3 * g1)
    return plan(State(0.0), State(1.0), Limits(v_max=sig, a_max=acc, j_max=jrk)).duration


def _moves(c: np.ndarray) -> bool:
    p = _poly_path(c)
    sp = np.linalg.norm(p.evaluate(np.linspace(0, 1, 201), 1), axis=1)
    return bool(sp.max() > 0.05)


@settings(max_examples=20, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(paths.filter(_moves), limit, limit)
def test_second_order_limits_hold_and_beat_the_reference(c, vm, am) -> None:
    p = _poly_path(c)
    tr = plan_path(p, vm, am, n_grid=200)
    r = worst_ratios(tr, vm, am)
    assert r["v"] <= 1 + 1e-9 and r["a"] <= 1 + 1e-9, r
    assert tr.duration <= _reference_time(p, vm, am, None) * (1 + 1e-9)
    assert np.allclose(tr.at(tr.duration).p, p.end, atol=1e-9)


@settings(max_examples=8, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(paths.filter(_moves), limit, limit, st.floats(1.0, 50.0))
def test_jerk_limited_limits_hold_and_beat_the_reference(c, vm, am, jm) -> None:
    p = _poly_path(c)
    tr = plan_path(p, vm, am, j_max=jm, n_grid=150)
    r = worst_ratios(tr, vm, am, jm)
    assert r["v"] <= 1 + 1e-9 and r["a"] <= 1 + 1e-9 and r["j"] <= 1 + 1e-9, r
    assert tr.duration >= tr.second_order_duration
    assert tr.duration <= _reference_time(p, vm, am, jm) * (1 + 1e-9)
