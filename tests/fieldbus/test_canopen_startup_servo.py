"""Our CANopen master against the independent CiA 402 servo of ``tests/interop`` (its public
API only: constructor, ``ServoQuirks``, ``process_pending``, ``reboot``, ``stop_heartbeat``,
``write_eds``, ``od_value``, ``mapping``, ``nmt_state``, ``mode_display``)."""

from __future__ import annotations

from collections.abc import Callable, Iterator
from pathlib import Path

import can
import pytest

from motionplc.fieldbus.base import DriveCommand, DriveFeedback, FieldbusError
from motionplc.fieldbus.canopen_drive import CanopenDrive, CanopenDriveConfig, CanopenMaster
from tests.interop.canopen_servo import CanopenServo, ServoQuirks

N = 5
DT = 0.001


class ServoPeer:
    """The servo stepped in lockstep with the master (it handles what is queued)."""

    def __init__(self, servo: CanopenServo) -> None:
        self.servo = servo

    def step(self, t: float) -> int:
        return self.servo.process_pending()


class Rig:
    def __init__(self, channel: str, quirks: ServoQuirks | None = None) -> None:
        self.servo_bus = can.Bus(interface="virtual", channel=channel)
        self.servo = CanopenServo(self.servo_bus, N, quirks=quirks)
        self.master = CanopenMaster(
            can.Bus(interface="virtual", channel=channel),
            peer=ServoPeer(self.servo),
            heartbeat_period=0.01,
        )
        self.drive: CanopenDrive | None = None
        self.k = 0

    def open(self, **cfg: object) -> CanopenDrive:
        self.drive = CanopenDrive("ax", self.master, CanopenDriveConfig(node_id=N, **cfg))  # type: ignore[arg-type]
        self.drive.open()
        return self.drive

    def cycle(self, enable: bool, reset: bool = False) -> DriveFeedback:
        assert self.drive is not None
        t = self.k * DT
        fb = self.drive.read_inputs(t)
        self.drive.write_outputs(t, DriveCommand(fb.position, enable=enable, fault_reset=reset))
        self.k += 1
        return fb

    def hold(self, n: int, enable: bool) -> DriveFeedback:
        fb = self.cycle(enable)
        for _ in range(n - 1):
            fb = self.cycle(enable)
        return fb


@pytest.fixture
def make(channel: str) -> Iterator[Callable[..., Rig]]:
    rigs: list[Rig] = []

    def factory(quirks: ServoQuirks | None = None) -> Rig:
        rig = Rig(channel, quirks)
        rigs.append(rig)
        return rig

    yield factory
    for rig in rigs:
        rig.master.close()
        rig.servo_bus.shutdown()


def test_plain_servo_runs_with_its_own_eds(make: Callable[..., Rig], tmp_path: Path) -> None:
    rig = make()
    eds = rig.servo.write_eds(tmp_path / "cs402.eds")
    d = rig.open(eds=str(eds))
    assert d.identity is not None and d.identity.vendor_id == 0x00000C5E
    assert rig.servo.mapping("tpdo", 1) == ((0x6041, 0, 16), (0x6064, 0, 32))
    assert rig.servo.mapping("rpdo", 1) == ((0x6040, 0, 16), (0x607A, 0, 32))
    fb = rig.hold(10, enable=True)
    assert fb.enabled and fb.comm_ok and not fb.stale


def test_servo_with_every_quirk(make: Callable[..., Rig]) -> None:
    quirks = ServoQuirks(
        mode_display_delay=3,
        has_6502=False,
        has_1006=False,
        heartbeat=False,
        tpdo_bit30_required=True,
        map_603f=False,
        rpdo_bit30=True,
    )
    rig = make(quirks)
    d = rig.open(heartbeat_period=0.0, guard_time=0.01)
    log = d.startup_log
    assert sum(line.startswith("SDO read 0x6061:00") for line in log) == 4
    assert any(line.startswith("SDO read 0x6502:00 skipped") for line in log)
    assert any(line.startswith("SDO write 0x1006:00 skipped") for line in log)
    assert "tpdo2: 0x603F left out: the drive cannot map it (0x1A01:02 aborted 0x06040041)" in log
    assert rig.servo.mapping("tpdo", 2) == ((0x606C, 0, 32),)
    assert rig.servo.od_value(0x1800, 1) & 0x40000000  # bit 30 kept as the drive wants it
    assert rig.servo.od_value(0x1400, 1) & 0x40000000  # reserved bit kept on the RPDO
    fb = rig.hold(30, enable=True)
    assert fb.enabled and fb.comm_ok and not fb.stale
    assert d.guard_toggle_errors == 0


