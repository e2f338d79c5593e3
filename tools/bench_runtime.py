"""Runtime benchmark: simulated-clock throughput and real-time lateness.

    python tools/bench_runtime.py                 # sim 1/8/32 axes + real time 8 axes x 60 s
    python tools/bench_runtime.py --rt-seconds 10 # shorter real-time run
    python tools/bench_runtime.py --no-rt         # simulated clock only
    python tools/bench_runtime.py --fifo 10       # real-time run under SCHED_FIFO (if allowed)
    python tools/bench_runtime.py --cpu 1 --mlock # pinned to CPU 1, memory locked (if allowed)
    python tools/bench_runtime.py --rss-cycles 1000000 --rss-axes 8 --no-rt --axes
                                                  # resident memory after 1,000,000 cycles
    python tools/bench_runtime.py --no-rt --axes 8 --drives can  # virtual CiA 402 over CAN
    python tools/bench_runtime.py --against a5addda --axes 8 --repeats 7 --base-calls kw
                                  # before/after in one run: a worktree of the commit
                                  # (keyword FB calls, the program before issue 15) and
                                  # this checkout (attribute calls), alternately
    python tools/bench_runtime.py --against 09895dc --base-build --axes 8 --no-rt
                                  # the same, the worktree compiled with its own sources

Issue 15 (a leaner cycle): ``--calls attr`` (default) sets the FB inputs as attributes when
they change and calls every FB as ``fb()``; ``--calls kw`` passes them as keywords every scan
(the program as it was). ``--drives can`` puts every axis on a virtual CiA 402 drive behind
our CANopen master on one in-process python-can ``virtual`` bus (lockstep, one SYNC per
cycle; positions and limits scaled by 0.01). ``--against REF`` measures each side in its own
process importing ``motionplc`` from its own tree (the worktree of REF gets this build's
compiled extensions, which its own ``motionplc._purepy`` uses only where its sources are the
ones they were built from; each side's core is printed; ``MOTIONPLC_PURE_PYTHON=1`` runs
both sides in pure Python), ``--repeats`` pairs, and prints the
medians of the cycles per CPU-second and the median ratio (the machine is shared: ratios of
one run, never absolute figures of different runs). Targets (simulated clock, 8 axes):
>= 40,000 cycles/s with ideal drives (18,000 before), >= 10,000 with virtual CAN drives.

Every axis runs an endless blended sequence of MC_MoveAbsolute blocks (BlendingLow between
0 -> 400 -> 1000 and back, jerk-limited), with MC_Power and MC_ReadStatus called every scan,
the trace recording every cycle and FB edges on. Invariant checks are off (they are for tests).
Targets (issue 4): 8 axes >= 10,000 simulated cycles/s; real time 8 axes at 1 ms with p99
lateness <= 200 us and <= 6 overruns in 60,000 cycles.

``--rss-cycles N`` runs N simulated cycles with the runtime's default trace settings (byte
budget ``motionplc.runtime.trace.TRACE_BYTES``) and reports the resident set size (VmRSS of
/proc/self/status) before and after, the peak (ru_maxrss) and what the trace holds. Target
(issue 11): 8 axes, 1,000,000 cycles, under 100 MB.

Simulated throughput is given per wall-clock second and per CPU second of this process
(``time.process_time``): on a shared machine the wall figure depends on the other load, the CPU
figure much less. Best and median of ``--repeats`` runs. The real-time run reports the lateness
and execution-time distributions, and what the tail coincides with: involuntary context
switches of this process, CPU time stolen by the hypervisor (``steal`` in /proc/stat) and the
CPU time of the other processes during the run.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from motionplc.blocks import BufferMode, MC_MoveAbsolute, MC_Power, MC_ReadStatus
from motionplc.blocks.axis import planner_calls
from motionplc.runtime import RealtimeClock, Runtime

LEGS = ((400.0, 120.0), (1000.0, 80.0), (600.0, 150.0), (0.0, 100.0))


class AxisProgram:
    """Per axis: power on, then keep two blended moves queued at all times.

    ``calls="attr"``: the FB inputs are attributes set when they change, every FB is called
    as ``fb()`` (the lean hot path); ``"kw"``: every call passes its inputs as keywords
    (``fb(axis=x, execute=True, ...)``, as before issue 15). Both give the same motion.
    ``scale`` multiplies positions, speeds and limits (the CAN rig moves metres, not 1000s).
    """

    def __init__(
        self, rt: Runtime, name: str, calls: str = "attr", scale: float = 1.0, drive=None
    ) -> None:
        self.x = rt.add_axis(
            name, v_max=200.0 * scale, a_max=1000.0 * scale, j_max=20_000.0 * scale, drive=drive
        )
        self.scale = scale
        self.acc = 800.0 * scale
        self.kw = calls == "kw"
        if self.kw:
            self.power = MC_Power()
            self.status = MC_ReadStatus()
            self.moves = [MC_MoveAbsolute(buffer_mode=BufferMode.BLENDING_LOW) for _ in range(2)]
        else:
            self.power = MC_Power(axis=self.x, enable=True)
            self.status = MC_ReadStatus(axis=self.x, enable=True)
            self.moves = [
                MC_MoveAbsolute(
                    axis=self.x,
                    buffer_mode=BufferMode.BLENDING_LOW,
                    acceleration=self.acc,
                    deceleration=self.acc,
                )
                for _ in range(2)
            ]
        self.leg = 0
        self.turn = 0

    def __call__(self) -> None:
        if self.kw:
            self._kw_scan()
            return
        power = self.power
        power()
        self.status()
        if not power.status:
            return
        cur = self.moves[self.turn]
        other = self.moves[1 - self.turn]
        if not cur.busy and not cur.execute:
            pos, vel = LEGS[self.leg % len(LEGS)]
            self.leg += 1
            cur.position = pos * self.scale
            cur.velocity = vel * self.scale
            cur.execute = True
        else:
            cur.execute = False
        cur()
        other()
        if cur.active:  # queue the next leg behind the running one
            self.turn = 1 - self.turn

    def _kw_scan(self) -> None:
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
                position=pos * self.scale,
                velocity=vel * self.scale,
                acceleration=self.acc,
                deceleration=self.acc,
            )
        else:
            cur(axis=x, execute=False)
        other(axis=x)
        if cur.active:  # queue the next leg behind the running one
            self.turn = 1 - self.turn


CAN_SCALE = 0.01  # CAN rig: legs of 4 to 10 m at 0.8 to 1.5 m/s, 1000 counts per metre


def build(
    n_axes: int,
    clock=None,
    seconds: float = 0.0,
    default_trace: bool = False,
    calls: str = "attr",
    drives: str = "ideal",
) -> Runtime:
    """The benchmark's runtime: ``n_axes`` axes on ideal drives or (``drives="can"``) on
    virtual CiA 402 drives behind our CANopen master on one python-can ``virtual`` bus (in
    process, lockstep: one SYNC per cycle). ``rt.close()`` closes the drives."""
    if default_trace:
        rt = Runtime(cycle=0.001, clock=clock)
    else:
        cap = max(70_000, int(seconds * 1000) + 10)
        rt = Runtime(cycle=0.001, clock=clock, trace_capacity=cap)
    if drives == "can":
        drv = _can_drives(rt, n_axes)
        programs = [AxisProgram(rt, f"a{i}", calls, CAN_SCALE, drv[i]) for i in range(n_axes)]
    else:
        programs = [AxisProgram(rt, f"a{i}", calls) for i in range(n_axes)]

    def main(ctx) -> None:
        for p in programs:
            p()

    rt.add_task("main", main, period=0.001, priority=0)
    return rt


def _can_drives(rt: Runtime, n_axes: int) -> list:
    import can

    from motionplc.fieldbus.canopen_drive import CanopenDrive, CanopenDriveConfig, CanopenMaster
    from motionplc.fieldbus.virtual_cia402 import VirtualCanBus, VirtualCia402Drive

    channel = f"bench-runtime-{os.getpid()}-{id(rt)}"
    rack = VirtualCanBus(
        can.Bus(interface="virtual", channel=channel),
        [VirtualCia402Drive(i) for i in range(1, n_axes + 1)],
    )
    master = CanopenMaster(
        can.Bus(interface="virtual", channel=channel), peer=rack, heartbeat_period=0.01
    )
    drives = [
        CanopenDrive(
            f"a{i - 1}",
            master,
            CanopenDriveConfig(node_id=i, counts_per_unit=1000.0, cycle_time=rt.cycle),
        )
        for i in range(1, n_axes + 1)
    ]
    rt._bench_closers = [master.close, rack.close]  # type: ignore[attr-defined]
    return drives


def close(rt: Runtime) -> None:
    """Close the drives and (CAN rig) the buses."""
    rt.close()
    for c in getattr(rt, "_bench_closers", ()):
        c()


def sim_throughput(
    n_axes: int, cycles: int, calls: str = "attr", drives: str = "ideal"
) -> tuple[float, float]:
    """(cycles per wall second, cycles per CPU second of this process)."""
    rt = build(n_axes, calls=calls, drives=drives)
    try:
        rt.run(cycles=200)  # warm-up
        w0, c0 = time.perf_counter(), time.process_time()
        rt.run(cycles=cycles)
        w, c = time.perf_counter() - w0, time.process_time() - c0
        bad = [ax.name for ax in rt.axes.values() if ax.axis_error.value != 0]
        if bad:
            raise SystemExit(f"axes in error after the run: {bad}")
        return cycles / w, cycles / max(c, 1e-9)
    finally:
        close(rt)


def _child(root: Path, n: int, cycles: int, calls: str, drives: str) -> tuple[float, float, str]:
    """One ``sim_throughput`` measurement in a fresh process importing ``motionplc`` from
    ``root`` (this checkout or a worktree of an older commit): (cycles per wall second, per
    CPU second, which compiled core it ran: ``motionplc._purepy.status()``)."""
    cmd = [sys.executable, str(Path(__file__).resolve()), "--child", str(root)]
    cmd += ["--axes", str(n), "--cycles", str(cycles), "--calls", calls, "--drives", drives]
    env = dict(os.environ, PYTHONPATH=str(root))
    out = subprocess.run(cmd, cwd=root, env=env, check=True, capture_output=True, text=True)
    wall, cpu, core = json.loads(out.stdout.strip().splitlines()[-1])
    return wall, cpu, core


def _lend_extensions(here: Path, base: Path) -> None:
    """Copy this build's compiled extensions and build manifest into the worktree ``base``
    (a git worktree has none), so that both sides of ``--against`` run the compiled planning
    core: the base's own ``_purepy`` still uses them only if its sources are the ones they
    were built from (else it runs pure Python, and the report says so)."""
    pkg = here / "motionplc"
    manifest = pkg / "_compiled.json"
    if not manifest.is_file():
        return
    # only the shared library and the modules the base itself compiles: an extension of a
    # module the base has as plain Python would shadow its source (an extension wins the import)
    listed = _compiled_modules(base / "motionplc" / "_purepy.py")
    for ext in pkg.rglob("*.so"):
        rel = ext.relative_to(here)
        module = ".".join((*rel.parent.parts, rel.name.split(".")[0]))
        if "__mypyc" not in rel.name and module not in listed:
            continue
        dest = base / rel
        if dest.parent.is_dir():
            shutil.copy2(ext, dest)
    shutil.copy2(manifest, base / "motionplc" / "_compiled.json")


def _build_extensions(base: Path) -> None:
    """Compile the worktree ``base``'s own extensions in place (its setup.py, this Python)."""
    res = subprocess.run(
        [sys.executable, "setup.py", "-q", "build_ext", "--inplace"],
        cwd=base,
        capture_output=True,
        text=True,
    )
    if res.returncode != 0:
        raise SystemExit(f"building the extensions of {base} failed:\n{res.stderr[-2000:]}")


