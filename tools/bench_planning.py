"""Time motionplc's ``plan`` against Ruckig on the same random 1-DoF cases.

Each call is timed on its own with ``time.perf_counter_ns`` (the timer's own overhead, a few
tens of ns, is included for both planners). Ruckig is timed as ``Ruckig(1).calculate`` on
prebuilt ``InputParameter`` objects; motionplc as ``plan`` on prebuilt ``State``/``Limits``.
Also times ``Profile.at`` (random t on random profiles) and ``Profile.sample`` on 10,000
times::

    python tools/bench_planning.py --cases 100000 --seed 42
"""

from __future__ import annotations

import argparse
import gc
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from motionplc.planning import Profile, plan  # noqa: E402
from tests.planning._cases import RuckigOracle, import_ruckig, iter_cases  # noqa: E402


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--cases", type=int, default=100_000, help="number of plan calls (100000)")
    ap.add_argument("--seed", type=int, default=42, help="numpy Generator seed (42)")
    ap.add_argument(
        "--outside-fraction", type=float, default=0.0, help="starts outside the limits (0.0)"
    )
    ap.add_argument("--order", type=int, choices=(2, 3), default=3, help="profile order (3)")
    ap.add_argument("--at-calls", type=int, default=100_000, help="Profile.at calls (100000)")
    ap.add_argument(
        "--sample-times", type=int, default=10_000, help="times per Profile.sample call (10000)"
    )
    ap.add_argument("--sample-calls", type=int, default=200, help="Profile.sample calls (200)")
    return ap.parse_args(argv)


def stats_us(ns: np.ndarray) -> dict[str, float]:
    us = ns / 1e3
    return {
        "mean": float(us.mean()),
        "p50": float(np.percentile(us, 50)),
        "p99": float(np.percentile(us, 99)),
        "max": float(us.max()),
    }


def fmt(name: str, s: dict[str, float]) -> str:
    return (
        f"{name:<10} mean {s['mean']:9.2f} us   p50 {s['p50']:9.2f} us   "
        f"p99 {s['p99']:9.2f} us   max {s['max']:10.2f} us"
    )


def time_ours(problems: list[tuple[Any, Any, Any]]) -> tuple[np.ndarray, list[Profile]]:
    out = np.empty(len(problems), dtype=np.int64)
    profs: list[Profile] = []
    clock = time.perf_counter_ns
    for i, (s, t, lim) in enumerate(problems):
        t0 = clock()
        prof = plan(s, t, lim)
        out[i] = clock() - t0
        profs.append(prof)
    return out, profs


def time_ruckig(rk: Any, inputs: list[Any]) -> np.ndarray:
    otg = rk.Ruckig(1)
    traj = rk.Trajectory(1)
    out = np.empty(len(inputs), dtype=np.int64)
    clock = time.perf_counter_ns
    for i, inp in enumerate(inputs):
        t0 = clock()
        otg.calculate(inp, traj)
        out[i] = clock() - t0
    return out


def main(argv: list[str] | None = None) -> int:
    args = parse_args(argv)
    rk = import_ruckig()
    oracle = RuckigOracle(rk) if rk is not None else None
    stream = iter_cases(
        args.seed,
        outside_fraction=args.outside_fraction,
        order=args.order,
        redraw_invalid=True,
        oracle=oracle,
    )
    cases = [next(stream) for _ in range(args.cases)]
    problems = [(c.start(), c.target(), c.limits()) for c in cases]
    print(
        f"{len(cases)} cases (seed {args.seed}, order {args.order}, "
        f"outside fraction {args.outside_fraction})"
    )

    gc.collect()
    gc.disable()
    try:
        # warm-up (imports, caches) on a few cases, not timed
        for s, t, lim in problems[:200]:
            plan(s, t, lim)
        ours_ns, profs = time_ours(problems)
        ours = stats_us(ours_ns)
        print(fmt("motionplc", ours))
        if rk is not None:
            inputs = [c.ruckig_input(rk) for c in cases]
            time_ruckig(rk, inputs[:200])
            theirs = stats_us(time_ruckig(rk, inputs))
            print(fmt("ruckig", theirs))
            print(
                f"ratio motionplc/ruckig: mean {ours['mean'] / theirs['mean']:.1f}x   "
                f"p99 {ours['p99'] / theirs['p99']:.1f}x"
            )
        else:
            print("ruckig not installed: no comparison")

        # Profile.at: random profile, random t (batch-timed, per-call mean)
        rng = np.random.default_rng(args.seed)
        idx = rng.integers(len(profs), size=args.at_calls)
        u = rng.random(args.at_calls)
        calls = [(profs[i], float(x * profs[i].duration)) for i, x in zip(idx, u, strict=True)]
        t0 = time.perf_counter_ns()
        for prof, t in calls:
            prof.at(t)
        at_ns = time.perf_counter_ns() - t0
        t0 = time.perf_counter_ns()
        for _prof, _t in calls:
            pass
        loop_ns = time.perf_counter_ns() - t0
        print(
            f"Profile.at      mean {(at_ns - loop_ns) / args.at_calls / 1e3:9.3f} us per call "
            f"({args.at_calls} calls)"
        )

        # Profile.sample on sample_times times spanning each profile
        per_call: list[int] = []
        for k in range(args.sample_calls):
            prof = profs[k]
            ts = np.linspace(0.0, prof.duration, args.sample_times)
            t0 = time.perf_counter_ns()
            prof.sample(ts)
            per_call.append(time.perf_counter_ns() - t0)
        sm = np.asarray(per_call) / 1e3
        print(
            f"Profile.sample  mean {sm.mean():9.1f} us per call of {args.sample_times} times "
            f"({sm.mean() * 1e3 / args.sample_times:.1f} ns per time, p99 "
            f"{np.percentile(sm, 99):.1f} us, {args.sample_calls} calls)"
        )
        if rk is not None:
            inp = cases[0].ruckig_input(rk)
            otg, traj = rk.Ruckig(1), rk.Trajectory(1)
            otg.calculate(inp, traj)
            ts_list = [float(x) for x in np.linspace(0.0, traj.duration, args.sample_times)]
            t0 = time.perf_counter_ns()
            for t in ts_list:
                traj.at_time(t)
            dt = (time.perf_counter_ns() - t0) / len(ts_list) / 1e3
            print(f"(ruckig Trajectory.at_time for reference: mean {dt:.3f} us per call)")
    finally:
        gc.enable()
    return 0


if __name__ == "__main__":
    sys.exit(main())
