"""MC_Jog (issue 16): press / release timing, inching steps exact, both buttons, software limits,
state machine. Every Bench checks the conformance invariants each cycle (limits, continuity, FB
output rules with ``execute`` = jog_forward OR jog_backward, state changes along the diagram)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from motionplc.blocks import AxisState, ErrorID, MC_Home, MC_MoveAbsolute, MC_MoveVelocity, MC_Stop
from motionplc.blocks.axis_config import AxisConfig
from motionplc.blocks.enums import JogMode
from motionplc.blocks.jog import MC_Jog, jog_velocity
from motionplc.blocks.motion import StaticAxis
from motionplc.config import build, load_config
from motionplc.errors import ConfigError
from tests.runtime.helpers import Bench

S = AxisState
LIM = {"v_max": 2.0, "a_max": 4.0, "j_max": 40.0}


def _bench(**kw: float) -> Bench:
    return Bench(**{**LIM, **kw}).powered()


def _rises(b: Bench, fb: MC_Jog, out: str) -> list[int]:
    return [c for c, v in b.edges(fb, out) if v]


@pytest.mark.parametrize(
    ("mode", "velocity", "expect"),
    [
        (JogMode.STANDARD_SLOW, 0.0, 0.2),
        (JogMode.STANDARD_FAST, 0.0, 1.0),
        (JogMode.CONTINUOUS, 0.7, 0.7),
    ],
)
@pytest.mark.parametrize("backward", [False, True])
def test_continuous_press_and_release(
    mode: JogMode, velocity: float, expect: float, backward: bool
) -> None:
    b = _bench()
    jog = b.add(MC_Jog(mode=mode, velocity=velocity))
    s = -1.0 if backward else 1.0
    k = b.cycle
    if backward:
        jog.jog_backward = True
    else:
        jog.jog_forward = True
    b.run(1)
    assert jog.busy and b.x.state is S.CONTINUOUS_MOTION
    b.run(1500)
    assert jog.active and b.x.v == pytest.approx(s * expect, abs=1e-12)
    r = b.cycle
    jog.jog_forward = jog.jog_backward = False
    b.run(1)
    assert jog.busy and b.x.state is S.DISCRETE_MOTION  # braking (MC_Halt)
    b.run(1000)
    assert b.x.state is S.STANDSTILL and b.x.v == 0.0
    v = b.col("x.velocity")
    rest = next(i for i in range(r, len(v)) if v[i] == 0.0)
    assert _rises(b, jog, "busy") == [k]
    assert _rises(b, jog, "done") == [rest + 1]  # seen at the next scan, for one scan
    assert [c for c, x in b.edges(jog, "done") if not x] == [rest + 2]
    # the axis moved only in the jog direction and braked jerk-limited (invariants each cycle)
    assert np.all(s * v[k:] >= -1e-12)


def test_standard_velocities_from_the_configuration() -> None:
    cfg = _bench(v_min=-1.0).x.cfg
    assert jog_velocity(cfg, JogMode.STANDARD_SLOW, 1.0) == pytest.approx(0.2)
    assert jog_velocity(cfg, JogMode.STANDARD_FAST, -1.0) == pytest.approx(0.5)


def test_inching_steps_are_exact() -> None:
    b = _bench()
    jog = b.add(MC_Jog(mode=JogMode.INCHING, position=0.1, velocity=0.5))
    expect = 0.0
    for n in range(3):
        jog.jog_forward = True
        b.run(1)
        assert jog.busy
        b.run(600)
        assert jog.done  # held while the button is held
        jog.jog_forward = False
        b.run(1)
        assert not jog.done
        expect += 0.1
        assert b.x.p == expect, n
        assert b.x.state is S.STANDSTILL
    # presses faster than the steps: queued, still exact
    for _ in range(4):
        jog.jog_backward = True
        b.run(30)
        jog.jog_backward = False
        b.run(30)
    b.run(3000)
    for _ in range(4):
        expect -= 0.1
    assert b.x.p == expect and b.x.state is S.STANDSTILL


@pytest.mark.parametrize(
    ("start", "forward", "steps"),
    [(0.13, True, [0.2, 0.30000000000000004]), (0.2, False, [0.1, 0.0]), (0.3, True, [0.4])],
)
def test_inching_modulo_goes_to_the_next_multiple(
    start: float, forward: bool, steps: list[float]
) -> None:
    b = _bench()
    if start:
        mv = b.add(MC_MoveAbsolute(position=start, velocity=1.0))
        b.pulse(mv)
        b.run(1000)
    jog = b.add(MC_Jog(mode=JogMode.INCHING_MODULO, position=0.1, velocity=0.5))
    for want in steps:
        if forward:
            jog.jog_forward = True
        else:
            jog.jog_backward = True
        b.run(800)
        assert jog.done
        jog.jog_forward = jog.jog_backward = False
        b.run(1)
        assert b.x.p == want


def test_inching_modulo_on_a_modulo_axis_wraps() -> None:
    b = _bench(modulo=1.0)
    jog = b.add(MC_Jog(mode=JogMode.INCHING_MODULO, position=0.25, velocity=1.0))
    for want in (0.75, 0.5):  # backward from 0: through the wrap
        jog.jog_backward = True
        b.run(800)
        assert jog.done, jog.error_text
        jog.jog_backward = False
        b.run(1)
        assert b.x.position == pytest.approx(want, abs=1e-12)


@settings(max_examples=15, deadline=None)
@given(
    presses=st.lists(
        st.tuples(st.booleans(), st.integers(1, 300), st.integers(1, 300)), min_size=1, max_size=5
    ),
    step=st.sampled_from([0.05, 0.1, 0.3]),
)
def test_inching_property_exact_sum(presses: list[tuple[bool, int, int]], step: float) -> None:
    """Any press timing: the axis ends at the float sum of the steps, at rest."""
    b = _bench()
    jog = b.add(MC_Jog(mode=JogMode.INCHING, position=step, velocity=1.0))
    expect = 0.0
    for fwd, hold, gap in presses:
        if fwd:
            jog.jog_forward = True
        else:
            jog.jog_backward = True
        b.run(hold)
        jog.jog_forward = jog.jog_backward = False
        b.run(gap)
        expect += step if fwd else -step
    b.rt.run_until(lambda: not jog.busy, max_seconds=10.0)
    b.run(2)
    assert b.x.p == pytest.approx(expect, abs=1e-12) and b.x.state is S.STANDSTILL


def test_both_buttons_is_an_error_and_brakes() -> None:
    b = _bench()
    jog = b.add(MC_Jog(mode=JogMode.STANDARD_FAST))
    jog.jog_forward = True
    b.run(500)
    jog.jog_backward = True
    b.run(1)
    assert jog.error and jog.error_id is ErrorID.INVALID_JOG_MODE
    assert "both" in jog.error_text
    b.run(1000)
    assert b.x.state is S.STANDSTILL and jog.error  # held while a button is held
    jog.jog_forward = False
    b.run(5)
    assert jog.error and b.x.state is S.STANDSTILL  # no new jog without a new press
    jog.jog_backward = False
    b.run(1)
    assert not jog.error
    # pressed together from rest
    jog.jog_forward = jog.jog_backward = True
    b.run(1)
    assert jog.error and b.x.state is S.STANDSTILL


def test_software_limit_stops_exactly_at_it() -> None:
    b = _bench(sw_limit_pos=0.6, sw_limit_neg=-0.4)
    jog = b.add(MC_Jog(mode=JogMode.STANDARD_FAST))
    jog.jog_forward = True
    b.run(3000)
    assert jog.done and b.x.p == 0.6 and b.x.state is S.STANDSTILL
    assert b.x.axis_error is ErrorID.OK
    jog.jog_forward = False
    b.run(2)
    jog.jog_forward = True  # at the limit: further out is refused
    b.run(1)
    assert jog.error and jog.error_id is ErrorID.MOVE_BEYOND_SW_LIMIT
    jog.jog_forward = False
    b.run(2)
    jog.jog_backward = True  # back is free; released before the other limit
    b.run(400)
    jog.jog_backward = False
    b.run(1000)
    assert jog.done is False and b.x.state is S.STANDSTILL and -0.4 < b.x.p < 0.6


def test_another_command_aborts_the_jog() -> None:
    b = _bench()
    jog = b.add(MC_Jog(mode=JogMode.STANDARD_SLOW))
    mv = b.add(MC_MoveVelocity(velocity=0.5))
    jog.jog_forward = True
    b.run(200)
    mv.execute = True
    b.run(2)
    assert jog.command_aborted and mv.busy and b.x.state is S.CONTINUOUS_MOTION
    jog.jog_forward = False  # the release does not halt the other FB's motion
    b.run(300)
    assert mv.in_velocity and b.x.v == pytest.approx(0.5)


def _enter(b: Bench, state: AxisState) -> None:
    if state is S.DISABLED:
        b.power.enable = False
        b.run(2)
    elif state is S.HOMING:
        b.pulse(b.add(MC_Home(position=0.0)))
    elif state is S.DISCRETE_MOTION:
        b.pulse(b.add(MC_MoveAbsolute(position=100.0, velocity=0.5)))
    elif state is S.CONTINUOUS_MOTION:
        b.pulse(b.add(MC_MoveVelocity(velocity=0.5)))
    elif state is S.STOPPING:
        st_ = b.add(MC_Stop(deceleration=1.0))
        st_.execute = True
    elif state is S.ERROR_STOP:
        b.x.drive.inject_fault()
    b.run(300)
    assert b.x.state is state


@pytest.mark.parametrize(
    "state",
    [
        S.DISABLED,
        S.STANDSTILL,
        S.HOMING,
        S.DISCRETE_MOTION,
        S.CONTINUOUS_MOTION,
        S.STOPPING,
        S.ERROR_STOP,
    ],
    ids=lambda s: s.name,
)
@pytest.mark.parametrize("mode", [JogMode.STANDARD_SLOW, JogMode.INCHING])
def test_jog_in_every_state(state: AxisState, mode: JogMode) -> None:
    b = Bench(home_switch=1e6, home_velocity=0.2, **LIM).powered()
    _enter(b, state)
    jog = b.add(MC_Jog(mode=mode, position=0.05, velocity=0.3))
    jog.jog_forward = True
    b.run(1)
    if state in (S.STANDSTILL, S.DISCRETE_MOTION, S.CONTINUOUS_MOTION):
        assert jog.busy and not jog.error
        want = S.CONTINUOUS_MOTION if mode is JogMode.STANDARD_SLOW else S.DISCRETE_MOTION
        assert b.x.state is want
    else:
        assert jog.error and jog.error_id is ErrorID.for_state(state)
        assert b.x.state is state


def test_input_checks() -> None:
    ax = StaticAxis(Bench(**LIM).x.cfg)
    assert MC_Jog().input_problems(ax) == {}
    probs = MC_Jog(mode="fast", jerk=-1.0).input_problems(ax)
    assert set(probs) == {"mode", "jerk"}
    assert probs["mode"].error_id is ErrorID.INVALID_JOG_MODE
    inch = MC_Jog(mode=JogMode.INCHING, position=0.0, velocity=math.nan)
    probs = inch.input_problems(ax)
    assert set(probs) == {"position", "velocity"}
    assert probs["position"].error_id is ErrorID.INVALID_DISTANCE
    assert "position" in str(probs["position"])
    # a bad input at the press: Error, the axis unaffected
    b = _bench()
    jog = b.add(MC_Jog(mode=JogMode.CONTINUOUS, velocity=5.0))
    jog.jog_forward = True
    b.run(1)
    assert jog.error and jog.error_id is ErrorID.INVALID_VELOCITY and b.x.state is S.STANDSTILL


CFG = """\
runtime:
  tick: 0.001
  tasks:
    main: {period: 0.001}
