"""Arcs must not fail by one rounding step (issue 25 point 7): G2/G3 moves aborted with
``PLANNING_FAILED ... distance: must be in (0.0, D], got D(1+eps)``.

The distance was computed twice, differently: the group trims the neighbours of a corner to the
room it allows (``seg.trim(u_end - room, u_end)``) and asks ``_solve_deviation`` for a blend of at
most ``room``; the trimmed arc's own length is ``radius * ((u1 - u0) / radius)``, which can be one
rounding step short of ``room``, and a blend of distance ``room`` on it was refused. The blend's
cap is now the trimmed pieces' own lengths. Reproduced here with arcs of awkward radii and angles
(hypothesis), directly and through the axes group and a G-code program.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from motionplc.blocks.enums import BufferMode, CircMode, PathChoice, TransitionMode
from motionplc.blocks.group_blocks import MC_MoveCircularAbsolute, MC_MoveLinearAbsolute
from motionplc.config import build, load_config
from motionplc.gcode_runner import GcodeRunner, load_gcode_job
from motionplc.planning.paths.blend import _solve_deviation
from motionplc.planning.paths.geometry import Arc, Line
from tests.blocks.group_rig import GroupBench


def _arc(cx: float, cy: float, r: float, phi0: float, angle: float) -> Arc:
    return Arc(
        (cx, cy), r, (math.cos(phi0), math.sin(phi0)), (-math.sin(phi0), math.cos(phi0)), angle
    )


def _trimmed_corner(arc: Arc, turn: float, out_len: float) -> tuple[Arc, Line, float]:
    """The group's view of an arc-line corner: both sides trimmed to the room (half of each)."""
    t = arc.evaluate(arc.u_end, 1)
    c, s = math.cos(turn), math.sin(turn)
    d = np.array([c * t[0] - s * t[1], s * t[0] + c * t[1]])
    line = Line(arc.end, arc.end + d * out_len)
    room = min(0.5 * arc.length, 0.5 * line.length)
    a_part = arc.trim(max(0.0, arc.u_end - room), arc.u_end)
    b_part = line.trim(0.0, min(line.u_end, room))
    return a_part, b_part, room


@settings(max_examples=400, deadline=None)
@given(
    cx=st.floats(-1.0, 1.0),
    cy=st.floats(-1.0, 1.0),
    r=st.floats(1e-5, 2.0),
    phi0=st.floats(0.0, 2.0 * math.pi),
    angle=st.floats(0.01, 2.0 * math.pi),
    turn=st.floats(0.05, 2.5),
    out=st.floats(0.1, 5.0),
    tol=st.sampled_from([1e-6, 1e-4, 1e3]),
)
def test_blend_of_a_trimmed_arc_never_exceeds_its_own_length(
    cx, cy, r, phi0, angle, turn, out, tol
) -> None:
    arc = _arc(cx, cy, r, phi0, angle)
    a_part, b_part, room = _trimmed_corner(arc, turn, out * r)
    blend = _solve_deviation(a_part, b_part, tol, room, turn)
    if blend is not None:
        assert 0.0 < blend.distance <= min(a_part.length, b_part.length)
        assert blend.distance <= room
        if tol >= 1e3:  # any deviation allowed: the blend takes all the room there is
            assert blend.distance == min(room, a_part.length, b_part.length)
            assert blend.distance >= room * (1.0 - 1e-13)  # (the trims' rounding, no more)


def test_the_known_one_ulp_case() -> None:
    """A case the old code refused: the trimmed arc is one ulp shorter than the room."""
    for seed in range(200):
        rng = np.random.default_rng(seed)
        arc = _arc(*rng.uniform(-1, 1, 2), 10 ** rng.uniform(-4, 0), *rng.uniform(0.05, 6.2, 2))
        a_part, b_part, room = _trimmed_corner(arc, 1.0, 2.0 * arc.radius)
        if a_part.length < room:
            blend = _solve_deviation(a_part, b_part, 1e3, room, 1.0)
            assert blend is not None and blend.distance == a_part.length
            return
    raise AssertionError("no one-ulp case in 200 random arcs (expected about 1 in 4)")


