"""G-code programs run by the runtime on configs/gcode/mill4.yaml (ideal drives): every move
one FB, helices with turns and rotary moves, machine events; set values checked by
differencing the traced positions against each axis' limits (group D of the invariants), the
traced path against the program's G64 P."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from tests.gcode.corpus_check import run_checked

ROOT = Path(__file__).resolve().parents[2]
MILL4 = ROOT / "configs" / "gcode" / "mill4.yaml"

PROGRAM = """\
%
(run test: helix with turns, ZX arc, drilling cycle, rotary A, events)
G21 G90 G17 G64 P0.05
T1 M6
G43 H1
S3000 M3
M8
M62 P0
G0 X10 Y0 Z5 A0
G1 Z0 F1200
G2 I-10 J0 Z-4 P2
G18 G2 X-10 Z-4 I-10 K0
G17 G0 Z5
G98 G81 X0 Y20 Z-3 R2 F600
G80
G1 X20 A90 F1500
G4 P0.1
M9
M5
M30
%
"""


def test_a_program_runs_within_the_limits_with_its_events(tmp_path: Path) -> None:
    prog = tmp_path / "run.ngc"
    prog.write_text(PROGRAM)
    seen: dict[str, object] = {}

    def inspect(machine, runner) -> None:  # noqa: ANN001
        trace = machine.runtime.trace
        seen["last"] = {n: trace.last(f"{n}.position") for n in ("x", "z", "a")}
        seen["edges"] = {(e.fb, e.output, e.value) for e in trace.events}
        seen["events"] = [text for _, text in runner.events]
        seen["sent"] = (runner.moves_sent, runner.lines_total)

    # limits by differencing every axis' traced positions, the path within G64 P of the
    # program, exact corners, the end point (tests/gcode/corpus_check.py)
    r = run_checked(prog, MILL4, inspect=inspect, timeout=120.0)
    assert r.finished, r.failures
    assert r.limit_violations == 0, r.worst_limit
    assert r.excess <= 0.0, (r.excess, r.excess_at)
    assert r.ok
    assert r.deviation > 0.0 and r.tolerances == (5e-5,)
    sent, total = seen["sent"]  # type: ignore[misc]
    assert sent == total  # one FB per move (helix: 1 FB)
    g54 = {"X": 0.3, "Y": 0.2, "Z": -0.05}
    tool_z = 0.05
    last = seen["last"]
    assert last["x"] == pytest.approx(g54["X"] + 0.02, abs=1e-9)  # type: ignore[index]
    assert last["z"] == pytest.approx(g54["Z"] + tool_z + 0.005, abs=1e-9)  # type: ignore[index]
    assert last["a"] == pytest.approx(math.pi / 2, abs=1e-9)  # type: ignore[index]
    edges = seen["edges"]
    assert ("gcode", "coolant_flood", True) in edges  # type: ignore[operator]
    assert ("gcode", "coolant_flood", False) in edges  # type: ignore[operator]
    assert ("gcode", "clamp", True) in edges  # type: ignore[operator]
    kinds = seen["events"]
    assert "spindle 3000 rev/min" in kinds and "dwell 0.1 s" in kinds  # type: ignore[operator]
