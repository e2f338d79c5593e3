"""Runtime benchmark: simulated-clock throughput and real-time lateness.

    python tools/bench_runtime.py                 # sim 1/8/32 axes + real time 8 axes x 60 s
    python tools/bench_runtime.py --rt-seconds 10 # shorter real-time run
    python tools/bench_runtime.py --no-rt         # simulated clock only
    python tools/bench_runtime.py --fifo 10       # real-time run under SCHED_FIFO (if allowed)

Every axis runs an endless blended sequence of MC_MoveAbsolute blocks (BlendingLow between
0 -> 400 -> 1000 and back, jerk-limited), with MC_Power and MC_ReadStatus called every scan,
the trace recording every cycle and FB edges on. Invariant checks are off (they are for tests).
Targets (issue 4): 8 axes >= 10,000 simulated cycles/s; real time 8 axes at 1 ms with p99
lateness <= 200 us and <= 6 overruns in 60,000 cycles.
"""

from __future__ import annotations

import argparse
import os
import time

from motionplc.blocks import BufferMode, MC_MoveAbsolute, MC_Power, MC_ReadStatus
from motionplc.runtime import RealtimeClock, Runtime

LEGS = ((400.0, 120.0), (1000.0, 80.0), (600.0, 150.0), (0.0, 100.0))


class AxisProgram:
    """Per axis: power on, then keep two blended moves queued at all times."""

    def __init__(self, rt: Runtime, name: str) -> None:
        self.x = rt.add_axis(name, v_max=200.0, a_max=1000.0, j_max=20_000.0)
        self.power = MC_Power()
        self.status = MC_ReadStatus()
        self.moves = [MC_MoveAbsolute(buffer_mode=BufferMode.BLENDING_LOW) for _ in range(2)]
        self.leg = 0
        self.turn = 0

    def __call__(self) -> None:
        x = self.x
        self.power(axis=x, enable=True)
        self.status(axis=x, enable=True)
        if not self.power.status:
            return
        cur = self.moves[self.turn]
        other = self.moves[1 - self.turn]
        if not cur.busy and not cur.execute:
            pos, vel = LEGS[self.leg % len(LEGS)]
            self.leg += 1
            cur(
                axis=x,
                execute=True,
                position=pos,
                velocity=vel,
                acceleration=800.0,
                deceleration=800.0,
            )
        else:
            cur(axis=x, execute=False)
        other(axis=x)
        if cur.active:  # queue the next leg behind the running one
            self.turn = 1 - self.turn


def build(n_axes: int, clock=None, seconds: float = 0.0) -> Runtime:
    rt = Runtime(cycle=0.001, clock=clock, trace_capacity=max(70_000, int(seconds * 1000) + 10))
    programs = [AxisProgram(rt, f"a{i}") for i in range(n_axes)]

    def main(ctx) -> None:
        for p in programs:
            p()

    rt.add_task("main", main, period=0.001, priority=0)
    return rt


def sim_throughput(n_axes: int, cycles: int) -> float:
    rt = build(n_axes)
    rt.run(cycles=200)  # warm-up
    t0 = time.perf_counter()
    rt.run(cycles=cycles)
    return cycles / (time.perf_counter() - t0)


def realtime(n_axes: int, seconds: float, fifo: int | None) -> None:
    clock = RealtimeClock(fifo_priority=fifo)
    rt = build(n_axes, clock=clock, seconds=seconds)
    rt.run(seconds=seconds)
    st = rt.stats()["main"]
    cycles = st.cycle_count + st.omitted_cycles
    policy = "SCHED_FIFO" if clock.fifo_active else "default scheduler"
    print(f"real time, {n_axes} axes at 1 ms for {seconds:g} s ({cycles} cycles, {policy}):")
    print(
        f"  lateness p50 {st.lateness_p50 * 1e6:7.1f} us   p99 {st.lateness_p99 * 1e6:7.1f} us"
        f"   max {st.lateness_max * 1e6:8.1f} us"
    )
    print(
        f"  exec mean {st.exec_mean * 1e6:7.1f} us   max {st.exec_max * 1e6:8.1f} us"
        f"   overruns {st.overruns}   omitted cycles {st.omitted_cycles}"
    )
    moved = sum(1 for ax in rt.axes.values() if abs(ax.p) > 0.0 or ax.v != 0.0)
    print(f"  axes in motion at the end: {moved}/{n_axes}")


def main() -> None:
    ap = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    ap.add_argument("--cycles", type=int, default=5000, help="simulated cycles per measurement")
    ap.add_argument("--rt-seconds", type=float, default=60.0)
    ap.add_argument("--rt-axes", type=int, default=8)
    ap.add_argument("--no-rt", action="store_true")
    ap.add_argument("--fifo", type=int, default=None, help="SCHED_FIFO priority for the RT run")
    args = ap.parse_args()
    print(f"cpus: {os.cpu_count()}, load average: {os.getloadavg()}")
    for n in (1, 8, 32):
        cps = sim_throughput(n, args.cycles)
        ratio = cps / 1000
        print(f"simulated clock, {n:2d} axes: {cps:9.0f} cycles/s ({ratio:.1f}x real time at 1 ms)")
    if not args.no_rt:
        realtime(args.rt_axes, args.rt_seconds, args.fifo)


if __name__ == "__main__":
    main()
