"""G-code on an axes group: G64 P (blended corners) against G61 (exact stop at every corner) and
against the lower bound length / F, on realistic programs with 5-20 mm and with 0.1-1 mm
segments (contours, pockets, arc corners, a 3-D raster, small wheel-shaped contours); then, in
real time at 1 kHz (the runtime's realtime clock, as ``motionplc run --realtime``), an
arc-corner program for the per-cycle cost of queueing lines and arcs against the same run's idle
cycles, and whether the group's queue ever ran dry while the program had moves left.

Checked on the traces, not trusted from the kernel: every axis' set values by differencing
(``motionplc.runtime.invariants.check_set_values``, the invariant checker's group D: the
differenced positions within v/a/j, positions agreeing with the velocity/acceleration columns),
the distance of every sample to the programmed path (lines and arcs sampled densely) against
G64's P, and the end position::

    python tools/bench_gcode.py                       # the table (about 10 min on this host)
    python tools/bench_gcode.py --quick               # smaller programs, a short real-time run
    python tools/bench_gcode.py --rt-segments 10000   # the issue's 10,000-segment real-time run
    python tools/bench_gcode.py --interpret largest   # lines/s of interpret + map on the largest
                                                      # real program (tests/gcode/thirdparty)

Programs are in mm (G21), F in mm/min; the machine is the gantry's axes and group on ideal
drives, one 1 ms task (``RT_CONFIG``): the kernel's own work, no bus. ``G64/G61 <= 1`` must hold
on every program; ``ok`` says it does.
"""

from __future__ import annotations

import argparse
import math
import re
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from motionplc.config import build, load_config  # noqa: E402
from motionplc.gcode import move_path  # noqa: E402
from motionplc.gcode_runner import GcodeRunner, load_gcode_job  # noqa: E402
from motionplc.runtime.invariants import SetValueLimits, check_set_values  # noqa: E402

RT_CONFIG = """# the gantry's axes and group, ideal drives, one 1 ms task (the kernel's cost)
runtime:
  tick: 0.001
  clock: {clock}
  tasks:
    motion: {{period: 0.001, priority: 1}}
axes:
  x: {{limits: {{v_max: 1.0, a_max: 4.0, j_max: 40.0}}, software_limits: {{min: -1.0, max: 1.0}}}}
  y: {{limits: {{v_max: 0.8, a_max: 3.0, j_max: 30.0}}, software_limits: {{min: -1.0, max: 1.0}}}}
  z: {{limits: {{v_max: 0.3, a_max: 2.0, j_max: 20.0}}, software_limits: {{min: -0.2, max: 0.2}}}}
groups:
  xyz: {{axes: [x, y, z], queue_depth: 64}}
"""


# -- programs (mm) ---------------------------------------------------------------------------
@dataclass
class Program:
    """A G-code body (moves only, mm) with its start point and feed, run under a corner mode."""

    name: str
    kind: str  # "5-20 mm" or "0.1-1 mm"
    start: tuple[float, float, float]
    body: list[str]
    feed: float  # mm/min
    tolerance: float  # G64 P [mm]

    def text(self, mode: str) -> str:
        """The program translated so that it starts where the machine stands (the origin): no
        rapid move in it, so length / F is a lower bound of its duration."""
        shift = dict(zip("XYZ", self.start, strict=True))

        def moved(m: re.Match) -> str:
            return f"{m.group(1)}{float(m.group(2)) - shift[m.group(1)]:.6f}"

        body = [_WORD.sub(moved, line) for line in self.body]
        head = ["%", f"({self.name}: motionplc bench_gcode)", "G21 G90 G17", mode]
        return "\n".join([*head, f"F{self.feed:.3f}", *body, "M2", "%"]) + "\n"


_WORD = re.compile(r"\b([XYZ])(-?\d+(?:\.\d*)?)")


def _fmt(*xyz: float) -> str:
    return " ".join(f"{a}{v:.6f}" for a, v in zip("XYZ", xyz, strict=False))


