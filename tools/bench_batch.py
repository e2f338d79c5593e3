"""Time ``plan_batch`` per plan against Ruckig's own loop and a Python loop of ``plan``.

For each N (default 10, 100, 1e3, 1e4, 1e5) and each kind of problem, in one run on the same cases:

* ``batch``: one ``plan_batch`` call on the N problems (arrays built beforehand), per plan;
* ``ruckig``: ``Ruckig(1).calculate(inp, traj)`` in a Python loop over prebuilt
  ``InputParameter`` objects (Ruckig's per-plan time as a Python user sees it);
* ``plan``: ``plan(start, target, limits)`` in a Python loop over prebuilt ``State``/``Limits``.

Kinds: ``rest`` rest to rest (v0 = a0 = vf = af = 0) with Ruckig's position and limit
distributions, symmetric limits; ``rest-asym`` the same with asymmetric limits (v_min, a_min
drawn independently: one-plateau and no-plateau rows by closed forms); ``general`` Ruckig's
``position-random`` distributions (tests/planning/_cases.py). Every timing is repeated
``--repeat`` times and the median is printed, with the ratios of the medians (the machine is
noisy: compare ratios of one run). ``--check`` also asserts that every batch duration equals
``plan``'s (bit for bit; within 1e-12 for the rest-to-rest rows with one acceleration plateau
or asymmetric limits, which plan solves by quartic roots and plan_batch in closed form)::

    python tools/bench_batch.py --repeat 5

``--cpu`` times by the process' CPU time instead of the wall clock (the figures then leave out
the time other jobs took the CPU). ``--touch`` adds the first use of ``BatchPlan.kind`` (its
tuple of N names is built lazily; every array is built by the call). Batches of at most
``batch._SMALL`` problems (with the compiled core every batch, as plain Python 64) take
plan_batch's row-by-row path, larger ones numpy; ``--path rows numpy`` adds a column per
path, plan_batch forced through it (how the compiled core's choice was made). Each
timing is one call, so it includes the cold caches left by the loops before it: a size timed
after others can differ by ~20 % from the same size timed alone (compare before/after runs
with the same ``--sizes``).
    python tools/bench_batch.py --sizes 10000 --kinds rest --repeat 9
"""

from __future__ import annotations

import argparse
import gc
import statistics
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from motionplc.planning import batch as batch_module  # noqa: E402
from motionplc.planning import plan  # noqa: E402
from motionplc.planning.batch import plan_batch  # noqa: E402
from tests.planning._cases import Case, generate_cases, import_ruckig  # noqa: E402

KINDS = ("rest", "rest-asym", "general")


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument(
        "--sizes",
        type=int,
        nargs="+",
        default=[10, 100, 1000, 10_000, 100_000],
        help="batch sizes N (10 100 1000 10000 100000)",
    )
    ap.add_argument("--kinds", nargs="+", choices=KINDS, default=list(KINDS), help="problem kinds")
    ap.add_argument("--repeat", type=int, default=3, help="repetitions; medians reported (3)")
    ap.add_argument("--seed", type=int, default=42, help="numpy Generator seed (42)")
    ap.add_argument(
        "--loop-max",
        type=int,
        default=20_000,
        help="at most this many cases in the plan loop per N (per-plan mean; 20000)",
    )
    ap.add_argument("--check", action="store_true", help="assert batch durations == plan's")
    ap.add_argument(
        "--cpu",
        action="store_true",
        help="time by the process' CPU time (user + system) instead of the wall clock: "
        "steadier on a machine shared with other jobs",
    )
    ap.add_argument(
        "--path",
        nargs="+",
        choices=("rows", "numpy"),
        default=[],
        help="also time plan_batch forced through these paths (batch._SMALL set): 'rows' row "
        "by row (the compiled core's path for every batch), 'numpy' the vectorised path (the "
        "pure-Python core's beyond 64 problems)",
    )
    ap.add_argument(
        "--touch",
        action="store_true",
        help="the batch timing also builds the kind tuple (built on first use of .kind)",
    )
    return ap.parse_args(argv)


def rest_cases(n: int, seed: int, asymmetric: bool) -> list[Case]:
    """Rest-to-rest cases: Ruckig's position and limit distributions, every v and a zero."""
    rng = np.random.default_rng(seed)
    p0 = rng.normal(0.0, 4.0, n)
    pf = rng.normal(0.0, 4.0, n)
    vmax = rng.uniform(0.08, 16.0, n)
    amax = rng.uniform(0.08, 16.0, n)
    jmax = rng.uniform(0.08, 16.0, n)
    vmin = -rng.uniform(0.08, 16.0, n)
    amin = -rng.uniform(0.08, 16.0, n)
    out = []
    for i in range(n):
        out.append(
            Case(
                float(p0[i]), 0.0, 0.0, float(pf[i]), 0.0, 0.0,
                float(vmax[i]), float(amax[i]), float(jmax[i]),
                float(vmin[i]) if asymmetric else None,
                float(amin[i]) if asymmetric else None,
                tag="rest",
            )
        )  # fmt: skip
    return out


