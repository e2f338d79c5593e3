"""G-code on an axes group: a program of many short random line segments under G64 P (blended
corners) against the same program under G61 (exact stop at every corner) and against a lower
bound (path length / F), on the shipped gantry (configs/gantry.yaml: X/Y on CANopen, Z on
Modbus TCP, virtual drives), simulated clock; then the blended program in real time (wall
clock, one 1 ms task, the gantry's axes on ideal drives: the kernel's own cost) for the
per-cycle cost (exec p50 / p99 / max, overruns).

Checked on the traces (not trusted from the kernel): every cycle each axis' |v|, |a|, |j| and
the finite differences of its set position (velocity) and acceleration (jerk) over the task
period within its limits; every sample within P of the programmed polyline (the corner
deviation); the end position exact::

    python tools/bench_gcode.py --segments 2000 --tolerance 0.5 --feed 30000 --rt-segments 300

(``--tolerance`` in mm, ``--feed`` in mm/min, as in the G-code.)
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from motionplc.config import build, load_config  # noqa: E402
from motionplc.gcode_runner import GcodeRunner, load_gcode_job  # noqa: E402

GANTRY = Path(__file__).resolve().parents[1] / "configs" / "gantry.yaml"
BOX = ((0.2, 1.0), (0.15, 0.65), (-0.1, -0.01))  # [m] inside the gantry's software limits


def random_points(n: int, seed: int, lo: float, hi: float) -> np.ndarray:
    """A random walk of ``n`` segments of length in [lo, hi] [m], in random 3-D directions
    (flatter in z), reflected into :data:`BOX`."""
    rng = np.random.default_rng(seed)
    p = np.array([0.6, 0.4, -0.05])
    out = [p.copy()]
    for _ in range(n):
        d = rng.normal(size=3) * np.array([1.0, 1.0, 0.3])
        d /= np.linalg.norm(d)
        q = p + d * rng.uniform(lo, hi)
        for k, (a, b) in enumerate(BOX):
            if q[k] < a:
                q[k] = 2 * a - q[k]
            if q[k] > b:
                q[k] = 2 * b - q[k]
        out.append(q)
        p = q
    return np.array(out)


def program_text(points: np.ndarray, mode: str, feed: float) -> str:
    """G-code (mm): G0 to the first point, then G1 through the rest at ``feed`` under
    ``mode`` ("G64 P<tol>" or "G61")."""
    lines = ["%", "(random short segments, motionplc bench)", "G21 G90 G17", mode]
    x, y, z = points[0] * 1000.0
    lines.append(f"G0 X{x:.6f} Y{y:.6f} Z{z:.6f}")
    lines.append(f"F{feed:.3f}")
    for p in points[1:]:
        x, y, z = p * 1000.0
        lines.append(f"G1 X{x:.6f} Y{y:.6f} Z{z:.6f}")
    lines += ["M2", "%"]
    return "\n".join(lines) + "\n"


def polyline_distance(samples: np.ndarray, corners: np.ndarray, chunk: int = 512) -> np.ndarray:
    """Distance of every sample to the polyline through ``corners``."""
    a = corners[:-1]
    d = corners[1:] - a
    dd = np.einsum("ij,ij->i", d, d)
    out = np.empty(len(samples))
    for s in range(0, len(samples), chunk):
        q = samples[s : s + chunk]
        t = np.clip(np.einsum("kij,ij->ki", q[:, None, :] - a[None], d) / dd, 0.0, 1.0)
        proj = a[None] + t[..., None] * d[None]
        out[s : s + chunk] = np.linalg.norm(q[:, None, :] - proj, axis=2).min(axis=1)
    return out


RT_CONFIG = """# the gantry's axes and group, ideal drives, one 1 ms task (the kernel's cost)
runtime:
  tick: 0.001
  clock: realtime
  tasks:
    motion: {period: 0.001, priority: 1}
axes:
  x: {limits: {v_max: 1.0, a_max: 4.0, j_max: 40.0}, software_limits: {min: 0.0, max: 1.2}}
  y: {limits: {v_max: 0.8, a_max: 3.0, j_max: 30.0}, software_limits: {min: 0.0, max: 0.8}}
  z: {limits: {v_max: 0.3, a_max: 2.0, j_max: 20.0}, software_limits: {min: -0.2, max: 0.01}}
groups:
  xyz: [x, y, z]
