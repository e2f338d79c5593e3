"""G-code programs on an axes group: the mapping of moves to group FB calls, the runner, and
``motionplc run configs/gantry.yaml configs/gcode/rounded_rectangle.ngc`` judged on its trace.

The rounded rectangle runs once (module fixture, X/Y on virtual CAN and Z on Modbus drives,
simulated clock) through the command line; its trace CSV is checked without trusting the
kernel: the programmed corners come from pygcode (a peer parser), the corner deviation and the
limits from the traced set positions (polyline distances, finite differences).
"""

from __future__ import annotations

import json
import math
import re
from pathlib import Path

import numpy as np
import pytest

from motionplc.cli import main
from motionplc.config import build, load_config
from motionplc.gcode import GcodeError, load_gcode, move_path, parse_gcode
from motionplc.gcode_runner import (
    GcodeRunner,
    group_moves,
    load_gcode_job,
)
from motionplc.planning.paths import Arc
from motionplc.scope import read_trace

ROOT = Path(__file__).resolve().parents[2]
CONFIGS = ROOT / "configs"
RECT = CONFIGS / "gcode" / "rounded_rectangle.ngc"
P_TOL = 1e-4  # G64 P0.1 (mm) of rounded_rectangle.ngc
TASK_PERIOD = 0.002  # configs/gantry.yaml: the motion task

IDEAL = """\
runtime:
  tick: 0.001
  tasks:
    motion: {period: 0.001}
axes:
  x:
    limits: {v_max: 1.0, a_max: 4.0, j_max: 40.0}
    software_limits: {min: -1.0, max: 1.0}
  y:
    limits: {v_max: 0.8, a_max: 3.0, j_max: 30.0}
    software_limits: {min: -1.0, max: 1.0}
  z:
    limits: {v_max: 0.3, a_max: 2.0, j_max: 20.0}
    software_limits: {min: -0.2, max: 0.2}
groups:
  xyz: [x, y, z]
"""


def mapped(text: str, start=(0.0, 0.0, 0.0), limits=None, axes=("x", "y", "z")):
    return group_moves(parse_gcode(text, "t.ngc", axes), start, limits)


def mapping_errors(text: str, **kw) -> list[str]:
    with pytest.raises(GcodeError) as info:
        mapped(text, **kw)
    return list(info.value.errors)


# ------------------------------------------------------------------------------ mapping
@pytest.mark.parametrize(("code", "normal"), [("G18", (0, 1, 0)), ("G19", (1, 0, 0))])
def _ideal_machine(tmp_path: Path):
    cfg_path = tmp_path / "m.yaml"
    cfg_path.write_text(IDEAL)
    return load_config(cfg_path)


def test_runtime_failure_names_the_gcode_line_and_error_id(tmp_path: Path) -> None:
    cfg = _ideal_machine(tmp_path)
    prog = tmp_path / "f.ngc"
    prog.write_text("G21 G90 G64 F6000\nG1 X100\nG1 X200 Y50\nG1 X0 Y0\n")
    job = load_gcode_job(prog, cfg)
    with build(cfg) as machine:
        runner = GcodeRunner(job, machine)
        machine.attach(runner, job.task)

        pulled = []

        def fault(ctx) -> None:  # noqa: ANN001 - a task program
            if ctx.t >= 1.5 and not pulled:
                pulled.append(ctx.t)
                machine.axes["y"].raise_axis_error("COMMUNICATION_LOST", "cable pulled")

        machine.attach(fault, job.task)
        machine.runtime.run_until(lambda: runner.over, max_seconds=30.0)
    assert runner.failed and not runner.finished
    (msg,) = runner.failures
    # at t = 1.5 s the second line (X200 Y50, from about 1.0 s to 3.1 s) is running
    assert re.match(
        rf"{re.escape(str(prog))}:3: G1: MC_MoveLinearAbsolute failed with AXIS_ERROR_STOP "
        r"\(0x[0-9A-F]{4}\).* at t = 1\.5\d\d s \(line 'G1 X200 Y50'\); axis 'y': "
        r"COMMUNICATION_LOST \(0x[0-9A-F]{4}\): cable pulled",
        msg,
    ), msg
    assert runner.lines_run == 1


def _programmed_corners() -> list[tuple[float, float, float]]:
    """The end point of every motion line of rounded_rectangle.ngc, by pygcode's machine."""
    pygcode = pytest.importorskip("pygcode")
    machine = pygcode.Machine()
    ends = []
    for raw in RECT.read_text().splitlines():
        text = re.sub(r"\(.*?\)", "", raw).split(";")[0].strip()
        if not text or text.startswith("%"):
            continue
        block = pygcode.Line(text).block
        before = machine.pos.vector
        machine.process_block(block)
        if any(str(g).startswith(("G00", "G01", "G02", "G03")) for g in block.gcodes):
            after = machine.pos.vector
            if tuple(after) != tuple(before) or str(block.gcodes[-1]).startswith(("G02", "G03")):
                ends.append(tuple(float(v) * 1e-3 for v in after))
    return ends


