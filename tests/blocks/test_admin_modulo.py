"""Modulo axes with Direction, override, homing, SetPosition, MoveAdditive/Relative bases."""

from __future__ import annotations

import numpy as np
import pytest

from motionplc.blocks import (
    AxisState,
    BufferMode,
    Direction,
    ErrorID,
    ExecutionMode,
    MC_Home,
    MC_MoveAbsolute,
    MC_MoveAdditive,
    MC_MoveRelative,
    MC_MoveVelocity,
    MC_ReadActualPosition,
    MC_ReadMotionState,
    MC_SetOverride,
    MC_SetPosition,
)
from tests.runtime.helpers import Bench

S = AxisState


@pytest.mark.parametrize(
    ("start", "target", "direction", "travel"),
    [
        (10.0, 350.0, Direction.SHORTEST, -20.0),
        (10.0, 350.0, Direction.POSITIVE, 340.0),
        (10.0, 350.0, Direction.NEGATIVE, -20.0),
        (350.0, 10.0, Direction.SHORTEST, 20.0),
        (0.0, 180.0, Direction.SHORTEST, 180.0),  # tie: positive way
        (90.0, 90.0, Direction.POSITIVE, 0.0),
    ],
)
def test_modulo_directions(
    start: float, target: float, direction: Direction, travel: float
) -> None:
    b = Bench(modulo=360.0, v_max=400.0, a_max=2000.0).powered()
    sp = b.add(MC_SetPosition(position=start))
    b.pulse(sp)
    m = b.add(MC_MoveAbsolute(position=target, velocity=300.0, direction=direction))
    p0 = b.x.p
    b.pulse(m)
    b.run_until_idle()
    assert b.x.p - p0 == pytest.approx(travel, abs=1e-9)
    assert b.x.position == pytest.approx(target % 360.0, abs=1e-9)
    pos = b.col("x.position")
    assert ((pos >= 0.0) & (pos < 360.0)).all()


def test_modulo_current_direction_follows_velocity() -> None:
    b = Bench(modulo=360.0, v_max=400.0, a_max=2000.0).powered()
    mv = b.add(MC_MoveVelocity(velocity=100.0, direction=Direction.NEGATIVE))
    m = b.add(MC_MoveAbsolute(position=300.0, velocity=100.0, direction=Direction.CURRENT))
    b.pulse(mv)
    b.run(200)
    p0 = b.x.p
    b.pulse(m)
    b.run_until_idle()
    assert b.x.p < p0 and b.x.position == pytest.approx(300.0)


def test_modulo_position_out_of_range_is_an_error() -> None:
    b = Bench(modulo=360.0).powered()
    m = b.add(MC_MoveAbsolute(position=360.0, velocity=10.0))
    b.pulse(m)
    assert m.error and m.error_id is ErrorID.INVALID_POSITION and "[0, 360)" in m.error_text


def test_override_scales_velocity_smoothly_and_zero_keeps_the_state() -> None:
    b = Bench(v_max=200.0, a_max=400.0, j_max=10_000.0).powered()
    mv = b.add(MC_MoveVelocity(velocity=100.0))
    ov = b.add(MC_SetOverride(enable=True))
    b.pulse(mv)
    b.run(1000)
    ov.vel_factor = 0.5
    b.run(1000)
    assert b.x.v == pytest.approx(50.0)
    assert mv.in_velocity  # its own contribution is unchanged
    ov.vel_factor = 0.0
    b.run(1000)
    assert b.x.v == 0.0 and b.x.state is S.CONTINUOUS_MOTION
    ov.vel_factor = 1.0
    b.run(1000)
    assert b.x.v == pytest.approx(100.0)
    v = b.col("x.velocity")
    assert np.abs(np.diff(v)).max() <= 400.0 * 0.001 * 1.01  # no velocity step


def test_override_on_a_position_move_reaches_the_target() -> None:
    b = Bench(v_max=200.0, a_max=400.0, j_max=10_000.0).powered()
    m = b.add(MC_MoveAbsolute(position=300.0, velocity=100.0))
    ov = b.add(MC_SetOverride(enable=True, vel_factor=0.25))
    b.run(1000)  # the factor ramps down first (jerk-limited)
    b.pulse(m)
    b.run_until_idle()
    assert b.x.p == pytest.approx(300.0, abs=1e-9)
    assert b.col("x.velocity").max() <= 25.0 + 1e-6
    assert ov.enabled


def test_set_position_homing() -> None:
    b = Bench().powered()
    h = b.add(MC_Home(position=42.0))
    rd = b.add(MC_ReadActualPosition(enable=True))
    b.pulse(h)
    b.run(3)
    assert h.done is False and b.x.homed and b.x.state is S.STANDSTILL
    assert rd.position == 42.0 and b.x.p == 42.0


