"""Interpolating clamped B-splines (seed 000 §4.6) against scipy as an oracle; the true
deviation from a reference path against exact distances; the compensation loop (§4.10) on
seed 000's line/arc path; bad input."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from motionplc.errors import PlanningError
from motionplc.planning.paths import (
    Arc,
    BSplinePath,
    CompositePath,
    Line,
    Path,
    adaptive_simpson,
    deviation,
    fit_bspline,
    join,
)
from tests.planning._strategies import hsettings
from tests.planning.paths._curve_checks import away_from, fd_error, quad_length

SEED000 = [
    ([0, 0, 0], 0),
    ([1, 1, 1], [1, -1, -1]),
    ([2, 2, 2], [-1, 1, 1]),
    ([3, 3, 3], 1),
    ([4, 4, 2], 1),
]


def random_points(n: int, dim: int, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    return np.cumsum(rng.uniform(-1, 1, size=(n, dim)) + 0.5, axis=0)


# -- the interpolant ------------------------------------------------------------------------------


@pytest.mark.parametrize("degree", [3, 5])
@pytest.mark.parametrize("dim", [1, 2, 3])
def test_matches_scipy_interpolant(degree: int, dim: int) -> None:
    interp = pytest.importorskip("scipy.interpolate")
    Q = random_points(11, dim, seed=degree * 10 + dim)
    b = BSplinePath.interpolate(Q, degree)
    ref = interp.make_interp_spline(b.point_params, Q, k=degree, t=b.knots)
    np.testing.assert_allclose(b.control_points, ref.c, rtol=1e-10, atol=1e-10)
    u = np.linspace(0, 1, 777)
    for k in range(4):
        want = ref(u, nu=k)
        scale = np.max(np.abs(want))
        np.testing.assert_allclose(b.evaluate(u, k), want, atol=1e-11 * scale)


def test_knots_are_averages_of_chord_parameters() -> None:
    Q = random_points(9, 2, seed=1)
    b = BSplinePath.interpolate(Q, 3)
    chords = np.linalg.norm(np.diff(Q, axis=0), axis=1)
    h = np.concatenate(([0], np.cumsum(chords))) / chords.sum()
    np.testing.assert_allclose(b.point_params, h, rtol=0, atol=1e-15)
    inner = [(h[j] + h[j + 1] + h[j + 2]) / 3 for j in range(1, 9 - 3)]
    np.testing.assert_allclose(b.knots, [0] * 4 + inner + [1] * 4, atol=1e-15)
    c = BSplinePath.interpolate(Q, 3, parametrization="centripetal")
    s = np.concatenate(([0], np.cumsum(np.sqrt(chords))))
    np.testing.assert_allclose(c.point_params, s / s[-1], atol=1e-15)
    g = BSplinePath.interpolate(Q, 3, params=np.linspace(0, 1, 9))
    np.testing.assert_allclose(g.evaluate(np.linspace(0, 1, 9)), Q, atol=1e-12)


def test_duplicate_points_are_dropped_and_mapped() -> None:
    pts = [[0, 0], [1, 0], [1, 0], [2, 1], [3, 0], [3, 0], [4, 2]]
    b = BSplinePath.interpolate(pts, 3)
    np.testing.assert_array_equal(b.source_index, [0, 1, 3, 4, 6])
    np.testing.assert_allclose(b.evaluate(b.point_params), b.points, atol=1e-12)
    assert np.all(np.isfinite(b.evaluate(np.linspace(0, 1, 101), 3)))
    with pytest.raises(PlanningError, match="^points: degree 5 needs at least 6 distinct points"):
        BSplinePath.interpolate(pts, 5)


def test_seed_orientation_data_six_points_degree5_is_one_bezier() -> None:
    # seed 000 §5.5: 6 points and p = 5 give the knot vector {0 x 6, 1 x 6}, no interior knot
    pts = [[0, 0, 0], [1, 0, 0], [2, 1, 0], [3, 2, 1], [4, 2, 3], [5, 2, 2]]
    b = BSplinePath.interpolate(pts, 5)
    np.testing.assert_array_equal(b.knots, [0.0] * 6 + [1.0] * 6)
    u = np.linspace(0, 1, 101)
    bern = np.stack([math.comb(5, i) * u**i * (1 - u) ** (5 - i) for i in range(6)], axis=1)
    np.testing.assert_allclose(b.evaluate(u), bern @ b.control_points, atol=1e-12)
    np.testing.assert_allclose(b.evaluate(b.point_params), pts, atol=1e-12)


@pytest.mark.parametrize("degree", [3, 5])
def test_partition_of_unity_clamped_ends_and_interpolation(degree: int) -> None:
    Q = random_points(10, 3, seed=degree)
    b = BSplinePath.interpolate(Q, degree)
    u = np.linspace(0, 1, 1001)
    N = b.basis(u)
    np.testing.assert_allclose(N.sum(axis=1), 1.0, atol=1e-14)
    assert np.all(N >= -1e-15)
    np.testing.assert_allclose(N @ b.control_points, b.evaluate(u), atol=1e-12)
    for k in (1, 2, 3):
        np.testing.assert_allclose(b.basis(u, k).sum(axis=1), 0.0, atol=1e-8)
        np.testing.assert_allclose(b.basis(u, k) @ b.control_points, b.evaluate(u, k), rtol=1e-9)
    np.testing.assert_allclose(b.evaluate(b.point_params), Q, atol=1e-9)
    np.testing.assert_array_equal(b.evaluate(0.0), b.control_points[0])
    np.testing.assert_allclose(b.evaluate(1.0), Q[-1], atol=1e-12)
    np.testing.assert_allclose(b.evaluate(1.0), b.control_points[-1], atol=1e-12)
    # clamped: end tangents along the first/last control legs
    U, P = b.knots, b.control_points
    np.testing.assert_allclose(b.evaluate(0.0, 1), degree / U[degree + 1] * (P[1] - P[0]))
    np.testing.assert_allclose(
        b.evaluate(1.0, 1), degree / (1 - U[-degree - 2]) * (P[-1] - P[-2]), rtol=1e-10
    )


@pytest.mark.parametrize("degree", [3, 5])
def test_continuity_at_interior_knots(degree: int) -> None:
    b = BSplinePath.interpolate(random_points(12, 2, seed=7), degree)
    inner = np.unique(b.knots[degree + 1 : -degree - 1])
    assert inner.size > 0
    coeffs = b._poly.coeffs  # (spans, p + 1, dim), local power basis
    breaks = b._poly.breaks
    jumps = []
    for k, knot in enumerate(breaks[1:-1], start=1):
        assert knot in inner
        dx = breaks[k] - breaks[k - 1]
        left = [
            sum(
                math.factorial(j) / math.factorial(j - m) * coeffs[k - 1, j] * dx ** (j - m)
                for j in range(m, degree + 1)
            )
            for m in range(degree + 1)
        ]
        right = [math.factorial(m) * coeffs[k, m] for m in range(degree + 1)]
        for m in range(degree):  # C^{p-1}
            scale = max(1.0, float(np.max(np.abs(right[m]))))
            np.testing.assert_allclose(left[m], right[m], atol=1e-8 * scale)
        jumps.append(float(np.max(np.abs(left[degree] - right[degree]))))
    assert max(jumps) > 1e-3  # the p-th derivative does jump (the check can fail)


def test_degree3_overshoots_less_than_degree5() -> None:
    # seed 000 Fig. 13 (qualitative): the quintic is wavier than the cubic
    x = np.arange(10.0)
    z = np.array([0, 0, 0, 0, 1.5, 1.5, 0, 0, 0, 0])
    over = {}
    for p in (3, 5):
        b = BSplinePath.interpolate(np.column_stack((x, np.zeros(10), z)), p)
        zz = b.evaluate(np.linspace(0, 1, 20001))[:, 2]
        over[p] = max(-zz.min(), zz.max() - 1.5)
    assert 0 < over[3] < over[5]


def test_arc_length_exact_on_a_line_and_against_quadrature() -> None:
    line = BSplinePath.interpolate([[0, 0, 0], [0.3, 0.6, 0.9], [1, 2, 3], [1.2, 2.4, 3.6]], 3)
    assert line.length == pytest.approx(math.sqrt(1.2**2 + 2.4**2 + 3.6**2), rel=1e-13)
    b = BSplinePath.interpolate(random_points(9, 3, seed=2), 5)
    breaks = np.unique(b.knots)
    assert b.length == pytest.approx(quad_length(b, breaks), rel=1e-10)
    simpson, err = adaptive_simpson(
        lambda x: np.linalg.norm(b.evaluate(x, 1), axis=1), 0.0, 1.0, 1e-8
    )
    assert simpson == pytest.approx(b.length, rel=1e-8) and err < 1e-6
    u = np.linspace(0, 1, 41)
    s = b.arc_length(u)
    assert s[0] == 0.0 and s[-1] == pytest.approx(b.length, rel=1e-14)
    assert s[17] == pytest.approx(quad_length(b, breaks, u[17]), rel=1e-10)
    np.testing.assert_allclose(b.u_at_arc_length(s), u, atol=1e-10)
    ss = np.linspace(0, b.length, 500)
    np.testing.assert_allclose(b.arc_length(b.u_at_arc_length(ss)), ss, atol=1e-12 * b.length)


# -- deviation --------------------------------------------------------------------------------


class Parametric(Path):
    """A test-local path from vectorised closed forms (independent of the package's paths)."""

    __slots__ = ("_f", "_dim", "_end")

    def __init__(self, funcs: list, dim: int, u_end: float = 1.0) -> None:
        self._f, self._dim, self._end = funcs, dim, u_end

    @property
    def dim(self) -> int:
        return self._dim

    @property
    def u_end(self) -> float:
        return self._end

    def evaluate(self, u: float | np.ndarray, order: int = 0) -> np.ndarray:
        arr = np.asarray(u, dtype=float)
        out = np.atleast_2d(self._f[order](np.atleast_1d(arr)))
        return out[0] if arr.ndim == 0 else out


def x_axis_segment() -> Parametric:
    """The segment from (0, 0) to (1, 0)."""
    return Parametric(
        [
            lambda u: np.column_stack((u, 0 * u)),
            lambda u: np.column_stack((1 + 0 * u, 0 * u)),
            lambda u: np.zeros((u.size, 2)),
            lambda u: np.zeros((u.size, 2)),
        ],
        2,
    )


def test_deviation_is_the_true_distance_not_sample_to_sample() -> None:
    ref = x_axis_segment()
    # a parallel segment 1 mm above: the distance is 0.001 everywhere, although the nearest
    # reference *sample* of a coarse grid (11 points) is up to 0.05 away
    above = Parametric([lambda u: np.column_stack((u, 0 * u + 1e-3))], 2)
    dev = deviation(above, ref, samples=7, reference_samples=11)
    assert dev.max == pytest.approx(1e-3, rel=1e-9)
    # the same segment traversed with another parameter: zero distance although the
    # index-matched distance |C(u_k) - R(u_k)| of the seed is large
    squashed = Parametric([lambda u: np.column_stack((u**2, 0 * u))], 2)
    u = np.linspace(0, 1, 101)
    index_matched = np.max(np.linalg.norm(squashed.evaluate(u) - ref.evaluate(u), axis=1))
    assert index_matched > 0.2
    assert deviation(squashed, ref).max < 1e-12


def test_deviation_maximum_between_samples_is_refined() -> None:
    ref = x_axis_segment()
    h = 0.3
    # y = h sin(pi u^2) peaks at u = 1/sqrt(2), between the 6 samples of u
    bump = Parametric([lambda u: np.column_stack((u, h * np.sin(np.pi * u**2)))], 2)
    dev = deviation(bump, ref, samples=6)
    assert dev.max == pytest.approx(h, rel=1e-12)
    assert dev.u == pytest.approx(1 / math.sqrt(2), abs=1e-5)
    assert dev.v == pytest.approx(dev.point[0], abs=1e-9)
    np.testing.assert_allclose(dev.nearest, [dev.point[0], 0.0], atol=1e-9)


def test_deviation_from_a_circle_against_exact_distances() -> None:
    optimize = pytest.importorskip("scipy.optimize")
    R0 = 2.0
    circle = Parametric(
        [
            lambda v: R0 * np.column_stack((np.cos(v), np.sin(v))),
            lambda v: R0 * np.column_stack((-np.sin(v), np.cos(v))),
            lambda v: -R0 * np.column_stack((np.cos(v), np.sin(v))),
            lambda v: R0 * np.column_stack((np.sin(v), -np.cos(v))),
        ],
        2,
        u_end=1.5 * math.pi,
    )
    ang = np.linspace(0.2, 1.3 * math.pi, 6)
    spline = BSplinePath.interpolate(R0 * np.column_stack((np.cos(ang), np.sin(ang))), 3)
    dev = deviation(spline, circle, breaks=spline.point_params)

    def dist(u: float | np.ndarray) -> np.ndarray:  # exact: the nearest point is on the arc
        return np.abs(np.linalg.norm(np.atleast_2d(spline.evaluate(u)), axis=1) - R0)

    u = np.linspace(0, 1, 200_001)
    d = dist(u)
    i = int(np.argmax(d))
    res = optimize.minimize_scalar(
        lambda x: -dist(x)[0],
        bounds=(u[i - 1], u[i + 1]),
        method="bounded",
        options={"xatol": 1e-12},
    )
    exact = -res.fun
    assert dev.max >= d.max() - 1e-15
    assert dev.max == pytest.approx(exact, rel=1e-9)
    # the per-interval maxima are the exact ones on each interval too
    for k in range(len(spline.point_params) - 1):
        uu = np.linspace(spline.point_params[k], spline.point_params[k + 1], 20001)
        assert dev.interval_max[k] == pytest.approx(dist(uu).max(), rel=1e-6, abs=1e-12)


def test_deviation_of_a_path_from_itself_is_zero() -> None:
    b = BSplinePath.interpolate(random_points(8, 3, seed=4), 3)
    assert deviation(b, b).max < 1e-12


# -- the compensation loop on seed 000's path ---------------------------------------------------


def distance_to_segment(q: np.ndarray, seg: Path) -> np.ndarray:
    """Exact distance from the points ``q`` to a Line or an Arc (closed forms)."""
    if isinstance(seg, Line):
        a, b = seg.start, seg.end
        t = np.clip((q - a) @ (b - a) / ((b - a) @ (b - a)), 0.0, 1.0)
        return np.linalg.norm(q - (a + t[:, None] * (b - a)), axis=1)
    assert isinstance(seg, Arc)
    w = q - seg.center
    x, y = w @ seg.x_axis, w @ seg.y_axis
    perp = w - np.outer(x, seg.x_axis) - np.outer(y, seg.y_axis)
    phi = np.mod(np.arctan2(y, x), 2 * math.pi)
    on_arc = np.sqrt(np.sum(perp**2, axis=1) + (np.hypot(x, y) - seg.radius) ** 2)
    ends = np.minimum(np.linalg.norm(q - seg.start, axis=1), np.linalg.norm(q - seg.end, axis=1))
    return np.where(phi <= seg.angle, on_arc, ends)


def assert_true_deviation(value: float, spline: BSplinePath, ref: CompositePath) -> None:
    """``value`` is the largest exact distance of the spline from the lines and arcs: at least
    the sampled maximum and at most that plus ``max|C'| du / 2`` (the distance to a set is
    1-Lipschitz, so it cannot rise more between samples)."""
    u = np.linspace(0, 1, 20001)
    q = spline.evaluate(u)
    sampled = float(np.max(np.min([distance_to_segment(q, s) for s in ref.segments], axis=0)))
    bound = float(np.max(np.linalg.norm(spline.evaluate(u, 1), axis=1))) * (u[1] - u[0]) / 2
    assert sampled - 1e-12 <= value <= sampled + 1.01 * bound


@pytest.fixture(scope="module")
def seed_path() -> tuple[CompositePath, np.ndarray]:
    ref = join(SEED000)  # the line/arc path of seed 000 §5.1 (arcs by Reading A)
    b = ref.breaks
    apexes = 0.5 * (b[:2] + b[1:3])  # the seed adds the arcs' apexes as pass points
    return ref, np.union1d(b, apexes)


def test_seed000_per_segment_loop_converges(seed_path: tuple[CompositePath, np.ndarray]) -> None:
    ref, params = seed_path
    np.testing.assert_allclose(ref.evaluate(params[1]), [1.5, 0, 0], atol=1e-12)  # apex arc 1
    tol = 0.01
    fit = fit_bspline(ref, tol, params=params, mode="per_segment")
    assert fit.converged and fit.reason == "converged"
    assert fit.deviation.max <= tol
    assert fit.iterations == len(fit.insertions) == len(fit.history) - 1 >= 2
    assert fit.history[0] > 0.4  # the spline through the junctions and apexes misses a lot
    # the spline passes through every passing point, all of them on the reference
    np.testing.assert_allclose(fit.spline.points, ref.evaluate(fit.params), atol=1e-12)
    np.testing.assert_allclose(
        fit.spline.evaluate(fit.spline.point_params), fit.spline.points, atol=1e-9
    )
    assert set(params) <= set(fit.params)
    np.testing.assert_allclose(fit.added_points, ref.evaluate(fit.added_params), atol=1e-12)
    assert len(fit.params) == len(params) + len(fit.added_params)
    # function 2 adds at most one point per interval between passing points per iteration
    current = np.array(params)
    for new in fit.insertions:
        slot = np.searchsorted(current, new)
        assert len(set(slot.tolist())) == len(new)
        current = np.union1d(current, new)
    # the reported deviation is the true one (exact distances to the lines and arcs)
    assert_true_deviation(fit.deviation.max, fit.spline, ref)


def test_seed000_global_loop_stops_when_the_error_grows(
    seed_path: tuple[CompositePath, np.ndarray],
) -> None:
    ref, params = seed_path
    f1 = fit_bspline(ref, 0.01, params=params, mode="global", stop_on_increase=True)
    assert f1.reason == "increased" and not f1.converged
    assert f1.history[-1] > f1.history[-2] == f1.deviation.max  # the last re-fit is dropped
    assert f1.deviation.max <= f1.history[0]
    assert all(len(new) == 1 for new in f1.insertions)  # function 1: one point per iteration
    last = f1.insertions[-1][0]
    assert last not in f1.params and len(f1.added_params) == f1.iterations - 1
    assert_true_deviation(f1.deviation.max, f1.spline, ref)
    # seed 000 §5.6 (qualitative): the per-segment function ends with a smaller error
    f2 = fit_bspline(ref, 0.01, params=params, mode="per_segment", max_iterations=3)
    assert f2.deviation.max < f1.deviation.max


def test_global_loop_converges_on_a_corner() -> None:
    ref = CompositePath([Line([0, 0], [1, 0]), Line([1, 0], [1, 1])])
    fit = fit_bspline(ref, 0.02, mode="global", samples=801, reference_samples=1601)
    assert fit.converged and fit.deviation.max <= 0.02
    assert len(fit.added_params) == fit.iterations > 0
    assert_true_deviation(fit.deviation.max, fit.spline, ref)


# -- bad input ----------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("points", "kwargs", "field"),
    [
        ([[0, 0], [1, math.nan], [2, 0], [3, 1]], {}, "points"),
        ([[0, 0]], {}, "points"),
        ([[0, 0], [1, 1, 1], [2, 0], [3, 1]], {}, "points"),
        ([[0, 0], [1, 1], [2, 0]], {}, "points"),  # degree 3 needs 4 points
        ([[0, 0], [1, 1], [2, 0], [3, 1]], {"degree": 5}, "points"),
        ([[0, 0], [1, 1], [2, 0], [3, 1]], {"degree": 4}, "degree"),
        ([[0, 0], [1, 1], [2, 0], [3, 1]], {"degree": 2}, "degree"),
        ([[0, 0], [1, 1], [2, 0], [3, 1]], {"degree": True}, "degree"),
        ([[0, 0], [1, 1], [2, 0], [3, 1]], {"parametrization": "foo"}, "parametrization"),
        ([[0, 0], [1, 1], [2, 0], [3, 1]], {"params": [0, 0.5, 0.4, 1]}, "params"),
        ([[0, 0], [1, 1], [2, 0], [3, 1]], {"params": [0, 0.5, 1]}, "params"),
        ([[0, 0], [1, 1], [2, 0], [3, 1]], {"params": [0.1, 0.2, 0.5, 1]}, "params"),
    ],
)
def test_bad_interpolation_input(points: object, kwargs: dict[str, object], field: str) -> None:
    with pytest.raises(PlanningError, match=rf"^{field}: "):
        BSplinePath.interpolate(points, **kwargs)  # type: ignore[arg-type]


