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
from dataclasses import replace
from pathlib import Path
from typing import Any

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


def run_program(
    tmp_path: Path, text: str, depth: int, **group: Any
) -> tuple[np.ndarray, np.ndarray, float]:
    """Positions and traced velocities of every cycle, the motion time (``group``: fields of
    the group's GroupConfig to change)."""
    cfg_p = tmp_path / "cfg.yaml"
    cfg_p.write_text(CONFIG.format(depth=depth))
    prog = tmp_path / "prog.ngc"
    prog.write_text(text)
    cfg = load_config(cfg_p)
    job = load_gcode_job(prog, cfg, "xyz")
    machine = build(cfg, realtime=False)
    try:
        if group:
            g = machine.axes_groups["xyz"]
            g.cfg = replace(g.cfg, **group)
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


def test_fine_segment_wheel_blended_is_faster_than_exact_stop(tmp_path: Path) -> None:
    """G64 on 0.001 in chords: the pieces of the rim run as one profile (RunPiece) with the
    acceleration carried through the joints; never slower than G61, here much faster."""
    p64, _, t64 = run_program(tmp_path, _program("G64", 20.0, 0.03), 64)
    p61, _, t61 = run_program(tmp_path, _program("G61", 20.0, 0.03), 64)
    assert t64 < 0.5 * t61, (t64, t61)
    for pos in (p64, p61):
        assert np.abs(pos[-1] - np.array([0.254, 0.254, -0.0254])).max() == 0.0  # exact end
        for rv, ra, rj in differenced_ratios(pos, 0.001):
            assert rv <= 1.0 + 1e-9 and ra <= 1.0 + 1e-6 and rj <= 1.0 + 1e-6


def _walk(n: int, lo: float, hi: float, seed: int) -> list[tuple[float, float, float]]:
    """A random walk of ``n`` segments of ``lo..hi`` [in] in 3-D (random corners)."""
    rng = np.random.default_rng(seed)
    p = np.array([10.0, 10.0, -1.0])
    out = [tuple(p)]
    for _ in range(n):
        d = rng.normal(size=3) * np.array([1.0, 1.0, 0.3])
        p = p + d / np.linalg.norm(d) * rng.uniform(lo, hi)
        out.append(tuple(p))
    return out


@pytest.mark.parametrize(("lo", "hi", "tol"), [(0.2, 0.8, 0.02), (0.004, 0.04, 0.002)])
def test_random_corners_blended_never_slower_than_exact_stop(
    tmp_path: Path, lo: float, hi: float, tol: float
) -> None:
    """Sharp random corners under jerk limits: a blend the tolerance allows can be slower than
    stopping at the corner; with GroupConfig.corner_choice the group then makes it smaller or
    stops (G64 <= G61)."""
    pts = _walk(25, lo, hi, 7)
    times = {}
    for mode in (f"G64 P{tol}", "G61"):
        lines = ["%", "G20 G90 G17", mode, "G0 X10 Y10 Z-1", "F1200"]
        lines += [f"G1 X{x:.5f} Y{y:.5f} Z{z:.5f}" for x, y, z in pts[1:]]
        text = "\n".join([*lines, "M2", "%"]) + "\n"
        pos, _, times[mode] = run_program(tmp_path, text, 64, corner_choice=True)
        for rv, ra, rj in differenced_ratios(pos, 0.001):
            assert rv <= 1.0 + 1e-9 and ra <= 1.0 + 1e-6 and rj <= 1.0 + 1e-6
    assert times[f"G64 P{tol}"] <= times["G61"] * (1.0 + 1e-9), times
