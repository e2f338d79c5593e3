"""Couplings never exceed the slave's limits silently (issue 31 part 3), checked by
differencing the slave's set positions: the GearIn catch-up takes its room beside the law
from the master's planned motion, a locked gear's jerk is supervised, and the kernel's one
limit supervision (``Axis.guard_limits``) turns anything beyond the limits into an ErrorID in
that cycle and a stop within them."""

from __future__ import annotations

import numpy as np
import pytest

from motionplc.blocks import MC_MoveVelocity, MC_Power
from motionplc.blocks.enums import AxisState, ErrorID
from motionplc.blocks.sync import MC_GearIn
from motionplc.runtime import Runtime
from tests.blocks.coupling_sweep import run_one

DT = 0.001


def _gear_run(
    ratio: tuple[int, int],
    master_acc: float,
    master_jerk: float,
    engage_v: float,
    slave: tuple[float, float, float] = (8.0, 20.0, 200.0),
    cycles: int = 1500,
) -> tuple[np.ndarray, MC_GearIn, object]:
    rt = Runtime(cycle=DT, check_invariants=True)
    m = rt.add_axis("m", v_max=2.0, a_max=10.0, j_max=100.0)
    s = rt.add_axis("s", v_max=slave[0], a_max=slave[1], j_max=slave[2])
    powers = [MC_Power(axis=m, enable=True), MC_Power(axis=s, enable=True)]
    mv = MC_MoveVelocity(axis=m, velocity=1.5, acceleration=master_acc, jerk=master_jerk)
    g = MC_GearIn(master=m, slave=s, ratio_numerator=ratio[0], ratio_denominator=ratio[1])
    ps: list[float] = []

    def program(ctx: object) -> None:
        for p in powers:
            p()
        powered = powers[0].status and powers[1].status
        if powered:
            mv(execute=True)
        g(execute=g.execute or (powered and m.v >= engage_v))

    rt.add_task("main", program)
    rt.add_cycle_hook(lambda rt, k: ps.append(s.p))
    rt.run(cycles=cycles)
    return np.asarray(ps), g, s


def _peaks(p: np.ndarray) -> tuple[float, float, float]:
    v = np.diff(p) / DT
    a = np.diff(v) / DT
    j = np.diff(a) / DT
    return float(np.abs(v).max()), float(np.abs(a).max()), float(np.abs(j).max())


@pytest.mark.parametrize("ratio", [(3, 1), (5, 2)])
def test_gear_in_catch_up_stays_within_the_slave_limits(ratio: tuple[int, int]) -> None:
    """The issue's case: master MC_MoveVelocity 1.5 with acceleration 5, jerk 50; GearIn at a
    master velocity of 0.3. The law needs a = 15, j = 150 (3/1); the catch-up used to add the
    slave's whole limits to it (a = 32, j = 350 by differencing, no error)."""
    p, g, s = _gear_run(ratio, 5.0, 50.0, 0.3)
    v, a, j = _peaks(p)
    assert g.in_gear and not g.error
    assert v <= 8.0 * (1 + 1e-9) and a <= 20.0 * (1 + 1e-6) and j <= 200.0 * (1 + 1e-6), (v, a, j)


def test_locked_gear_jerk_beyond_the_slave_limit_is_an_error_and_a_stop() -> None:
    """A 3/1 gear while the master ramps with its own jerk 100: the slave would run at jerk
    300 against its j_max 200. Now SLAVE_LIMITS_EXCEEDED and a stop within the limits."""
    p, g, s = _gear_run((3, 1), 10.0, 100.0, 0.0, cycles=3000)
    v, a, j = _peaks(p)
    assert g.error and g.error_id is ErrorID.SLAVE_LIMITS_EXCEEDED
    assert s.v == 0.0 and s.state is AxisState.STANDSTILL  # type: ignore[attr-defined]
    assert v <= 8.0 * (1 + 1e-9) and a <= 20.0 * (1 + 1e-6) and j <= 200.0 * (1 + 1e-6), (v, a, j)


@pytest.mark.parametrize(
    ("kind", "ratio", "factor", "engage", "moving"),
    [
        ("gear", (1, 4), 0.5, "ramp", False),
        ("gear", (3, 1), 0.75, "rest", True),
        ("gear", (5, 1), 1.0, "ramp", True),
        ("gear", (5, 2), 1.5, "cruise", False),
        ("gear", (1, 1), 2.0, "ramp", True),
        ("cam", (1, 2), 0.5, "cruise", True),
        ("cam", (3, 2), 1.0, "ramp", False),
        ("cam", (4, 1), 2.0, "rest", True),
    ],
)
def test_sweep_cases_hold_the_limits_or_end_in_an_error_with_a_stop(
    kind: str, ratio: tuple[int, int], factor: float, engage: str, moving: bool
) -> None:
    """A sample of the sweep (``python -m tests.blocks.coupling_sweep``: all of it)."""
    out = run_one(kind, ratio, factor, engage, moving)
    assert out.result in ("held", "error"), out
    if factor >= 2.0 and not moving:
        assert out.result == "held", out  # twice what the law needs: room for the catch-up


def test_the_guard_stops_an_axis_whose_set_values_leave_its_limits() -> None:
    """The kernel's one supervision, on a set value no planner made: a superimposed-like jump
    written into the kernel's state is caught by differencing in that very step."""
    rt = Runtime(cycle=DT)
    x = rt.add_axis("x", v_max=1.0, a_max=10.0, j_max=100.0)
    power = MC_Power(axis=x, enable=True)
    mv = MC_MoveVelocity(axis=x, velocity=0.5)
    rt.add_task("main", lambda ctx: (power(), mv(execute=power.status)))
    rt.run(cycles=300)
    assert x.v == pytest.approx(0.5)
    ps: list[float] = []
    rt.add_cycle_hook(lambda rt, k: ps.append(x.p))
    # a defect elsewhere: the running job's shift moves the set position by 1 mm at once
    x.active.shift += 1e-3
    rt.run(cycles=400)
    assert x.axis_error is ErrorID.SET_VALUE_LIMIT and "differenced" in x.axis_error_reason
    assert x.state is AxisState.ERROR_STOP and x.v == 0.0
    v, a, j = _peaks(np.asarray(ps))
    assert v <= 1.0 * (1 + 1e-9) and a <= 10.0 * (1 + 1e-6) and j <= 100.0 * (1 + 1e-6), (v, a, j)
