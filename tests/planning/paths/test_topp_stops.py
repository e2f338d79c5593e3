"""plan_path never plans an impossible motion: exact stops at tangent jumps, the limits held by
differenced samples, sample() the true derivatives of its positions, durations between an
independent feasible bound and toppra, no absolute tolerance that changes small paths."""

from __future__ import annotations

import importlib.util
import math

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from motionplc.errors import PlanningError
from motionplc.planning import Limits, State, plan
from motionplc.planning.paths import (
    Arc,
    CompositePath,
    Line,
    Transition,
    blend_corners,
    blend_polyline,
    plan_path,
    polyline,
)
from motionplc.planning.paths._chain import Chain
from tests.planning.paths._topp_paths import (
    random_blended_polyline,
    random_bspline,
    random_limits,
    random_lines_and_arcs,
)

HAVE_TOPPRA = importlib.util.find_spec("toppra") is not None
DT = 1e-3


def differenced(tr, v_max, a_max, dt: float = DT):
    """Largest |dp|/dt / v_max and |d2p|/dt^2 / a_max over samples every ``dt``, and the
    rounding allowance of the second difference (relative to the smallest a_max)."""
    ts = np.append(np.arange(0.0, tr.duration, dt), tr.duration)
    p = tr.sample(ts).p
    vm = np.broadcast_to(np.asarray(v_max, float), (p.shape[0],))[:, None]
    am = np.broadcast_to(np.asarray(a_max, float), (p.shape[0],))[:, None]
    rv = float(np.max(np.abs(np.diff(p, axis=1)) / np.diff(ts)[None, :] / vm))
    q = p[:, :-1]
    ra = float(np.max(np.abs(np.diff(q, 2, axis=1)) / dt**2 / am)) if q.shape[1] > 2 else 0.0
    floor = 8.0 * np.finfo(float).eps * float(np.abs(p).max()) / dt**2 / float(am.min())
    return rv, ra, floor


def assert_held(tr, v_max, a_max) -> None:
    rv, ra, floor = differenced(tr, v_max, a_max)
    assert rv <= 1.0 + 1e-9, rv
    assert ra <= 1.0 + 1e-9 + floor, (ra, floor)


def speed_at_u(tr, u: float) -> float:
    """The path speed du/dt of the law at the parameter ``u`` (a knot of the law there)."""
    law = tr.law
    k = int(np.argmin(np.abs(law.u - u)))
    assert abs(law.u[k] - u) <= 1e-12 * max(1.0, tr.path.u_end), "no knot at the corner"
    return float(law.du[k])


# -- exact stops -------------------------------------------------------------------------------


def test_reversal_is_a_stop_and_reverse() -> None:
    # the case: 3.000 s and a velocity jump +1 -> -1 before; rest to rest twice is 4 s
    p = polyline([[0, 0], [1, 0], [0, 0]])
    tr = plan_path(p, 1.0, 1.0)
    assert tr.duration == pytest.approx(4.0, rel=1e-9)
    assert tr.info["stops"] == 1.0
    assert speed_at_u(tr, 1.0) == 0.0
    assert_held(tr, 1.0, 1.0)
    # jerk-limited: the same stop, every limit held by differencing
    trj = plan_path(p, 1.0, 1.0, j_max=10.0, n_grid=200)
    assert speed_at_u(trj, 1.0) == 0.0
    assert trj.duration >= 4.0
    assert_held(trj, 1.0, 1.0)


def test_right_angle_and_dropped_duplicate_point_corners_stop() -> None:
    for pts in ([[0, 0], [1, 0], [1, 1]], [[0, 0], [1, 0], [1, 0], [1, 1]]):
        p = polyline(pts)
        tr = plan_path(p, 1.0, 1.0)
        assert tr.duration == pytest.approx(4.0, rel=1e-9)  # two rest-to-rest unit moves
        assert speed_at_u(tr, 1.0) == 0.0
        assert_held(tr, 1.0, 1.0)


