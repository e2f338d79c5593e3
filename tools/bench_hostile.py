#!/usr/bin/env python3
"""Time and peak memory of ``motionplc validate`` on every hostile YAML file of
tests/config/hostile_corpus.py, each in its own process, against a valid configuration
measured in the same run (the machine is noisy: the interpreter's start and imports are in
both).

    .venv/bin/python tools/bench_hostile.py [--only NAME ...] [--keep DIR]

Per file (one process each, after the imports): exit code, the time of ``validate`` on it and
on the valid configuration in the same process, peak RSS of the process (VmHWM), the first
error line. The summary gives the largest time and memory.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from tests.config.hostile_corpus import DEMO, cases, write_case  # noqa: E402

DEMO_SEQUENCE = DEMO.with_name("demo_sequence.yaml")

CHILD = """
import contextlib, io, json, sys, time
from motionplc.cli import main
good, seq, args = sys.argv[1], sys.argv[2], sys.argv[3:]
err = io.StringIO()
with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
    t0 = time.perf_counter()
    main(["validate", good, seq])  # the valid files first: imports and first uses warm
    t1 = time.perf_counter()
    rc = main(["validate", *args]) if args else 0
    t2 = time.perf_counter()
first = (err.getvalue().splitlines() or [""])[0]
hwm = [r for r in open("/proc/self/status") if r.startswith("VmHWM:")]
peak = int(hwm[0].split()[1]) / 1024.0 if hwm else -1.0
out = {"good": t1 - t0, "bad": t2 - t1, "rc": rc, "first": first, "peak": peak}
sys.stdout.write(json.dumps(out))
"""


def measure(args: list[str]) -> tuple[int, float, float, float, str]:
    """(exit code, seconds of the valid files, seconds of the file, peak RSS in MB, first
    error line): one process validates the valid configuration and sequence, then the
    file."""
    proc = subprocess.Popen(
        [sys.executable, "-c", CHILD, str(DEMO), str(DEMO_SEQUENCE), *args],
        stdout=subprocess.PIPE,
        stderr=subprocess.DEVNULL,
        text=True,
        env=dict(os.environ, PYTHONPATH=str(ROOT)),
    )
    assert proc.stdout is not None
    out = json.loads(proc.stdout.read())
    proc.wait()
    # the child's own high-water mark (ru_maxrss of a forked child includes the parent's)
    return out["rc"], out["good"], out["bad"], out["peak"], out["first"]


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--only", nargs="*", default=None, help="case names")
    ap.add_argument("--keep", type=Path, default=None, help="write the files here and keep them")
    opts = ap.parse_args()
    _, base_s, _, base_mb, _ = measure([])
    print(f"{'(valid demo.yaml + demo_sequence)':32} {base_s:6.3f} s  {base_mb:6.1f} MB")
    worst_s = worst_mb = worst_ratio = 0.0
    bad = 0
    with tempfile.TemporaryDirectory() as tmp:
        directory = opts.keep or Path(tmp)
        selected = [c for c in cases() if not opts.only or c.name in opts.only]
        for case in selected:
            args, path = write_case(case, directory)
            size = path.stat().st_size
            rc, good_s, s, mb, first = measure(args)
            if opts.keep is None:
                path.unlink()
            worst_s, worst_mb = max(worst_s, s), max(worst_mb, mb)
            worst_ratio = max(worst_ratio, s / good_s)
            located = first.startswith(f"motionplc: error: {path}:")
            bad += rc != 2 or not located
            text = first.removeprefix("motionplc: error: ")[:80]
            print(
                f"{case.name:28} rc {rc} {s:6.3f} s ({s / good_s:5.1f}x valid) {mb:6.1f} MB "
                f"{size:>10} B {'located' if located else 'NOT LOCATED'}: {text}"
            )
    print(
        f"{len(selected)} files: largest time {worst_s:.3f} s (largest {worst_ratio:.1f}x the "
        f"valid files' validate in the same process), largest peak RSS {worst_mb:.1f} MB "
        f"({worst_mb - base_mb:+.1f} MB against validating the valid files alone); "
        f"{bad} not rc 2 with a located line"
    )
    return 1 if bad else 0


if __name__ == "__main__":
    raise SystemExit(main())
