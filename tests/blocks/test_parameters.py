"""MC_ReadParameter / MC_WriteParameter / MC_Read/WriteBoolParameter with the PLCopen numbers
1-17 (Table 5): every number read, every writable one written and its effect on the axis
observed (software limits stop a following move, the *Appl limits bound the next move, the
following-error monitoring trips), read-only numbers refused, ranges named in the errors."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from motionplc.blocks import (
    AxisState,
    ErrorID,
    ExecutionMode,
    MC_MoveAbsolute,
    MC_MoveVelocity,
    MC_Power,
    MC_ReadBoolParameter,
    MC_ReadParameter,
    MC_WriteBoolParameter,
    MC_WriteParameter,
)
from motionplc.blocks.axis_config import AxisConfig
from motionplc.blocks.axis_params import (
    PARAMETERS,
    ConfigTracker,
    coe_parameter_number,
    decode_drive_number,
    modbus_parameter_number,
)
from motionplc.blocks.base import InputError
from motionplc.blocks.motion import StaticAxis
from motionplc.fieldbus.base import DriveCommand, DriveFeedback
from motionplc.fieldbus.ideal import IdealDrive
from motionplc.runtime import Runtime
from tests.runtime.helpers import Bench

AXIS = {"v_max": 2.0, "a_max": 4.0, "j_max": 40.0, "sw_limit_pos": 1.0, "sw_limit_neg": -1.0}
READ_ONLY = [n for n, p in PARAMETERS.items() if not p.writable]
BOOLS = [n for n, p in PARAMETERS.items() if p.kind == "bool"]


def _bench(**kw: Any) -> Bench:
    return Bench(**{**AXIS, **kw}).powered()


def _write(b: Bench, number: int, value: Any, fb: Any = None) -> Any:
    """One Execute pulse of a write FB (a fresh FB unless given), its outputs after it."""
    if fb is None:
        kind = MC_WriteBoolParameter if PARAMETERS.get(number, None) and number in BOOLS else None
        fb = b.add((kind or MC_WriteParameter)(parameter_number=number, value=value))
    fb.parameter_number = number
    fb.value = value
    b.pulse(fb)
    return fb


def _read(b: Bench, number: int) -> Any:
    fb = b.add((MC_ReadBoolParameter if number in BOOLS else MC_ReadParameter)(enable=True))
    fb.parameter_number = number
    b.run(1)
    assert fb.valid and not fb.error, fb.error_text
    return fb.value


def test_the_table_is_plcopen_table_5() -> None:
    assert sorted(PARAMETERS) == list(range(1, 18))
    assert READ_ONLY == [1, 8, 10, 11, 12, 14, 16]
    assert BOOLS == [4, 5, 6]


def test_every_number_reads_the_axis() -> None:
    b = _bench(following_error_limit=0.3)
    ma = b.add(MC_MoveAbsolute(position=0.6, velocity=1.0))
    b.pulse(ma)
    b.run(300)  # moving: set and actual values differ from 0
    x = b.x
    values = {n: _read(b, n) for n in PARAMETERS}
    # the reads ran in one more cycle each: compare the motion values with the trace
    assert values[1] == pytest.approx(x.p, abs=0.05) and values[1] != 0.0
    assert values[2] == 1.0 and values[3] == -1.0
    assert values[4] is True and values[5] is True and values[6] is True
    assert values[7] == 0.3
    assert values[8] == values[9] == 2.0
    assert values[10] != 0.0 and values[11] != 0.0
    assert values[12] == values[13] == 4.0 and values[14] == values[15] == 4.0
    assert values[16] == values[17] == 40.0


def test_read_values_follow_the_image_each_cycle() -> None:
    b = _bench()
    mv = b.add(MC_MoveVelocity(velocity=0.5))
    pos = b.add(MC_ReadParameter(enable=True, parameter_number=1))
    vel = b.add(MC_ReadParameter(enable=True, parameter_number=11))
    act = b.add(MC_ReadParameter(enable=True, parameter_number=10))
    b.pulse(mv)
    for _ in range(50):
        b.run(1)
        x = b.x
        # the FBs read the image of their cycle: the set values before this cycle's step
        assert pos.value == x.img_p and vel.value == x.img_v and act.value == x.img_act_v
    assert vel.value > 0.0


@pytest.mark.parametrize("number", READ_ONLY)
def test_read_only_numbers_refuse_writes(number: int) -> None:
    b = _bench()
    before = b.x.cfg
    fb = _write(b, number, 1.0)
    assert fb.error and fb.error_id is ErrorID.PARAMETER_READ_ONLY and not fb.done
    assert str(number) in fb.error_text and "read-only" in fb.error_text
    assert b.x.cfg is before


@pytest.mark.parametrize(
    ("number", "value"),
    [(2, 0.8), (3, -0.4), (7, 0.25), (9, 1.5), (13, 3.0), (15, 2.5), (17, 12.0)],
)
def test_writable_real_numbers_read_back(number: int, value: float) -> None:
    b = _bench(following_error_limit=0.3)
    fb = _write(b, number, value)
    assert fb.done and not fb.error, fb.error_text
    assert _read(b, number) == value
    assert b.x.cfg_system.v_max == 2.0 and b.x.cfg_system.a_max == 4.0  # system unchanged


def test_bool_numbers_switch_the_checks_and_keep_the_values() -> None:
    b = _bench(following_error_limit=0.3)
    x = b.x
    for number, field, value in ((4, "sw_limit_pos", 1.0), (5, "sw_limit_neg", -1.0)):
        fb = _write(b, number, False)
        assert fb.done, fb.error_text
        assert getattr(x.cfg, field) is None and _read(b, number) is False
        assert _read(b, number - 2) == value  # the value stays
        b.run(1)
        fb = _write(b, number, True, fb)
        assert fb.done and getattr(x.cfg, field) == value and _read(b, number) is True
    fb = _write(b, 6, False)
    assert fb.done and x.cfg.following_error_limit is None and x._fe_limit is None
    assert _read(b, 7) == 0.3
    b.run(1)
    _write(b, 6, True, fb)
    assert x.cfg.following_error_limit == 0.3 and x._fe_limit == 0.3


def test_written_sw_limit_stops_a_following_move_at_it() -> None:
    b = _bench()
    fb = _write(b, 2, 0.4)
    assert fb.done
    bad = b.add(MC_MoveAbsolute(position=0.5, velocity=1.0))
    b.pulse(bad)
    assert bad.error and bad.error_id is ErrorID.TARGET_OUTSIDE_SW_LIMITS
    mv = b.add(MC_MoveVelocity(velocity=0.5))
    b.pulse(mv)
    b.run(3000)
    x = b.x
    assert abs(x.p - 0.4) <= 1e-9 and x.v == 0.0
    assert np.max(b.col("x.position")) <= 0.4 + 1e-9
    assert x.state is AxisState.ERROR_STOP and x.axis_error is ErrorID.SW_LIMIT


def test_switched_off_limit_lets_the_move_pass() -> None:
    b = _bench()
    _write(b, 4, False)
    ma = b.add(MC_MoveAbsolute(position=1.5, velocity=1.0))
    b.pulse(ma)
    b.run_until_idle()
    assert ma.done or b.x.p == 1.5
    assert b.x.p == 1.5 and b.x.state is AxisState.STANDSTILL


def test_written_max_velocity_appl_limits_the_next_move() -> None:
    b = _bench()
    assert _write(b, 9, 0.5).done
    fast = b.add(MC_MoveAbsolute(position=0.9, velocity=1.0))
    b.pulse(fast)
    assert fast.error and fast.error_id is ErrorID.INVALID_VELOCITY  # above the Appl value
    ma = b.add(MC_MoveAbsolute(position=0.9, velocity=0.5))
    b.pulse(ma)
    b.run_until_idle()
    v = b.col("x.velocity")
    assert np.max(np.abs(v)) == pytest.approx(0.5, rel=1e-9)
    assert b.x.p == 0.9


def test_written_acceleration_deceleration_jerk_bound_the_next_move() -> None:
    b = _bench()
    for number, value in ((13, 1.0), (15, 2.0), (17, 5.0)):
        assert _write(b, number, value).done
    k0 = b.cycle
    ma = b.add(MC_MoveAbsolute(position=0.9, velocity=2.0))
    b.pulse(ma)
    b.run_until_idle()
    a = b.col("x.acceleration")[k0:]
    # moving positively: acceleration = the positive side, deceleration = the negative side
    assert np.max(a) == pytest.approx(1.0, rel=1e-6) and np.min(a) == pytest.approx(-2.0, rel=1e-6)
    assert np.max(np.abs(np.diff(a))) <= 5.0 * b.rt.cycle * (1 + 1e-6)
    assert b.x.p == 0.9


def test_a_running_move_keeps_its_plan() -> None:
    # the invariant checker judges the set values by the system limits: a move planned
    # before the write goes on at its velocity without tripping it
    rt = Runtime(cycle=0.001, check_invariants=True)
    x = rt.add_axis("x", v_max=2.0, a_max=4.0, j_max=40.0)
    power = MC_Power(axis=x, enable=True)
    ma = MC_MoveAbsolute(axis=x, position=3.0, velocity=2.0)
    wr = MC_WriteParameter(axis=x, parameter_number=9, value=0.5)
    rt.add_task("main", lambda ctx: (power(), ma(), wr()))
    rt.run(cycles=2)
    ma.execute = True
    rt.run(cycles=800)
    v_before = x.v
    wr.execute = True
    rt.run(cycles=1)
    assert wr.done and x.cfg.v_max == 0.5
    rt.run(cycles=1)
    assert x.v == pytest.approx(v_before, rel=1e-3) and v_before > 1.9  # cruising on
    ok = rt.run_until(lambda: ma.done, max_seconds=10.0)
    assert ok and x.p == 3.0


def test_max_position_lag_trips_the_following_error() -> None:
    class Lagging(IdealDrive):
        """Follows 0.01 behind while moving (a real drive's following error)."""

        def read_inputs(self, t: float) -> DriveFeedback:
            fb = super().read_inputs(t)
            lag = 0.01 if fb.velocity else 0.0
            return DriveFeedback(fb.position - lag, fb.velocity, fb.enabled)

        def write_outputs(self, t: float, command: DriveCommand) -> None:
            super().write_outputs(t, command)

    b = Bench(**AXIS, drive=Lagging()).powered()
    mv = b.add(MC_MoveVelocity(velocity=0.2))
    b.pulse(mv)
    b.run(100)
    assert b.x.state is AxisState.CONTINUOUS_MOTION  # no monitoring configured
    fb = _write(b, 7, 0.005)
    assert fb.done and b.x.cfg.following_error_limit is None  # stored, not yet on
    b.run(5)
    assert b.x.state is AxisState.CONTINUOUS_MOTION
    _write(b, 6, True)
    b.run(2)
    assert b.x.state is AxisState.ERROR_STOP and b.x.axis_error is ErrorID.FOLLOWING_ERROR


@pytest.mark.parametrize(
    ("number", "value", "text"),
    [
        (9, 2.5, "[1e-06, 2]"),
        (9, 0.0, "[1e-06, 2]"),
        (13, math.nan, "[1e-06, 4]"),
        (15, math.inf, "[1e-06, 4]"),
        (17, 41.0, "[1e-06, 40]"),
        (7, 0.0, "(0, 1e+12]"),
        (2, math.inf, "[-1e+12, 1e+12]"),
        (2, -1.5, "must be above the checked SWLimitNeg"),
        (3, 1.5, "must be below the checked SWLimitPos"),
        (2, "1.0", "[-1e+12, 1e+12]"),
        (4, 2, "must be a BOOL"),
    ],
)
def test_values_out_of_range_are_refused_naming_the_range(
    number: int, value: Any, text: str
) -> None:
    b = _bench()
    before = b.x.cfg
    fb = b.add((MC_WriteBoolParameter if number in BOOLS else MC_WriteParameter)())
    _write(b, number, value, fb)
    assert fb.error and fb.error_id is ErrorID.INVALID_PARAMETER_VALUE, fb.error_text
    assert text in fb.error_text
    assert b.x.cfg is before


def test_switching_a_check_on_without_a_value_is_refused() -> None:
    b = Bench(v_max=2.0, a_max=4.0).powered()
    for number, first in ((4, "parameter 2"), (5, "parameter 3"), (6, "parameter 7")):
        fb = _write(b, number, True)
        assert fb.error and fb.error_id is ErrorID.INVALID_PARAMETER_VALUE
        assert first in fb.error_text
        b.run(1)
    assert _read(b, 2) == math.inf and _read(b, 3) == -math.inf and _read(b, 7) == math.inf


@pytest.mark.parametrize(
    ("fb_cls", "number"),
    [
        (MC_ReadParameter, 4),
        (MC_ReadBoolParameter, 9),
        (MC_ReadParameter, 0),
        (MC_ReadParameter, 18),
        (MC_ReadParameter, 999),
        (MC_ReadParameter, 1000),
        (MC_ReadParameter, 1.0),
    ],
)
def test_wrong_or_unknown_numbers(fb_cls: Any, number: Any) -> None:
    b = _bench()
    fb = b.add(fb_cls(enable=True, parameter_number=number))
    b.run(1)
    assert fb.error and fb.error_id is ErrorID.INVALID_PARAMETER_NUMBER and not fb.valid
    assert fb.busy  # an Enable FB with an error stays Busy until Enable falls
    fb.parameter_number = 2 if fb_cls is MC_ReadParameter else 4
    b.run(1)
    assert fb.valid and not fb.error  # the error clears by itself
    fb.enable = False
    b.run(1)
    assert not fb.valid and not fb.busy and not fb.error


def test_modulo_axis_has_no_software_limits() -> None:
    b = Bench(v_max=2.0, a_max=4.0, modulo=1.0).powered()
    fb = _write(b, 2, 0.5)
    assert fb.error and fb.error_id is ErrorID.INVALID_PARAMETER_NUMBER
    assert "modulo" in fb.error_text
    assert _read(b, 4) is False and _read(b, 5) is False


def test_queued_write_waits_for_the_motion() -> None:
    b = _bench()
    ma = b.add(MC_MoveAbsolute(position=0.8, velocity=1.0))
    wr = b.add(
        MC_WriteParameter(parameter_number=9, value=0.5, execution_mode=ExecutionMode.QUEUED)
    )
    b.pulse(ma)
    b.run(10)
    wr.execute = True
    b.run(1)
    assert wr.busy and not wr.done and b.x.cfg.v_max == 2.0
    done_at = None
    for _ in range(5000):
        b.run(1)
        if wr.done:
            done_at = b.cycle
            break
    assert done_at is not None and b.x.cfg.v_max == 0.5
    assert b.x.p == 0.8 and b.x.state is AxisState.STANDSTILL
    bad = MC_WriteParameter(axis=b.x, parameter_number=9, value=1.0, execution_mode="later")
    b.add(bad)
    b.pulse(bad)
    assert bad.error and bad.error_id is ErrorID.INVALID_EXECUTION_MODE


def test_input_checks_before_the_run() -> None:
    """``motionplc validate`` checks literal inputs against the axis configuration."""
    cfg = AxisConfig(name="x", **AXIS)  # type: ignore[arg-type]
    ax = StaticAxis(cfg)
    ok = MC_WriteParameter(parameter_number=9, value=1.5)
    assert ok.input_problems(ax) == {}
    probs = MC_WriteParameter(parameter_number=9, value=3.0).input_problems(ax)
    assert set(probs) == {"value"}
    assert probs["value"].error_id is ErrorID.INVALID_PARAMETER_VALUE
    probs = MC_WriteParameter(parameter_number=8, value=1.0).input_problems(ax)
    assert probs["value"].error_id is ErrorID.PARAMETER_READ_ONLY
    probs = MC_ReadParameter(parameter_number=42).input_problems(ax)
    assert probs["parameter_number"].error_id is ErrorID.INVALID_PARAMETER_NUMBER
    probs = MC_WriteBoolParameter(parameter_number=4, value=3).input_problems(ax)
    assert set(probs) == {"value"}
    drive_pn = coe_parameter_number(0x6065, 0, size=4)
    assert MC_WriteParameter(parameter_number=drive_pn, value=100).input_problems(ax) == {}
    probs = MC_WriteParameter(parameter_number=drive_pn, value=math.nan).input_problems(ax)
    assert set(probs) == {"value"}


def test_drive_numbers_on_an_axis_without_drive_parameters() -> None:
    b = _bench()
    rd = b.add(MC_ReadParameter(enable=True, parameter_number=coe_parameter_number(0x6065)))
    b.run(1)
    assert rd.error and rd.error_id is ErrorID.INVALID_PARAMETER_NUMBER
    assert "no drive parameters" in rd.error_text


def test_drive_number_scheme() -> None:
    n = coe_parameter_number(0x6065, 0)
    assert n == 0x606500 and decode_drive_number(n) == decode_drive_number(-n)
    a = decode_drive_number(coe_parameter_number(0x60C2, 2, size=1, signed=True))
    assert a is not None and (a.bus, a.index, a.subindex, a.size, a.signed) == (
        "coe",
        0x60C2,
        2,
        1,
        True,
    )
    m = decode_drive_number(modbus_parameter_number(0x0208, size=2, signed=True))
    assert m is not None and (m.bus, m.index, m.size, m.signed) == ("modbus", 0x0208, 2, True)
    assert modbus_parameter_number(0x0300) == 0x10300
    r = decode_drive_number(modbus_parameter_number(0x3008, real=True))
    assert r is not None and (r.index, r.size, r.real) == (0x3008, 4, True)
    assert coe_parameter_number(0x6085, real=True) == 0x24608500
    with pytest.raises(ValueError, match="size 4"):
        coe_parameter_number(0x6085, size=2, real=True)
    for bad in (0, 17, 999, 0xFFFF, 0x20000, 0x3606500, 0x1010300, True, 1.5):
        assert decode_drive_number(bad) is None  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="index"):
        coe_parameter_number(0x0FFF)
    with pytest.raises(ValueError, match="size"):
        coe_parameter_number(0x6065, 0, size=3)
    with pytest.raises(ValueError, match="1-byte"):
        modbus_parameter_number(0x10, size=1)


