"""A program that raises: its task halts, its axes stop under control, then run() raises."""

from __future__ import annotations

import numpy as np
import pytest

from motionplc.blocks import AxisState, MC_MoveVelocity, MC_Power
from motionplc.blocks.enums import ErrorID
from motionplc.errors import ProgramError
from motionplc.runtime import Runtime

A_MAX = 4.0


def _rig(fail_at: int) -> tuple[Runtime, list[int], object, object]:
    rt = Runtime(cycle=0.001, check_invariants=True)
    x = rt.add_axis("x", v_max=2.0, a_max=A_MAX, j_max=40.0)
    y = rt.add_axis("y", v_max=2.0, a_max=A_MAX, j_max=40.0)
    calls: list[int] = []
    px, mx = MC_Power(axis=x, enable=True), MC_MoveVelocity(axis=x, velocity=1.5)
    py, my = MC_Power(axis=y, enable=True), MC_MoveVelocity(axis=y, velocity=1.0)

    def bad(ctx) -> None:
        calls.append(ctx.cycle)
        px()
        mx(execute=px.status)
        if ctx.cycle == fail_at:
            raise ZeroDivisionError("a bug in the user's program")

    def good(ctx) -> None:
        py()
        my(execute=py.status)

    rt.add_task("bad", bad)
    rt.add_task("good", good)
    x.task_name, y.task_name = "bad", "good"
    return rt, calls, x, y


def test_program_exception_stops_its_axes_then_raises() -> None:
    rt, calls, x, y = _rig(fail_at=1500)
    with pytest.raises(ProgramError, match="ZeroDivisionError: a bug") as info:
        rt.run(cycles=5000)
    err = info.value
    assert isinstance(err.__cause__, ZeroDivisionError)
    assert err.task == "bad" and err.where.endswith("test_program_error.py:29")
    # run() returned only once the failed task's axes were at rest
    assert x.v == 0.0 and x.active is None
    assert x.state is AxisState.ERROR_STOP and x.axis_error is ErrorID.INTERNAL_ERROR
    assert "test_program_error.py:29" in x.axis_error_reason
    assert calls[-1] == 1500 and len(calls) == 1501  # never called again
    # the controlled stop: speed falls monotonically with |a| <= a_max; every cycle traced
    n = rt.tick
    assert (rt.trace.column("cycle") == np.arange(n)).all()
    v = rt.trace.column("x.velocity")[1500:]
    assert (np.diff(v) <= 1e-12).all() and np.abs(rt.trace.column("x.acceleration")).max() <= A_MAX
    # the other task and its axis run on, also in later runs (which do not raise again)
    assert y.state is AxisState.CONTINUOUS_MOTION and y.v == pytest.approx(1.0)
    rt.run(cycles=100)
    assert y.state is AxisState.CONTINUOUS_MOTION and len(calls) == 1501
    assert rt.error_reason == str(err)


def test_run_ends_before_the_stop_is_done_raises_then_the_stop_continues() -> None:
    rt, _, x, _ = _rig(fail_at=1500)
    rt.run(cycles=1500)
    with pytest.raises(ProgramError):
        rt.run(cycles=5)  # the stop takes longer than this run
    assert x.v > 0.0
    rt.run(cycles=2000)  # no second raise; the ramp goes on to rest
    assert x.v == 0.0 and x.state is AxisState.ERROR_STOP
