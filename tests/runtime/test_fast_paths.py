"""The hot-path shortcuts give the same results as the straightforward code.

* FB edge tracing visits only FBs marked dirty by their scan: every output edge must still be
  in the trace (checked against the outputs after every cycle of a random FB sequence);
* the cheap ``DriveCommand`` / ``DriveFeedback`` builders give equal values and are in use (they
  fall back to the normal constructors if the dataclasses change);
* the lateness histogram percentiles.
"""

from __future__ import annotations

import random
from typing import Any

import pytest

from motionplc.blocks import (
    BufferMode,
    Direction,
    MC_Halt,
    MC_MoveAbsolute,
    MC_MoveRelative,
    MC_MoveVelocity,
    MC_Power,
    MC_ReadActualPosition,
    MC_ReadStatus,
    MC_Reset,
    MC_SetOverride,
    MC_Stop,
)
from motionplc.fieldbus.base import DriveCommand, DriveFeedback
from motionplc.runtime import Runtime
from motionplc.runtime.task import Task


def _random_program(rt: Runtime, seed: int) -> list[Any]:
    x = rt.add_axis("x", v_max=100.0, a_max=500.0, j_max=20_000.0)
    rng = random.Random(seed)
    power = MC_Power(axis=x)
    fbs: list[Any] = [
        power,
        MC_ReadStatus(axis=x),
        MC_ReadActualPosition(axis=x),
        MC_MoveAbsolute(axis=x, velocity=50.0, buffer_mode=BufferMode.BLENDING_LOW),
        MC_MoveAbsolute(axis=x, velocity=80.0, buffer_mode=BufferMode.BUFFERED),
        MC_MoveRelative(axis=x, velocity=60.0),
        MC_MoveVelocity(axis=x, velocity=40.0, direction=Direction.NEGATIVE),
        MC_Halt(axis=x),
        MC_Stop(axis=x),
        MC_Reset(axis=x),
        MC_SetOverride(axis=x),
    ]
    inputs = {
        "enable": [True, True, True, False],
        "execute": [True, False],
        "position": [0.0, 50.0, -30.0, 120.0],
        "distance": [10.0, -25.0],
        "vel_factor": [1.0, 0.5, 0.0, 2.0],
    }

    def program(ctx: Any) -> None:
        if ctx.cycle < 5:
            power(enable=True)
        for fb in fbs:
            kw = {}
            if rng.random() < 0.03:
                for name, values in inputs.items():
                    if name in fb.INPUTS and (fb is not power or ctx.cycle > 200):
                        kw[name] = rng.choice(values)
            fb(**kw)

    rt.add_task("main", program)
    return fbs


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_every_output_edge_is_traced(seed: int) -> None:
    rt = Runtime(cycle=0.001, check_invariants=True)
    fbs = _random_program(rt, seed)
    last: dict[tuple[str, str], bool] = {}
    n_events = 0

    def check(rt: Runtime, cycle: int) -> None:
        nonlocal n_events
        events = rt.trace.events
        for e in list(events)[n_events:]:
            last[(e.fb, e.output)] = e.value
        n_events = len(events)
        for fb in fbs:
            for out in fb.OUTPUTS:
                traced = last.get((fb.name, out), False)
                assert traced == bool(getattr(fb, out)), (cycle, fb.name, out)

    rt.add_cycle_hook(check)
    rt.run(cycles=3000)
    assert n_events > 100  # the random sequence did exercise the FBs


def test_cheap_drive_value_builders_are_equal_and_in_use() -> None:
    from motionplc.blocks import axis as axis_mod
    from motionplc.fieldbus import ideal

    # If one of these fails, DriveCommand/DriveFeedback changed: update the field tuples in
    # blocks/axis.py and fieldbus/ideal.py (the code falls back to the slow constructors).
    assert axis_mod._drive_command is not DriveCommand
    assert ideal._healthy_feedback.__doc__ is not None
    for args in [(1.5, -2.0, 0.25, True, False), (0.0, 0.0, 0.0, False, True)]:
        c = axis_mod._drive_command(*args)
        assert type(c) is DriveCommand
        assert c == DriveCommand(*args)
        with pytest.raises(AttributeError):
            c.position = 3.0  # type: ignore[misc]
    for args in [(1.5, -2.0, True), (0.0, 0.0, False)]:
        f = ideal._healthy_feedback(*args)
        assert type(f) is DriveFeedback
        assert f == DriveFeedback(*args)
        assert hash(f) == hash(DriveFeedback(*args))


def test_lateness_percentiles_from_the_histogram() -> None:
    t = Task("t", lambda ctx: None, 1, 0.001, 0, 0)
    for us in range(100):  # 0..99 us
        t.record(us * 1000 + 500, 10_000, False)
    t.record(30_000_000, 10_000, True)  # 30 ms: beyond the histogram range (last bin)
    st = t.stats()
    # the upper edge of the bin holding the ceil(q * n)-th sample
    assert st.lateness_p50 == pytest.approx(51e-6)
    assert st.lateness_p99 == pytest.approx(100e-6)
    assert st.lateness_max == pytest.approx(0.030)
    assert t.lateness_percentile(1.0) == pytest.approx(0.030)
    assert int(t.lat_hist.sum()) == 101
