"""ContinuousUpdate (spec 2.3) for MC_MoveAbsolute/Relative/Additive and MC_MoveVelocity.

Every test runs with the per-cycle invariants (continuity of p, v and - for a finite j_max - a:
a re-plan never makes the acceleration jump).
"""

from __future__ import annotations

import numpy as np
import pytest

from motionplc.blocks import (
    AxisState,
    BufferMode,
    ErrorID,
    MC_MoveAbsolute,
    MC_MoveAdditive,
    MC_MoveRelative,
    MC_MoveVelocity,
)
from tests.runtime.helpers import Bench

S = AxisState
JERKY = {"v_max": 50.0, "a_max": 20.0, "j_max": 200.0}


def _run_until(b: Bench, pred, max_cycles: int = 100_000) -> None:
    assert b.rt.run_until(pred, max_seconds=max_cycles * b.rt.cycle)


def test_spec_example_move_relative() -> None:
    """Spec p. 25: from 0, Distance 100, Velocity 10, ContinuousUpdate; at 50 the inputs become
    Distance 130 and Velocity 20: the axis accelerates to 20, stops at 130, sets Done and
    takes no further updates."""
    b = Bench(**JERKY).powered()
    m = b.add(MC_MoveRelative(distance=100.0, velocity=10.0, continuous_update=True))
    k0 = b.pulse(m)
    _run_until(b, lambda: b.x.p >= 50.0)
    k_change = b.cycle
    m.distance, m.velocity = 130.0, 20.0
    b.run_until_idle()
    assert b.x.p == pytest.approx(130.0, abs=1e-9)
    v = b.col("x.velocity")
    assert v[k0:k_change].max() == pytest.approx(10.0, abs=1e-9)
    assert v[k_change:].max() == pytest.approx(20.0, abs=1e-9)
    assert (v >= -1e-12).all()  # no reversal
    done = b.edges(m, "done")
    assert len(done) == 2 and done[0][1] and not done[1][1]  # a one-cycle Done pulse
    assert b.edges(m, "command_aborted") == []
    assert b.edges(m, "error") == []
    # after Done: changing the inputs (ContinuousUpdate still TRUE) moves nothing
    m.distance = 200.0
    b.run(200)
    assert b.x.p == pytest.approx(130.0, abs=1e-9)
    assert b.x.state is S.STANDSTILL


def test_relative_inputs_refer_to_the_initial_condition() -> None:
    b = Bench(**JERKY).powered()
    assert b.x.p == 0.0
    m = b.add(MC_MoveAdditive(distance=40.0, velocity=20.0, continuous_update=True))
    b.pulse(m)
    b.run(500)
    m.distance = 25.0  # the target becomes 0 + 25, not the current position + 25
    b.run_until_idle()
    assert b.x.p == pytest.approx(25.0, abs=1e-9)


def test_continuous_update_false_at_execute_ignores_later_changes() -> None:
    b = Bench(**JERKY).powered()
    m = b.add(MC_MoveAbsolute(position=60.0, velocity=20.0))
    b.pulse(m)
    b.run(300)
    m.continuous_update = True  # too late: only its value at the rising edge counts
    m.position = 10.0
    b.run_until_idle()
    assert b.x.p == pytest.approx(60.0, abs=1e-9)


def test_updates_stop_once_continuous_update_falls() -> None:
    b = Bench(**JERKY).powered()
    m = b.add(MC_MoveAbsolute(position=80.0, velocity=20.0, continuous_update=True))
    b.pulse(m)
    b.run(300)
    m.position = 70.0
    b.run(1)
    m.continuous_update = False
    b.run(1)
    m.position = 10.0
    m.continuous_update = True  # set again: has no effect for this command
    b.run_until_idle()
    assert b.x.p == pytest.approx(70.0, abs=1e-9)


def test_absolute_target_behind_the_axis_reverses_jerk_limited() -> None:
    b = Bench(**JERKY).powered()
    m = b.add(MC_MoveAbsolute(position=100.0, velocity=30.0, continuous_update=True))
    b.pulse(m)
    _run_until(b, lambda: b.x.p >= 40.0)
    m.position = 20.0
    b.run_until_idle()
    assert b.x.p == pytest.approx(20.0, abs=1e-9)
    assert b.edges(m, "command_aborted") == []
    a = b.col("x.acceleration")
    assert np.abs(np.diff(a)).max() <= JERKY["j_max"] * b.rt.cycle * (1 + 1e-6) + 1e-9


