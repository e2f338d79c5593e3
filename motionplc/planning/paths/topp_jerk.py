"""Jerk-limited time-optimal motion along a path (third-order path parameterisation, TOPP3).

Per-axis velocity, acceleration and jerk limits (asymmetric where ``PathLimits`` carries
``v_min``/``a_min``/``j_min``), a path speed limit, from and to any path speed and tangential
path acceleration. With ``x(u) = du^2`` the axis values along ``q(u)`` are::

    v = q' sqrt(x)      a = q' x'/2 + q'' x      j = sqrt(x) (q' x''/2 + 3/2 q'' x' + q''' x)

Method (:mod:`motionplc.planning.paths._topp3`):

1. **Model.** ``x`` is a uniform quadratic B-spline on the planner's grid (C1: ``du`` and
   ``d2u/dt2`` continuous, ``x''`` constant per interval). Velocity and acceleration limits are
   linear in its coefficients, the jerk limit ``|q' x''/2 + 3/2 q'' x' + q''' x| <= J / sqrt(x)``
   becomes linear after replacing the convex ``J / sqrt(x)`` by its tangent at a reference
   ``x_r`` -- a lower bound, so the linearised set lies *inside* the true one (as COPP's
   successive linearisation, Pham & Pham's TOPP3 structure). All limits are imposed at the start,
   middle and end of every interval. From and to rest the optimum grows like ``u^(4/3)``, which
   no polynomial follows: the first (last) interval is an exact constant-jerk start (stop),
   ``x_1 = 1.5 h ddu_1``, whose limits are bounded in closed form at its check points.
2. **Solve.** ``min sum_k w_k / sqrt(x_k)`` (the trapezoid rule of the duration; exact
   ``3 h / v_1`` on a constant-jerk start) under those rows: a convex problem, solved by a
   Mehrotra primal-dual interior-point method whose normal equations are pentadiagonal (every
   row touches three neighbouring coefficients): a banded Cholesky factorisation, O(n) per
   iteration, ~20 iterations. Round 1 linearises at the second-order optimum (its upper bound,
   :func:`~motionplc.planning.paths.topp.solve_second_order`); rounds 2-3 at the previous
   solution, with only the rows nearest to active. Each round's optimum is feasible for the
   next linearisation, so the model duration does not increase from round to round.
3. **Time law.** The node states ``(du_k, d2u_k)`` are joined by two constant-jerk pieces per
   interval, matching both states exactly (closed form: ``h = V d - (a_1 - a_0) d^2 / 3``), so
   the result is an exact C2 piecewise cubic ``u(t)`` (``PathTrajectory.sample`` returns the true
   derivatives of its positions).
4. **Check and repair.** Every piece is checked on 9 samples with the conservative bound of
   :mod:`topp` (largest sample plus a quarter of the largest second difference); an interval
   exceeding a limit has it tightened (twice the excess, with its neighbours) and the problem is
   solved again. From rest to rest a remaining excess ``r`` is removed exactly by slowing the whole
   law down by ``max(r_v, sqrt(r_a), cbrt(r_j))``. If nothing feasible is found, the old smoothed
   second-order law (:mod:`_topp_jerk_filter`) is the fallback (``info["fallback"]``).

What is proven and what is not:

* **Feasible**: every returned law holds every limit at the check samples of every piece, and
  between them up to the (standard, not rigorous) second-difference allowance; the path speed is
  checked exactly non-negative. Tested by differencing sampled positions at 1 ms.
* **Not slower than needed by more than the discretisation**: the interior-point solution is the
  global optimum (to a 1e-7 duality gap) of the *linearised discrete* problem of its round; that
  problem is an inner approximation of the discrete TOPP3, so the sequence is a successive convex
  (inner) approximation converging to a KKT point of the discrete problem -- a local optimum, not
  proven global (TOPP3 is non-convex). The objective is the trapezoid rule of the duration, not
  the exact duration of the two-piece law. The duration is never below the second-order optimum
  (``second_order_duration``: a lower bound for any jerk limit).
* **Not optimal**: the constant-jerk first and last interval, the margins of the repair, the
  final time scaling, the grid (``n`` intervals). Curvature jumps of the path (a line meeting an
  arc) make the axis acceleration jump at non-zero speed: the chain rule sees no jerk there, so
  such paths should be split (or blended G2) by the caller.
"""

