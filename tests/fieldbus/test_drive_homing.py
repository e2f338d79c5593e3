"""Homing by the drive over CAN: MC_Home on an axis whose CiA 402 drive homes itself (homing
mode 6, 0x6098/0x6099/0x609A/0x607C by SDO in the cycle, controlword bit 4, statusword bits
10/12/13, back to CSP), against the virtual drive's homing methods with virtual limit
switches, home switch and index pulse. Each method must end at its reference: the motor at
the right switch edge / index pulse (physical position), the axis position = home offset."""

from __future__ import annotations

import math
import uuid

import can
import pytest

from motionplc.blocks import AxisState, ErrorID, MC_Home, MC_Power, MC_Stop
from motionplc.fieldbus.canopen_drive import CanopenDrive, CanopenDriveConfig, CanopenMaster
from motionplc.fieldbus.cia402 import HomingSpec, HomingSwitches
from motionplc.fieldbus.plant import PlantState
from motionplc.fieldbus.virtual_cia402 import VirtualCanBus, VirtualCia402Drive
from motionplc.runtime import Runtime

N = 7
CPU = 1.0e6  # counts per metre
INF = math.inf
NLS, PLS = -0.2, 0.2  # limit switches [m]
CAM = (0.05, 0.08)  # home cam of methods 23..30 [m]
INDEX = (0.01, 0.003)  # index pulse pitch and offset [m]
OFFSET = 0.123  # home offset [m]
CYCLE = 0.002


def home_switch(method: int) -> tuple[float, float]:
    if method in (19, 20):
        return (CAM[0], INF)  # a positive home switch
    if method in (21, 22):
        return (-INF, CAM[0])  # a negative home switch
    return CAM


# the reference each method must find from physical position 0 (the CiA 402 method figures)
EXPECTED = {
    17: NLS,
    18: PLS,
    19: CAM[0],
    20: CAM[0],
    21: CAM[0],
    22: CAM[0],
    23: CAM[0],  # home cam, positive limit switch: left edge (falling / rising)
    24: CAM[0],
    25: CAM[1],  # right edge
    26: CAM[1],
    27: CAM[1],  # home cam, negative limit switch: right edge
    28: CAM[1],
    29: CAM[0],  # left edge
    30: CAM[0],
    33: -0.007,  # the first index pulse in the negative direction
    34: 0.003,  # ... in the positive direction
    35: 0.0,  # the current position
    37: 0.0,
}


class HomingRig:
    def __init__(
        self,
        method: int,
        switches: HomingSwitches | None,
        start: float = 0.0,
        timeout: float = 5.0,
    ):
        channel = f"t-{uuid.uuid4()}"
        self.vdrive = VirtualCia402Drive(N)
        self.vdrive.device.actual = PlantState(start * CPU, 0.0, 0.0)
        if switches is not None:
            self.vdrive.set_switches(switches)
        self.rack = VirtualCanBus(can.Bus(interface="virtual", channel=channel), [self.vdrive])
        self.master = CanopenMaster(can.Bus(interface="virtual", channel=channel), peer=self.rack)
        spec = HomingSpec(method, 0.5, 0.02, 5.0, offset=OFFSET, timeout=timeout)
        cfg = CanopenDriveConfig(node_id=N, counts_per_unit=CPU, cycle_time=CYCLE, homing=spec)
        self.drive = CanopenDrive("x", self.master, cfg)
        self.rt = Runtime(cycle=CYCLE, check_invariants=True)
        self.x = self.rt.add_axis("x", v_max=1.0, a_max=10.0, j_max=1000.0, drive=self.drive)
        self.fbs: list[object] = [MC_Power(axis=self.x, enable=True)]
        self.rt.add_task("main", lambda ctx: [fb() for fb in self.fbs])
        self.rt.run(cycles=10)
        assert self.x.drive_enabled

    def add(self, fb):  # type: ignore[no-untyped-def]
        fb.axis = self.x
        self.fbs.append(fb)
        return fb

    def close(self) -> None:
        self.master.close()
        self.rack.close()


def switches_for(method: int) -> HomingSwitches:
    return HomingSwitches(
        negative_limit=NLS * CPU,
        positive_limit=PLS * CPU,
        home_switch=tuple(b * CPU for b in home_switch(method)),  # type: ignore[arg-type]
        index_pitch=INDEX[0] * CPU,
        index_offset=INDEX[1] * CPU,
    )


