"""Degenerate FB inputs and the cyclic fault barrier (issue 11, finding 5).

* every numeric input of every motion/admin FB outside its documented range (tiny, huge, inf,
  NaN, negative, not a number) gives Error with the input's ErrorID at once, not Busy, the
  range in ``error_text``, and the axis keeps its motion;
* inputs at the lower ends of the ranges are accepted and plan within the 1e4 s envelope;
* an exception inside the planner or an FB body never escapes a cycle: the FB ends with
  PLANNING_FAILED / INTERNAL_ERROR, or the axis goes to ErrorStop with a controlled stop;
* a stateful property test throws random (also degenerate) inputs at the blocks: nothing
  escapes, the invariants hold every cycle, and once the axis is stopped no FB stays Busy.
"""

from __future__ import annotations

import math

import pytest
from hypothesis import HealthCheck, settings
from hypothesis import strategies as st
from hypothesis.stateful import RuleBasedStateMachine, initialize, invariant, rule

import motionplc.blocks.axis as axis_mod
from motionplc.blocks import (
    AxisState,
    BufferMode,
    Direction,
    ErrorID,
    MC_Halt,
    MC_Home,
    MC_MoveAbsolute,
    MC_MoveAdditive,
    MC_MoveRelative,
    MC_MoveVelocity,
    MC_ReadStatus,
    MC_Reset,
    MC_SetOverride,
    MC_SetPosition,
    MC_Stop,
)
from motionplc.blocks.axis import SUPPORTED_DURATION, AxisConfig
from tests.runtime.helpers import Bench

INF, NAN = math.inf, math.nan
DEGENERATE = [1e-300, 1e-100, -1e-300, -1.0, 1e300, INF, -INF, NAN, "1", None]
E = ErrorID

# (FB class, valid base inputs, input under test, its ErrorID, values that must be refused
# besides DEGENERATE where they apply)
_MOVE = {"position": 1.0, "velocity": 10.0}
CASES = [
    (MC_MoveAbsolute, _MOVE, "position", E.INVALID_POSITION, [1e13, -1e13, INF, NAN, "x"]),
    (MC_MoveAbsolute, _MOVE, "velocity", E.INVALID_VELOCITY, DEGENERATE + [0.0, 300.0]),
    (MC_MoveAbsolute, _MOVE, "acceleration", E.INVALID_ACCELERATION, DEGENERATE),
    (MC_MoveAbsolute, _MOVE, "deceleration", E.INVALID_DECELERATION, DEGENERATE),
    (MC_MoveAbsolute, _MOVE, "jerk", E.INVALID_JERK, DEGENERATE),
    (MC_MoveRelative, {"distance": 1.0, "velocity": 10.0}, "distance", E.INVALID_DISTANCE,
     [1e13, 1e300, INF, NAN, None]),
    (MC_MoveRelative, {"distance": 1.0, "velocity": 10.0}, "velocity", E.INVALID_VELOCITY,
     DEGENERATE),
    (MC_MoveAdditive, {"distance": 1.0, "velocity": 10.0}, "deceleration",
     E.INVALID_DECELERATION, DEGENERATE),
    (MC_MoveVelocity, {"velocity": 5.0}, "velocity", E.INVALID_VELOCITY,
     [1e300, -1e300, INF, NAN, "1", None, 201.0]),
    (MC_MoveVelocity, {"velocity": 5.0}, "acceleration", E.INVALID_ACCELERATION, DEGENERATE),
    (MC_MoveVelocity, {"velocity": 5.0}, "deceleration", E.INVALID_DECELERATION, DEGENERATE),
    (MC_MoveVelocity, {"velocity": 5.0}, "jerk", E.INVALID_JERK, DEGENERATE),
    (MC_Halt, {}, "deceleration", E.INVALID_DECELERATION, DEGENERATE),
    (MC_Halt, {}, "jerk", E.INVALID_JERK, DEGENERATE),
    (MC_Stop, {}, "deceleration", E.INVALID_DECELERATION, DEGENERATE),
    (MC_Stop, {}, "jerk", E.INVALID_JERK, DEGENERATE),
    (MC_Home, {}, "position", E.INVALID_POSITION, [1e13, INF, NAN, "x"]),
    (MC_SetPosition, {}, "position", E.INVALID_POSITION, [1e13, -1e300, INF, NAN, None]),
]  # fmt: skip
PARAMS = [
    pytest.param(cls, base, name, eid, value, id=f"{cls.__name__}.{name}={value!r}")
    for cls, base, name, eid, values in CASES
    for value in values
]