def test_homing_move_to_virtual_switch() -> None:
    b = Bench(home_switch=25.0, home_velocity=10.0, a_max=100.0, j_max=5000.0).powered()
    h = b.add(MC_Home(position=100.0))
    h.execute = True
    b.run(2)
    assert b.x.state is S.HOMING
    b.run_until_idle()
    assert h.done and b.x.state is S.STANDSTILL and b.x.homed
    # the switch (drive position 25) is now axis position 100
    assert b.x.p - (b.x.p - b.x.offset - 25.0) == pytest.approx(100.0)
    assert b.x.p > 100.0  # stopped just past the switch
    states = b.col("x.state")
    assert S.HOMING in states


def test_set_position_during_motion_keeps_the_physical_motion() -> None:
    b = Bench().powered()
    m = b.add(MC_MoveAbsolute(position=100.0, velocity=50.0))
    sp = b.add(MC_SetPosition(position=1000.0, relative=True))
    b.pulse(m)
    b.run(500)
    drive_before = b.x.drive._position
    b.pulse(sp)
    b.run_until_idle()
    assert b.x.p == pytest.approx(1100.0)
    assert b.x.drive._position == pytest.approx(100.0)
    assert b.x.drive._position > drive_before


def test_set_position_queued_waits_for_the_motion() -> None:
    b = Bench().powered()
    m = b.add(MC_MoveAbsolute(position=100.0, velocity=50.0))
    sp = b.add(MC_SetPosition(position=0.0, execution_mode=ExecutionMode.QUEUED))
    b.pulse(m)
    b.run(10)
    b.pulse(sp)
    b.run(10)
    assert sp.busy
    b.run_until_idle()
    assert b.x.p == 0.0 and b.x.drive._position == pytest.approx(100.0)


def test_move_additive_vs_relative_after_abort() -> None:
    """Spec pp. 37-40: after an abort, Relative counts from the set position, Additive from
    the aborted command's target."""
    for cls, expected in ((MC_MoveRelative, None), (MC_MoveAdditive, 150.0)):
        b = Bench().powered()
        m1 = b.add(MC_MoveAbsolute(position=100.0, velocity=50.0))
        m2 = b.add(cls(distance=50.0, velocity=50.0))
        b.pulse(m1)
        b.run(600)
        p_at = b.x.p
        b.pulse(m2)
        b.run_until_idle()
        assert b.x.p == pytest.approx(expected if expected is not None else p_at + 50.0)


def test_buffered_relative_counts_from_the_previous_target() -> None:
    b = Bench().powered()
    m1 = b.add(MC_MoveAbsolute(position=100.0, velocity=50.0))
    m2 = b.add(MC_MoveRelative(distance=30.0, velocity=50.0, buffer_mode=BufferMode.BUFFERED))
    b.pulse(m1)
    b.run(10)
    b.pulse(m2)
    b.run_until_idle()
    assert b.x.p == 130.0


def test_queue_full() -> None:
    b = Bench(queue_depth=2).powered()
    fbs = [
        b.add(MC_MoveRelative(distance=10.0, velocity=50.0, buffer_mode=BufferMode.BUFFERED))
        for _ in range(4)
    ]
    for fb in fbs:
        fb.execute = True
    b.run(1)
    # the first is idle -> immediate; two wait; the fourth does not fit
    assert [fb.error for fb in fbs] == [False, False, False, True]
    assert fbs[3].error_id is ErrorID.QUEUE_FULL
    b.run_until_idle()
    assert b.x.p == 30.0


def test_blending_after_velocity_error_option() -> None:
    b = Bench(blend_after_continuous="error").powered()
    mv = b.add(MC_MoveVelocity(velocity=10.0))
    m = b.add(MC_MoveAbsolute(position=100.0, velocity=10.0, buffer_mode=BufferMode.BLENDING_LOW))
    b.pulse(mv)
    b.pulse(m)
    assert m.error and m.error_id is ErrorID.BLENDING_NOT_SUPPORTED_BY_PREVIOUS


def test_blending_after_velocity_acts_like_previous() -> None:
    b = Bench().powered()
    mv = b.add(MC_MoveVelocity(velocity=40.0, acceleration=100.0))
    m = b.add(MC_MoveAbsolute(position=200.0, velocity=40.0, buffer_mode=BufferMode.BLENDING_LOW))
    b.pulse(mv)
    b.pulse(m)
    b.run_until_idle()
    v = b.col("x.velocity")
    ab = [c for c, val in b.edges(mv, "command_aborted") if val]
    act = [c for c, val in b.edges(m, "active") if val]
    assert ab == act  # hand-over at InVelocity, no stop in between
    assert v[act[0]] == pytest.approx(40.0)
    assert b.x.p == 200.0


def test_read_motion_state() -> None:
    b = Bench().powered()
    rms = b.add(MC_ReadMotionState(enable=True))
    mv = b.add(MC_MoveVelocity(velocity=-50.0, acceleration=100.0))
    b.pulse(mv)
    b.run(10)
    assert rms.accelerating and rms.direction_negative and not rms.constant_velocity
    b.run(1000)
    assert rms.constant_velocity and rms.direction_negative and not rms.accelerating
