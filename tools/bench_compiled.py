"""Time ``plan`` with the compiled planning core, the pure-Python core and Ruckig, in one run.

The same random 1-DoF cases (Ruckig's "position-random" distributions, general states:
``tests.planning._cases``) are planned by

* ``compiled``: motionplc with its mypyc-compiled core (a subprocess without the switch; it
  must report the compiled core, else this tool stops and says why);
* ``pure``: motionplc's pure-Python sources (a subprocess with ``MOTIONPLC_PURE_PYTHON=1``);
* ``ruckig``: ``Ruckig(1).calculate`` on prebuilt ``InputParameter`` objects, in this process.

Each call is timed on its own with ``time.perf_counter_ns`` (garbage collector off, after a
warm-up pass over the same cases), problems prebuilt. The three are measured ``--repeat``
times in turn (the machine is shared: figures are noisy); per repeat the ratios
compiled/ruckig, pure/ruckig and pure/compiled, and at the end the medians over the repeats.
The compiled core also gets a check: its durations equal the pure ones bit for bit. Issue 15
targets: ``plan`` mean <= 10 us and p99 <= 30 us compiled::

    python tools/bench_compiled.py --cases 20000 --repeat 3
"""

from __future__ import annotations

import argparse
import gc
import json
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from motionplc import _purepy  # noqa: E402
from tests.planning._cases import generate_cases, import_ruckig  # noqa: E402


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--cases", type=int, default=20_000, help="plan calls per measurement")
    ap.add_argument("--seed", type=int, default=42, help="numpy Generator seed (42)")
    ap.add_argument("--repeat", type=int, default=3, help="measurements of each (3)")
    ap.add_argument("--worker", action="store_true", help=argparse.SUPPRESS)
    return ap.parse_args(argv)


def stats(ns: np.ndarray) -> dict[str, float]:
    us = ns / 1e3
    return {
        "mean": float(us.mean()),
        "p50": float(np.percentile(us, 50)),
        "p99": float(np.percentile(us, 99)),
        "max": float(us.max()),
    }


def worker(cases: int, seed: int) -> None:
    """Time motionplc's ``plan`` on the cases with the core this process imported; JSON out."""
    from motionplc import compiled_core
    from motionplc.planning import plan

    problems = [(c.start(), c.target(), c.limits()) for c in generate_cases(cases, seed)]
    for s, t, lim in problems:  # warm-up
        plan(s, t, lim)
    out = np.empty(len(problems), dtype=np.int64)
    durations: list[str] = []
    clock = time.perf_counter_ns
    gc.collect()
    gc.disable()
    try:
        for i, (s, t, lim) in enumerate(problems):
            t0 = clock()
            prof = plan(s, t, lim)
            out[i] = clock() - t0
            durations.append(prof.duration.hex())
    finally:
        gc.enable()
    core = compiled_core()
    json.dump({"core": list(core), "stats": stats(out), "durations": durations}, sys.stdout)


def run_worker(cases: int, seed: int, pure: bool) -> dict[str, Any]:
    env = dict(os.environ)
    env.pop(_purepy.ENV_PURE, None)
    if pure:
        env[_purepy.ENV_PURE] = "1"
    cmd = [sys.executable, __file__, "--worker", "--cases", str(cases), "--seed", str(seed)]
    res = subprocess.run(cmd, env=env, capture_output=True, text=True, cwd=ROOT, check=False)
    if res.returncode != 0:
        raise SystemExit(f"bench_compiled: worker failed:\n{res.stderr[-3000:]}")
    return json.loads(res.stdout)


def time_ruckig(rk: Any, inputs: list[Any]) -> np.ndarray:
    otg = rk.Ruckig(1)
    traj = rk.Trajectory(1)
    for inp in inputs:  # warm-up
        otg.calculate(inp, traj)
    out = np.empty(len(inputs), dtype=np.int64)
    clock = time.perf_counter_ns
    gc.collect()
    gc.disable()
    try:
        for i, inp in enumerate(inputs):
            t0 = clock()
            otg.calculate(inp, traj)
            out[i] = clock() - t0
    finally:
        gc.enable()
    return out