@settings(
    max_examples=12,
    deadline=None,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture],
)
@given(
    r=st.floats(0.003, 0.09),
    start_angle=st.floats(0.0, 2.0 * math.pi),
    sweep=st.floats(0.2, 3.0),
    cw=st.booleans(),
    tol=st.sampled_from([1e-5, 1e-4, 1e-2]),
)
def test_group_line_arc_line_with_blends_completes(r, start_angle, sweep, cw, tol) -> None:
    """line -> CENTER arc -> line, both corners blended under TMMaxCornerDeviation: every move
    done (no PLANNING_FAILED by a rounding step), the invariants (group D included) hold."""
    b = GroupBench(axes={k: v for k, v in GroupBench().limits.items() if k != "z"}).enabled()
    c = np.array([0.5, 0.4])
    sgn = -1.0 if cw else 1.0
    p_start = c + r * np.array([math.cos(start_angle), math.sin(start_angle)])
    end_angle = start_angle + sgn * sweep
    p_end = c + r * np.array([math.cos(end_angle), math.sin(end_angle)])
    tin = sgn * np.array([-math.sin(start_angle), math.cos(start_angle)])
    tout = sgn * np.array([-math.sin(end_angle), math.cos(end_angle)])
    # approach and leave at an angle to the arc's tangents (real corners)
    rot = np.array([[math.cos(0.7), -math.sin(0.7)], [math.sin(0.7), math.cos(0.7)]])
    before = p_start - rot @ tin * 0.05
    after = p_end + rot @ tout * 0.05
    blend = {
        "buffer_mode": BufferMode.BLENDING_LOW,
        "transition_mode": TransitionMode.TM_MAX_CORNER_DEVIATION,
        "transition_parameter": tol,
    }
    m0 = b.add(MC_MoveLinearAbsolute(execute=True, position=tuple(before), velocity=0.5))
    b.run_until_idle()
    m1 = b.add(MC_MoveLinearAbsolute(execute=True, position=tuple(p_start), velocity=0.3))
    m2 = b.add(
        MC_MoveCircularAbsolute(
            execute=True,
            circ_mode=CircMode.CENTER,
            aux_point=tuple(c),
            end_point=tuple(p_end),
            path_choice=PathChoice.CLOCKWISE if cw else PathChoice.COUNTER_CLOCKWISE,
            velocity=0.3,
            **blend,
        )
    )
    m3 = b.add(MC_MoveLinearAbsolute(execute=True, position=tuple(after), velocity=0.3, **blend))
    b.run_until_idle()
    for m in (m0, m1, m2, m3):
        assert m.done, (m.error_id, m.error_text)


GCODE_CFG = """\
runtime:
  tick: 0.001
  tasks:
    motion: {period: 0.001}
axes:
  x: {limits: {v_max: 1.0, a_max: 4.0, j_max: 40.0}}
  y: {limits: {v_max: 1.0, a_max: 4.0, j_max: 40.0}}
  z: {limits: {v_max: 0.3, a_max: 2.0, j_max: 20.0}}
groups:
  xyz: [x, y, z]
"""


def test_gcode_arcs_of_awkward_radii_run(tmp_path: Path) -> None:
    """A G-code program of G1/G2/G3 with awkward radii (R and I/J), blended with G64 P:
    validate-clean and every line runs."""
    rng = np.random.default_rng(25)
    lines = ["G21 G90 G17 G64 P0.5 F3000", "G0 X10 Y10 Z0"]
    x, y = 10.0, 10.0
    for k in range(24):
        r = float(rng.uniform(0.3, 7.0))
        ang = float(rng.uniform(0.3, 2.8))
        phi = float(rng.uniform(0.0, 2.0 * math.pi))
        cx, cy = x - r * math.cos(phi), y - r * math.sin(phi)
        ccw = bool(rng.integers(2))
        ex = cx + r * math.cos(phi + (ang if ccw else -ang))
        ey = cy + r * math.sin(phi + (ang if ccw else -ang))
        word = "G3" if ccw else "G2"
        if k % 2:
            lines.append(f"{word} X{ex:.9f} Y{ey:.9f} I{cx - x:.9f} J{cy - y:.9f}")
        else:
            rr = r if ang <= math.pi else -r
            lines.append(f"{word} X{ex:.9f} Y{ey:.9f} R{rr:.9f}")
        x, y = ex, ey
        x, y = x + float(rng.uniform(-3, 3)), y + float(rng.uniform(-3, 3))
        lines.append(f"G1 X{x:.9f} Y{y:.9f}")
    prog = tmp_path / "arcs.ngc"
    prog.write_text("\n".join(lines) + "\nM2\n")
    cfg_path = tmp_path / "m.yaml"
    cfg_path.write_text(GCODE_CFG)
    cfg = load_config(cfg_path)
    job = load_gcode_job(prog, cfg)
    with build(cfg) as machine:
        runner = GcodeRunner(job, machine)
        machine.attach(runner, job.task)
        machine.runtime.run_until(lambda: runner.over, max_seconds=120.0)
        assert runner.failures == [] and runner.finished, runner.failures