def test_stops_forbid_names_the_corner() -> None:
    p = polyline([[0, 0], [1, 0], [1, 2]])
    with pytest.raises(PlanningError, match=r"tangent jump of 90 deg at u=1\.0 \(position \[1\.0"):
        plan_path(p, 1.0, 1.0, stops="forbid")
    with pytest.raises(PlanningError, match="stops='forbid'"):
        plan_path(p, 1.0, 1.0, j_max=5.0, stops="forbid")
    with pytest.raises(PlanningError, match=r"stops: must be 'allow' or 'forbid'"):
        plan_path(p, 1.0, 1.0, stops="maybe")
    # a blended corner is no stop: forbid plans it
    bp = blend_polyline([[0, 0], [1, 0], [1, 2]], Transition.max_corner_deviation(0.05))
    tr = plan_path(bp, 1.0, 1.0, stops="forbid")
    assert tr.info["stops"] == 0.0


def test_needs_stop_corners_of_blend_corners_stop() -> None:
    segs = [
        Line([0, 0], [1, 0]),
        Line([1, 0], [1, 1]),  # 90 deg, kept exact (TransitionMode.NONE)
        Line([1, 1], [2, 1]),  # 90 deg, blended
        Line([2, 1], [1, 1]),  # reversal: a STOP corner
    ]
    bp = blend_corners(
        CompositePath(segs),
        [Transition.none(), Transition.max_corner_deviation(0.01), Transition.corner_distance(0.1)],
    )
    stops = [c for c in bp.corners if c.needs_stop]
    assert len(stops) == 2
    tr = plan_path(bp, [1.0, 0.5], [2.0, 1.0])
    assert tr.info["stops"] == 2.0
    for c in stops:
        assert speed_at_u(tr, c.u_start) == 0.0
    assert_held(tr, [1.0, 0.5], [2.0, 1.0])


corner_points = st.lists(
    st.tuples(st.floats(-1, 1), st.floats(-1, 1), st.floats(-1, 1)), min_size=3, max_size=6
)


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(corner_points, st.lists(st.booleans(), min_size=5, max_size=5), st.integers(0, 2**31))
def test_every_tangent_jump_is_an_exact_stop(points, blend, seed) -> None:
    pts = np.array(points, dtype=float)
    if len(pts) > 3:
        pts = np.insert(pts, 2, pts[1], axis=0)  # a repeated point, dropped by polyline
    try:
        base = polyline(pts)
    except PlanningError:
        return  # all points coincide
    n = len(base.segments) - 1
    trans = [
        Transition.corner_distance(0.2 * min(base.segments[i].length, base.segments[i + 1].length))
        if blend[i % len(blend)]
        else Transition.none()
        for i in range(n)
    ]
    path = blend_corners(base, trans) if n else base
    rng = np.random.default_rng(seed)
    vm, am = random_limits(rng, 3, spread=10.0)
    tr = plan_path(path, vm, am, n_grid=300)
    jumps = [j for j in Chain(path).junctions() if j.stop]
    assert tr.info["stops"] == len(jumps)
    for c in getattr(path, "corners", ()):
        if c.needs_stop:
            assert speed_at_u(tr, c.u_start) == 0.0
    for j in jumps:
        assert speed_at_u(tr, j.u) == 0.0
    assert_held(tr, vm, am)
    assert np.allclose(tr.at(tr.duration).p, path.end, atol=1e-9)


# -- sample() is the derivative of its positions ---------------------------------------------


