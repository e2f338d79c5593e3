"""G-code programs run by the runtime on configs/gcode/mill4.yaml (ideal drives): every move
one FB, helices with turns and rotary moves, machine events; set values checked by
differencing the traced positions against each axis' limits."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from motionplc.config import build, load_config
from motionplc.gcode_runner import GcodeRunner, load_gcode_job

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
    cfg = load_config(MILL4)
    job = load_gcode_job(prog, cfg)
    with build(cfg) as machine:
        runner = GcodeRunner(job, machine)
        machine.attach(runner, job.task)
        rt = machine.runtime
        rt.run_until(lambda: runner.over, max_seconds=120.0)
        assert runner.finished, runner.failures
        assert runner.moves_sent == runner.lines_total  # one FB per move (helix: 1 FB)
        trace = rt.trace
        dt = cfg.runtime.tasks[0].period
        for name in ("x", "y", "z", "a"):
            spec = cfg.axis(name).limits
            p = trace.column(f"{name}.position")[:: int(round(dt / cfg.runtime.tick))]
            v = np.diff(p) / dt
            a = np.diff(v) / dt
            assert np.max(np.abs(v)) <= spec.v_max * (1 + 1e-6) + 1e-9, name
            assert np.max(np.abs(a)) <= spec.a_max * (1 + 1e-3) + 1e-6, name
        g54 = {"X": 0.3, "Y": 0.2, "Z": -0.05}
        tool_z = 0.05
        assert trace.last("x.position") == pytest.approx(g54["X"] + 0.02, abs=1e-9)
        assert trace.last("z.position") == pytest.approx(g54["Z"] + tool_z + 0.005, abs=1e-9)
        assert trace.last("a.position") == pytest.approx(math.pi / 2, abs=1e-9)
        edges = {(e.fb, e.output, e.value) for e in trace.events}
        assert ("gcode", "coolant_flood", True) in edges
        assert ("gcode", "coolant_flood", False) in edges
        assert ("gcode", "clamp", True) in edges
        kinds = [text for _, text in runner.events]
        assert "spindle 3000 rev/min" in kinds and "dwell 0.1 s" in kinds