def test_bad_spline_and_fit_input() -> None:
    P = [[0, 0], [1, 1], [2, 0], [3, 1]]
    with pytest.raises(PlanningError, match="^knots: .*entries"):
        BSplinePath([0, 0, 0, 0, 1, 1, 1], P, 3)
    with pytest.raises(PlanningError, match="^knots: must be clamped"):
        BSplinePath([0, 0, 0, 0.1, 1, 1, 1, 1], P, 3)
    with pytest.raises(PlanningError, match="^knots: must be finite and non-decreasing"):
        BSplinePath([0, 0, 0, 0, 1, 1, math.nan, 1], P, 3)
    ref = CompositePath([Line([0, 0], [1, 0]), Line([1, 0], [1, 1])])
    for tol in (0.0, -1.0, math.nan, math.inf):
        with pytest.raises(PlanningError, match=r"^tolerance: must be in \(0.0, inf\)"):
            fit_bspline(ref, tol)
    with pytest.raises(PlanningError, match="^degree: must be 3 or 5"):
        fit_bspline(ref, 0.1, degree=4)
    with pytest.raises(PlanningError, match="^mode: "):
        fit_bspline(ref, 0.1, mode="both")  # type: ignore[arg-type]
    with pytest.raises(PlanningError, match=r"^params: .*\[0, 2\.0\]"):
        fit_bspline(ref, 0.1, params=[0, 3.0])
    b = BSplinePath.interpolate(P, 3)
    with pytest.raises(PlanningError, match="^reference: dimension"):
        deviation(b, join(SEED000))
    with pytest.raises(PlanningError, match="^breaks: "):
        deviation(b, ref, breaks=[0.0, 0.7, 0.5, 1.0])
    with pytest.raises(PlanningError, match="^order: "):
        b.evaluate(0.5, 4)
    with pytest.raises(PlanningError, match="^u: "):
        b.evaluate(1.5)