def test_servo_reboot_then_mc_reset_reconfigures(make: Callable[..., Rig]) -> None:
    rig = make()
    rig.open()
    fb = rig.hold(20, enable=True)
    assert fb.enabled
    rig.servo.reboot()
    fb = rig.hold(3, enable=True)
    assert not fb.comm_ok and fb.kind == "heartbeat"
    assert fb.detail == "node 5 rebooted: configuration lost, MC_Reset re-configures it"
    assert rig.servo.mapping("tpdo", 1) == ((0x6041, 0, 16),)  # factory mapping
    rig.cycle(False, reset=True)
    pending = []
    for _ in range(200):
        fb = rig.cycle(False)
        pending.append(fb.reset_pending)
        if not fb.reset_pending:
            break
    assert pending[-1] is False and all(pending[:-1]) and len(pending) > 20
    assert fb.comm_ok and not fb.fault
    # the drive's own dictionary, read over SDO by the servo's API: our layout again
    assert rig.servo.mapping("tpdo", 1) == ((0x6041, 0, 16), (0x6064, 0, 32))
    assert rig.servo.mapping("tpdo", 2) == ((0x606C, 0, 32), (0x603F, 0, 16))
    assert rig.servo.mode_display == 8
    assert rig.servo.od_value(0x1017) == 50
    fb = rig.hold(10, enable=True)
    assert fb.enabled and fb.comm_ok


def test_servo_heartbeat_loss(make: Callable[..., Rig]) -> None:
    rig = make()
    rig.open(heartbeat_period=0.01)
    rig.hold(20, enable=True)
    rig.servo.stop_heartbeat()
    fb = rig.hold(30, enable=True)
    assert not fb.comm_ok and fb.kind == "heartbeat"
    assert fb.detail == "heartbeat of node 5 lost"


def test_servo_heartbeat_only_without_1017_is_a_located_error(make: Callable[..., Rig]) -> None:
    rig = make(ServoQuirks(heartbeat=False))
    with pytest.raises(FieldbusError) as err:
        rig.open()
    assert str(err.value) == (
        "ax: node 5: SDO write 0x1017:00 aborted 0x06020000 (object does not exist in the "
        "object dictionary)"
    )


def test_warning_emcy_is_a_warning_not_a_fault(make: Callable[..., Rig]) -> None:
    rig = make()
    rig.open()
    rig.hold(10, enable=True)
    rig.servo.warn(0x4210)
    fb = rig.hold(2, enable=True)
    assert fb.enabled and not fb.fault and fb.comm_ok and fb.warning == "EMCY 0x4210"
    rig.servo.clear_warning()
    fb = rig.hold(2, enable=True)
    assert fb.warning == ""


def _threaded_run(channel: str) -> list[tuple[float, float, bool]]:
    """The servo in its own thread (an external drive), the master on the simulated clock."""
    servo_bus = can.Bus(interface="virtual", channel=channel)
    servo = CanopenServo(servo_bus, N)
    servo.start(poll_s=0.001)
    master = CanopenMaster(can.Bus(interface="virtual", channel=channel), sdo_timeout=0.5)
    out = []
    try:
        drive = CanopenDrive("ax", master, CanopenDriveConfig(node_id=N, heartbeat_period=0.0))
        drive.bind_clock(False)
        drive.open()
        for k in range(150):
            t = k * DT
            fb = drive.read_inputs(t)
            out.append((fb.position, fb.velocity, fb.stale))
            target = 0.002 * min(1.0, k / 100.0)
            drive.write_outputs(t, DriveCommand(target if fb.enabled else fb.position, enable=True))
        assert master.external_waits == 0
    finally:
        master.close()
        servo.stop()
        servo_bus.shutdown()
    return out


def test_external_servo_thread_runs_are_reproducible() -> None:
    import uuid

    first = _threaded_run(f"t-{uuid.uuid4()}")
    second = _threaded_run(f"t-{uuid.uuid4()}")
    assert first == second
    assert not any(stale for _, _, stale in first[3:])
    assert first[-1][0] == pytest.approx(0.002, abs=2e-5)
