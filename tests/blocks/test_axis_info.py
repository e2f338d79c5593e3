"""MC_ReadAxisInfo: every flag follows the axis and its drive cycle by cycle (power, homing,
the reference switch, communication, faults, warnings, simulation)."""

from __future__ import annotations

import dataclasses
import uuid
from typing import Any

import can

from motionplc.blocks import (
    AxisState,
    ErrorID,
    MC_Home,
    MC_MoveAbsolute,
    MC_Power,
    MC_ReadAxisInfo,
    MC_Reset,
)
from motionplc.blocks.params import simulated
from motionplc.fieldbus.base import DriveCommand, DriveFeedback
from motionplc.fieldbus.canopen_drive import CanopenDrive, CanopenDriveConfig, CanopenMaster
from motionplc.fieldbus.ideal import IdealDrive
from motionplc.fieldbus.modbus_drive import ModbusDrive, ModbusDriveConfig
from motionplc.fieldbus.virtual_cia402 import VirtualCanBus, VirtualCia402Drive
from motionplc.runtime import Runtime

FLAGS = MC_ReadAxisInfo._FLAGS


class WarningDrive(IdealDrive):
    """An ideal follower that reports ``warning`` while it is set."""

    def __init__(self) -> None:
        super().__init__("w")
        self.warning = ""

    def read_inputs(self, t: float) -> DriveFeedback:
        return dataclasses.replace(super().read_inputs(t), warning=self.warning)

    def write_outputs(self, t: float, command: DriveCommand) -> None:
        super().write_outputs(t, command)


class Rig:
    def __init__(self, drive: Any = None, **axis: Any) -> None:
        self.rt = Runtime(cycle=0.001)
        kw = {"v_max": 1.0, "a_max": 10.0, **axis}
        self.x = self.rt.add_axis("x", drive=drive, **kw) if drive else self.rt.add_axis("x", **kw)
        self.power = MC_Power(axis=self.x)
        self.info = MC_ReadAxisInfo(axis=self.x, enable=True)
        self.fbs: list[Any] = [self.power, self.info]
        self.rt.add_task("main", lambda ctx: [fb() for fb in self.fbs])

    def run(self, n: int = 1) -> None:
        self.rt.run(cycles=n)

    def flags(self) -> dict[str, bool]:
        return {f: getattr(self.info, f) for f in FLAGS}


def test_power_homing_and_switch_flags() -> None:
    rig = Rig(home_switch=0.3, home_velocity=0.5)
    rig.run(2)
    info = rig.info
    assert info.valid and not info.error and info.busy
    assert rig.flags() == {
        **dict.fromkeys(FLAGS, False),
        "simulation": True,
        "communication_ready": True,
        "ready_for_power_on": True,
    }
    rig.power.enable = True
    rig.run(3)
    assert info.power_on and not info.is_homed and not info.home_abs_switch
    home = MC_Home(axis=rig.x, position=0.0)
    rig.fbs.append(home)
    home.execute = True
    switch_seen = []
    for _ in range(3000):
        rig.run(1)
        switch_seen.append(info.home_abs_switch)
        if home.done:
            break
    assert home.done and any(switch_seen)  # the search passed the switch at 0.3
    rig.run(1)
    assert info.is_homed
    # after homing the switch is at 0.0 of the axis; the axis stands just past it
    ma = MC_MoveAbsolute(axis=rig.x, position=-0.2, velocity=0.5)
    rig.fbs.append(ma)
    ma.execute = True
    for _ in range(2000):
        rig.run(1)
        if ma.done:
            break
    rig.run(1)
    assert not info.home_abs_switch and info.is_homed  # below the switch
    rig.power.enable = False
    rig.run(2)
    assert not info.power_on and info.ready_for_power_on


def test_fault_communication_and_error_stop() -> None:
    drive = IdealDrive("x")
    rig = Rig(drive)
    rig.power.enable = True
    rig.run(3)
    info = rig.info
    assert info.power_on and info.ready_for_power_on
    drive.inject_fault(0x2310)
    rig.run(2)
    assert rig.x.state is AxisState.ERROR_STOP
    assert not info.ready_for_power_on and not info.power_on and info.communication_ready
    drive.clear_fault()
    reset = MC_Reset(axis=rig.x, execute=True)
    rig.fbs.append(reset)
    rig.run(5)
    assert rig.x.state is AxisState.STANDSTILL and info.ready_for_power_on and info.power_on
    drive.set_comm_ok(False)
    rig.run(2)
    assert not info.communication_ready and not info.ready_for_power_on
    assert rig.x.axis_error is ErrorID.COMMUNICATION_LOST


def test_warning_flag_and_enable_resets() -> None:
    drive = WarningDrive()
    rig = Rig(drive)
    rig.run(2)
    assert not rig.info.axis_warning
    drive.warning = "EMCY 0x4210 (temperature)"
    rig.run(2)
    assert rig.info.axis_warning
    drive.warning = ""
    rig.run(2)
    assert not rig.info.axis_warning
    drive.warning = "again"
    rig.run(2)
    rig.info.enable = False
    rig.run(1)
    assert not rig.info.valid and not rig.info.busy
    assert rig.flags() == dict.fromkeys(FLAGS, False)


def test_no_axis_is_an_error() -> None:
    rt = Runtime(cycle=0.001)
    rt.add_axis("x", v_max=1.0, a_max=1.0)
    info = MC_ReadAxisInfo(enable=True)
    rt.add_task("main", lambda ctx: info())
    rt.run(cycles=1)
    assert info.error and info.error_id is ErrorID.INVALID_AXIS and not info.valid


def test_simulation_flag_by_drive_kind() -> None:
    channel = f"ai-{uuid.uuid4()}"
    rack = VirtualCanBus(can.Bus(interface="virtual", channel=channel), [VirtualCia402Drive(1)])
    master = CanopenMaster(can.Bus(interface="virtual", channel=channel), peer=rack)
    external = CanopenMaster(can.Bus(interface="virtual", channel=f"{channel}-x"))
    try:
        assert simulated(IdealDrive("x"))
        assert simulated(CanopenDrive("a", master, CanopenDriveConfig(node_id=1)))
        assert not simulated(CanopenDrive("b", external, CanopenDriveConfig(node_id=2)))
        assert simulated(ModbusDrive("m", ModbusDriveConfig(port=1502), peer=object()))
        assert not simulated(ModbusDrive("n", ModbusDriveConfig(port=1502)))
    finally:
        master.close()
        external.close()
        rack.close()
