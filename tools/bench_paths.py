"""Path following: motionplc's ``plan_path`` against toppra (and copp-py for jerk) on the same
paths and limits, measured in the same run (the machine is noisy: compare the ratios).

Cases: a straight line, a circle, a 6-axis cubic spline through 5 waypoints (the same scipy
CubicSpline toppra's SplineInterpolator builds), a 3-axis curve with many curvature changes,
seed 000's line/arc path with G2 corner blends (``join`` + ``blend_corners``, 0.05 m) and the
package's interpolating cubic B-spline through 5 points (``BSplinePath.interpolate``).
For each: durations (ours at N intervals, toppra at N and at 4N), the worst limit ratios on
dense resampling (1 ms and 20 samples per grid interval) for both planners, compute times
(median of --repeat runs, interleaved) and their ratio; then the jerk-limited duration against
the second-order optimum and against copp-py's TOPP3 (SOCP) where it runs::

    python tools/bench_paths.py --grid 1000 --repeat 5
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from motionplc.planning.paths import plan_path  # noqa: E402
from tests.planning.paths._topp_checks import worst_ratios  # noqa: E402
from tests.planning.paths._topp_oracle import toppra_solve, toppra_violation  # noqa: E402
from tests.planning.paths._topp_paths import (  # noqa: E402
    BSPLINE_POINTS,
    bspline_through,
    circle,
    line,
    seed000_blended,
    spline,
    wiggly,
)


def cases():
    rng = np.random.default_rng(7)
    sp6 = spline(np.linspace(0.0, 1.0, 5), rng.uniform(-1.0, 1.0, (5, 6)))
    return {
        "line": (line([0, 0, 0], [1, 2, 0.5]), 1.0, 2.0, 10.0),
        "circle": (circle((0.2, 0.1), 0.5), [1.0, 0.7], [2.0, 1.5], [10.0, 10.0]),
        "spline6": (sp6, np.linspace(1.0, 2.0, 6), np.linspace(2.0, 4.0, 6), np.full(6, 20.0)),
        "wiggly3": (wiggly(), [1.0, 0.8, 1.5], [2.0, 3.0, 1.0], [20.0, 10.0, 15.0]),
        "seed000": (seed000_blended(), [1.0, 0.8, 1.2], [2.0, 3.0, 1.5], [20.0, 20.0, 20.0]),
        "bspline3": (
            bspline_through(BSPLINE_POINTS),
            [1.0, 0.8, 1.2],
            [2.0, 3.0, 1.5],
            [20.0, 20.0, 20.0],
        ),
    }


def copp_topp3(path, vm, am, jm, n: int) -> float | None:
    """copp-py TOPP2-RA then TOPP3-SOCP (linearised around the TOPP2 profile); None if it fails."""
    try:
        import copp_py as copp
    except ImportError:
        return None
    dim = path.dim
    s = np.linspace(0.0, path.u_end, n + 1)
    q, dq, ddq, dddq = (np.ascontiguousarray(path.evaluate(s, k)) for k in range(4))
    vm, am, jm = (np.broadcast_to(np.asarray(x, float), (dim,)).copy() for x in (vm, am, jm))
    try:
        robot = copp.Robot(dim, capacity=n + 1)
        robot.append_s(s)
        robot.set_q(q, dq, ddq, 0, dddq=dddq)
        robot.add_velocity_limits(vm, -vm, start_idx_s=0, length=n + 1)
        robot.add_acceleration_limits(am, -am, start_idx_s=0, length=n + 1)
        robot.add_jerk_limits(jm, -jm, start_idx_s=0, length=n + 1)
        p2 = copp.solver.topp2_ra.Problem(
            robot.constraints, idx_s_interval=(0, n), a_boundary=(0.0, 0.0)
        )
        a2 = np.asarray(copp.solver.topp2_ra.solve(p2, copp.solver.topp2_ra.Options()))
        a_lin = np.maximum(a2, 1e-6 * max(a2.max(), 1e-12))
        prob = copp.solver.topp3_socp.Problem(
            robot.constraints,
            a_lin,
            idx_s_start=0,
            a_boundary=(0.0, 0.0),
            b_boundary=(0.0, 0.0),
            num_stationary_max=1,
        )
        prof = copp.solver.topp3_socp.solve(prob)
        t_final, _ = copp.interpolation.s_to_t_topp3(s, prof, 0.0)
        return float(t_final)
    except Exception as exc:  # noqa: BLE001 - report, do not crash the benchmark
        print(f"    copp-py failed: {type(exc).__name__}: {exc}")
        return None


def timed(fn, repeat: int) -> tuple[object, float]:
    out = None
    ts = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        out = fn()
        ts.append(time.perf_counter() - t0)
    return out, statistics.median(ts)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--grid", type=int, default=1000)
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--jerk-grid", type=int, default=300)
    args = ap.parse_args()
    n = args.grid
    print(f"second order, N = {n} intervals (compute: median of {args.repeat})")
    hdr = "case       T_ours      T_toppra(N)  T_toppra(4N) dT/T_t(4N)  ours v/a ratio     "
    print(hdr + "toppra v/a ratio    t_ours    t_toppra  ratio")
    ratios = []
    for name, (p, vm, am, _jm) in cases().items():
        ours_t, ref_t = [], []
        ours = ref = None
        for _ in range(args.repeat):  # interleaved
            ours, t1 = timed(lambda p=p, vm=vm, am=am: plan_path(p, vm, am, n_grid=n), 1)
            ref, t2 = timed(lambda p=p, vm=vm, am=am: toppra_solve(p, vm, am, n), 1)
            ours_t.append(t1)
            ref_t.append(t2)
        fine = toppra_solve(p, vm, am, 4 * n)
        r = worst_ratios(ours, vm, am)
        tv, ta = toppra_violation(ref, vm, am, max(20 * n, int(ref.duration / 1e-3)))
        to, tt = statistics.median(ours_t), statistics.median(ref_t)
        ratios.append(to / tt)
        print(
            f"{name:9s} {ours.duration:11.6f} {ref.duration:12.6f} {fine.duration:12.6f} "
            f"{ours.duration / fine.duration - 1:+10.2e}  {r['v']:.9f}/{r['a']:.9f}  "
            f"{tv:.6f}/{ta:.6f}  {to * 1e3:7.1f}ms {tt * 1e3:7.1f}ms {to / tt:5.2f}"
        )
    print(f"compute-time ratio ours/toppra: median {statistics.median(ratios):.2f}")
    print(f"\njerk-limited, N = {args.jerk_grid}")
    print(
        "case       T_jerk      T_2nd      T_jerk/T_2nd  v/a/j ratio              t_ours   T_copp3"
    )
    for name, (p, vm, am, jm) in cases().items():
        tr, t = timed(
            lambda p=p, vm=vm, am=am, jm=jm: plan_path(p, vm, am, j_max=jm, n_grid=args.jerk_grid),
            1,
        )
        r = worst_ratios(tr, vm, am, jm)
        tc = copp_topp3(p, vm, am, jm, args.jerk_grid)
        tcs = f"{tc:.6f}" if tc is not None else "failed"
        print(
            f"{name:9s} {tr.duration:10.6f} {tr.second_order_duration:10.6f} "
            f"{tr.duration / tr.second_order_duration:10.4f}  "
            f"{r['v']:.6f}/{r['a']:.6f}/{r['j']:.6f}  {t * 1e3:7.0f}ms  {tcs}"
        )


if __name__ == "__main__":
    main()
