"""Fieldbus benchmarks with the runtime in the loop (issue 5).

1. Simulated clock: cycles per wall-clock second for 1, 4 and 8 axes on the python-can
   ``virtual`` bus (our CANopen master + in-process virtual CiA 402 drives, lockstep, one SYNC
   per cycle, 1 ms) and on Modbus TCP (our master + one in-process virtual Modbus drive server
   per axis on 127.0.0.1, one FC23 per axis per cycle, 4 ms), each axis running blended
   MC_MoveAbsolute sequences (BlendingLow, Appendix-A-like) through the scheduler and FBs.
   CPU time per cycle is printed too (the machine is shared: wall time includes other load).
2. Real time (RealtimeClock): lateness p50/p99/max and overruns for 4 CAN axes at 1 ms and
   4 Modbus axes at 4 ms over ``--seconds`` (default 60).
3. FC23 round trip on loopback (spec item 19: median < 1 ms as a loose regression guard).

    python tools/bench_fieldbus.py [--seconds 60] [--sim-cycles 4000] [--skip-rt] [--fifo 10]
    python tools/bench_fieldbus.py --can-profile 5000  # where the 8-axis CAN cycle's time goes
"""

from __future__ import annotations

import argparse
import logging
import statistics
import sys
import time
import uuid
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import can  # noqa: E402

from motionplc.blocks import MC_MoveAbsolute, MC_Power  # noqa: E402
from motionplc.blocks.enums import AxisState, BufferMode  # noqa: E402
from motionplc.fieldbus.base import DriveCommand  # noqa: E402
from motionplc.fieldbus.canopen_drive import (  # noqa: E402
    CanopenDrive,
    CanopenDriveConfig,
    CanopenMaster,
)
from motionplc.fieldbus.modbus_drive import ModbusDrive, ModbusDriveConfig  # noqa: E402
from motionplc.fieldbus.virtual_cia402 import VirtualCanBus, VirtualCia402Drive  # noqa: E402
from motionplc.fieldbus.virtual_modbus import VirtualModbusDrive, VirtualModbusServer  # noqa: E402
from motionplc.runtime import RealtimeClock, Runtime  # noqa: E402

COUNTS_PER_UNIT = 1000.0
LEGS_UP = ((1.0, 20.0), (2.0, 10.0), (3.0, 20.0))  # (position, velocity): 3 blended moves
LEGS_DOWN = ((2.0, 20.0), (1.0, 10.0), (0.0, 20.0))


class Blended:
    """Per axis: three blended MC_MoveAbsolute (BlendingLow), issued in consecutive scans,
    then the same back down, forever."""

    def __init__(self, axis: Any) -> None:
        self.axis = axis
        self.power = MC_Power(axis=axis, enable=True)
        self.moves = [
            MC_MoveAbsolute(
                axis=axis,
                acceleration=200.0,
                deceleration=200.0,
                buffer_mode=BufferMode.BLENDING_LOW,
            )
            for _ in range(3)
        ]
        self.up = True
        self.issued = 0  # moves issued of the current sequence
        self.sequences = 0

    def __call__(self) -> None:
        self.power()
        moves = self.moves
        if self.axis.state is AxisState.STANDSTILL and self.issued == 3 and moves[2].done:
            self.issued = 0
            self.up = not self.up
            self.sequences += 1
        if self.axis.state in (AxisState.STANDSTILL, AxisState.DISCRETE_MOTION) and (
            self.issued < 3
        ):
            legs = LEGS_UP if self.up else LEGS_DOWN
            m = moves[self.issued]
            m.position, m.velocity = legs[self.issued]
            m.execute = True
            self.issued += 1
        for m in moves:
            m()
            if m.execute and (m.busy or m.done or m.error):
                m.execute = False


