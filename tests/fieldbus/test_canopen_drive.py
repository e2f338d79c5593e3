"""Our CANopen master driving our virtual CiA 402 drives, lockstep with manual time."""

from __future__ import annotations

from collections.abc import Callable

import can
import pytest

from motionplc.fieldbus.base import DriveCommand, DriveFeedback, FieldbusError
from motionplc.fieldbus.canopen_drive import (
    CanopenDrive,
    CanopenDriveConfig,
    CanopenMaster,
    interpolation_period_code,
)
from motionplc.fieldbus.virtual_cia402 import VirtualCanBus, VirtualCia402Drive

from .conftest import DT, CanRig

V = 0.05  # m/s ramp
CPU = 1.0e6  # counts per m


def enable_all(rig: CanRig, limit: int = 10) -> list[DriveFeedback]:
    for _ in range(limit):
        fbs = rig.hold(1, enable=True)
        if all(fb.enabled for fb in fbs):
            return fbs
    raise AssertionError(f"not enabled: {rig.log[-1]}")


def ramp(rig: CanRig, n: int, v: float = V) -> tuple[list[float], list[list[DriveFeedback]]]:
    """n cycles of a constant-velocity ramp from the actual position; returns the setpoints."""
    start = rig.log[-1][0].position
    setpoints: list[float] = []
    fbs_log: list[list[DriveFeedback]] = []
    for i in range(n):
        sp = start + v * DT * (i + 1)
        setpoints.append(sp)
        fbs_log.append(
            rig.cycle(lambda fbs, sp=sp: [DriveCommand(sp, v, enable=True) for _ in fbs])
        )
    return setpoints, fbs_log


def test_interpolation_period_codes() -> None:
    assert interpolation_period_code(0.001) == (1, -3)
    assert interpolation_period_code(0.004) == (4, -3)
    assert interpolation_period_code(0.0025) == (25, -4)
    with pytest.raises(ValueError):
        interpolation_period_code(0.3)


def test_config_validation() -> None:
    with pytest.raises(ValueError, match="node_id"):
        CanopenDriveConfig(node_id=0)
    with pytest.raises(ValueError, match="cycle_time"):
        CanopenDriveConfig(node_id=1, cycle_time=0.0)


def test_setup_configures_the_drive(can_rig: Callable[..., CanRig]) -> None:
    rig = can_rig((2,), following_error_window=0.002, following_error_timeout=0.004)
    vd = rig.rack[2]
    assert vd.nmt_state == "OPERATIONAL"
    assert vd.device.mode_display == 8
    assert vd.interpolation_period == pytest.approx(0.001)
    assert vd.comm_cycle_period == pytest.approx(0.001)
    assert vd.device.following_error_window == 2000
    assert vd.device.following_error_timeout == pytest.approx(0.004)
    assert [(v.index) for v in vd.node.tpdo[2].map] == [0x606C, 0x603F]


def test_enable_follow_ramp_disable(can_rig: Callable[..., CanRig]) -> None:
    rig = can_rig((1,))
    fbs = rig.hold(1, enable=False)
    assert not fbs[0].enabled and fbs[0].comm_ok
    enable_all(rig)
    assert rig.k <= 6  # SOD -> RTSO -> SO -> OE, one transition per cycle
    setpoints, log = ramp(rig, 300)
    plant = rig.rack[1].device.plant
    lag = plant.following_error(V * CPU) / CPU
    # transport delay: feedback read in cycle k+1 reflects the setpoint written in cycle k
    for i in range(200, 299):
        fb = log[i + 1][0]
        assert fb.enabled and not fb.stale and fb.comm_ok
        assert setpoints[i] - fb.position == pytest.approx(lag, abs=2e-6)
        assert fb.velocity == pytest.approx(V, rel=1e-3)
    # every cycle stays within the plant's bound (start-up transient included)
    bound = plant.following_error(V * CPU, plant.a_max) / CPU
    assert max(sp - lg[0].position for sp, lg in zip(setpoints[:-1], log[1:], strict=True)) <= (
        bound
    )
    fbs = rig.hold(3, enable=False)
    assert not fbs[0].enabled and not fbs[0].fault
    assert rig.rack[1].device.state.name == "READY_TO_SWITCH_ON"


