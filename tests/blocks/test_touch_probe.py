"""MC_TouchProbe / MC_AbortTrigger on in-process drives (ideal drive, virtual CiA 402 device).

The latched position is checked against the true edge: the mark a virtual sensor switches at,
crossed by the axis' jerk-limited profile (planned independently here with the same limits).
The latch must be within one cycle's motion of it (the interpolation of the drive between its
position samples); the measured maximum is printed (``-s``) for the report.
"""

from __future__ import annotations

import math

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from motionplc.blocks import (
    ErrorID,
    MC_AbortTrigger,
    MC_MoveAbsolute,
    MC_MoveVelocity,
    MC_Power,
    MC_SetPosition,
    MC_TouchProbe,
    TriggerRef,
)
from motionplc.blocks.motion import StaticAxis
from motionplc.fieldbus.ideal import IdealDrive
from motionplc.fieldbus.plant import PlantParams, ProbeSensor
from motionplc.fieldbus.virtual_device import Cia402Device
from motionplc.planning import Limits, State, plan
from motionplc.runtime import Runtime


class Rig:
    """One axis on an ideal drive with probe sensors; FBs called every scan."""

    def __init__(self, cycle: float = 0.001, sensor: ProbeSensor | None = None, **axis: object):
        self.rt = Runtime(cycle=cycle, check_invariants=True)
        self.drive = IdealDrive("x", probes={1: sensor} if sensor is not None else None)
        kw = {"v_max": 2.0, "a_max": 20.0, "j_max": 1000.0, **axis}
        self.x = self.rt.add_axis("x", drive=self.drive, **kw)
        self.fbs: list[object] = [MC_Power(axis=self.x, enable=True)]
        self.rt.add_task("main", self._program)
        self.rt.run(cycles=2)

    def _program(self, ctx: object) -> None:
        for fb in self.fbs:
            fb()

    def add(self, fb):  # type: ignore[no-untyped-def]
        fb.axis = self.x
        self.fbs.append(fb)
        return fb

    def run(self, cycles: int = 1) -> None:
        self.rt.run(cycles=cycles)

    def run_until(self, cond, seconds: float = 5.0) -> None:  # type: ignore[no-untyped-def]
        assert self.rt.run_until(cond, max_seconds=seconds)


def crossing_time(prof, p: float) -> float:  # type: ignore[no-untyped-def]
    """First time the (monotonic, rising) profile passes ``p`` (bisection)."""
    lo, hi = 0.0, prof.duration
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        if prof.at(mid)[0] < p:
            lo = mid
        else:
            hi = mid
    return 0.5 * (lo + hi)


ERRORS: list[tuple[float, float]] = []  # (latched error, one cycle's motion at the edge)


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    cycle=st.sampled_from([0.0005, 0.001, 0.002, 0.004]),
    mark=st.floats(0.02, 0.95),
    v=st.floats(0.2, 2.0),
    a=st.floats(2.0, 20.0),
    j=st.floats(20.0, 1000.0),
)
def test_latched_position_within_one_cycle_of_the_true_edge(
    cycle: float, mark: float, v: float, a: float, j: float
) -> None:
    rig = Rig(cycle, ProbeSensor(marks=(mark,), width=0.01), v_max=v, a_max=a, j_max=j)
    tp = rig.add(MC_TouchProbe(execute=True))
    mv = rig.add(MC_MoveAbsolute(position=1.0, velocity=v, execute=True))
    rig.run_until(lambda: tp.done or tp.error, seconds=30.0)
    assert tp.done and not tp.error
    # the true motion: the same jerk-limited profile, planned here
    prof = plan(State(0.0), State(1.0), Limits(v_max=v, a_max=a, j_max=j))
    t_edge = crossing_time(prof, mark)
    step = abs(prof.at(t_edge)[1]) * cycle  # one cycle's motion at the edge
    err = abs(tp.recorded_position - mark)
    ERRORS.append((err, step))
    assert err <= step
    # the interpolation between two samples of a motion with |acc| <= a: a * dt^2 / 8
    assert err <= a * cycle**2 / 8.0 * 1.01 + 1e-12
    assert mv.busy or mv.done


def test_report_latched_error() -> None:
    if not ERRORS:
        pytest.skip("run with the property test")
    worst = max(e for e, _ in ERRORS)
    ratio = max(e / s for e, s in ERRORS if s > 0)
    print(  # noqa: T201 - the figure for the report (pytest -s)
        f"\ntouch probe (ideal drive): max |latched - edge| = {worst:.3e} m over {len(ERRORS)}"
        f" runs; max fraction of one cycle's motion = {ratio:.3e}"
    )


