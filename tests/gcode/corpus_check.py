"""Runs a G-code program on a configured mill and checks the commanded motion in its trace
against the program (used by tests/gcode/test_corpus_run.py and tools/gcode_corpus.py).

Nothing here trusts the kernel's own columns for the verdict on the motion:

* **limits**: every axis' traced set values sampled at its task's cycles through the invariant
  checker's group D (:func:`motionplc.runtime.invariants.check_set_values`: the differenced
  positions within v/a/j, positions agreeing with the velocity/acceleration columns);
* **path**: the distance of every traced group position (every tick) to the programmed toolpath
  (the interpreter's moves, exact lines, arcs and helices, computed in closed form / by Newton
  steps, not on a sampled polyline), against what the program allows there: on the half of a
  move next to a corner the corner's tolerance (``G64 P``; ``G64`` / ``G64 P0`` "as fast as
  possible": half the shorter move, the group's largest blend; ``G61`` / ``G61.1`` / a
  synchronised event between the moves: 0), plus ``G64 Q`` on lines of a naive-CAM run; 0 in
  between. A rounding allowance of :data:`PATH_ATOL` is the only slack;
* **exact corners**: every join that is not tangent and allowed no deviation (G61, G61.1, an
  event) is reached: the nearest traced position to the corner point within
  :data:`CORNER_ATOL`;
* **end**: the last traced position is the program's last point.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from motionplc.config import build, load_config
from motionplc.gcode import GcodeEvent, GcodeMove, move_path
from motionplc.gcode_runner import AS_FAST_AS_POSSIBLE, GcodeRunner, load_gcode_job
from motionplc.runtime.invariants import SetValueLimits, check_set_values

ROOT = Path(__file__).resolve().parents[2]
CORPUS_DIR = ROOT / "tests" / "gcode" / "corpus"
MILL3 = ROOT / "configs" / "gcode" / "mill3.yaml"
MILL4 = ROOT / "configs" / "gcode" / "mill4.yaml"

PATH_ATOL = 1e-9
"""[m] rounding allowance of a traced position's distance to the programmed path."""
CORNER_ATOL = 1e-9
"""[m] rounding allowance of how close the trace comes to an exact corner (G61, G61.1), on
top of the kinematic one (:func:`corner_allowance`)."""
_TANGENT = 1e-6  # [rad] a join turning less is tangent (passed at speed under G61)


@dataclass
class Segment:
    """One programmed move: its path, the tolerances at its start and end corners [m] and
    the naive-CAM tolerance (G64 Q) it was run under (0: none)."""

    move: GcodeMove
    path: Any
    tol_start: float = 0.0
    tol_end: float = 0.0
    q: float = 0.0


@dataclass
class RunResult:
    """A program's run and its checks (see the module docstring)."""

    program: str
    machine: str
    finished: bool
    failures: list[str]
    moves: int
    motion: float  # [s] of motion
    cpu: float = 0.0
    samples: int = 0
    limit_violations: int = 0
    worst_limit: str = "-"
    worst_ratio: dict[str, float] = field(default_factory=dict)  # |v|,|a|,|j| / limit (worst)
    deviation: float = 0.0  # [m] largest distance of a traced position to the path
    excess: float = 0.0  # [m] largest distance beyond what the program allows there
    excess_at: str = "-"
    allowed_ratio: float = 0.0  # largest distance / allowed (over samples with allowed > 0)
    tolerances: tuple[float, ...] = ()  # the G64 P tolerances the program uses [m]
    exact_corners: int = 0
    corner_miss: float = 0.0  # [m] largest distance of an exact corner to the trace
    corner_allowance: float = CORNER_ATOL  # [m] what corner_miss may be
    end_error: float = 0.0  # [m]
    dropped_rows: int = 0

    @property
    def ok(self) -> bool:
        return (
            self.finished
            and not self.failures
            and self.limit_violations == 0
            and self.excess <= 0.0
            and self.corner_miss <= self.corner_allowance
            and self.end_error <= PATH_ATOL
            and self.dropped_rows == 0
        )


def _tangent(path: Any, end: bool) -> np.ndarray:
    d = path.evaluate(np.array([path.u_end if end else 0.0]), 1)[0]
    n = float(np.linalg.norm(d))
    return d / n if n > 0 else d


def segments(items: Sequence[GcodeMove | GcodeEvent]) -> list[Segment]:
    """The programmed moves with the tolerance of each corner (as the runner maps them:
    :func:`motionplc.gcode_runner._transition`, a synchronised event makes the next corner an
    exact stop)."""
    out: list[Segment] = []
    synced = True
    for it in items:
        if isinstance(it, GcodeEvent):
            if it.sync and it.kind not in ("message", "note"):
                synced = True
            continue
        seg = Segment(it, move_path(it), q=float(it.naive_tolerance or 0.0))
        if out and not synced:
            prev = out[-1]
            pm = prev.move
            if pm.exact_stop or pm.exact_path:
                tol = 0.0
            else:
                tol = AS_FAST_AS_POSSIBLE if pm.tolerance is None else float(pm.tolerance)
                if tol >= AS_FAST_AS_POSSIBLE:  # the blend takes at most half of either move
                    tol = 0.5 * min(prev.path.length, seg.path.length)
            prev.tol_end = seg.tol_start = tol
        out.append(seg)
        synced = False
    return out