def test_four_axes_without_cross_talk(can_rig: Callable[..., CanRig]) -> None:
    rig = can_rig((1, 2, 3, 4))
    enable_all(rig)
    targets = [0.001, -0.002, 0.003, 0.0]
    fbs = rig.run(
        400, lambda k, f: [DriveCommand(min(k / 300.0, 1.0) * t, enable=True) for t in targets]
    )
    for fb, target in zip(fbs, targets, strict=True):
        assert fb.position == pytest.approx(target, abs=2e-6)
    assert rig.master.sync_sent == rig.k  # one SYNC per cycle for all four axes


def test_drive_fault_reported_and_reset(can_rig: Callable[..., CanRig]) -> None:
    rig = can_rig((1,))
    enable_all(rig)
    ramp(rig, 20)
    rig.rack[1].inject_fault(0x2310, persistent=True)
    fbs = rig.hold(1, enable=True)
    assert not fbs[0].fault  # the TPDO of the next SYNC carries it
    fbs = rig.hold(1, enable=True)
    assert fbs[0].fault and fbs[0].error_code == 0x2310 and fbs[0].comm_ok
    assert "0x2310" in fbs[0].detail
    fbs = rig.hold(60, enable=True)
    assert fbs[0].fault and not fbs[0].enabled  # stays in FAULT
    fbs = rig.hold(6, enable=False, reset=True)
    assert fbs[0].fault  # fault still present: reset refused
    rig.rack[1].clear_fault()
    fbs = rig.hold(6, enable=False, reset=True)
    assert not fbs[0].fault and fbs[0].error_code == 0 and fbs[0].comm_ok
    enable_all(rig)


def test_following_error_exceeded(can_rig: Callable[..., CanRig]) -> None:
    rig = can_rig((1,), following_error_window=0.001, following_error_timeout=0.003)
    enable_all(rig)
    rig.rack[1].device.stalled = True  # jammed mechanics
    fbs: list[DriveFeedback] = []
    for _ in range(40):
        fbs = rig.cycle(lambda f: [DriveCommand(f[0].position + 0.0005 * rig.k, enable=True)])
        if fbs[0].fault:
            break
    assert fbs[0].fault and fbs[0].error_code == 0x8611 and fbs[0].comm_ok


def test_heartbeat_loss(can_rig: Callable[..., CanRig]) -> None:
    rig = can_rig((1,), heartbeat_period=0.01)
    enable_all(rig)
    rig.hold(30, enable=True)
    rig.rack.stop_heartbeat(1)
    last_beat = rig.drives[0].node.nmt.timestamp
    assert last_beat is not None
    for _ in range(40):
        t = rig.t
        fbs = rig.hold(1, enable=True)
        if not fbs[0].comm_ok:
            break
        assert t - last_beat <= 1.5 * 0.01 + 1e-9
    assert not fbs[0].comm_ok and fbs[0].error_code == 0x8130
    assert "heartbeat" in fbs[0].detail
    assert t - last_beat <= 1.5 * 0.01 + DT  # offline within 1.5 x 0x1017


def test_dropped_and_late_tpdos(can_rig: Callable[..., CanRig]) -> None:
    rig = can_rig((1,), tpdo_loss_limit=3)
    enable_all(rig)
    rig.rack.faults.drop_tx_ids.add(0x181)
    fbs = rig.hold(1, enable=True)
    assert not fbs[0].stale  # answer to the SYNC before the drop
    fbs = rig.hold(1, enable=True)
    assert fbs[0].stale and fbs[0].comm_ok  # flagged within one cycle
    fbs = rig.hold(3, enable=True)
    assert not fbs[0].comm_ok and fbs[0].error_code == 0x8250
    rig.rack.faults.drop_tx_ids.clear()
    fbs = rig.hold(2, enable=True)
    assert fbs[0].comm_ok and not fbs[0].stale
    # late frames: TPDO1 held one cycle -> one stale cycle, then one extra cycle of delay
    rig.rack.faults.delay_tx[0x181] = 1
    log = [rig.hold(1, enable=True)[0] for _ in range(6)]
    assert [fb.stale for fb in log] == [False, True, False, False, False, False]
    assert all(fb.comm_ok and fb.enabled for fb in log)