from __future__ import annotations

import math
import time

import numpy as np

from motionplc.errors import PlanningError
from motionplc.planning.paths import _topp3 as k3
from motionplc.planning.paths.base import Path
from motionplc.planning.paths.topp import (
    PathLimits,
    _boundary_x,
    _evaluate_grid,
    solve_second_order,
)
from motionplc.planning.paths.trajectory import PathTrajectory, SpeedLaw

__all__ = ["plan_jerk_limited"]

_ROUNDS = 8  # successive linearisations of the jerk rows at most
_ROUND_TOL = 1e-4  # stop when a round gains less (relative duration)
_REPAIRS = 6
_GAPS = (1e-6, 1e-7)  # duality gap per round (relative to the duration)
_ACCEPT = 1e-9


def _limits3(lim: PathLimits) -> k3.Limits3:
    def lo(name: str, hi: np.ndarray) -> np.ndarray:
        m = getattr(lim, name, None)
        return hi if m is None else np.abs(np.asarray(m, dtype=float))

    assert lim.j_max is not None
    return k3.Limits3(
        lim.v_max,
        lo("v_min", lim.v_max),
        lim.a_max,
        lo("a_min", lim.a_max),
        lim.j_max,
        lo("j_min", lim.j_max),
        lim.v_path,
    )


def _ddu(name: str, acc: float, x: float, grid, k: int) -> float:
    """``d2u/dt2`` of a tangential path acceleration ``acc`` [m/s^2] at half-grid index k."""
    q1, q2 = grid.q1[k], grid.q2[k]
    sp = math.sqrt(float(q1 @ q1))
    if sp == 0.0:
        if acc != 0.0:
            raise PlanningError(f"{name}: the path has a zero tangent there; allowed [0, 0]")
        return 0.0
    return (acc - float(q1 @ q2) / sp * x) / sp


def _break_candidates(path: Path, offset: float = 0.0, depth: int = 0) -> list[float]:
    """Parameters where a path may change its second derivative: the breaks of composite
    paths (and of their segments), the passing points of Hermite curves, B-spline knots."""
    out: list[float] = []
    for attr in ("breaks", "point_params", "knots"):
        v = getattr(path, attr, None)
        if v is not None:
            with np.errstate(all="ignore"):
                arr = np.asarray(v, dtype=float).ravel()
            out.extend((offset + arr[np.isfinite(arr)]).tolist())
    segs = getattr(path, "segments", None)
    breaks = getattr(path, "breaks", None)
    if segs is not None and breaks is not None and depth < 4:
        for seg, b0 in zip(segs, np.asarray(breaks, dtype=float)[:-1], strict=False):
            out.extend(_break_candidates(seg, offset + float(b0), depth + 1))
    return out


def curvature_jumps(path: Path, rtol: float = 1e-7) -> np.ndarray:
    """Interior parameters where ``q''`` (or ``q'``: a corner) jumps. At such a point the axis
    acceleration ``q' ddu + q'' du^2`` jumps unless ``du = 0``: a jerk-limited motion stops
    there. Found among :func:`_break_candidates` by comparing ``q'`` and ``q''`` just left and
    right of each."""
    u_end = float(path.u_end)
    cand = np.unique(np.asarray(_break_candidates(path), dtype=float))
    tol_u = 1e-9 * max(u_end, 1.0)
    cand = cand[(cand > 1e3 * tol_u) & (cand < u_end - 1e3 * tol_u)]
    if not len(cand):
        return cand
    grid = np.linspace(0.0, u_end, 257)
    scale = float(np.abs(np.asarray(path.evaluate(grid, 2), dtype=float)).max())
    scale = max(scale, float(np.abs(np.asarray(path.evaluate(grid, 1), dtype=float)).max()) ** 2)
    q3 = float(np.abs(np.asarray(path.evaluate(grid, 3), dtype=float)).max())
    s1 = float(np.abs(np.asarray(path.evaluate(grid, 1), dtype=float)).max())
    jumps = np.zeros(len(cand), dtype=bool)
    for k, sc, d in ((1, s1, scale), (2, scale, q3)):
        lo = np.asarray(path.evaluate(cand - tol_u, k), dtype=float).reshape(len(cand), -1)
        hi = np.asarray(path.evaluate(cand + tol_u, k), dtype=float).reshape(len(cand), -1)
        jumps |= np.abs(hi - lo).max(axis=1) > rtol * sc + 4.0 * tol_u * d
    return cand[jumps]


