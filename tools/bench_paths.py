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


def copp_topp3(path, vm, am, jm, n: int) -> float | None:  # kept for callers; see bench_jerk
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
    ap.add_argument("--jerk-grid", type=int, default=1000)
    ap.add_argument("--jerk-repeat", type=int, default=3)
    ap.add_argument("--jerk-cases", type=int, default=12, help="random jerk-limited cases")
    ap.add_argument("--jerk-only", action="store_true", help="only the jerk-limited section")
    args = ap.parse_args()
    if args.jerk_only:
        bench_jerk(args.jerk_grid, args.jerk_repeat, args.jerk_cases)
        return
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
    bench_jerk(args.jerk_grid, args.jerk_repeat, args.jerk_cases)


# -- jerk-limited section (third-order parameterisation against copp-py's TOPP3) -------------


def lissajous():
    """The 3-axis path of issue 25: q(s) = [sin 2 pi s, sin(3 pi s + 0.3), sin(5 pi s + 0.7)]."""
    from tests.planning.paths._topp_paths import FuncPath

    w = np.array([2.0, 3.0, 5.0]) * np.pi
    ph = np.array([0.0, 0.3, 0.7])
    fs = [
        lambda u: np.sin(w * u[:, None] + ph),
        lambda u: w * np.cos(w * u[:, None] + ph),
        lambda u: -(w**2) * np.sin(w * u[:, None] + ph),
        lambda u: -(w**3) * np.cos(w * u[:, None] + ph),
    ]
    return FuncPath(fs, 1.0, 3)


def _sines(w, ph, amp, k: int):
    """The k-th derivative of amp * sin(w u + ph), per axis."""
    return lambda u: amp * w**k * np.sin(w * u[:, None] + ph + k * np.pi / 2)


def jerk_random_cases(count: int, seed: int = 25):
    """Random smooth curves (sums of sines, 2-4 axes), interpolating B-splines through random
    points and polylines with G2 corner blends, with random per-axis limits over three orders
    of magnitude (scaled to the path's size)."""
    from motionplc.planning.paths import Transition, blend_polyline
    from tests.planning.paths._topp_paths import FuncPath

    rng = np.random.default_rng(seed)
    out = []
    for i in range(count):
        kind = ("smooth", "bspline", "blended")[i % 3]
        dim = int(rng.integers(2, 5))
        if kind == "smooth":
            w = rng.uniform(1.0, 5.0, dim) * np.pi
            ph = rng.uniform(0.0, np.pi, dim)
            amp = rng.uniform(0.2, 1.0, dim)
            fs = [_sines(w, ph, amp, k) for k in range(4)]
            p = FuncPath(fs, 1.0, dim)
        elif kind == "bspline":
            pts = np.cumsum(rng.uniform(-0.5, 0.5, (int(rng.integers(4, 8)), dim)), axis=0)
            pts += np.linspace(0.0, 1.0, len(pts))[:, None]
            p = bspline_through(pts, 3)
        else:
            pts = np.cumsum(rng.uniform(-0.5, 0.5, (int(rng.integers(3, 7)), dim)), axis=0)
            pts += np.linspace(0.0, 1.0, len(pts))[:, None]
            seg = float(np.min(np.linalg.norm(np.diff(pts, axis=0), axis=1)))
            p = blend_polyline(pts, Transition.max_corner_deviation(0.1 * seg))
        scale = 10.0 ** rng.uniform(-1.0, 2.0)
        vm = rng.uniform(0.5, 2.0, dim) * scale
        am = rng.uniform(0.5, 2.0, dim) * scale
        jm = rng.uniform(0.5, 2.0, dim) * scale
        out.append((f"{kind}{i:02d}", p, vm, am, jm))
    return out


def copp_topp3_run(path, vm, am, jm, n: int, rounds: int):
    """copp-py: TOPP2-RA, then ``rounds`` TOPP3-SOCP solves (each linearised at the previous
    profile); returns (duration, compute seconds, sampler s(t)) or None if it fails."""
    try:
        import copp_py as copp
    except ImportError:
        return None
    dim = path.dim
    vm, am, jm = (np.broadcast_to(np.asarray(x, float), (dim,)).copy() for x in (vm, am, jm))
    try:
        t0 = time.process_time()
        s = np.linspace(0.0, path.u_end, n + 1)
        q, dq, ddq, dddq = (np.ascontiguousarray(path.evaluate(s, k)) for k in range(4))
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
        b_lin = None
        for _ in range(rounds):
            prob = copp.solver.topp3_socp.Problem(
                robot.constraints,
                a_lin,
                idx_s_start=0,
                a_boundary=(0.0, 0.0),
                b_boundary=(0.0, 0.0),
                num_stationary_max=1,
                b_linearization=b_lin,
            )
            prof = copp.solver.topp3_socp.solve(prob)
            a_lin, b_lin = np.asarray(prof.a), np.asarray(prof.b)
        t_final, t_s = copp.interpolation.s_to_t_topp3(s, prof, 0.0)
        dt = time.process_time() - t0

        def sample(ts, s=s, prof=prof, t_s=t_s):
            out = copp.interpolation.t_to_s_topp3_samples(s, prof, t_s, ts)
            return np.clip(np.nan_to_num(out, nan=path.u_end), 0.0, path.u_end)

        return float(t_final), dt, sample
    except Exception as exc:  # noqa: BLE001 - report, do not crash the benchmark
        print(f"    copp-py failed: {type(exc).__name__}: {exc}")
        return None