@pytest.mark.parametrize("make", [random_blended_polyline, random_lines_and_arcs, random_bspline])
def test_sampled_derivatives_match_differenced_positions(make) -> None:
    rng = np.random.default_rng(11)
    path = make(rng)
    vm, am = random_limits(rng, path.dim, spread=10.0)
    tr = plan_path(path, vm, am, n_grid=400)
    dt = 1e-5
    ts = np.linspace(dt, tr.duration - dt, 4001)
    s0, sm, sp = tr.sample(ts), tr.sample(ts - dt), tr.sample(ts + dt)
    v_num = (sp.p - sm.p) / (2 * dt)
    # the velocity is continuous: central differences agree everywhere
    scale_v = np.broadcast_to(np.asarray(vm, float), (path.dim,))[:, None]
    assert np.max(np.abs(v_num - s0.v) / scale_v) < 1e-4
    # acceleration: away from the law's knots (where d2u/dt2 steps)
    knots = tr.law.t
    k = np.searchsorted(knots, ts)
    gap = np.minimum(
        np.abs(ts - knots[np.clip(k - 1, 0, len(knots) - 1)]),
        np.abs(knots[np.clip(k, 0, len(knots) - 1)] - ts),
    )
    inside = gap > 2 * dt
    a_num = (sp.p - 2 * s0.p + sm.p) / dt**2
    scale_a = np.broadcast_to(np.asarray(am, float), (path.dim,))[:, None]
    err = np.abs(a_num - s0.a)[:, inside] / scale_a
    assert inside.sum() > 1000 and np.max(err) < 1e-2
    # and the velocity at a corner stop of a polyline is zero in the samples as well
    p = polyline([[0, 0, 0], [1, 0, 0], [1, 1, 0]])
    tr2 = plan_path(p, 1.0, 1.0)
    k = int(np.argmin(np.abs(tr2.law.u - 1.0)))
    assert tr2.law.t[k] == pytest.approx(2.0, rel=1e-9)  # rest to rest over 1 m, v = a = 1
    s = tr2.sample([tr2.law.t[k]])
    assert np.all(s.v[:, 0] == 0.0) and np.allclose(s.p[:, 0], [1, 0, 0], atol=1e-15)


# -- small scales ------------------------------------------------------------------------------


@pytest.mark.parametrize("scale", [1e-9, 1e-6, 1.0, 1e3])
def test_points_close_together_stay_the_path_at_any_scale(scale: float) -> None:
    pts = scale * np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0]])
    p = polyline(pts)
    assert len(p.segments) == 2  # not merged into one diagonal segment
    tr = plan_path(p, 1.0, 1.0)
    # two rest-to-rest moves of `scale` at a = 1 (v_max not reached when scale < 1)
    one = plan(State(0.0), State(scale), Limits(v_max=1.0, a_max=1.0)).duration
    assert tr.duration == pytest.approx(2 * one, rel=1e-9)
    assert np.allclose(tr.at(tr.duration / 2).p, pts[1], rtol=0, atol=1e-12 * scale)
    # exact repeats are still dropped, whatever the scale
    assert len(polyline(np.insert(pts, 1, pts[1], axis=0)).segments) == 2


def test_composite_gap_is_scale_aware() -> None:
    s = 1e-9
    a = Line([0.0, 0.0], [s, 0.0])
    b = Line([s, 0.5 * s], [s, s])  # a gap of half the segments' length
    with pytest.raises(PlanningError, match=r"segments\[1\]: starts .* gap"):
        CompositePath([a, b])
    CompositePath([a, b], gap_tol=1e-8)  # an explicit tolerance is taken as given
    # rounding-level gaps of ordinary paths still pass
    c = Line([1.0, 0.0], [2.0, 0.0])
    d = Line([2.0 + 1e-15, 0.0], [3.0, 1.0])
    CompositePath([c, d])


# -- durations: an independent feasible bound and toppra --------------------------------------


def _feasible_bound(path, vm, am) -> float:
    """A feasible law computed independently of the planner: rest to rest on every smooth
    piece with a constant speed cap and path acceleration, each term of the chain rule
    ``a = q' ddu + q'' du^2`` given half of every axis' acceleration."""
    chain = Chain(path)
    vm = np.broadcast_to(np.asarray(vm, float), (path.dim,))
    am = np.broadcast_to(np.asarray(am, float), (path.dim,))
    total = 0.0
    for k in range(chain.n_pieces):
        L = float(chain.length[k])
        t = np.linspace(0.0, L, 2001)
        q1, q2 = chain.eval(np.full(len(t), k), t, (1, 2))
        g1 = np.abs(q1).max(axis=0) * (1 + 1e-6)
        g2 = np.abs(q2).max(axis=0) * (1 + 1e-6)
        with np.errstate(divide="ignore"):
            sig = min(
                float(np.min(np.where(g1 > 0, vm / g1, np.inf))),
                float(np.min(np.where(g2 > 0, np.sqrt(am / (2 * g2)), np.inf))),
            )
            acc = float(np.min(np.where(g1 > 0, am / (2 * g1), np.inf)))
        total += plan(State(0.0), State(L), Limits(v_max=sig, a_max=acc)).duration
    return total