class _Piece(Path):
    """``path`` restricted to ``[u0, u1]``, reparametrised to start at 0."""

    __slots__ = ("_p", "_u0", "_len")

    def __init__(self, path: Path, u0: float, u1: float) -> None:
        self._p = path
        self._u0 = float(u0)
        self._len = float(u1) - float(u0)

    @property
    def dim(self) -> int:
        return self._p.dim

    @property
    def u_end(self) -> float:
        return self._len

    def evaluate(self, u, order: int = 0):
        uu = np.clip(np.asarray(u, dtype=float), 0.0, self._len) + self._u0
        return self._p.evaluate(np.minimum(uu, float(self._p.u_end)), order)


def plan_jerk_limited(
    path: Path,
    lim: PathLimits,
    vs: float,
    ve: float,
    n: int,
    *,
    a_start: float = 0.0,
    a_end: float = 0.0,
) -> PathTrajectory:
    """Jerk-limited motion along ``path`` (validated limits; see the module docstring).

    ``vs``/``ve``: path speeds ``|dp/dt|`` at the ends; ``a_start``/``a_end``: tangential path
    accelerations ``d|dp/dt|/dt`` there [m/s^2]. Where the path's second derivative jumps
    (:func:`curvature_jumps`) the motion stops: the pieces between are planned one by one (grid
    intervals shared by length) and joined.
    """
    jumps = curvature_jumps(path)
    if not len(jumps):
        return _plan_piece(path, lim, vs, ve, n, a_start, a_end)
    t_start = time.perf_counter()
    u_end = float(path.u_end)
    cuts = np.concatenate([[0.0], jumps, [u_end]])
    laws, gu, gdu, gmax = [], [], [], []
    info: dict[str, float] = {"stops": float(len(jumps)), "rounds": 0.0}
    t_off = 0.0
    for i in range(len(cuts) - 1):
        u0, u1 = float(cuts[i]), float(cuts[i + 1])
        ni = max(8, round(n * (u1 - u0) / u_end))
        first, last = i == 0, i == len(cuts) - 2
        tr = _plan_piece(
            _Piece(path, u0, u1),
            lim,
            vs if first else 0.0,
            ve if last else 0.0,
            ni,
            a_start if first else 0.0,
            a_end if last else 0.0,
        )
        if "fallback" in tr.info:
            info["fallback"] = 1.0
        info["rounds"] = max(info["rounds"], tr.info.get("rounds", 0.0))
        lw = tr.law
        laws.append((lw.t + t_off, lw.u + u0, lw.du, lw.ddu, lw.dddu))
        t_off += lw.duration
        gu.append(tr.grid_u[:-1] + u0)
        gdu.append(tr.grid_du[:-1])
        gmax.append(tr.grid_du_max[:-1])
    law = SpeedLaw(*(np.concatenate(c) for c in zip(*laws, strict=True)), t_off, u_end)
    grid = _evaluate_grid(path, n)
    x0 = _boundary_x("v_start", vs, grid, 0)
    xe = _boundary_x("v_end", ve, grid, 2 * n)
    sol2, _, _ = solve_second_order(path, lim, x0, xe, n, grid)
    t2 = float(np.sum(2.0 * grid.h / (np.sqrt(sol2.x[:-1]) + np.sqrt(sol2.x[1:]))))
    info["second_order_duration"] = t2
    info["compute_s"] = time.perf_counter() - t_start
    gu.append([u_end])
    gdu.append([math.sqrt(max(tr.grid_du[-1], 0.0) ** 2)])
    gmax.append([tr.grid_du_max[-1]])
    return PathTrajectory(
        path, law, 3, np.concatenate(gu), np.concatenate(gdu), np.concatenate(gmax), t2, info
    )


