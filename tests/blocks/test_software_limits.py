"""Software limits (issue 11, finding 4): PLCopen semantics without lock-out.

* a target beyond a limit is refused at Execute (input ErrorID, the axis keeps its motion);
* a motion that would cross a limit brakes to rest AT the limit (within 1e-9, jerk-limited with
  the axis' own limits, checked every cycle by the runtime's invariants), then ErrorStop with
  SW_LIMIT;
* MC_Reset of that error gives Standstill at the limit without re-tripping; from there (or from
  beyond a limit) only moves back towards the allowed range are accepted.

Every Bench checks the conformance invariants each cycle (v, a within the axis limits, a and v
continuous within j_max * dt and a_max * dt, state changes along the diagram).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from motionplc.blocks import (
    AxisState,
    ErrorID,
    MC_Halt,
    MC_MoveAbsolute,
    MC_MoveRelative,
    MC_MoveVelocity,
    MC_ReadAxisError,
    MC_Reset,
    MC_SetPosition,
)
from tests.runtime.helpers import Bench

HI, LO = 0.5, -0.5
TOL = 1e-9


def _bench(**kw: float) -> Bench:
    axis = {"v_max": 1.0, "a_max": 2.0, "j_max": 20.0, "sw_limit_pos": HI, "sw_limit_neg": LO}
    axis.update(kw)
    return Bench(**axis).powered()


def _held(b: Bench, v_max: float, a_max: float, j_max: float) -> None:
    """The set values over the whole trace stayed within the axis' limits (the jerk as the
    difference of consecutive accelerations, which the planner's phases bound exactly)."""
    v = b.col("x.velocity")
    a = b.col("x.acceleration")
    assert np.max(np.abs(v)) <= v_max * (1 + 1e-9)
    assert np.max(np.abs(a)) <= a_max * (1 + 1e-9)
    if math.isfinite(j_max):
        assert np.max(np.abs(np.diff(a))) <= j_max * b.rt.cycle * (1 + 1e-6)


def _into_limit(b: Bench, velocity: float, cycles: int = 6000) -> MC_MoveVelocity:
    mv = b.add(MC_MoveVelocity(velocity=abs(velocity)))
    mv.direction = mv.direction if velocity > 0 else type(mv.direction).NEGATIVE
    mv.execute = True  # held: the final Error stays visible
    b.run(cycles)
    return mv


@pytest.mark.parametrize(
    ("velocity", "j_max"),
    [(0.2, 20.0), (1.0, 20.0), (0.2, math.inf), (1.0, math.inf), (-0.7, 20.0), (0.05, 5.0)],
)
def test_velocity_move_stops_at_the_limit(velocity: float, j_max: float) -> None:
    b = _bench(j_max=j_max)
    err = b.add(MC_ReadAxisError(enable=True))
    mv = _into_limit(b, velocity, cycles=round(1.0 / abs(velocity) / b.rt.cycle) + 2000)
    limit = HI if velocity > 0 else LO
    p = b.col("x.position")
    x = b.x
    # never beyond the limit, at rest exactly on it
    assert np.max(p) <= HI + TOL and np.min(p) >= LO - TOL
    assert abs(x.p - limit) <= TOL and x.v == 0.0 and x.a == 0.0
    _held(b, 1.0, 2.0, j_max)
    assert x.state is AxisState.ERROR_STOP and x.axis_error is ErrorID.SW_LIMIT
    assert mv.error and mv.error_id is ErrorID.SW_LIMIT and not mv.busy
    assert "software limit" in mv.error_text
    assert err.axis_error_id is ErrorID.SW_LIMIT and "software limit" in err.axis_error_reason


def test_reset_then_move_back_without_lockout() -> None:
    b = _bench()
    mv = _into_limit(b, 0.2)
    rs = b.add(MC_Reset())
    ma = b.add(MC_MoveAbsolute(position=0.0, velocity=0.5))
    back = b.add(MC_MoveVelocity(velocity=0.3))
    b.pulse(rs)
    b.run(3)
    x = b.x
    assert x.state is AxisState.STANDSTILL and x.axis_error is ErrorID.OK
    assert abs(x.p - HI) <= TOL
    b.run(500)  # no re-trip while standing at the limit
    assert x.state is AxisState.STANDSTILL
    # further out: refused at Execute, the axis stays where it is
    mv.execute = False
    b.run(1)
    mv.execute = True
    b.run(2)
    assert mv.error and mv.error_id is ErrorID.MOVE_BEYOND_SW_LIMIT and not mv.busy
    assert "further out" in mv.error_text and x.state is AxisState.STANDSTILL
    mv.execute = False
    # back: a velocity move away from the limit runs, then an absolute move home
    back.direction = type(back.direction).NEGATIVE
    b.pulse(back)
    b.run(1000)
    assert back.in_velocity and x.p < HI - 0.1
    b.pulse(ma)
    b.run_until_idle()
    assert ma.done or abs(x.p) <= TOL
    assert abs(x.p) <= TOL and x.state is AxisState.STANDSTILL


