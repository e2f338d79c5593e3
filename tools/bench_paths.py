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

The second-order sets (``--sets``, on by default; ``--random K`` paths per set): random
tangent-continuous lines-and-arcs chains (curvature jumps at every junction), random polylines
with corner blends (2-6 axes, blends 1e-4 to 1e-1 of the segment lengths, limits log-uniform over
three orders of magnitude) and random interpolating B-splines. Per path: ``plan_path`` at its
default settings against toppra (ConstAccel, Seidel) on a fine grid (every interval of ours cut
in ``--fine`` parts: the reference optimum) and on the same grid as ours (the compute
reference); the duration ratios, the compute ratio, and the largest limit overshoot of both
planners measured by differencing positions sampled at 1 ms (``|dp|/dt`` against v_max,
``|d2p|/dt^2`` against a_max, relative; the rounding floor ``4 eps |p| / dt^2`` of the second
difference is printed beside it). ``--fine-grid N``: ours at N intervals against toppra at 4N
on the lines-and-arcs set (the 0.1 % target at a fine grid).
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
    random_blended_polyline,
    random_bspline,
    random_limits,
    random_lines_and_arcs,
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


# -- second order on random path sets (paths2) ----------------------------------------------------


def differenced_overshoot(tr, v_max, a_max, dt: float = 1e-3) -> tuple[float, float, float]:
    """Largest relative overshoot of the velocity and acceleration limits measured by
    differencing positions sampled every ``dt`` (and at the end), and the rounding floor of
    the second difference relative to the smallest acceleration limit."""
    ts = np.append(np.arange(0.0, tr.duration, dt), tr.duration)
    p = tr.sample(ts).p  # (dim, n)
    vm = np.broadcast_to(np.asarray(v_max, float), (p.shape[0],))[:, None]
    am = np.broadcast_to(np.asarray(a_max, float), (p.shape[0],))[:, None]
    d1 = np.diff(p, axis=1) / np.diff(ts)[None, :]
    ov = float(np.max(np.abs(d1) / vm)) - 1.0
    if p.shape[1] > 3:
        inner = p[:, :-1]  # uniform spacing only
        d2 = np.diff(inner, 2, axis=1) / dt**2
        oa = float(np.max(np.abs(d2) / am)) - 1.0
    else:
        oa = -1.0
    floor = 4.0 * np.finfo(float).eps * float(np.abs(p).max()) / dt**2 / float(am.min())
    return ov, oa, floor


def toppra_on(path, v_max, a_max, gridpoints):
    """toppra (ConstAccel, Seidel) on the given grid points (None: its own default grid
    selection); its duration and trajectory."""
    import toppra.algorithm as algo
    import toppra.constraint as constraint

    from tests.planning.paths._topp_oracle import ToppraPath

    dim = path.dim
    vm = np.broadcast_to(np.asarray(v_max, float), (dim,))
    am = np.broadcast_to(np.asarray(a_max, float), (dim,))
    inst = algo.TOPPRA(
        [
            constraint.JointVelocityConstraint(np.stack([-vm, vm], axis=1)),
            constraint.JointAccelerationConstraint(np.stack([-am, am], axis=1)),
        ],
        ToppraPath(path),
        gridpoints=None if gridpoints is None else np.asarray(gridpoints, float),
        solver_wrapper="seidel",
        parametrizer="ParametrizeConstAccel",
    )
    traj = inst.compute_trajectory(0.0, 0.0)
    if traj is None:
        raise RuntimeError("toppra failed")
    return float(traj.path_interval[1]), traj


def _toppra_overshoot(traj, duration, v_max, a_max, dim, dt: float = 1e-3) -> tuple[float, float]:
    ts = np.append(np.arange(0.0, duration, dt), duration)
    p = np.asarray(traj(ts)).T
    vm = np.broadcast_to(np.asarray(v_max, float), (dim,))[:, None]
    am = np.broadcast_to(np.asarray(a_max, float), (dim,))[:, None]
    ov = float(np.max(np.abs(np.diff(p, axis=1) / np.diff(ts)[None, :]) / vm)) - 1.0
    oa = float(np.max(np.abs(np.diff(p[:, :-1], 2, axis=1) / dt**2) / am)) - 1.0
    return ov, oa


def _refined(u: np.ndarray, parts: int) -> np.ndarray:
    th = np.arange(parts) / parts
    return np.append((u[:-1, None] + np.diff(u)[:, None] * th[None, :]).reshape(-1), u[-1])