def _compiled_modules(purepy: Path) -> set[str]:
    """COMPILED_MODULES of a tree's ``motionplc/_purepy.py`` (read, not imported); empty
    when it has none."""
    import ast

    if not purepy.is_file():
        return set()
    for node in ast.parse(purepy.read_text()).body:
        if isinstance(node, ast.Assign) and any(
            isinstance(t, ast.Name) and t.id == "COMPILED_MODULES" for t in node.targets
        ):
            return {str(v) for v in ast.literal_eval(node.value)}
    return set()


def against(
    ref: str,
    axes: list[int],
    cycles: int,
    repeats: int,
    calls: str,
    drives: str,
    base_calls: str | None = None,
    base_build: bool = False,
) -> None:
    """Before/after in one run: alternately this checkout and a temporary detached worktree
    of ``ref``, each measurement in its own process; medians of the CPU-second rates and the
    median of the per-pair ratios. ``base_calls``: the FB call style of the ``ref`` side
    (default: ``calls``; ``kw`` is the benchmark's program as it was before issue 15).
    ``base_build``: compile the worktree's own extensions (``setup.py build_ext --inplace``,
    about a minute) instead of lending it this build's (needed when the compiled modules
    changed since ``ref``: lent extensions of other sources are not used)."""
    base_calls = base_calls or calls
    here = Path(__file__).resolve().parent.parent
    tmp = Path(tempfile.mkdtemp(prefix="bench-runtime-"))
    base = tmp / "base"
    subprocess.run(
        ["git", "-C", str(here), "worktree", "add", "--detach", str(base), ref],
        check=True,
        capture_output=True,
    )
    try:
        if base_build:
            _build_extensions(base)
        else:
            _lend_extensions(here, base)
        for n in axes:
            new_r: list[float] = []
            old_r: list[float] = []
            cores: set[tuple[str, str]] = set()
            for _ in range(repeats):
                _, old_cpu, old_core = _child(base, n, cycles, base_calls, drives)
                _, new_cpu, new_core = _child(here, n, cycles, calls, drives)
                if old_core.startswith("compiled") != new_core.startswith("compiled"):
                    raise SystemExit(
                        f"bench_runtime --against: the two sides run different cores ({ref}: "
                        f"{old_core}; this checkout: {new_core}): the ratio would compare "
                        "compiled code with pure Python. With --base-build the worktree is "
                        "compiled by this interpreter's mypy (install mypy>=2.4 into it: it "
                        "is a build requirement only, absent from an ordinary venv)"
                    )
                old_r.append(old_cpu)
                new_r.append(new_cpu)
                cores.add((old_core, new_core))
            for old_core, new_core in sorted(cores):
                print(f"  core: {ref}: {old_core}; this checkout: {new_core}")
            ratios = [a / b for a, b in zip(new_r, old_r, strict=True)]
            print(
                f"{drives} drives, {n:2d} axes, {cycles} cycles x {repeats}:"
                f" {ref} ({base_calls} calls) {statistics.median(old_r):7.0f} cycles per"
                f" CPU-second (median), this checkout ({calls} calls)"
                f" {statistics.median(new_r):7.0f};"
                f" ratio {statistics.median(ratios):.2f}x (median of {repeats} pairs,"
                f" {min(ratios):.2f}-{max(ratios):.2f})",
                flush=True,
            )
    finally:
        subprocess.run(
            ["git", "-C", str(here), "worktree", "remove", "--force", str(base)],
            check=False,
            capture_output=True,
        )
        shutil.rmtree(tmp, ignore_errors=True)