def contour(n: int, rng: np.random.Generator, lo: float, hi: float) -> list[str]:
    """A closed part outline: straight edges of lo..hi mm around a centre, every third corner
    rounded by a tangent G2/G3 arc of radius lo..hi/2 mm (arc corners), the others sharp."""
    out: list[str] = []
    c = np.array([500.0, 350.0])
    ang, rad = 0.0, 60.0
    p = c + rad * np.array([1.0, 0.0])
    pts = [p]
    while len(pts) < n:
        ang += rng.uniform(lo, hi) / rad
        rad = float(np.clip(rad + rng.uniform(-8.0, 8.0), 30.0, 120.0))
        pts.append(c + rad * np.array([math.cos(ang), math.sin(ang)]))
    for k in range(1, len(pts) - 1):
        a, b, nxt = pts[k - 1], pts[k], pts[k + 1]
        if k % 3:
            out.append("G1 " + _fmt(*b))
            continue
        # round the corner at b: a tangent arc between the two edges
        u, v = (b - a) / np.linalg.norm(b - a), (nxt - b) / np.linalg.norm(nxt - b)
        turn = math.atan2(u[0] * v[1] - u[1] * v[0], float(u @ v))
        if abs(turn) < 0.05:
            out.append("G1 " + _fmt(*b))
            continue
        r = min(
            rng.uniform(lo, hi) / 2.0, 0.4 * min(np.linalg.norm(b - a), np.linalg.norm(nxt - b))
        )
        d = r * math.tan(abs(turn) / 2.0)
        p_in, p_out = b - u * d, b + v * d
        out.append("G1 " + _fmt(*p_in))
        word = "G3" if turn > 0 else "G2"
        out.append(f"{word} {_fmt(*p_out)} R{r:.6f}")
    return out


def pocket(rng: np.random.Generator, lo: float, hi: float, rows: int) -> list[str]:
    """A zigzag pocket: passes split into lo..hi mm segments (as CAM posts them), step-overs
    of lo mm joined by half-circle G2/G3 turnarounds."""
    out: list[str] = []
    x0, y0, width = 300.0, 200.0, 8.0 * hi
    step = lo * 1.2
    x = x0
    for r in range(rows):
        forward = r % 2 == 0
        y_end = y0 + width if forward else y0
        y = y0 if forward else y0 + width
        while abs(y_end - y) > 1e-9:
            seg = min(rng.uniform(lo, hi), abs(y_end - y))
            y += seg if forward else -seg
            out.append("G1 " + _fmt(x, y))
        # turnaround: a half circle of diameter step to the next pass
        word = "G2" if forward else "G3"
        x += step
        out.append(f"{word} {_fmt(x, y)} R{step / 2.0:.6f}")
    return out


def walk(n: int, rng: np.random.Generator, lo: float, hi: float) -> tuple[tuple, list[str]]:
    """A 3-D random walk of segments lo..hi mm (flatter in z), reflected into a box."""
    box = ((200.0, 1000.0), (150.0, 650.0), (-100.0, -10.0))
    p = np.array([600.0, 400.0, -50.0])
    start = tuple(p)
    out = []
    for _ in range(n):
        d = rng.normal(size=3) * np.array([1.0, 1.0, 0.3])
        q = p + d / np.linalg.norm(d) * rng.uniform(lo, hi)
        for k, (a, b) in enumerate(box):
            q[k] = 2 * a - q[k] if q[k] < a else (2 * b - q[k] if q[k] > b else q[k])
        out.append("G1 " + _fmt(*q))
        p = q
    return start, out


def wheels(n: int, rng: np.random.Generator, lo: float, hi: float) -> list[str]:
    """Small wheel-shaped contours (a hub circle with teeth), tessellated into lo..hi mm chords
    as a CAM posts a spline, one wheel after the other (joined by a G1 at the same feed)."""
    out: list[str] = []
    cx, cy = 400.0, 300.0
    while len(out) < n:
        r0, teeth = rng.uniform(6.0, 12.0), int(rng.integers(6, 14))
        amp = rng.uniform(0.5, 1.5)
        s = 0.0
        while s < 2.0 * math.pi and len(out) < n:
            rr = r0 + amp * math.sin(teeth * s)
            out.append("G1 " + _fmt(cx + rr * math.cos(s), cy + rr * math.sin(s)))
            s += rng.uniform(lo, hi) / (r0 + amp * teeth)
        cx += 2.0 * r0 + 4.0
    return out


