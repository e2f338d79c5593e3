"""FB interface rules (spec 2.1, conformance group B) and input validation."""

from __future__ import annotations

import math
import subprocess
import sys

import numpy as np
import pytest

from motionplc.blocks import (
    AxisState,
    BufferMode,
    Direction,
    ErrorID,
    MC_Halt,
    MC_MoveAbsolute,
    MC_MoveRelative,
    MC_MoveVelocity,
    MC_ReadActualPosition,
    MC_SetOverride,
)
from tests.runtime.helpers import Bench


def rise(b: Bench, fb, out: str) -> list[int]:
    return [c for c, v in b.edges(fb, out) if v]


def fall(b: Bench, fb, out: str) -> list[int]:
    return [c for c, v in b.edges(fb, out) if not v]


def test_b1_done_held_while_execute_true() -> None:
    b = Bench().powered()
    m = b.add(MC_MoveAbsolute(position=10.0, velocity=100.0))
    m.execute = True
    b.run_until_idle()
    [d] = rise(b, m, "done")
    b.run(50)
    assert m.done and fall(b, m, "done") == []
    m.execute = False
    k = b.cycle
    b.run(1)
    assert not m.done and fall(b, m, "done") == [k]
    assert d < k


def test_b2_error_after_pulse_lasts_one_cycle() -> None:
    b = Bench().powered()
    m = b.add(MC_MoveAbsolute(position=10.0, velocity=-1.0))
    k = b.pulse(m)
    b.run(3)
    assert rise(b, m, "error") == [k] and fall(b, m, "error") == [k + 1]
    assert rise(b, m, "busy") == []


def test_b3_inputs_changed_while_busy_have_no_effect() -> None:
    b = Bench().powered()
    m = b.add(MC_MoveAbsolute(position=100.0, velocity=100.0))
    b.pulse(m)
    b.run(100)
    m.position = 300.0
    m.velocity = 10.0
    b.run_until_idle()
    assert b.x.p == 100.0


@pytest.mark.parametrize("beckhoff", [False, True])
def test_b4_retrigger(beckhoff: bool) -> None:
    b = Bench().powered()
    m = b.add(MC_MoveAbsolute(position=100.0, velocity=100.0, retrigger_ignored=beckhoff))
    b.pulse(m)
    b.run(200)
    b.pulse(m, position=50.0)
    b.run_until_idle()
    assert rise(b, m, "command_aborted") == []
    assert len(rise(b, m, "done")) == 1  # only for the command that was executed
    assert b.x.p == (100.0 if beckhoff else 50.0)


def test_b5_unconnected_input_keeps_its_value() -> None:
    b = Bench().powered()
    m = MC_MoveAbsolute()
    b.add(m)
    m(position=500.0, velocity=100.0)  # a call without an Execute edge
    b.run(2)
    b.pulse(m)  # no position given: 500 stays
    b.run_until_idle()
    assert b.x.p == 500.0


def test_b6_enable_fb_valid_and_recoverable_error() -> None:
    b = Bench().powered()
    r = b.add(MC_ReadActualPosition())
    r.enable = True
    k = b.cycle
    b.run(1)
    assert r.valid and rise(b, r, "valid") == [k]  # same cycle as Enable
    b.x.drive.set_comm_ok(False)
    b.run(1)
    assert r.busy and r.error and not r.valid and r.error_id is ErrorID.COMMUNICATION_LOST
    b.x.drive.set_comm_ok(True)
    b.run(1)
    assert r.valid and not r.error
    r.enable = False
    b.run(1)
    assert not (r.valid or r.busy or r.error)


def test_unknown_input_raises_type_error() -> None:
    m = MC_MoveAbsolute()
    with pytest.raises(TypeError, match="unknown input 'distance'"):
        m(distance=3.0)


BAD_INPUTS = [
    (MC_MoveAbsolute, {"position": math.nan}, ErrorID.INVALID_POSITION, "position"),
    (MC_MoveAbsolute, {"position": 1.0, "velocity": 0.0}, ErrorID.INVALID_VELOCITY, "velocity"),
    (MC_MoveAbsolute, {"position": 1.0, "velocity": 500.0}, ErrorID.INVALID_VELOCITY, "(0, 200]"),
    (
        MC_MoveAbsolute,
        {"position": 1.0, "velocity": 1.0, "acceleration": -1.0},
        ErrorID.INVALID_ACCELERATION,
        "acceleration",
    ),
    (
        MC_MoveAbsolute,
        {"position": 1.0, "velocity": 1.0, "deceleration": 1e9},
        ErrorID.INVALID_DECELERATION,
        "deceleration",
    ),
    (
        MC_MoveAbsolute,
        {"position": 1.0, "velocity": 1.0, "jerk": math.inf},
        ErrorID.INVALID_JERK,
        "jerk",
    ),
    (
        MC_MoveAbsolute,
        {"position": 1.0, "velocity": 1.0, "buffer_mode": 9},
        ErrorID.INVALID_BUFFER_MODE,
        "buffer_mode",
    ),
    (
        MC_MoveAbsolute,
        {"position": 1.0, "velocity": 1.0, "direction": "up"},
        ErrorID.INVALID_DIRECTION,
        "direction",
    ),
    (MC_MoveRelative, {"distance": "far", "velocity": 1.0}, ErrorID.INVALID_DISTANCE, "distance"),
    (
        MC_MoveVelocity,
        {"velocity": 1.0, "direction": Direction.SHORTEST},
        ErrorID.INVALID_DIRECTION,
        "direction",
    ),
    (MC_MoveVelocity, {"velocity": -300.0}, ErrorID.INVALID_VELOCITY, "velocity"),
    (MC_Halt, {"deceleration": -5.0}, ErrorID.INVALID_DECELERATION, "deceleration"),
]