class Rig:
    def __init__(self, kind: str, n: int, cycle: float, clock: Any = None) -> None:
        self.closers: list[Any] = []
        self.rt = Runtime(cycle=cycle, clock=clock, trace_capacity=200_000, trace_edges=False)
        drives: list[Any] = []
        if kind == "can":
            channel = f"bench-{uuid.uuid4()}"
            rack = VirtualCanBus(
                can.Bus(interface="virtual", channel=channel),
                [VirtualCia402Drive(i) for i in range(1, n + 1)],
            )
            master = CanopenMaster(
                can.Bus(interface="virtual", channel=channel), peer=rack, heartbeat_period=0.01
            )
            self.closers += [master.close, rack.close]
            drives = [
                CanopenDrive(
                    f"a{i}",
                    master,
                    CanopenDriveConfig(
                        node_id=i, counts_per_unit=COUNTS_PER_UNIT, cycle_time=cycle
                    ),
                )
                for i in range(1, n + 1)
            ]
        else:
            for i in range(n):
                srv = VirtualModbusServer(VirtualModbusDrive(1))
                srv.start()
                self.closers.append(srv.stop)
                drives.append(
                    ModbusDrive(
                        f"a{i}",
                        ModbusDriveConfig(
                            port=srv.port,
                            counts_per_unit=COUNTS_PER_UNIT,
                            cycle_time=cycle,
                            timeout=0.5,
                        ),
                        peer=srv,
                    )
                )
        self.programs = [
            Blended(self.rt.add_axis(d.name, v_max=100.0, a_max=400.0, drive=d)) for d in drives
        ]

        def main(ctx: Any) -> None:
            for p in self.programs:
                p()

        self.rt.add_task("main", main)

    def check(self) -> None:
        for p in self.programs:
            if p.axis.state is AxisState.ERROR_STOP or p.sequences < 1:
                raise SystemExit(
                    f"axis {p.axis.name}: {p.axis.state.name} {p.axis.axis_error_reason!r}, "
                    f"{p.sequences} sequences"
                )

    def close(self) -> None:
        self.rt.close()
        for c in self.closers:
            c()


def sim_throughput(kind: str, n: int, cycles: int) -> tuple[float, float]:
    cycle = 0.001 if kind == "can" else 0.004
    rig = Rig(kind, n, cycle)
    try:
        rig.rt.run(cycles=20)  # power up, configure
        w0, c0 = time.perf_counter(), time.process_time()
        rig.rt.run(cycles=cycles)
        wall, cpu = time.perf_counter() - w0, time.process_time() - c0
        rig.check()
        return cycles / wall, cpu / cycles
    finally:
        rig.close()


def realtime(kind: str, n: int, cycle: float, seconds: float, fifo: int | None) -> None:
    clock = RealtimeClock(fifo_priority=fifo)
    rig = Rig(kind, n, cycle, clock)
    try:
        rig.rt.run(seconds=seconds)
        rig.check()
        st = rig.rt.stats()["main"]
    finally:
        rig.close()
    pct = 100.0 * st.overruns / max(1, st.cycle_count)
    policy = "SCHED_FIFO" if clock.fifo_active else "default scheduler"
    print(
        f"  {kind:6s} {n} axes @ {cycle * 1e3:g} ms, {seconds:g} s ({policy}): "
        f"{st.cycle_count} cycles, lateness p50 {st.lateness_p50 * 1e6:.0f} us, "
        f"p99 {st.lateness_p99 * 1e6:.0f} us, max {st.lateness_max * 1e6:.0f} us; "
        f"exec mean {st.exec_mean * 1e6:.0f} us, max {st.exec_max * 1e6:.0f} us; "
        f"overruns {st.overruns} ({pct:.3f} %), omitted cycles {st.omitted_cycles}"
    )


def bench_latency(requests: int) -> tuple[float, float]:
    srv = VirtualModbusServer(VirtualModbusDrive(1))
    srv.start()
    drive = ModbusDrive("m", ModbusDriveConfig(port=srv.port, timeout=0.5, cycle_time=0.001))
    try:
        drive.open()
        samples = []
        for k in range(requests):
            t0 = time.perf_counter()
            drive.write_outputs(k * 0.001, DriveCommand(0.0))
            samples.append(time.perf_counter() - t0)
        samples.sort()
        return statistics.median(samples), samples[int(0.99 * (len(samples) - 1))]
    finally:
        drive.close()
        srv.stop()