def _bench() -> Bench:
    """v_max 200, a_max 400, j_max 4000: a = 0 is the axis' limit, 1e-300 is not."""
    return Bench(j_max=4000.0).powered()


@pytest.mark.parametrize(("cls", "base", "name", "eid", "value"), PARAMS)
def test_bad_input_is_refused_at_once_and_keeps_the_motion(cls, base, name, eid, value) -> None:
    b = _bench()
    mv = b.add(MC_MoveVelocity(velocity=20.0))
    bad = b.add(cls(**{**base, name: value}))
    b.pulse(mv)
    b.run(300)
    assert mv.in_velocity
    v_before = b.x.v
    bad.execute = True
    b.run(1)
    assert bad.error and bad.error_id is eid and not bad.busy, (bad.error_id, bad.error_text)
    assert name in bad.error_text
    b.run(2)
    assert mv.in_velocity and b.x.v == v_before and b.x.state is AxisState.CONTINUOUS_MOTION


@pytest.mark.parametrize("factor", ["vel_factor", "acc_factor", "jerk_factor"])
@pytest.mark.parametrize("value", [1e-300, 1e-4, -0.1, 1.5, 1e300, INF, NAN, None])
def test_override_factor_outside_its_range(factor: str, value: object) -> None:
    b = _bench()
    ov = b.add(MC_SetOverride(enable=True, **{factor: value}))
    ma = b.add(MC_MoveAbsolute(position=1.0, velocity=10.0))
    b.run(2)
    assert ov.error and ov.error_id is E.INVALID_OVERRIDE and not ov.enabled
    assert factor in ov.error_text and "[0.001, 1]" in ov.error_text
    assert b.x.override == (1.0, 1.0, 1.0)  # unchanged
    b.pulse(ma)
    b.run_until_idle()
    assert b.x.p == 1.0


def test_lowest_accepted_inputs_plan_within_the_envelope() -> None:
    """Inputs at the lower ends of their ranges are accepted and the profiles they give last at
    most about the supported 1e4 s (velocity change over the whole range, jerk-only too)."""
    b = _bench()
    cfg: AxisConfig = b.x.cfg
    a_lo = cfg.acceleration_range()[0]
    j_lo = cfg.jerk_range()[0]
    mv = b.add(MC_MoveVelocity(velocity=cfg.v_max, acceleration=a_lo, deceleration=a_lo))
    b.pulse(mv)
    b.run(1)
    assert mv.busy and not mv.error
    assert b.x.active is not None and b.x.active.duration <= SUPPORTED_DURATION
    jm = b.add(MC_MoveVelocity(velocity=-cfg.v_max, jerk=j_lo))
    b.pulse(jm)
    b.run(1)
    assert jm.busy and not jm.error
    assert b.x.active is not None and b.x.active.duration <= 2.0 * SUPPORTED_DURATION
    st_ = b.add(MC_Stop(deceleration=a_lo, jerk=j_lo))
    b.pulse(st_)
    b.run(1)
    assert st_.busy and b.x.active is not None
    assert b.x.active.duration <= 2.0 * SUPPORTED_DURATION
    ov = b.add(MC_SetOverride(enable=True, vel_factor=1e-3, acc_factor=1e-3, jerk_factor=1e-3))
    b.run(2)
    assert ov.enabled and not ov.error