def raster(n: int, rng: np.random.Generator, lo: float, hi: float) -> list[str]:
    """A 3-D finishing raster over z = f(x, y): lines of lo..hi mm following the surface,
    a sharp 90-degree corner at the end of every pass."""
    out: list[str] = []
    x, y, forward = 400.0, 300.0, True
    while len(out) < n:
        y_end = 340.0 if forward else 300.0
        while (y < y_end if forward else y > y_end) and len(out) < n:
            y = (
                min(y + rng.uniform(lo, hi), y_end)
                if forward
                else max(y - rng.uniform(lo, hi), y_end)
            )
            z = -20.0 + 3.0 * math.sin(x / 7.0) * math.cos(y / 5.0)
            out.append("G1 " + _fmt(x, y, z))
        x += 0.8
        forward = not forward
    return out


def arc_corners(n: int, rng: np.random.Generator, lo: float, hi: float) -> list[str]:
    """Short lines (lo..hi mm) joined by small tangent corner arcs (radius 0.05..0.5 of the
    neighbouring lines, G2/G3 by the turn), as arc-fitting CAM output: every second move an
    arc. The real-time program."""
    out: list[str] = []
    p = np.array([500.0, 350.0])
    heading = 0.0
    while len(out) < n:
        seg = rng.uniform(lo, hi)
        q = p + seg * np.array([math.cos(heading), math.sin(heading)])
        turn = rng.uniform(0.3, 1.6) * (1 if rng.random() < 0.5 else -1)
        r = rng.uniform(0.05, 0.5) * seg
        d = r * math.tan(abs(turn) / 2.0)
        d = min(d, 0.45 * seg)
        r = d / math.tan(abs(turn) / 2.0)
        u = np.array([math.cos(heading), math.sin(heading)])
        heading += turn
        v = np.array([math.cos(heading), math.sin(heading)])
        p_in, p_out = q - u * d, q + v * d
        out.append("G1 " + _fmt(*p_in))
        out.append(("G3 " if turn > 0 else "G2 ") + _fmt(*p_out) + f" R{r:.6f}")
        p = p_out
        # keep it in the working area: steer back to the middle
        if np.linalg.norm(p - np.array([500.0, 350.0])) > 150.0:
            heading = math.atan2(350.0 - p[1], 500.0 - p[0])
    return out


def programs(scale: float, seed: int) -> list[Program]:
    rng = np.random.default_rng(seed)
    n = lambda k: max(20, int(k * scale))  # noqa: E731
    out = []
    body = contour(n(240), rng, 5.0, 20.0)
    out.append(Program("contour", "5-20 mm", (560.0, 350.0, -20.0), body, 6000.0, 0.05))
    body = pocket(rng, 5.0, 20.0, n(30))
    out.append(Program("pocket", "5-20 mm", (300.0, 200.0, -20.0), body, 4000.0, 0.05))
    start, body = walk(n(300), rng, 5.0, 20.0)
    out.append(Program("3-D walk", "5-20 mm", start, body, 6000.0, 0.05))
    body = wheels(n(1500), rng, 0.1, 1.0)
    first = body[0].split()
    sx, sy = float(first[1][1:]), float(first[2][1:])
    out.append(Program("wheels", "0.1-1 mm", (sx, sy, -20.0), body[1:], 2400.0, 0.01))
    body = raster(n(1500), rng, 0.1, 1.0)
    out.append(Program("3-D raster", "0.1-1 mm", (400.0, 300.0, -20.0), body, 2400.0, 0.01))
    body = arc_corners(n(1500), rng, 0.1, 1.0)
    out.append(Program("arc corners", "0.1-1 mm", (500.0, 350.0, -20.0), body, 2400.0, 0.01))
    return out