@pytest.mark.parametrize("method", sorted(EXPECTED))
def test_each_method_reaches_its_reference(method: int) -> None:
    rig = HomingRig(method, switches_for(method))
    try:
        home = rig.add(MC_Home(execute=True))
        homing_seen = False

        def until() -> bool:
            nonlocal homing_seen
            homing_seen |= rig.x.state is AxisState.HOMING
            return home.done or home.error

        assert rig.rt.run_until(until, max_seconds=8.0)
        assert home.done, home.error_text
        assert homing_seen or method in (35, 37)
        phys = rig.vdrive.device.physical_position() / CPU
        assert phys == pytest.approx(EXPECTED[method], abs=2e-6)  # within 2 increments
        assert rig.x.homed and rig.x.state is AxisState.STANDSTILL
        # the axis position is the home offset (to the increment the drive reports)
        assert rig.x.position == pytest.approx(OFFSET + (phys - EXPECTED[method]), abs=1.5e-6)
        assert rig.x.offset == 0.0  # the axis position is the drive's
        assert rig.vdrive.device.mode_display == 8  # back in CSP
        assert abs(rig.x.following_error) < 1e-3
        # the axis moves normally afterwards (CSP again)
        rig.rt.run(cycles=20)
        assert rig.x.state is AxisState.STANDSTILL and not rig.x.axis_error
    finally:
        rig.close()


@pytest.mark.parametrize(
    ("method", "switches"),
    [
        (19, HomingSwitches(negative_limit=NLS * CPU, positive_limit=PLS * CPU)),  # no switch
        (21, HomingSwitches(negative_limit=NLS * CPU, home_switch=(-INF, -0.5 * CPU))),
        (
            26,
            HomingSwitches(
                negative_limit=NLS * CPU,
                positive_limit=PLS * CPU,
                home_switch=(0.5 * CPU, 0.6 * CPU),
            ),
        ),
        (33, HomingSwitches()),  # no index pulse
    ],
)
def test_missing_switch_gives_homing_failed(method: int, switches: HomingSwitches) -> None:
    rig = HomingRig(method, switches)
    try:
        home = rig.add(MC_Home(execute=True))
        assert rig.rt.run_until(lambda: home.done or home.error, max_seconds=8.0)
        assert home.error and home.error_id is ErrorID.HOMING_FAILED
        assert "homing error" in home.error_text
        assert rig.x.state is AxisState.ERROR_STOP
        assert rig.x.axis_error is ErrorID.HOMING_FAILED
        assert not rig.x.homed
        rig.rt.run(cycles=20)
        assert rig.vdrive.device.mode_display == 8  # back in CSP for the stop ramp
    finally:
        rig.close()


def test_homing_not_attained_in_time_fails() -> None:
    # a home switch far away, no limit switch: the drive searches until the time-out
    rig = HomingRig(19, HomingSwitches(home_switch=(10.0 * CPU, INF)), timeout=0.3)
    try:
        home = rig.add(MC_Home(execute=True))
        t0 = rig.rt.time
        assert rig.rt.run_until(lambda: home.done or home.error, max_seconds=2.0)
        assert home.error and home.error_id is ErrorID.HOMING_FAILED
        assert "not attained within 0.3 s" in home.error_text
        assert 0.3 <= rig.rt.time - t0 < 0.3 + 0.05  # at the time-out (+ the SDO back to CSP)
        assert rig.x.state is AxisState.ERROR_STOP
        rig.rt.run(cycles=200)
        assert rig.vdrive.device.mode_display == 8 and rig.x.v == 0.0
    finally:
        rig.close()


def test_stop_during_drive_homing_interrupts_it() -> None:
    rig = HomingRig(17, switches_for(17))
    try:
        home = rig.add(MC_Home(execute=True))
        rig.rt.run(cycles=100)
        assert rig.x.state is AxisState.HOMING and home.busy
        assert rig.vdrive.device.mode_display == 6
        stop = rig.add(MC_Stop(execute=True))
        assert rig.rt.run_until(lambda: stop.done, max_seconds=2.0)
        assert home.command_aborted
        rig.rt.run(cycles=20)
        assert rig.vdrive.device.mode_display == 8
        assert not rig.x.homed
    finally:
        rig.close()


def test_homing_spec_validation() -> None:
    with pytest.raises(ValueError, match="homing.method"):
        HomingSpec(0, 1.0, 0.1, 1.0)
    with pytest.raises(ValueError, match="homing.speed_zero"):
        HomingSpec(17, 1.0, -0.1, 1.0)
    with pytest.raises(ValueError, match="homing.acceleration"):
        HomingSpec(17, 1.0, 0.1, math.inf)
    with pytest.raises(ValueError, match="home_switch"):
        HomingSwitches(home_switch=(1.0, 0.0))


