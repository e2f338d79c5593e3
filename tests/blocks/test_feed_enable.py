"""MC_Power.enable_positive / enable_negative (feed enables per direction).

motionplc rule (the spec only names the inputs; Beckhoff Tc2_MC2/MC3: "feed enable in positive /
negative direction"): a command that would move in a direction that is not enabled is refused
with Error DIRECTION_NOT_ENABLED and the axis is unaffected; a running command whose direction
loses its enable ends with that Error (queued commands too) and the axis stops with its own
limits (DiscreteMotion, like MC_Halt, then Standstill). Motion in the other direction stays
possible, also during that stop.
"""

from __future__ import annotations

import pytest

from motionplc.blocks import (
    AxisState,
    BufferMode,
    ErrorID,
    MC_Home,
    MC_MoveAbsolute,
    MC_MoveRelative,
    MC_MoveVelocity,
)
from tests.runtime.helpers import Bench

S = AxisState
E = ErrorID.DIRECTION_NOT_ENABLED


def test_a_move_in_a_disabled_direction_is_refused_in_the_calling_scan() -> None:
    b = Bench(v_max=100.0, a_max=400.0, j_max=10_000.0).powered()
    b.power.enable_positive = False
    b.run(1)
    up = b.add(MC_MoveAbsolute(position=50.0, velocity=50.0))
    up.execute = True
    b.run(1)
    assert up.error and up.error_id is E and not up.busy
    assert b.x.state is S.STANDSTILL and b.x.p == 0.0
    down = b.add(MC_MoveRelative(distance=-20.0, velocity=50.0))
    b.pulse(down)
    b.run_until_idle()
    assert b.x.p == pytest.approx(-20.0, abs=1e-9)
    assert down.error_id is ErrorID.OK


@pytest.mark.parametrize(("velocity", "refused"), [(-30.0, True), (30.0, False)])
def test_move_velocity_direction(velocity: float, refused: bool) -> None:
    b = Bench(v_max=100.0, a_max=400.0).powered()
    b.power.enable_negative = False
    mv = b.add(MC_MoveVelocity(velocity=velocity))
    mv.execute = True
    b.run(300)
    assert mv.error is refused
    assert (b.x.state is S.STANDSTILL) is refused
    if refused:
        assert mv.error_id is E


def test_enable_removed_during_motion_stops_with_error() -> None:
    b = Bench(v_max=100.0, a_max=400.0, j_max=10_000.0).powered()
    mv = b.add(MC_MoveAbsolute(position=1000.0, velocity=80.0))
    queued = b.add(MC_MoveAbsolute(position=500.0, velocity=50.0, buffer_mode=BufferMode.BUFFERED))
    mv.execute = True
    b.run(1)
    queued.execute = True
    b.run(500)
    assert mv.active and queued.busy
    b.power.enable_positive = False
    k = b.cycle
    b.run(2)
    assert mv.error and mv.error_id is E and not mv.busy
    assert queued.error and queued.error_id is E
    assert b.x.state is S.DISCRETE_MOTION  # braking, like MC_Halt
    b.run(1000)
    assert b.x.state is S.STANDSTILL and b.x.v == 0.0
    v = b.col("x.velocity")[k:]
    assert (v >= 0.0).all() and (v[1:] <= v[:-1] + 1e-12).all()  # monotonic controlled stop
    assert b.x.axis_error is ErrorID.OK  # not an axis error: no ErrorStop, no reset needed


def test_reverse_command_during_the_feed_stop_is_accepted() -> None:
    b = Bench(v_max=100.0, a_max=400.0, j_max=10_000.0).powered()
    mv = b.add(MC_MoveVelocity(velocity=80.0))
    b.pulse(mv)
    b.run(500)
    b.power.enable_positive = False
    b.run(10)
    back = b.add(MC_MoveAbsolute(position=0.0, velocity=50.0))
    b.pulse(back)
    b.run_until_idle()
    assert back.error_id is ErrorID.OK
    assert b.x.p == pytest.approx(0.0, abs=1e-9)


def test_enables_checked_again_when_a_queued_command_starts() -> None:
    b = Bench(v_max=100.0, a_max=400.0).powered()
    first = b.add(MC_MoveAbsolute(position=-20.0, velocity=50.0))
    second = b.add(MC_MoveAbsolute(position=30.0, velocity=50.0, buffer_mode=BufferMode.BUFFERED))
    b.pulse(first)
    b.pulse(second)  # accepted: positive motion is enabled now
    b.power.enable_positive = False
    b.run_until_idle()
    assert first.error_id is ErrorID.OK
    assert b.edges(second, "error") and b.x.p == pytest.approx(-20.0, abs=1e-9)


def test_homing_search_in_a_disabled_direction_is_refused() -> None:
    b = Bench(v_max=100.0, a_max=400.0, home_switch=50.0).powered()
    b.power.enable_positive = False
    h = b.add(MC_Home(position=0.0))
    h.execute = True
    b.run(2)
    assert h.error and h.error_id is E
    assert b.x.state is S.STANDSTILL
