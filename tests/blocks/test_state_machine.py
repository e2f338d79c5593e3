"""State machine scenarios (conformance group C)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from motionplc.blocks import (
    AxisState,
    BufferMode,
    ErrorID,
    MC_Halt,
    MC_Home,
    MC_MoveAbsolute,
    MC_MoveAdditive,
    MC_MoveRelative,
    MC_MoveVelocity,
    MC_ReadAxisError,
    MC_ReadStatus,
    MC_Reset,
    MC_Stop,
)
from tests.runtime.helpers import Bench

S = AxisState


def rise(b: Bench, fb, out: str) -> list[int]:
    return [c for c, v in b.edges(fb, out) if v]


def test_c1_power_on_sequence() -> None:
    b = Bench()
    b.power.enable = False
    rs = b.add(MC_ReadStatus(enable=True))
    b.run(3)
    assert rs.disabled and rs.state is S.DISABLED and not b.power.status
    b.power.enable = True
    k = b.cycle
    b.run(2)
    assert rise(b, b.power, "status") == [k + 1]  # pinned: next cycle
    assert rs.standstill and b.x.state is S.STANDSTILL


def _enter(b: Bench, state: AxisState) -> None:
    if state is S.DISABLED:
        b.power.enable = False
        b.run(2)
    elif state is S.HOMING:
        h = b.add(MC_Home(position=0.0))
        b.pulse(h)
    elif state is S.DISCRETE_MOTION:
        b.pulse(b.add(MC_MoveAbsolute(position=100.0, velocity=50.0)))
    elif state is S.CONTINUOUS_MOTION:
        b.pulse(b.add(MC_MoveVelocity(velocity=50.0)))
    elif state is S.STOPPING:
        st = b.add(MC_Stop(deceleration=100.0))
        st.execute = True
    elif state is S.ERROR_STOP:
        b.x.drive.inject_fault()
    b.run(5)
    assert b.x.state is state


FBS = {
    "MC_Home": (lambda: MC_Home(position=0.0), S.HOMING, {S.STANDSTILL}),
    "MC_Stop": (
        lambda: MC_Stop(),
        S.STOPPING,
        {S.STANDSTILL, S.HOMING, S.DISCRETE_MOTION, S.CONTINUOUS_MOTION, S.STOPPING},
    ),
    "MC_Halt": (
        lambda: MC_Halt(),
        S.DISCRETE_MOTION,
        {S.STANDSTILL, S.DISCRETE_MOTION, S.CONTINUOUS_MOTION},
    ),
    "MC_MoveAbsolute": (
        lambda: MC_MoveAbsolute(position=-50.0, velocity=20.0),
        S.DISCRETE_MOTION,
        {S.STANDSTILL, S.DISCRETE_MOTION, S.CONTINUOUS_MOTION},
    ),
    "MC_MoveRelative": (
        lambda: MC_MoveRelative(distance=-50.0, velocity=20.0),
        S.DISCRETE_MOTION,
        {S.STANDSTILL, S.DISCRETE_MOTION, S.CONTINUOUS_MOTION},
    ),
    "MC_MoveAdditive": (
        lambda: MC_MoveAdditive(distance=-50.0, velocity=20.0),
        S.DISCRETE_MOTION,
        {S.STANDSTILL, S.DISCRETE_MOTION, S.CONTINUOUS_MOTION},
    ),
    "MC_MoveVelocity": (
        lambda: MC_MoveVelocity(velocity=20.0),
        S.CONTINUOUS_MOTION,
        {S.STANDSTILL, S.DISCRETE_MOTION, S.CONTINUOUS_MOTION},
    ),
}
STATES = [
    S.DISABLED,
    S.STANDSTILL,
    S.HOMING,
    S.DISCRETE_MOTION,
    S.CONTINUOUS_MOTION,
    S.STOPPING,
    S.ERROR_STOP,
]


@pytest.mark.parametrize("fbname", list(FBS))
@pytest.mark.parametrize("state", STATES, ids=lambda s: s.name)
def test_c2_state_x_command_matrix(state: AxisState, fbname: str) -> None:
    make, target, accepted_in = FBS[fbname]
    b = Bench(home_switch=1e6, home_velocity=10.0).powered()  # homing runs for a long time
    _enter(b, state)
    fb = b.add(make())
    fb.execute = True
    b.run(1)
    if state in accepted_in:
        assert not fb.error
        if fbname == "MC_Halt" and state is S.STANDSTILL:
            target = S.STANDSTILL  # T8 then T9 in the same kernel step (already at rest)
        assert b.x.state is target
    else:
        assert fb.error and fb.error_id is ErrorID.for_state(state)
        assert b.x.state is state


def test_c3_stop_during_move_velocity() -> None:
    b = Bench(a_max=100.0).powered()
    mv = b.add(MC_MoveVelocity(velocity=50.0, acceleration=100.0))
    st = b.add(MC_Stop(deceleration=20.0))
    ma = b.add(MC_MoveAbsolute(position=0.0, velocity=10.0))
    b.pulse(mv)
    b.run(1000)
    assert mv.in_velocity
    st.execute = True
    k = b.cycle
    b.run(1)
    assert b.x.state is S.STOPPING
    b.run(1)
    assert rise(b, mv, "command_aborted") == [k + 1]
    b.run(3000)
    [d] = rise(b, st, "done")
    assert abs((d - k) - 2500) <= 1  # 50 / 20 s
    assert b.x.state is S.STOPPING and st.done
    ma.execute = True
    b.run(1)
    assert ma.error and ma.error_id is ErrorID.STATE_STOPPING
    ma.execute = False
    st.execute = False
    b.run(2)
    assert b.x.state is S.STANDSTILL and not st.done


def test_c4_halt_aborted_by_new_velocity() -> None:
    b = Bench().powered()
    rs = b.add(MC_ReadStatus(enable=True))
    mv1 = b.add(MC_MoveVelocity(velocity=50.0, acceleration=100.0))
    h = b.add(MC_Halt(deceleration=10.0))
    mv2 = b.add(MC_MoveVelocity(velocity=30.0, acceleration=100.0))
    b.pulse(mv1)
    b.run(1000)
    b.pulse(h)
    b.run(5)
    assert b.x.state is S.DISCRETE_MOTION and h.busy and h.active
    b.pulse(mv2)
    b.run(1000)
    assert rise(b, h, "command_aborted") and rise(b, h, "done") == []
    assert rise(b, rs, "standstill") == []
    assert mv2.in_velocity and b.x.v == pytest.approx(30.0)


def test_c5_power_off_aborts() -> None:
    b = Bench().powered()
    m = b.add(MC_MoveAbsolute(position=100.0, velocity=50.0))
    m.execute = True
    b.run(100)
    b.power.enable = False
    b.run(2)
    assert b.x.state is S.DISABLED
    assert m.command_aborted and not m.error


@pytest.mark.parametrize("enable_at_reset", [True, False])
def test_c6_drive_fault_errors_queue_and_reset(enable_at_reset: bool) -> None:
    b = Bench(j_max=5000.0).powered()
    m1 = b.add(MC_MoveAbsolute(position=100.0, velocity=50.0))
    m2 = b.add(MC_MoveAbsolute(position=200.0, velocity=50.0, buffer_mode=BufferMode.BUFFERED))
    m3 = b.add(MC_MoveAbsolute(position=0.0, velocity=50.0))
    rst = b.add(MC_Reset())
    rae = b.add(MC_ReadAxisError(enable=True))
    m1.execute = m2.execute = True
    b.run(500)
    b.x.drive.inject_fault(0x7300, "encoder")
    b.run(2)
    assert b.x.state is S.ERROR_STOP
    assert m1.error and m1.error_id is ErrorID.AXIS_ERROR_STOP
    assert m2.error and m2.error_id is ErrorID.AXIS_ERROR_STOP
    assert (
        not b.x.queue
        and rae.axis_error_id is ErrorID.DRIVE_FAULT
        and "0x7300" in rae.axis_error_reason
    )
    b.pulse(m3)
    assert m3.error and m3.error_id is ErrorID.STATE_ERROR_STOP
    b.run(1000)  # controlled stop ramp done
    assert b.x.v == 0.0
    b.power.enable = enable_at_reset
    rst.execute = True
    b.run(5)
    assert rst.done
    assert b.x.state is (S.STANDSTILL if enable_at_reset else S.DISABLED)
    assert rae.axis_error_id is ErrorID.OK


def test_c7_runtime_error_of_active_fb_activates_the_buffered_one_at_once() -> None:
    b = Bench(sw_limit_pos=500.0, sw_limit_neg=-500.0).powered()
    mv = b.add(MC_MoveVelocity(velocity=10.0))
    m1 = b.add(MC_MoveRelative(distance=1000.0, velocity=50.0, buffer_mode=BufferMode.BUFFERED))
    m2 = b.add(MC_MoveAbsolute(position=200.0, velocity=50.0, buffer_mode=BufferMode.BUFFERED))
    b.pulse(mv)
    m1.execute = True  # target unknown until MoveVelocity hands over (at InVelocity)
    b.pulse(m2)
    b.run_until_idle()
    [e] = rise(b, m1, "error")
    assert m1.error_id is ErrorID.TARGET_OUTSIDE_SW_LIMITS
    assert rise(b, m2, "active") == [e]
    assert b.x.p == 200.0


def test_following_error_and_errorstop_ramp() -> None:
    b = Bench(j_max=5000.0, following_error_limit=0.5).powered()
    mv = b.add(MC_MoveVelocity(velocity=100.0))
    b.pulse(mv)
    b.run(2000)
    b.x.drive._position -= 1.0  # the load slips
    b.x.drive._refresh()
    b.run(2)
    assert b.x.state is S.ERROR_STOP and b.x.axis_error is ErrorID.FOLLOWING_ERROR
    assert mv.error
    b.run(2000)
    assert b.x.v == 0.0  # stopped with the axis limits, jerk-limited (invariants)


@pytest.mark.parametrize("velocity", [0.0, 50.0])
def test_buffered_move_after_a_velocity_cruise_starts_from_the_current_state(
    velocity: float,
) -> None:
    """Found by the stateful test: MC_MoveVelocity at its velocity (InVelocity) for a while,
    then a Buffered MC_MoveAbsolute. The move takes over from the set state of that cycle --
    not from where the velocity job reached its velocity, not with the whole cruise time as
    its first step (that jumped the velocity by several cycles' worth)."""
    b = Bench(v_max=200.0, a_max=400.0, j_max=math.inf).powered()
    mv = b.add(MC_MoveVelocity(velocity=velocity, acceleration=100.0, deceleration=100.0))
    ma = b.add(
        MC_MoveAbsolute(
            position=300.0,
            velocity=50.0,
            acceleration=100.0,
            deceleration=100.0,
            buffer_mode=BufferMode.BUFFERED,
        )
    )
    b.pulse(mv)
    b.run(1500)  # InVelocity after 0.5 s at most, then cruising
    assert mv.in_velocity
    before = b.x.p
    b.pulse(ma)
    b.run_until_idle()
    assert rise(b, ma, "done") and b.x.p == 300.0
    p = b.col("x.position")
    v = b.col("x.velocity")
    k = int(np.argmax(p >= before)) if velocity else 0
    assert np.all(np.abs(np.diff(p)) <= 50.0 * 0.001 + 1e-9), "position jump"
    assert np.all(np.abs(np.diff(v)) <= 100.0 * 0.001 + 1e-9), "velocity jump"
    assert np.all(np.diff(p[k:]) >= -1e-12), "moved back"
