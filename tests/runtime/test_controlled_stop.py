"""Every end of a run is a controlled stop (issue 31 part 2): ``Runtime.shutdown`` and the
``with`` forms of Runtime and Machine bring every axis and group to rest within its limits
(checked by differencing the set positions, not the kernel's columns), switch the drives off
and keep those cycles in the trace; a quick stop on request; bounded; a drive that does not
answer is reported."""

from __future__ import annotations

import math
import signal
from typing import Any

import numpy as np
import pytest

from motionplc.blocks import MC_MoveVelocity, MC_Power
from motionplc.blocks.enums import AxisState, ErrorID, GroupState
from motionplc.blocks.group_blocks import MC_GroupEnable, MC_MoveLinearAbsolute
from motionplc.blocks.sync import MC_GearIn
from motionplc.fieldbus.base import DriveFeedback
from motionplc.fieldbus.ideal import IdealDrive
from motionplc.runtime import Runtime

LIM = {"x": (0.5, 2.0, 20.0), "y": (0.4, 1.5, 15.0), "z": (0.3, 1.0, 10.0)}


def _within(rt: Runtime, name: str, lim: tuple[float, float, float]) -> tuple[float, ...]:
    """Max |v|/v_max, |a|/a_max, |j|/j_max over the trace by differencing ``name.position``
    up to its last powered row (after it the set position is the drive's)."""
    p = rt.trace.column(f"{name}.position")
    st = rt.trace.column(f"{name}.state")
    on = np.nonzero(st != float(AxisState.DISABLED))[0]
    p = p[: on[-1] + 1]
    v = np.diff(p) / rt.cycle
    a = np.diff(v) / rt.cycle
    j = np.diff(a) / rt.cycle
    return (
        float(np.abs(v).max()) / lim[0],
        float(np.abs(a).max()) / lim[1],
        float(np.abs(j).max()) / lim[2],
    )


def _machine(check: bool = True) -> tuple[Runtime, dict[str, Any]]:
    rt = Runtime(cycle=0.001, check_invariants=check)
    axes = {n: rt.add_axis(n, v_max=v, a_max=a, j_max=j) for n, (v, a, j) in LIM.items()}
    group = rt.add_group("xy", ["x", "y"])
    powers = [MC_Power(axis=ax, enable=True) for ax in axes.values()]
    enable = MC_GroupEnable(axes_group=group)
    line = MC_MoveLinearAbsolute(axes_group=group, position=(0.9, 0.6), velocity=0.45)
    spin = MC_MoveVelocity(axis=axes["z"], velocity=0.25)

    def program(ctx: Any) -> None:
        for p in powers:
            p()
        if all(p.status for p in powers):
            enable(execute=True)
            spin(execute=True)
        if enable.done:
            line(execute=True)

    rt.add_task("main", program)
    return rt, {"axes": axes, "group": group}


def test_shutdown_brings_axes_and_a_group_to_rest_within_their_limits() -> None:
    rt, m = _machine()
    rt.run(seconds=0.6)
    assert m["group"].state is GroupState.GROUP_MOVING and m["axes"]["z"].v == 0.25
    x0, y0 = m["axes"]["x"].p, m["axes"]["y"].p
    report = rt.shutdown("test")
    assert report.ok and not report.quick and report.cycles > 100, report
    assert report.seconds <= report.bound
    for n, ax in m["axes"].items():
        assert ax.state is AxisState.DISABLED and ax.v == 0.0 and not ax.drive_enabled
        assert max(_within(rt, n, LIM[n])) <= 1 + 1e-6, (n, _within(rt, n, LIM[n]))
    assert m["group"].state is GroupState.GROUP_DISABLED
    # along the path: the group braked on its line through the origin and (0.9, 0.6)
    x1, y1 = m["axes"]["x"].p, m["axes"]["y"].p
    assert x1 > x0 and y1 > y0 and x1 * 0.6 == pytest.approx(y1 * 0.9, abs=1e-9)
    assert len(rt.trace) == rt.tick  # every cycle of the stop is in the trace
    assert rt.shutdown("again") is report  # idempotent


def test_with_block_and_an_exception_inside_it_end_in_the_controlled_stop() -> None:
    rt, m = _machine()
    with pytest.raises(RuntimeError, match="user code"):
        with rt:
            rt.run(seconds=0.5)
            raise RuntimeError("user code")
    assert rt.stop_report is not None and rt.stop_report.reason == "exception RuntimeError"
    assert rt.stop_report.ok
    assert all(ax.state is AxisState.DISABLED and ax.v == 0.0 for ax in m["axes"].values())