def _grid_sizes(path: Path, n: int) -> list[int]:
    """Grid sizes to try: ``n``, raised so that every segment of a piecewise path (between
    :func:`_break_candidates`) spans at least 4 intervals (at most 16 n and 100000), then
    four times that."""
    u_end = float(path.u_end)
    cand = np.unique(np.concatenate([[0.0, u_end], _break_candidates(path)]))
    cand = cand[(cand >= 0.0) & (cand <= u_end)]
    gap = float(np.min(np.diff(cand))) if len(cand) > 1 else u_end
    cap = min(16 * n, 100_000)
    n1 = n if gap <= 0.0 else min(max(n, math.ceil(4.0 * u_end / gap)), cap)
    return sorted({n1, min(4 * n1, max(cap, n1))})


def _plan_piece(
    path: Path,
    lim: PathLimits,
    vs: float,
    ve: float,
    n: int,
    a_start: float,
    a_end: float,
) -> PathTrajectory:
    """One piece without curvature jumps (see :func:`plan_jerk_limited`)."""
    t_start = time.perf_counter()
    law = None
    err: Exception | None = None
    info: dict[str, float] = {}
    for nn in _grid_sizes(path, n):
        grid = _evaluate_grid(path, nn)
        x0 = _boundary_x("v_start", vs, grid, 0)
        xe = _boundary_x("v_end", ve, grid, 2 * nn)
        a0 = _ddu("a_start", float(a_start), x0, grid, 0)
        ae = _ddu("a_end", float(a_end), xe, grid, 2 * nn)
        if x0 == 0.0 and a0 < 0.0:
            raise PlanningError(f"a_start: must be >= 0 at zero start speed, got {a_start!r}")
        if xe == 0.0 and ae > 0.0:
            raise PlanningError(f"a_end: must be <= 0 at zero end speed, got {a_end!r}")
        sol2, _, _ = solve_second_order(path, lim, x0, xe, nn, grid)
        t2 = float(np.sum(2.0 * grid.h / (np.sqrt(sol2.x[:-1]) + np.sqrt(sol2.x[1:]))))
        info = {"second_order_duration": t2, "grid": float(nn)}
        try:
            law, xs, info2 = _solve(path, nn, _limits3(lim), k3.Boundary(x0, a0, xe, ae), sol2.x)
            info.update(info2)
            break
        except (ValueError, PlanningError, np.linalg.LinAlgError) as exc:
            err = exc
    if law is None:
        info["fallback"] = 1.0
        from motionplc.planning.paths._topp_jerk_filter import plan_filtered

        if a0 != 0.0 or ae != 0.0:
            raise PlanningError(
                f"j_max: no jerk-limited motion found along this path ({err})"
            ) from err
        tr = plan_filtered(path, lim, vs, ve, n)  # on the caller's grid
        info.update(tr.info)
        info["compute_s"] = time.perf_counter() - t_start
        return PathTrajectory(path, tr.law, 3, tr.grid_u, tr.grid_du, tr.grid_du_max, t2, info)
    info["compute_s"] = time.perf_counter() - t_start
    return PathTrajectory(
        path,
        law,
        3,
        grid.u[::2],
        np.sqrt(np.maximum(xs, 0.0)),
        np.sqrt(np.maximum(sol2.mvc, 0.0)),
        t2,
        info,
    )


def _scaled(law: SpeedLaw, lam: float) -> SpeedLaw:
    """``law`` slowed down ``lam`` times (velocities / lam, accelerations / lam^2, jerks /
    lam^3: every ratio of the limits scales exactly)."""
    return SpeedLaw(
        law.t * lam,
        law.u,
        law.du / lam,
        law.ddu / lam**2,
        law.dddu / lam**3,
        law.duration * lam,
        law.u_end,
    )


