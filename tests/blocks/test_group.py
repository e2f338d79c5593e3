"""Axes groups: path moves, blending, stops, errors (ideal drives, invariants every cycle)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from motionplc.blocks.enums import (
    AxisState,
    BufferMode,
    CircMode,
    ErrorID,
    GroupState,
    PathChoice,
    TransitionMode,
)
from motionplc.blocks.group_blocks import (
    MC_GroupContinue,
    MC_GroupHalt,
    MC_GroupInterrupt,
    MC_GroupReadStatus,
    MC_GroupReset,
    MC_GroupStop,
    MC_MoveCircularAbsolute,
    MC_MoveDirectAbsolute,
    MC_MoveLinearAbsolute,
    MC_MoveLinearRelative,
    MC_MovePassingPoints,
)
from motionplc.planning.paths.pieces import BlendPiece
from tests.blocks.group_rig import GroupBench, distance_to_polyline

B = BufferMode
TM = TransitionMode
RECT = [(0.3, 0.0, 0.0), (0.3, 0.2, 0.0), (0.0, 0.2, 0.0), (0.0, 0.0, 0.0)]


def _chain(
    bench: GroupBench, points, mode=B.BLENDING_LOW, tm=TM.TM_MAX_CORNER_DEVIATION, par=0.005, v=0.5
):
    fbs = []
    for i, p in enumerate(points):
        fbs.append(
            bench.add(
                MC_MoveLinearAbsolute(
                    execute=True,
                    position=p,
                    velocity=v,
                    buffer_mode=B.ABORTING if i == 0 else mode,
                    transition_mode=TM.TM_NONE if i == 0 else tm,
                    transition_parameter=0.0 if i == 0 else par,
                )
            )
        )
    return fbs


def test_rectangle_with_blended_corners_keeps_limits_tolerance_and_ends_exactly() -> None:
    # the blends as the tolerance sizes them (corner_choice off; with it, the default, exact
    # stops pass the rectangle's corners faster at these limits, see the test below)
    b = GroupBench(corner_choice=False).enabled()
    fbs = _chain(b, RECT)
    b.run_until_idle()
    assert all(fb.done for fb in fbs), [(fb.error_id, fb.error_text) for fb in fbs]
    b.check_limits()
    pos = b.positions()
    assert tuple(pos[-1]) == (0.0, 0.0, 0.0)  # end position exact
    dev = distance_to_polyline(pos, [(0.0, 0.0, 0.0), *RECT])
    assert dev.max() <= 0.005 * (1 + 1e-9)
    # the corner deviation (distance from the programmed corner) uses the tolerance: the
    # sampled path passes between 4.99 and 5 mm from every corner (the blend's true minimum is
    # 5 mm; samples 1 ms apart come a little less close)
    for c in RECT[:3]:
        dc = np.linalg.norm(pos - np.array(c), axis=1).min()
        assert 0.005 * (1 - 1e-9) <= dc <= 0.00501, dc
    pv = b.col("g.path_velocity")
    # continuous path speed: the corners are passed at speed (no stop until the end)
    for c in RECT[:3]:
        i = int(np.argmin(np.linalg.norm(pos - np.array(c), axis=1)))
        assert pv[i] > 0.05
    moving = np.nonzero(pv > 0)[0]
    assert np.all(pv[moving[0] : moving[-1] + 1] > 0.0)
    assert b.g.state is GroupState.GROUP_STANDBY
    assert all(ax.state is AxisState.STANDSTILL for ax in b.rt.axes.values())


def test_corner_choice_never_slower_than_the_tolerance_sized_blends() -> None:
    """The rectangle again with the corner choice on (GroupConfig.corner_choice): a corner is
    blended as the tolerance allows, with a smaller blend or stopped exactly, whichever passes
    it fastest; the whole motion is faster than with the tolerance-sized blends and keeps the
    limits (by differencing) and the tolerance."""
    times = {}
    for cc in (True, False):
        b = GroupBench(corner_choice=cc).enabled()
        fbs = _chain(b, RECT)
        b.run_until_idle()
        assert all(fb.done for fb in fbs), [(fb.error_id, fb.error_text) for fb in fbs]
        b.check_limits()
        pos = b.positions()
        assert tuple(pos[-1]) == (0.0, 0.0, 0.0)
        assert distance_to_polyline(pos, [(0.0, 0.0, 0.0), *RECT]).max() <= 0.005 * (1 + 1e-9)
        moving = np.nonzero(b.col("g.path_velocity") > 0.0)[0]
        times[cc] = moving[-1] - moving[0]
        dt = b.rt.cycle
        for n, lim in b.limits.items():
            p = b.col(f"{n}.position")
            assert np.abs(np.diff(p, 2)).max() / dt**2 <= lim["a_max"] * (1 + 1e-6)
            assert np.abs(np.diff(p, 3)).max() / dt**3 <= lim["j_max"] * (1 + 1e-6)
    assert times[True] < times[False], times


def test_corner_speed_is_near_the_highest_constant_speed_the_axis_limits_allow() -> None:
    # the tolerance-sized blend (with the corner choice, the default, this corner is an exact
    # stop: faster at these limits)
    b = GroupBench(corner_choice=False).enabled()
    _chain(b, RECT[:2])
    b.run_until_idle()
    pv = b.col("g.path_velocity")
    pos = b.positions()
    i = int(np.argmin(np.linalg.norm(pos - np.array(RECT[0]), axis=1)))
    # the blend of this corner, and its fastest constant-speed passage computed here from
    # dense samples of its exact derivatives (not from the kernel's bounds)
    d = 2 * 0.005 / math.sin(math.pi / 4)
    bp = BlendPiece(RECT[0], (1.0, 0.0, 0.0), (0.0, 1.0, 0.0), d)
    g_mid = math.hypot(*bp.at(0.5 * bp.U)[1])  # |p'| at the blend's middle (path speed / du)
    us = np.linspace(0.0, bp.U, 4001)
    d2 = np.array([bp.at(u)[2] for u in us])
    d3 = np.array([bp.at(u)[3] for u in us])
    v_star = math.inf
    for k, n in enumerate("xyz"):
        lim = b.limits[n]
        m2, m3 = np.abs(d2[:, k]).max(), np.abs(d3[:, k]).max()
        if m2 > 0:
            v_star = min(v_star, math.sqrt(lim["a_max"] / m2))
        if m3 > 0:
            v_star = min(v_star, (lim["j_max"] / m3) ** (1 / 3))
    du = pv[i] / g_mid
    assert 0.95 * v_star <= du <= v_star * (1 + 1e-6), (du, v_star)


def test_buffered_moves_stop_at_every_corner() -> None:
    b = GroupBench().enabled()
    _chain(b, RECT, mode=B.BUFFERED, tm=TM.TM_NONE, par=0.0)
    b.run_until_idle()
    b.check_limits()
    pos = b.positions()
    pv = b.col("g.path_velocity")
    assert distance_to_polyline(pos, [(0.0, 0.0, 0.0), *RECT]).max() <= 1e-12
    for c in RECT[:3]:
        near = np.linalg.norm(pos - np.array(c), axis=1) <= 1e-5
        # at rest at the corner within a cycle: from rest, one cycle at j_max gives 2e-5 m/s
        assert near.any() and pv[near].min() <= 1e-4


def test_blending_with_tm_none_passes_smooth_junctions_and_stops_at_corners() -> None:
    b = GroupBench().enabled()
    pts = [(0.1, 0.0, 0.0), (0.2, 0.0, 0.0), (0.2, 0.1, 0.0)]
    _chain(b, pts, mode=B.BLENDING_LOW, tm=TM.TM_NONE, par=0.0, v=0.4)
    b.run_until_idle()
    b.check_limits()
    pos, pv = b.positions(), b.col("g.path_velocity")
    i = int(np.argmin(np.linalg.norm(pos - np.array(pts[0]), axis=1)))
    assert pv[i] > 0.3  # collinear junction: passed at speed
    near = np.linalg.norm(pos - np.array(pts[1]), axis=1) <= 1e-5
    assert near.any() and pv[near].min() <= 1e-4  # a real corner with TM_NONE: exact stop


def test_circle_border_and_center_modes_stay_on_the_circle() -> None:
    b = GroupBench().enabled()
    c = (0.3, 0.2, 0.0)
    r = 0.1
    m0 = b.add(MC_MoveLinearAbsolute(execute=True, position=(0.4, 0.2, 0.0), velocity=0.5))
    m1 = b.add(
        MC_MoveCircularAbsolute(
            execute=True,
            circ_mode=CircMode.BORDER,
            aux_point=(0.3, 0.3, 0.0),
            end_point=(0.2, 0.2, 0.0),
            velocity=0.5,
            buffer_mode=B.BUFFERED,
        )
    )
    m2 = b.add(
        MC_MoveCircularAbsolute(
            execute=True,
            circ_mode=CircMode.CENTER,
            aux_point=c,
            end_point=(0.4, 0.2, 0.0),
            path_choice=PathChoice.COUNTER_CLOCKWISE,
            velocity=0.5,
            buffer_mode=B.BLENDING_LOW,
        )
    )
    b.run_until_idle()
    assert m0.done and m1.done and m2.done, (m1.error_text, m2.error_text)
    b.check_limits()
    pos = b.positions()
    start = np.array((0.4, 0.2, 0.0))
    t0 = int(np.nonzero(np.linalg.norm(pos - start, axis=1) <= 1e-4)[0][0])
    on = pos[t0:]
    on = on[np.linalg.norm(on - start, axis=1) > 2e-4]  # the circles (not the line's end)
    rad = np.hypot(on[:, 0] - c[0], on[:, 1] - c[1])
    assert np.abs(rad - r).max() <= 1e-9
    assert tuple(pos[-1]) == (0.4, 0.2, 0.0)
    # the half circle through (0.3, 0.3) goes above the centre, the CENTER arc back below it
    assert on[:, 1].max() == pytest.approx(0.3, abs=1e-6)
    assert on[:, 1].min() == pytest.approx(0.1, abs=1e-6)


def test_passing_points_curve_reaches_the_last_point_within_limits() -> None:
    b = GroupBench().enabled()
    pts = [(0.1, 0.05, 0.0), (0.2, 0.0, -0.01), (0.3, 0.08, 0.0)]
    m = b.add(MC_MovePassingPoints(execute=True, points=pts))
    b.run_until_idle()
    assert m.done, m.error_text
    b.check_limits()
    pos = b.positions()
    assert np.abs(pos[-1] - np.array(pts[-1])).max() <= 1e-9
    for p in pts[:-1]:
        assert np.linalg.norm(pos - np.array(p), axis=1).min() < 0.002


def test_direct_move_axes_arrive_together() -> None:
    b = GroupBench().enabled()
    m = b.add(MC_MoveDirectAbsolute(execute=True, position=(0.5, 0.1, -0.05), velocity=1.0))
    b.run_until_idle()
    assert m.done
    b.check_limits()
    t = b.col("t")
    ends = []
    for n in "xyz":
        v = b.col(f"{n}.velocity")
        ends.append(t[np.nonzero(np.abs(v) > 0)[0][-1]])
    assert max(ends) - min(ends) <= 0.0011
    assert tuple(b.positions()[-1]) == (0.5, 0.1, -0.05)


def test_aborting_move_brakes_along_the_path_then_goes_on() -> None:
    b = GroupBench().enabled()
    m0 = b.add(MC_MoveLinearAbsolute(execute=True, position=(0.6, 0.0, 0.0), velocity=0.8))
    b.run(400)
    m1 = b.add(MC_MoveLinearAbsolute(execute=True, position=(0.2, 0.3, 0.0), velocity=0.5))
    b.run(2)
    assert m0.command_aborted
    b.run_until_idle()
    assert m1.done
    b.check_limits()
    pos = b.positions()
    assert np.abs(pos[:, 1][:400]).max() == 0.0
    assert tuple(pos[-1]) == (0.2, 0.3, 0.0)
    # braking stayed on the x axis line (y untouched until the stop)
    i_stop = int(np.nonzero(pos[:, 1] > 0)[0][0])
    assert np.abs(b.col("x.velocity")[i_stop - 3 : i_stop + 1]).min() < 1e-4


def test_halt_stops_on_the_path_and_aborts_the_queue() -> None:
    b = GroupBench().enabled()
    fbs = _chain(b, RECT)
    b.run(500)
    h = b.add(MC_GroupHalt(execute=True))
    b.run_until_idle()
    b.run(2)
    assert h.done
    assert any(fb.command_aborted for fb in fbs)
    b.check_limits()
    pos = b.positions()
    assert distance_to_polyline(pos, [(0.0, 0.0, 0.0), *RECT]).max() <= 0.005 * (1 + 1e-9)
    assert b.g.state is GroupState.GROUP_STANDBY


def test_interrupt_and_continue_finish_the_path() -> None:
    b = GroupBench().enabled()
    fbs = _chain(b, RECT)
    b.run(700)
    it = b.add(MC_GroupInterrupt(execute=True))
    b.run_until_idle()
    b.run(3)
    assert it.done
    assert all(fb.busy or fb.done for fb in fbs)
    assert not fbs[-1].done
    stopped_at = b.positions()[-1].copy()
    c = b.add(MC_GroupContinue(execute=True))
    b.run_until_idle()
    assert c.done
    assert all(fb.done for fb in fbs)
    assert tuple(b.positions()[-1]) == (0.0, 0.0, 0.0)
    b.check_limits()
    assert distance_to_polyline(b.positions(), [(0.0, 0.0, 0.0), *RECT]).max() <= 0.005 * (1 + 1e-9)
    assert np.linalg.norm(stopped_at) > 0.1


def test_group_stop_holds_stopping_while_execute() -> None:
    b = GroupBench().enabled()
    _chain(b, RECT)
    b.run(300)
    st = b.add(MC_GroupStop(execute=True))
    rs = b.add(MC_GroupReadStatus(enable=True))
    b.run_until_idle()
    b.run(5)
    assert st.done and rs.group_stopping
    move = b.add(MC_MoveLinearRelative(execute=True, distance=(0.01, 0.0, 0.0), velocity=0.1))
    b.run(2)
    assert move.error and move.error_id is ErrorID.GROUP_STATE_STOPPING
    st.execute = False
    b.run(2)
    assert rs.group_standby
    b.check_limits()


def test_member_error_stops_the_group_along_the_path_and_reset_recovers() -> None:
    b = GroupBench().enabled()
    fbs = _chain(b, RECT)
    b.run(500)
    b.rt.axes["y"].raise_axis_error("DRIVE_FAULT", "test: injected drive fault")
    b.run_until_idle()
    b.run(2)
    assert b.g.state is GroupState.GROUP_ERROR_STOP
    assert all(fb.error or fb.done for fb in fbs)
    b.check_limits()
    pos = b.positions()
    assert distance_to_polyline(pos, [(0.0, 0.0, 0.0), *RECT]).max() <= 0.005 * (1 + 1e-9)
    assert b.rt.axes["x"].state is AxisState.STANDSTILL
    # MC_GroupReset needs the axis reset first
    r = b.add(MC_GroupReset(execute=True))
    b.run(2)
    assert r.error and r.error_id is ErrorID.GROUP_AXIS_NOT_READY
    b.rt.axes["y"].request_reset()
    b.run(3)
    r.execute = False
    b.run(1)
    r.execute = True
    b.run(2)
    assert r.done and b.g.state is GroupState.GROUP_STANDBY


def test_bad_inputs_are_fb_errors_naming_the_input() -> None:
    b = GroupBench().enabled()
    m = b.add(MC_MoveLinearAbsolute(execute=True, position=(0.1, 0.1), velocity=0.5))
    b.run(1)
    assert m.error and m.error_id is ErrorID.INVALID_POSITION and "3 values" in m.error_text
    m2 = b.add(
        MC_MoveLinearAbsolute(
            execute=True,
            position=(0.1, 0.1, 0.0),
            velocity=0.5,
            buffer_mode=B.BUFFERED,
            transition_mode=TM.TM_CORNER_DISTANCE,
            transition_parameter=0.01,
        )
    )
    b.run(1)
    assert m2.error and m2.error_id is ErrorID.INVALID_TRANSITION_MODE
    m3 = b.add(MC_MoveLinearAbsolute(execute=True, position=(0.1, 0.1, 0.0), velocity=-1.0))
    b.run(1)
    assert m3.error and m3.error_id is ErrorID.INVALID_VELOCITY and "velocity" in m3.error_text
    m4 = b.add(MC_MoveLinearAbsolute(execute=True, position=(0.1, 0.1, 0.0), velocity=math.nan))
    b.run(1)
    assert m4.error and m4.error_id is ErrorID.INVALID_VELOCITY


def test_members_of_an_enabled_group_refuse_single_axis_commands() -> None:
    from motionplc.blocks import MC_MoveAbsolute
    from motionplc.blocks.group_blocks import MC_GroupDisable

    b = GroupBench().enabled()
    x = b.rt.axes["x"]
    mv = MC_MoveAbsolute(axis=x, execute=True, position=0.1, velocity=0.5)
    b.fbs.append(mv)
    b.run(2)
    assert mv.error and mv.error_id is ErrorID.AXIS_IN_GROUP and "group" in mv.error_text
    dis = b.add(MC_GroupDisable(execute=True))
    b.run(2)
    assert dis.done and b.g.state is GroupState.GROUP_DISABLED
    mv.execute = False
    b.run(1)
    mv.execute = True
    b.run(2)
    assert mv.busy or mv.done
    b.run(2000)
    assert mv.done and x.p == 0.1


@pytest.mark.parametrize(
    ("tm", "par"),
    [(TM.TM_CORNER_DISTANCE, 0.004), (TM.TM_CONSTANT_VELOCITY, 0.1), (TM.TM_START_VELOCITY, 0.1)],
)
def test_transition_modes_size_the_blend(tm: TransitionMode, par: float) -> None:
    b = GroupBench().enabled()
    pts = RECT[:2]
    _chain(b, pts, tm=tm, par=par)
    b.run_until_idle()
    b.check_limits()
    pos, pv = b.positions(), b.col("g.path_velocity")
    dev = np.linalg.norm(pos - np.array(pts[0]), axis=1).min()
    i = int(np.argmin(np.linalg.norm(pos - np.array(pts[0]), axis=1)))
    if tm is TM.TM_CORNER_DISTANCE:
        # a 90 degree line-line blend of corner distance d deviates d sin(45 deg) / 2
        assert dev == pytest.approx(par * math.sin(math.pi / 4) / 2, rel=1e-3)
    else:
        # the blend is made large enough to be passed at the requested speed
        assert pv[i] >= 0.9 * par
    assert tuple(pos[-1]) == pts[-1]


def test_queue_full_is_an_fb_error_and_the_queue_runs_on() -> None:
    b = GroupBench(queue_depth=2).enabled()
    fbs = _chain(b, RECT)
    b.run(2)
    assert fbs[3].error and fbs[3].error_id is ErrorID.QUEUE_FULL
    b.run_until_idle()
    assert all(fb.done for fb in fbs[:3])
    assert tuple(b.positions()[-1]) == RECT[2]
