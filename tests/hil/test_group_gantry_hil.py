"""Acceptance of axes groups on the shipped gantry (configs/gantry.yaml): X and Y on CANopen
(virtual CiA 402 drives on the in-process CAN bus), Z on Modbus TCP (virtual drive on
127.0.0.1), simulated clock, invariants checked every cycle.

The group ``xyz`` draws a rectangle with rounded corners (blending, TM_MAX_CORNER_DEVIATION),
a circle (two CENTER half circles, blended) and a passing-point curve (B-spline). The trace must
show: the path within the tolerance of the programmed geometry, no axis velocity /
acceleration / jerk limit exceeded in any cycle (the kernel's values and finite differences
of the set positions and accelerations), continuous path speed through every blend, exact end
positions (set values; actual values within the drives' settling), no axis error.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np

from motionplc.blocks import MC_Power
from motionplc.blocks.enums import (
    AxisState,
    BufferMode,
    CircMode,
    GroupState,
    PathChoice,
    TransitionMode,
)
from motionplc.blocks.group_blocks import (
    MC_GroupEnable,
    MC_MoveBSpline,
    MC_MoveCircularAbsolute,
    MC_MoveLinearAbsolute,
)
from motionplc.config import build, load_config
from tests.blocks.group_rig import distance_to_polyline

GANTRY = Path(__file__).resolve().parents[2] / "configs" / "gantry.yaml"
TOL = 0.001  # [m] corner deviation
Z = -0.05
RECT = [(0.6, 0.2, Z), (0.6, 0.5, Z), (0.2, 0.5, Z), (0.2, 0.2, Z)]
CENTER = (0.4, 0.35, Z)
R = 0.1
CURVE = [(0.5, 0.3, Z), (0.7, 0.45, -0.02), (0.9, 0.3, Z), (1.0, 0.6, -0.08)]


def _run_gantry() -> tuple[Any, dict[str, Any]]:
    machine = build(load_config(GANTRY), check_invariants=True)
    rt = machine.runtime
    g = rt.groups["xyz"]
    fbs: list[Any] = [MC_Power(axis=ax, enable=True) for ax in machine.axes.values()]
    moves: dict[str, Any] = {}
    phase = {"k": 0}

    def program(ctx: Any) -> None:
        for fb in fbs:
            fb()
        k = phase["k"]
        phase["k"] += 1
        if k == 20:
            fbs.append(MC_GroupEnable(axes_group=g, execute=True))
        if k == 25:
            add = []
            # to the start corner (exact stop), then the rounded rectangle
            add.append(("approach", MC_MoveLinearAbsolute(position=RECT[-1], velocity=0.5)))
            for i, p in enumerate(RECT):
                add.append(
                    (
                        f"rect{i}",
                        MC_MoveLinearAbsolute(
                            position=p,
                            velocity=0.4,
                            buffer_mode=BufferMode.BUFFERED if i == 0 else BufferMode.BLENDING_LOW,
                            transition_mode=TransitionMode.TM_NONE
                            if i == 0
                            else TransitionMode.TM_MAX_CORNER_DEVIATION,
                            transition_parameter=0.0 if i == 0 else TOL,
                        ),
                    )
                )
            # a circle about CENTER: to its rightmost point, two blended half circles
            start = (CENTER[0] + R, CENTER[1], Z)
            add.append(
                (
                    "to_circle",
                    MC_MoveLinearAbsolute(
                        position=start, velocity=0.4, buffer_mode=BufferMode.BUFFERED
                    ),
                )
            )
            for i, end in enumerate(((CENTER[0] - R, CENTER[1], Z), start)):
                add.append(
                    (
                        f"circle{i}",
                        MC_MoveCircularAbsolute(
                            circ_mode=CircMode.CENTER,
                            aux_point=CENTER,
                            end_point=end,
                            path_choice=PathChoice.COUNTER_CLOCKWISE,
                            velocity=0.3,
                            buffer_mode=BufferMode.BUFFERED if i == 0 else BufferMode.BLENDING_LOW,
                        ),
                    )
                )
            add.append(
                (
                    "curve",
                    MC_MoveBSpline(points=CURVE, velocity=0.4, buffer_mode=BufferMode.BUFFERED),
                )
            )
            for name, fb in add:
                fb.axes_group = g
                fb.execute = True
                moves[name] = fb
                fbs.append(fb)

    machine.attach(program)
    rt.run(cycles=30)
    ok = rt.run_until(lambda: not g.moving and not g.mq.inbox and phase["k"] > 30, max_seconds=60)
    assert ok
    rt.run(cycles=300)  # settle (drives' following error decays)
    return machine, moves


def test_gantry_draws_rectangle_circle_and_curve_within_limits_and_tolerance() -> None:
    machine, moves = _run_gantry()
    try:
        rt = machine.runtime
        g = rt.groups["xyz"]
        for name, fb in moves.items():
            assert fb.done, (name, fb.error_id, fb.error_text)
        assert g.state is GroupState.GROUP_STANDBY
        for ax in machine.axes.values():
            assert ax.state is AxisState.STANDSTILL, (ax.name, ax.axis_error_reason)
        tr = rt.trace
        t = tr.column("t")
        dt = rt.cycle
        names = list(g.axis_names)
        cfg = {a.name: a for a in load_config(GANTRY).axes}
        # every cycle: the kernel's values within the limits; finite differences of the set
        # positions (velocity) and accelerations (jerk) too. The group steps in the 2 ms task.
        for n in names:
            lim = cfg[n].limits
            p, v = tr.column(f"{n}.position"), tr.column(f"{n}.velocity")
            a, j = tr.column(f"{n}.acceleration"), tr.column(f"{n}.jerk")
            assert np.abs(v).max() <= lim.v_max * (1 + 1e-9)
            assert np.abs(a).max() <= lim.a_max * (1 + 1e-9)
            assert np.abs(j).max() <= lim.j_max * (1 + 1e-9)
            period = 0.002
            k = int(round(period / dt))
            assert np.abs(np.diff(p[::k])).max() <= lim.v_max * period * (1 + 1e-9)
            assert np.abs(np.diff(a[::k])).max() <= lim.j_max * period * (1 + 1e-6)
        pos = np.stack([tr.column(f"{n}.position") for n in names], axis=1)
        pv = tr.column("xyz.path_velocity")
        # the rectangle: within TOL of the polyline, each corner passed at speed within TOL
        # (the loop starts and ends at rest at RECT[-1]: the samples within 0.1 mm of it)
        near = np.nonzero(np.linalg.norm(pos - np.array(RECT[-1]), axis=1) <= 1e-4)[0]
        i0, i1 = int(near[0]), int(near[-1])
        seg = pos[i0 : i1 + 1]
        assert distance_to_polyline(seg, [RECT[-1], *RECT]).max() <= TOL * (1 + 1e-9)
        stopped = 0
        for c in RECT[:3]:
            d = np.linalg.norm(seg - np.array(c), axis=1)
            k = int(np.argmin(d))
            # the tolerance is a bound (GroupConfig.corner_choice): the group blends with the
            # whole of it, 1/4 or 1/16 of the blend, or stops exactly, whichever is fastest
            if d[k] <= 1e-7:
                stopped += 1
                continue
            assert any(s * TOL * (1 - 1e-9) <= d[k] <= s * TOL * 1.01 for s in (1, 0.25, 0.0625))
            assert pv[i0 + k] > 0.001  # a blend keeps the path moving
        moving = pv[i0 + 1 : i1]
        inner = moving[np.nonzero(moving > 0)[0][0] : np.nonzero(moving > 0)[0][-1]]
        if not stopped:
            assert inner.min() > 0.0  # continuous path speed from the first corner to the last
        # the circle: on the circle, passed without a stop at the half-circle junction
        start = np.array((CENTER[0] + R, CENTER[1], Z))
        at_start = np.nonzero(np.linalg.norm(pos - start, axis=1) <= 1e-4)[0]
        c0, c1 = int(at_start[0]), int(at_start[-1])
        circ = pos[c0 : c1 + 1]
        # (the samples near its start/end point may lie on the moves before and after it)
        circ = circ[np.linalg.norm(circ - start, axis=1) > 2e-4]
        rad = np.hypot(circ[:, 0] - CENTER[0], circ[:, 1] - CENTER[1])
        assert np.abs(rad - R).max() <= 1e-9
        assert np.abs(circ[:, 2] - Z).max() <= 1e-12
        left = int(np.argmin(np.abs(circ[:, 0] - (CENTER[0] - R)) + np.abs(circ[:, 1] - CENTER[1])))
        assert pv[c0 + left] > 0.1
        # the curve passes through its points (sampled every 2 ms at <= 0.4 m/s) and ends
        # exactly at the last
        for p in CURVE[:-1]:
            assert np.linalg.norm(pos - np.array(p), axis=1).min() <= 0.4 * 0.002
        assert tuple(pos[-1]) == CURVE[-1]
        for n, x in zip(names, CURVE[-1], strict=True):
            assert abs(machine.axes[n].actual_position - x) <= 5e-6
        assert math.isclose(t[-1], rt.time - dt)
    finally:
        machine.close()