def test_target_beyond_the_limit_is_an_input_error_and_keeps_the_motion() -> None:
    b = _bench()
    mv = b.add(MC_MoveVelocity(velocity=0.1))
    bad = b.add(MC_MoveAbsolute(position=0.6, velocity=0.5))
    rel = b.add(MC_MoveRelative(distance=-2.0, velocity=0.5))
    b.pulse(mv)
    b.run(300)
    v_before = b.x.v
    for fb in (bad, rel):
        b.pulse(fb)
        assert fb.error and fb.error_id is ErrorID.TARGET_OUTSIDE_SW_LIMITS and not fb.busy
        assert "software limits" in fb.error_text
    assert mv.in_velocity and b.x.v == v_before and b.x.state is AxisState.CONTINUOUS_MOTION


def test_move_to_the_limit_itself_is_fine() -> None:
    b = _bench()
    ma = b.add(MC_MoveAbsolute(position=HI, velocity=1.0))
    b.pulse(ma)
    b.run_until_idle()
    assert b.x.p == HI and b.x.state is AxisState.STANDSTILL and b.x.axis_error is ErrorID.OK


def test_overshooting_profile_brakes_at_the_limit() -> None:
    """A move whose own profile would pass the limit (a gentle Deceleration input, issued too
    late to stop at its target) brakes with the axis' limits and stops AT the limit."""
    b = _bench(sw_limit_pos=5.0, sw_limit_neg=-5.0)
    mv = b.add(MC_MoveVelocity(velocity=1.0))
    ma = b.add(MC_MoveAbsolute(position=4.95, velocity=1.0, deceleration=0.2))
    b.pulse(mv)
    b.rt.run_until(lambda: b.x.p >= 3.5, max_seconds=10.0)
    assert mv.in_velocity  # 1.45 m before the target, 2.5 m needed at Deceleration 0.2
    ma.execute = True
    b.run(6000)
    assert np.max(b.col("x.position")) <= 5.0 + TOL
    assert abs(b.x.p - 5.0) <= TOL and b.x.state is AxisState.ERROR_STOP
    assert ma.error and ma.error_id is ErrorID.SW_LIMIT
    _held(b, 1.0, 2.0, 20.0)


def test_halt_that_stops_inside_does_not_trip() -> None:
    """Braking already (a < 0) near the limit: the exact stopping distance decides, not a bound."""
    b = _bench(sw_limit_pos=5.0, sw_limit_neg=-5.0)
    mv = b.add(MC_MoveVelocity(velocity=1.0))
    halt = b.add(MC_Halt())
    b.pulse(mv)
    # Halt with the axis' limits from 1 m/s needs 0.3 m (a 2, j 20): start it 0.305 m before
    # the limit (the bound from a = 0 then says "crossing" while it brakes; the exact one not)
    b.rt.run_until(lambda: b.x.p >= 5.0 - 0.306, max_seconds=10.0)
    assert mv.in_velocity
    b.pulse(halt)
    b.run_until_idle()
    assert b.x.state is AxisState.STANDSTILL and b.x.axis_error is ErrorID.OK
    assert 5.0 - 0.01 < b.x.p <= 5.0


def test_standing_beyond_a_limit_moves_back_only() -> None:
    """MC_SetPosition puts the axis beyond the limit: no trip while standing; a move further out
    is refused, one back towards the range (even to a target still outside) runs."""
    b = _bench()
    sp = b.add(MC_SetPosition(position=0.8))
    out = b.add(MC_MoveAbsolute(position=0.9, velocity=0.5))
    out_rel = b.add(MC_MoveRelative(distance=0.01, velocity=0.5))
    part = b.add(MC_MoveAbsolute(position=0.6, velocity=0.5))
    home = b.add(MC_MoveAbsolute(position=0.0, velocity=0.5))
    b.pulse(sp)
    b.run(100)
    x = b.x
    assert x.p == 0.8 and x.state is AxisState.STANDSTILL
    for fb in (out, out_rel):
        b.pulse(fb)
        assert fb.error and fb.error_id is ErrorID.TARGET_OUTSIDE_SW_LIMITS
    assert x.p == 0.8
    b.pulse(part)
    b.run_until_idle()
    assert abs(x.p - 0.6) <= TOL and x.state is AxisState.STANDSTILL
    b.pulse(home)
    b.run_until_idle()
    assert abs(x.p) <= TOL and x.axis_error is ErrorID.OK


def test_shift_beyond_the_limit_while_moving_out_stops_and_resets() -> None:
    """The last resort: MC_SetPosition during an outward motion jumps the axis beyond the limit;
    it stops as fast as its limits allow (ErrorStop SW_LIMIT), MC_Reset works, moving back too."""
    b = _bench()
    mv = b.add(MC_MoveVelocity(velocity=0.2))
    sp = b.add(MC_SetPosition(position=0.7))
    rs = b.add(MC_Reset())
    ma = b.add(MC_MoveAbsolute(position=0.0, velocity=0.5))
    b.pulse(mv)
    b.run(300)
    b.pulse(sp)
    b.run(500)
    x = b.x
    assert x.state is AxisState.ERROR_STOP and x.axis_error is ErrorID.SW_LIMIT and x.v == 0.0
    stopped_at = x.p
    assert stopped_at > 0.7
    b.pulse(rs)
    b.run(5)
    assert x.state is AxisState.STANDSTILL and x.p == stopped_at
    b.run(200)
    assert x.state is AxisState.STANDSTILL
    b.pulse(ma)
    b.run_until_idle()
    assert abs(x.p) <= TOL
