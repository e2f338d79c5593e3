"""Asymmetric axis limits (v_min / a_min): the axis plans with them as given (no silent
clamp to the tighter symmetric pair), FB inputs only cap them, the config carries them."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from motionplc.blocks import (
    AxisState,
    Direction,
    ErrorID,
    MC_Halt,
    MC_MoveAbsolute,
    MC_MoveVelocity,
    MC_Stop,
)
from motionplc.blocks.axis import AxisConfig
from motionplc.config import build, load_config
from motionplc.sequence import runner_for
from tests.runtime.helpers import Bench

V_MAX, V_MIN = 1.0, -0.5
A_MAX, A_MIN = 4.0, -1.5
TOL = 1e-9


def _bench(j_max: float = math.inf) -> Bench:
    return Bench(v_max=V_MAX, a_max=A_MAX, j_max=j_max, v_min=V_MIN, a_min=A_MIN).powered()


def _execute(b: Bench, fb: object, **inputs: object) -> None:
    """A rising edge of Execute (held TRUE) with ``inputs``, run until the axis is idle."""
    for k, v in inputs.items():
        setattr(fb, k, v)
    fb.execute = False  # type: ignore[attr-defined]
    b.run(1)
    fb.execute = True  # type: ignore[attr-defined]
    b.run_until_idle()


def _within_limits(b: Bench) -> tuple[np.ndarray, np.ndarray]:
    v = b.col("x.velocity")
    a = b.col("x.acceleration")
    assert v.max() <= V_MAX * (1 + TOL) and v.min() >= V_MIN * (1 + TOL)
    assert a.max() <= A_MAX * (1 + TOL) and a.min() >= A_MIN * (1 + TOL)
    return v, a


@pytest.mark.parametrize("j_max", [math.inf, 40.0])
def test_moves_both_ways_reach_each_directions_own_limits(j_max: float) -> None:
    b = _bench(j_max)
    m = b.add(MC_MoveAbsolute(position=3.0, velocity=V_MAX))
    _execute(b, m)
    assert m.done and b.x.p == pytest.approx(3.0, abs=1e-9)
    # the FB Velocity 1.0 caps both directions, the axis' v_min (-0.5) the negative one
    _execute(b, m, position=0.0)
    assert m.done and b.x.p == pytest.approx(0.0, abs=1e-9)
    v, a = _within_limits(b)
    assert v.max() == pytest.approx(V_MAX, rel=1e-9)
    assert v.min() == pytest.approx(V_MIN, rel=1e-9)
    assert a.max() == pytest.approx(A_MAX, rel=1e-9)
    assert a.min() == pytest.approx(A_MIN, rel=1e-9)


def test_fb_inputs_cap_each_side() -> None:
    b = _bench()
    m = b.add(MC_MoveAbsolute(position=2.0, velocity=0.8, acceleration=1.0, deceleration=3.0))
    m.execute = True
    b.run_until_idle()
    assert m.done
    v, a = _within_limits(b)
    assert v.max() == pytest.approx(0.8, rel=1e-9)
    # moving positively: Acceleration caps a > 0 (1.0 < a_max), Deceleration caps a < 0 but
    # never beyond |a_min| = 1.5 (3.0 is capped, not the axis limit widened)
    assert a.max() == pytest.approx(1.0, rel=1e-9)
    assert a.min() == pytest.approx(A_MIN, rel=1e-9)


def test_move_velocity_and_halt_use_the_asymmetric_limits() -> None:
    b = _bench()
    mv = b.add(MC_MoveVelocity(velocity=0.5, direction=Direction.NEGATIVE))
    b.pulse(mv)
    b.run(2000)
    assert mv.in_velocity and b.x.v == pytest.approx(-0.5)
    h = b.add(MC_Halt())
    _execute(b, h)
    assert h.done and b.x.state is AxisState.STANDSTILL
    v, a = _within_limits(b)
    assert a.min() == pytest.approx(A_MIN, rel=1e-9)  # speeding up negatively
    assert a.max() == pytest.approx(A_MAX, rel=1e-9)  # slowing down from a negative speed
    # a negative velocity beyond v_min is rejected, not clamped
    bad = b.add(MC_MoveVelocity(velocity=0.8, direction=Direction.NEGATIVE))
    b.pulse(bad)
    assert bad.error and bad.error_id is ErrorID.INVALID_VELOCITY
    ok = b.add(MC_MoveVelocity(velocity=0.8, direction=Direction.POSITIVE))
    b.pulse(ok)
    b.run(500)
    assert ok.in_velocity and b.x.v == pytest.approx(0.8)
    st = b.add(MC_Stop())
    st.execute = True
    b.run_until_idle()
    assert st.done
    v, a = _within_limits(b)
    assert a.min() == pytest.approx(A_MIN, rel=1e-9)  # the stop decelerates with |a_min|


def test_axis_config_validates_and_defaults_symmetric() -> None:
    cfg = AxisConfig(name="x", v_max=1.0, a_max=2.0)
    assert (cfg.v_neg, cfg.a_neg) == (1.0, 2.0)
    cfg = AxisConfig(name="x", v_max=1.0, a_max=2.0, v_min=-0.5, a_min=-3.0)
    assert (cfg.v_neg, cfg.a_neg) == (0.5, 3.0)
    for bad in (0.0, 0.5, -math.inf, math.nan):
        with pytest.raises(ValueError, match="v_min"):
            AxisConfig(name="x", v_max=1.0, a_max=2.0, v_min=bad)
        with pytest.raises(ValueError, match="a_min"):
            AxisConfig(name="x", v_max=1.0, a_max=2.0, a_min=bad)


CONFIG = """\
runtime:
  tick: 0.001
  tasks:
    motion: {period: 0.001}