def fmt(name: str, s: dict[str, float]) -> str:
    return (
        f"  {name:<9} mean {s['mean']:8.2f} us   p50 {s['p50']:8.2f} us   "
        f"p99 {s['p99']:8.2f} us   max {s['max']:9.1f} us"
    )


def main(argv: list[str] | None = None) -> int:
    args = parse_args(argv)
    if args.worker:
        worker(args.cases, args.seed)
        return 0
    rk = import_ruckig()
    if rk is None:
        raise SystemExit("bench_compiled: the ruckig package is not installed (pip install ruckig)")
    inputs = [c.ruckig_input(rk) for c in generate_cases(args.cases, args.seed)]
    print(
        f"plan: {args.cases} random general-state cases (seed {args.seed}), {args.repeat} repeats"
    )
    rows: dict[str, list[dict[str, float]]] = {"compiled": [], "pure": [], "ruckig": []}
    for k in range(args.repeat):
        comp = run_worker(args.cases, args.seed, pure=False)
        if not comp["core"][0]:
            raise SystemExit(f"bench_compiled: no compiled core in use ({comp['core'][1]})")
        pure = run_worker(args.cases, args.seed, pure=True)
        if pure["core"][0]:
            raise SystemExit("bench_compiled: the pure-Python switch did not take effect")
        if comp["durations"] != pure["durations"]:
            n = sum(a != b for a, b in zip(comp["durations"], pure["durations"], strict=True))
            raise SystemExit(f"bench_compiled: {n} durations differ between compiled and pure")
        rk_stats = stats(time_ruckig(rk, inputs))
        rows["compiled"].append(comp["stats"])
        rows["pure"].append(pure["stats"])
        rows["ruckig"].append(rk_stats)
        print(f"repeat {k + 1}: compiled {comp['core'][1]}; durations bit-identical to pure")
        for name, s in (("compiled", comp["stats"]), ("pure", pure["stats"]), ("ruckig", rk_stats)):
            print(fmt(name, s))
        c, p, r = comp["stats"], pure["stats"], rk_stats
        print(
            f"  ratios (mean / p99): compiled/ruckig {c['mean'] / r['mean']:.1f}x / "
            f"{c['p99'] / r['p99']:.1f}x   pure/ruckig {p['mean'] / r['mean']:.1f}x / "
            f"{p['p99'] / r['p99']:.1f}x   pure/compiled {p['mean'] / c['mean']:.2f}x / "
            f"{p['p99'] / c['p99']:.2f}x"
        )
    print(f"median over {args.repeat} repeats:")
    med = {
        name: {key: statistics.median(s[key] for s in runs) for key in runs[0]}
        for name, runs in rows.items()
    }
    for name, s in med.items():
        print(fmt(name, s))

    def ratio(a: str, b: str, key: str) -> float:
        return statistics.median(x[key] / y[key] for x, y in zip(rows[a], rows[b], strict=True))

    print(
        f"  ratios (median of per-repeat, mean / p99): compiled/ruckig "
        f"{ratio('compiled', 'ruckig', 'mean'):.1f}x / {ratio('compiled', 'ruckig', 'p99'):.1f}x"
        f"   pure/ruckig {ratio('pure', 'ruckig', 'mean'):.1f}x / "
        f"{ratio('pure', 'ruckig', 'p99'):.1f}x   pure/compiled "
        f"{ratio('pure', 'compiled', 'mean'):.2f}x / {ratio('pure', 'compiled', 'p99'):.2f}x"
    )
    c = med["compiled"]
    ok = c["mean"] <= 10.0 and c["p99"] <= 30.0
    print(
        f"  target compiled mean <= 10 us and p99 <= 30 us: "
        f"{'met' if ok else 'MISSED'} ({c['mean']:.2f} / {c['p99']:.2f} us)"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