@settings(max_examples=40, deadline=None)
@given(
    v=st.floats(1e-6, 2.0),
    a=st.floats(1e-6, 4.0),
    d=st.floats(1e-6, 4.0),
    j=st.floats(1e-6, 40.0),
)
def test_appl_writes_within_the_system_values_read_back(
    v: float, a: float, d: float, j: float
) -> None:
    b = Bench(v_max=2.0, a_max=4.0, j_max=40.0)
    wr = b.add(MC_WriteParameter())
    for number, value in ((9, v), (13, a), (15, d), (17, j)):
        _write(b, number, value, wr)
        assert wr.done, wr.error_text
        b.run(1)
    cfg = b.x.cfg
    assert (cfg.v_top, cfg.a_max, cfg.a_neg, cfg.j_max) == (v, a, d, j)
    over = b.add(MC_WriteParameter())
    _write(b, 13, 4.0 * (1 + 1e-9), over)
    assert over.error and over.error_id is ErrorID.INVALID_PARAMETER_VALUE


# --------------------------------------------------------------------------- stateful
from hypothesis.stateful import RuleBasedStateMachine, invariant, rule  # noqa: E402

SYS = {"v": 2.0, "a": 4.0, "d": 4.0, "j": 40.0}


class ParameterMachine(RuleBasedStateMachine):
    """Random writes (valid and invalid) of every writable number and moves in between; a
    model predicts each write's outcome, every number reads back as the model says, and each
    move is refused at an active software limit or runs within the applied limits."""

    def __init__(self) -> None:
        super().__init__()
        self.b = Bench(cycle=0.01, **AXIS).powered()
        self.m: dict[int, Any] = {2: 1.0, 3: -1.0, 4: True, 5: True, 6: False, 7: math.inf}
        self.m.update({9: 2.0, 13: 4.0, 15: 4.0, 17: 40.0})
        self.wr = self.b.add(MC_WriteParameter())
        self.wb = self.b.add(MC_WriteBoolParameter())
        self.ma = self.b.add(MC_MoveAbsolute())

    def _expect(self, n: int, x: float) -> ErrorID:
        """The outcome of writing REAL ``x`` to ``n`` by the model."""
        m = self.m
        bad = ErrorID.INVALID_PARAMETER_VALUE
        top = {9: SYS["v"], 13: SYS["a"], 15: SYS["d"], 17: SYS["j"]}.get(n)
        if top is not None:
            return ErrorID.OK if 1e-6 <= x <= top else bad
        if n == 7:
            return ErrorID.OK if 0 < x <= 1e12 else bad
        if n == 2 and m[4] and m[5] and not x > m[3]:
            return bad
        if n == 3 and m[4] and m[5] and not x < m[2]:
            return bad
        return ErrorID.OK

    @rule(
        n=st.sampled_from([2, 3, 7, 9, 13, 15, 17]),
        x=st.one_of(st.floats(-3.0, 50.0), st.sampled_from([0.0, 2.0, 4.0, 40.0, 1e-6])),
    )
    def write_real(self, n: int, x: float) -> None:
        want = self._expect(n, x)
        self.b.run(1)
        _write(self.b, n, x, self.wr)
        assert self.wr.error_id is want, (n, x, self.wr.error_text)
        if want is ErrorID.OK:
            assert self.wr.done
            self.m[n] = x

    @rule(n=st.sampled_from([4, 5, 6]), x=st.booleans())
    def write_bool(self, n: int, x: bool) -> None:
        m = self.m
        want = ErrorID.OK
        if n == 6 and x and m[7] == math.inf:
            want = ErrorID.INVALID_PARAMETER_VALUE
        if n == 4 and x and m[5] and not m[2] > m[3]:
            want = ErrorID.INVALID_PARAMETER_VALUE
        if n == 5 and x and m[4] and not m[3] < m[2]:
            want = ErrorID.INVALID_PARAMETER_VALUE
        self.b.run(1)
        _write(self.b, n, x, self.wb)
        assert self.wb.error_id is want, (n, x, self.wb.error_text)
        if want is ErrorID.OK:
            m[n] = x

    @rule(pos=st.floats(-1.2, 1.2))
    def move(self, pos: float) -> None:
        b, m = self.b, self.m
        x = b.x
        if x.state is not AxisState.STANDSTILL:
            return
        hi = m[2] if m[4] else math.inf
        lo = m[3] if m[5] else -math.inf
        dist = abs(pos - x.p)
        acc = min(m[13], m[15])
        if dist / m[9] + 2.0 * math.sqrt(dist / acc) + 2.0 * acc / m[17] > 20.0:
            return  # a move of more than ~20 s (tiny *Appl limits): not run here
        k0 = b.cycle
        b.run(1)
        b.pulse(self.ma, position=pos, velocity=m[9])
        if (pos > hi and pos > x.p) or (pos < lo and pos < x.p):
            assert self.ma.error and self.ma.error_id is ErrorID.TARGET_OUTSIDE_SW_LIMITS
            return
        assert not self.ma.error, self.ma.error_text
        b.run_until_idle()
        assert x.p == pos
        v = b.col("x.velocity")[k0:]
        a = b.col("x.acceleration")[k0:]
        assert np.max(np.abs(v)) <= m[9] * (1 + 1e-9)
        assert np.max(a) <= m[13] * (1 + 1e-9) and np.min(a) >= -m[15] * (1 + 1e-9)

    @invariant()
    def reads_match_the_model(self) -> None:
        if not hasattr(self, "b"):
            return
        cfg = self.b.x.cfg
        m = self.m
        assert (cfg.v_top, cfg.a_max, cfg.a_neg, cfg.j_max) == (m[9], m[13], m[15], m[17])
        assert cfg.sw_limit_pos == (m[2] if m[4] else None)
        assert cfg.sw_limit_neg == (m[3] if m[5] else None)
        lag = m[7] if m[6] else None
        assert cfg.following_error_limit == lag


