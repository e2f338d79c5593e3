"""Time-optimal motion along a path: limits on dense resampling, exact cases, robustness, errors."""

from __future__ import annotations

import math

import numpy as np
import pytest

from motionplc.errors import PlanningError
from motionplc.planning.paths import PathTrajectory, plan_path
from tests.planning.paths._topp_checks import worst_ratios
from tests.planning.paths._topp_paths import FuncPath, circle, line, wiggly

TOL = 1e-9


def trapezoid_time(length: float, v: float, a: float, v0: float = 0.0, v1: float = 0.0) -> float:
    """Rest/speed to speed trapezoid on a straight line."""
    L = length
    d_acc = (v * v - v0 * v0) / (2 * a)
    d_dec = (v * v - v1 * v1) / (2 * a)
    if d_acc + d_dec <= L:
        return (v - v0) / a + (v - v1) / a + (L - d_acc - d_dec) / v
    vp = math.sqrt(a * L + (v0 * v0 + v1 * v1) / 2)
    return (vp - v0) / a + (vp - v1) / a


def test_line_equals_the_trapezoid() -> None:
    p = line([0, 0, 0], [1, 2, 0.5])
    tr = plan_path(p, 1.0, 2.0)
    L = p.length
    g = np.abs(np.array([1, 2, 0.5])) / L  # |dq/ds|
    v_s, a_s = 1.0 / g.max(), 2.0 / g.max()
    assert tr.duration == pytest.approx(trapezoid_time(L, v_s, a_s), rel=1e-9)
    r = worst_ratios(tr, 1.0, 2.0)
    assert r["v"] <= 1 + TOL and r["a"] <= 1 + TOL
    # seed 004 §7 item 11: a straight path has VM = min_i V_i / |G_i| everywhere
    assert np.allclose(tr.grid_du_max[:-1], v_s, rtol=1e-9)
    end = tr.at(tr.duration)
    assert np.allclose(end.p, [1, 2, 0.5], atol=1e-12) and end.du == pytest.approx(0, abs=1e-9)


@pytest.mark.parametrize(
    "path, vm, am",
    [
        (circle((0, 0), 0.5), 1.0, 2.0),
        (circle((1, -1), 0.05, turns=2), [0.3, 0.5], [1.0, 3.0]),
        (wiggly(), [1.0, 0.8, 1.5], [2.0, 3.0, 1.0]),
    ],
)
def test_limits_hold_on_dense_resampling(path, vm, am) -> None:
    tr = plan_path(path, vm, am, n_grid=300)
    r = worst_ratios(tr, vm, am)
    assert r["v"] <= 1 + TOL and r["a"] <= 1 + TOL, r
    # the limits are used: the motion is time-optimal, so some limit is reached
    assert max(r.values()) > 0.999
    assert tr.at(tr.duration).u == pytest.approx(path.u_end, abs=1e-12)


def test_path_speed_limit_holds() -> None:
    p = wiggly()
    tr = plan_path(p, 2.0, 4.0, v_path=0.7, n_grid=300)
    r = worst_ratios(tr, 2.0, 4.0, v_path=0.7)
    assert r["v_path"] <= 1 + TOL and r["v_path"] > 0.999 and r["a"] <= 1 + TOL


def test_mvc_is_never_exceeded_and_is_touched() -> None:
    tr = plan_path(wiggly(), 1.0, 2.0, n_grid=300)
    assert np.all(tr.grid_du <= tr.grid_du_max * (1 + 1e-9) + 1e-12)
    inner = slice(20, -20)
    gap = tr.grid_du_max[inner] - tr.grid_du[inner]
    assert np.sum(gap <= 1e-6 * tr.grid_du_max[inner]) >= 3  # switching/touching points


def _cubic_stop_path() -> FuncPath:
    """p(u) = d (u - 1/2)^3 + ...: the path derivative vanishes at u = 1/2 (a standstill point)."""
    d = np.array([1.0, 0.5])
    return FuncPath(
        [
            lambda u: 4 * (u[:, None] - 0.5) ** 3 * d,
            lambda u: 12 * (u[:, None] - 0.5) ** 2 * d,
            lambda u: 24 * (u[:, None] - 0.5) * d,
            lambda u: 24 * np.ones_like(u)[:, None] * d,
        ],
        1.0,
        2,
    )