def _solve(path: Path, n: int, lim: k3.Limits3, bnd: k3.Boundary, x2: np.ndarray):
    model = k3.Model(path, n, lim, bnd)
    free = model.free_mask()
    if not float(np.max(x2)) > 0.0:
        raise ValueError("second-order profile is zero")
    E, off, w = model.objective_rows()
    # variable scaling c = sc * chat with sc the coefficients of the second-order optimum (so
    # chat ~ 1 everywhere), the objective scaled to O(1), every row to a largest coefficient 1
    sc = k3.coefficients_from_nodes(0.5 * x2)
    sc = np.maximum(sc, 1e-6 * float(sc.max()))
    w_s = w / math.sqrt(float(sc.max()))
    w_s = w_s / (float(np.sum(w_s)) or 1.0)
    offs = off
    xr = np.stack([x2[:-1], 0.5 * (x2[:-1] + x2[1:]), x2[1:]], axis=1)
    c = np.ones(n + 2)
    rest = bnd.rest_start and bnd.rest_end
    best: tuple[float, SpeedLaw, np.ndarray] | None = None
    info: dict[str, float] = {"rounds": 0.0, "ipm_iterations": 0.0, "repairs": 0.0}
    prev_T = math.inf
    for rnd in range(1, _ROUNDS + _REPAIRS + 1):
        # variables scaled by the previous solution (the second-order one at first)
        tri = np.stack([sc[:-2], sc[1:-1], sc[2:]], axis=1)[:, None, :]  # (n, 1, 3)
        Es = E * tri
        G, r = model.rows(xr)
        Gs = G * tri
        rho = np.abs(Gs).max(axis=2)
        rho = np.where(rho > 0.0, rho, 1.0)
        Gs = Gs / rho[:, :, None]
        rs = r / rho
        gap = _GAPS[min(rnd, len(_GAPS)) - 1]
        res = k3.solve_ipm(Gs, rs, Es, offs, w_s, free, c, gap=gap)
        info["ipm_iterations"] += res.iterations
        info["rounds"] = float(rnd)
        c = res.c
        cf = model.expand(c * sc)
        x, a = model.nodes(cf)
        law = k3.law_from_nodes(model.u[::2], np.sqrt(np.maximum(x, 0.0)), a, float(path.u_end))
        chk = k3.check_law(path, law, lim)
        rv, ra, rj = (float(chk[k].max()) for k in ("v", "a", "j"))
        worst = max(rv, ra, rj)
        cand = None
        if float(chk["du"].min()) >= -1e-12 * float(np.max(law.du)):
            if worst <= 1.0 + _ACCEPT:
                cand = law
            elif rest and worst < 1.01:
                # rest to rest: slow the whole law down by the small excess (exact)
                stretch = max(rv, math.sqrt(ra), rj ** (1.0 / 3.0)) * (1.0 + 4.0 * _ACCEPT)
                cand = _scaled(law, stretch)
        if cand is not None and (best is None or cand.duration < best[0]):
            best = (cand.duration, cand, x)
            info["time_scale"] = cand.duration / law.duration
        T = law.duration
        violated = worst > 1.0 + _ACCEPT
        if violated:
            # margins: intervals whose law exceeded a limit get it tightened by the excess
            for kind in ("v", "a", "j"):
                arr = chk[kind]
                ratio = np.maximum(arr[0::2], arr[1::2])
                sel = np.flatnonzero(ratio > 1.0 + _ACCEPT)
                if not len(sel):
                    continue
                f = 1.0 / (2.0 * ratio[sel] - 1.0)  # twice the excess: the solution moves
                scl = {"v": model.scale_vel, "a": model.scale_acc, "j": model.scale_jerk}[kind]
                g = scl[sel] * (f * f if kind == "v" else f[:, None])
                for d in (-1, 0, 1):
                    ii = np.clip(sel + d, 0, n - 1)
                    scl[ii] = np.minimum(scl[ii], g)
        converged = rnd >= 2 and prev_T - T < _ROUND_TOL * T
        if best is not None and (rnd >= _ROUNDS or converged) and (not violated or rest):
            break
        if best is not None and rnd >= _ROUNDS + 2:
            break
        prev_T = T
        info["repairs"] += float(violated)
        # next round: linearised at this solution
        xr = model.x_points(cf)
        sc_new = np.maximum(np.where(free, cf, 1.0), 1e-6 * float(np.max(cf)))
        c = c * sc / sc_new
        sc = sc_new
        tri = np.stack([sc[:-2], sc[1:-1], sc[2:]], axis=1)[:, None, :]
    if best is None:
        raise ValueError("no feasible third-order solution")
    T, law, x = best
    return law, x, info