"""


def run(path: Path, realtime: bool, max_seconds: float, config: Path = GANTRY) -> dict:
    cfg = load_config(config)
    job = load_gcode_job(path, cfg, "xyz")
    machine = build(cfg, realtime=realtime)
    try:
        runner = GcodeRunner(job, machine)
        machine.attach(runner, job.task)
        rt = machine.runtime
        w0 = time.perf_counter()
        rt.run_until(lambda: runner.over, max_seconds=max_seconds)
        wall = time.perf_counter() - w0
        if runner.failures:
            raise SystemExit(f"{path}: {runner.failures[0]}")
        out = {"runner": runner, "wall": wall, "report": runner.report()}
        out["motion"] = (runner.t_finished or rt.time) - (runner.t_motion or 0.0)
        names = list(machine.axes_groups["xyz"].axis_names)
        tr = rt.trace
        out["pos"] = np.stack([tr.column(f"{n}.position") for n in names], axis=1)
        task = next(t for t in rt.tasks if t.name == job.task)
        k = task.period_ticks
        ratios = {}
        for spec in cfg.axes:  # (checked on the simulated runs' traces)
            n, lim = spec.name, spec.limits
            v, a = tr.column(f"{n}.velocity"), tr.column(f"{n}.acceleration")
            j, p = tr.column(f"{n}.jerk"), tr.column(f"{n}.position")
            period = task.period
            ratios[n] = (
                max(np.abs(v).max(), np.abs(np.diff(p[::k])).max() / period) / lim.v_max,
                np.abs(a).max() / lim.a_max,
                max(np.abs(j).max(), np.abs(np.diff(a[::k])).max() / period) / lim.j_max,
            )
        out["ratios"] = ratios
        out["stats"] = rt.stats()[job.task]
        out["states"] = {a.name: a.state.name for a in machine.axes.values()}
        return out
    finally:
        machine.close()


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--segments", type=int, default=2000)
    ap.add_argument("--min-length", type=float, default=5.0, help="[mm]")
    ap.add_argument("--max-length", type=float, default=20.0, help="[mm]")
    ap.add_argument("--tolerance", type=float, default=0.5, help="G64 P [mm]")
    ap.add_argument("--feed", type=float, default=30000.0, help="F [mm/min]")
    ap.add_argument("--seed", type=int, default=12)
    ap.add_argument("--rt-segments", type=int, default=300, help="0: no real-time run")
    ap.add_argument("--out", default=None, help="keep the programs in this directory")
    args = ap.parse_args()
    pts = random_points(args.segments, args.seed, args.min_length / 1e3, args.max_length / 1e3)
    length = float(np.linalg.norm(np.diff(pts, axis=0), axis=1).sum())
    feed = args.feed / 60000.0
    tmp = Path(args.out) if args.out else Path(tempfile.mkdtemp(prefix="bench_gcode_"))
    tmp.mkdir(parents=True, exist_ok=True)
    blend_p = tmp / "blend.ngc"
    exact_p = tmp / "exact.ngc"
    blend_p.write_text(program_text(pts, f"G64 P{args.tolerance}", args.feed))
    exact_p.write_text(program_text(pts, "G61", args.feed))
    print(
        f"{args.segments} segments of {args.min_length:g}..{args.max_length:g} mm, path "
        f"{length:.3f} m, F {args.feed:g} mm/min ({feed:g} m/s), G64 P{args.tolerance:g} mm; "
        f"gantry.yaml (X/Y CANopen, Z Modbus TCP, virtual drives); programs in {tmp}"
    )
    res = {}
    for name, path in (("G64", blend_p), ("G61", exact_p)):
        r = run(path, realtime=False, max_seconds=36000.0)
        res[name] = r
        pos = r["pos"]
        runner = r["runner"]
        prog = [m.end for m in runner.job.program.moves(runner.start)]
        corners = np.array([runner.start, *prog])  # the programmed polyline (G0 included)
        dev = polyline_distance(pos, corners)
        end = np.abs(pos[-1] - np.array(prog[-1])).max()
        worst = max(max(x) for x in r["ratios"].values())
        print(
            f"  {name}: motion {r['motion']:.3f} s (simulated, {r['wall']:.1f} s wall), "
            f"max distance to the programmed path {dev.max() * 1e3:.4f} mm "
            f"(P = {args.tolerance:g} mm), end error {end:.1e} m, worst limit ratio "
            f"{worst:.6f} (v, a, j per axis: "
            + ", ".join(f"{n} {v:.3f}/{a:.3f}/{j:.3f}" for n, (v, a, j) in r["ratios"].items())
            + f"), axes {sorted(set(r['states'].values()))}"
        )
    lb = length / feed
    print(
        f"  time G64 / G61 = {res['G64']['motion'] / res['G61']['motion']:.3f}; "
        f"G64 / lower bound (length / F = {lb:.3f} s) = {res['G64']['motion'] / lb:.3f}; "
        f"G61 / lower bound = {res['G61']['motion'] / lb:.3f}"
    )
    if args.rt_segments:
        n = min(args.rt_segments, args.segments)
        rt_p = tmp / "blend_rt.ngc"
        rt_p.write_text(program_text(pts[: n + 1], f"G64 P{args.tolerance}", args.feed))
        rt_cfg = tmp / "gantry_ideal_1ms.yaml"
        rt_cfg.write_text(RT_CONFIG)
        r = run(rt_p, realtime=True, max_seconds=3600.0, config=rt_cfg)
        s = r["stats"]
        print(
            f"  real time ({n} segments, ideal drives, 1 ms task {s.name}): "
            f"{s.cycle_count} cycles, "
            f"exec p50 {s.exec_p50 * 1e6:.0f} us, p99 {s.exec_p99 * 1e6:.0f} us, max "
            f"{s.exec_max * 1e6:.0f} us, overruns {s.overruns}, lateness p99 "
            f"{s.lateness_p99 * 1e6:.0f} us; {r['report']}"
        )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
