"""Compare motionplc's single-axis planner with Ruckig on random 1-DoF cases.

Same cases and criteria as ``tests/planning/test_vs_ruckig.py`` (shared code in
``tests/planning/_cases.py`` and ``tests/planning/_compare.py``), at a larger scale::

    python tools/compare_ruckig.py --cases 100000 --seed 42 --outside-fraction 0.1 --order 3

Prints the number of cases, how many Ruckig rejected, our failures (invalid profile, error
where Ruckig found a profile, or slower than Ruckig), the max / mean duration ratio
ours/ruckig and the worst cases as pasteable calls. Exit status 1 when anything failed.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from tests.planning._cases import RuckigOracle, import_ruckig, iter_cases  # noqa: E402
from tests.planning._compare import Comparison, compare_cases, fmt_ratio  # noqa: E402


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--cases", type=int, default=100_000, help="number of cases (100000)")
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


def main(argv: list[str] | None = None) -> int:
    args = parse_args(argv)
    rk = import_ruckig()
    if rk is None:
        print("ruckig is not installed (pip install ruckig==0.19.4)", file=sys.stderr)
        return 2
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