ParameterMachine.TestCase.settings = settings(
    max_examples=15, stateful_step_count=10, deadline=None
)
test_parameter_machine = ParameterMachine.TestCase


@pytest.mark.parametrize(("number", "value"), [(17, 1.0), (15, 0.2), (13, 0.2), (9, 0.1)])
def test_lower_appl_dynamics_during_a_move_to_the_limit(number: int, value: float) -> None:
    """A move planned with the system dynamics to the software limit itself keeps its plan
    after a lower *Appl write: the supervision judges (and would brake) with the dynamics
    the axis has, not the lower applied ones, so there is no false SW_LIMIT and no
    overshoot."""
    rt = Runtime(cycle=0.001)  # the invariants check the applied limits: not here
    x = rt.add_axis("x", v_max=2.0, a_max=4.0, j_max=40.0, sw_limit_pos=1.0)
    power = MC_Power(axis=x, enable=True)
    ma = MC_MoveAbsolute(axis=x, position=1.0, velocity=2.0)
    wr = MC_WriteParameter(axis=x, parameter_number=number, value=value)
    rt.add_task("main", lambda ctx: (power(), ma(), wr()))
    rt.run(cycles=2)
    ma.execute = True
    rt.run(cycles=500)
    wr.execute = True
    rt.run(cycles=1)
    assert wr.done
    assert rt.run_until(lambda: ma.done or ma.error, max_seconds=5.0)
    assert ma.done and x.p == 1.0 and x.axis_error is ErrorID.OK
    assert np.max(rt.trace.column("x.position")) <= 1.0 + 1e-9