def columns(cases: list[Case]) -> list[np.ndarray]:
    """The eleven plan_batch arguments as arrays."""
    cols = [np.array([getattr(c, f) for c in cases]) for f in Case.__slots__[:9]]
    cols.append(np.array([c.lo_v for c in cases]))
    cols.append(np.array([c.lo_a for c in cases]))
    return cols


def timed(fn: Callable[[], object], clock: Callable[[], int] = time.perf_counter_ns) -> float:
    gc.collect()
    gc.disable()
    try:
        t0 = clock()
        fn()
        return float(clock() - t0)
    finally:
        gc.enable()


def bench(kind: str, n: int, args: argparse.Namespace, rk: Any) -> dict[str, float]:
    if kind == "general":
        cases = generate_cases(n, args.seed)
    else:
        cases = rest_cases(n, args.seed, asymmetric=kind == "rest-asym")
    cols = columns(cases)
    m = min(n, args.loop_max)
    problems = [(c.start(), c.target(), c.limits()) for c in cases[:m]]
    res: dict[str, list[float]] = {"batch": [], "ruckig": [], "plan": []}
    for path in args.path:
        res[path] = []
    clock = time.process_time_ns if args.cpu else time.perf_counter_ns
    inputs = [c.ruckig_input(rk) for c in cases] if rk is not None else []
    if rk is not None:
        otg = rk.Ruckig(1)
        traj = rk.Trajectory(1)
    for _ in range(args.repeat):
        if args.touch:
            res["batch"].append(timed(lambda: plan_batch(*cols).kind, clock) / n)
        else:
            res["batch"].append(timed(lambda: plan_batch(*cols), clock) / n)
        for path in args.path:
            saved = batch_module._SMALL
            batch_module._SMALL = sys.maxsize if path == "rows" else 0
            try:
                res[path].append(timed(lambda: plan_batch(*cols), clock) / n)
            finally:
                batch_module._SMALL = saved
        if rk is not None:

            def loop_rk() -> None:
                calc = otg.calculate
                for inp in inputs:
                    calc(inp, traj)

            res["ruckig"].append(timed(loop_rk, clock) / n)

        def loop_plan() -> None:
            for s, t, lim in problems:
                plan(s, t, lim)

        res["plan"].append(timed(loop_plan, clock) / m)
    if args.check:  # bit for bit, but closed-form rest-to-rest rows: within 1e-12
        b = plan_batch(*cols)
        for i, (s, t, lim) in enumerate(problems):
            ref = plan(s, t, lim).duration
            assert abs(ref - b.duration[i]) <= 1e-12 * max(1.0, ref), (kind, i, cases[i])
            assert ref == b.duration[i] or b.kind[i].split("-")[0] in ("none", "acc0", "acc1")
    return {k: statistics.median(v) / 1e3 for k, v in res.items() if v}


def main(argv: list[str] | None = None) -> int:
    args = parse_args(argv)
    rk = import_ruckig()
    import motionplc

    status = getattr(motionplc, "compiled_core", None)
    print(f"planning core: {status().reason if status is not None else 'pure Python'}")
    print(
        f"plan_batch per plan [us, {'CPU' if args.cpu else 'wall'} time], medians of "
        f"{args.repeat}; ruckig: Ruckig(1).calculate loop, "
        f"plan: Python loop of plan (at most {args.loop_max} cases)"
    )
    if rk is None:
        print("ruckig is not installed: no Ruckig column")
    head = f"{'kind':10s} {'N':>7s} {'batch':>9s} {'ruckig':>9s} {'plan':>9s}"
    head += f" {'batch/ruckig':>13s} {'plan/batch':>11s}"
    print(head + "".join(f" {p:>9s}" for p in args.path))
    for kind in args.kinds:
        for n in args.sizes:
            r = bench(kind, n, args, rk)
            rr = r.get("ruckig", float("nan"))
            print(
                f"{kind:10s} {n:7d} {r['batch']:9.3f} {rr:9.3f} {r['plan']:9.3f} "
                f"{r['batch'] / rr:13.2f} {r['plan'] / r['batch']:11.1f}"
                + "".join(f" {r[p]:9.3f}" for p in args.path)
            )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