def second_order_sets(k: int, fine: int, repeat: int, seed: int) -> dict[str, list[float]]:
    """Random lines-and-arcs, blended polylines and B-splines against toppra (see the module
    docstring); prints one line per set and returns the per-path duration ratios."""
    makers = {
        "lines+arcs": random_lines_and_arcs,
        "poly+blends": random_blended_polyline,
        "bspline": random_bspline,
    }
    print(
        f"\nsecond order, default settings, {k} random paths per set "
        f"(toppra fine: every interval of ours in {fine}; compute: median of {repeat})"
    )
    print(
        "set           T/T_toppra_fine: median    max   T/T_toppra_same: median  max   "
        "compute ours/toppra_same  overshoot v / a (ours)   overshoot a (toppra)  floor  fails"
    )
    out: dict[str, list[float]] = {}
    for si, (name, make) in enumerate(makers.items()):
        rng = np.random.default_rng(seed + 1000 * si)
        r_fine, r_same, r_cpu, ov_o, oa_o, oa_t, floors = [], [], [], [], [], [], []
        r_def, r_cpu_def, oa_def = [], [], []
        fails = 0
        for _ in range(k):
            path = make(rng)
            vm, am = random_limits(rng, path.dim)
            try:
                t_o, t_t, t_d = [], [], []
                tr = None
                for _r in range(repeat):  # interleaved
                    t0 = time.perf_counter()
                    tr = plan_path(path, vm, am)
                    t_o.append(time.perf_counter() - t0)
                    grid = tr.grid_u
                    t0 = time.perf_counter()
                    same, _ = toppra_on(path, vm, am, grid)
                    t_t.append(time.perf_counter() - t0)
                    t0 = time.perf_counter()
                    dflt, dtraj = toppra_on(path, vm, am, None)
                    t_d.append(time.perf_counter() - t0)
                ref, traj = toppra_on(path, vm, am, _refined(tr.grid_u, fine))
            except Exception as exc:  # noqa: BLE001 - counted and shown, the run goes on
                fails += 1
                print(f"    {name}: {type(exc).__name__}: {exc}")
                continue
            if not np.isfinite(tr.duration):
                fails += 1
                continue
            r_fine.append(tr.duration / ref)
            r_same.append(tr.duration / same)
            r_cpu.append(statistics.median(t_o) / statistics.median(t_t))
            r_def.append(tr.duration / dflt)
            r_cpu_def.append(statistics.median(t_o) / statistics.median(t_d))
            oa_def.append(_toppra_overshoot(dtraj, dflt, vm, am, path.dim)[1])
            ov, oa, floor = differenced_overshoot(tr, vm, am)
            ov_o.append(ov)
            oa_o.append(oa)
            floors.append(floor)
            oa_t.append(_toppra_overshoot(traj, ref, vm, am, path.dim)[1])
        out[name] = r_fine
        if not r_fine:
            print(f"{name:12s}  no result ({fails} failures)")
            continue
        print(
            f"{name:12s}  {statistics.median(r_fine):22.6f} {max(r_fine):8.6f} "
            f"{statistics.median(r_same):22.6f} {max(r_same):8.6f} "
            f"{statistics.median(r_cpu):18.2f}  {max(ov_o):+10.2e} / {max(oa_o):+10.2e}  "
            f"{max(oa_t):+14.2e}  {max(floors):7.1e}  {fails}"
        )
        print(
            f"{'':12s}  against toppra's own default grid: T/T median "
            f"{statistics.median(r_def):.6f}, max {max(r_def):.6f}, compute "
            f"{statistics.median(r_cpu_def):.2f}, its overshoot a {max(oa_def):+.2e}"
        )
    return out


def fine_grid_lines_arcs(k: int, n: int, seed: int) -> None:
    """Ours at ``n`` intervals against toppra at ``4 n`` (uniform) on random lines-and-arcs."""
    rng = np.random.default_rng(seed + 77)
    ratios = []
    for _ in range(k):
        path = random_lines_and_arcs(rng)
        vm, am = random_limits(rng, path.dim)
        tr = plan_path(path, vm, am, n_grid=n)
        ref, _ = toppra_on(path, vm, am, _refined(tr.grid_u, 4))
        ratios.append(tr.duration / ref)
    print(
        f"lines+arcs at n_grid = {n} against toppra on that grid cut in 4: T/T_toppra median "
        f"{statistics.median(ratios):.6f}, max {max(ratios):.6f}"
    )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--grid", type=int, default=1000)
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--jerk-grid", type=int, default=1000)
    ap.add_argument("--jerk-repeat", type=int, default=3)
    ap.add_argument("--jerk-cases", type=int, default=12, help="random jerk-limited cases")
    ap.add_argument("--jerk-only", action="store_true", help="only the jerk-limited section")
    ap.add_argument("--random", type=int, default=20, help="random paths per second-order set")
    ap.add_argument("--fine", type=int, default=4, help="toppra reference: parts per interval")
    ap.add_argument("--fine-grid", type=int, default=4000, help="n_grid of the fine-grid check")
    ap.add_argument("--seed", type=int, default=2026)
    ap.add_argument("--sets-only", action="store_true", help="only the random second-order sets")
    ap.add_argument("--no-jerk", action="store_true", help="skip the jerk-limited section")
    args = ap.parse_args()
    if args.jerk_only:
        bench_jerk(args.jerk_grid, args.jerk_repeat, args.jerk_cases)
        return
    if args.sets_only:
        second_order_sets(args.random, args.fine, args.repeat, args.seed)
        fine_grid_lines_arcs(max(3, args.random // 4), args.fine_grid, args.seed)
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
    second_order_sets(args.random, args.fine, args.repeat, args.seed)
    fine_grid_lines_arcs(max(3, args.random // 4), args.fine_grid, args.seed)
    if args.no_jerk:
        return
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


def differenced_overshoot_vaj(path, s_of_t, duration: float, vm, am, jm, dt: float = 1e-3):
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
        (ov, nan) = differenced_overshoot_vaj(
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
                oc, _ = differenced_overshoot_vaj(p, res[0][2], tc, vm, am, jm)
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