def test_a_coupled_slave_stops_within_its_own_limits() -> None:
    rt = Runtime(cycle=0.001, check_invariants=True)
    mst = rt.add_axis("m", v_max=2.0, a_max=10.0, j_max=100.0)
    slv = rt.add_axis("s", v_max=4.0, a_max=15.0, j_max=150.0)
    powers = [MC_Power(axis=mst, enable=True), MC_Power(axis=slv, enable=True)]
    mv = MC_MoveVelocity(axis=mst, velocity=1.0, acceleration=2.0, jerk=20.0)
    gear = MC_GearIn(master=mst, slave=slv, ratio_numerator=2, ratio_denominator=1)

    def program(ctx: Any) -> None:
        for p in powers:
            p()
        if all(p.status for p in powers):
            mv(execute=True)
            gear(execute=True)

    rt.add_task("main", program)
    rt.run(seconds=1.5)
    assert gear.in_gear and slv.v == pytest.approx(2.0)
    report = rt.shutdown()
    assert report.ok, report
    assert max(_within(rt, "s", (4.0, 15.0, 150.0))) <= 1 + 1e-6
    assert max(_within(rt, "m", (2.0, 10.0, 100.0))) <= 1 + 1e-6
    assert slv.state is AxisState.DISABLED and mst.state is AxisState.DISABLED


def test_a_quick_stop_requested_during_the_stop_is_reported_as_such() -> None:
    rt, m = _machine(check=False)
    rt.run(seconds=0.6)
    asked = []

    def ask(rt: Runtime, k: int) -> None:
        if rt._stopping and not asked:
            asked.append(k)
            rt.quick_stop_requested = True

    rt.add_cycle_hook(ask)
    report = rt.shutdown("test")
    assert report.quick and report.ok, report
    assert m["axes"]["z"].axis_error is ErrorID.QUICK_STOP
    assert m["group"].error_id in (ErrorID.QUICK_STOP, ErrorID.OK)
    for n in LIM:
        assert max(_within(rt, n, LIM[n])) <= 1 + 1e-6


class _DeafDrive(IdealDrive):
    """An ideal drive whose power stage never reports switched off."""

    def read_inputs(self, t: float) -> DriveFeedback:
        fb = super().read_inputs(t)
        return DriveFeedback(fb.position, fb.velocity, True)


def test_a_drive_that_does_not_switch_off_is_reported_and_the_stop_is_bounded() -> None:
    rt = Runtime(cycle=0.001)
    x = rt.add_axis("x", v_max=1.0, a_max=5.0, j_max=50.0, drive=_DeafDrive("x"))
    power = MC_Power(axis=x, enable=True)
    mv = MC_MoveVelocity(axis=x, velocity=0.5)
    rt.add_task("main", lambda ctx: (power(), mv(execute=power.status)))
    rt.run(seconds=0.5)
    report = rt.shutdown("test", disable_time=0.2)
    assert report.not_disabled == ["x"] and not report.not_at_rest and not report.ok
    assert report.seconds <= report.bound + 0.2 + 2 * rt.cycle
    assert "did not report disabled" in "\n".join(report.lines())


def test_the_cli_signal_handler_asks_for_a_quick_stop_on_a_second_signal() -> None:
    from motionplc.cli import _Ending

    rt = Runtime(cycle=0.001)
    ending = _Ending(rt)
    ending._handle(signal.SIGTERM, None)
    assert ending.signal == "SIGTERM" and not rt.quick_stop_requested
    ending.stopping = True
    ending._handle(signal.SIGINT, None)
    assert rt.quick_stop_requested
    assert ending.words() == "terminated (SIGTERM)"


def test_stop_time_estimate_bounds_a_planned_stop() -> None:
    from motionplc.planning import Limits, State, plan_velocity
    from motionplc.runtime.runtime import stop_time

    for v, a in ((0.5, 0.0), (0.5, 2.0), (-0.3, 1.5), (0.01, -2.0)):
        lim = Limits(1.0, 2.0, 20.0)
        prof = plan_velocity(State(0.0, v, a), 0.0, lim)
        assert prof.duration <= stop_time(v, a, 2.0, 20.0) + 1e-12
    assert stop_time(1.0, 0.0, 2.0, math.inf) == pytest.approx(0.5)


def test_a_machine_with_block_stops_its_can_axis_and_switches_the_drive_off(tmp_path: Any) -> None:
    from motionplc.config import build, load_config

    cfg = tmp_path / "m.yaml"
    cfg.write_text(
        "runtime:\n  tick: 0.001\n  tasks:\n    motion: {period: 0.001}\n"
        "buses:\n  can0: {type: can, interface: virtual, channel: ctlstop, drives: simulated}\n"
        "axes:\n  x:\n    limits: {v_max: 0.5, a_max: 2.0, j_max: 20.0}\n"
        "    drive: {bus: can0, node_id: 3, counts_per_unit: 1.0e6}\n"
    )
    with build(load_config(cfg)) as machine:
        x = machine.axes["x"]
        power = MC_Power(axis=x, enable=True)
        mv = MC_MoveVelocity(axis=x, velocity=0.4)
        machine.attach(lambda ctx: (power(), mv(execute=power.status)))
        machine.runtime.run(seconds=0.6)
        assert x.v == pytest.approx(0.4) and x.drive_enabled
    report = machine.runtime.stop_report
    assert report is not None and report.ok and report.reason == "end of block"
    assert x.state is AxisState.DISABLED and not x.drive_enabled
    assert max(_within(machine.runtime, "x", (0.5, 2.0, 20.0))) <= 1 + 1e-6