# -- one run -----------------------------------------------------------------------------------
def run(path: Path, config: Path, realtime: bool, idle: int = 0) -> dict:
    """Run a program; the trace, timings per cycle (exec ns, what the cycle did) and outcome."""
    cfg = load_config(config)
    job = load_gcode_job(path, cfg, "xyz")
    machine = build(cfg, realtime=realtime)
    try:
        rt = machine.runtime
        g = machine.axes_groups["xyz"]
        task = next(t for t in rt.tasks if t.name == job.task)
        per_cycle: list[tuple[int, int, int, int]] = []  # (cycle, exec ns, phase, dry)
        state = {"phase": 0, "runner": None}

        def sample(rt_, cycle: int) -> None:
            r = state["runner"]
            dry = 0
            if r is not None and r.t_motion is not None and not r.over:
                left = not r._exhausted or r._next is not None  # program not all queued
                dry = int(left and not g.mq.queue and not g.mq.inbox)
            per_cycle.append((cycle, task.exec_last_ns, state["phase"], dry))

        rt.add_cycle_hook(sample)
        runner = GcodeRunner(job, machine)
        state["runner"] = runner
        # idle cycles of the same run: the axes powered, the group enabled, nothing moving
        if idle:
            from motionplc.blocks import MC_Power
            from motionplc.blocks.group_blocks import MC_GroupEnable

            powers = [MC_Power(axis=machine.axes[a], enable=True) for a in job.axes]
            en = MC_GroupEnable(axes_group=g, execute=False)

            def warm(ctx) -> None:  # noqa: ANN001 - a task program
                for p in powers:
                    p()
                en(execute=all(p.status for p in powers))

            machine.attach(warm, job.task)
            rt.run_until(lambda: en.done, max_seconds=5.0)
            state["phase"] = 1
            rt.run(cycles=idle)
            state["phase"] = 2
        machine.attach(runner, job.task)
        w0 = time.perf_counter()
        rt.run_until(lambda: runner.over, max_seconds=36000.0)
        wall = time.perf_counter() - w0
        if idle:
            state["phase"] = 3
            rt.run(cycles=idle)
        if runner.failures:
            raise SystemExit(f"{path}: {runner.failures[0]}")
        tr = rt.trace
        names = list(g.axis_names)
        cols = {c: tr.column(c) for c in tr.columns if c.split(".")[0] in names or c == "t"}
        limits = {n: SetValueLimits.of(machine.axes[n].cfg) for n in names}
        return {
            "runner": runner,
            "wall": wall,
            "motion": (runner.t_finished or rt.time) - (runner.t_motion or 0.0),
            "cols": cols,
            "names": names,
            "limits": limits,
            "period": task.period,
            "k": task.period_ticks,
            "events": list(tr.events),
            "cycles": np.array(per_cycle, dtype=np.int64).reshape(-1, 4),
            "stats": rt.stats()[job.task],
        }
    finally:
        machine.close()


def trace_check(r: dict) -> tuple[int, str]:
    """Group D on every axis' traced set values: (violating samples, the worst as text)."""
    k = r["k"]
    bad, worst, text = 0, 0.0, "-"
    for n in r["names"]:
        c = r["cols"]
        sl = slice(None, None, k)
        p, v = c[f"{n}.position"][sl], c[f"{n}.velocity"][sl]
        a, j = c[f"{n}.acceleration"][sl], c[f"{n}.jerk"][sl]
        t = c["t"][sl]  # (in real time, ticks skipped after an overrun leave gaps)
        found = check_set_values(t, p, v, a, j, r["limits"][n])
        bad += len(found)
        for f in found:
            ratio = abs(f.value / f.bound) if f.bound else math.inf
            if ratio > worst:
                worst, text = ratio, f"{n} {f.rule.split()[0]} {ratio:.7g}x @{t[f.index]:.3f}s"
    return bad, text


def path_deviation(r: dict, step: float) -> float:
    """Largest distance of a traced sample (during the motion) to the programmed path [m]."""
    from scipy.spatial import cKDTree

    runner = r["runner"]
    pts = [np.asarray(runner.start, dtype=float)[None]]
    for mv in runner.job.program.moves(runner.start):
        path = move_path(mv)
        m = max(2, int(math.ceil(path.length / step)) + 1)
        pts.append(path.evaluate(np.linspace(0.0, path.u_end, m)))
    ref = np.concatenate(pts)
    pos = np.stack([r["cols"][f"{n}.position"] for n in r["names"]], axis=1)
    d, _ = cKDTree(ref).query(pos)
    # the distance to the sampled path is an upper bound of the distance to the path (and
    # exceeds it by at most step / 2)
    return float(d.max())