# -- properties -------------------------------------------------------------------------------


@st.composite
def spline_data(draw: st.DrawFn) -> tuple[np.ndarray, int]:
    degree = draw(st.sampled_from([3, 5]))
    dim = draw(st.integers(1, 3))
    n = draw(st.integers(degree + 1, degree + 6))
    steps = draw(
        st.lists(st.lists(st.floats(-3, 3), min_size=dim, max_size=dim), min_size=n, max_size=n)
    )
    pts = np.array(steps, dtype=float)
    # keep the chords comparable (no near-duplicate points: see the duplicate policy)
    gaps = np.linalg.norm(np.diff(pts, axis=0), axis=1)
    if gaps.min() < 0.05 * max(gaps.max(), 1e-9):
        pts = np.cumsum(np.abs(pts) + 0.1, axis=0)
    return pts, degree


@given(spline_data())
@hsettings(50)
def test_property_interpolates_clamped_and_derivatives(data: tuple[np.ndarray, int]) -> None:
    Q, p = data
    b = BSplinePath.interpolate(Q, p)
    scale = max(1.0, float(np.max(np.abs(Q))))
    np.testing.assert_allclose(b.evaluate(b.point_params), Q, atol=1e-7 * scale)
    np.testing.assert_allclose(b.evaluate(0.0), Q[0], atol=1e-12 * scale)
    np.testing.assert_allclose(b.evaluate(1.0), Q[-1], atol=1e-7 * scale)
    u = away_from(np.linspace(0.001, 0.999, 61), np.unique(b.knots), 1e-4)
    for k in range(3):
        assert fd_error(b, u, k) < 1e-5
    for k in range(4):
        assert np.all(np.isfinite(b.evaluate(u, k)))
    s = b.arc_length(np.linspace(0, 1, 21))
    assert np.all(np.diff(s) >= 0)