def test_a_move_too_slow_for_its_distance_is_an_input_error() -> None:
    b = _bench()
    v_lo = b.x.cfg.velocity_range()[0]
    ok = b.add(MC_MoveAbsolute(position=v_lo * SUPPORTED_DURATION * 0.5, velocity=v_lo))
    slow = b.add(MC_MoveRelative(distance=10.0, velocity=v_lo))
    b.pulse(slow)
    assert slow.error and slow.error_id is E.INVALID_VELOCITY
    assert "supported 10000 s" in slow.error_text and b.x.state is AxisState.STANDSTILL
    b.pulse(ok)
    assert ok.busy and not ok.error


def test_planner_exception_becomes_an_fb_error(monkeypatch: pytest.MonkeyPatch) -> None:
    """A planner that raises something other than its PlanningError (here ZeroDivisionError, a
    defect) at a command's start: the FB ends with INTERNAL_ERROR naming it -- not disguised as
    PLANNING_FAILED -- (not Busy), the axis keeps its motion, the cycle goes on."""
    b = _bench()
    mv = b.add(MC_MoveVelocity(velocity=20.0))
    ma = b.add(MC_MoveAbsolute(position=5.0, velocity=10.0))
    b.pulse(mv)
    b.run(300)

    def boom(*args: object, **kw: object) -> None:
        raise ZeroDivisionError("float division by zero")

    monkeypatch.setattr(axis_mod, "plan", boom)
    tick = b.rt.tick
    ma.execute = True
    b.run(3)
    assert ma.error and ma.error_id is E.INTERNAL_ERROR and not ma.busy
    assert "ZeroDivisionError: float division by zero" in ma.error_text
    assert mv.in_velocity and b.x.state is AxisState.CONTINUOUS_MOTION
    assert b.rt.tick == tick + 3 and len(b.col("x.position")) == b.rt.tick