def path_length(r: dict) -> float:
    runner = r["runner"]
    return float(sum(move_path(m).length for m in runner.job.program.moves(runner.start)))


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--quick", action="store_true", help="programs at 1/5 size, short RT run")
    ap.add_argument("--scale", type=float, default=1.0, help="program size factor")
    ap.add_argument("--seed", type=int, default=25)
    ap.add_argument("--rt-segments", type=int, default=3000, help="0: no real-time run")
    ap.add_argument("--rt-idle", type=int, default=2000, help="idle cycles before and after")
    ap.add_argument("--only", default="", help="comma-separated program names")
    ap.add_argument("--out", default=None, help="keep the programs in this directory")
    ap.add_argument(
        "--interpret",
        action="append",
        default=[],
        metavar="FILE",
        help="only interpret + map FILE on mill3 (lines per second; 'largest': the largest "
        "third-party program; tools/bench_gcode_interp.py --file)",
    )
    args = ap.parse_args()
    if args.interpret:
        from tools.bench_gcode_interp import file_figures, largest_program

        for f in args.interpret:
            print(file_figures(largest_program() if f == "largest" else Path(f).resolve()))
        return 0
    scale = 0.2 if args.quick else args.scale
    tmp = Path(args.out) if args.out else Path(tempfile.mkdtemp(prefix="bench_gcode_"))
    tmp.mkdir(parents=True, exist_ok=True)
    sim_cfg = tmp / "gantry_ideal_1ms.yaml"
    sim_cfg.write_text(RT_CONFIG.format(clock="simulated"))
    progs = programs(scale, args.seed)
    if args.only:
        keep = {s.strip() for s in args.only.split(",")}
        progs = [p for p in progs if p.name in keep]
    print(
        "G-code bench: the gantry's axes and group on ideal drives, one 1 ms task, simulated "
        f"clock; programs (seed {args.seed}) in {tmp}"
    )
    head = (
        f"{'program':<12} {'segments':>9} {'moves':>6} {'length':>9} {'F':>6} {'P':>5} "
        f"{'L/F':>8} {'G61':>8} {'G64':>8} {'G64/G61':>8} {'G61/LF':>7} {'G64/LF':>7} "
        f"{'dev/P':>6} {'D-check G61 | G64 (worst)':<44}"
    )
    print(head)
    print(
        f"{'':<12} {'':>9} {'':>6} {'[mm]':>9} {'mm/min':>6} {'[mm]':>5} "
        f"{'[s]':>8} {'[s]':>8} {'[s]':>8}"
    )
    all_ok = True
    for prog in progs:
        res = {}
        for mode in ("G61", f"G64 P{prog.tolerance:g}"):
            f = tmp / f"{prog.name.replace(' ', '_')}_{mode.split()[0]}.ngc"
            f.write_text(prog.text(mode))
            res[mode.split()[0]] = run(f, sim_cfg, realtime=False)
        g61, g64 = res["G61"], res["G64"]
        length = path_length(g64) * 1e3
        lf = length / (prog.feed / 60.0)
        ratio = g64["motion"] / g61["motion"]
        ok = ratio <= 1.0
        all_ok &= ok
        dev = path_deviation(g64, prog.tolerance * 1e-3 / 20.0) / (prog.tolerance * 1e-3)
        d61, w61 = trace_check(g61)
        d64, w64 = trace_check(g64)
        moves = g64["runner"].moves_sent
        print(
            f"{prog.name:<12} {prog.kind:>9} {moves:>6} {length:>9.1f} {prog.feed:>6.0f} "
            f"{prog.tolerance:>5g} {lf:>8.3f} {g61['motion']:>8.3f} {g64['motion']:>8.3f} "
            f"{ratio:>7.3f}{' ' if ok else '!'} {g61['motion'] / lf:>7.3f} "
            f"{g64['motion'] / lf:>7.3f} {dev:>6.3f} {d61:>4} | {d64:>4} ({w64 if d64 else w61})"
        )
        sys.stdout.flush()
    print(
        "  G64/G61 <= 1 on every program: "
        + ("yes" if all_ok else "NO (marked !)")
        + "; dev/P: largest distance of the G64 trace to the programmed path / P (<= 1: within P); "
        "D-check: samples breaking a differencing rule (invariants group D) in the G61 | G64 trace"
    )
    if args.rt_segments:
        n = args.rt_segments if not args.quick else min(args.rt_segments, 600)
        rng = np.random.default_rng(args.seed + 1)
        prog = Program(
            "arc corners",
            "0.1-1 mm",
            (500.0, 350.0, -20.0),
            arc_corners(n, rng, 0.1, 1.0),
            2400.0,
            0.01,
        )
        f = tmp / "arc_corners_rt.ngc"
        f.write_text(prog.text(f"G64 P{prog.tolerance:g}"))
        rt_cfg = tmp / "gantry_ideal_1ms_rt.yaml"
        rt_cfg.write_text(RT_CONFIG.format(clock="realtime"))
        r = run(f, rt_cfg, realtime=True, idle=args.rt_idle)
        cyc = r["cycles"]
        idx, ex, phase, dry = cyc[:, 0], cyc[:, 1] / 1e3, cyc[:, 2], cyc[:, 3]  # ex [us]
        # which cycles queued a line or an arc (busy edges of the runner's FBs)
        q_line, q_arc = set(), set()
        for ev in r["events"]:
            if ev.output == "busy" and ev.value:
                if ev.fb.startswith("xyz.gcode_linear"):
                    q_line.add(ev.cycle)
                elif ev.fb.startswith("xyz.gcode_circular"):
                    q_arc.add(ev.cycle)
        groups = {
            "idle (same run)": (phase == 1) | (phase == 3),
            "moving, nothing queued": (phase == 2) & ~np.isin(idx, list(q_line | q_arc)),
            "queued a line": np.isin(idx, list(q_line)),
            "queued an arc": np.isin(idx, list(q_arc)),
        }
        s = r["stats"]
        length = path_length(r) * 1e3
        print(
            "\nreal time, 1 kHz (realtime clock, ideal drives): 'arc corners' "
            f"{r['runner'].moves_sent} moves ({n} segments, {length:.0f} mm at F{prog.feed:g}, "
            f"G64 P{prog.tolerance:g}), "
            f"{s.cycle_count} cycles, overruns {s.overruns}, omitted {s.omitted_cycles}, "
            f"lateness p99 {s.lateness_p99 * 1e6:.0f} us"
        )
        print(f"  {'cycles':<24} {'n':>7} {'exec p50':>9} {'p99':>9} {'max':>9}  [us]")
        for name, m in groups.items():
            if m.any():
                e = ex[m]
                print(
                    f"  {name:<24} {int(m.sum()):>7} {np.percentile(e, 50):>9.0f} "
                    f"{np.percentile(e, 99):>9.0f} {e.max():>9.0f}"
                )
        idle_p99 = (
            np.percentile(ex[groups["idle (same run)"]], 99)
            if groups["idle (same run)"].any()
            else math.nan
        )
        busy = groups["queued a line"] | groups["queued an arc"]
        print(
            f"  queueing cycles over 1 ms: {int((ex[busy] > 1000).sum())} of {int(busy.sum())}; "
            f"queue-a-move p99 / idle p99 = {np.percentile(ex[busy], 99) / idle_p99:.1f}x; "
            f"queue ran dry (nothing behind the running move, program not all queued): "
            f"{int(dry.sum())} cycles; motion {r['motion']:.3f} s vs length / F "
            f"{length / (prog.feed / 60.0):.3f} s"
        )
        d, w = trace_check(r)
        print(f"  D-check of the real-time trace: {d} samples ({w})")
    return 0 if all_ok else 1


if __name__ == "__main__":
    raise SystemExit(main())