@pytest.mark.parametrize(("cls", "inputs", "eid", "text"), BAD_INPUTS)
def test_bad_input_gives_error_and_keeps_the_motion(cls, inputs, eid, text) -> None:
    b = Bench().powered()
    mv = b.add(MC_MoveVelocity(velocity=20.0))
    bad = b.add(cls(**inputs))
    b.pulse(mv)
    b.run(300)
    assert mv.in_velocity
    v_before = b.x.v
    bad.execute = True
    b.run(3)
    assert bad.error and bad.error_id is eid and text in bad.error_text
    assert not bad.busy
    assert mv.in_velocity and mv.active and b.x.v == v_before
    assert b.x.state is AxisState.CONTINUOUS_MOTION


def test_override_validation() -> None:
    b = Bench().powered()
    o = b.add(MC_SetOverride())
    o.enable = True
    o.vel_factor = 1.5
    b.run(1)
    assert o.error and o.error_id is ErrorID.INVALID_OVERRIDE and not o.enabled
    o.vel_factor = 0.5
    b.run(1)
    assert o.enabled and not o.error
    o.acc_factor = 0.0
    b.run(1)
    assert o.error and b.x.override == (0.5, 1.0, 1.0)


def _buffered_trace(swap: bool) -> tuple[np.ndarray, list]:
    b = Bench().powered()
    m1 = MC_MoveAbsolute(
        name="fb1", position=1000.0, velocity=100.0, acceleration=100.0, deceleration=100.0
    )
    m2 = MC_MoveAbsolute(
        name="fb2",
        position=2000.0,
        velocity=50.0,
        acceleration=200.0,
        deceleration=200.0,
        buffer_mode=BufferMode.BUFFERED,
    )
    if swap:
        b.add(m2, m1)
    else:
        b.add(m1, m2)
    b.pulse(m1)
    b.run(2000)
    b.pulse(m2)
    b.run_until_idle()
    return b.rt.trace.array(), sorted(b.rt.trace.events)


def test_h7_call_order_independence() -> None:
    a1, e1 = _buffered_trace(False)
    a2, e2 = _buffered_trace(True)
    assert np.array_equal(a1, a2)
    assert e1 == e2


def _blending_low_digest() -> str:
    b = Bench(v_max=200.0, a_max=400.0, j_max=5000.0).powered()
    m1 = MC_MoveAbsolute(position=1000.0, velocity=100.0, acceleration=100.0, deceleration=100.0)
    m2 = MC_MoveAbsolute(
        position=2000.0,
        velocity=50.0,
        acceleration=50.0,
        deceleration=50.0,
        buffer_mode=BufferMode.BLENDING_LOW,
    )
    b.add(m1, m2)
    b.pulse(m1)
    b.run(2000)
    b.pulse(m2)
    b.run_until_idle()
    return b.rt.trace.digest()


def test_h1_determinism_also_under_load() -> None:
    d1 = _blending_low_digest()
    burner = subprocess.Popen([sys.executable, "-c", "while True: pass"])
    try:
        d2 = _blending_low_digest()
    finally:
        burner.kill()
        burner.wait()
    assert d1 == d2


def test_jerk_limited_abort_keeps_acceleration_continuous() -> None:
    b = Bench(v_max=200.0, a_max=400.0, j_max=2000.0).powered()
    m1 = b.add(MC_MoveAbsolute(position=1000.0, velocity=150.0))
    m2 = b.add(MC_MoveAbsolute(position=-200.0, velocity=100.0))
    b.pulse(m1)
    b.run(150)  # mid acceleration ramp
    assert 0.0 < b.x.a
    b.pulse(m2)
    b.run_until_idle()
    a = b.col("x.acceleration")
    assert np.abs(np.diff(a)).max() <= 2000.0 * 0.001 * (1 + 1e-9)
    assert b.x.p == -200.0