def _reversal_path() -> FuncPath:
    """p(u) = (u - 1/2)^2 d: out and back, zero derivative at the turning point (a duplicate
    point of a sampled path)."""
    d = np.array([1.0, -2.0, 0.5])
    return FuncPath(
        [
            lambda u: (u[:, None] - 0.5) ** 2 * d,
            lambda u: 2 * (u[:, None] - 0.5) * d,
            lambda u: 2 * np.ones_like(u)[:, None] * d,
            lambda u: 0 * u[:, None] * d,
        ],
        1.0,
        3,
    )


@pytest.mark.parametrize("make", [_cubic_stop_path, _reversal_path])
def test_zero_path_derivative(make) -> None:
    p = make()
    tr = plan_path(p, 0.5, 1.0, n_grid=400)
    assert math.isfinite(tr.duration) and tr.duration > 0
    r = worst_ratios(tr, 0.5, 1.0)
    assert r["v"] <= 1 + TOL and r["a"] <= 1 + TOL
    assert np.allclose(tr.at(tr.duration).p, p.end, atol=1e-12)


def test_reversal_matches_two_rest_to_rest_moves() -> None:
    # out-and-back along a line: the optimum stops at the turning point; each half is a
    # trapezoid on |d|/4 of length (axis 2 limits)
    p = _reversal_path()
    tr = plan_path(p, 0.5, 1.0, n_grid=2000)
    L = 0.25 * np.linalg.norm([1.0, -2.0, 0.5])
    g = 2.0 / np.linalg.norm([1.0, -2.0, 0.5])  # the tightest axis's share of the path speed
    assert tr.duration == pytest.approx(2 * trapezoid_time(L, 0.5 / g, 1.0 / g), rel=2e-3)


def test_nonzero_start_and_end_speed() -> None:
    p = line([0, 0], [2, 0])
    tr = plan_path(p, 1.0, 1.0, v_start=0.5, v_end=0.25)
    # (the switch to braking lies between grid points: first-order discretisation error)
    assert tr.duration == pytest.approx(trapezoid_time(2.0, 1.0, 1.0, 0.5, 0.25), rel=1e-5)
    s = tr.sample([0.0, tr.duration])
    assert s.v[0, 0] == pytest.approx(0.5) and s.v[0, 1] == pytest.approx(0.25, rel=1e-9)
    # a circle entered at speed
    c = circle((0, 0), 0.5)
    tr2 = plan_path(c, 1.0, 2.0, v_start=0.8, n_grid=300)
    assert np.linalg.norm(tr2.at(0.0).v) == pytest.approx(0.8, rel=1e-12)
    r = worst_ratios(tr2, 1.0, 2.0)
    assert r["v"] <= 1 + TOL and r["a"] <= 1 + TOL
    assert tr2.duration < plan_path(c, 1.0, 2.0, n_grid=300).duration


def test_start_speed_above_what_the_path_allows() -> None:
    c = circle((0, 0), 0.5)
    with pytest.raises(PlanningError, match=r"v_start.*allowed \[0, "):
        plan_path(c, 1.0, 2.0, v_start=5.0, n_grid=100)
    with pytest.raises(PlanningError, match=r"v_end.*allowed \[0, "):
        plan_path(line([0, 0], [0.01, 0]), 1.0, 1.0, v_end=0.9, n_grid=100)


