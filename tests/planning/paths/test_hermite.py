"""Seed 002's Hermite passing-point curve: the angle rule (obtuse / acute / turn-back), the
unspecified cases, continuity, coefficients, arc length and its inverse, bad input."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from motionplc.errors import PlanningError
from motionplc.planning.paths import HermitePath, adaptive_simpson
from tests.planning._strategies import hsettings
from tests.planning.paths._curve_checks import away_from, fd_error, quad_length

R = 50.0  # the seed's prescribed value (Fig. 10 example)


def unit(v: object) -> np.ndarray:
    a = np.asarray(v, dtype=float)
    return a / np.linalg.norm(a)


def left_velocity(h: HermitePath, k: int) -> np.ndarray:
    """P'_{k-1}(1) from the coefficient table (the left limit at passing point k)."""
    a, b, c, _ = np.moveaxis(h.coefficients[k - 1], 1, 0)
    return 3 * a + 2 * b + c


# -- the seed's rule on constructed inputs (seed 002 §9, T1–T5; not patent data) ---------------


def test_t1_straight_through() -> None:
    h = HermitePath([[10, 0], [20, 0]], start=[0, 0], r=R)
    assert h.branches == ("obtuse",)
    assert math.degrees(h.passing_angles[0]) == pytest.approx(180.0)
    np.testing.assert_allclose(h.velocities[1], [50.0, 0.0], atol=1e-12)


def test_t2_right_angle_takes_the_obtuse_branch() -> None:
    h = HermitePath([[10, 0], [10, 10]], start=[0, 0], r=R)
    assert math.degrees(h.passing_angles[0]) == pytest.approx(90.0)
    assert h.branches == ("obtuse",)  # "θ >= 90" includes 90°
    np.testing.assert_allclose(h.velocities[1], 50.0 * unit([1, 1]), atol=1e-12)


def test_t3_acute_60_degrees() -> None:
    h = HermitePath([[10, 0], [5, 8.660254037844386]], start=[0, 0], r=R)
    assert math.degrees(h.passing_angles[0]) == pytest.approx(60.0)
    assert h.branches == ("acute",)
    assert np.linalg.norm(h.velocities[1]) == pytest.approx(75.0)  # r (1 + cos 60°)
    np.testing.assert_allclose(unit(h.velocities[1]), [0.5, 0.8660254037844386], atol=1e-12)