@pytest.fixture(scope="module")
def gantry_run(tmp_path_factory: pytest.TempPathFactory) -> dict:
    out = tmp_path_factory.mktemp("gantry")
    trace = out / "rr.csv"
    code = main(["run", str(CONFIGS / "gantry.yaml"), str(RECT), "--trace", str(trace), "-q"])
    return {"code": code, "trace": trace}


def test_cli_run_exits_0_and_writes_the_groups_sidecar(gantry_run: dict) -> None:
    assert gantry_run["code"] == 0
    sidecar = gantry_run["trace"].with_suffix(".groups.json")
    assert json.loads(sidecar.read_text()) == {"groups": {"xyz": ["x", "y", "z"]}}
    tr = read_trace(gantry_run["trace"])
    assert tr.groups == {"xyz": ["x", "y", "z"]}
    assert "xyz.path_velocity" in tr.columns


@pytest.fixture(scope="module")
def positions(gantry_run: dict) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    tr = read_trace(gantry_run["trace"])
    col = {c: tr.data[:, i] for i, c in enumerate(tr.columns)}
    # the run's controlled stop switches the drives off at its end: the rows from then on
    # hold the drives' actual positions as set positions (Disabled); the program's are before
    from motionplc.blocks.enums import AxisState

    n = int(np.nonzero(col["x.state"] != float(AxisState.DISABLED))[0][-1]) + 1
    col = {c: v[:n] for c, v in col.items()}
    return np.stack([col[f"{a}.position"] for a in "xyz"], axis=1), col


def test_ends_at_the_programmed_end_point(positions) -> None:  # noqa: ANN001
    pos, col = positions
    end = _programmed_corners()[-1]
    assert end == pytest.approx((0.6, 0.4, 0.005), abs=1e-12)  # the peer read the file
    assert tuple(pos[-1]) == pytest.approx(end, abs=1e-12)
    assert [col[f"{a}.actual_position"][-1] for a in "xyz"] == pytest.approx(end, abs=1e-5)
    assert col["xyz.path_velocity"][-1] == 0.0


def _polyline_distance(points: np.ndarray, q: np.ndarray) -> float:
    a, b = points[:-1], points[1:]
    d = b - a
    dd = np.einsum("ij,ij->i", d, d)
    t = np.einsum("ij,ij->i", q - a, d) / np.where(dd > 0.0, dd, 1.0)
    t = np.clip(np.where(dd > 0.0, t, 0.0), 0.0, 1.0)
    return float(np.linalg.norm(a + t[:, None] * d - q, axis=1).min()) if len(a) else math.inf


def _corner_passes(pos: np.ndarray, corners, radius: float = 2e-3) -> list[float]:
    """For each corner in program order, the distance from the corner to the traced path
    while the group passes it (the first run of samples within ``radius`` after the previous
    corner's run: the program revisits some corners later)."""
    out = []
    cursor = 0
    for c in corners:
        q = np.asarray(c)
        near = np.linalg.norm(pos[cursor:] - q, axis=1) < radius
        assert near.any(), f"the path never comes near the corner {c}"
        i0 = cursor + int(np.argmax(near))
        rest = near[i0 - cursor :]
        k = int(np.argmin(rest))  # the first sample outside again (0: none)
        i1 = i0 + k if not rest[k] else len(pos)
        out.append(_polyline_distance(pos[max(i0 - 1, 0) : i1 + 1], q))
        cursor = i1
    return out