def test_dropped_rpdos_fault_the_drive(can_rig: Callable[..., CanRig]) -> None:
    rig = can_rig((1,))
    enable_all(rig)
    rig.master_bus.drop_tx_ids.add(0x201)
    fbs = rig.hold(2, enable=True)
    assert not fbs[0].fault  # one lost RPDO: the drive holds
    fbs = rig.hold(3, enable=True)
    assert fbs[0].fault and fbs[0].error_code == 0x8250


def test_sync_loss_faults_the_drive(can_rig: Callable[..., CanRig]) -> None:
    rig = can_rig((1,))
    enable_all(rig)
    rig.master.sync_enabled = False
    rig.hold(3, enable=True)
    rig.master.sync_enabled = True
    fbs = rig.hold(2, enable=True)
    assert fbs[0].fault and fbs[0].error_code == 0x8700


def test_bus_off_latches_until_reset(can_rig: Callable[..., CanRig]) -> None:
    rig = can_rig((1, 2))
    enable_all(rig)
    rig.master_bus.bus_off = True
    fbs = rig.hold(3, enable=True)
    assert all(not fb.comm_ok and fb.error_code == 0x8140 for fb in fbs)
    assert all(not fb.enabled for fb in fbs)
    rig.master_bus.bus_off = False
    fbs = rig.hold(3, enable=True)
    assert all(not fb.comm_ok for fb in fbs)  # no automatic re-enable
    assert all("reset required" in fb.detail for fb in fbs)
    fbs = rig.hold(8, enable=False, reset=True)
    assert all(fb.comm_ok and not fb.fault for fb in fbs), fbs
    enable_all(rig)


def test_drive_side_bus_off_and_recovery_emcy(can_rig: Callable[..., CanRig]) -> None:
    rig = can_rig((1,))
    enable_all(rig)
    rig.rack.faults.bus_off = True
    fbs = rig.hold(6, enable=True)
    assert not fbs[0].comm_ok and fbs[0].stale
    rig.rack.faults.bus_off = False
    fbs = rig.hold(2, enable=True)
    assert fbs[0].fault  # the drive lost the SYNC meanwhile
    assert rig.drives[0].emcy_code in (0x8140, 0x8700)
    fbs = rig.hold(8, enable=False, reset=True)
    assert not fbs[0].fault and fbs[0].comm_ok


def test_sdo_abort_during_setup_is_a_configuration_error(channel: str) -> None:
    rack = VirtualCanBus(can.Bus(interface="virtual", channel=channel), [VirtualCia402Drive(1)])
    rack[1].device.set_mode = lambda mode: False  # type: ignore[method-assign]
    master = CanopenMaster(can.Bus(interface="virtual", channel=channel), peer=rack)
    try:
        drive = CanopenDrive("ax", master, CanopenDriveConfig(node_id=1))
        with pytest.raises(FieldbusError) as err:
            drive.open()
        assert str(err.value) == (
            "ax: node 1: SDO write 0x6060:00 aborted 0x06090030 (value range of parameter exceeded)"
        )
        fb = drive.read_inputs(0.0)
        assert not fb.comm_ok and not fb.enabled
    finally:
        master.close()
        rack.close()


def test_setup_timeout_without_drive(channel: str) -> None:
    master = CanopenMaster(can.Bus(interface="virtual", channel=channel), sdo_timeout=0.02)
    try:
        drive = CanopenDrive("ax", master, CanopenDriveConfig(node_id=9))
        with pytest.raises(FieldbusError) as err:
            drive.open()
        assert str(err.value) == "ax: node 9: SDO read 0x1000:00: no answer within 0.02 s"
    finally:
        master.close()