def _rss_mb() -> float:
    """Resident set size of this process [MB] (VmRSS of /proc/self/status; NaN if absent)."""
    try:
        with open("/proc/self/status") as f:
            for line in f:
                if line.startswith("VmRSS:"):
                    return int(line.split()[1]) * 1024 / 1e6
    except OSError:
        pass
    return float("nan")


def rss_run(n_axes: int, cycles: int, report_every: int = 100_000) -> None:
    """Run ``cycles`` simulated cycles with the default trace settings; print the memory."""
    rt = build(n_axes, default_trace=True)
    rt.run(cycles=200)
    tr = rt.trace
    r0 = _rss_mb()
    print(
        f"memory, {n_axes} axes, {cycles} simulated cycles, default trace settings "
        f"(budget {tr.max_bytes / 2**20:g} MiB = {tr.rows_capacity} rows of {tr.row_bytes} B"
        f" + FB edges):"
    )
    print(f"  RSS after 200 cycles {r0:7.1f} MB")
    w0 = time.perf_counter()
    done = 200
    while done < cycles:
        n = min(report_every, cycles - done)
        rt.run(cycles=n)
        done += n
        print(
            f"  RSS after {done:>9} cycles {_rss_mb():7.1f} MB"
            f"   ({done / (time.perf_counter() - w0):7.0f} cycles/s)",
            flush=True,
        )
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024 / 1e6
    moved = sum(1 for ax in rt.axes.values() if abs(ax.p) > 0.0 or ax.v != 0.0)
    print(
        f"  final RSS {_rss_mb():.1f} MB, peak {peak:.1f} MB; the trace holds {len(tr)} rows"
        f" (dropped {tr.dropped_rows}), {len(tr.events)} FB edges (dropped"
        f" {tr.dropped_events}); its storage bound is {tr.nbytes / 1e6:.1f} MB"
        f" ({tr.row_bytes} B per cycle = 16 + {n_axes} x 57); axes in motion: {moved}/{n_axes}"
    )


