"""Concatenation: G0 check, global parameter, vectorised lookup, seed 000's joiner."""

from __future__ import annotations

import math

import numpy as np
import pytest

from motionplc.errors import PlanningError
from motionplc.planning.paths import Arc, CompositePath, Helix, Line, join, polyline
from tests.planning.paths._geom_checks import integrated_length

SQ3 = math.sqrt(3.0)

# Seed 000 §5.1: start, two arcs (the vector is the arc's start tangent), two lines.
SEED_POINTS = [
    ([0, 0, 0], 0),
    ([1, 1, 1], [1, -1, -1]),
    ([2, 2, 2], [-1, 1, 1]),
    ([3, 3, 3], 1),
    ([4, 4, 2], 1),
]


def test_seed000_joiner_exact_lengths() -> None:
    path = join(SEED_POINTS)
    assert [type(s).__name__ for s in path.segments] == ["Arc", "Arc", "Line", "Line"]
    lengths = np.diff(path.cumulative_lengths)
    # §6.1 (implementation notes, Reading A), rounded to the printed digits
    np.testing.assert_allclose(lengths, [3.51006, 2.26142, SQ3, SQ3], atol=5e-6)
    assert path.length == pytest.approx(9.2356, abs=5e-5)
    assert path.u_end == path.length and path.is_arc_length
    # exact: the sum of the closed forms, and agrees with quadrature of |p'|
    arcs = path.segments[:2]
    assert path.length == pytest.approx(sum(a.radius * a.angle for a in arcs) + 2 * SQ3, rel=1e-15)
    assert integrated_length(path.segments[0]) + integrated_length(path.segments[1]) == (
        pytest.approx(float(lengths[0] + lengths[1]), rel=1e-11)
    )
    # G0 at every junction, through the programmed points
    for k, (xyz, _) in enumerate(SEED_POINTS):
        np.testing.assert_allclose(path.evaluate(path.breaks[k]), xyz, atol=1e-12)


def test_seed000_tangent_jumps() -> None:
    """Seed §5.1/§6.1: jumps at pass1, pass2, pass3; the largest y/z jump at pass2."""
    path = join(SEED_POINTS)
    b = path.breaks
    jumps = [
        path.segments[k + 1].evaluate(0.0, 1) - path.segments[k].evaluate(path.segments[k].u_end, 1)
        for k in range(3)
    ]
    np.testing.assert_allclose(jumps[0], [0.385, 0.385, 0.385], atol=1e-3)
    np.testing.assert_allclose(jumps[1], [-0.385, 0.770, 0.770], atol=1e-3)
    np.testing.assert_allclose(jumps[2], [0.0, 0.0, -1.155], atol=1e-3)
    # at pass2 the velocity jumps mostly in y and z (the seed's Fig. 9 remark), and pass2 has
    # the largest y jump of the path (z jumps more at pass3, where only z jumps)
    assert min(abs(jumps[1][1]), abs(jumps[1][2])) > 2 * abs(jumps[1][0])
    assert np.argmax([abs(j[1]) for j in jumps]) == 1
    assert np.all(path.deflections > 0.5)
    # a junction value belongs to the following segment
    np.testing.assert_allclose(path.evaluate(b[2], 1), np.ones(3) / SQ3, atol=1e-15)


def test_gap_is_an_error_naming_the_segment_and_the_gap() -> None:
    segs = [Line([0, 0], [1, 0]), Line([1, 0], [1, 1]), Line([1, 1.001], [0, 1])]
    with pytest.raises(PlanningError, match=r"^segments\[2\]: starts 0\.001 m from the end"):
        CompositePath(segs)
    CompositePath(segs, gap_tol=2e-3)  # accepted with a wider tolerance
    with pytest.raises(PlanningError, match=r"^segments\[1\]: dimension 3 differs"):
        CompositePath([Line([0, 0], [1, 0]), Line([1, 0, 0], [2, 0, 0])])
    with pytest.raises(PlanningError, match=r"^segments: at least one"):
        CompositePath([])
    with pytest.raises(PlanningError, match=r"^segments\[0\]: must be a Path"):
        CompositePath([[0, 1]])  # type: ignore[list-item]
    with pytest.raises(PlanningError, match=r"^gap_tol:"):
        CompositePath(segs, gap_tol=-1.0)


