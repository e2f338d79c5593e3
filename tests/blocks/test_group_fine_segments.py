"""Axes group on fine-segment G-code (0.001 in segments, small wheel contours): the set positions
checked by differencing at the cycle time (never the kernel's v/a/j columns).

Regression of issue 25 point 6 (the freeze-and-jump): with a short look-ahead, a corner blend
entering the queue trimmed the piece before it and so lowered the junction speeds below what the
running piece was committed to; the next piece was then planned between speeds it cannot join
(its profile left the piece), the set position stood still at the piece's end while the traced
velocity ran +v -> -v -> +v, then jumped: ~100x the jerk limit by third differences.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from motionplc.config import build, load_config
from motionplc.gcode_runner import GcodeRunner, load_gcode_job

LIMITS = {"x": (1.0, 4.0, 40.0), "y": (0.8, 3.0, 30.0), "z": (0.3, 2.0, 20.0)}
CONFIG = """runtime:
  tick: 0.001
  clock: simulated
  tasks:
    motion: {{period: 0.001, priority: 1}}
axes:
  x: {{limits: {{v_max: 1.0, a_max: 4.0, j_max: 40.0}}, software_limits: {{min: 0.0, max: 1.2}}}}
  y: {{limits: {{v_max: 0.8, a_max: 3.0, j_max: 30.0}}, software_limits: {{min: 0.0, max: 0.8}}}}
  z: {{limits: {{v_max: 0.3, a_max: 2.0, j_max: 20.0}}, software_limits: {{min: -0.2, max: 0.01}}}}
groups:
  xyz: {{axes: [x, y, z], queue_depth: {depth}, tolerance: 1.0e-4}}
"""


def wheel(cx: float, cy: float, r: float, seg: float, spokes: int) -> list[tuple[float, float]]:
    """A wheel contour (spokes from the hub and rim arcs between them) as chords of at most
    ``seg`` (CAM style: every feature in tiny segments)."""
    corners = []
    n = max(8, round(2.0 * math.pi * r / seg))
    for s in range(spokes):
        a0, a1 = 2.0 * math.pi * s / spokes, 2.0 * math.pi * (s + 1) / spokes
        corners.append((cx, cy))
        m = max(1, round(n / spokes))
        for i in range(m + 1):
            a = a0 + (a1 - a0) * i / m
            corners.append((cx + r * math.cos(a), cy + r * math.sin(a)))
    corners.append((cx, cy))
    out = [corners[0]]
    for (x0, y0), (x1, y1) in zip(corners[:-1], corners[1:], strict=True):
        k = max(1, math.ceil(math.hypot(x1 - x0, y1 - y0) / seg - 1e-9))
        out.extend((x0 + (x1 - x0) * i / k, y0 + (y1 - y0) * i / k) for i in range(1, k + 1))
    return out


def _program(mode: str, feed: float, r: float) -> str:
    lines = ["%", "G20 G90 G17", mode, "G0 X10 Y10 Z-1", f"F{feed:g}"]
    lines += [f"G1 X{x:.5f} Y{y:.5f}" for x, y in wheel(10.0, 10.0, r, 0.001, 4)]
    return "\n".join([*lines, "M2", "%"]) + "\n"


def run_program(tmp_path: Path, text: str, depth: int) -> tuple[np.ndarray, np.ndarray, float]:
    """Positions and traced velocities of every cycle, the motion time."""
    cfg_p = tmp_path / "cfg.yaml"
    cfg_p.write_text(CONFIG.format(depth=depth))
    prog = tmp_path / "prog.ngc"
    prog.write_text(text)
    cfg = load_config(cfg_p)
    job = load_gcode_job(prog, cfg, "xyz")
    machine = build(cfg, realtime=False)
    try:
        runner = GcodeRunner(job, machine)
        machine.attach(runner, job.task)
        rt = machine.runtime
        rt.run_until(lambda: runner.over, max_seconds=120.0)
        assert runner.finished and not runner.failures, runner.failures
        tr = rt.trace
        pos = np.stack([tr.column(f"{n}.position") for n in LIMITS], axis=1)
        vel = np.stack([tr.column(f"{n}.velocity") for n in LIMITS], axis=1)
        motion = (runner.t_finished or rt.time) - (runner.t_motion or 0.0)
    finally:
        machine.close()
    return pos, vel, motion


def differenced_ratios(pos: np.ndarray, dt: float) -> list[tuple[float, float, float]]:
    """Per axis: max |first|, |second|, |third| difference of the positions over the cycle
    time, as a share of v_max, a_max, j_max."""
    out = []
    for i, (v, a, j) in enumerate(LIMITS.values()):
        p = pos[:, i]
        out.append(
            (
                float(np.abs(np.diff(p)).max() / dt / v),
                float(np.abs(np.diff(p, 2)).max() / dt**2 / a),
                float(np.abs(np.diff(p, 3)).max() / dt**3 / j),
            )
        )
    return out


@pytest.mark.parametrize("depth", [4, 16])
def test_fine_segment_wheel_never_freezes_and_holds_the_limits_by_differencing(
    tmp_path: Path, depth: int
) -> None:
    pos, vel, _ = run_program(tmp_path, _program("G64", 20.0, 0.03), depth)
    # the set position never stands still while the traced velocity says it moves
    still = np.all(np.diff(pos, axis=0) == 0.0, axis=1)
    moving = np.linalg.norm(vel[1:], axis=1) > 1e-6
    assert not np.any(still & moving), int(np.sum(still & moving))
    for name, (rv, ra, rj) in zip(LIMITS, differenced_ratios(pos, 0.001), strict=True):
        # (third differences of positions ~0.25 m carry ~1e-8 of rounding at 1 ms)
        assert rv <= 1.0 + 1e-9 and ra <= 1.0 + 1e-6 and rj <= 1.0 + 1e-6, (name, rv, ra, rj)