@pytest.mark.parametrize("length", [1e-6, 1e4])
def test_very_short_and_very_long_lines(length: float) -> None:
    L = length
    p = line([0, 0, 0], [L, 0, 0])
    tr = plan_path(p, 1.0, 2.0)
    # uniform grid: on the long line the 0.25 m ramps lie inside the first and last 10 m
    # interval (first-order discretisation error, 0.2 %); the short one is exact
    rel = 1e-6 if L < 1 else 3e-3
    assert trapezoid_time(L, 1.0, 2.0) <= tr.duration * (1 + 1e-9)
    assert tr.duration == pytest.approx(trapezoid_time(L, 1.0, 2.0), rel=rel)
    r = worst_ratios(tr, 1.0, 2.0)
    assert r["v"] <= 1 + TOL and r["a"] <= 1 + TOL
    assert tr.at(tr.duration).p[0] == pytest.approx(L, rel=1e-12)


@pytest.mark.parametrize(
    "kwargs, field",
    [
        ({"v_max": [1.0, 1.0, 1.0]}, "v_max"),
        ({"v_max": float("nan")}, r"v_max\[0\]"),
        ({"a_max": 0.0}, r"a_max\[0\]"),
        ({"a_max": [1.0, -2.0]}, r"a_max\[1\]"),
        ({"a_max": float("inf")}, r"a_max\[0\]"),
        ({"j_max": [1.0, 0.0]}, r"j_max\[1\]"),
        ({"v_path": -1.0}, "v_path"),
        ({"v_start": float("nan")}, "v_start"),
        ({"v_end": -0.1}, "v_end"),
        ({"n_grid": 1}, "n_grid"),
        ({"n_grid": 2.5}, "n_grid"),
    ],
)
def test_bad_input_names_the_field(kwargs, field) -> None:
    args = {"v_max": 1.0, "a_max": 1.0} | kwargs
    with pytest.raises(PlanningError, match=field) as exc:
        plan_path(circle((0, 0), 1.0), **args)
    assert "allowed" in str(exc.value) or "must be" in str(exc.value)


def test_bad_path() -> None:
    with pytest.raises(PlanningError, match="path"):
        plan_path("not a path", 1.0, 1.0)  # type: ignore[arg-type]
    nanpath = FuncPath(
        [lambda u: 0 * u[:, None], lambda u: np.where(u > 0.5, np.nan, 1.0)[:, None]] * 2, 1.0, 1
    )
    with pytest.raises(PlanningError, match="not finite"):
        plan_path(nanpath, 1.0, 1.0, n_grid=10)


def test_trajectory_is_immutable_and_at_matches_sample() -> None:
    tr = plan_path(circle((0, 0), 0.5), 1.0, 2.0, n_grid=100)
    assert isinstance(tr, PathTrajectory)
    with pytest.raises(AttributeError):
        tr.duration = 1.0  # type: ignore[misc]
    with pytest.raises(ValueError):
        tr.grid_du[0] = 1.0
    ts = np.linspace(-0.1, tr.duration + 0.1, 37)
    s = tr.sample(ts)
    for k, t in enumerate(ts):
        one = tr.at(t)
        assert np.allclose(one.p, s.p[:, k]) and np.allclose(one.a, s.a[:, k])
        assert one.u == s.u[k] and one.du == s.du[k]
    # p, v, a consistent with finite differences of the samples (smooth inside pieces)
    t = np.linspace(0.3, 0.31, 3)
    s = tr.sample(t)
    assert np.allclose((s.p[:, 2] - s.p[:, 0]) / 0.01, s.v[:, 1], atol=1e-4)


def test_jerk_limited_holds_every_limit_and_is_not_faster_than_second_order() -> None:
    for p, vm, am, jm in [
        (line([0, 0, 0], [1, 2, 0.5]), 1.0, 2.0, 10.0),
        (circle((0, 0), 0.5), 1.0, 2.0, 10.0),
        (wiggly(), [1.0, 0.8, 1.5], [2.0, 3.0, 1.0], [20.0, 10.0, 15.0]),
    ]:
        tr = plan_path(p, vm, am, j_max=jm, n_grid=200)
        assert tr.order == 3
        r = worst_ratios(tr, vm, am, jm)
        assert r["v"] <= 1 + TOL and r["a"] <= 1 + TOL and r["j"] <= 1 + TOL, r
        assert tr.duration >= tr.second_order_duration
        two = plan_path(p, vm, am, n_grid=200)
        # the jerk-limited planner's base runs on its own uniform grid, plan_path's second order
        # on the path's pieces with local refinement: the same optimum to discretisation
        assert tr.second_order_duration == pytest.approx(two.duration, rel=1e-2)
        assert tr.duration >= two.duration * (1 - 1e-3)
        end = tr.at(tr.duration)
        assert np.allclose(end.p, p.end, atol=1e-9) and abs(end.du) < 1e-9
        # continuous path acceleration: no step between neighbouring 0.1 ms samples
        ts = np.arange(0.0, tr.duration, 1e-4)
        s = tr.sample(ts)
        assert np.max(np.abs(np.diff(s.ddu))) < 1e-2 * max(1.0, np.max(np.abs(s.ddu)))