# -- exact distance of points to a move ------------------------------------------------------
def _distance(seg: Segment, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(distance of each point of ``q`` (n x dim) to the move, the fraction 0..1 of the move
    at the nearest point)."""
    p = seg.path
    if hasattr(p, "direction"):  # a Line
        a = p.start
        d = p.end - a
        dd = float(d @ d)
        t = np.clip(((q - a) @ d) / dd, 0.0, 1.0) if dd > 0 else np.zeros(len(q))
        return np.linalg.norm(a + t[:, None] * d - q, axis=1), t
    base, x, y, n = p._base, p._x, p._y, p._n  # noqa: SLF001 - the closed form
    r, c, k = p._r, p._c, p._k  # noqa: SLF001
    phi = p.angle
    w = q - base
    qx, qy = w @ x, w @ y
    if c == 0.0:
        th = np.mod(np.arctan2(qy, qx), 2.0 * math.pi)
        if phi < 2.0 * math.pi:  # outside the swept angle: the nearer end
            out = th > phi
            to_start = 2.0 * math.pi - th
            th = np.where(out & (to_start < th - phi), 0.0, np.where(out, phi, th))
    else:
        # a helix p(th) = base + r (cos th x + sin th y) + c th n: start from the turn nearest
        # along the axis, then Newton steps on |p(th) - q|^2
        qn = w @ n
        th0 = np.mod(np.arctan2(qy, qx), 2.0 * math.pi)
        turn = np.round((qn / c - th0) / (2.0 * math.pi))
        th = np.clip(th0 + 2.0 * math.pi * turn, 0.0, phi)
        for _ in range(8):
            f1 = r * (qx * np.sin(th) - qy * np.cos(th)) + c * (c * th - qn)
            f2 = r * (qx * np.cos(th) + qy * np.sin(th)) + c * c
            th = np.clip(th - f1 / np.where(f2 > 0, f2, c * c), 0.0, phi)
    pts = p.evaluate(th / k)
    return np.linalg.norm(pts - q, axis=1), th / phi


def path_check(segs: list[Segment], pos: np.ndarray) -> tuple[float, float, int, float]:
    """(largest distance of a position to the path, largest excess over the allowance, the
    sample index of that excess, largest distance / allowance where the allowance is > 0)."""
    from scipy.spatial import cKDTree

    # candidate moves of a position: the moves of the nearest points of a dense sampling
    ref, owner = [], []
    for i, s in enumerate(segs):
        m = max(3, min(2000, int(math.ceil(s.path.length / 2e-4)) + 1))
        ref.append(s.path.evaluate(np.linspace(0.0, s.path.u_end, m)))
        owner.append(np.full(m, i))
    tree = cKDTree(np.concatenate(ref))
    own = np.concatenate(owner)
    kq = min(16, len(own))
    _, idx = tree.query(pos, k=kq)
    idx = idx.reshape(len(pos), kq)
    cand = own[idx]
    best_dist = np.full(len(pos), np.inf)
    best_excess = np.full(len(pos), np.inf)
    best_ratio = np.full(len(pos), np.inf)
    for i in np.unique(cand):
        rows = np.nonzero((cand == i).any(axis=1))[0]
        s = segs[int(i)]
        d, frac = _distance(s, pos[rows])
        allowed = np.where(frac <= 0.5, s.tol_start, s.tol_end) + s.q
        ex = d - allowed - PATH_ATOL
        zero = np.where(d > PATH_ATOL, np.inf, 0.0)  # no allowance: on the path or infinite
        ratio = np.where(allowed > 0, d / np.where(allowed > 0, allowed, 1.0), zero)
        best_dist[rows] = np.minimum(best_dist[rows], d)
        better = ex < best_excess[rows]
        best_excess[rows] = np.where(better, ex, best_excess[rows])
        best_ratio[rows] = np.minimum(best_ratio[rows], ratio)
    k = int(np.argmax(best_excess))
    finite = best_ratio[np.isfinite(best_ratio)]
    return (
        float(best_dist.max()),
        float(best_excess[k]),
        k,
        float(finite.max()) if finite.size else 0.0,
    )


def exact_corners(segs: list[Segment]) -> list[tuple[np.ndarray, np.ndarray]]:
    """The corner points the program passes exactly (non-tangent joins with tolerance 0), each
    with the mask of the axes moving in the two moves."""
    out = []
    for a, b in zip(segs, segs[1:], strict=False):
        if a.tol_end > 0.0 or a.q > 0.0 or b.q > 0.0:
            continue
        ta, tb = _tangent(a.path, True), _tangent(b.path, False)
        dot = max(-1.0, min(1.0, float(ta @ tb)))
        if math.acos(dot) > _TANGENT:
            pa, pb = (np.asarray(m.start) for m in (a.move, b.move))
            moving = (np.asarray(a.move.end) != pa) | (np.asarray(b.move.end) != pb)
            out.append((np.asarray(a.move.end, dtype=float), moving))
    return out


def corner_allowance(j_max: Sequence[float], h: float) -> float:
    """[m] how far the trace's nearest sample may lie from a corner where the motion stops:
    the stop is reached between two samples ``h`` apart, at most ``h / 2`` from one of them,
    and at rest (v = a = 0) a jerk-limited axis moves ``j_max (h/2)^3 / 6`` in that time."""
    return CORNER_ATOL + math.sqrt(sum((j * (0.5 * h) ** 3 / 6.0) ** 2 for j in j_max))


def _roomy(cfg: Any) -> Any:
    """The configuration with a trace that keeps every cycle of a long program."""
    rs = dataclasses.replace(cfg.runtime, trace_capacity=2_000_000, trace_bytes=2**30)
    return dataclasses.replace(cfg, runtime=rs)


def run_checked(
    program: Path,
    config: Path,
    *,
    timeout: float = 3600.0,
    inspect: Callable[[Any, GcodeRunner], None] | None = None,
) -> RunResult:
    """Run ``program`` on ``config`` (its only group) and check the trace; ``inspect(machine,
    runner)`` is called after the run, before the machine is closed."""
    import time

    cfg = _roomy(load_config(config))
    job = load_gcode_job(program, cfg, timeout=timeout)
    c0 = time.process_time()
    with build(cfg) as machine:
        runner = GcodeRunner(job, machine)
        machine.attach(runner, job.task)
        rt = machine.runtime
        rt.run_until(lambda: runner.over, max_seconds=timeout + 1.0)
        tr = rt.trace
        group = machine.axes_groups[job.group]
        names = list(group.axis_names)
        cols = {f"{n}.{q}": tr.column(f"{n}.{q}") for n in names for q in _Q}
        t = tr.column("t")
        task = next(tk for tk in rt.tasks if tk.name == job.task)
        k = task.period_ticks
        limits = {n: SetValueLimits.of(machine.axes[n].cfg) for n in names}
        res = RunResult(
            program.name,
            config.stem,
            runner.finished,
            list(runner.failures),
            runner.lines_run,
            (runner.t_finished or rt.time) - (runner.t_motion or 0.0),
            dropped_rows=tr.dropped_rows,
        )
        start = runner.start
        if inspect is not None:
            inspect(machine, runner)
    res.cpu = time.process_time() - c0
    # limits by differencing, at the task's cycles
    worst = 0.0
    for n in names:
        sl = slice(None, None, k)
        p, v, a, j = (cols[f"{n}.{q}"][sl] for q in _Q)
        found = check_set_values(t[sl], p, v, a, j, limits[n])
        res.limit_violations += len(found)
        for f in found:
            ratio = abs(f.value / f.bound) if f.bound else math.inf
            if ratio > worst:
                worst = ratio
                at = t[sl][f.index]
                res.worst_limit = f"{n} {f.rule.split()[0]} {ratio:.7g}x at t = {at:.3f} s"
        h = float(np.median(np.diff(t[sl]))) if len(p) > 3 else 1.0
        dv = np.diff(p) / h
        da = np.diff(dv) / h
        dj = np.diff(da) / h
        lim = limits[n]
        for key, arr, bound in (("v", dv, lim.v_max), ("a", da, lim.a_max), ("j", dj, lim.j_max)):
            if arr.size and math.isfinite(bound):
                res.worst_ratio[key] = max(
                    res.worst_ratio.get(key, 0.0), float(np.abs(arr).max()) / bound
                )
    # the path
    program_obj = job.program
    items = list(program_obj.items(start))
    segs = segments(items)
    pos = np.stack([cols[f"{n}.position"] for n in names], axis=1)
    res.samples = len(pos)
    if segs:
        dev, excess, at, ratio = path_check(segs, pos)
        res.deviation, res.excess, res.allowed_ratio = dev, max(0.0, excess), ratio
        if excess > 0.0:
            res.excess_at = f"t = {t[at]:.3f} s, position {np.round(pos[at], 9).tolist()}"
        res.tolerances = tuple(sorted({s.move.tolerance for s in segs if s.move.tolerance}))
        corners = exact_corners(segs)
        res.exact_corners = len(corners)
        if corners:
            from scipy.spatial import cKDTree

            h = float(np.max(np.diff(t[::k])))
            jm = np.array([limits[n].j_max for n in names])
            d, _ = cKDTree(pos).query(np.stack([c for c, _ in corners]))
            allow = np.array([corner_allowance(jm[m], h) for _, m in corners])
            w = int(np.argmax(d / allow))
            res.corner_miss, res.corner_allowance = float(d[w]), float(allow[w])
        res.end_error = float(np.linalg.norm(pos[-1] - np.asarray(segs[-1].move.end)))
    return res


_Q = ("position", "velocity", "acceleration", "jerk")


def fits(program: Path, config: Path) -> str | None:
    """None if the program is meant for the machine, else why not (a rotary program on the
    3-axis mill)."""
    if "rotary" in program.name and config.stem == "mill3":
        return "uses the A axis (mill3 has none)"
    return None
