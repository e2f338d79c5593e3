"""MC_ReadMotionState: ACTUAL_VALUE uses the actual acceleration (derived from the actual
velocities, since drives report none), not the set acceleration."""

from __future__ import annotations

from collections import deque

import pytest

from motionplc.blocks import ErrorID, MC_MoveAbsolute, MC_ReadMotionState, Source
from motionplc.fieldbus.base import DriveCommand, DriveFeedback
from motionplc.fieldbus.ideal import IdealDrive
from motionplc.runtime import Runtime
from tests.runtime.helpers import Bench


class LagDrive(IdealDrive):
    """Reports the commanded velocity ``lag`` cycles late (a slow velocity loop)."""

    def __init__(self, lag: int) -> None:
        super().__init__("lag")
        self._hist: deque[float] = deque([0.0] * lag, maxlen=lag)

    def write_outputs(self, t: float, command: DriveCommand) -> None:
        super().write_outputs(t, command)
        self._hist.append(self._velocity)
        self._feedback = DriveFeedback(self._position, self._hist[0], self._enabled)


def _flags(fb: MC_ReadMotionState) -> tuple[bool, bool, bool]:
    return fb.accelerating, fb.constant_velocity, fb.decelerating


def test_actual_flags_follow_the_actual_velocity_differences() -> None:
    b = Bench(v_max=100.0, a_max=200.0, j_max=5000.0).powered()
    act = b.add(MC_ReadMotionState(enable=True, source=Source.ACTUAL_VALUE))
    m = b.add(MC_MoveAbsolute(position=50.0, velocity=60.0))
    b.pulse(m)
    seen = []
    while m.busy or not seen:
        k = b.cycle
        b.run(1)
        seen.append((k, _flags(act), b.x.img_act_a))
    # the derived acceleration is the backward difference of the traced actual velocity
    v_act = b.col("x.actual_velocity")
    dt = b.rt.cycle
    for k, (accel, const, decel), a in seen:
        assert a == pytest.approx((v_act[k] - v_act[k - 1]) / dt, abs=1e-6)
        assert const == (abs(a) <= 1e-6 * 200.0)
        assert accel == (abs(v_act[k]) > abs(v_act[k - 1]) and not const)
        assert decel == (abs(v_act[k]) < abs(v_act[k - 1]) and not const)
    assert any(f[0] for _, f, _ in seen) and any(f[1] for _, f, _ in seen)
    assert any(f[2] for _, f, _ in seen)


def test_actual_source_differs_from_set_source_with_a_lagging_drive() -> None:
    rt = Runtime(cycle=0.001, check_invariants=True)
    x = rt.add_axis("x", v_max=100.0, a_max=200.0, drive=LagDrive(lag=20))
    from motionplc.blocks import MC_Power

    power = MC_Power(axis=x, enable=True)
    set_fb = MC_ReadMotionState(axis=x, enable=True, source=Source.SET_VALUE)
    act_fb = MC_ReadMotionState(axis=x, enable=True, source=Source.ACTUAL_VALUE)
    m = MC_MoveAbsolute(axis=x, position=40.0, velocity=50.0)
    log: list[tuple[tuple[bool, bool, bool], tuple[bool, bool, bool]]] = []

    def prog(ctx) -> None:
        power()
        m(execute=ctx.cycle >= 3)
        set_fb()
        act_fb()
        log.append((_flags(set_fb), _flags(act_fb)))

    rt.add_task("main", prog)
    rt.run(cycles=1500)
    # the set velocity reaches 50 after 0.25 s and cruises; the actual velocity is 20 cycles
    # late, so there are cycles where the set value is constant and the actual one still rises
    mixed = [k for k, (s, a) in enumerate(log) if s[1] and a[0]]
    assert len(mixed) >= 15
    assert not act_fb.error


def test_bad_window_is_an_error() -> None:
    b = Bench(v_max=100.0, a_max=200.0).powered()
    fb = b.add(MC_ReadMotionState(enable=True, source=Source.ACTUAL_VALUE, acc_window=-1.0))
    b.run(1)
    assert fb.error and fb.error_id is ErrorID.INVALID_ACCELERATION and not fb.valid