def test_a_new_limit_ahead_of_a_running_move_stops_it_there() -> None:
    rt = Runtime(cycle=0.001)
    x = rt.add_axis("x", v_max=2.0, a_max=4.0, j_max=40.0, sw_limit_pos=3.0)
    power = MC_Power(axis=x, enable=True)
    ma = MC_MoveAbsolute(axis=x, position=2.5, velocity=1.0)
    wr = MC_WriteParameter(axis=x, parameter_number=2, value=1.5)
    rt.add_task("main", lambda ctx: (power(), ma(), wr()))
    rt.run(cycles=2)
    ma.execute = True
    rt.run(cycles=400)
    assert x.p < 1.0
    wr.execute = True
    rt.run(cycles=3000)
    assert wr.done and ma.error and ma.error_id is ErrorID.SW_LIMIT
    assert abs(x.p - 1.5) <= 1e-9 and x.v == 0.0
    assert np.max(rt.trace.column("x.position")) <= 1.5 + 1e-9


def test_config_tracker_follows_writes_like_the_axis() -> None:
    """The static tracker (for checks before the run) ends with the very configuration a
    running axis has after the same writes, and refuses what the FB refuses."""
    writes = [(4, False), (9, 0.5), (2, 0.7), (4, True), (13, 1.0), (7, 0.1), (6, True)]
    b = _bench()
    tracker = ConfigTracker(b.x.cfg)
    for number, value in writes:
        fb = _write(b, number, value)
        assert fb.done, fb.error_text
        tracker.write(number, value)
        b.run(1)
    assert tracker.cfg == b.x.cfg and tracker.cfg_system == b.x.cfg_system
    assert tracker.cfg.sw_limit_pos == 0.7 and tracker.cfg.v_max == 0.5
    with pytest.raises(InputError) as err:
        tracker.write(9, 5.0)
    assert err.value.error_id is ErrorID.INVALID_PARAMETER_VALUE
    with pytest.raises(InputError) as err:
        tracker.write(8, 1.0)
    assert err.value.error_id is ErrorID.PARAMETER_READ_ONLY
    with pytest.raises(InputError) as err:
        tracker.write(0x606500, 1.0)
    assert err.value.error_id is ErrorID.INVALID_PARAMETER_NUMBER
