"""Compare motionplc's planner with Ruckig on random cases (1 DoF, or synchronised N DoFs).

Same cases and criteria as ``tests/planning/test_vs_ruckig.py`` and
``tests/planning/test_sync.py`` (shared code in ``tests/planning/_cases.py`` and
``tests/planning/_compare.py``), at a larger scale::

    python tools/compare_ruckig.py --cases 100000 --seed 42 --outside-fraction 0.1 --order 3
    python tools/compare_ruckig.py --sync time --dofs 6 --cases 20000
    python tools/compare_ruckig.py --sync phase --dofs 3 --collinear-fraction 0.5
    python tools/compare_ruckig.py --sync discrete --dofs 3 --dt 0.001

1 DoF (no ``--sync``): prints the number of cases, how many Ruckig rejected, our failures
(invalid profile, error where Ruckig found a profile, or slower than Ruckig), the max / mean
duration ratio ours/ruckig and the worst cases as pasteable calls.

``--sync time|phase|discrete|none`` compares ``plan_sync`` with Ruckig's
``Synchronization.Time`` / ``.Phase`` / ``DurationDiscretization.Discrete`` (time
synchronisation, ``Ruckig(dofs, dt)``) / ``.No`` on ``--dofs`` axes drawn from Ruckig's
``random_3`` distributions; besides the above it prints the largest spread of the axes' end
times, how often phase synchronisation was used (and why not), the largest deviation from
the straight line and from a whole number of cycles. Exit status 1 when anything failed.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import dataclasses  # noqa: E402

import numpy as np  # noqa: E402

from tests.planning._cases import (  # noqa: E402
    MultiCase,
    RuckigOracle,
    RuckigSyncOracle,
    import_ruckig,
    iter_cases,
    iter_multi_cases,
)
from tests.planning._compare import (  # noqa: E402
    Comparison,
    SyncComparison,
    compare_cases,
    compare_sync_case,
    fmt_ratio,
)


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument(
        "--cases", type=int, default=None, help="number of cases (100000; --sync: 20000)"
    )
    ap.add_argument("--seed", type=int, default=42, help="numpy Generator seed (42)")
    ap.add_argument(
        "--outside-fraction",
        type=float,
        default=0.0,
        help="fraction of cases whose start is moved outside the limits (0.0)",
    )
    ap.add_argument(
        "--boundary-fraction",
        type=float,
        default=0.0,
        help="fraction of the other cases starting on a braking boundary (0.0)",
    )
    ap.add_argument(
        "--order",
        type=int,
        choices=(2, 3),
        default=3,
        help="3: jerk-limited; 2: j_max = inf with zero accelerations (Ruckig second order)",
    )
    ap.add_argument(
        "--asymmetric-fraction",
        type=float,
        default=0.0,
        help="fraction of cases with v_min != -v_max and a_min != -a_max (0.0)",
    )
    ap.add_argument(
        "--allow-zeros",
        action="store_true",
        help="draw v0, a0, vf, af as 0 with Ruckig's probabilities 0.1/0.2/0.3/0.4 "
        "(default: all non-zero, as in test_vs_ruckig)",
    )
    ap.add_argument(
        "--redraw-invalid",
        action="store_true",
        help="redraw cases whose target Ruckig rejects (default: keep and compare them)",
    )
    ap.add_argument(
        "--velocity", action="store_true", help="compare plan_velocity (velocity interface)"
    )
    ap.add_argument("--show", type=int, default=10, help="failures to print (10)")
    sync = ap.add_argument_group("synchronised axes (plan_sync)")
    sync.add_argument(
        "--sync",
        choices=("time", "phase", "discrete", "none"),
        default=None,
        help="compare plan_sync on --dofs axes with this synchronisation (default: 1 DoF mode)",
    )
    sync.add_argument("--dofs", type=int, default=3, help="number of axes (3)")
    sync.add_argument(
        "--dt", type=float, default=0.001, help="cycle time of --sync discrete [s] (0.001)"
    )
    sync.add_argument(
        "--collinear-fraction",
        type=float,
        default=None,
        help="fraction of cases with v0, a0, vf, af parallel to the move "
        "(default 0.5 for --sync phase, else 0)",
    )
    sync.add_argument(
        "--velocity-fraction",
        type=float,
        default=0.0,
        help="probability of each axis using the velocity interface (0.0)",
    )
    return ap.parse_args(argv)


def _ratio(r: float) -> str:
    return f"{r:.15f} ({fmt_ratio(r)})"


def report(res: Comparison, show: int, seconds: float) -> None:
    print(f"cases:            {res.cases}  ({seconds:.1f} s)")
    print(f"start outside:    {res.outside}")
    print(
        f"ruckig rejected:  {res.ruckig_rejected}  (we rejected {res.both_rejected} of them, "
        f"planned {res.ruckig_only_rejected})"
    )
    for err, n in sorted(res.ruckig_errors.items(), key=lambda kv: -kv[1]):
        print(f"    {n:7d}  {err}")
    print(f"ours rejected where ruckig planned: {res.ours_only_rejected}")
    print(f"our failures:     {len(res.failures)}")
    print(f"compared:         {len(res.ratios)} durations")
    if res.ratios:
        print(f"max ratio:        {_ratio(res.max_ratio)}")
        print(f"mean ratio:       {_ratio(res.mean_ratio)}")
        print(f"min ratio:        {_ratio(res.min_ratio)}")
    p, v, a = res.max_end_error
    print(f"max end error:    |p| {p:.2e}  |v| {v:.2e}  |a| {a:.2e}")
    print("\nworst 5 cases (highest ours/ruckig):")
    for o in res.worst:
        print(f"  ratio {_ratio(o.ratio or 0.0)}")
        print("  " + o.describe(velocity=res.velocity).replace("\n", "\n  "))
    print("\nbest 5 cases (lowest ours/ruckig):")
    for o in res.best:
        print(f"  ratio {_ratio(o.ratio or 0.0)}")
        print("  " + o.describe(velocity=res.velocity).replace("\n", "\n  "))
    if res.failures:
        print(f"\nfirst {min(show, len(res.failures))} failures:")
        for o in res.failures[:show]:
            print("  " + o.describe(velocity=res.velocity).replace("\n", "\n  "))


def sync_cases(args: argparse.Namespace) -> list[MultiCase]:
    collinear = args.collinear_fraction
    if collinear is None:
        collinear = 0.5 if args.sync == "phase" else 0.0
    stream = iter_multi_cases(
        args.seed,
        args.dofs,
        sync="time" if args.sync == "discrete" else args.sync,
        dt=args.dt if args.sync == "discrete" else None,
        collinear_fraction=collinear,
        nonzero=False,  # Ruckig's random_3: zeros with probability 0.1/0.2/0.3/0.4
        redraw_invalid=True,
    )
    cases = [next(stream) for _ in range(args.cases)]
    if args.velocity_fraction > 0.0:
        rng = np.random.default_rng(args.seed + 1)
        cases = [
            dataclasses.replace(
                c,
                interface=tuple(
                    "velocity" if rng.random() < args.velocity_fraction else "position"
                    for _ in range(args.dofs)
                ),
            )
            for c in cases
        ]
    return cases


def report_sync(res: SyncComparison, show: int, seconds: float, per_case_ms: float) -> None:
    print(f"cases:            {res.cases}  ({seconds:.1f} s, {per_case_ms:.2f} ms per case)")
    print(f"axis outside:     {res.outside}  (cases with an axis starting outside its limits)")
    print(f"ruckig rejected:  {res.ruckig_rejected}  (we rejected {res.both_rejected} of them)")
    print(f"ours rejected where ruckig planned: {res.ours_only_rejected}")
    print(f"our failures:     {len(res.failures)}")
    used = ", ".join(f"{k} {v}" for k, v in sorted(res.used.items()))
    print(f"synchronisation:  {used}")
    for note, n in sorted(res.notes.items(), key=lambda kv: -kv[1]):
        print(f"    {n:7d}  {note}")
    if res.ratios:
        print(f"max ratio:        {_ratio(res.max_ratio)}")
        print(f"mean ratio:       {_ratio(res.mean_ratio)}")
        print(f"min ratio:        {_ratio(res.min_ratio)}")
    print(f"axes end spread:  max {res.max_spread:.2e} s")
    print(f"line deviation:   max {res.max_line:.2e} (phase; relative to the move)")
    print(f"cycle error:      max {res.max_cycle:.2e} s")
    p, v, a = res.max_end_error
    print(f"max end error:    |p| {p:.2e}  |v| {v:.2e}  |a| {a:.2e}")
    print("\nworst 5 cases (highest ours/ruckig):")
    for o in res.worst:
        print(f"  ratio {_ratio(o.ratio or 0.0)}")
        print("  " + o.describe().replace("\n", "\n  "))
    if res.failures:
        print(f"\nfirst {min(show, len(res.failures))} failures:")
        for o in res.failures[:show]:
            print("  " + o.describe().replace("\n", "\n  "))


def main_sync(args: argparse.Namespace, rk: object) -> int:
    oracle = RuckigSyncOracle(rk, args.dt)  # type: ignore[arg-type]
    cases = sync_cases(args)
    print(
        f"plan_sync vs ruckig: {args.cases} cases, {args.dofs} axes, sync {args.sync}"
        + (f" (dt {args.dt})" if args.sync == "discrete" else "")
        + f", seed {args.seed}"
    )
    res = SyncComparison()
    t0 = time.perf_counter()
    for case in cases:
        res.add(compare_sync_case(case, oracle))
    seconds = time.perf_counter() - t0
    report_sync(res, args.show, seconds, 1e3 * seconds / max(len(cases), 1))
    return 1 if res.failures else 0


def main(argv: list[str] | None = None) -> int:
    args = parse_args(argv)
    if args.cases is None:
        args.cases = 100_000 if args.sync is None else 20_000
    rk = import_ruckig()
    if rk is None:
        print("ruckig is not installed (pip install ruckig==0.19.4)", file=sys.stderr)
        return 2
    if args.sync is not None:
        return main_sync(args, rk)
    oracle = RuckigOracle(rk)
    stream = iter_cases(
        args.seed,
        nonzero=not args.allow_zeros,
        outside_fraction=args.outside_fraction,
        boundary_fraction=args.boundary_fraction,
        asymmetric_fraction=args.asymmetric_fraction,
        order=args.order,
        redraw_invalid=args.redraw_invalid,
        oracle=oracle,
    )
    cases = [next(stream) for _ in range(args.cases)]
    t0 = time.perf_counter()
    res = compare_cases(cases, oracle, velocity=args.velocity)
    report(res, args.show, time.perf_counter() - t0)
    return 1 if res.failures else 0


if __name__ == "__main__":
    sys.exit(main())