def differenced_overshoot(path, s_of_t, duration: float, vm, am, jm, dt: float = 1e-3):
    """Largest |v|/v_max - 1, |a|/a_max - 1, |j|/j_max - 1 (0 if none) of the positions sampled
    every ``dt`` (first, second and third differences), and whether any value is NaN."""
    ts = np.arange(0.0, duration + 0.5 * dt, dt)
    ts[-1] = min(ts[-1], duration)
    p = np.asarray(path.evaluate(s_of_t(ts), 0), dtype=float)
    out = []
    nan = not np.all(np.isfinite(p))
    for k, lim in ((1, vm), (2, am), (3, jm)):
        d = np.diff(p, k, axis=0) / dt**k
        out.append(max(0.0, float(np.max(np.abs(d) / np.asarray(lim, float))) - 1.0))
    return out, nan


def bench_jerk(n: int, repeat: int, count: int, rounds: tuple[int, ...] = (1, 3)) -> None:
    """Jerk-limited duration and compute against copp-py's TOPP3-SOCP (``rounds`` successive
    linearisations) on the Lissajous path (every limit 1) and on the random set; the largest
    limit overshoot by differencing positions at 1 ms for both; exceptions and NaNs. Compute is
    the process's CPU time (``time.process_time``, all threads; wall time on this shared
    machine measures the other engineers' load), median of ``repeat`` runs."""
    cases = [("lissajous", lissajous(), np.ones(3), np.ones(3), np.ones(3))]
    cases += jerk_random_cases(count)
    hdr = f"{'case':12s} {'T_ours':>10s} {'T_2nd':>10s} {'t_ours':>8s}"
    for r in rounds:
        hdr += f" {'T_copp' + str(r):>10s} {'t_copp' + str(r):>8s}"
        hdr += f" {'T/T' + str(r):>7s} {'t/t' + str(r):>6s}"
    print(f"\njerk-limited, N = {n} (compute: median of {repeat}); overshoot by 1 ms differences")
    print(hdr + "  over_ours  over_copp")
    ratios: dict[int, list[tuple[float, float]]] = {r: [] for r in rounds}
    worst_ours = 0.0
    failures = []
    for name, p, vm, am, jm in cases:
        try:
            times = []
            tr = None
            for _ in range(repeat):
                t0 = time.process_time()
                tr = plan_path(p, vm, am, j_max=jm, n_grid=n)
                times.append(time.process_time() - t0)
        except Exception as exc:  # noqa: BLE001 - counted and reported
            failures.append(f"{name}: {type(exc).__name__}: {exc}")
            print(f"{name:12s} ours failed: {type(exc).__name__}: {exc}")
            continue
        t_ours = statistics.median(times)
        (ov, nan) = differenced_overshoot(
            p, lambda ts, tr=tr: tr.law.evaluate(ts)[0], tr.duration, vm, am, jm
        )
        if nan or not np.isfinite(tr.duration):
            failures.append(f"{name}: NaN")
        worst_ours = max(worst_ours, *ov)
        line = (
            f"{name:12s} {tr.duration:10.5f} {tr.second_order_duration:10.5f} {t_ours * 1e3:6.0f}ms"
        )
        over_copp = ""
        for r in rounds:
            res = [copp_topp3_run(p, vm, am, jm, n, r) for _ in range(repeat)]
            if any(x is None for x in res):
                line += f" {'failed':>10s} {'':>8s} {'':>7s} {'':>6s}"
                continue
            tc = res[0][0]
            t_c = statistics.median(x[1] for x in res)
            ratios[r].append((tr.duration / tc, t_ours / t_c))
            line += f" {tc:10.5f} {t_c * 1e3:6.0f}ms {tr.duration / tc:7.4f} {t_ours / t_c:6.3f}"
            if r == rounds[-1]:
                oc, _ = differenced_overshoot(p, res[0][2], tc, vm, am, jm)
                over_copp = f"{max(oc):.2e}"
        fb = " (fallback)" if "fallback" in tr.info else ""
        print(f"{line}  {max(ov):.2e}   {over_copp}{fb}")
    for r in rounds:
        if ratios[r]:
            d = [x[0] for x in ratios[r]]
            c = [x[1] for x in ratios[r]]
            print(
                f"against copp TOPP3-SOCP x{r}: duration ratio median {statistics.median(d):.4f} "
                f"max {max(d):.4f}; compute ratio median {statistics.median(c):.3f} "
                f"max {max(c):.3f} ({len(d)} cases where copp ran)"
            )
    print(f"largest overshoot (ours, 1 ms differences): {worst_ours:.2e} relative")
    print(f"exceptions/NaN (ours): {len(failures)}" + "".join(f"\n  {f}" for f in failures))


if __name__ == "__main__":
    main()
