"""configs/gantry_groups_sequence.yaml on configs/gantry.yaml (X/Y on virtual CAN, Z on a
Modbus drive, simulated clock): the group blocks of a YAML sequence reach their positions, and
the trace (not the kernel) shows the blends within their tolerance, the circle on its circle,
the limits kept and the group's states."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from motionplc.config import build, load_config
from motionplc.sequence import runner_for

CONFIGS = Path(__file__).resolve().parents[2] / "configs"
TASK_PERIOD = 0.002  # the gantry's motion task
Z_WORK = -0.02


@pytest.fixture(scope="module")
def run() -> dict:
    cfg = load_config(CONFIGS / "gantry.yaml")
    with build(cfg) as machine:
        runner, task = runner_for(CONFIGS / "gantry_groups_sequence.yaml", machine)
        machine.attach(runner, task)
        machine.runtime.run_until(lambda: runner.over, max_seconds=25.0)
        trace = machine.runtime.trace
        cols = {c: trace.column(c) for c in trace.columns}
        return {
            "failures": list(runner.failures),
            "finished": runner.finished,
            "steps": runner.steps_done,
            "cols": cols,
            "events": list(trace.events),
            "cfg": cfg,
            "group_state": machine.axes_groups["xyz"].state.name,
            "axes": {n: (ax.state.name, ax.position) for n, ax in machine.axes.items()},
        }


def _pos(run: dict) -> np.ndarray:
    return np.stack([run["cols"][f"{a}.position"] for a in "xyz"], axis=1)


def test_sequence_finishes_with_every_expectation_met(run: dict) -> None:
    assert run["failures"] == []
    assert run["finished"] and run["steps"] == 12
    assert run["group_state"] == "GROUP_DISABLED"
    assert run["axes"]["z"] == ("STANDSTILL", pytest.approx(-0.01, abs=1e-12))
    # every group block was Done (or, for the halted line, CommandAborted) once
    done = {ev.fb for ev in run["events"] if ev.output == "done" and ev.value}
    for name in ("en", "go", "r1", "r2", "r3", "r4", "c1", "c2", "bs", "halt", "dis"):
        assert f"xyz.{name}" in done
    aborted = {ev.fb for ev in run["events"] if ev.output == "command_aborted" and ev.value}
    assert aborted == {"xyz.long"}


def test_group_states_in_the_trace(run: dict) -> None:
    state = run["cols"]["xyz.state"].astype(int)
    from motionplc.blocks.enums import GroupState as G

    seen = [int(s) for s, k in zip(state, np.r_[True, state[1:] != state[:-1]], strict=True) if k]
    assert seen[0] == G.GROUP_DISABLED and seen[-1] == G.GROUP_DISABLED
    assert {G.GROUP_STANDBY, G.GROUP_MOVING} <= set(seen)
    # members in SynchronizedMotion exactly while the group moves
    from motionplc.blocks.enums import AxisState as S

    moving = state == G.GROUP_MOVING
    for a in "xyz":
        sync = run["cols"][f"{a}.state"].astype(int) == S.SYNCHRONIZED_MOTION
        assert not (sync & ~moving).any()


def _corner_distance(points: np.ndarray, q: tuple[float, ...]) -> float:
    a, b = points[:-1], points[1:]
    d = b - a
    dd = np.einsum("ij,ij->i", d, d)
    t = np.clip(np.einsum("ij,ij->i", np.asarray(q) - a, d) / np.where(dd > 0, dd, 1.0), 0, 1)
    return float(np.linalg.norm(a + t[:, None] * d - np.asarray(q), axis=1).min())


def test_rectangle_corners_blended_within_the_tolerance(run: dict) -> None:
    pos = _pos(run)
    work = pos[np.abs(pos[:, 2] - Z_WORK) < 1e-12]  # the rectangle and the circle
    slack = 4.0 * TASK_PERIOD**2 / 8.0  # a chord lies inside the curve by at most a dt^2/8
    for corner in ((0.3, 0.1, Z_WORK), (0.3, 0.25, Z_WORK), (0.1, 0.25, Z_WORK)):
        d = _corner_distance(work, corner)
        # the tolerance is a bound (GroupConfig.corner_choice): a blend with the whole of it,
        # 1/4 or 1/16 of the blend, or an exact stop, whichever passes the corner fastest
        assert d <= 1e-7 or any(
            0.99e-3 * s <= d <= 1e-3 * s + slack for s in (1.0, 0.25, 0.0625)
        ), (corner, d)
    # the path never leaves the rectangle's edges by more than the tolerance
    rect = work[(work[:, 1] > 0.1 - 1e-12) & (work[:, 0] > 0.1 + 1e-9)]
    edge = np.minimum.reduce(
        [
            np.abs(rect[:, 1] - 0.1),
            np.abs(rect[:, 0] - 0.3),
            np.abs(rect[:, 1] - 0.25),
            np.abs(rect[:, 0] - 0.1),
        ]
    )
    inside_circle = np.hypot(rect[:, 0] - 0.15, rect[:, 1] - 0.1) <= 0.05 + 1e-9
    assert edge[~inside_circle].max() <= 1e-3


def test_circle_on_its_circle_and_passed_smoothly(run: dict) -> None:
    pos = _pos(run)
    speed = run["cols"]["xyz.path_velocity"]
    work = (np.abs(pos[:, 2] - Z_WORK) < 1e-12) & (pos[:, 0] < 0.2 + 1e-12)
    below = work & (pos[:, 1] < 0.1 - 1e-9)  # the second half circle (BORDER)
    above = work & (pos[:, 1] > 0.1 + 1e-9) & (pos[:, 0] > 0.1 + 1e-9) & (pos[:, 1] < 0.15)
    for part in (below, above):
        assert part.sum() > 100
        r = np.hypot(pos[part, 0] - 0.15, pos[part, 1] - 0.1)
        assert np.abs(r - 0.05).max() <= 1e-9
    # the joint of the two halves at (0.2, 0.1) is passed at speed (tangent, same curvature)
    i = int(np.argmin(np.linalg.norm(pos - np.array([0.2, 0.1, Z_WORK]), axis=1)))
    assert speed[i] > 0.25
    # the clockwise half goes over the top first: y > 0.1 before y < 0.1
    assert np.argmax(above) < np.argmax(below)


def test_axis_limits_hold_every_cycle(run: dict) -> None:
    cols = run["cols"]
    for ax in run["cfg"].axes:
        lim = ax.limits
        for f, top in (("velocity", lim.v_max), ("acceleration", lim.a_max), ("jerk", lim.j_max)):
            assert np.abs(cols[f"{ax.name}.{f}"]).max() <= top * (1 + 1e-9), (ax.name, f)
        a = cols[f"{ax.name}.acceleration"]
        p = cols[f"{ax.name}.position"]
        assert np.abs(np.diff(a)).max() <= lim.j_max * TASK_PERIOD * (1 + 1e-9)
        assert np.abs(np.diff(p)).max() <= lim.v_max * TASK_PERIOD * (1 + 1e-9)
    # the path speed is continuous: its change per cycle within the fastest axis' a_max * dt
    # times sqrt(3) (three axes)
    v = cols["xyz.path_velocity"]
    assert np.abs(np.diff(v)).max() <= math.sqrt(3) * 4.0 * TASK_PERIOD * (1 + 1e-9)