def test_window_skips_edges_outside_it() -> None:
    web = ProbeSensor(first=0.1, pitch=0.1, width=0.01)
    rig = Rig(sensor=web)
    tp = rig.add(MC_TouchProbe(window_only=True, first_position=0.35, last_position=0.45))
    tp.execute = True
    rig.add(MC_MoveAbsolute(position=1.0, velocity=1.0, execute=True))
    rig.run_until(lambda: tp.done or tp.error)
    assert tp.done
    assert tp.recorded_position == pytest.approx(0.4, abs=1e-4)
    # window bounds are inclusive: a window of one point at the mark
    rig2 = Rig(sensor=web)
    tp2 = rig2.add(MC_TouchProbe(window_only=True, first_position=0.5, last_position=0.5))
    tp2.execute = True
    rig2.add(MC_MoveVelocity(velocity=1.0, execute=True))
    rig2.run_until(lambda: tp2.done or tp2.error)
    assert abs(tp2.recorded_position - 0.5) <= 1e-3  # the latched edge, within one cycle


@pytest.mark.parametrize(
    ("first", "last", "expected"),
    [(0.7, 0.1, 0.75), (0.9, 0.1, 0.0), (0.2, 0.4, 0.25), (0.3, 0.6, 0.5)],
)
def test_modulo_window_may_wrap(first: float, last: float, expected: float) -> None:
    # marks at 0.05 + k/4 in drive coordinates on a modulo-1 axis; after MC_SetPosition(0.2)
    # the axis position is the drive position + 0.2: marks at 0.25, 0.5, 0.75, 0.0 (wrapped)
    rig = Rig(sensor=ProbeSensor(first=0.05, pitch=0.25, width=0.01), modulo=1.0)
    sp = rig.add(MC_SetPosition(position=0.2, execute=True))
    rig.run(2)
    sp.execute = False
    tp = rig.add(MC_TouchProbe(window_only=True, first_position=first, last_position=last))
    tp.execute = True
    rig.add(MC_MoveVelocity(velocity=1.0, execute=True))
    rig.run_until(lambda: tp.done or tp.error)
    assert tp.done
    assert 0.0 <= tp.recorded_position < 1.0
    d = (tp.recorded_position - expected + 0.5) % 1.0 - 0.5  # distance on the circle
    assert abs(d) <= 1e-4


def test_recorded_position_in_axis_coordinates_and_falling_edge() -> None:
    rig = Rig(sensor=ProbeSensor(marks=(0.3,), width=0.02))
    rig.add(MC_SetPosition(position=5.0, execute=True))
    rig.run(2)
    tp = rig.add(MC_TouchProbe(trigger_input=TriggerRef(1, "falling"), execute=True))
    rig.add(MC_MoveAbsolute(position=6.0, velocity=1.0, execute=True))
    rig.run_until(lambda: tp.done or tp.error)
    assert tp.recorded_position == pytest.approx(5.32, abs=1e-4)  # mark end, shifted by 5


def test_abort_trigger_and_retrigger() -> None:
    rig = Rig(sensor=ProbeSensor(marks=(10.0,), width=0.01))
    tp = rig.add(MC_TouchProbe(execute=True))
    rig.run(3)
    assert tp.busy and rig.x.probe_jobs and rig.x._ideal is None  # the object path while armed
    ab = rig.add(MC_AbortTrigger(trigger_input=1, execute=True))
    rig.run(2)
    assert ab.done and not ab.error
    assert tp.command_aborted and not tp.busy and not tp.done
    assert not rig.x.probe_jobs and rig.x._ideal is rig.drive  # the fast path again
    # a second MC_TouchProbe on the same input takes it over: the first is aborted
    tp.execute = False
    rig.run(1)
    tp.execute = True
    rig.run(1)
    tp2 = rig.add(MC_TouchProbe(execute=True))
    rig.run(2)
    assert tp.command_aborted and tp2.busy
    # MC_AbortTrigger with nothing armed on probe 2: Done, no effect on probe 1
    ab2 = rig.add(MC_AbortTrigger(trigger_input=TriggerRef(2), execute=True))
    rig.run(2)
    assert ab2.done and tp2.busy


def test_program_set_input_is_an_edge_at_the_end_of_the_cycle() -> None:
    rig = Rig()
    rig.add(MC_MoveVelocity(velocity=0.5, execute=True))
    rig.run(100)
    tp = rig.add(MC_TouchProbe(execute=True))
    rig.run(5)
    assert tp.busy
    rig.drive.set_probe_input(1, True)
    rig.run(1)  # the next write scans the edge
    p_at_edge = rig.drive._position + rig.x.offset
    rig.run(2)
    assert tp.done
    assert tp.recorded_position == pytest.approx(p_at_edge, abs=1e-12)