axes:
  x:
    limits: {v_max: 1.0, a_max: 4.0, j_max: 40.0, v_min: -0.5, a_min: -1.5}
"""

SEQUENCE = """\
timeout: 30
steps:
  - name: power on
    call:
      - {block: pwr, type: MC_Power, axis: x, enable: true}
    until: {done: pwr, state: {x: STANDSTILL}}
  - name: out
    call:
      - {block: m, type: MC_MoveAbsolute, axis: x, position: 3.0, velocity: 1.0}
    until: {done: m}
    expect: {x.position: 3.0, within: 1.0e-9}
  - name: back
    call:
      - {block: m, position: 0.0, velocity: 1.0}
    until: {done: m}
    expect: {x.position: 0.0, x.state: STANDSTILL, within: 1.0e-9}
"""


def test_config_with_asymmetric_limits_builds_and_runs(tmp_path: Path) -> None:
    (tmp_path / "m.yaml").write_text(CONFIG)
    (tmp_path / "s.yaml").write_text(SEQUENCE)
    cfg = load_config(tmp_path / "m.yaml")
    with build(cfg) as machine:
        ax = machine.axes["x"]
        assert (ax.cfg.v_max, ax.cfg.v_min, ax.cfg.a_max, ax.cfg.a_min) == (1.0, -0.5, 4.0, -1.5)
        runner, task = runner_for(tmp_path / "s.yaml", machine)
        machine.attach(runner, task)
        machine.runtime.run_until(lambda: runner.over, max_seconds=60.0)
        assert runner.failures == [] and runner.finished
        assert ax.state is not AxisState.ERROR_STOP, ax.axis_error_reason
        tr = machine.runtime.trace
        v = tr.column("x.velocity")
        a = tr.column("x.acceleration")
        assert v.max() == pytest.approx(1.0, rel=1e-9)
        assert v.min() == pytest.approx(-0.5, rel=1e-9)
        assert a.max() <= 4.0 * (1 + TOL) and a.min() >= -1.5 * (1 + TOL)
        assert a.min() == pytest.approx(-1.5, rel=1e-9)