def test_planner_exception_in_a_standstill_start_leaves_standstill(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    b = _bench()
    ma = b.add(MC_MoveAbsolute(position=5.0, velocity=10.0))
    monkeypatch.setattr(axis_mod, "plan", lambda *a: 1 / 0)
    b.pulse(ma)
    b.run(2)
    assert b.x.state is AxisState.STANDSTILL and not ma.busy


def test_kernel_exception_gives_error_stop_with_a_controlled_stop(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """Something raising inside the kernel while moving: ErrorStop INTERNAL_ERROR, the FB
    Error, a jerk-limited stop with the axis' limits (the invariants check it every cycle);
    MC_Reset brings the axis back."""
    b = _bench()
    mv = b.add(MC_MoveVelocity(velocity=20.0))
    rs = b.add(MC_Reset())
    mv.execute = True
    b.run(300)
    calls = {"n": 0}
    real = axis_mod.Axis._advance

    def flaky(self, job, dt, ftau):  # type: ignore[no-untyped-def]
        if job.kind == "velocity" and calls["n"] == 0:
            calls["n"] += 1
            raise RuntimeError("injected")
        return real(self, job, dt, ftau)

    monkeypatch.setattr(axis_mod.Axis, "_advance", flaky)
    b.run(2)
    x = b.x
    assert x.state is AxisState.ERROR_STOP and x.axis_error is E.INTERNAL_ERROR
    assert "RuntimeError: injected" in x.axis_error_reason
    assert mv.error and mv.error_id is E.AXIS_ERROR_STOP
    b.run(1000)
    assert x.v == 0.0 and x.active is None
    mv.execute = False
    b.pulse(rs)
    b.run(3)
    assert x.state is AxisState.STANDSTILL


class _BrokenMove(MC_MoveAbsolute):
    def _command(self, axis):  # type: ignore[no-untyped-def]
        raise KeyError("broken")


class _BrokenStatus(MC_ReadStatus):
    def _update(self, axis):  # type: ignore[no-untyped-def]
        raise RuntimeError("broken")


def test_exception_in_an_fb_body_is_an_fb_error() -> None:
    b = _bench()
    bad = b.add(_BrokenMove(position=1.0, velocity=1.0))
    rd = b.add(_BrokenStatus(enable=True))
    bad.execute = True
    b.run(3)
    assert bad.error and bad.error_id is E.INTERNAL_ERROR and not bad.busy
    assert "KeyError" in bad.error_text
    assert rd.error and rd.error_id is E.INTERNAL_ERROR and not rd.valid
    bad.execute = False
    b.run(1)
    assert not bad.error  # reset on the falling edge like any Error
    assert b.x.state is AxisState.STANDSTILL


# -- stateful: random and degenerate inputs ------------------------------------------------
_VALUES = st.one_of(
    st.floats(-1.0, 1.0),
    st.sampled_from([0.0, 1e-300, 1e-100, 1e-12, -1e-300, 1e300, INF, -INF, NAN]),
)


class DegenerateMachine(RuleBasedStateMachine):
    """Random FB calls with random (often degenerate) inputs; every cycle runs the runtime's
    invariants; nothing may escape a cycle; after a stop every FB leaves Busy."""

    bench: Bench

    @initialize(
        v_max=st.sampled_from([1.0, 50.0]),
        a_max=st.sampled_from([50.0, 500.0]),
        j_max=st.sampled_from([INF, 1e4]),
        sw=st.booleans(),
    )
    def setup(self, v_max: float, a_max: float, j_max: float, sw: bool) -> None:
        limits = {"sw_limit_pos": 5.0 * v_max, "sw_limit_neg": -5.0 * v_max} if sw else {}
        b = Bench(v_max=v_max, a_max=a_max, j_max=j_max, queue_depth=2, **limits)
        self.bench = b
        self.scale = {"position": 3.0 * v_max, "velocity": v_max, "a": a_max, "j": j_max}
        self.fbs = {
            "abs": b.add(MC_MoveAbsolute()),
            "rel": b.add(MC_MoveRelative()),
            "add": b.add(MC_MoveAdditive()),
            "vel": b.add(MC_MoveVelocity()),
            "halt": b.add(MC_Halt()),
            "stop": b.add(MC_Stop()),
            "home": b.add(MC_Home()),
            "setpos": b.add(MC_SetPosition()),
        }
        self.override = b.add(MC_SetOverride())
        self.reset = b.add(MC_Reset())
        b.run(2)

    def _value(self, x: float, what: str) -> float:
        s = self.scale[what]
        return x * s if math.isfinite(x) and abs(x) <= 1.0 and math.isfinite(s) else x

    @rule(
        which=st.sampled_from(["abs", "rel", "add", "vel", "halt", "stop", "home", "setpos"]),
        pos=_VALUES, vel=_VALUES, acc=_VALUES, dec=_VALUES, jerk=_VALUES,
        mode=st.sampled_from(list(BufferMode)), hold=st.booleans(),
    )  # fmt: skip
    def issue(self, which, pos, vel, acc, dec, jerk, mode, hold) -> None:
        fb = self.fbs[which]
        for name, x, what in (
            ("position", pos, "position"),
            ("distance", pos, "position"),
            ("velocity", vel, "velocity"),
            ("acceleration", abs(acc) if math.isfinite(acc) else acc, "a"),
            ("deceleration", abs(dec) if math.isfinite(dec) else dec, "a"),
            ("jerk", abs(jerk) if math.isfinite(jerk) else jerk, "j"),
        ):
            if name in fb.INPUTS:
                setattr(fb, name, self._value(x, what))
        if "buffer_mode" in fb.INPUTS:
            fb.buffer_mode = mode
        if "direction" in fb.INPUTS and which == "vel":
            fb.direction = Direction.POSITIVE
        fb.execute = False
        self.bench.run(1)
        fb.execute = True
        self.bench.run(1)
        if fb.error:
            assert not fb.busy and fb.error_id is not ErrorID.OK
        if not hold:
            fb.execute = False

    @rule(vel=_VALUES, acc=_VALUES, enable=st.booleans())
    def set_override(self, vel: float, acc: float, enable: bool) -> None:
        self.override.vel_factor = abs(vel) if math.isfinite(vel) else vel
        self.override.acc_factor = abs(acc) if math.isfinite(acc) else acc
        self.override.enable = enable

    @rule(n=st.integers(1, 30))
    def run(self, n: int) -> None:
        self.bench.run(n)

    @invariant()
    def finite_and_traced(self) -> None:
        b = self.bench
        x = b.x
        assert math.isfinite(x.p) and math.isfinite(x.v) and math.isfinite(x.a)
        assert len(b.col("x.position")) == b.rt.tick  # every cycle ran and was traced
        # no FB can stay Busy forever: whatever runs was planned within the envelope (the
        # override's AccFactor/JerkFactor, >= 1e-3, stretch it by at most their inverse)
        _, af, jf = x.override
        if x.active is not None:
            assert x.active.duration <= 2.0 * SUPPORTED_DURATION / (af * jf)

    def teardown(self) -> None:
        """Stop everything with the axis' limits: no FB may stay Busy afterwards."""
        b = getattr(self, "bench", None)
        if b is None:
            return
        self.override.enable = True
        self.override.vel_factor = self.override.acc_factor = self.override.jerk_factor = 1.0
        for fb in self.fbs.values():
            fb.execute = False
        stop = self.fbs["stop"]
        stop.deceleration = stop.jerk = 0.0
        b.run(1)
        self.reset.execute = True
        stop.execute = True
        assert b.rt.run_until(lambda: b.x.active is None and b.x.v == 0.0, max_seconds=60.0)
        b.run(3)
        stop.execute = self.reset.execute = False
        b.run(3)
        for name, fb in self.fbs.items():
            assert not fb.busy, f"{name} still busy ({b.x!r})"
        assert b.x.state in (AxisState.STANDSTILL, AxisState.DISABLED, AxisState.ERROR_STOP)


DegenerateMachine.TestCase.settings = settings(
    max_examples=60,
    stateful_step_count=40,
    deadline=None,
    derandomize=True,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large],
)
TestDegenerateMachine = DegenerateMachine.TestCase


# -- configuration: the YAML accepts the same axis ranges ----------------------------------
@pytest.mark.parametrize(
    ("limits", "expected"),
    [
        ("{v_max: 1.0e-300, a_max: 2.0}", "v_max: got 1e-300 (allowed: a number in [1e-06"),
        ("{v_max: 1.0, a_max: 1.0e300}", "a_max: got 1e+300 (allowed: a number in [1e-06"),
        ("{v_max: 1.0, a_max: 2.0, j_max: 1.0e-9}", "j_max: got 1e-09 (allowed: a number in"),
        ("{v_max: 1.0, a_max: 2.0, a_min: -1.0e-300}", "a_min: got -1e-300 (allowed: a number in"),
    ],
)  # fmt: skip
def test_config_limits_outside_the_axis_range(tmp_path, limits: str, expected: str) -> None:
    from motionplc.config import load_config
    from motionplc.errors import ConfigError

    f = tmp_path / "c.yaml"
    f.write_text(
        f"runtime:\n  tasks:\n    motion: {{period: 0.001}}\naxes:\n  x:\n    limits: {limits}\n"
    )
    with pytest.raises(ConfigError) as exc:
        load_config(f)
    assert any(expected in line for line in exc.value.errors), exc.value.errors
    with pytest.raises(ValueError, match="must be in"):  # the axis itself checks the same
        AxisConfig("x", v_max=1e-300, a_max=2.0)
