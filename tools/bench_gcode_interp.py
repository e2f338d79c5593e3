"""The G-code interpreter's own figures (tools/bench_gcode.py is the motion benchmark).

1. **Interpret + map**: a file of ``--lines`` tiny G1 segments (a random walk, 0.05-0.2 mm,
   CAM style ``X.. Y.. Z..`` words) is interpreted and mapped to group FB calls
   (:func:`motionplc.gcode_runner.iter_group_moves`), streaming: lines per second, and the
   peak traced memory of the pass (flat in the file length: compared with a file of a tenth
   of the lines).
2. **Runtime memory per executed move**: the same kind of program run by the runtime
   (configs/gcode/mill3.yaml, ideal drives, simulated clock, GcodeRunner): traced memory after
   ``--run-segments`` / 10 moves and after all of them; the growth per move.
3. **Corpus**: every program of tests/gcode/corpus validated on both mills (counts).

    python tools/bench_gcode_interp.py --lines 150000 --run-segments 150000
    python tools/bench_gcode_interp.py --file largest     # a real program: the largest one of
                                                          # tests/gcode/thirdparty (or a path)
"""

from __future__ import annotations

import argparse
import gc
import random
import sys
import tempfile
import time
import tracemalloc
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from motionplc.config import build, load_config  # noqa: E402
from motionplc.gcode import load_gcode  # noqa: E402
from motionplc.gcode_runner import (  # noqa: E402
    GcodeRunner,
    iter_group_moves,
    load_gcode_job,
    setup_from_config,
)

MILL3 = ROOT / "configs" / "gcode" / "mill3.yaml"
MILL4 = ROOT / "configs" / "gcode" / "mill4.yaml"


def tiny_segments(n: int, seed: int = 1) -> str:
    rng = random.Random(seed)
    x, y, z = 0.0, 0.0, -1.0
    out = [
        "%",
        "(tiny segments, motionplc bench)",
        "G21 G90 G17 G64 P0.01",
        "G0 X0 Y0 Z2",
        "G1 Z-1 F300",
        "F1200",
    ]
    for _ in range(n):
        x = max(-80.0, min(80.0, x + rng.uniform(-0.2, 0.2)))
        y = max(-80.0, min(80.0, y + rng.uniform(-0.2, 0.2)))
        z = max(-3.0, min(-0.5, z + rng.uniform(-0.01, 0.01)))
        out.append(f"X{x:.4f} Y{y:.4f} Z{z:.4f}")
    out += ["G0 Z5", "M2", "%"]
    return "\n".join(out) + "\n"


def interpret_and_map(path: Path, cfg: object, traced: bool) -> tuple[int, float, int]:
    """(group moves, CPU seconds, peak traced bytes (0 untraced)) of one streaming pass."""
    setup = setup_from_config(cfg, cfg.groups[0].name)  # type: ignore[attr-defined]
    from motionplc.gcode import GcodeProgram

    prog = GcodeProgram(str(path), setup)
    gc.collect()
    if traced:
        tracemalloc.start()
    t0 = time.process_time()
    n = 0
    for _ in iter_group_moves(prog.interpreter().run(), setup):
        n += 1
    dt = time.process_time() - t0
    peak = 0
    if traced:
        peak = tracemalloc.get_traced_memory()[1]
        tracemalloc.stop()
    return n, dt, peak


THIRDPARTY = ROOT / "tests" / "gcode" / "thirdparty"


def largest_program() -> Path:
    """The largest third-party program that validates on mill3 (tests/gcode/thirdparty)."""
    rows = (ln.split("\t") for ln in (THIRDPARTY / "expected.tsv").read_text().splitlines())
    ok = [THIRDPARTY / r[0] for r in rows if r[1].startswith("ok")]
    return max(ok, key=lambda p: p.stat().st_size)


def file_figures(path: Path, cfg_path: Path = MILL3, repeat: int = 3) -> str:
    """Interpret + map of a real program on ``cfg_path`` (the best of ``repeat`` passes, CPU
    time; the file is validated first, as ``motionplc run`` does, timed apart)."""
    cfg = load_config(cfg_path)
    setup = setup_from_config(cfg, cfg.groups[0].name)
    t0 = time.process_time()
    load_gcode(path, setup=setup)
    t_val = time.process_time() - t0
    n_lines = len(path.read_bytes().splitlines())
    best, n = float("inf"), 0
    for _ in range(repeat):
        n, dt, _ = interpret_and_map(path, cfg, False)
        best = min(best, dt)
    _, _, peak = interpret_and_map(path, cfg, True)
    name = path.relative_to(ROOT) if path.is_relative_to(ROOT) else path
    return (
        f"{name} ({path.stat().st_size / 1e6:.2f} MB, {n_lines} lines) on "
        f"{cfg_path.stem}: validate {t_val:.2f} s CPU; interpret + map {n} group moves in "
        f"{best:.2f} s CPU = {n_lines / best:,.0f} lines/s ({best / n_lines * 1e4:.3f} s per "
        f"10000 lines), peak traced memory {peak / 1e6:.2f} MB"
    )