def test_t4_turn_back_velocity_follows_the_rule() -> None:
    S, p1, p2, p3 = (np.array(p, dtype=float) for p in ([0, 0], [10, 0], [0, 0.1], [5, 5]))
    h = HermitePath([p1, p2, p3], start=S, r=R)
    th = h.passing_angles[0]
    assert math.degrees(th) == pytest.approx(0.5729, abs=1e-4)
    assert h.branches == ("turn_back", "acute")
    v1 = h.velocities[1]
    assert np.linalg.norm(v1) == pytest.approx(R * (1 + math.cos(th)), rel=1e-12)
    assert np.linalg.norm(v1) == pytest.approx(99.9975, abs=1e-4)
    assert v1 @ (p2 - p1) == pytest.approx(0.0, abs=1e-9)  # orthogonal to p_{i+1} - p_i
    assert v1 @ (p3 - p1) < 0.0  # pointing away from p_{i+2}
    np.testing.assert_allclose(unit(v1), [-0.0099995, -0.99995], atol=1e-6)
    # the curve really leaves p1 with that velocity and passes through the points
    np.testing.assert_array_equal(h.evaluate(1.0, 1), v1)
    np.testing.assert_allclose(left_velocity(h, 1), v1, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(h.evaluate(h.point_params), [S, p1, p2, p3], atol=1e-12)
    # turning back: just before p1 the curve heads +x, just after it heads -y, then -x
    assert h.evaluate(0.5, 1)[0] > 0 and h.evaluate(1.01, 1)[1] < 0
    assert h.evaluate(1.9, 1)[0] < 0


def test_t5_magnitude_continuous_at_90_direction_jumps_at_threshold() -> None:
    def interior_velocity(angle_deg: float, **kw: float) -> tuple[np.ndarray, str]:
        a = math.radians(angle_deg)
        nxt = [10 + 10 * math.cos(math.pi - a), 10 * math.sin(math.pi - a)]
        h = HermitePath([[0, 0], [10, 0], nxt, [5, 5]], r=R, **kw)
        return h.velocities[1], h.branches[0]

    below, kind_b = interior_velocity(90 - 1e-9)
    above, kind_a = interior_velocity(90 + 1e-9)
    assert (kind_b, kind_a) == ("acute", "obtuse")
    assert np.linalg.norm(below) == pytest.approx(np.linalg.norm(above), rel=1e-9)
    assert np.linalg.norm(above) == pytest.approx(R)
    # around the prescribed angle (default 1°): chord direction vs. the normal
    v_in, k_in = interior_velocity(1.0 + 1e-6)
    v_tb, k_tb = interior_velocity(1.0 - 1e-6)
    assert (k_in, k_tb) == ("acute", "turn_back")
    assert unit(v_in) @ unit(v_tb) < -0.99  # chord towards +y, normal away from (5, 5): a jump
    assert np.linalg.norm(v_in) == pytest.approx(np.linalg.norm(v_tb), rel=1e-9)
    # theta_th is a parameter: with 0.5° the same 0.9999° point is acute again
    _, k_half = interior_velocity(1.0 - 1e-6, theta_th=math.radians(0.5))
    assert k_half == "acute"
    # the threshold itself takes the normal branches ("≥ prescribed angle")
    _, k_eq = interior_velocity(30.0, theta_th=math.radians(30.0) * (1 - 1e-12))
    assert k_eq == "acute"


def test_passing_angles_straight_right_reversal() -> None:
    h = HermitePath([[0, 0], [1, 0], [2, 0], [2, 1], [2, 0.5]], r=1.0)
    np.testing.assert_allclose(np.degrees(h.passing_angles), [180.0, 90.0, 0.0], atol=1e-9)


def test_end_velocities_default_and_given() -> None:
    pts = [[1, 2], [4, 6], [5, 1]]
    S, E = np.array([0.0, 0.0]), np.array([7.0, -3.0])
    h = HermitePath(pts, start=S, end=E, r=R)
    np.testing.assert_allclose(h.velocities[0], R * unit(np.array(pts[0]) - S))
    np.testing.assert_allclose(h.velocities[-1], R * unit(E - np.array(pts[-1])))
    g = HermitePath(pts, start=S, end=E, r=R, v_start=[0, 0], v_end=[1, 2])
    np.testing.assert_array_equal(g.evaluate(0.0, 1), [0.0, 0.0])
    np.testing.assert_allclose(g.evaluate(g.u_end, 1), [1.0, 2.0], atol=1e-12)
    np.testing.assert_array_equal(g.velocities[1:-1], h.velocities[1:-1])


def test_section_numbering_variants_and_fig10_setup() -> None:
    rng = np.random.default_rng(10)
    pts = rng.uniform(0, 500, size=(14, 2))
    a = HermitePath(pts, start=[0, 0], end=[0, 0], r=R)  # variant (A): S = E = (0, 0)
    assert a.sections == 15 and a.coefficients.shape == (15, 2, 4)  # 120 coefficients
    b = HermitePath(pts, r=R)  # variant (B): p1 is the start
    assert b.sections == 13
    assert HermitePath(pts, end=[0, 0], r=R).sections == 14


def test_coefficients_and_section_end_conditions() -> None:
    rng = np.random.default_rng(3)
    h = HermitePath(rng.uniform(-5, 5, size=(7, 2)), r=4.0)
    C = h.coefficients
    for k in range(h.sections):
        a, b, c, d = C[k].T
        P0, P1 = h.points[k], h.points[k + 1]
        V0, V1 = h.velocities[k], h.velocities[k + 1]
        np.testing.assert_allclose(a + b + c + d, P1, atol=1e-9)
        np.testing.assert_allclose(3 * a + 2 * b + c, V1, atol=1e-9)
        np.testing.assert_array_equal(d, P0)
        np.testing.assert_array_equal(c, V0)
        np.testing.assert_allclose(h.evaluate(k + 1.0), P1, atol=1e-9)
        np.testing.assert_array_equal(h.evaluate(float(k)), P0)
        np.testing.assert_array_equal(h.evaluate(float(k), 1), V0)  # shared vector, bitwise
        t = np.linspace(0, 1, 5)
        np.testing.assert_allclose(
            h.evaluate(k + t), np.outer(t**3, a) + np.outer(t**2, b) + np.outer(t, c) + d
        )


def test_3d_with_zero_z_reproduces_2d_and_3d_is_continuous() -> None:
    rng = np.random.default_rng(5)
    p2 = rng.uniform(-3, 3, size=(6, 2))
    p2[3] = p2[1] + [1e-3, 0.0]  # a turn-back in the middle
    h2 = HermitePath(p2, r=2.0)
    h3 = HermitePath(np.column_stack((p2, np.zeros(6))), r=2.0)
    assert h2.branches == h3.branches and "turn_back" in h2.branches
    np.testing.assert_array_equal(h3.coefficients[:, :2], h2.coefficients)
    np.testing.assert_array_equal(h3.coefficients[:, 2], 0.0)
    p3 = np.column_stack((p2, rng.uniform(-1, 1, 6)))
    g = HermitePath(p3, r=2.0)
    for k in range(1, g.sections):
        np.testing.assert_allclose(left_velocity(g, k), g.evaluate(float(k), 1), atol=1e-12)
    np.testing.assert_allclose(g.evaluate(g.point_params), p3, atol=1e-12)


# -- cases the seed leaves open ----------------------------------------------------------------


def test_turn_back_without_a_following_point_turns_away_from_the_previous_side() -> None:
    # p1 is a turn-back and p2 the last point: no p3
    p0, p1, p2 = np.array([0.0, -0.05]), np.array([10.0, 0.0]), np.array([0.0, 0.05])
    h = HermitePath([p0, p1, p2], r=5.0)
    v = h.velocities[1]
    assert h.branches == ("turn_back",)
    assert np.all(np.isfinite(v)) and abs(v @ (p2 - p1)) < 1e-9
    assert v @ (p0 - p1) < 0.0  # away from the side of the previous point
    # the incoming section then stays on p0's side of the line p1 p2 (no crossing)
    d = unit(p2 - p1)
    side = np.array([-d[1], d[0]])
    inc = h.evaluate(np.linspace(0.0, 0.999, 200)) - p1
    assert np.all(np.sign(inc @ side) == np.sign((p0 - p1) @ side))


def test_turn_back_with_collinear_next_point_falls_back() -> None:
    p0, p1, p2 = np.array([0.0, -0.05]), np.array([10.0, 0.0]), np.array([0.0, 0.05])
    p3 = p1 + 2.0 * (p2 - p1)  # on the line p1 p2: no side to turn away from
    h = HermitePath([p0, p1, p2, p3], r=5.0)
    v = h.velocities[1]
    assert h.branches[0] == "turn_back"
    assert abs(v @ (p2 - p1)) < 1e-9 and v @ (p0 - p1) < 0.0


def test_exact_reversal_on_a_line_is_finite() -> None:
    h = HermitePath([[0, 0, 0], [1, 1, 1], [0.5, 0.5, 0.5], [0, 0, 0]], r=1.0)
    assert h.branches[0] == "turn_back"
    v = h.velocities[1]
    assert np.linalg.norm(v) == pytest.approx(2.0)  # r (1 + cos 0)
    assert abs(v @ unit([1, 1, 1])) < 1e-12
    u = np.linspace(0, h.u_end, 301)
    assert all(np.all(np.isfinite(h.evaluate(u, k))) for k in range(4))
    assert math.isfinite(h.length)


def test_one_dimensional_turn_back_stops_at_the_point() -> None:
    h = HermitePath([0.0, 2.0, 1.0, 3.0], r=1.0)
    assert h.dim == 1 and h.branches[0] == "turn_back"
    np.testing.assert_array_equal(h.velocities[1], [0.0])
    assert h.length == pytest.approx(2.0 + 1.0 + 2.0, rel=1e-9)  # monotone pieces


def test_duplicate_points_are_dropped_and_mapped() -> None:
    pts = [[0, 0], [1, 0], [1, 0], [1, 0], [2, 1], [2, 1]]
    h = HermitePath(pts, r=1.0)
    np.testing.assert_array_equal(h.points, [[0, 0], [1, 0], [2, 1]])
    np.testing.assert_array_equal(h.source_index, [0, 1, 4])
    assert np.all(np.isfinite(h.velocities))
    with pytest.raises(PlanningError, match="2 distinct points"):
        HermitePath([[1, 1], [1, 1]])


def test_patent_example_direction_differs_from_the_general_rule() -> None:
    pts = [[0, 0], [4, 1], [8, 0], [9, 4]]  # obtuse angles at p1 and p2
    general = HermitePath(pts, r=R)
    literal = HermitePath(pts, r=R, patent_example_direction=True)
    assert general.branches == literal.branches == ("obtuse", "obtuse")
    np.testing.assert_allclose(general.velocities[1], R * unit([8, 0]))  # p0 -> p2
    np.testing.assert_allclose(literal.velocities[1], R * unit([4, 1]))  # p0 -> p1 (example)
    assert not np.allclose(general.velocities[1:-1], literal.velocities[1:-1])


def test_default_r_is_the_mean_chord() -> None:
    h = HermitePath([[0, 0], [3, 4], [3, 10]])
    assert h.r == pytest.approx(5.5)


# -- arc length ---------------------------------------------------------------------------------


def test_arc_length_against_quadrature_simpson_and_inverse() -> None:
    h = HermitePath([[10, 0], [0, 0.1], [5, 5], [9, 9]], start=[0, 0], r=R)
    ref = quad_length(h, h.point_params)
    assert h.length == pytest.approx(ref, rel=1e-10)
    simpson, err = adaptive_simpson(lambda x: np.linalg.norm(h.evaluate(x, 1), axis=1), 0, 4, 1e-6)
    assert simpson == pytest.approx(h.length, rel=1e-8) and err < 1e-5
    u = np.linspace(0, h.u_end, 57)
    s = h.arc_length(u)
    assert s.shape == (57,) and s[0] == 0.0 and np.all(np.diff(s) > 0)
    for ui, si in zip(u[3::13], s[3::13], strict=True):
        assert si == pytest.approx(quad_length(h, h.point_params, ui), rel=1e-9)
    back = h.u_at_arc_length(s)
    np.testing.assert_allclose(back, u, atol=1e-10)
    assert isinstance(h.arc_length(1.5), float) and isinstance(h.u_at_arc_length(3.0), float)
    assert h.u_at_arc_length(h.length) == pytest.approx(h.u_end, abs=1e-12)
    ss = np.linspace(0, h.length, 1001)
    uu = h.u_at_arc_length(ss)
    assert np.all(np.diff(uu) > 0)
    np.testing.assert_allclose(h.arc_length(uu), ss, atol=1e-12 * h.length)


def exact_length_1d(h: HermitePath) -> float:
    """Arc length of a 1-D curve: the sum of |x(t_j+1) - x(t_j)| between the roots of x'."""
    total = 0.0
    for a, b, c, d in h.coefficients[:, 0]:
        x = np.polynomial.Polynomial([d, c, b, a])
        roots = [r.real for r in x.deriv().roots() if abs(r.imag) < 1e-12 and 0 < r.real < 1]
        ts = [0.0, *sorted(roots), 1.0]
        total += sum(abs(x(t1) - x(t0)) for t0, t1 in zip(ts[:-1], ts[1:], strict=True))
    return total


@pytest.mark.parametrize(
    ("pts", "r"),
    [
        ([[0.0], [4.23792713]], 12.941925703706818),  # r > 3 chords: x' < 0 inside (two kinks)
        ([[0.0], [2.20011957], [0.0]], 3.0),  # turn-back in 1-D: speed 0 at the point
    ],
)
def test_arc_length_exact_where_the_speed_vanishes(pts: list[list[float]], r: float) -> None:
    # regressions: the speed |x'| has kinks there; the table splits at them
    h = HermitePath(pts, r=r)
    assert h.length == pytest.approx(exact_length_1d(h), rel=1e-12)
    s = h.arc_length(np.linspace(0, h.u_end, 201))
    assert np.all(np.diff(s) >= 0)


def test_derivatives_match_finite_differences() -> None:
    h = HermitePath([[0, 0, 0], [1, 2, 0], [3, 1, 1], [2, -1, 2]], r=2.0)
    u = away_from(np.linspace(0, h.u_end, 97), h.point_params, 1e-3)
    for k in range(3):
        assert fd_error(h, u, k) < 1e-7
    p, d1, d2 = h.derivatives(u, 2)
    assert p.shape == d1.shape == d2.shape == (u.size, 3)
    np.testing.assert_array_equal(h.evaluate(u, 3), np.broadcast_to(h.evaluate(u, 3), (u.size, 3)))


# -- bad input ------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("kwargs", "field"),
    [
        ({"points": [[0, 0], [1, math.nan]]}, "points"),
        ({"points": [[0, 0]]}, "points"),
        ({"points": []}, "points"),
        ({"points": [[0, 0], [1, 1, 1]]}, "points"),
        ({"points": [[0, 0], [1, 1]], "start": [0, 0, 0]}, "start"),
        ({"points": [[0, 0], [1, 1]], "r": 0.0}, "r"),
        ({"points": [[0, 0], [1, 1]], "r": -2.0}, "r"),
        ({"points": [[0, 0], [1, 1]], "r": math.inf}, "r"),
        ({"points": [[0, 0], [1, 1]], "theta_th": 0.0}, "theta_th"),
        ({"points": [[0, 0], [1, 1]], "theta_th": 2.0}, "theta_th"),
        ({"points": [[0, 0], [1, 1]], "v_end": [1.0]}, "v_end"),
        ({"points": [[0, 0], [1, 1]], "v_start": [math.nan, 0]}, "v_start"),
    ],
)
def test_bad_input_names_the_field(kwargs: dict[str, object], field: str) -> None:
    pts = kwargs.pop("points")
    with pytest.raises(PlanningError, match=rf"^{field}: "):
        HermitePath(pts, **kwargs)  # type: ignore[arg-type]


