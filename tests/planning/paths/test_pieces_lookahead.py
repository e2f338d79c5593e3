"""The group kernel's path pieces and look-ahead formulas against independent references: the
line-line blend against blend.py's CornerBlend, the derivative bounds against dense samples of
the exact derivatives, the reachability distance against the time-optimal 1-D planner."""

from __future__ import annotations

import math

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from motionplc.planning import Limits, State, plan_velocity
from motionplc.planning.paths import Arc, Helix, HermitePath, Line
from motionplc.planning.paths.blend import CornerBlend
from motionplc.planning.paths.lookahead import max_speed_change, speed_change_distance
from motionplc.planning.paths.pieces import BlendPiece, CurvePiece, piece_for

unit3 = st.tuples(*[st.floats(-1.0, 1.0)] * 3).filter(lambda v: 0.2 < math.hypot(*v))


def _unit(v: tuple[float, ...]) -> np.ndarray:
    a = np.asarray(v, dtype=float)
    return a / np.linalg.norm(a)


@settings(max_examples=40, deadline=None)
@given(unit3, unit3, st.floats(1e-4, 0.05))
def test_blend_piece_is_the_corner_blend_of_two_lines(ta, tb, d) -> None:
    ta, tb = _unit(ta), _unit(tb)
    if ta @ tb > 1.0 - 1e-6 or ta @ tb < -0.99:
        return  # no corner / a reversal (not blended)
    c = np.array([0.3, 0.2, -0.1])
    a, b = Line(c - 0.2 * ta, c), Line(c, c + 0.2 * tb)
    ref = CornerBlend(a, b, d)
    bp = BlendPiece(c, ta, tb, d)
    assert math.isclose(bp.U, ref.u_end, rel_tol=1e-12)
    assert math.isclose(bp.length, ref.length, rel_tol=1e-9)
    for u in np.linspace(0.0, bp.U, 9):
        mine = bp.at(float(u))
        theirs = ref.derivatives(float(u), 3)
        for k in range(4):
            scale = d ** (1 - k)
            assert np.abs(np.array(mine[k]) - np.ravel(theirs[k])).max() <= 1e-9 * scale
    assert math.isclose(bp.deviation, ref.distance_to(c)[0], rel_tol=1e-9)


def _check_bounds(piece, n: int = 4001) -> None:
    us = np.linspace(0.0, piece.U, n)
    ders = np.array([piece.at(float(u)) for u in us])  # (n, 4, dim)
    for k, bound in ((1, piece.b1), (2, piece.b2), (3, piece.b3)):
        assert np.all(np.abs(ders[:, k, :]).max(axis=0) <= np.asarray(bound) * (1 + 1e-12))
    assert np.linalg.norm(ders[:, 1, :], axis=1).max() <= piece.gmax * (1 + 1e-12)


@settings(max_examples=25, deadline=None)
@given(unit3, unit3, st.floats(1e-4, 0.05))
def test_blend_bounds_hold_between_their_samples(ta, tb, d) -> None:
    ta, tb = _unit(ta), _unit(tb)
    if ta @ tb > 1.0 - 1e-6 or ta @ tb < -0.99:
        return
    bp = BlendPiece((0.0, 0.0, 0.0), ta, tb, d)
    _check_bounds(bp)
    for part in bp.split(8):
        _check_bounds(part, 501)


def test_arc_helix_and_curve_bounds_hold() -> None:
    _check_bounds(piece_for(Arc.from_center([0.4, 0.2, 0.0], [0.2, 0.4, 0.0], [0.2, 0.2, 0.0])))
    _check_bounds(piece_for(Helix([0.1, 0, 0], [0, 0, 0], [0.3, 0.1, 1.0], 7.0, 0.02)))
    h = HermitePath([[0, 0, 0], [0.1, 0.05, 0], [0.2, 0.0, -0.01], [0.3, 0.08, 0.0]])
    for a in range(3):
        _check_bounds(CurvePiece(h, float(a), float(a + 1)))


@settings(max_examples=60, deadline=None)
@given(
    st.floats(0.0, 2.0),
    st.floats(0.0, 2.0),
    st.floats(0.1, 10.0),
    st.one_of(st.just(math.inf), st.floats(1.0, 200.0)),
)
def test_speed_change_distance_is_the_time_optimal_ramps_distance(v, w, a, j) -> None:
    """The closed form against the exact 1-D planner: a velocity change from rest
    acceleration to rest acceleration covers exactly this distance."""
    prof = plan_velocity(State(0.0, v, 0.0), w, Limits(v_max=math.inf, a_max=a, j_max=j))
    d = speed_change_distance(v, w, a, j)
    assert math.isclose(prof.end.p, d, rel_tol=1e-9, abs_tol=1e-12)


@settings(max_examples=60, deadline=None)
@given(
    st.floats(0.0, 2.0),
    st.floats(1e-6, 1.0),
    st.floats(0.1, 10.0),
    st.one_of(st.just(math.inf), st.floats(1.0, 200.0)),
)
def test_max_speed_change_inverts_the_distance(v, length, a, j) -> None:
    x = max_speed_change(v, length, a, j)
    assert x >= 0.0
    w = v + x  # rounds: the change w - v is x up to half an ulp of w
    rel = 1e-9 + 2.0 * math.ulp(w) / x if x > 0.0 else 1.0
    assert math.isclose(speed_change_distance(v, w, a, j), length, rel_tol=rel)