def _untraced(snapshot: tracemalloc.Snapshot) -> int:
    """Traced bytes outside the trace's own ring buffer (bounded by its max_bytes)."""
    flt = tracemalloc.Filter(False, "*/runtime/trace.py")
    return sum(st.size for st in snapshot.filter_traces([flt]).statistics("filename"))


def runtime_memory(path: Path, cfg_path: Path, total: int) -> tuple[int, int, int, float, int]:
    """(moves at the first sample, bytes then, bytes at the end, seconds, trace bytes):
    traced memory outside the trace ring (the trace is bounded by its own max_bytes)."""
    cfg = load_config(cfg_path)
    job = load_gcode_job(path, cfg, timeout=1e6)
    machine = build(cfg)
    runner = GcodeRunner(job, machine)
    machine.attach(runner, job.task)
    rt = machine.runtime
    first = max(1, total // 10)
    tracemalloc.start()
    t0 = time.perf_counter()
    rt.run_until(lambda: runner.over or runner.lines_run >= first, max_seconds=1e7)
    gc.collect()
    mark = (runner.lines_run, _untraced(tracemalloc.take_snapshot()))
    rt.run_until(lambda: runner.over, max_seconds=1e7)
    dt = time.perf_counter() - t0
    gc.collect()
    end = _untraced(tracemalloc.take_snapshot())
    tracemalloc.stop()
    trace_bytes = int(rt.trace.nbytes)
    machine.close()
    if runner.failed:
        raise SystemExit(f"the run failed: {runner.failures}")
    return mark[0], mark[1], end, dt, trace_bytes


def corpus() -> tuple[int, int, int]:
    files = sorted((ROOT / "tests" / "gcode" / "corpus").glob("*.ngc"))
    ok3 = ok4 = 0
    for cfg_path in (MILL3, MILL4):
        cfg = load_config(cfg_path)
        group = cfg.groups[0].name
        setup = setup_from_config(cfg, group)
        for f in files:
            try:
                load_gcode(f, setup=setup)
            except Exception:  # noqa: BLE001 - counted (the rotary programs on mill3)
                continue
            if cfg_path == MILL3:
                ok3 += 1
            else:
                ok4 += 1
    return len(files), ok3, ok4


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--lines", type=int, default=150_000)
    ap.add_argument("--run-segments", type=int, default=20_000)
    ap.add_argument(
        "--file",
        action="append",
        default=[],
        help="interpret + map this program only (repeatable; 'largest': the largest "
        "third-party program of tests/gcode/thirdparty)",
    )
    args = ap.parse_args(argv)
    if args.file:
        for f in args.file:
            print(file_figures(largest_program() if f == "largest" else Path(f).resolve()))  # noqa: T201
        return 0
    cfg = load_config(MILL3)
    with tempfile.TemporaryDirectory() as tmp:
        big = Path(tmp) / "tiny.ngc"
        small = Path(tmp) / "tiny_small.ngc"
        big.write_text(tiny_segments(args.lines))
        small.write_text(tiny_segments(max(1, args.lines // 10)))
        n, dt, _ = interpret_and_map(big, cfg, False)
        _, _, peak = interpret_and_map(big, cfg, True)
        _, _, peak_s = interpret_and_map(small, cfg, True)
        print(  # noqa: T201
            f"interpret + map: {args.lines} lines -> {n} group moves in {dt:.2f} s CPU = "
            f"{args.lines / dt:,.0f} lines/s ({dt / args.lines * 1e4:.3f} s per 10000 lines); "
            f"peak traced memory {peak / 1e6:.2f} MB (a tenth of the lines: "
            f"{peak_s / 1e6:.2f} MB)"
        )
        run = Path(tmp) / "run.ngc"
        run.write_text(tiny_segments(args.run_segments, seed=2))
        m0, b0, b1, rdt, tb = runtime_memory(run, MILL3, args.run_segments)
        total = args.run_segments + 2
        print(  # noqa: T201
            f"runtime: {total} moves in {rdt:.1f} s; memory outside the trace ring after {m0} "
            f"moves {b0 / 1e6:.2f} MB, after {total} moves {b1 / 1e6:.2f} MB: "
            f"{(b1 - b0) / max(1, total - m0):.1f} bytes per move (the trace ring: "
            f"{tb / 1e6:.1f} MB, bounded by its max_bytes)"
        )
    n_files, ok3, ok4 = corpus()
    print(f"corpus: {n_files} programs; valid on mill3 {ok3}, on mill4 {ok4}")  # noqa: T201
    return 0


if __name__ == "__main__":
    sys.exit(main())