def make_mixed() -> CompositePath:
    line = Line([0.0, 0.0, 0.0], [1.0, 0.0, 0.0])
    arc = Arc.from_three_points([1, 0, 0], [1.5, 0.5, 0.2], [1, 1, 0.4])
    helix = Helix(arc.end, arc.end + np.array([0.3, 0.0, 0.0]), [0, 0, 1], 5.0, 0.2)
    return CompositePath([line, arc, helix])


def test_vectorised_evaluation_matches_segments() -> None:
    path = make_mixed()
    rng = np.random.default_rng(7)
    u = rng.uniform(0.0, path.u_end, 500)
    for order in range(4):
        vals = path.evaluate(u, order)
        assert vals.shape == (500, 3)
        for i, ui in enumerate(u[:50]):
            k = int(np.searchsorted(path.breaks, ui, side="right") - 1)
            seg = path.segments[min(k, len(path) - 1)]
            np.testing.assert_allclose(vals[i], seg.evaluate(ui - path.breaks[k], order))
            np.testing.assert_array_equal(path.evaluate(float(ui), order), vals[i])
        # unsorted and sorted input agree
        order_idx = np.argsort(u)
        np.testing.assert_array_equal(path.evaluate(u[order_idx], order), vals[order_idx])
    derivs = path.derivatives(u, 3)
    for k in range(4):
        np.testing.assert_array_equal(derivs[k], path.evaluate(u, k))
    assert path.evaluate(np.array([]), 0).shape == (0, 3)


def test_arc_length_and_inverse() -> None:
    path = make_mixed()
    s = np.linspace(0.0, path.length, 101)
    np.testing.assert_allclose(path.u_at_arc_length(s), s, rtol=0, atol=1e-15)
    np.testing.assert_allclose(path.arc_length(s), s)
    total = sum(integrated_length(seg) for seg in path.segments)
    assert total == pytest.approx(path.length, rel=1e-11)


def test_nested_composites_are_flattened() -> None:
    a = polyline([[0, 0], [1, 0], [1, 1]])
    b = polyline([[1, 1], [2, 1]])
    c = CompositePath([a, b])
    assert len(c) == 3 and c.length == pytest.approx(3.0)


def test_polyline_drops_zero_length_segments() -> None:
    p = polyline([[0, 0], [1, 0], [1, 0], [1, 0 + 1e-12], [1, 2]])
    assert len(p) == 2 and p.length == pytest.approx(3.0)
    assert np.all(np.isfinite(p.evaluate(np.linspace(0, p.u_end, 11), 1)))
    with pytest.raises(PlanningError, match=r"^points: all points coincide"):
        polyline([[1, 1], [1, 1]])
    with pytest.raises(PlanningError, match=r"^points\[1\]: must have 2 entries"):
        polyline([[1, 1], [1, 1, 1]])
    with pytest.raises(PlanningError, match=r"^points\[2\]: entries must be finite"):
        polyline([[1, 1], [2, 1], [math.nan, 0]])


@pytest.mark.parametrize(
    ("points", "field"),
    [
        ([([0, 0, 0], 1), ([1, 1, 1], 1)], r"points\[0\]\.interp"),
        ([([0, 0, 0], 0), ([1, 1, 1], 2)], r"points\[1\]\.interp"),
        ([([0, 0, 0], 0), ([1, 1, 1], 7)], r"points\[1\]\.interp"),
        ([([0, 0, 0], 0), ([1, 1, 1], [1, 1])], r"points\[1\]\.interp"),
        ([([0, 0, 0], 0), ([1, 1, 1], [1, 1, 1])], r"tangent"),
        ([([0, 0, 0], 0), ([1, 1], 1)], r"points\[1\]\.xyz"),
        ([([0, 0, 0], 0)], r"points"),
        ([([0, 0, 0], 0), ([0, 0, 0], 1)], r"end"),
    ],
)
def test_join_bad_input(points: list, field: str) -> None:
    with pytest.raises(PlanningError, match=rf"^{field}:"):
        join(points)


def test_composite_is_immutable() -> None:
    p = polyline([[0, 0], [1, 0]])
    with pytest.raises(AttributeError):
        p._segments = ()  # type: ignore[misc]
    with pytest.raises(ValueError):
        p.breaks[0] = 1.0
