"""Corpus programs run by the runtime on the mills, checked on their traces
(tests/gcode/corpus_check.py): limits by differencing the traced positions, every traced
position within the program's blend tolerance of the programmed path, exact G61 corners, the
end point. A representative subset (G64 P with the G64 Q merge, G61 with helices with turns
and a ZX arc, a canned cycle in loops on the 4-axis mill; rotary A moves blended with X are
checked the same way in test_gcode_run.py);
``tools/gcode_corpus.py`` runs the whole corpus on both mills and prints the figures. The
checker itself is tested on traces with the defects it must find."""

from __future__ import annotations

import numpy as np
import pytest

from motionplc.gcode import GcodeMove, MachineSetup, parse_gcode
from tests.gcode.corpus_check import (
    CORPUS_DIR,
    MILL3,
    MILL4,
    PATH_ATOL,
    exact_corners,
    path_check,
    run_checked,
    segments,
)

SUBSET = [
    ("spiral_00", MILL3),  # G64 P0.01 Q0.005: 145 chords merged, blended
    ("helix_00", MILL3),  # G61: helix with two turns, a full circle, a ZX half circle
    ("grid_00", MILL4),  # G81 in nested while loops, G10 L2 / G55, on the 4-axis mill
]  # rotary A with X under G64 P: tests/gcode/test_gcode_run.py (the corpus' take 65 s of motion)


@pytest.mark.parametrize(("name", "config"), SUBSET, ids=[f"{n}-{c.stem}" for n, c in SUBSET])
def test_corpus_program_runs_within_limits_and_tolerance(name: str, config) -> None:  # noqa: ANN001
    r = run_checked(CORPUS_DIR / f"{name}.ngc", config)
    assert r.finished and not r.failures, r.failures
    assert r.dropped_rows == 0
    assert r.limit_violations == 0, r.worst_limit
    assert r.excess <= 0.0, (r.excess, r.excess_at)
    assert r.corner_miss <= r.corner_allowance
    assert r.end_error <= PATH_ATOL
    assert r.ok
    if name == "helix_00":
        assert r.exact_corners >= 5 and r.deviation <= 1e-9  # G61: on the path everywhere
    else:
        assert 0.0 < r.deviation  # the corners are blended


def _segs(text: str):  # noqa: ANN202
    setup = MachineSetup.for_axes(("x", "y", "z"))
    prog = parse_gcode(text, setup=setup)
    return segments(list(prog.items()))


def test_the_checker_finds_a_cut_corner_and_a_blend_beyond_p() -> None:
    exact = _segs("G21 G61 G1 X10 F600\nY10\nM2\n")
    assert [s.tol_end for s in exact] == [0.0, 0.0]
    assert len(exact_corners(exact)) == 1
    on = np.array([[0.0, 0, 0], [5, 0, 0], [10, 0, 0], [10, 5, 0], [10, 10, 0]]) * 1e-3
    assert path_check(exact, on)[1] <= 0.0
    cut = on.copy()
    cut[2] = [9.995e-3, 0.005e-3, 0.0]  # cuts the exact corner: 5 um from both lines
    dev, excess, at, _ = path_check(exact, cut)
    assert at == 2 and dev == pytest.approx(5e-6) and excess == pytest.approx(5e-6 - PATH_ATOL)
    blended = _segs("G21 G64 P0.01 G1 X10 F600\nY10\nM2\n")
    assert blended[0].tol_end == pytest.approx(1e-5)
    assert path_check(blended, cut)[1] <= 0.0  # 5 um from the path, P is 10 um: ok
    far = on.copy()
    far[2] = [9.97e-3, 0.02e-3, 0.0]  # 20 um off both lines: beyond P
    assert path_check(blended, far)[1] > 0.0
    middle = on.copy()
    middle[1] = [5e-3, 1e-6, 0.0]  # off the path halfway along a move: no tolerance there
    assert path_check(blended, middle)[1] > 0.0


def test_the_checker_measures_arcs_and_helices_exactly() -> None:
    segs = _segs("G21 G90 G0 X10 Y0\nG3 X10 Y0 I-10 J0 Z-3 P2 F600\nM2\n")
    helix = segs[-1]
    assert isinstance(helix.move, GcodeMove) and helix.move.turns == 1
    u = np.linspace(0.0, helix.path.u_end, 777)
    pts = helix.path.evaluate(u)
    assert path_check(segs, pts)[0] <= 1e-12
    normal = pts - np.array([0.0, 0.0, 1.0]) * 2e-6  # 2 um along the axis
    assert path_check(segs, normal)[0] == pytest.approx(2e-6 * helix.path._k * 10e-3, rel=0.05)  # noqa: SLF001
