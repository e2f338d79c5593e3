"""Fieldbus benchmarks (drive layer only; the runtime-level numbers come with the HIL work).

Prints simulated-clock cycles/s for 1, 4 and 8 axes on the python-can virtual bus (our CANopen
master + in-process virtual CiA 402 drives, lockstep) and on Modbus TCP (our master + in-process
virtual Modbus drives on 127.0.0.1, one FC23 per axis per cycle), and the FC23 round-trip
latency on loopback (spec item 19: median < 1 ms as a loose regression guard).

Not yet here (needs the runtime): the same counts with the scheduler and PLCopen blocks in
the loop, and real-time lateness p99 / overruns for 4 CAN axes at 1 ms and 4 Modbus axes at
4 ms over 60 s.

    python tools/bench_fieldbus.py [--cycles 2000] [--latency-requests 1000]
"""

from __future__ import annotations

import argparse
import logging
import statistics
import time
import uuid

import can

from motionplc.fieldbus.base import DriveCommand
from motionplc.fieldbus.canopen_drive import CanopenDrive, CanopenDriveConfig, CanopenMaster
from motionplc.fieldbus.modbus_drive import ModbusDrive, ModbusDriveConfig
from motionplc.fieldbus.virtual_cia402 import VirtualCanBus, VirtualCia402Drive
from motionplc.fieldbus.virtual_modbus import VirtualModbusDrive, VirtualModbusServer

DT = 0.001


def _run(drives: list, cycles: int) -> float:
    """Lockstep cycles with a slow ramp; returns simulated cycles per wall-clock second."""
    positions = [0.0] * len(drives)
    start = time.perf_counter()
    for k in range(cycles):
        t = k * DT
        fbs = [d.read_inputs(t) for d in drives]
        for i, (d, fb) in enumerate(zip(drives, fbs, strict=True)):
            if fb.enabled:
                positions[i] += 0.05 * DT
            else:
                positions[i] = fb.position
            d.write_outputs(t, DriveCommand(positions[i], 0.05, enable=True))
    elapsed = time.perf_counter() - start
    if not all(fb.enabled and fb.comm_ok for fb in fbs):
        raise SystemExit(f"axes not all enabled at the end: {fbs}")
    return cycles / elapsed


def bench_can(n: int, cycles: int) -> float:
    channel = f"bench-{uuid.uuid4()}"
    rack = VirtualCanBus(
        can.Bus(interface="virtual", channel=channel),
        [VirtualCia402Drive(i) for i in range(1, n + 1)],
    )
    master = CanopenMaster(can.Bus(interface="virtual", channel=channel), peer=rack)
    try:
        drives = [
            CanopenDrive(f"ax{i}", master, CanopenDriveConfig(node_id=i)) for i in range(1, n + 1)
        ]
        for d in drives:
            d.open()
        return _run(drives, cycles)
    finally:
        master.close()
        rack.close()


def bench_modbus(n: int, cycles: int) -> float:
    servers = [VirtualModbusServer(VirtualModbusDrive(1)) for _ in range(n)]
    drives = []
    try:
        for srv in servers:
            srv.start()
            drive = ModbusDrive(
                f"m{srv.port}",
                ModbusDriveConfig(port=srv.port, timeout=0.5, cycle_time=DT),
                peer=srv,
            )
            drive.open()
            drives.append(drive)
        return _run(drives, cycles)
    finally:
        for d in drives:
            d.close()
        for srv in servers:
            srv.stop()


def bench_latency(requests: int) -> tuple[float, float]:
    srv = VirtualModbusServer(VirtualModbusDrive(1))
    srv.start()
    drive = ModbusDrive("m", ModbusDriveConfig(port=srv.port, timeout=0.5, cycle_time=DT))
    try:
        drive.open()
        samples = []
        for k in range(requests):
            t0 = time.perf_counter()
            drive.write_outputs(k * DT, DriveCommand(0.0))
            samples.append(time.perf_counter() - t0)
        samples.sort()
        return statistics.median(samples), samples[int(0.99 * (len(samples) - 1))]
    finally:
        drive.close()
        srv.stop()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cycles", type=int, default=2000)
    parser.add_argument("--latency-requests", type=int, default=1000)
    args = parser.parse_args()
    logging.getLogger("pymodbus").setLevel(logging.CRITICAL)
    print(f"simulated-clock cycles/s (drive layer only, {args.cycles} cycles, dt = 1 ms)")
    for n in (1, 4, 8):
        print(f"  CAN virtual bus  {n} axes: {bench_can(n, args.cycles):8.0f} cycles/s")
    for n in (1, 4, 8):
        print(f"  Modbus TCP       {n} axes: {bench_modbus(n, args.cycles):8.0f} cycles/s")
    median, p99 = bench_latency(args.latency_requests)
    verdict = "ok" if median < 1e-3 else "SLOW (guard: median < 1 ms)"
    print(
        f"FC23 round trip on loopback ({args.latency_requests} requests): "
        f"median {median * 1e3:.3f} ms, p99 {p99 * 1e3:.3f} ms  [{verdict}]"
    )


if __name__ == "__main__":
    main()