def test_corner_deviation_within_p_at_every_corner(positions) -> None:  # noqa: ANN001
    """G64 P0.1: every corner (the project's TMMaxCornerDeviation: the distance from the
    programmed corner to the path) within P, a corner blended with the tolerance or a share of
    it, or stopped exactly where that is faster; the reversal at the circle is an exact stop."""
    pos, _ = positions
    corners = _programmed_corners()[:-1]
    moves = list(load_gcode(RECT).moves((0.0, 0.0, 0.0)))
    assert len(moves) == len(corners) + 1
    assert np.abs(np.array([m.end for m in moves[:-1]]) - np.array(corners)).max() <= 1e-12
    # sampled every task cycle: a chord lies inside the curve by at most a dt^2 / 8
    slack = 4.0 * TASK_PERIOD**2 / 8.0
    dev = _corner_passes(pos, corners)
    kinds = []
    for a, b, d in zip(moves[:-1], moves[1:], dev, strict=True):
        ta = move_path(a).evaluate(move_path(a).u_end, 1)
        tb = move_path(b).evaluate(0.0, 1)
        angle = math.degrees(math.acos(max(-1.0, min(1.0, float(np.dot(ta, tb))))))
        assert d <= P_TOL + slack, (a.line, angle, d)
        if angle > 179.0:
            # an exact stop: the group reaches the corner at rest (a sample within one cycle
            # of a jerk-limited start from it: j T^3 / 6 = 5e-8 m)
            kinds.append("stop")
            assert d <= 1e-7, (a.line, d)
        elif angle < 1e-4 and a.kind == b.kind:
            kinds.append("smooth")  # the two half circles: passed at speed on the circle
            assert d <= slack
        elif angle < 1e-4:  # (tangents from the mm program: ~1e-6 degrees apart)
            # a tangent line-arc junction (curvature jump): blended, the blend limited by
            # half the arc here (the kernel gives 0.085 mm when the moves are queued ahead)
            kinds.append("tangent")
            assert d >= 0.5 * P_TOL, (a.line, d)
        else:
            kinds.append("corner")
            # the tolerance is a bound: the group blends with the whole of it, or with 1/4 or
            # 1/16 of the blend, or stops exactly, whichever passes the corner fastest
            # (GroupConfig.corner_choice)
            assert d <= 1e-7 or any(
                0.99 * s * P_TOL <= d <= s * P_TOL + slack for s in (1.0, 0.25, 0.0625)
            ), (a.line, angle, d)
    # 8 corners of 90 degrees and 7 tangent line-arc junctions blended, the reversal where the
    # full circle meets the half circles stopped, the two half circles joined smoothly
    assert [kinds.count(k) for k in ("corner", "tangent", "stop", "smooth")] == [8, 7, 1, 1]


def _distance_to_move(points: np.ndarray, path) -> np.ndarray:  # noqa: ANN001
    """Exact distance of points to a programmed line or arc."""
    if not isinstance(path, Arc):
        p0 = np.asarray(path.evaluate(0.0))
        d = np.asarray(path.evaluate(path.u_end)) - p0
        t = np.clip(((points - p0) @ d) / (d @ d), 0.0, 1.0)
        return np.linalg.norm(p0 + t[:, None] * d - points, axis=1)
    c, r, x, y, phi = path.center, path.radius, path.x_axis, path.y_axis, path.angle
    q = points - c
    qx, qy = q @ x, q @ y
    off = np.linalg.norm(q - np.outer(qx, x) - np.outer(qy, y), axis=1)
    ang = np.arctan2(qy, qx) % (2.0 * math.pi)
    on = (ang <= phi) | (phi >= 2.0 * math.pi * (1 - 1e-12))
    ends = np.minimum(
        np.linalg.norm(points - path.evaluate(0.0), axis=1),
        np.linalg.norm(points - path.evaluate(path.u_end), axis=1),
    )
    return np.where(on, np.hypot(np.hypot(qx, qy) - r, off), ends)


def test_path_stays_within_p_of_the_programmed_path(positions) -> None:  # noqa: ANN001
    """G64 P as LinuxCNC means it: the path within P of the programmed lines and arcs."""
    pos, _ = positions
    rows = pos[::5]  # every 5th sample (10 ms): 5,000 points
    best = np.full(len(rows), math.inf)
    for mv in load_gcode(RECT).moves((0.0, 0.0, 0.0)):
        best = np.minimum(best, _distance_to_move(rows, move_path(mv)))
    assert best.max() <= P_TOL + 4.0 * TASK_PERIOD**2 / 8.0


def test_axis_limits_hold_every_cycle(positions) -> None:  # noqa: ANN001
    """|v|, |a|, |j| of the kernel within the limits, and the finite differences of the
    traced set values (per task cycle: the rows between repeat the last cycle's values)."""
    _, col = positions
    cfg = load_config(CONFIGS / "gantry.yaml")
    for ax in cfg.axes:
        lim = ax.limits
        v, a, j = (col[f"{ax.name}.{f}"] for f in ("velocity", "acceleration", "jerk"))
        p = col[f"{ax.name}.position"]
        assert np.abs(v).max() <= lim.v_max * (1 + 1e-9)
        assert np.abs(a).max() <= lim.a_max * (1 + 1e-9)
        assert np.abs(j).max() <= lim.j_max * (1 + 1e-9)
        assert np.abs(np.diff(a)).max() <= lim.j_max * TASK_PERIOD * (1 + 1e-9)
        assert np.abs(np.diff(p)).max() <= lim.v_max * TASK_PERIOD * (1 + 1e-9)
        assert p.min() >= ax.sw_limit_min and p.max() <= ax.sw_limit_max
