"""Time motionplc's ``plan`` against Ruckig on the same random 1-DoF cases.

Each call is timed on its own with ``time.perf_counter_ns`` (the timer's own overhead, a few
tens of ns, is included for both planners). Ruckig is timed as ``Ruckig(1).calculate`` on
prebuilt ``InputParameter`` objects; motionplc as ``plan`` on prebuilt ``State``/``Limits``.
Also times ``Profile.at`` (random t on random profiles) and ``Profile.sample`` on 10,000
times::

    python tools/bench_planning.py --cases 100000 --seed 42

Synchronised planning (issues 3 and 15): ``plan_sync`` (time synchronisation) against
Ruckig's ``Synchronization.Time`` on the same 3-, 6-, 12- and 24-axis cases, rest to rest
(every v and a zero: exact limit scaling) and general (Ruckig's ``random_3`` distributions);
each is also expressed per axis relative to single-axis ``plan`` calls on the same axes, timed
interleaved with it (issue 15 targets: rest to rest <= 1.5x, general <= 3x; the ratio of the
totals, the median of the per-case ratios beside it), and to the 1-DoF run's mean. The general
rows are timed with both fixed-duration methods in the same run, interleaved per case:
``direct`` (the closed-form families of ``motionplc.planning._fixed``, the default) and
``bisection`` (the seed 004 jerk bisection, the previous code), with their ratio and the
fallback rate of ``direct`` (axes whose profile still came from the bisection or a scan).
Finally ``OnlineGenerator.update`` when the target is unchanged (no re-plan), per axis
(target: <= 3 us)::

    python tools/bench_planning.py --sync-cases 2000 --update-calls 200000
    python tools/bench_planning.py --cases 20000 --sync-only   # the synchronisation part only
"""

from __future__ import annotations

import argparse
import dataclasses
import gc
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from motionplc.planning import Limits, OnlineGenerator, Profile, State, plan, plan_sync  # noqa: E402
from motionplc.planning.sync import is_fallback_kind  # noqa: E402
from tests.planning._cases import (  # noqa: E402
    MultiCase,
    RuckigOracle,
    import_ruckig,
    iter_cases,
    iter_multi_cases,
)


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
    ap.add_argument(
        "--sync-cases",
        type=int,
        default=2000,
        help="plan_sync calls per configuration (3/6/12/24 axes x rest/general) (2000; 0 skips)",
    )
    ap.add_argument(
        "--sync-axes",
        type=int,
        nargs="+",
        default=[3, 6, 12, 24],
        help="axis counts of the plan_sync rows (3 6 12 24)",
    )
    ap.add_argument(
        "--sync-only",
        action="store_true",
        help="time only the single-axis plan (as the reference) and plan_sync",
    )
    ap.add_argument(
        "--update-calls",
        type=int,
        default=200_000,
        help="OnlineGenerator.update calls per configuration (200000; 0 skips)",
    )
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


def rest_to_rest(case: MultiCase) -> MultiCase:
    """The same positions and limits with every velocity and acceleration zero."""
    axes = tuple(
        dataclasses.replace(c, v0=0.0, a0=0.0, vf=0.0, af=0.0, tag="rest") for c in case.axes
    )
    return dataclasses.replace(case, axes=axes, tag="rest")


def time_plan_cases(problems: list[tuple[Any, Any, Any]]) -> np.ndarray:
    out = np.empty(len(problems), dtype=np.int64)
    clock = time.perf_counter_ns
    for i, (s, t, lim) in enumerate(problems):
        t0 = clock()
        plan(s, t, lim)
        out[i] = clock() - t0
    return out


def time_sync_methods(
    cases: list[MultiCase], both: bool
) -> tuple[np.ndarray, np.ndarray | None, np.ndarray, int, int]:
    """Per case, interleaved (so that the load of the machine hits all alike): ns of
    ``plan_sync`` with the ``direct`` method, with the ``bisection`` method (``both`` only,
    else None), and of single-axis ``plan`` calls on the same axes (summed); then the number
    of axes ``direct`` solved by its fallback and the number of axes slowed at all (not
    already ending at the synchronised duration)."""
    args = [(c.starts(), c.targets(), c.limits()) for c in cases]
    for s, t, lim in args[:20]:  # warm-up
        plan_sync(s, t, lim)
        plan_sync(s, t, lim, method="bisection")
    direct = np.empty(len(args), dtype=np.int64)
    bisect = np.empty(len(args), dtype=np.int64) if both else None
    single = np.empty(len(args), dtype=np.int64)
    clock = time.perf_counter_ns
    fallback = slowed = 0
    for i, (s, t, lim) in enumerate(args):
        total = 0
        for s1, t1, lim1 in zip(s, t, lim, strict=True):
            t0 = clock()
            plan(s1, t1, lim1)
            total += clock() - t0
        single[i] = total
        t0 = clock()
        traj = plan_sync(s, t, lim)
        direct[i] = clock() - t0
        if bisect is not None:
            t0 = clock()
            plan_sync(s, t, lim, method="bisection")
            bisect[i] = clock() - t0
        for prof, tmin in zip(traj.profiles, traj.independent_min_durations, strict=True):
            if prof.duration > tmin + 1e-9:
                slowed += 1
                fallback += is_fallback_kind(prof.kind)
    return direct, bisect, single, fallback, slowed