@pytest.mark.parametrize(
    ("inputs", "pin"),
    [
        ({"trigger_input": 3}, "trigger_input"),
        ({"trigger_input": "probe1"}, "trigger_input"),
        ({"trigger_input": {"probe": 1, "edge": "up"}}, "trigger_input"),
        ({"window_only": True, "first_position": 2.0, "last_position": 1.0}, "last_position"),
        ({"window_only": True, "first_position": math.nan}, "first_position"),
    ],
)
def test_bad_inputs_give_invalid_trigger(inputs: dict, pin: str) -> None:
    rig = Rig()
    tp = rig.add(MC_TouchProbe(**inputs))
    tp.execute = True
    rig.run(1)
    assert tp.error and tp.error_id is ErrorID.INVALID_TRIGGER
    assert pin.split("_")[0] in tp.error_text or "trigger" in tp.error_text
    assert not rig.x.probe_jobs
    # the same check without a running axis (motionplc validate)
    problems = MC_TouchProbe(**inputs).input_problems(StaticAxis(rig.x.cfg))
    assert problems[pin].error_id is ErrorID.INVALID_TRIGGER


def test_trigger_ref_validation() -> None:
    with pytest.raises(ValueError, match="probe must be 1..2"):
        TriggerRef(0)
    with pytest.raises(ValueError, match="edge"):
        TriggerRef(1, "both")
    with pytest.raises(ValueError, match="width"):
        ProbeSensor(marks=(0.0,), width=0.0)
    with pytest.raises(ValueError, match="overlap"):
        ProbeSensor(marks=(0.0, 0.005), width=0.01)


def test_cia402_device_probe_latches_plant_motion() -> None:
    """The virtual CiA 402 device: 0x60B8 arms, 0x60B9 shows the stored edge, the value is
    the plant's motion interpolated at the edge (increments)."""
    dev = Cia402Device(PlantParams())
    dev.following_error_window = 0xFFFFFFFF  # the step in the setpoint speed is no fault
    dev.set_mode(8)
    for cw in (0x06, 0x07, 0x0F):
        dev.apply_controlword(cw)
    mark = 123_456.0
    dev.probes[1].sensor = ProbeSensor(marks=(mark,), width=1000.0)
    dev.write_probe_function(0x0031)  # probe 1 on, first event, both edges
    assert dev.probe_status() == 0x0001
    dt, v, p = 0.001, 2.0e6, 0.0  # 2e6 inc/s ramp of the setpoint
    worst = 0.0
    samples: list[float] = []
    for _ in range(200):
        p += v * dt
        before = dev.actual.position
        dev.latch(round(p))
        dev.cycle(dt)
        samples.append(dev.actual.position - before)
        if dev.probe_status() & 0x06 == 0x06:
            break
    assert dev.probe_status() == 0x0007
    step = max(samples)
    worst = max(abs(dev.probe_value(1, True) - mark), abs(dev.probe_value(1, False) - mark - 1000))
    assert worst <= step  # within one cycle's motion
    # re-arm by setting bit 4 again: the stored positive flag clears
    dev.write_probe_function(0x0021)
    dev.write_probe_function(0x0031)
    assert dev.probe_status() == 0x0005
    dev.write_probe_function(0)
    assert dev.probe_status() == 0
    with pytest.raises(ValueError, match="trigger source"):
        dev.write_probe_function(0x0005)


def test_probe_sensor_from_yaml(tmp_path) -> None:  # type: ignore[no-untyped-def]
    """``axes.<name>.simulation.probe1`` wires the ideal drive's probe input."""
    from motionplc.config import build, load_config

    f = tmp_path / "machine.yaml"
    f.write_text(
        "runtime: {tick: 0.001, clock: simulated, tasks: {main: {period: 0.001}}}\n"
        "axes:\n  x:\n    limits: {v_max: 1.0, a_max: 10.0, j_max: 100.0}\n"
        "    simulation:\n      probe1: {first: 0.25, pitch: 0.5, width: 0.01}\n"
    )
    machine = build(load_config(f), check_invariants=True)
    try:
        x = machine.axes["x"]
        tp = MC_TouchProbe(axis=x, trigger_input={"probe": 1, "edge": "falling"})
        fbs = [MC_Power(axis=x, enable=True), tp, MC_MoveVelocity(axis=x, velocity=0.5)]
        machine.attach(lambda ctx: [fb() for fb in fbs])
        machine.runtime.run(cycles=3)
        tp.execute = fbs[2].execute = True
        assert machine.runtime.run_until(lambda: tp.done or tp.error, max_seconds=2.0)
        assert tp.done and tp.recorded_position == pytest.approx(0.26, abs=1e-6)
    finally:
        machine.close()