def test_bad_evaluation_arguments() -> None:
    h = HermitePath([[0, 0], [1, 1], [2, 0]])
    with pytest.raises(PlanningError, match="^order: .*0..3"):
        h.evaluate(0.5, 4)
    with pytest.raises(PlanningError, match="^u: "):
        h.evaluate(2.5)
    with pytest.raises(PlanningError, match="^u: "):
        h.arc_length(math.nan)
    with pytest.raises(PlanningError, match="^u: "):
        h.u_at_arc_length(h.length * 1.1)
    with pytest.raises(AttributeError):
        h.r = 2.0  # type: ignore[misc]
    with pytest.raises(ValueError):
        h.points[0, 0] = 1.0


# -- properties -------------------------------------------------------------------------------

coord = st.floats(-10.0, 10.0, allow_nan=False)


@st.composite
def passing_points(draw: st.DrawFn) -> np.ndarray:
    dim = draw(st.integers(1, 3))
    n = draw(st.integers(2, 7))
    pts = [draw(st.lists(coord, min_size=dim, max_size=dim)) for _ in range(n)]
    out = []
    for p in pts:  # repeat some points: duplicate consecutive points
        out.extend([p] * draw(st.integers(1, 2)))
    return np.array(out, dtype=float)


@given(passing_points(), st.floats(0.1, 20.0))
@hsettings(40)
def test_property_passes_through_c1_finite_and_length(pts: np.ndarray, r: float) -> None:
    scale = max(1.0, float(np.max(np.abs(pts))))
    gaps = np.linalg.norm(np.diff(pts, axis=0), axis=1)
    if np.all(gaps <= 1e-12 * scale):
        with pytest.raises(PlanningError):
            HermitePath(pts, r=r)
        return
    h = HermitePath(pts, r=r)
    # passes through every input point (duplicates map to the kept one)
    kept = np.searchsorted(h.source_index, np.arange(len(pts)), side="right") - 1
    np.testing.assert_allclose(h.evaluate(kept.astype(float)), pts, atol=1e-9 * scale)
    # C1: left and right velocity agree at every passing point
    for k in range(1, h.sections):
        right = h.evaluate(float(k), 1)
        np.testing.assert_allclose(left_velocity(h, k), right, atol=1e-9 * max(r, scale))
    # finite everywhere
    u = np.linspace(0, h.u_end, 201)
    for k in range(4):
        assert np.all(np.isfinite(h.evaluate(u, k)))
    # arc length consistent with numerical integration, inverse consistent
    # (1-D: the exact length; quad misses the kinks of |x'| where x' changes sign)
    ref = exact_length_1d(h) if h.dim == 1 else quad_length(h, h.point_params)
    assert h.length == pytest.approx(ref, rel=1e-8, abs=1e-12)
    s = h.arc_length(u)
    assert np.all(np.diff(s) >= -1e-12 * h.length)
    np.testing.assert_allclose(h.arc_length(h.u_at_arc_length(s)), s, atol=1e-9 * h.length)