@settings(max_examples=12, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.integers(0, 2**31), st.sampled_from(["blends", "arcs", "bspline"]))
def test_durations_between_a_feasible_bound_and_toppra(seed, kind) -> None:
    rng = np.random.default_rng(seed)
    make = {
        "blends": random_blended_polyline,
        "arcs": random_lines_and_arcs,
        "bspline": random_bspline,
    }[kind]
    path = make(rng)
    vm, am = random_limits(rng, path.dim)
    tr = plan_path(path, vm, am, n_grid=300)
    assert "fallback_scale" not in tr.info
    assert tr.duration <= _feasible_bound(path, vm, am)
    assert_held(tr, vm, am)
    if HAVE_TOPPRA:
        from tools.bench_paths import _refined, toppra_on

        ref, _ = toppra_on(path, vm, am, _refined(tr.grid_u, 4))
        # toppra holds its limits only at grid points (it is a lower estimate up to its own
        # discretisation); ours must not be faster than it by more than that, nor much slower.
        # Where a line meets an arc toppra is not: its interpolation scheme imposes the arc's
        # curvature at the junction on the line's last interval too, so it runs slower there
        # (ours holds every limit by differencing above; 0.8 % on some of these paths).
        low = 2e-2 if kind == "arcs" else 2e-3
        assert ref * (1 - low) <= tr.duration <= ref * 1.01


# -- curvature jumps and fine features ---------------------------------------------------------


def _stadium(r: float = 0.3):
    return CompositePath(
        [
            Line([0, 0], [1, 0]),
            Arc.from_center([1, 0], [1, 2 * r], [1, r]),
            Line([1, 2 * r], [0, 2 * r]),
            Arc.from_center([0, 2 * r], [0, 0], [0, r]),
        ]
    )


@pytest.mark.skipif(not HAVE_TOPPRA, reason="toppra not installed")
def test_curvature_jumps_are_switches_not_violations() -> None:
    from tools.bench_paths import _refined, toppra_on

    p = _stadium()
    vm, am = [1.0, 0.8], [2.0, 1.5]
    tr = plan_path(p, vm, am, n_grid=2000)
    ref, _ = toppra_on(p, vm, am, _refined(tr.grid_u, 4))
    assert abs(tr.duration / ref - 1) <= 1e-3  # was ~8 % slower (the jump read as a violation)
    # grid points on every junction
    assert all(np.min(np.abs(tr.grid_u - b)) == 0.0 for b in p.breaks)
    assert_held(tr, vm, am)


def test_fine_blends_get_a_local_grid_not_a_global_scale_down() -> None:
    rng = np.random.default_rng(3)
    pts = np.cumsum(rng.uniform(-2.0, 2.0, (8, 3)), axis=0)
    bp = blend_polyline(pts, Transition.corner_distance(0.002))
    assert bp.u_end > 10.0
    tr = plan_path(bp, 1.0, 2.0)
    assert "fallback_scale" not in tr.info
    assert_held(tr, 1.0, 2.0)
    if HAVE_TOPPRA:
        from tools.bench_paths import _refined, toppra_on

        ref, _ = toppra_on(bp, 1.0, 2.0, _refined(tr.grid_u, 4))
        assert tr.duration <= ref * 1.002  # was 4x to 16x toppra's duration


def test_stop_positions_are_exact() -> None:
    # the path is at the corner, at rest, for an instant: no drift of the position there
    p = polyline([[0, 0], [2, 0], [2, -1], [0, 0]])
    tr = plan_path(p, 1.0, 3.0)
    for u in (2.0, 3.0):
        k = int(np.argmin(np.abs(tr.law.u - u)))
        s = tr.at(float(tr.law.t[k]))
        assert np.allclose(s.p, p.evaluate(u), atol=1e-12) and s.du == 0.0
    assert tr.info["stops"] == 2.0
    assert math.isfinite(tr.duration)
