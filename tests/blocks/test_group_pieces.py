"""The group's curved corner blends are sampled every cycle through a plain-float evaluation
(``CurvePiece`` of a ``CornerBlend`` between lines and arcs): it must give the very values of the
blend's own numpy evaluation, at every order up to the jerk, to the rounding of the trigonometric
functions: numpy's vectorised sin/cos (numpy >= 2) may differ from the C library's ``math.sin`` by
an ulp (amplified to ~8 ulps in the jerk of a helix blend by its sums), so the two agree within
1e-14 of each derivative's size, not bit for bit (a simulated run
is reproducible for one installed numpy; an error in the plain-float formulas shows as many orders
of magnitude more)."""

from __future__ import annotations

import numpy as np
import pytest

from motionplc.planning.paths.blend import CornerBlend
from motionplc.planning.paths.geometry import Arc, Helix, Line
from motionplc.planning.paths.pieces import CurvePiece


def _cases():
    line = Line([0.0, 0.0, 0.0], [5e-4, 0.0, 0.0])
    arc = Arc.from_tangent([5e-4, 0.0, 0.0], [7e-4, 2e-4, 0.0], [1.0, 0.0, 0.0])
    out = Line(arc.end, arc.end + np.array([0.0, 5e-4, 1e-4]))
    arc2 = Arc.from_tangent(
        arc.end, arc.end + np.array([2e-4, 3e-4, 0.0]), arc.evaluate(arc.u_end, 1)
    )
    helix = Helix(arc.end, [5e-4, 2e-4, 0.0], [0.0, 0.0, 1.0], 1.0, 1e-4)
    return {
        "line-arc": (line, arc),
        "arc-line": (arc, out),
        "arc-arc": (arc, arc2),
        "arc-helix": (arc, helix),
    }


@pytest.mark.parametrize("name", list(_cases()))
def test_curve_piece_of_a_corner_blend_matches_the_blend_bit_for_bit(name: str) -> None:
    a, b = _cases()[name]
    d = 0.4 * min(a.length, b.length)
    piece = CurvePiece(CornerBlend(a, b, d))
    assert piece._fast is not None  # noqa: SLF001 - the plain-float path is used
    rng = np.random.default_rng(7)
    us = [*np.linspace(0.0, piece.U, 401), *rng.uniform(0.0, piece.U, 400), -1.0, 2 * piece.U]
    for u in us:
        fast = piece.at(float(u))
        uu = min(max(float(u), 0.0), piece._u1_in)  # noqa: SLF001 - the piece's own clamp
        ref = tuple(tuple(float(x) for x in np.ravel(k)) for k in piece._path.derivatives(uu, 3))  # noqa: SLF001
        for k, (f, r) in enumerate(zip(fast, ref, strict=True)):
            scale = max(abs(x) for x in r) or 1.0
            err = max(abs(x - y) for x, y in zip(f, r, strict=True))
            assert err <= 1e-14 * scale, (name, u, k, err / np.spacing(scale))
