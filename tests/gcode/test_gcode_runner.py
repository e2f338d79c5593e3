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

from motionplc.blocks.enums import BufferMode, CircMode, PathChoice, TransitionMode
from motionplc.cli import main
from motionplc.config import build, load_config
from motionplc.gcode import GcodeError, load_gcode, move_path, parse_gcode
from motionplc.gcode_runner import (
    RAPID_VELOCITY,
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
def test_lines_rapids_and_corner_modes_follow_linuxcnc() -> None:
    moves = mapped(
        "G21 G90 F600\n"
        "G1 X10\n"  # 2: first move, from rest
        "G1 Y10\n"  # 3: corner at X10 under G61 (start state): exact stop
        "G64 P0.5 G1 X0\n"  # 4: corner at Y10 still G61 (mode of line 3)
        "G64 G0 Y0\n"  # 5: corner at the end of line 4, under G64 P0.5
        "G1 Z-1\n"  # 6: corner at the end of line 5, G64 without P
    )
    got = [
        (m.line, m.kind, m.buffer_mode, m.transition_mode, m.transition_parameter) for m in moves
    ]
    B, TM = BufferMode, TransitionMode
    assert got == [
        (2, "linear", B.BUFFERED, TM.TM_NONE, 0.0),
        (3, "linear", B.BUFFERED, TM.TM_NONE, 0.0),
        (4, "linear", B.BUFFERED, TM.TM_NONE, 0.0),
        (5, "linear", B.BLENDING_LOW, TM.TM_MAX_CORNER_DEVIATION, pytest.approx(0.5e-3)),
        (6, "linear", B.BLENDING_LOW, TM.TM_MAX_CORNER_DEVIATION, 0.0),
    ]
    assert [m.velocity for m in moves] == [0.01, 0.01, 0.01, RAPID_VELOCITY, 0.01]
    assert [m.position for m in moves][-1] == pytest.approx((0.0, 0.0, -0.001), abs=1e-15)
    assert all(m.last for m in moves)


def test_xy_arcs_are_center_arcs_and_full_circles_are_split() -> None:
    moves = mapped("G21 G90 F600\nG0 X10\nG2 X20 Y10 I10\nG3 I-10 J0 P2\n")
    arc = moves[1]
    assert (arc.kind, arc.circ_mode, arc.path_choice) == (
        "circular",
        CircMode.CENTER,
        PathChoice.CLOCKWISE,
    )
    assert arc.aux_point == pytest.approx((0.02, 0.0, 0.0), abs=1e-15)
    assert arc.position == pytest.approx((0.02, 0.01, 0.0), abs=1e-15)
    # G3 with P2: two full turns about (0.01, 0.01) as four half circles, one G-code move
    turns = moves[2:]
    assert len(turns) == 4 and {m.index for m in turns} == {2}
    assert [m.last for m in turns] == [False, False, False, True]
    assert all(m.path_choice is PathChoice.COUNTER_CLOCKWISE for m in turns)
    assert all(m.aux_point == pytest.approx((0.01, 0.01, 0.0), abs=1e-15) for m in turns)
    # the joints inside the circle are passed at speed (tangent, equal curvature)
    assert [m.transition_mode for m in turns[1:]] == [TransitionMode.TM_NONE] * 3
    assert [m.buffer_mode for m in turns[1:]] == [BufferMode.BLENDING_LOW] * 3
    # every piece ends on the circle, the last exactly at the programmed end
    for m in turns:
        assert math.dist(m.position, (0.01, 0.01, 0.0)) == pytest.approx(0.01, rel=1e-12)
    assert turns[-1].position == moves[1].position


@pytest.mark.parametrize(("code", "normal"), [("G18", (0, 1, 0)), ("G19", (1, 0, 0))])
def test_arcs_outside_xy_are_border_arcs_through_points_of_the_programmed_arc(
    code: str, normal: tuple[int, int, int]
) -> None:
    # from (5, 5, 5) mm: a half circle about (5, 5, 0) to Z-5, then a full circle back (G3)
    text = f"G21 G90 F600 {code}\nG0 X5 Y5 Z5\nG2 Z-5 K-5\nG3 K5\n"
    moves = mapped(text)[1:]
    assert all(m.kind == "circular" and m.circ_mode is CircMode.BORDER for m in moves)
    assert [m.index for m in moves] == [1, 2, 2]  # the full circle as two half circles
    assert [m.last for m in moves] == [True, False, True]
    center = np.array([0.005, 0.005, 0.0])
    start = np.array([0.005, 0.005, 0.005])
    for m, sense in zip(moves, (-1.0, 1.0, 1.0), strict=True):  # G2 clockwise, G3 ccw
        via, end = np.array(m.aux_point), np.array(m.position)
        for p in (via, end):  # on the programmed circle, in its plane
            assert np.linalg.norm(p - center) == pytest.approx(0.005, rel=1e-12)
            assert float(np.dot(p - center, normal)) == pytest.approx(0.0, abs=1e-15)
        # via between start and end in the programmed sense, seen from the normal's + side
        turn1 = float(np.dot(np.cross(start - center, via - center), normal))
        turn2 = float(np.dot(np.cross(via - center, end - center), normal))
        assert np.sign(turn1) == np.sign(turn2) == sense
        assert np.linalg.norm(via - start) == pytest.approx(np.linalg.norm(end - via), rel=1e-9)
        start = end
    assert tuple(moves[-1].position) == pytest.approx((0.005, 0.005, -0.005), abs=1e-15)


def test_a_helix_is_a_located_error_before_the_run_never_skipped() -> None:
    errs = mapping_errors("G21 F600\nG1 X10\nG17 G2 X20 Y10 I10 Z-2\nG1 X0\nG3 I5 Z1 P2\n")
    assert len(errs) == 2
    assert errs[0].startswith("t.ngc:3: G2: helix (the arc in the XY plane also moves Z by ")
    assert "(allowed: arcs in one plane, lines" in errs[0]
    assert errs[1].startswith("t.ngc:5: G3: helix") and "1 extra turns" in errs[1]


def test_software_limits_and_feed_range_are_located_errors() -> None:
    limits = [(0.0, 0.1), (0.0, 0.1), (None, None)]
    errs = mapping_errors(
        "G21 F600\nG1 X50 Y50\nG1 X120\nG2 X70 Y50 I-25 J0\nG1 X50 F100000000000000\nG2 X0 I1\n",
        limits=limits,
    )
    assert errs[0] == (
        "t.ngc:3: G1: the move takes axis 'x' to 0.12 m, outside its software limits "
        "[0, 0.1] m (allowed: a path within the limits)"
    )
    # the mapping goes on from the refused move's end (every problem of the file at once)
    assert errs[1].startswith("t.ngc:4: G2: the arc takes axis 'x' to 0.12 m")
    assert errs[2].startswith("t.ngc:5: G1: feed 1.66666667e+09 m/s is above the path-speed")
    # the resolver's geometric error (radii differ) ends the list
    assert errs[3].startswith("t.ngc:6: G2: radius to the end ") and len(errs) == 4


def test_arc_extent_is_exact() -> None:
    # a near half circle over the top from (-10, 0) to (10, 0) mm: it bulges beyond both end
    # points; its highest point is R - sqrt(R^2 - 10^2) above... the centre's height + R
    text = "G21 F600\nG0 X-10\nG2 X10 Y0 R10.001\n"
    top = (10.001 - math.sqrt(10.001**2 - 100.0)) * 1e-3
    errs = mapping_errors(text, limits=[(-1.0, 1.0), (-1.0, top - 1e-9), (None, None)])
    assert len(errs) == 1 and errs[0].startswith("t.ngc:3: G2: the arc takes axis 'y' to ")
    assert float(errs[0].split(" to ")[1].split(" m")[0]) == pytest.approx(top, rel=1e-8)
    assert len(mapped(text, limits=[(-1.0, 1.0), (-1.0, top + 1e-9), (None, None)])) == 2


# ------------------------------------------------------------------------------ running
def _ideal_machine(tmp_path: Path):
    cfg_path = tmp_path / "m.yaml"
    cfg_path.write_text(IDEAL)
    return load_config(cfg_path)


def test_runner_follows_zx_arcs_and_feeds_at_most_per_cycle(tmp_path: Path) -> None:
    cfg = _ideal_machine(tmp_path)
    prog = tmp_path / "zx.ngc"
    lines = ["G21 G90 G64 P0.05 F3000", "G0 X10 Y10 Z0", "G18 G2 X30 Z0 I10"]
    lines += [f"G1 X{30 + 2 * k} Y{10 + (k % 2)}" for k in range(1, 15)] + ["G3 X58 Z0 K-10 I0"]
    prog.write_text("\n".join(lines) + "\n")
    job = load_gcode_job(prog, cfg)
    with build(cfg) as machine:
        runner = GcodeRunner(job, machine, per_cycle=2)
        machine.attach(runner, job.task)
        machine.runtime.run_until(lambda: runner.over, max_seconds=30.0)
        assert runner.failures == [] and runner.finished
        assert runner.lines_run == runner.lines_total == 17
        assert re.search(r"17 of 17 lines run on group 'xyz' .* s of motion", runner.report())
        trace = machine.runtime.trace
        pos = np.stack([trace.column(f"{a}.position") for a in "xyz"], axis=1)
        assert tuple(pos[-1]) == pytest.approx((0.058, 0.010, 0.0), abs=1e-12)
        # the first arc: a half circle about (20, 10, 0) through Z = -10 (G2 in G18 turns from
        # +X towards -Z... seen from +Y, clockwise): every sample while on it lies on it
        on = (pos[:, 0] > 0.0101) & (pos[:, 0] < 0.0299) & (np.abs(pos[:, 1] - 0.01) < 1e-12)
        assert on.sum() > 20
        rad = np.hypot(pos[on, 0] - 0.02, pos[on, 2])
        assert np.abs(rad - 0.01).max() <= 1e-9 and pos[on, 2].max() < 0.0
        # at most per_cycle new moves per cycle (busy edges of the runner's FBs)
        starts: dict[int, int] = {}
        for ev in trace.events:
            move_fb = ev.fb.startswith(("xyz.gcode_linear", "xyz.gcode_circular"))
            if move_fb and ev.output == "busy" and ev.value:
                starts[ev.cycle] = starts.get(ev.cycle, 0) + 1
        assert max(starts.values()) <= 2 and sum(starts.values()) == len(runner.moves)


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


def test_runner_refuses_an_unrunnable_program_before_the_first_cycle(tmp_path: Path) -> None:
    cfg = _ideal_machine(tmp_path)
    job = load_gcode_job(CONFIGS / "gcode" / "planes_helix.ngc", cfg)
    with build(cfg) as machine:
        with pytest.raises(GcodeError) as info:
            GcodeRunner(job, machine)
        assert machine.runtime.tick == 0
    assert [e.split(": ", 2)[1] for e in info.value.errors] == ["G2"]
    assert info.value.errors[0].startswith(f"{job.path}:6: G2: helix")


# ------------------------------------------------------------------------------ the gantry
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
    programmed corner to the path) within P, and the tolerance used where the path has a
    corner (blended, not an exact stop); the reversal at the circle is an exact stop."""
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
            assert d >= 0.99 * P_TOL, (a.line, angle, d)  # the whole tolerance used
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
