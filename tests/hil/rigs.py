"""Hardware-in-the-loop rigs: a Runtime whose axes sit on real fieldbus masters talking to the
virtual drives in the same process, lock-stepped with the simulated clock.

* ``can``: our CANopen master (:class:`CanopenMaster`) and virtual CiA 402 drives
  (:class:`VirtualCanBus`) on a python-can ``virtual`` channel unique to the rig;
* ``modbus``: our Modbus master (:class:`ModbusDrive`) and one virtual Modbus drive server per
  axis on 127.0.0.1 (ephemeral ports);
* ``ideal``: the in-process ideal drive (the reference for the commanded trace).

Every rig is closed by :meth:`HilRig.close` (buses shut down, servers stopped, bounded waits).
"""

from __future__ import annotations

import math
import uuid
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import can

from motionplc.blocks import MC_Power
from motionplc.fieldbus.can_faults import FaultInjectingBus
from motionplc.fieldbus.canopen_drive import CanopenDrive, CanopenDriveConfig, CanopenMaster
from motionplc.fieldbus.ideal import IdealDrive
from motionplc.fieldbus.modbus_drive import ModbusDrive, ModbusDriveConfig
from motionplc.fieldbus.plant import PlantParams
from motionplc.fieldbus.virtual_cia402 import VirtualCanBus, VirtualCia402Drive
from motionplc.fieldbus.virtual_modbus import VirtualModbusDrive, VirtualModbusServer
from motionplc.runtime import Runtime

COUNTS_PER_UNIT = 1000.0  # 1 count = 0.001 u; the Appendix A positions (<= 3000 u) fit INT32
PLANT = PlantParams()  # defaults: kp 100/s, kff 0.9, tau_v 2 ms, 8 substeps


@dataclass
class HilRig:
    """A runtime with ``n`` axes (``x``, ``y``, ...) on one kind of drive."""

    kind: str
    rt: Runtime
    axes: list[Any]
    fbs: list[Any] = field(default_factory=list)
    powers: list[Any] = field(default_factory=list)
    rack: VirtualCanBus | None = None
    master: CanopenMaster | None = None
    master_bus: FaultInjectingBus | None = None
    servers: list[VirtualModbusServer] = field(default_factory=list)
    vdrives: list[Any] = field(default_factory=list)  # the virtual drives (fault injection)
    program_hook: Callable[[Any], None] | None = None

    def program(self, ctx: Any) -> None:
        for p in self.powers:
            p()
        for fb in self.fbs:
            fb()
        if self.program_hook is not None:
            self.program_hook(ctx)

    def add(self, *fbs: Any) -> Any:
        for fb in fbs:
            if fb.axis is None:
                fb.axis = self.axes[0]
            self.fbs.append(fb)
        return fbs[0] if len(fbs) == 1 else fbs

    def run(self, cycles: int) -> None:
        self.rt.run(cycles=cycles)

    def pulse(self, fb: Any) -> int:
        fb.execute = True
        k = self.rt.tick
        self.run(1)
        fb.execute = False
        return k

    def col(self, name: str) -> Any:
        return self.rt.trace.column(name)

    def close(self) -> None:
        try:
            self.rt.close()
        finally:
            if self.master is not None:
                self.master.close()
            if self.rack is not None:
                self.rack.close()
            for srv in self.servers:
                srv.stop(timeout=2.0)


def make_rig(
    kind: str,
    n_axes: int = 1,
    *,
    cycle: float = 0.001,
    v_max: float = 200.0,
    a_max: float = 400.0,
    j_max: float = math.inf,
    plant: PlantParams = PLANT,
    check_invariants: bool = True,
    trace_edges: bool = True,
    axis_options: dict[str, Any] | None = None,
    drive_options: dict[str, Any] | None = None,
    power: bool = True,
) -> HilRig:
    """Build a rig; ``drive_options`` go to the master-side drive configuration."""
    rt = Runtime(cycle=cycle, check_invariants=check_invariants, trace_edges=trace_edges)
    names = [chr(ord("x") + i) if i < 3 else f"a{i}" for i in range(n_axes)]
    rig = HilRig(kind, rt, [])
    drive_options = dict(drive_options or {})
    try:
        drives: list[Any] = []
        if kind == "ideal":
            drives = [IdealDrive(name) for name in names]
        elif kind == "can":
            channel = f"hil-{uuid.uuid4()}"
            rig.vdrives = [VirtualCia402Drive(i + 1, plant=plant) for i in range(n_axes)]
            rig.rack = VirtualCanBus(can.Bus(interface="virtual", channel=channel), rig.vdrives)
            rig.master_bus = FaultInjectingBus(can.Bus(interface="virtual", channel=channel))
            rig.master = CanopenMaster(rig.master_bus, peer=rig.rack, heartbeat_period=0.01)
            drive_options.setdefault("counts_per_unit", COUNTS_PER_UNIT)
            drive_options.setdefault("cycle_time", cycle)
            drives = [
                CanopenDrive(name, rig.master, CanopenDriveConfig(node_id=i + 1, **drive_options))
                for i, name in enumerate(names)
            ]
        elif kind == "modbus":
            drive_options.setdefault("counts_per_unit", COUNTS_PER_UNIT)
            drive_options.setdefault("cycle_time", cycle)
            drive_options.setdefault("timeout", 1.0)  # generous: the machine may be loaded
            for name in names:
                vd = VirtualModbusDrive(1, plant=plant)
                srv = VirtualModbusServer(vd)
                rig.servers.append(srv)
                rig.vdrives.append(vd)
                port = srv.start()
                drives.append(
                    ModbusDrive(name, ModbusDriveConfig(port=port, **drive_options), peer=srv)
                )
        else:
            raise ValueError(kind)
        for name, drive in zip(names, drives, strict=True):
            rig.axes.append(
                rt.add_axis(
                    name,
                    v_max=v_max,
                    a_max=a_max,
                    j_max=j_max,
                    drive=drive,
                    **(axis_options or {}),
                )
            )
        rig.powers = [MC_Power(axis=ax, enable=power) for ax in rig.axes]
        rt.add_task("main", rig.program)
    except BaseException:
        rig.close()
        raise
    return rig
