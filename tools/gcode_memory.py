"""Memory of a long G-code run through the runtime: a program of ``--segments`` fine chords
(0.05-0.2 mm, as CAM posts a spline: a slowly turning curve over the table, F3000, G64 P0.01)
run by :class:`motionplc.gcode_runner.GcodeRunner` on configs/gcode/mill3.yaml (ideal drives,
simulated clock, every move one group FB, the file streamed), with the memory measured when
the runner has completed each of ``--marks`` moves:

* ``traced``: bytes held by Python allocations (tracemalloc), outside the trace's ring buffer
  (bounded by ``runtime.trace_bytes``: set to ``--trace-mb`` here, so that the ring is full
  before the first mark and the RSS is comparable);
* ``RSS``: the process' resident set (``/proc/self/status`` VmRSS) and its high-water mark;
* ``objects``: objects the garbage collector tracks.

Flat memory: the growth between the first and the last mark, per move run in between, is
printed (the issue's "~1.3 kB per move" was the runtime holding every move).

    python tools/gcode_memory.py                               # 10k / 50k / 150k segments
    python tools/gcode_memory.py --segments 20000 --marks 2000,10000,20000 --no-tracemalloc
"""

from __future__ import annotations

import argparse
import dataclasses
import gc
import math
import random
import sys
import tempfile
import time
import tracemalloc
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from motionplc.config import build, load_config  # noqa: E402
from motionplc.gcode_runner import GcodeRunner, load_gcode_job  # noqa: E402

MILL3 = ROOT / "configs" / "gcode" / "mill3.yaml"


def chords(n: int, seed: int = 3) -> str:
    """``n`` G1 chords of 0.05-0.2 mm along a slowly turning curve kept on the table (program
    coordinates within +-100 mm of the G54 origin), CAM style (``X.. Y..`` words only)."""
    rng = random.Random(seed)
    x, y, heading, turn = 0.0, 0.0, 0.0, 0.0
    out = [
        "%",
        f"({n} fine chords: motionplc tools/gcode_memory.py)",
        "G21 G90 G17 G64 P0.01",
        "G0 X0 Y0 Z2",
        "G1 Z-1 F300",
        "F3000",
    ]
    for _ in range(n):
        turn = max(-0.02, min(0.02, turn + rng.uniform(-0.002, 0.002)))
        heading += turn
        if math.hypot(x, y) > 90.0:  # steer back towards the middle
            heading = math.atan2(-y, -x) + rng.uniform(-0.5, 0.5)
        step = rng.uniform(0.05, 0.2)
        x += step * math.cos(heading)
        y += step * math.sin(heading)
        out.append(f"X{x:.4f} Y{y:.4f}")
    out += ["G0 Z5", "M2", "%"]
    return "\n".join(out) + "\n"


def _rss() -> tuple[int, int]:
    """(VmRSS, VmHWM) [bytes] of this process."""
    rss = hwm = 0
    for line in Path("/proc/self/status").read_text().splitlines():
        if line.startswith("VmRSS:"):
            rss = int(line.split()[1]) * 1024
        elif line.startswith("VmHWM:"):
            hwm = int(line.split()[1]) * 1024
    return rss, hwm


def _untraced(snapshot: tracemalloc.Snapshot) -> int:
    """Traced bytes outside the trace's own ring buffer (bounded by its trace_bytes)."""
    flt = tracemalloc.Filter(False, "*/runtime/trace.py")
    return sum(st.size for st in snapshot.filter_traces([flt]).statistics("filename"))


def _reached(runner: GcodeRunner, moves: int):  # noqa: ANN202 - a predicate
    return lambda: runner.over or runner.lines_run >= moves


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--segments", type=int, default=150_000)
    ap.add_argument("--marks", default="10000,50000,150000", help="moves run at each figure")
    ap.add_argument("--trace-mb", type=float, default=4.0, help="runtime.trace_bytes [MiB]")
    ap.add_argument("--no-tracemalloc", action="store_true", help="RSS only (faster)")
    args = ap.parse_args(argv)
    marks = sorted(int(m) for m in args.marks.split(","))
    total = args.segments + 3  # the rapid and the plunge before, the retract after
    marks = [m for m in marks if m <= total] or [total]
    cfg = load_config(MILL3)
    cfg = dataclasses.replace(
        cfg,
        runtime=dataclasses.replace(cfg.runtime, trace_bytes=int(args.trace_mb * 2**20)),
    )
    with tempfile.TemporaryDirectory() as tmp:
        prog = Path(tmp) / "chords.ngc"
        prog.write_text(chords(args.segments))
        size = prog.stat().st_size
        job = load_gcode_job(prog, cfg, timeout=1e7)
        machine = build(cfg)
        runner = GcodeRunner(job, machine)
        machine.attach(runner, job.task)
        rt = machine.runtime
        traced = not args.no_tracemalloc
        print(  # noqa: T201
            f"{args.segments} chords ({size / 1e6:.1f} MB file, {job.program.n_moves} moves) on "
            f"mill3, trace ring {args.trace_mb:g} MiB, tracemalloc {'on' if traced else 'off'}"
        )
        print(  # noqa: T201
            f"{'moves run':>10} {'virtual s':>10} {'cpu s':>8} {'traced MB':>10} "
            f"{'RSS MB':>8} {'RSS max MB':>10} {'objects':>9} {'trace rows':>10}"
        )
        if traced:
            tracemalloc.start()
        c0 = time.process_time()
        rows = []
        for m in marks:
            rt.run_until(_reached(runner, m), max_seconds=1e7)
            gc.collect()
            b = _untraced(tracemalloc.take_snapshot()) if traced else 0
            rss, hwm = _rss()
            objs = len(gc.get_objects())
            rows.append((runner.lines_run, b, rss, objs))
            print(  # noqa: T201
                f"{runner.lines_run:>10} {rt.time:>10.1f} {time.process_time() - c0:>8.1f} "
                f"{b / 1e6:>10.3f} {rss / 1e6:>8.1f} {hwm / 1e6:>10.1f} {objs:>9} "
                f"{len(rt.trace):>10}"
            )
            sys.stdout.flush()
            if runner.over:
                break
        rt.run_until(lambda: runner.over, max_seconds=1e7)
        if traced:
            tracemalloc.stop()
        machine.close()
    if runner.failed:
        print(f"the run failed: {runner.failures[0]}")  # noqa: T201
        return 1
    print(runner.report())  # noqa: T201
    (n0, b0, r0, o0), (n1, b1, r1, o1) = rows[0], rows[-1]
    dn = max(1, n1 - n0)
    print(  # noqa: T201
        f"growth from {n0} to {n1} moves: traced {(b1 - b0) / dn:+.2f} B per move, RSS "
        f"{(r1 - r0) / dn:+.2f} B per move, objects {(o1 - o0) / dn:+.4f} per move"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