axes:
  x:
    limits: {v_max: 2.0, a_max: 4.0, v_min: -1.5}
"""


def test_jog_velocities_from_yaml(tmp_path: Path) -> None:
    f = tmp_path / "m.yaml"
    f.write_text(CFG + "    jog_velocity_slow: 0.05\n    jog_velocity_fast: 1.5\n")
    with build(load_config(f)) as machine:
        cfg = machine.axes["x"].cfg
        assert (cfg.jog_velocity_slow, cfg.jog_velocity_fast) == (0.05, 1.5)
        assert jog_velocity(cfg, JogMode.STANDARD_SLOW, -1.0) == 0.05
        assert jog_velocity(cfg, JogMode.STANDARD_FAST, 1.0) == 1.5
    f.write_text(CFG)  # defaults: 10 % / 50 % of each direction's limit
    with build(load_config(f)) as machine:
        cfg = machine.axes["x"].cfg
        assert cfg.jog_velocity_slow is None
        assert jog_velocity(cfg, JogMode.STANDARD_FAST, -1.0) == 0.75


@pytest.mark.parametrize(
    ("extra", "where", "allowed"),
    [
        ("    jog_velocity_fast: 1.6\n", "axes.x.jog_velocity_fast", "<= 1.5"),
        ("    jog_velocity_slow: 0\n", "axes.x.jog_velocity_slow", "> 0"),
        ("    jog_velocity_slow: fast\n", "axes.x.jog_velocity_slow", "number"),
    ],
)
def test_bad_jog_velocities_are_located_errors(
    tmp_path: Path, extra: str, where: str, allowed: str
) -> None:
    f = tmp_path / "m.yaml"
    f.write_text(CFG + extra)
    with pytest.raises(ConfigError) as exc:
        load_config(f)
    text = str(exc.value)
    assert f"m.yaml:8: {where}" in text and allowed in text, text


def test_a_jog_velocity_above_the_limit_is_refused_at_the_press() -> None:
    """AxisConfig takes any positive jog velocity (MC_WriteParameter may lower the limits after
    the YAML check); MC_Jog refuses one above the speed limit of the jog direction."""
    with pytest.raises(ValueError, match="jog_velocity_slow must be in"):
        AxisConfig("x", v_max=2.0, a_max=1.0, jog_velocity_slow=0.0)
    b = _bench(v_min=-1.0, jog_velocity_fast=1.5)
    jog = b.add(MC_Jog(mode=JogMode.STANDARD_FAST))
    jog.jog_forward = True
    b.run(1000)
    assert jog.busy and b.x.v == pytest.approx(1.5)
    jog.jog_forward = False
    b.run(1000)
    jog.jog_backward = True
    b.run(1)
    assert jog.error and jog.error_id is ErrorID.INVALID_VELOCITY
    assert "jog_velocity_fast 1.5" in jog.error_text and b.x.state is S.STANDSTILL


def test_switching_direction_without_a_gap() -> None:
    b = _bench(sw_limit_pos=5.0, sw_limit_neg=-0.3)
    jog = b.add(MC_Jog(mode=JogMode.STANDARD_FAST))
    jog.jog_forward = True
    b.run(500)
    jog.jog_forward, jog.jog_backward = False, True  # same scan: reverses while busy
    b.run(1)
    assert jog.busy and not jog.error
    b.run(3000)
    assert jog.done and b.x.p == -0.3  # stopped at the negative software limit
    jog.jog_forward, jog.jog_backward = True, False  # not busy: needs a release first
    b.run(5)
    assert not jog.busy and b.x.state is S.STANDSTILL
    jog.jog_forward = False
    b.run(1)
    jog.jog_forward = True
    b.run(1)
    assert jog.busy and b.x.state is S.DISCRETE_MOTION  # a move to the positive limit
