"""Corner blending: deviation bound (measured independently), G2 continuity at every junction,
arc length against quadrature, caps and special corners, seed 000's path, random polylines."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from hypothesis import assume, given
from hypothesis import strategies as st

from motionplc.errors import PlanningError
from motionplc.planning.paths import (
    Arc,
    BlendedPath,
    CornerBlend,
    CornerKind,
    Helix,
    Line,
    Path,
    Transition,
    TransitionMode,
    blend_corners,
    blend_polyline,
    join,
    polyline,
)
from motionplc.planning.paths.base import as_param
from tests.planning._strategies import hsettings
from tests.planning.paths._geom_checks import (
    curvature_vector,
    fd_derivative_error,
    integrated_length,
)
from tests.planning.paths.test_composite import SEED_POINTS

MAXDEV = TransitionMode.MAX_CORNER_DEVIATION
CDIST = TransitionMode.CORNER_DISTANCE


# -- independent measurements ------------------------------------------------------------------


def measured_deviation(path: Path, corner) -> float:
    """Distance from the programmed corner to the blend: dense sampling of the blend's global
    parameter range, then a bounded scalar minimisation (scipy) around the best sample."""
    from scipy.optimize import minimize_scalar

    q = np.asarray(corner.point)
    u = np.linspace(corner.u_start, corner.u_end, 2001)
    d = np.linalg.norm(path.evaluate(u) - q, axis=1)
    k = int(np.argmin(d))
    lo, hi = u[max(k - 1, 0)], u[min(k + 1, u.size - 1)]
    res = minimize_scalar(
        lambda x: float(np.linalg.norm(path.evaluate(float(x)) - q)),
        bounds=(lo, hi),
        method="bounded",
        options={"xatol": 1e-13 * max(1.0, hi)},
    )
    return float(min(d[k], res.fun))


def distance_to_lines(path: Path, corner, a: Line, b: Line) -> float:
    """Largest distance (sampled) of the blend from the programmed pieces it replaces."""
    u = np.linspace(corner.u_start, corner.u_end, 401)
    p = path.evaluate(u)
    out = np.full(u.size, np.inf)
    for p0, p1 in (
        (a.evaluate(a.u_end - corner.distance), a.end),
        (b.start, b.evaluate(corner.distance)),
    ):
        ab = p1 - p0
        t = np.clip((p - p0) @ ab / (ab @ ab), 0.0, 1.0)
        out = np.minimum(out, np.linalg.norm(p - (p0 + t[:, None] * ab), axis=1))
    return float(out.max())


def junction_jumps(path: BlendedPath) -> list[tuple[float, float, float, float]]:
    """(u, tangent jump, curvature-vector jump, curvature) at every junction of pieces."""
    out = []
    segs = path.segments
    for k in range(len(segs) - 1):
        a, b = segs[k], segs[k + 1]
        la = [np.asarray(a.evaluate(a.u_end, i)) for i in (1, 2)]
        rb = [np.asarray(b.evaluate(0.0, i)) for i in (1, 2)]
        ta, tb = la[0] / np.linalg.norm(la[0]), rb[0] / np.linalg.norm(rb[0])
        ka, kb = curvature_vector(*la), curvature_vector(*rb)
        kap = max(float(np.linalg.norm(ka)), float(np.linalg.norm(kb)))
        out.append(
            (
                float(path.breaks[k + 1]),
                float(np.linalg.norm(ta - tb)),
                float(np.linalg.norm(ka - kb)),
                kap,
            )
        )
    return out


def check_blended(path: BlendedPath, *, check_length: bool = True) -> None:
    """Every invariant the module guarantees, measured independently."""
    src = path.source
    # no NaN anywhere, orders 0..3 (dense grid plus every junction)
    u = np.concatenate((np.linspace(0.0, path.u_end, 1501), path.breaks))
    for k in range(4):
        assert np.all(np.isfinite(path.evaluate(u, k)))
    # the global parameter spans the programmed length
    assert path.u_end == pytest.approx(sum(s.length for s in src), rel=1e-9)
    stops = {c.u_start for c in path.corners if c.needs_stop}
    for uj, dt, dk, kap in junction_jumps(path):
        if any(abs(uj - s) <= 1e-12 * max(1.0, path.u_end) for s in stops):
            continue
        assert dt <= 2e-9, f"tangent jump {dt} at u={uj}"
        assert dk <= 1e-8 * max(1.0, kap), f"curvature jump {dk} (kappa {kap}) at u={uj}"
    for c in path.corners:
        a, b = src[c.index], src[c.index + 1]
        tr = c.transition
        if c.kind == CornerKind.BLENDED:
            cap = 0.5 * min(a.length, b.length)
            assert 0.0 < c.distance <= cap * (1.0 + 1e-12)
            assert c.u_end - c.u_start == pytest.approx(2.0 * c.distance, rel=1e-12)
            dev = measured_deviation(path, c)
            if isinstance(a, Line) and isinstance(b, Line):
                assert distance_to_lines(path, c, a, b) <= c.deviation * (1.0 + 1e-9) + 1e-15
            assert dev == pytest.approx(c.deviation, rel=1e-8, abs=1e-14)
            if tr.mode == MAXDEV:
                assert dev <= tr.parameter * (1.0 + 1e-9) + 1e-15
                if c.distance < cap * (1.0 - 1e-9):  # not capped: the whole tolerance is used
                    assert dev >= 0.9 * tr.parameter
                    assert c.deviation >= (1.0 - 1e-8) * tr.parameter
            else:
                assert c.distance == pytest.approx(min(tr.parameter, cap), rel=1e-12)
        elif c.kind == CornerKind.SMOOTH:
            assert c.deflection <= 1e-9
        elif c.kind == CornerKind.STOP:
            assert c.deflection > math.radians(179.0) - 1e-12 and c.needs_stop
        else:
            assert tr.mode == TransitionMode.NONE or tr.parameter == 0.0
        if c.kind != CornerKind.BLENDED:
            assert c.distance == 0.0 and c.deviation == 0.0 and c.u_start == c.u_end
            np.testing.assert_allclose(path.evaluate(c.u_start), c.point, atol=1e-9)
    if check_length:
        total = sum(integrated_length(seg) for seg in path.segments)
        assert total == pytest.approx(path.length, rel=1e-9)
        np.testing.assert_allclose(path.arc_length(path.breaks), path.cumulative_lengths)


# -- seed 000 ------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    "transition", [Transition.max_corner_deviation(0.05), Transition.corner_distance(0.2)]
)
def test_seed000_path_blended(transition: Transition) -> None:
    """Seed §5.1 path (Reading A): exact lengths outside the blends; blended corners give a
    continuous unit tangent and a continuous curvature vector."""
    source = join(SEED_POINTS)
    path = blend_corners(source, transition)
    assert [c.kind for c in path.corners] == [CornerKind.BLENDED] * 3
    check_blended(path)
    # outside the blends the programmed segments are kept exactly (same arc length parameter)
    for c, nxt in zip(path.corners, path.corners[1:] + (None,), strict=True):
        u_next = path.u_end if nxt is None else nxt.u_start
        u = np.linspace(c.u_end, u_next, 50)
        np.testing.assert_allclose(path.evaluate(u), source.evaluate(u), atol=1e-12)
        np.testing.assert_allclose(np.linalg.norm(path.evaluate(u, 1), axis=1), 1.0, atol=1e-12)
    if transition.mode == MAXDEV:
        for c in path.corners:
            assert 0.9 * 0.05 <= c.deviation <= 0.05
    # dense sampling: the unit tangent never jumps (bounded by curvature * step)
    u = np.linspace(0.0, path.u_end, 40001)
    t = path.unit_tangent(u)
    kap = np.linalg.norm(path.curvature_vector(u), axis=1)
    speed = np.linalg.norm(path.evaluate(u, 1), axis=1)
    step = np.linalg.norm(np.diff(t, axis=0), axis=1)
    bound = 1.5 * np.maximum(kap[1:] * speed[1:], kap[:-1] * speed[:-1]) * np.diff(u) + 1e-12
    assert np.all(step <= bound)
    # and the curvature vector is continuous too (steps shrink with the sampling step)
    kv = path.curvature_vector(u)
    assert np.max(np.linalg.norm(np.diff(kv, axis=0), axis=1)) < 0.05
    # unblended, the same path has tangent jumps at every corner
    assert np.all(source.deflections > 0.5)


# -- closed forms and the guarantees on simple corners --------------------------------------------


@pytest.mark.parametrize("deg", [1.0, 30.0, 90.0, 135.0, 170.0, 178.9])
def test_line_line_closed_form(deg: float) -> None:
    th = math.radians(deg)
    pts = [[-2.0, 0.0], [0.0, 0.0], [2.0 * math.cos(th), 2.0 * math.sin(th)]]
    path = blend_polyline(pts, Transition.corner_distance(0.3))
    c = path.corners[0]
    assert c.kind == CornerKind.BLENDED and c.deflection == pytest.approx(th)
    assert c.deviation == pytest.approx(0.3 * math.sin(th / 2) / 2, rel=1e-12)
    a, b = np.array([1.0, 0.0]), np.array([math.cos(th), math.sin(th)])
    np.testing.assert_allclose(
        path.evaluate(0.5 * (c.u_start + c.u_end)), 0.075 * (b - a), atol=1e-15
    )
    # convex: the signed curvature keeps its sign; speed >= cos(theta/2)
    u = np.linspace(c.u_start, c.u_end, 2001)
    d1, d2 = path.evaluate(u, 1), path.evaluate(u, 2)
    cross = d1[:, 0] * d2[:, 1] - d1[:, 1] * d2[:, 0]
    assert np.all(cross >= -1e-12)
    assert np.linalg.norm(d1, axis=1).min() >= math.cos(th / 2) - 1e-12
    check_blended(path)


@pytest.mark.parametrize("deg", [0.5, 5.0, 45.0, 90.0, 120.0, 160.0, 175.0])
@pytest.mark.parametrize("tol", [1e-4, 1e-2, 0.3])
def test_max_deviation_uses_the_whole_tolerance(deg: float, tol: float) -> None:
    th = math.radians(deg)
    pts = [[-20.0, 0.0, 0.0], [0.0, 0.0, 0.0], [20.0 * math.cos(th), 0.0, 20.0 * math.sin(th)]]
    path = blend_polyline(pts, Transition.max_corner_deviation(tol))
    c = path.corners[0]
    if 2 * tol / math.sin(th / 2) < 10.0:  # the half-segment cap does not bind
        assert c.deviation == pytest.approx(tol, rel=1e-9) and c.deviation <= tol
    assert measured_deviation(path, c) <= tol * (1 + 1e-9)
    check_blended(path, check_length=False)


def test_half_segment_cap_and_consumed_segment() -> None:
    pts = [[0.0, 0.0], [1.0, 0.0], [1.0, 0.1], [2.0, 0.1]]
    path = blend_polyline(pts, Transition.max_corner_deviation(1.0))
    assert [c.distance for c in path.corners] == pytest.approx([0.05, 0.05])
    assert all(c.deviation < 1.0 for c in path.corners)
    # the short segment is consumed by its two blends: blend follows blend directly
    assert [type(s).__name__ for s in path.segments] == [
        "Line",
        "CornerBlend",
        "CornerBlend",
        "Line",
    ]
    check_blended(path)
    # corner distance larger than half a segment is capped the same way (and reported)
    path2 = blend_polyline(pts, Transition.corner_distance(0.5))
    assert [c.distance for c in path2.corners] == pytest.approx([0.05, 0.05])


def test_per_corner_transitions_and_exact_corners() -> None:
    pts = [[0, 0], [1, 0], [1, 1], [2, 1], [2, 2]]
    trans = [
        Transition.none(),
        Transition.corner_distance(0.2),
        Transition.max_corner_deviation(0.0),
    ]
    path = blend_polyline(pts, trans)
    kinds = [c.kind for c in path.corners]
    assert kinds == [CornerKind.EXACT, CornerKind.BLENDED, CornerKind.EXACT]
    assert [c.needs_stop for c in path.corners] == [True, False, True]
    assert path.max_deviation == pytest.approx(path.corners[1].deviation)
    check_blended(path)
    unblended = blend_polyline(pts, Transition.none())
    assert len(unblended) == 4 and unblended.max_deviation == 0.0


# -- arcs, helices and curvature transitions ------------------------------------------------


def test_line_into_tangent_arc_gets_a_curvature_transition() -> None:
    line = Line([-1.0, 0.0, 0.0], [0.0, 0.0, 0.0])
    arc = Arc.from_tangent([0.0, 0.0, 0.0], [1.0, 1.0, 0.5], [1.0, 0.0, 0.0])
    src = polyline([[-1, 0, 0], [0, 0, 0]]).segments + (arc,)
    assert src[0].length == line.length
    path = blend_corners(src, Transition.max_corner_deviation(1e-3))
    c = path.corners[0]
    assert c.kind == CornerKind.BLENDED and c.deflection < 1e-12
    assert c.deviation == pytest.approx(1e-3, rel=1e-8)
    # the curvature grows from 0 (line) to 1/r (arc) without a jump
    u = np.linspace(c.u_start, c.u_end, 501)
    kap = np.linalg.norm(path.curvature_vector(u), axis=1)
    assert kap[0] == pytest.approx(0.0, abs=1e-12)
    assert kap[-1] == pytest.approx(1.0 / arc.radius, rel=1e-12)
    check_blended(path)


def test_arc_helix_and_circle_neighbours() -> None:
    helix = Helix([1, 0, 0], [0, 0, 0], [0, 0, 1], 2 * math.pi, 0.3)
    circle = Arc.full_circle(helix.end, helix.end - np.array([0.5, 0.0, 0.0]), normal=[0, 1, 1])
    tail = Line(circle.end, circle.end + np.array([0.0, 1.0, -1.0]))
    path = blend_corners([helix, circle, tail], Transition.max_corner_deviation(0.02))
    assert [c.kind for c in path.corners] == [CornerKind.BLENDED] * 2
    check_blended(path)
    for seg in path.segments:
        if isinstance(seg, CornerBlend):
            t = np.linspace(0.0, seg.u_end, 13)
            for k in range(3):
                assert fd_derivative_error(seg, t, k) < 1e-5
            for x in (0.3 * seg.u_end, seg.u_end):
                assert seg.arc_length(x) == pytest.approx(integrated_length(seg, 0.0, x), rel=1e-11)


def test_blended_path_arc_length_inverse() -> None:
    path = blend_corners(join(SEED_POINTS), Transition.max_corner_deviation(0.1))
    assert not path.is_arc_length
    s = np.linspace(0.0, path.length, 257)
    u = path.u_at_arc_length(s)
    assert np.all(np.diff(u) > 0)
    np.testing.assert_allclose(path.arc_length(u), s, atol=1e-11)


# -- special corners -----------------------------------------------------------------------------


def test_near_tangent_corners() -> None:
    smooth = blend_polyline([[0, 0], [1, 0], [2, 1e-13]], Transition.max_corner_deviation(0.1))
    assert smooth.corners[0].kind == CornerKind.SMOOTH and len(smooth) == 2
    tiny = blend_polyline([[0, 0], [1, 0], [2, 1e-7]], Transition.max_corner_deviation(0.1))
    c = tiny.corners[0]
    assert c.kind == CornerKind.BLENDED and c.distance == pytest.approx(0.5)
    assert c.deviation == pytest.approx(0.5 * math.sin(c.deflection / 2) / 2, rel=1e-6)
    check_blended(smooth)
    check_blended(tiny)


@pytest.mark.parametrize("deg", [179.5, 180.0])
def test_reversal_is_an_exact_stop(deg: float) -> None:
    th = math.radians(deg)
    pts = [[0.0, 0.0], [1.0, 0.0], [1.0 + math.cos(th), math.sin(th)]]
    path = blend_polyline(pts, Transition.max_corner_deviation(0.05))
    c = path.corners[0]
    assert c.kind == CornerKind.STOP and c.needs_stop and c.deviation == 0.0
    check_blended(path)
    # allowed explicitly: a very sharp but finite G2 turn within the bound
    if deg < 180.0:
        sharp = blend_polyline(
            pts, Transition.max_corner_deviation(0.05), max_deflection=math.radians(179.8)
        )
        assert sharp.corners[0].kind == CornerKind.BLENDED
        check_blended(sharp)


# -- bad input -----------------------------------------------------------------------------------


class _UnitParamLine(Path):
    """A straight line over u in [0, 1] (not arc length): not blendable here."""

    __slots__ = ("_p0", "_p1")

    def __init__(self, p0, p1) -> None:
        object.__setattr__(self, "_p0", np.asarray(p0, float))
        object.__setattr__(self, "_p1", np.asarray(p1, float))

    @property
    def dim(self) -> int:
        return self._p0.size

    @property
    def u_end(self) -> float:
        return 1.0

    @property
    def length(self) -> float:
        return float(np.linalg.norm(self._p1 - self._p0))

    def arc_length(self, u):
        return as_param(u, 1.0) * self.length

    def evaluate(self, u, order=0):
        uu = as_param(u, 1.0)
        d = self._p1 - self._p0
        if order == 0:
            return self._p0 + np.multiply.outer(uu, d)
        if order == 1:
            return np.broadcast_to(d, np.shape(uu) + d.shape).copy()
        return np.zeros(np.shape(uu) + d.shape)


def test_bad_input_names_the_field() -> None:
    pts = [[0, 0], [1, 0], [1, 1]]
    with pytest.raises(PlanningError, match=r"^Transition\.parameter:"):
        Transition.max_corner_deviation(-0.1)
    with pytest.raises(PlanningError, match=r"^Transition\.parameter:"):
        Transition.corner_distance(math.nan)
    with pytest.raises(PlanningError, match=r"^Transition\.mode:"):
        Transition(7, 0.1)  # type: ignore[arg-type]
    assert Transition(4, 0.1).mode is MAXDEV  # type: ignore[arg-type]
    with pytest.raises(PlanningError, match=r"^transitions\[0\]\.mode: START_VELOCITY"):
        blend_polyline(pts, Transition(TransitionMode.START_VELOCITY, 1.0))
    with pytest.raises(PlanningError, match=r"^transitions: one per corner"):
        blend_polyline(pts, [Transition.none(), Transition.none()])
    with pytest.raises(PlanningError, match=r"^transitions\[0\]:"):
        blend_polyline(pts, [0.1])  # type: ignore[list-item]
    with pytest.raises(PlanningError, match=r"^max_deflection:"):
        blend_polyline(pts, Transition.none(), max_deflection=math.pi)
    with pytest.raises(PlanningError, match=r"^segments\[1\]: starts"):
        blend_corners([Line([0, 0], [1, 0]), Line([1, 0.1], [2, 0])], Transition.none())
    odd = [Line([0, 0], [1, 0]), _UnitParamLine([1, 0], [1, 1])]
    with pytest.raises(PlanningError, match=r"^segments\[1\]: corner 0 is blended"):
        blend_corners(odd, Transition.max_corner_deviation(0.1))
    assert blend_corners(odd, Transition.none()).corners[0].kind == CornerKind.EXACT
    with pytest.raises(PlanningError, match=r"^distance:"):
        CornerBlend(Line([0, 0], [1, 0]), Line([1, 0], [1, 1]), 1.5)


def test_results_are_immutable() -> None:
    path = blend_polyline([[0, 0], [1, 0], [1, 1]], Transition.max_corner_deviation(0.1))
    with pytest.raises(dataclasses.FrozenInstanceError):
        path.corners[0].deviation = 1.0  # type: ignore[misc]
    with pytest.raises(AttributeError):
        path._corners = ()  # type: ignore[misc]
    with pytest.raises(AttributeError):
        path.segments[1]._d = 3.0  # type: ignore[attr-defined]


# -- property: random polylines --------------------------------------------------------------------

DIR_KINDS = ["random", "random", "near", "sharp", "straight", "reverse", "repeat"]


@st.composite
def polylines(draw: st.DrawFn) -> tuple[list[np.ndarray], Transition | list[Transition]]:
    dim = draw(st.sampled_from([2, 3]))
    n = draw(st.integers(3, 7))

    def rand_unit() -> np.ndarray:
        v = np.array(draw(st.lists(st.floats(-1, 1), min_size=dim, max_size=dim)))
        assume(np.linalg.norm(v) > 0.1)
        return v / np.linalg.norm(v)

    d = rand_unit()
    pts = [np.zeros(dim)]
    for _ in range(n - 1):
        kind = draw(st.sampled_from(DIR_KINDS))
        if kind == "random":
            d = rand_unit()
        elif kind == "near":  # near-collinear
            d = d + 10.0 ** draw(st.floats(-10, -2)) * rand_unit()
        elif kind == "sharp":  # near-reversal
            d = -d + 10.0 ** draw(st.floats(-3, 0)) * rand_unit()
        elif kind == "reverse":
            d = -d
        elif kind == "repeat":  # a zero-length segment (dropped by polyline)
            pts.append(pts[-1].copy())
            continue
        assume(np.linalg.norm(d) > 1e-6)
        d = d / np.linalg.norm(d)
        pts.append(pts[-1] + 10.0 ** draw(st.floats(-3, 1)) * d)
    tol = st.floats(-4, 0).map(lambda e: 10.0**e)
    if draw(st.booleans()):
        trans: Transition | list[Transition] = Transition.max_corner_deviation(draw(tol))
    else:
        modes = st.sampled_from([MAXDEV, MAXDEV, CDIST, TransitionMode.NONE])
        trans = [Transition(draw(modes), draw(tol)) for _ in range(n - 2)]
    return pts, trans


@hsettings(60)
@given(polylines())
def test_random_polylines_property(case) -> None:
    pts, trans = case
    try:
        source = polyline(pts)
    except PlanningError as exc:  # only when every point is a repeat of the first
        assert "all points coincide" in str(exc)
        return
    if isinstance(trans, list):  # one per corner left after dropping repeated points
        trans = trans[: len(source) - 1]
    path = blend_corners(source, trans)
    check_blended(path)