def can_profile(n_axes: int, cycles: int, top: int = 30) -> None:
    """Where the CPU time of the lockstep CAN cycle goes: a sampling profile of ``cycles``
    simulated cycles of ``n_axes`` CAN axes (a thread takes the main thread's stack every
    0.5 ms; no tracing hooks, so small functions are not inflated as under cProfile). Prints
    the share of samples in which each function was on the stack (inclusive) and, among
    those, the ones at the top (exclusive). Shares of a shared machine's CPU time: compare
    shares, not absolute times."""
    import collections
    import threading

    rig = Rig("can", n_axes, 0.001)
    main_id = threading.get_ident()
    inclusive: collections.Counter[str] = collections.Counter()
    exclusive: collections.Counter[str] = collections.Counter()
    samples = 0
    done = threading.Event()

    def sample() -> None:
        nonlocal samples
        while not done.wait(0.0005):
            frame = sys._current_frames().get(main_id)
            if frame is None:
                continue
            samples += 1
            seen: set[str] = set()
            top_frame = True
            while frame is not None:
                code = frame.f_code
                name = f"{Path(code.co_filename).stem}.{code.co_name}"
                if top_frame:
                    exclusive[name] += 1
                    top_frame = False
                if name not in seen:
                    seen.add(name)
                    inclusive[name] += 1
                frame = frame.f_back

    try:
        rig.rt.run(cycles=20)  # power up, configure
        switch = sys.getswitchinterval()
        sys.setswitchinterval(0.0002)
        sampler = threading.Thread(target=sample, daemon=True)
        sampler.start()
        c0 = time.process_time()
        try:
            rig.rt.run(cycles=cycles)
        finally:
            done.set()
            sampler.join()
            sys.setswitchinterval(switch)
        cpu = time.process_time() - c0
        rig.check()
    finally:
        rig.close()
    print(
        f"CAN cycle profile, {n_axes} axes, {cycles} cycles ({cpu / cycles * 1e6:.0f} us CPU per"
        f" cycle with the sampler), {samples} samples; inclusive / exclusive share:"
    )
    skip = {"bench_fieldbus.can_profile", "bench_fieldbus.main", "bench_fieldbus.<module>"}
    for name, count in inclusive.most_common(top + len(skip)):
        if name not in skip:
            print(
                f"  {100 * count / samples:5.1f} % {100 * exclusive[name] / samples:5.1f} %  {name}"
            )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=60.0, help="duration of each real-time run")
    ap.add_argument("--sim-cycles", type=int, default=4000, help="simulated cycles per CAN run")
    ap.add_argument("--skip-rt", action="store_true", help="only the simulated-clock part")
    ap.add_argument("--fifo", type=int, default=None, help="SCHED_FIFO priority for RT runs")
    ap.add_argument("--latency-requests", type=int, default=1000)
    ap.add_argument(
        "--can-profile",
        type=int,
        default=0,
        metavar="CYCLES",
        help="only a sampling profile of this many cycles of 8 CAN axes",
    )
    args = ap.parse_args()
    logging.getLogger("pymodbus").setLevel(logging.CRITICAL)
    if args.can_profile:
        can_profile(8, args.can_profile)
        return
    print("simulated clock, runtime + FBs + blended moves (cycles per wall second; CPU/cycle):")
    for kind, cycles in (("can", args.sim_cycles), ("modbus", max(500, args.sim_cycles // 4))):
        for n in (1, 4, 8):
            rate, cpu = sim_throughput(kind, n, cycles)
            target = "  (target >= 2000)" if (kind, n) == ("can", 8) else ""
            print(
                f"  {kind:6s} {n} axes: {rate:8.0f} cycles/s   {cpu * 1e6:6.0f} us CPU/cycle"
                f"{target}"
            )
    if not args.skip_rt:
        print("real time (RealtimeClock; target CAN: <= 0.1 % overrun cycles):")
        realtime("can", 4, 0.001, args.seconds, args.fifo)
        realtime("modbus", 4, 0.004, args.seconds, args.fifo)
    median, p99 = bench_latency(args.latency_requests)
    verdict = "ok" if median < 1e-3 else "SLOW (guard: median < 1 ms)"
    print(
        f"FC23 round trip on loopback ({args.latency_requests} requests): "
        f"median {median * 1e3:.3f} ms, p99 {p99 * 1e3:.3f} ms  [{verdict}]"
    )


if __name__ == "__main__":
    main()