def test_move_velocity_update_leaves_and_regains_in_velocity() -> None:
    b = Bench(**JERKY).powered()
    m = b.add(MC_MoveVelocity(velocity=40.0, continuous_update=True))
    b.pulse(m)
    _run_until(b, lambda: m.in_velocity)
    m.velocity = 15.0
    b.run(2)
    assert not m.in_velocity and m.busy and m.active
    _run_until(b, lambda: m.in_velocity)
    assert b.x.v == pytest.approx(15.0, abs=1e-9)
    assert b.x.state is S.CONTINUOUS_MOTION
    m.acceleration = 10.0  # a new limit alone: re-planned, nothing to do at this speed
    for _ in range(5):
        b.run(1)
        assert m.in_velocity and b.x.v == pytest.approx(15.0, abs=1e-9)
    assert b.edges(m, "command_aborted") == []


def test_queued_command_starts_with_the_updated_inputs() -> None:
    b = Bench(**JERKY).powered()
    first = b.add(MC_MoveAbsolute(position=30.0, velocity=20.0))
    second = b.add(
        MC_MoveAbsolute(
            position=60.0, velocity=20.0, buffer_mode=BufferMode.BUFFERED, continuous_update=True
        )
    )
    b.pulse(first)
    b.pulse(second)
    b.run(50)
    assert second.busy and not second.active
    second.position = 45.0
    b.run_until_idle()
    assert b.x.p == pytest.approx(45.0, abs=1e-9)


def test_blending_successor_update_replans_the_junction() -> None:
    b = Bench(**JERKY).powered()
    first = b.add(MC_MoveAbsolute(position=100.0, velocity=30.0))
    second = b.add(
        MC_MoveAbsolute(
            position=300.0,
            velocity=30.0,
            buffer_mode=BufferMode.BLENDING_LOW,
            continuous_update=True,
        )
    )
    b.pulse(first)
    b.pulse(second)
    b.run(100)
    assert first.end_velocity == pytest.approx(30.0)
    second.position = 50.0  # reversal: no blending possible any more, junction velocity 0
    b.run(2)
    assert first.end_velocity == pytest.approx(0.0)
    b.run_until_idle()
    assert b.x.p == pytest.approx(50.0, abs=1e-9)


def test_invalid_update_ends_the_command_with_error_and_stops() -> None:
    b = Bench(**JERKY).powered()
    m = b.add(MC_MoveVelocity(velocity=30.0, continuous_update=True))
    m.execute = True
    b.run(300)
    m.velocity = 500.0  # above v_max
    b.run(2)
    assert m.error and m.error_id is ErrorID.INVALID_VELOCITY and not m.busy
    assert "velocity" in m.error_text
    b.run(2000)
    assert b.x.state is S.STANDSTILL and b.x.v == 0.0  # controlled stop, then Standstill


def test_invalid_update_lets_the_queued_command_take_over() -> None:
    b = Bench(**JERKY).powered()
    first = b.add(MC_MoveAbsolute(position=100.0, velocity=20.0, continuous_update=True))
    second = b.add(MC_MoveAbsolute(position=-10.0, velocity=20.0, buffer_mode=BufferMode.BUFFERED))
    b.pulse(first)
    b.pulse(second)
    b.run(200)
    first.velocity = -1.0
    b.run(2)
    assert first.error and first.error_id is ErrorID.INVALID_VELOCITY
    assert second.active
    b.run_until_idle()
    assert b.x.p == pytest.approx(-10.0, abs=1e-9)


@pytest.mark.parametrize("scenario", ["replan", "invalid"])
def test_updates_are_independent_of_the_call_order(scenario: str) -> None:
    def run(swap: bool) -> tuple[np.ndarray, list]:
        b = Bench(**JERKY).powered()
        first = MC_MoveAbsolute("first", position=100.0, velocity=20.0, continuous_update=True)
        second = MC_MoveAbsolute(
            "second", position=-10.0, velocity=20.0, buffer_mode=BufferMode.BLENDING_LOW
        )
        b.add(*((second, first) if swap else (first, second)))
        b.pulse(first)
        b.run(5)
        b.pulse(second)
        b.run(200)
        if scenario == "replan":
            first.position = 60.0
        else:
            first.velocity = -1.0
        b.run(3000)
        return b.rt.trace.array(), sorted(b.rt.trace.events)

    a1, e1 = run(False)
    a2, e2 = run(True)
    assert np.array_equal(a1, a2)
    assert e1 == e2