def _proc_stat() -> tuple[int, int]:
    """(total busy jiffies of all processes, steal jiffies) from /proc/stat; (0, 0) if absent."""
    try:
        with open("/proc/stat") as f:
            parts = f.readline().split()
    except OSError:
        return 0, 0
    vals = [int(x) for x in parts[1:]]
    user, nice, system = vals[0], vals[1], vals[2]
    steal = vals[7] if len(vals) > 7 else 0
    return user + nice + system, steal


def realtime(
    n_axes: int, seconds: float, fifo: int | None, cpu: int | None, mlock: bool, spin_us: float
) -> None:
    clock = RealtimeClock(
        spin_ns=round(spin_us * 1000), fifo_priority=fifo, cpu=cpu, lock_memory=mlock
    )
    rt = build(n_axes, clock=clock, seconds=seconds)
    # attribute slow cycles: how many profiles did the axes plan in that cycle?
    calls = [planner_calls()]
    spikes: list[tuple[int, int, int]] = []  # (cycle, exec us, profiles planned)

    def hook(rt: Runtime, k: int) -> None:
        n = planner_calls()
        planned = n - calls[0]
        calls[0] = n
        e = rt.tasks[0].exec_last_ns
        if e > 500_000:
            spikes.append((k, e // 1000, planned))

    rt.add_cycle_hook(hook)
    hz = os.sysconf("SC_CLK_TCK")
    ru0 = resource.getrusage(resource.RUSAGE_SELF)
    busy0, steal0 = _proc_stat()
    load0 = os.getloadavg()
    rt.run(seconds=seconds)
    ru1 = resource.getrusage(resource.RUSAGE_SELF)
    busy1, steal1 = _proc_stat()
    st = rt.stats()["main"]
    task = rt.tasks[0]
    cycles = st.cycle_count + st.omitted_cycles
    settings = [
        "SCHED_FIFO" if clock.fifo_active else "default scheduler",
        f"CPU {cpu}" if clock.affinity_active else "no affinity",
        "mlockall" if clock.mlock_active else "no mlock",
        f"spin {spin_us:g} us",
    ]
    print(f"real time, {n_axes} axes at 1 ms for {seconds:g} s ({cycles} cycles):")
    print(f"  settings: {', '.join(settings)}; load average before {load0[0]:.2f}")
    if fifo is not None and not clock.fifo_active:
        print("  (SCHED_FIFO refused)")
    if cpu is not None and not clock.affinity_active:
        print("  (affinity refused)")
    if mlock and not clock.mlock_active:
        print("  (mlockall refused)")
    lq = [task.lateness_percentile(q) * 1e6 for q in (0.5, 0.9, 0.99, 0.999)]
    print(
        f"  lateness p50 {lq[0]:6.1f} us   p90 {lq[1]:6.1f}   p99 {lq[2]:6.1f}"
        f"   p99.9 {lq[3]:8.1f}   max {st.lateness_max * 1e6:8.1f} us"
    )
    eq = [task.exec_percentile(q) * 1e6 for q in (0.5, 0.9, 0.99, 0.999)]
    print(
        f"  exec     p50 {eq[0]:6.1f} us   p90 {eq[1]:6.1f}   p99 {eq[2]:6.1f}"
        f"   p99.9 {eq[3]:8.1f}   max {st.exec_max * 1e6:8.1f} us   mean {st.exec_mean * 1e6:.1f}"
    )
    eh = task.exec_hist
    lh = task.lat_hist
    slow = {ms: int(eh[ms * 1000 :].sum()) for ms in (0.5, 1, 2, 5) if ms >= 1}
    slow_half = int(eh[500:].sum())
    late = {us: int(lh[us:].sum()) for us in (200, 500, 1000)}
    print(
        f"  overruns {st.overruns}   omitted cycles {st.omitted_cycles}   cycles with exec"
        f" > 0.5/1/2/5 ms: {slow_half}/{slow[1]}/{slow[2]}/{slow[5]}   started"
        f" > 0.2/0.5/1 ms late: {late[200]}/{late[500]}/{late[1000]}"
    )
    nivcsw = ru1.ru_nivcsw - ru0.ru_nivcsw
    own = (ru1.ru_utime + ru1.ru_stime) - (ru0.ru_utime + ru0.ru_stime)
    others = max(0.0, (busy1 - busy0) / hz - own)
    steal = (steal1 - steal0) / hz
    print(
        f"  tail causes: {nivcsw} involuntary context switches of this process;"
        f" other processes used {others:.1f} CPU-s ({others / seconds:.2f} CPUs) during the run;"
        f" hypervisor steal {steal:.2f} s"
    )
    planning = [x for x in spikes if x[2] > 0]
    print(
        f"  cycles with exec > 0.5 ms: {len(spikes)}, of which {len(planning)} re-planned"
        f" (max {max((x[1] for x in planning), default=0)} us, up to"
        f" {max((x[2] for x in planning), default=0)} profiles in one cycle: the benchmark's"
        " axes run their legs in lockstep, ~60-90 us per planned profile); the others"
        f" (max {max((x[1] for x in spikes if not x[2]), default=0)} us) were preempted"
    )
    print(
        f"  (a normal cycle needs ~{eq[0]:.0f} us; exec above 1 ms without planning means the"
        " process was descheduled inside the cycle)"
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
    ap.add_argument("--cpu", type=int, default=None, help="pin the RT run to this CPU")
    ap.add_argument("--mlock", action="store_true", help="mlockall for the RT run")
    ap.add_argument("--spin-us", type=float, default=200.0, help="busy-wait before a deadline")
    ap.add_argument("--repeats", type=int, default=3, help="simulated runs per axis count")
    ap.add_argument("--axes", type=int, nargs="*", default=[1, 8, 32])
    ap.add_argument(
        "--rss-cycles",
        type=int,
        default=0,
        help="also run this many cycles with the default trace and report the RSS",
    )
    ap.add_argument("--rss-axes", type=int, default=8, help="axes of the --rss-cycles run")
    ap.add_argument("--calls", choices=("attr", "kw"), default="attr", help="FB call style")
    ap.add_argument("--drives", choices=("ideal", "can"), default="ideal")
    ap.add_argument(
        "--against",
        metavar="REF",
        default=None,
        help="also time a worktree of this git ref, alternately, and print the ratio",
    )
    ap.add_argument(
        "--base-calls",
        choices=("attr", "kw"),
        default=None,
        help="FB call style of the --against side (default: --calls)",
    )
    ap.add_argument(
        "--base-build",
        action="store_true",
        help="compile the --against worktree's own extensions (~1 min; when compiled modules"
        " changed since REF) instead of lending it this build's",
    )
    ap.add_argument("--child", type=Path, default=None, help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.child is not None:  # one measurement for --against (motionplc from --child)
        import motionplc

        if not Path(motionplc.__file__).resolve().is_relative_to(args.child.resolve()):
            raise SystemExit(f"motionplc imported from {motionplc.__file__}, not {args.child}")
        from motionplc._purepy import status

        wall, cpu = sim_throughput(args.axes[0], args.cycles, args.calls, args.drives)
        print(json.dumps([wall, cpu, status().reason]))
        return
    if args.against is not None:
        against(
            args.against,
            args.axes,
            args.cycles,
            args.repeats,
            args.calls,
            args.drives,
            args.base_calls,
            args.base_build,
        )
        return
    print(f"cpus: {os.cpu_count()}, load average: {os.getloadavg()}")
    for n in args.axes:
        runs = [
            sim_throughput(n, args.cycles, args.calls, args.drives) for _ in range(args.repeats)
        ]
        wall = [w for w, _ in runs]
        cpu = [c for _, c in runs]
        print(
            f"simulated clock, {args.drives} drives, {args.calls} calls, {n:2d} axes:"
            f" {max(wall):7.0f} cycles/s wall best"
            f" ({statistics.median(wall):7.0f} median), {max(cpu):7.0f} per CPU-second best"
            f" ({statistics.median(cpu):7.0f} median) = {max(wall) / 1000:.1f}x real time"
        )
    if args.rss_cycles > 0:
        rss_run(args.rss_axes, args.rss_cycles)
    if not args.no_rt:
        realtime(args.rt_axes, args.rt_seconds, args.fifo, args.cpu, args.mlock, args.spin_us)


if __name__ == "__main__":
    main()