def time_ruckig_sync(rk: Any, cases: list[MultiCase]) -> np.ndarray:
    dofs = cases[0].dofs
    otg, traj = rk.Ruckig(dofs), rk.Trajectory(dofs)
    inputs = [c.ruckig_input(rk) for c in cases]
    for inp in inputs[:20]:
        otg.calculate(inp, traj)
    out = np.empty(len(inputs), dtype=np.int64)
    clock = time.perf_counter_ns
    for i, inp in enumerate(inputs):
        t0 = clock()
        otg.calculate(inp, traj)
        out[i] = clock() - t0
    return out


def bench_sync(args: argparse.Namespace, rk: Any, single: dict[str, float]) -> None:
    """plan_sync vs Ruckig, rest to rest and general, at ``args.sync_axes`` axes; per axis vs
    the single-axis ``plan`` of the same axes timed interleaved with it (the issue 15 ratio:
    the total over all cases, and the median of the per-case ratios), and vs ``single`` (the
    single-axis means of the 1-DoF run above, noisier: other cases, other moments); the
    general rows with both fixed-duration methods (before/after) and the fallback rate."""
    print(
        f"\nsynchronised planning (time sync), {args.sync_cases} cases per row; "
        f"single-axis plan mean of the 1-DoF run: general {single['general']:.1f} us, "
        f"rest to rest {single['rest']:.1f} us"
    )
    print(
        f"{'':18}{'motionplc mean':>15}{'p99':>9}{'ruckig mean':>13}{'ratio':>7}"
        f"{'per axis / plan of the same axes (median)':>43}{'/ 1-DoF mean':>14}{'target':>9}"
    )
    before: list[str] = []
    for kind, target in (("rest", 1.5), ("general", 3.0)):
        for dofs in args.sync_axes:
            stream = iter_multi_cases(args.seed + dofs, dofs, sync="time")
            cases = [next(stream) for _ in range(args.sync_cases)]
            if kind == "rest":
                cases = [rest_to_rest(c) for c in cases]
            d_ns, b_ns, s_ns, fallback, slowed = time_sync_methods(cases, kind == "general")
            ours = stats_us(d_ns)
            same = float(d_ns.sum() / s_ns.sum())
            same_med = float(np.median(d_ns / s_ns))
            if b_ns is not None:
                old = stats_us(b_ns)
                before.append(
                    f"general {dofs:2d} axes: bisection (before) mean {old['mean']:8.1f} us, "
                    f"direct (after) {ours['mean']:7.1f} us, before/after "
                    f"{old['mean'] / ours['mean']:.2f}x; per axis / plan of the same axes: "
                    f"before {float(b_ns.sum() / s_ns.sum()):.2f}x, after {same:.2f}x; "
                    f"fallback {fallback} of {slowed} slowed axes "
                    f"({100.0 * fallback / max(slowed, 1):.2f} %)"
                )
            row = f"{kind + f' {dofs} axes':<18}{ours['mean']:>12.1f} us{ours['p99']:>6.0f} us"
            if rk is not None:
                theirs = stats_us(time_ruckig_sync(rk, cases))
                row += f"{theirs['mean']:>10.1f} us{ours['mean'] / theirs['mean']:>6.0f}x"
            else:
                row += f"{'-':>13}{'-':>7}"
            per_axis = ours["mean"] / (dofs * single[kind])
            ok = "ok" if same <= target else "MISSED"
            row += f"{same:>33.2f}x ({same_med:.2f}x){per_axis:>13.2f}x{f'<= {target:g}x':>9} {ok}"
            print(row)
    for line in before:
        print(line)


def time_updates(gen: OnlineGenerator, target: Any, calls: int) -> float:
    """Mean ns per ``update`` with an unchanged target (batch-timed, loop overhead removed)."""
    gen.update(target)  # plans once
    replans = gen.replans
    update = gen.update
    rng = range(calls)
    t0 = time.perf_counter_ns()
    for _ in rng:
        update(target)
    total = time.perf_counter_ns() - t0
    t0 = time.perf_counter_ns()
    for _ in rng:
        pass
    loop = time.perf_counter_ns() - t0
    assert gen.replans == replans, "update re-planned with an unchanged target"
    return (total - loop) / calls


def bench_updates(args: argparse.Namespace) -> None:
    """OnlineGenerator.update without re-plan: one axis and groups of 3 and 6."""
    lim = Limits(v_max=1.0, a_max=2.0, j_max=10.0)
    far = State(p=5e3)  # a long move (5,000 s): every timed call is mid-profile
    print(f"\nOnlineGenerator.update without re-plan ({args.update_calls} calls each):")
    gen = OnlineGenerator(lim, 0.001)
    ns = time_updates(gen, far, args.update_calls)
    print(f"  1 axis                {ns / 1e3:6.3f} us per call  {ns / 1e3:6.3f} us per axis")
    for dofs in (3, 6):
        group = OnlineGenerator([lim] * dofs, 0.001)
        ns = time_updates(group, [far] * dofs, args.update_calls)
        print(
            f"  group of {dofs}            {ns / 1e3:6.3f} us per call  "
            f"{ns / 1e3 / dofs:6.3f} us per axis"
        )
    print("  target: <= 3 us per axis")


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

        if not args.sync_only:
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

        if args.sync_cases > 0:
            rest_problems = [
                (State(c.p0), State(c.pf), c.limits()) for c in cases[: args.sync_cases * 3]
            ]
            time_plan_cases(rest_problems[:200])
            single = {
                "general": ours["mean"],
                "rest": stats_us(time_plan_cases(rest_problems))["mean"],
            }
            bench_sync(args, rk, single)
        if args.update_calls > 0:
            bench_updates(args)
    finally:
        gc.enable()
    return 0


if __name__ == "__main__":
    sys.exit(main())