def test_jerk_limited_with_start_and_end_speed() -> None:
    c = circle((0, 0), 0.5)
    tr = plan_path(c, 1.0, 2.0, j_max=10.0, v_start=0.9, v_end=0.9, n_grid=300)
    r = worst_ratios(tr, 1.0, 2.0, 10.0)
    assert r["v"] <= 1 + TOL and r["a"] <= 1 + TOL and r["j"] <= 1 + TOL
    s = tr.sample([0.0, tr.duration])
    assert np.linalg.norm(s.v[:, 0]) == pytest.approx(0.9, rel=1e-9)
    assert np.linalg.norm(s.v[:, 1]) == pytest.approx(0.9, rel=1e-9)
    assert abs(s.ddu[0]) < 1e-9 and abs(s.ddu[1]) < 1e-9


@pytest.mark.parametrize(
    "path, vm, am",
    [
        (circle((0, 0), 0.5), [1.0, 0.7], [2.0, 1.5]),
        (wiggly(), [1.0, 0.8, 1.5], [2.0, 3.0, 1.0]),
        (wiggly(), float("inf"), [2.0, 3.0, 1.0]),
    ],
)
def test_interval_mvc_equals_the_pairwise_minimum(path, vm, am) -> None:
    from motionplc.planning.paths import topp

    n = 300
    lim, _, _, _ = topp._validate(path, vm, am, None, None, 0.0, 0.0, n)
    grid = topp._evaluate_grid(path, n)
    caps = topp._speed_caps(grid, lim)
    C = caps[2 * np.arange(n)[:, None] + np.arange(3)[None, :]]
    A = np.broadcast_to(lim.a_max, (n, path.dim)).copy()
    lines = topp._lines(grid, A, C, np.arange(n))
    fast = topp._interval_mvc(*lines)
    ref = topp._pairwise_mvc(*lines)
    assert np.allclose(np.minimum(fast, 1e300), np.minimum(ref, 1e300), rtol=1e-12, atol=0)


@pytest.mark.parametrize("vs, ve", [(0.3, 0.5), (0.0, 0.5), (0.5, 0.0), (0.6, 0.2)])
def test_jerk_limited_with_unequal_start_and_end_speeds(vs: float, ve: float) -> None:
    c = circle((0, 0), 0.5)
    tr = plan_path(c, 1.0, 2.0, j_max=10.0, v_start=vs, v_end=ve, n_grid=300)
    r = worst_ratios(tr, 1.0, 2.0, 10.0)
    assert r["v"] <= 1 + TOL and r["a"] <= 1 + TOL and r["j"] <= 1 + TOL, r
    s = tr.sample([0.0, tr.duration])
    assert np.linalg.norm(s.v[:, 0]) == pytest.approx(vs, rel=1e-9, abs=1e-12)
    assert np.linalg.norm(s.v[:, 1]) == pytest.approx(ve, rel=1e-9, abs=1e-12)
    assert abs(s.ddu[0]) < 1e-9 and abs(s.ddu[1]) < 1e-9
    assert np.allclose(tr.at(tr.duration).p, c.end, atol=1e-9)
    # the third-order parameterisation itself, not its fallback (the old smoothed law)
    assert "fallback" not in tr.info
    assert tr.second_order_duration <= tr.duration < 1.25 * tr.second_order_duration
