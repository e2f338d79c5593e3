"""Lines, arcs and helices: closed forms against independent checks; constructors; bad input."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import assume, given
from hypothesis import strategies as st

from motionplc.errors import PlanningError
from motionplc.planning.paths import Arc, Helix, Line, PathSegment
from tests.planning._strategies import hsettings
from tests.planning.paths._geom_checks import fd_derivative_error, integrated_length

SQ3 = math.sqrt(3.0)


def check_segment(seg: PathSegment, n: int = 41) -> None:
    """Arc-length parametrisation and derivative consistency of any primitive."""
    u = np.linspace(0.0, seg.u_end, n)
    assert seg.u_end == seg.length
    np.testing.assert_allclose(np.linalg.norm(seg.evaluate(u, 1), axis=1), 1.0, atol=1e-12)
    for k in range(3):
        assert fd_derivative_error(seg, u, k) < 1e-6
    np.testing.assert_allclose(seg.arc_length(u), u)
    assert integrated_length(seg) == pytest.approx(seg.length, rel=1e-11)
    for k in range(4):
        v = seg.evaluate(u, k)
        assert v.shape == (n, seg.dim) and np.all(np.isfinite(v))
        assert seg.evaluate(0.3 * seg.u_end, k).shape == (seg.dim,)
        one = seg.evaluate(np.array([0.3 * seg.u_end]), k)
        np.testing.assert_array_equal(seg.evaluate(0.3 * seg.u_end, k), one[0])
        assert len(seg.derivatives(u, 3)) == 4


# -- lines ---------------------------------------------------------------------------------------


@pytest.mark.parametrize("dim", [1, 2, 3, 6])
def test_line_any_dimension(dim: int) -> None:
    rng = np.random.default_rng(dim)
    p0, p1 = rng.normal(size=dim), rng.normal(size=dim)
    line = Line(p0, p1)
    assert line.dim == dim
    assert line.length == pytest.approx(np.linalg.norm(p1 - p0), rel=1e-15)
    np.testing.assert_allclose(line.start, p0)
    np.testing.assert_allclose(line.end, p1, atol=1e-15)
    np.testing.assert_array_equal(line.evaluate(0.5 * line.length, 2), np.zeros(dim))
    check_segment(line)


def test_line_trim_keeps_direction_and_points() -> None:
    line = Line([0.0, 0.0, 0.0], [3.0, 4.0, 12.0])
    piece = line.trim(2.0, 7.5)
    assert isinstance(piece, Line) and piece.length == pytest.approx(5.5)
    np.testing.assert_allclose(piece.start, line.evaluate(2.0))
    np.testing.assert_allclose(piece.end, line.evaluate(7.5))
    np.testing.assert_allclose(piece.direction, line.direction)


@pytest.mark.parametrize(
    ("args", "field"),
    [
        (([0, 0, 0], [0, 0, 0]), "end"),
        (([0, 0, 0], [1, 0]), "end"),
        (([0, math.nan, 0], [1, 0, 0]), "start"),
        (([0, 0, 0], [1, math.inf, 0]), "end"),
        (([[0, 0]], [1, 0]), "start"),
        (("ab", [1, 0]), "start"),
    ],
)
def test_line_bad_input_names_the_field(args: tuple, field: str) -> None:
    with pytest.raises(PlanningError, match=rf"^{field}:"):
        Line(*args)


def test_bad_parameter_and_order() -> None:
    line = Line([0.0, 0.0], [1.0, 0.0])
    with pytest.raises(PlanningError, match=r"^u:"):
        line.evaluate(1.5)
    with pytest.raises(PlanningError, match=r"^u:"):
        line.evaluate(np.array([0.1, math.nan]))
    with pytest.raises(PlanningError, match=r"^order:"):
        line.evaluate(0.5, 4)
    with pytest.raises(PlanningError, match=r"^u0:"):
        line.trim(-0.1, 0.5)
    with pytest.raises(PlanningError, match=r"^u1:"):
        line.trim(0.5, 0.5)


def test_segments_are_immutable() -> None:
    arc = Arc.from_three_points([1.0, 0.0], [0.0, 1.0], [-1.0, 0.0])
    with pytest.raises(AttributeError):
        arc._r = 2.0  # type: ignore[misc]
    with pytest.raises(ValueError):
        arc.center[0] = 5.0
    line = Line([0.0, 0.0], [1.0, 0.0])
    with pytest.raises(ValueError):
        line.direction[0] = 5.0


# -- arcs ----------------------------------------------------------------------------------------


def test_seed000_arcs_reading_a() -> None:
    """Seed 000 §6.1 (Reading A: the arc's vector is the start tangent)."""
    a1 = Arc.from_tangent([0, 0, 0], [1, 1, 1], [1, -1, -1])
    a2 = Arc.from_tangent([1, 1, 1], [2, 2, 2], [-1, 1, 1])
    for arc, centre, phi_deg, s_f, t_end, apex in (
        (a1, [0.75, 0.375, 0.375], 218.94, 3.51006, [-0.96225, 0.19245, 0.19245], [1.5, 0, 0]),
        (a2, [1.75, 1.375, 1.375], 141.06, 2.26142, [0.96225, -0.19245, -0.19245], [1, 1.75, 1.75]),
    ):
        np.testing.assert_allclose(arc.center, centre, atol=1e-12)
        assert arc.radius == pytest.approx(0.91856, abs=5e-6)
        assert math.degrees(arc.angle) == pytest.approx(phi_deg, abs=5e-3)
        assert arc.length == pytest.approx(s_f, abs=5e-6)
        assert arc.length == pytest.approx(arc.radius * arc.angle, rel=1e-15)
        np.testing.assert_allclose(arc.evaluate(arc.length, 1), t_end, atol=5e-6)
        np.testing.assert_allclose(arc.evaluate(arc.length / 2), apex, atol=1e-12)
        check_segment(arc)
    np.testing.assert_allclose(a1.evaluate(0.0, 1), np.array([1, -1, -1]) / SQ3, atol=1e-15)
    np.testing.assert_allclose(a1.end, [1, 1, 1], atol=1e-12)
    np.testing.assert_allclose(a2.end, [2, 2, 2], atol=1e-12)


def test_arc_closed_forms_radius_and_curvature() -> None:
    arc = Arc.from_center([2.0, 1.0, 0.0], [1.0, 2.0, 0.0], [1.0, 1.0, 0.0])
    u = np.linspace(0.0, arc.u_end, 31)
    p = arc.evaluate(u)
    np.testing.assert_allclose(np.linalg.norm(p - arc.center, axis=1), 1.0, atol=1e-14)
    # p'' points to the centre with magnitude 1/r, p''' = -p'/r^2
    np.testing.assert_allclose(arc.evaluate(u, 2), (arc.center - p) / 1.0, atol=1e-14)
    np.testing.assert_allclose(arc.evaluate(u, 3), -arc.evaluate(u, 1), atol=1e-14)
    assert arc.angle == pytest.approx(math.pi / 2)
    check_segment(arc)


def test_from_center_directions() -> None:
    ccw = Arc.from_center([1.0, 0.0], [0.0, 1.0], [0.0, 0.0])
    cw = Arc.from_center([1.0, 0.0], [0.0, 1.0], [0.0, 0.0], clockwise=True)
    assert ccw.angle == pytest.approx(math.pi / 2) and cw.angle == pytest.approx(1.5 * math.pi)
    np.testing.assert_allclose(ccw.evaluate(0.0, 1), [0.0, 1.0], atol=1e-15)
    np.testing.assert_allclose(cw.evaluate(0.0, 1), [0.0, -1.0], atol=1e-15)
    np.testing.assert_allclose(cw.end, [0.0, 1.0], atol=1e-12)
    # 3-D: counter-clockwise about the given normal
    down = Arc.from_center([1, 0, 0], [0, 1, 0], [0, 0, 0], normal=[0, 0, -1])
    assert down.angle == pytest.approx(1.5 * math.pi)
    np.testing.assert_allclose(down.end, [0, 1, 0], atol=1e-12)
    # semicircle in 3-D needs the normal
    half = Arc.from_center([1, 0, 0], [-1, 0, 0], [0, 0, 0], normal=[0, 1, 0])
    np.testing.assert_allclose(half.evaluate(half.length / 2), [0, 0, -1], atol=1e-12)
    check_segment(half)


def test_from_three_points_passes_the_via_point() -> None:
    for via, mid in (([0.0, 1.0], [0.0, 1.0]), ([0.0, -1.0], [0.0, -1.0])):
        arc = Arc.from_three_points([1.0, 0.0], via, [-1.0, 0.0])
        assert arc.angle == pytest.approx(math.pi)
        np.testing.assert_allclose(arc.evaluate(arc.length / 2), mid, atol=1e-12)
    # more than half a circle, in 3-D
    arc = Arc.from_three_points([1, 0, 0], [0, 0, -1], [0, 0, 1])
    assert arc.angle == pytest.approx(1.5 * math.pi)
    np.testing.assert_allclose(arc.end, [0, 0, 1], atol=1e-12)


def test_from_radius_picks_the_requested_arc() -> None:
    r = math.sqrt(2.0)
    short = Arc.from_radius([0.0, 0.0], [2.0, 0.0], r)
    long = Arc.from_radius([0.0, 0.0], [2.0, 0.0], r, large=True)
    cw = Arc.from_radius([0.0, 0.0], [2.0, 0.0], r, clockwise=True)
    np.testing.assert_allclose(short.center, [1.0, 1.0], atol=1e-12)
    np.testing.assert_allclose(long.center, [1.0, -1.0], atol=1e-12)
    np.testing.assert_allclose(cw.center, [1.0, -1.0], atol=1e-12)
    assert short.angle == pytest.approx(math.pi / 2)
    assert long.angle == pytest.approx(1.5 * math.pi)
    assert cw.angle == pytest.approx(math.pi / 2)
    for arc in (short, long, cw):
        np.testing.assert_allclose(arc.end, [2.0, 0.0], atol=1e-12)
    arc3 = Arc.from_radius([0, 0, 0], [0, 2, 0], 1.0, normal=[1, 0, 0])
    np.testing.assert_allclose(arc3.evaluate(arc3.length / 2), [0, 1, -1], atol=1e-12)


def test_full_circle_and_turns() -> None:
    c2 = Arc.full_circle([1.0, 0.0], [0.0, 0.0], turns=2.0)
    assert c2.length == pytest.approx(4.0 * math.pi)
    np.testing.assert_allclose(c2.end, [1.0, 0.0], atol=1e-12)
    c3 = Arc.full_circle([0, 0, 2], [0, 0, 0], normal=[1, 0, 0], clockwise=True)
    np.testing.assert_allclose(c3.evaluate(0.0, 1), [0, 1, 0], atol=1e-15)
    check_segment(c3)


def test_arc_trim_is_the_same_curve() -> None:
    arc = Arc.from_three_points([1, 0, 0], [0, 1, 1], [-1, 0, 2])
    piece = arc.trim(0.4, 1.3)
    u = np.linspace(0.0, piece.length, 9)
    for k in range(4):
        np.testing.assert_allclose(piece.evaluate(u, k), arc.evaluate(u + 0.4, k), atol=1e-13)


@pytest.mark.parametrize(
    ("make", "field"),
    [
        (lambda: Arc.from_three_points([0, 0], [1, 1], [2, 2]), "via"),
        (lambda: Arc.from_three_points([0, 0, 0], [1, 1, 1], [3, 3, 3 + 1e-13]), "via"),
        (lambda: Arc.from_three_points([0, 0], [0, 0], [1, 1]), "via"),
        (lambda: Arc.from_three_points([0, 0], [1, 1], [0, 0]), "end"),
        (lambda: Arc.from_three_points([0, 0], [1, 1], [0, 1, 2]), "end"),
        (lambda: Arc.from_center([1, 0], [0, 1], [1, 0]), "center"),
        (lambda: Arc.from_center([1, 0], [0, 2], [0, 0]), "end"),
        (lambda: Arc.from_center([1, 0], [1, 0], [0, 0]), "end"),
        (lambda: Arc.from_center([1, 0, 0], [-1, 0, 0], [0, 0, 0]), "normal"),
        (lambda: Arc.from_center([1, 0, 0], [0, 1, 0], [0, 0, 0], normal=[1, 0, 0]), "normal"),
        (lambda: Arc.from_center([1, 0], [0, 1], [0, 0], normal=[0, 0, 1]), "normal"),
        (lambda: Arc.from_radius([0, 0], [2, 0], 0.0), "radius"),
        (lambda: Arc.from_radius([0, 0], [2, 0], -1.0), "radius"),
        (lambda: Arc.from_radius([0, 0], [2, 0], 0.99), "radius"),
        (lambda: Arc.from_radius([0, 0], [2, 0], math.nan), "radius"),
        (lambda: Arc.from_radius([0, 0, 0], [2, 0, 0], 2.0), "normal"),
        (lambda: Arc.from_tangent([0, 0], [1, 1], [1, 1]), "tangent"),
        (lambda: Arc.from_tangent([0, 0], [1, 1], [0, 0]), "tangent"),
        (lambda: Arc.from_tangent([0, 0], [1, math.nan], [1, 0]), "end"),
        (lambda: Arc.full_circle([0, 0, 1], [0, 0, 0]), "normal"),
        (lambda: Arc.full_circle([1, 0], [0, 0], turns=0.0), "turns"),
        (lambda: Arc([0, 0], 0.0, [1, 0], [0, 1], 1.0), "radius"),
        (lambda: Arc([0, 0], 1.0, [1, 0], [1, 1], 1.0), "y_axis"),
        (lambda: Arc([0, 0], 1.0, [1, 0], [0, 1], -1.0), "angle"),
        (lambda: Arc([0, 0], 1.0, [1, 0, 0], [0, 1], 1.0), "x_axis"),
        (lambda: Arc([0], 1.0, [1], [1], 1.0), "center"),
        (lambda: Helix([0, 0, 0], [0, 0, 0], [0, 0, 1], 1.0, 0.1), "center"),
        (lambda: Helix([1, 0, 0], [0, 0, 0], [0, 0, 0], 1.0, 0.1), "axis"),
        (lambda: Helix([1, 0, 0], [0, 0, 0], [0, 0, 1], 1.0, math.inf), "pitch"),
        (lambda: Helix([1, 0], [0, 0], [0, 1], 1.0, 0.1), "start"),
    ],
)
def test_arc_bad_input_names_the_field(make, field: str) -> None:
    with pytest.raises(PlanningError, match=rf"^{field}:"):
        make()


# -- helices -------------------------------------------------------------------------------------


@pytest.mark.parametrize("clockwise", [False, True])
@pytest.mark.parametrize("pitch", [0.5, -0.2, 0.0])
def test_helix_closed_forms(pitch: float, clockwise: bool) -> None:
    h = Helix(
        [2.0, 0.0, 1.0], [0.0, 0.0, 0.0], [0.0, 0.0, 1.0], 3 * math.pi, pitch, clockwise=clockwise
    )
    c = pitch / (2 * math.pi)
    assert h.radius == pytest.approx(2.0)
    assert h.length == pytest.approx(3 * math.pi * math.hypot(2.0, c), rel=1e-15)
    np.testing.assert_allclose(h.start, [2.0, 0.0, 1.0], atol=1e-15)
    np.testing.assert_allclose(h.end, [-2.0, 0.0, 1.0 + 1.5 * pitch], atol=1e-12)
    u = np.linspace(0.0, h.u_end, 25)
    p = h.evaluate(u)
    np.testing.assert_allclose(np.hypot(p[:, 0], p[:, 1]), 2.0, atol=1e-13)
    # curvature of a helix: rho / (rho^2 + c^2)
    np.testing.assert_allclose(np.linalg.norm(h.evaluate(u, 2), axis=1), 2.0 / (4.0 + c * c))
    turn = 1.0 if not clockwise else -1.0
    assert np.sign(h.evaluate(0.0, 1)[1]) == turn
    check_segment(h)


# -- property: random arcs through three points ----------------------------------------------------

coords = st.floats(-10.0, 10.0, allow_nan=False)


@hsettings(80)
@given(
    dim=st.sampled_from([2, 3, 4]),
    data=st.data(),
)
def test_three_point_arcs_property(dim: int, data: st.DataObject) -> None:
    pts = [np.array(data.draw(st.lists(coords, min_size=dim, max_size=dim))) for _ in range(3)]
    p0, pv, p1 = pts
    a, b = pv - p0, p1 - p0
    gram = float(a @ a) * float(b @ b) - float(a @ b) ** 2
    assume(min(np.linalg.norm(a), np.linalg.norm(b), np.linalg.norm(p1 - pv)) > 1e-3)
    assume(gram > 1e-6 * float(a @ a) * float(b @ b))
    arc = Arc.from_three_points(p0, pv, p1)
    np.testing.assert_allclose(arc.start, p0, atol=1e-9)
    np.testing.assert_allclose(arc.end, p1, atol=1e-9 * max(1.0, arc.radius))
    # the via point is on the arc, between the ends
    u = np.linspace(0.0, arc.u_end, 4001)
    d = np.linalg.norm(arc.evaluate(u) - pv, axis=1)
    k = int(np.argmin(d))
    assert 0 < k < u.size - 1
    assert d[k] <= arc.u_end / 4000 + 1e-9
    np.testing.assert_allclose(np.linalg.norm(arc.evaluate(u, 1), axis=1), 1.0, atol=1e-12)
    assert fd_derivative_error(arc, u[::200], 0) < 1e-6
