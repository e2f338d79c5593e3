"""Fixtures for the fieldbus tests: unique virtual CAN channels, lockstep CAN rigs."""

from __future__ import annotations

import logging
import uuid
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field

import can
import pytest

from motionplc.fieldbus.base import DriveCommand, DriveFeedback
from motionplc.fieldbus.can_faults import FaultInjectingBus
from motionplc.fieldbus.canopen_drive import CanopenDrive, CanopenDriveConfig, CanopenMaster
from motionplc.fieldbus.plant import PlantParams
from motionplc.fieldbus.virtual_cia402 import VirtualCanBus, VirtualCia402Drive

DT = 0.001


@pytest.fixture(autouse=True)
def _quiet_pymodbus() -> None:
    logging.getLogger("pymodbus").setLevel(logging.CRITICAL)


@pytest.fixture
def channel() -> str:
    return f"t-{uuid.uuid4()}"


@dataclass
class CanRig:
    """A lockstep rig: master + in-process virtual drives on one virtual channel."""

    rack: VirtualCanBus
    master: CanopenMaster
    master_bus: FaultInjectingBus
    drives: list[CanopenDrive]
    k: int = 0
    log: list[list[DriveFeedback]] = field(default_factory=list)

    @property
    def t(self) -> float:
        return self.k * DT

    def cycle(self, commands: Callable[[list[DriveFeedback]], list[DriveCommand]]) -> list:
        t = self.t
        fbs = [d.read_inputs(t) for d in self.drives]
        self.log.append(fbs)
        for d, cmd in zip(self.drives, commands(fbs), strict=True):
            d.write_outputs(t, cmd)
        self.k += 1
        return fbs

    def run(self, n: int, command: Callable[[int, list[DriveFeedback]], list[DriveCommand]]):
        fbs: list[DriveFeedback] = []
        for _ in range(n):
            k = self.k
            fbs = self.cycle(lambda f, k=k: command(k, f))
        return fbs

    def hold(self, n: int, enable: bool, position: float | None = None, reset: bool = False):
        """n cycles with the same power request, setpoint = given or actual position."""

        def cmd(k: int, fbs: list[DriveFeedback]) -> list[DriveCommand]:
            return [
                DriveCommand(
                    position=fb.position if position is None else position,
                    enable=enable,
                    fault_reset=reset,
                )
                for fb in fbs
            ]

        return self.run(n, cmd)


@pytest.fixture
def can_rig(channel: str) -> Iterator[Callable[..., CanRig]]:
    made: list[CanRig] = []

    def make(
        node_ids: tuple[int, ...] = (1,),
        plant: PlantParams | None = None,
        open_drives: bool = True,
        **cfg: object,
    ) -> CanRig:
        rack = VirtualCanBus(
            can.Bus(interface="virtual", channel=channel),
            [VirtualCia402Drive(n, plant=plant) for n in node_ids],
        )
        master_bus = FaultInjectingBus(can.Bus(interface="virtual", channel=channel))
        master = CanopenMaster(master_bus, peer=rack, heartbeat_period=0.01)
        drives = [
            CanopenDrive(f"ax{n}", master, CanopenDriveConfig(node_id=n, **cfg))  # type: ignore[arg-type]
            for n in node_ids
        ]
        if open_drives:
            for d in drives:
                d.open()
        rig = CanRig(rack, master, master_bus, drives)
        made.append(rig)
        return rig

    yield make
    for rig in made:
        rig.master.close()
        rig.rack.close()