def test_drive_homing_from_yaml(tmp_path) -> None:  # type: ignore[no-untyped-def]
    """The configuration path: ``homing: {method: drive, ...}`` and the virtual drive's
    ``simulation`` switches (SI, scaled to increments by the drive's counts_per_unit)."""
    from motionplc.config import build, load_config

    f = tmp_path / "machine.yaml"
    f.write_text(
        "runtime: {tick: 0.002, clock: simulated, tasks: {main: {period: 0.002}}}\n"
        "buses:\n  can0: {type: can, interface: virtual, channel: homing}\n"
        "axes:\n  x:\n    limits: {v_max: 1.0, a_max: 10.0, j_max: 1000.0}\n"
        "    homing: {method: drive, drive_method: 24, speed_switch: 0.5, speed_zero: 0.02,\n"
        "             acceleration: 5.0, offset: -0.01, timeout: 5.0}\n"
        "    drive: {bus: can0, node_id: 3, counts_per_unit: 2.0e6}\n"
        "    simulation: {negative_limit: -0.2, positive_limit: 0.2, home_switch: [0.05, 0.08]}\n"
    )
    machine = build(load_config(f), check_invariants=True)
    try:
        x = machine.axes["x"]
        fbs = [MC_Power(axis=x, enable=True), MC_Home(axis=x)]
        machine.attach(lambda ctx: [fb() for fb in fbs])
        machine.runtime.run(cycles=10)
        fbs[1].execute = True
        assert machine.runtime.run_until(lambda: fbs[1].done or fbs[1].error, max_seconds=8.0)
        assert fbs[1].done, fbs[1].error_text
        device = machine.peers["can0"][3].device
        assert device.physical_position() / 2.0e6 == pytest.approx(0.05, abs=1e-6)
        assert x.position == pytest.approx(-0.01, abs=1e-6) and x.homed
    finally:
        machine.close()


class _ServoPeer:
    """The independent servo of tests/interop stepped in lockstep with the master."""

    def __init__(self, servo: object) -> None:
        self.servo = servo

    def step(self, t: float) -> int:
        return self.servo.process_pending()  # type: ignore[attr-defined]


@pytest.mark.parametrize(("method", "home"), [(17, -150_000.0), (18, 150_000.0), (37, 30_000.0)])
def test_drive_homing_against_the_independent_servo(method: int, home: float) -> None:
    """Homing by the drive through our master against a drive we did not write (its homing
    mode written from CiA 402 alone): the shaft ends at the switch's border (or where it
    stood), the axis position is the home offset."""
    from tests.interop.canopen_servo import CanopenServo, ServoQuirks

    channel = f"t-{uuid.uuid4()}"
    servo_bus = can.Bus(interface="virtual", channel=channel)
    servo = CanopenServo(
        servo_bus,
        N,
        quirks=ServoQuirks(has_homing=True),
        limit_switches=(-150_000.0, 150_000.0),
        position=30_000.0,
    )
    master = CanopenMaster(can.Bus(interface="virtual", channel=channel), peer=_ServoPeer(servo))
    try:
        spec = HomingSpec(method, 0.4, 0.02, 4.0, offset=OFFSET, timeout=5.0)
        cfg = CanopenDriveConfig(
            node_id=N, counts_per_unit=CPU, cycle_time=CYCLE, homing=spec, heartbeat_period=0
        )
        drive = CanopenDrive("x", master, cfg)
        rt = Runtime(cycle=CYCLE, check_invariants=True)
        x = rt.add_axis("x", v_max=1.0, a_max=10.0, j_max=1000.0, drive=drive)
        home_fb = MC_Home(axis=x)
        fbs = [MC_Power(axis=x, enable=True), home_fb]
        rt.add_task("main", lambda ctx: [fb() for fb in fbs])
        rt.run(cycles=10)
        assert x.drive_enabled
        home_fb.execute = True
        assert rt.run_until(lambda: home_fb.done or home_fb.error, max_seconds=8.0)
        assert home_fb.done, home_fb.error_text
        assert servo.shaft == pytest.approx(home, abs=2.0)
        assert x.position == pytest.approx(OFFSET, abs=2.0 / CPU) and x.homed
        assert servo.mode_display == 8
        rt.run(cycles=20)
        assert x.state is AxisState.STANDSTILL
    finally:
        master.close()
        servo_bus.shutdown()


def test_touch_probe_after_drive_homing_in_axis_coordinates() -> None:
    """Homing shifts the drive's position values, not the marks: a mark at physical 0.3 m
    is latched at 0.3 - home position + home offset (0x60BA in the new coordinates)."""
    from motionplc.blocks import MC_MoveAbsolute, MC_TouchProbe
    from motionplc.fieldbus.plant import ProbeSensor

    rig = HomingRig(19, switches_for(19))  # home: the switch edge at physical 0.05 m
    rig.vdrive.set_probe_sensor(1, ProbeSensor(marks=(0.3 * CPU,), width=1000.0))
    try:
        home = rig.add(MC_Home(execute=True))
        assert rig.rt.run_until(lambda: home.done or home.error, max_seconds=8.0)
        assert home.done, home.error_text
        tp = rig.add(MC_TouchProbe(execute=True))
        rig.add(MC_MoveAbsolute(position=0.5, velocity=0.5, execute=True))
        assert rig.rt.run_until(lambda: tp.done or tp.error, max_seconds=4.0)
        assert tp.done, tp.error_text
        assert tp.recorded_position == pytest.approx(0.3 - CAM[0] + OFFSET, abs=2e-6)
    finally:
        rig.close()
