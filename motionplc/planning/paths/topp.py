"""Time-optimal motion along a path (second order: axis velocity and acceleration limits).

Method: reachability analysis on a grid of the path parameter (TOPP-RA, Pham & Pham 2018; the
same forward/backward passes as seed 004's GAVS(s, v) in the ``(u, du^2)`` plane). On each grid
interval the path acceleration ``d2u/dt2 = a_i`` is constant, so ``x = (du/dt)^2`` is linear in
``u`` and ``u(t)`` is exactly quadratic in time. With ``q = p(u)`` each axis obeys::

    v_k = q'_k du            a_k = q'_k a_i + q''_k x

and every limit is a linear inequality in ``(x_i, a_i)`` at any point of the interval. The
planner imposes them at the start, middle and end of every interval (not only at the grid
points, as toppra does), which turns each interval into a set of lines ``lo_c(x) <= a <=
hi_d(x)`` in closed form: the maximum-velocity curve, the backward pass (controllable sets) and
the forward pass (greedy maximal ``a_i``) need no LP solver.

The grid (:func:`plan_path`'s second order) lies on the path's own smooth pieces
(:class:`~motionplc.planning.paths._chain.Chain`: segments of composites, Hermite sections,
B-spline knot spans): every break is a grid point and every interval is evaluated on its own
piece, so the derivatives at its ends are one-sided. A curvature jump (a line meeting an arc) is
then a switch of the active constraint at a grid point, never a violation inside an interval.
A tangent jump (an unblended corner, a reversal, a zero tangent on one side of a break) is an
exact stop: ``x = 0`` at that grid point (or a :class:`PlanningError` with ``stops="forbid"``).
About ``n_grid`` intervals of equal length are laid out first, with more where the tangent turns
quickly (at most ``_PHI`` rad per interval: arcs, corner blends, tight spline bends).

Between the three points a limit could still be exceeded by a term of order ``h^2``. After
solving, every interval is checked on 8 sub-intervals with a conservative bound (largest sample
plus a quarter of the largest second difference, i.e. twice the interpolation error of a smooth
function). Intervals exceeding a limit by more than ``_REFINE_TOL`` are cut (locally refined
grid, never a global scale-down); what is left is removed by tightening those intervals' limits
by the excess. Then the intervals where a constant path acceleration loses the most time
(:func:`_lossy`) are cut and the problem solved again, twice. The result is feasible on any
resampling (differenced 1 ms samples stay inside the limits to rounding), within the
discretisation of the optimum. Points where the path derivative vanishes inside a smooth piece,
switching points where the maximum-velocity curve is touched, and a non-zero start speed need
no special handling in this formulation.

The uniform-grid solver (:func:`solve_second_order`, one grid of ``n`` equal intervals over the
whole path) is kept for the jerk-limited planner's base law.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from motionplc.errors import PlanningError
from motionplc.planning.paths._chain import Chain, Junction, SubPath
from motionplc.planning.paths.base import Path
from motionplc.planning.paths.trajectory import PathTrajectory, SpeedLaw

__all__ = ["plan_path", "DEFAULT_GRID"]

DEFAULT_GRID = 1000
_MIN_PART_GRID = 64  # grid intervals of a jerk-limited part between two exact stops
_SUB = 8  # sub-intervals per grid interval in the feasibility check
_MARGIN = 1e-11  # relative margin on every limit (rounding)
_ACCEPT = 1e-12  # a bound up to 1 + _ACCEPT counts as held
_MAX_REPAIRS = 12
_MARGIN_FACTOR = 3.0  # first repair: margin in units of the sub-point second difference


# -- input checking -------------------------------------------------------------------------


def _per_axis(name: str, value: float | Sequence[float], dim: int, allow_inf: bool) -> np.ndarray:
    arr = np.atleast_1d(np.asarray(value, dtype=float))
    if arr.ndim != 1 or (arr.size != 1 and arr.size != dim):
        raise PlanningError(
            f"{name}: must be one value or one per axis ({dim} values), got shape {arr.shape}"
        )
    if arr.size == 1:
        arr = np.full(dim, float(arr[0]))
    upper = "inf]" if allow_inf else "inf)"
    for k, v in enumerate(arr):
        bad = math.isnan(v) or v <= 0.0 or (not allow_inf and math.isinf(v))
        if bad:
            raise PlanningError(f"{name}[{k}]: must be in (0, {upper}, got {v!r}")
    return arr


def _scalar(name: str, value: float, lo: float, hi: float, lo_open: bool = False) -> float:
    v = float(value)
    ok = (v > lo if lo_open else v >= lo) and v <= hi
    if math.isnan(v) or not ok:
        left = "(" if lo_open else "["
        right = "]" if math.isinf(hi) else "]"
        raise PlanningError(f"{name}: must be in {left}{lo!r}, {hi!r}{right}, got {value!r}")
    return v


@dataclass(frozen=True, slots=True)
class PathLimits:
    """Validated limits along a path (all arrays of length ``dim``, SI units).

    ``v_max`` may be infinite (no velocity limit); ``a_max`` is finite; ``j_max`` is ``None``
    for the second-order problem; ``v_path`` bounds the path speed ``|dp/dt|``.
    """

    v_max: np.ndarray
    a_max: np.ndarray
    j_max: np.ndarray | None
    v_path: float


# -- the evaluated grid ---------------------------------------------------------------------


@dataclass(frozen=True, slots=True)
class _Grid:
    n: int  # intervals
    h: float  # interval length in u
    u: np.ndarray  # (2n+1,) half-grid points
    q1: np.ndarray  # (2n+1, dim)
    q2: np.ndarray
    speed2: np.ndarray  # (2n+1,) |p'|^2
    tiny: float  # |c| below this counts as zero (c: the coefficient of a_i)


def _evaluate_grid(path: Path, n: int) -> _Grid:
    u_end = float(path.u_end)
    u = np.linspace(0.0, u_end, 2 * n + 1)
    q1 = np.asarray(path.evaluate(u, 1), dtype=float).reshape(len(u), -1)
    q2 = np.asarray(path.evaluate(u, 2), dtype=float).reshape(len(u), -1)
    for name, arr in (("first", q1), ("second", q2)):
        if not np.all(np.isfinite(arr)):
            bad = u[~np.all(np.isfinite(arr), axis=1)][0]
            raise PlanningError(f"path: {name} derivative is not finite at u={bad!r}")
    scale = float(np.abs(q1).max()) if q1.size else 0.0
    if scale == 0.0:
        raise PlanningError("path: the path does not move (zero derivative everywhere)")
    return _Grid(n, u_end / n, u, q1, q2, np.einsum("ij,ij->i", q1, q1), 1e-10 * scale)


def _speed_caps(grid: _Grid, lim: PathLimits, extra: np.ndarray | None = None) -> np.ndarray:
    """Largest ``x = du^2`` allowed by the velocity and path-speed limits at every half-grid
    point (``inf`` where nothing binds)."""
    cap = _caps_at(grid.q1, lim)
    if extra is not None:
        cap = np.minimum(cap, extra)
    return cap


# -- the solver ---------------------------------------------------------------------------------


@dataclass(frozen=True, slots=True)
class _Solution:
    x: np.ndarray  # (n+1,) du^2 at the grid points
    X: np.ndarray  # (n+1,) upper ends of the controllable sets
    mvc: np.ndarray  # (n+1,) interval maximum-velocity curve (x units)


_THETA = np.array([0.0, 0.5, 1.0])


def _lines(grid: _Grid, A: np.ndarray, C: np.ndarray, rows: np.ndarray):
    """Constraint lines of the intervals ``rows`` of a uniform grid (see :func:`_lines_at`)."""
    idx = 2 * rows[:, None] + np.arange(3)[None, :]  # (n, 3)
    h = np.full(len(rows), grid.h)
    return _lines_at(grid.q1[idx], grid.q2[idx], h, A[rows], C[rows], grid.tiny)


def _lines_at(q1: np.ndarray, q2: np.ndarray, h: np.ndarray, A: np.ndarray, C: np.ndarray, tiny):
    """Constraint lines of intervals of lengths ``h`` (n,).

    ``q1``, ``q2``: (n, 3, dim) path derivatives at the start, middle and end of every interval
    (one-sided at its ends: the interval's own piece); ``A``: (n, dim) acceleration limits;
    ``C``: (n, 3) caps on x at the same three points. Returns lower lines ``a >= p + r x``
    (n, mL), upper lines ``a <= s + w x`` (n, mU) and a static cap on ``x_i`` (n,).
    """
    n = len(h)
    hh = h[:, None]
    c = q1 + (2.0 * hh * _THETA[None, :])[:, :, None] * q2
    absc = np.abs(c)
    small = absc <= tiny
    A3 = np.broadcast_to(A[:, None, :], c.shape)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        s_acc = np.where(small, np.inf, A3 / absc)
        w_acc = np.where(small, 0.0, -q2 / c)
        stat = np.where(small & (q2 != 0.0), A3 / np.abs(q2), np.inf)
    static = np.minimum(C[:, 0], stat.reshape(n, -1).min(axis=1, initial=np.inf))
    lo_p = np.concatenate([-s_acc.reshape(n, -1), np.zeros((n, 1))], axis=1)
    lo_r = np.concatenate([w_acc.reshape(n, -1), -0.5 / hh], axis=1)
    cap_s = np.stack([C[:, 1] / h, C[:, 2] / (2.0 * h)], axis=1)  # inf stays inf
    cap_w = np.concatenate([-1.0 / hh, -0.5 / hh], axis=1)
    up_s = np.concatenate([s_acc.reshape(n, -1), cap_s], axis=1)
    up_w = np.concatenate([w_acc.reshape(n, -1), cap_w], axis=1)
    return lo_p, lo_r, up_s, up_w, static


def _prune(alpha: np.ndarray, beta: np.ndarray, top: np.ndarray) -> list[tuple[list, list]]:
    """Per row, a small superset of the lines ``alpha * y + beta`` that are the minimum for
    some ``y`` in ``[0, top]`` (so the minimum over the kept lines equals the minimum over all
    of them there).

    O(rows x lines): with ``c0``/``cT`` the lowest lines at ``y = 0``/``y = top`` and ``U`` the
    smaller of the two, ``line - U`` is convex on ``[0, top]`` with its only kink where ``c0`` and
    ``cT`` cross (``y*``), and it is >= 0 at both ends; a line can be below ``U`` (and so on
    the lower envelope) only if it is below ``U`` at ``y*``. Rows whose ``top`` is too large to
    evaluate the lines keep every finite line.
    """
    m = alpha.shape[1]
    with np.errstate(invalid="ignore", over="ignore", divide="ignore"):
        b = np.where(np.isnan(beta), np.inf, beta)
        finite = np.isfinite(b)
        if m == 0:
            return [([], [])] * len(b)
        topc = np.where(top > _PRUNE_TOP, 0.0, np.maximum(top, 0.0))
        vt = alpha * topc[:, None] + b
        vt = np.where(np.isnan(vt), np.inf, vt)
        rows = np.arange(len(b))
        c0 = np.argmin(b, axis=1)
        ct = np.argmin(vt, axis=1)
        a0, b0 = alpha[rows, c0], b[rows, c0]
        at, bt = alpha[rows, ct], b[rows, ct]
        da = a0 - at
        ys = np.where(da != 0.0, (bt - b0) / np.where(da != 0.0, da, 1.0), 0.0)
        ys = np.clip(np.nan_to_num(ys, nan=0.0, posinf=0.0, neginf=0.0), 0.0, topc)
        us = np.minimum(a0 * ys + b0, at * ys + bt)
        vs = alpha * ys[:, None] + b
        below = vs < us[:, None] - 1e-13 * np.abs(us[:, None])
        keep = finite & (below | (np.arange(m)[None, :] == c0[:, None]))
        keep |= finite & (np.arange(m)[None, :] == ct[:, None])
        keep |= finite & (top > _PRUNE_TOP)[:, None]
    counts = keep.sum(axis=1)
    fa = alpha[keep].tolist()
    fb = b[keep].tolist()
    ends = np.cumsum(counts).tolist()
    starts = [0, *ends[:-1]]
    return [(fa[i:j], fb[i:j]) for i, j in zip(starts, ends, strict=True)]


_PRUNE_TOP = 1e150  # a larger range keeps every line
_BIG = 1e300  # stands for "unbounded" in x (a path piece that does not move)
_MVC_STEPS = 12


def _pairwise_mvc(lo_p, lo_r, up_s, up_w, static) -> np.ndarray:
    """Interval maximum-velocity curve: the largest ``x_i`` with ``max_c lo_c(x) <= min_d
    hi_d(x)``. ``x = 0`` (with ``a = 0``) is always feasible, so each pair of lines bounds ``x``
    from above only: the minimum over all pairs (O(rows x lines^2))."""
    m = len(static)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        den = lo_r[:, :, None] - up_w[:, None, :]
        num = up_s[:, None, :] - lo_p[:, :, None]
        val = np.where(den > 0.0, num / np.where(den > 0.0, den, 1.0), np.inf)
    return np.minimum(static, val.reshape(m, -1).min(axis=1, initial=np.inf))


def _interval_mvc(lo_p, lo_r, up_s, up_w, static) -> np.ndarray:
    """The same value as :func:`_pairwise_mvc` in O(rows x lines x iterations): Newton's method
    from the right on the concave piecewise-linear ``g(x) = min_d hi_d(x) - max_c lo_c(x)``
    (``g(0) >= 0``). Each step jumps to where the two active lines cross (computed from the
    lines alone, no cancellation against a huge ``x``); for a concave ``g`` that point is never
    left of the root, and the active pair changes at most once per line. Rows that have not
    settled after a few steps are solved pairwise."""
    x = np.minimum(static, _BIG)
    rows = np.arange(len(x))
    active = rows
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        for _ in range(_MVC_STEPS):
            xa = x[active, None]
            hi = up_s[active] + up_w[active] * xa
            lo = lo_p[active] + lo_r[active] * xa
            d = np.argmin(hi, axis=1)
            c = np.argmax(lo, axis=1)
            k = np.arange(len(active))
            g = hi[k, d] - lo[k, c]
            bad = ~(g >= 0.0)
            if not bad.any():
                return x
            active = active[bad]
            c, d = c[bad], d[bad]
            den = lo_r[active, c] - up_w[active, d]
            xn = (up_s[active, d] - lo_p[active, c]) / den
            xo = x[active]
            xn = np.where((den > 0.0) & (xn >= 0.0), np.minimum(xn, xo), 0.0)
            x[active] = xn
            moving = xn < xo * (1.0 - 4e-16)
            active = active[moving]
            if not len(active):
                return x
    x[active] = _pairwise_mvc(
        lo_p[active], lo_r[active], up_s[active], up_w[active], static[active]
    )
    return x


class _Solver:
    """The forward/backward passes on a fixed grid of interval lengths ``h``; re-solving after a
    tightening of some intervals recomputes only those rows. ``lines(A, C, rows)`` returns the
    constraint lines of the intervals ``rows`` (:func:`_lines_at`)."""

    def __init__(self, h: np.ndarray, lines, x0: float, x_end: float) -> None:
        self.h = np.asarray(h, dtype=float)
        self.lines = lines
        self.x0 = x0
        self.x_end = min(x_end, _BIG)
        n = len(self.h)
        self.n = n
        self.mvc = np.zeros(n)
        self.back: list[tuple[list, list]] = [([], [])] * n
        self.fwd: list[tuple[list, list]] = [([], [])] * n

    def solve(self, A: np.ndarray, C: np.ndarray, rows: np.ndarray | None = None) -> _Solution:
        n = self.n
        rows = np.arange(n) if rows is None else np.asarray(rows, dtype=int)
        self.A = A
        self.C = C
        if len(rows):
            self._update(rows)
        mv = self.mvc.tolist()
        back = self.back
        fwd = self.fwd
        # Backward pass: X_i = min(mvc_i, min_c (X_{i+1} - 2h p_c) / (1 + 2h r_c)).
        Xl = [0.0] * (n + 1)
        Xn = self.x_end
        Xl[n] = Xn
        for i in range(n - 1, -1, -1):
            b = mv[i]
            al, be = back[i]
            for a_, b_ in zip(al, be, strict=True):
                v = a_ * Xn + b_
                if v < b:
                    b = v
            Xn = b if b > 0.0 else 0.0
            Xl[i] = Xn
        # Forward pass: x_{i+1} = min(X_{i+1}, min_d (x_i + 2h (s_d + w_d x_i))).
        xl = [0.0] * (n + 1)
        xi = min(self.x0, Xl[0])
        xl[0] = xi
        for i in range(n):
            b = Xl[i + 1]
            al, be = fwd[i]
            for a_, b_ in zip(al, be, strict=True):
                v = a_ * xi + b_
                if v < b:
                    b = v
            xi = b if b > 0.0 else 0.0
            xl[i + 1] = xi
        mvc = np.append(self.mvc, min(C[-1, 2], _BIG))
        return _Solution(np.array(xl), np.array(Xl), mvc)

    def _back_lines(self, lo_p: np.ndarray, lo_r: np.ndarray, rows: np.ndarray) -> None:
        # Backward lines (the last lower line, x_{i+1} >= 0, has a zero denominator up to
        # rounding and never binds: left out); the range of X_{i+1} is [0, mvc_{i+1}].
        h = self.h[rows][:, None]
        R = 1.0 + 2.0 * h * lo_r[:, :-1]
        pos = R > 0.0
        alpha = np.where(pos, 1.0 / np.where(pos, R, 1.0), 0.0)
        with np.errstate(invalid="ignore"):
            beta = np.where(pos, -2.0 * h * lo_p[:, :-1] * alpha, np.inf)
        top = np.append(self.mvc, self.x_end)[rows + 1]
        for i, item in zip(rows.tolist(), _prune(alpha, beta, top), strict=True):
            self.back[i] = item

    def _update(self, rows: np.ndarray) -> None:
        h = self.h[rows][:, None]
        lo_p, lo_r, up_s, up_w, static = self.lines(self.A, self.C, rows)
        mvc_r = _interval_mvc(lo_p, lo_r, up_s, up_w, static)
        self.mvc[rows] = np.clip(mvc_r, 0.0, _BIG)
        self._back_lines(lo_p, lo_r, rows)
        prev = np.setdiff1d(rows - 1, rows)  # a changed mvc_i changes the range of row i - 1
        prev = prev[prev >= 0]
        if len(prev):
            lo_p2, lo_r2, _, _, _ = self.lines(self.A, self.C, prev)
            self._back_lines(lo_p2, lo_r2, prev)
        for i, item in zip(
            rows.tolist(),
            _prune(1.0 + 2.0 * h * up_w, 2.0 * h * up_s, self.mvc[rows]),
            strict=True,
        ):
            self.fwd[i] = item


# -- feasibility check on sub-intervals ---------------------------------------------------------


@dataclass(frozen=True, slots=True)
class _Check:
    acc: np.ndarray  # (n, dim) bound of |a_k| / a_max_k per interval
    speed: np.ndarray  # (n,) bound of the squared speed ratio (velocity and path speed)
    acc_d2: np.ndarray  # (n, dim) largest |second difference| of a_k / a_max_k on the sub-points
    speed_d2: np.ndarray  # (n,) the same for the squared speed ratio
    worst: float


def _dense_eval(path: Path, n: int, sub: int) -> tuple[np.ndarray, np.ndarray]:
    u = np.linspace(0.0, float(path.u_end), n * sub + 1)
    q1 = np.asarray(path.evaluate(u, 1), dtype=float).reshape(len(u), -1)
    q2 = np.asarray(path.evaluate(u, 2), dtype=float).reshape(len(u), -1)
    sub_idx = sub * np.arange(n)[:, None] + np.arange(sub + 1)[None, :]
    return q1[sub_idx], q2[sub_idx]


def _bound(f: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Conservative (max, min) over the sub-interval axis (axis 1) of samples ``f``, and the
    largest |second difference| (a quarter of it is the allowance added to both)."""
    d2 = np.abs(np.diff(f, 2, axis=1)).max(axis=1)
    return f.max(axis=1) + 0.25 * d2, f.min(axis=1) - 0.25 * d2, d2


def _check(dense: tuple[np.ndarray, np.ndarray], x: np.ndarray, lim: PathLimits, h):
    Q1, Q2 = dense  # (n, sub+1, dim)
    n = len(x) - 1
    sub = Q1.shape[1] - 1
    th = np.arange(sub + 1) / sub
    a = (x[1:] - x[:-1]) / (2.0 * h)  # (n,)
    xs = x[:-1, None] + th[None, :] * (x[1:] - x[:-1])[:, None]  # (n, sub+1)
    acc = (Q1 * a[:, None, None] + Q2 * xs[:, :, None]) / lim.a_max  # (n, sub+1, dim)
    hi, lo, acc_d2 = _bound(acc)
    racc = np.maximum(hi, -lo)
    speed = np.zeros((n, sub + 1))
    with np.errstate(divide="ignore", invalid="ignore"):
        if np.any(np.isfinite(lim.v_max)):
            g = Q1**2 * xs[:, :, None] / (lim.v_max**2)[None, None, :]
            speed = np.where(np.isfinite(g), g, 0.0).max(axis=2)
        if math.isfinite(lim.v_path):
            sp = np.einsum("ijk,ijk->ij", Q1, Q1) * xs / lim.v_path**2
            speed = np.maximum(speed, sp)
    rspeed, _, speed_d2 = _bound(speed)
    worst = max(float(racc.max(initial=0.0)), float(rspeed.max(initial=0.0)))
    return _Check(racc, rspeed, acc_d2, speed_d2, worst)


def _neighbour_max(f: np.ndarray) -> np.ndarray:
    """``max(f[i - 1], f[i], f[i + 1])`` along axis 0."""
    g = f.copy()
    g[1:] = np.maximum(g[1:], f[:-1])
    g[:-1] = np.maximum(g[:-1], f[1:])
    return g


# -- public entry ---------------------------------------------------------------------------


def _validate(
    path: Path,
    v_max: float | Sequence[float],
    a_max: float | Sequence[float],
    j_max: float | Sequence[float] | None,
    v_path: float | None,
    v_start: float,
    v_end: float,
    n_grid: int | None,
) -> tuple[PathLimits, float, float, int]:
    if not isinstance(path, Path):
        raise PlanningError(f"path: must be a motionplc Path, got {type(path).__name__}")
    dim = int(path.dim)
    if dim < 1:
        raise PlanningError(f"path.dim: must be >= 1, got {dim}")
    u_end = float(path.u_end)
    if not (math.isfinite(u_end) and u_end > 0.0):
        raise PlanningError(f"path.u_end: must be in (0, inf), got {u_end!r}")
    vm = _per_axis("v_max", v_max, dim, allow_inf=True)
    am = _per_axis("a_max", a_max, dim, allow_inf=False)
    jm = None if j_max is None else _per_axis("j_max", j_max, dim, allow_inf=False)
    vp = math.inf if v_path is None else _scalar("v_path", v_path, 0.0, math.inf, lo_open=True)
    vs = _scalar("v_start", v_start, 0.0, 1e300)
    ve = _scalar("v_end", v_end, 0.0, 1e300)
    if n_grid is None:
        n = DEFAULT_GRID
    else:
        if isinstance(n_grid, bool) or not isinstance(n_grid, int | np.integer):
            raise PlanningError(f"n_grid: must be an integer in [2, 1000000], got {n_grid!r}")
        n = int(n_grid)
        if not 2 <= n <= 1_000_000:
            raise PlanningError(f"n_grid: must be in [2, 1000000], got {n}")
    return PathLimits(vm, am, jm, vp), vs, ve, n


def _boundary_x(name: str, speed: float, grid: _Grid, k: int) -> float:
    """``x = du^2`` of a path speed ``speed`` [m/s] at half-grid index ``k``."""
    return _speed_to_x(name, speed, float(grid.speed2[k]), "start" if k == 0 else "end")


def _law_second_order(
    x: np.ndarray, h: float | np.ndarray, u_end: float, u: np.ndarray | None = None
) -> SpeedLaw:
    """The speed law of constant path acceleration on every interval from ``x = du^2`` at the
    grid points (intervals of length ``h``, uniform or one per interval, starting at ``u``)."""
    n = len(x) - 1
    sig = np.sqrt(x)
    ssum = sig[:-1] + sig[1:]
    if u is None:
        u = np.asarray(h, dtype=float) * np.arange(n, dtype=float)
    if np.any(ssum <= 0.0):
        i = int(np.flatnonzero(ssum <= 0.0)[0])
        raise PlanningError(
            f"path: the limits allow no motion near u={float(u[i])!r} (the admissible path "
            "speed is 0)"
        )
    dur = 2.0 * np.asarray(h, dtype=float) / ssum
    t = np.concatenate([[0.0], np.cumsum(dur)])
    acc = (sig[1:] - sig[:-1]) / dur
    return SpeedLaw(t[:-1], u, sig[:-1], acc, np.zeros(n), float(t[-1]), u_end)


def _solve_repaired(
    solver: _Solver,
    dense: tuple[np.ndarray, np.ndarray],
    lim: PathLimits,
    h: np.ndarray,
    A: np.ndarray,
    C: np.ndarray,
    speed2: tuple[float, float],
    info: dict[str, float],
    max_repairs: int = _MAX_REPAIRS,
) -> _Solution:
    """Solve, check every interval on its sub-points and tighten the intervals that exceed a
    limit until none does (``speed2``: ``|p'|^2`` at the two ends, for the error messages).
    The last resort, scaling the whole profile, is reported in ``info["fallback_scale"]``."""
    x0, x_end = solver.x0, solver.x_end
    sol = solver.solve(A, C)
    for it in range(max_repairs + 1):
        if x0 > sol.X[0] * (1.0 + 1e-9) + 1e-300:
            vmax0 = math.sqrt(sol.X[0] * speed2[0])
            raise PlanningError(
                f"v_start: above what the path allows at its start; allowed [0, {vmax0!r}]"
            )
        chk = _check(dense, sol.x, lim, h)
        if chk.worst <= 1.0 + _ACCEPT:
            break
        if it == max_repairs:
            break
        info["repairs"] = info.get("repairs", 0.0) + 1.0
        if it == 0:
            # First repair, on every interval at once: between the three constraint points a
            # ratio can exceed its value there by the linear-interpolation error (<= 2 x the
            # second difference on the 4x finer sub-points) plus the check's own allowance
            # (0.25 x); 3 x the largest second difference of the interval and its neighbours
            # (the solution moves a little) covers both.
            # Only where a ratio comes that close to its limit (the boundary speeds a caller
            # imposes through extra_cap stay untouched where they are not near a limit).
            ma = np.minimum(_MARGIN_FACTOR * _neighbour_max(chk.acc_d2), 0.5)
            mv = np.minimum(_MARGIN_FACTOR * _neighbour_max(chk.speed_d2), 0.5)
            ma = np.where(_neighbour_max(chk.acc) + ma > 1.0, ma, 0.0)
            mv = np.where(_neighbour_max(chk.speed) + mv > 1.0, mv, 0.0)
            A = A * (1.0 - ma)
            C = C * (1.0 - mv)[:, None]
            rows = np.flatnonzero((ma > 0.0).any(axis=1) | (mv > 0.0))
            sol = solver.solve(A, C, rows)
            continue
        # tighten by twice the excess (the excess moves a little as the solution changes)
        fa = np.where(chk.acc > 1.0 + _ACCEPT, 1.0 / (2.0 * chk.acc - 1.0 + 1e-9), 1.0)
        fv = np.where(chk.speed > 1.0 + _ACCEPT, 1.0 / (2.0 * chk.speed - 1.0 + 1e-9), 1.0)
        A = A * fa
        C = C * fv[:, None]
        rows = np.flatnonzero((fa < 1.0).any(axis=1) | (fv < 1.0))
        sol = solver.solve(A, C, rows)
    if chk.worst > 1.0 + _ACCEPT:
        if x0 > 0.0 or x_end > 0.0:
            raise PlanningError(
                f"path: could not satisfy the limits between grid points after {max_repairs} "
                f"refinements (worst ratio {chk.worst!r}); use a finer n_grid"
            )
        # exact fallback: scaling x scales every ratio linearly
        sol = _Solution(sol.x * (1.0 - 1e-9) / chk.worst, sol.X, sol.mvc)
        info["fallback_scale"] = 1.0 / chk.worst
    info["worst_ratio"] = chk.worst
    if x_end > 0.0 and sol.x[-1] < x_end * (1.0 - 1e-9):
        reach = math.sqrt(sol.x[-1] * speed2[1])
        raise PlanningError(f"v_end: not reachable along this path; allowed [0, {reach!r}]")
    return sol


def solve_second_order(
    path: Path,
    lim: PathLimits,
    x0: float,
    x_end: float,
    n: int,
    grid: _Grid | None = None,
    extra_cap: np.ndarray | None = None,
    acc_scale: np.ndarray | None = None,
    span: tuple[int, int] | None = None,
) -> tuple[_Solution, _Grid, dict[str, float]]:
    """The feasible discretised optimum ``x_i`` on ``n`` intervals (see the module docstring).

    ``extra_cap`` (half-grid, x units) and ``acc_scale`` ((n, dim) factors <= 1) tighten the
    problem further (used by the jerk-limited planner). ``span = (i0, i1)`` solves only on the
    grid intervals ``i0 .. i1 - 1``, from ``x0`` at grid point ``i0`` to ``x_end`` at ``i1``,
    and holds ``x = x0`` before and ``x = x_end`` after (constant path speed; the caller checks
    those pieces). Raises :class:`PlanningError` when the start speed exceeds what the path
    allows or the end speed cannot be reached.
    """
    if grid is None:
        grid = _evaluate_grid(path, n)
    full_grid = grid
    caps = _speed_caps(grid, lim, extra_cap) * (1.0 - _MARGIN)
    idx = 2 * np.arange(n)[:, None] + np.arange(3)[None, :]
    C = caps[idx].copy()
    A = np.broadcast_to(lim.a_max * (1.0 - _MARGIN), (n, grid.q1.shape[1])).copy()
    if acc_scale is not None:
        A *= acc_scale
    dense = _dense_eval(path, n, _SUB)
    i0, i1 = (0, n) if span is None else (int(span[0]), int(span[1]))
    if not 0 <= i0 < i1 <= n:
        raise ValueError(f"span: must satisfy 0 <= i0 < i1 <= {n}, got {span!r}")
    if (i0, i1) != (0, n):
        k = slice(2 * i0, 2 * i1 + 1)
        grid = _Grid(i1 - i0, grid.h, grid.u[k], grid.q1[k], grid.q2[k], grid.speed2[k], grid.tiny)
        C, A = C[i0:i1], A[i0:i1]
        dense = (dense[0][i0:i1], dense[1][i0:i1])
        n = i1 - i0
    info: dict[str, float] = {"repairs": 0.0}
    h = grid.h
    sub_grid = grid
    solver = _Solver(np.full(n, h), lambda A_, C_, r_: _lines(sub_grid, A_, C_, r_), x0, x_end)
    sol = _solve_repaired(
        solver, dense, lim, np.full(n, h), A, C, (grid.speed2[0], grid.speed2[-1]), info
    )
    xs = sol.x.copy()
    xs[-1] = x_end if x_end > 0.0 else xs[-1]
    if grid is not full_grid:
        n_full = full_grid.n
        pre, post = np.full(i0, x0), np.full(n_full - i1, x_end)
        xs = np.concatenate([pre, xs, post])
        X = np.concatenate([pre, sol.X, post])
        mvc = np.concatenate([pre, sol.mvc, post])
        return _Solution(xs, X, mvc), full_grid, info
    return _Solution(xs, sol.X, sol.mvc), grid, info


# -- the second-order planner on the path's own pieces ---------------------------------------

_PHI = 0.03  # [rad] tangent turning (or log |p'| change) per grid interval, at most
_MAX_EXTRA = 512  # extra intervals one piece may get for its curvature
_REFINE_TOL = 1e-4  # intervals exceeding a limit by more than this are split (else tightened)
_MAX_REFINE = 8  # rounds of splitting
_MAX_GRID_FACTOR = 16  # splitting stops at this many times the initial interval count
_ACC_ROUNDS = 2  # rounds of splitting where the discretisation loses the most time
_ACC_GROWTH = 2.0  # ... up to this many times the initial interval count
_ACC_TOL = 2e-5  # ... until the estimated loss left is below this share of the duration


@dataclass(frozen=True, slots=True)
class _PieceGrid:
    """A grid on the pieces of a :class:`Chain`: interval ``i`` lies in piece ``piece[i]``
    from its local parameter ``t0[i]`` over ``h[i]``; ``stop[i]``: its start is an exact stop."""

    piece: np.ndarray
    t0: np.ndarray
    h: np.ndarray
    stop: np.ndarray

    @property
    def n(self) -> int:
        return len(self.h)

    def nodes(self, chain: Chain) -> np.ndarray:
        u = chain.u0[self.piece] + self.t0
        return np.append(u, chain.u_end)


def _piece_grid(chain: Chain, n: int, stop_pieces: set[int]) -> _PieceGrid:
    """About ``n`` intervals of equal length, every piece boundary a grid point, plus more
    intervals where the tangent turns (or ``|p'|`` changes) quickly, equidistributing
    ``1/h0 + rate/_PHI`` over each piece."""
    from motionplc.planning.paths.geometry import Line

    m = chain.n_pieces
    h0 = chain.u_end / n
    L = chain.length
    counts = np.maximum(1, np.ceil(L / h0 * (1.0 - 1e-12))).astype(int)
    is_line = np.array([isinstance(chain.leaves[k][1], Line) for k in chain.leaf.tolist()])
    curved = np.flatnonzero(~is_line)
    samples = np.clip(2 * counts[curved] + 1, 33, 4097)
    P = np.repeat(curved, samples)
    starts = np.cumsum(samples) - samples
    frac = (np.arange(len(P)) - np.repeat(starts, samples)) / np.repeat(samples - 1, samples)
    T = frac * L[P]
    pieces, t0s, hs, stops = [], [], [], []
    rates: dict[int, tuple[np.ndarray, np.ndarray]] = {}
    if len(P):
        q1, q2 = chain.eval(P, T, (1, 2))
        n1 = np.linalg.norm(q1, axis=1)
        with np.errstate(divide="ignore", invalid="ignore"):
            along = np.einsum("ij,ij->i", q2, q1) / n1**2
            perp = np.linalg.norm(q2 - along[:, None] * q1, axis=1) / n1
            rate = np.nan_to_num(perp + np.abs(along), nan=np.inf, posinf=np.inf)
        for j, st, cnt in zip(curved.tolist(), starts.tolist(), samples.tolist(), strict=True):
            rates[j] = (T[st : st + cnt], rate[st : st + cnt])
    for j in range(m):
        Lj = float(L[j])
        if j in rates:
            t, r = rates[j]
            dens = 1.0 / h0 + np.minimum(r / _PHI, _MAX_EXTRA / Lj)
            F = np.concatenate([[0.0], np.cumsum(0.5 * (dens[1:] + dens[:-1]) * np.diff(t))])
            k = max(1, math.ceil(F[-1] * (1.0 - 1e-12)))
            nodes = np.interp(np.linspace(0.0, F[-1], k + 1), F, t)
            nodes[0], nodes[-1] = 0.0, Lj
        else:
            k = int(counts[j])
            nodes = np.linspace(0.0, Lj, k + 1)
        pieces.append(np.full(k, j))
        t0s.append(nodes[:-1])
        hs.append(np.diff(nodes))
        st = np.zeros(k, dtype=bool)
        st[0] = j in stop_pieces
        stops.append(st)
    return _PieceGrid(
        np.concatenate(pieces), np.concatenate(t0s), np.concatenate(hs), np.concatenate(stops)
    )


def _split(grid: _PieceGrid, rows: np.ndarray, parts: np.ndarray | int = 2) -> _PieceGrid:
    """``grid`` with the intervals ``rows`` cut into ``parts`` equal parts each."""
    k = np.ones(grid.n, dtype=int)
    k[rows] = parts
    idx = np.repeat(np.arange(grid.n), k)
    first = np.concatenate([[0], np.cumsum(k)[:-1]])
    j = np.arange(len(idx)) - first[idx]  # part number inside the old interval
    h = grid.h[idx] / k[idx]
    t0 = grid.t0[idx] + j * h
    stop = grid.stop[idx] & (j == 0)
    return _PieceGrid(grid.piece[idx], t0, h, stop)


def _dense_pieces(chain: Chain, grid: _PieceGrid) -> tuple[np.ndarray, np.ndarray]:
    """``p'``, ``p''`` at ``_SUB + 1`` points of every interval, (n, _SUB + 1, dim), each
    interval evaluated on its own piece (one-sided at its ends)."""
    th = np.arange(_SUB + 1) / _SUB
    P = np.repeat(grid.piece, _SUB + 1)
    T = (grid.t0[:, None] + grid.h[:, None] * th[None, :]).reshape(-1)
    last = np.isclose(th, 1.0)
    ends = grid.t0 + grid.h
    T.reshape(grid.n, _SUB + 1)[:, last] = ends[:, None]
    q1, q2 = chain.eval(P, T, (1, 2))
    shape = (grid.n, _SUB + 1, chain.dim)
    q1, q2 = q1.reshape(shape), q2.reshape(shape)
    for name, arr in (("first", q1), ("second", q2)):
        if not np.all(np.isfinite(arr)):
            i = int(np.flatnonzero(~np.all(np.isfinite(arr), axis=(1, 2)))[0])
            u = float(chain.u0[grid.piece[i]] + grid.t0[i])
            raise PlanningError(f"path: {name} derivative is not finite near u={u!r}")
    return q1, q2


def _caps_at(q1: np.ndarray, lim: PathLimits) -> np.ndarray:
    """Largest ``x = du^2`` the velocity and path-speed limits allow at the points ``q1``
    (..., dim) (``inf`` where nothing binds)."""
    with np.errstate(divide="ignore", invalid="ignore"):
        v2 = lim.v_max**2 / q1**2
        v2 = np.where(q1 == 0.0, np.inf, v2)
        cap = v2.min(axis=-1) if q1.shape[-1] else np.full(q1.shape[:-1], np.inf)
        if math.isfinite(lim.v_path):
            s2 = np.einsum("...k,...k->...", q1, q1)
            cap = np.minimum(cap, np.where(s2 > 0.0, lim.v_path**2 / s2, np.inf))
    return cap


def _solve_on_pieces(
    chain: Chain, lim: PathLimits, vs: float, ve: float, n: int, stop_pieces: set[int]
) -> tuple[np.ndarray, np.ndarray, np.ndarray, dict[str, float]]:
    """The feasible second-order optimum on a grid of the path's pieces, refined where a
    limit is exceeded between grid points and where the discretisation loses the most time.
    Returns grid nodes ``u``, ``x`` there, the interval maximum-velocity curve and
    diagnostics."""
    grid = _piece_grid(chain, n, stop_pieces)
    n_max = _MAX_GRID_FACTOR * max(grid.n, n)
    info: dict[str, float] = {"repairs": 0.0, "refinements": 0.0, "accuracy_refinements": 0.0}
    n_acc = 0
    for acc_round in range(_ACC_ROUNDS + 1):
        final = acc_round == _ACC_ROUNDS
        grid, sol, s2_e, xe = _solve_feasible(chain, grid, lim, vs, ve, info, n_max, final)
        if acc_round == 0:
            n_acc = int(_ACC_GROWTH * grid.n)  # the accuracy refinement's budget
        if final:
            break
        rows = _lossy(sol.x, grid.h, grid.n)[: max(0, n_acc - grid.n)]
        if not len(rows):
            # nothing (more) to refine: the last solve, repaired where needed
            grid, sol, s2_e, xe = _solve_feasible(chain, grid, lim, vs, ve, info, n_max, True)
            break
        info["accuracy_refinements"] += 1.0
        grid = _split(grid, rows)
    if xe > 0.0 and sol.x[-1] < xe * (1.0 - 1e-9):
        reach = math.sqrt(sol.x[-1] * s2_e)
        raise PlanningError(f"v_end: not reachable along this path; allowed [0, {reach!r}]")
    xs = sol.x.copy()
    if xe > 0.0:
        xs[-1] = xe
    info["grid_intervals"] = float(grid.n)
    return grid.nodes(chain), xs, sol.mvc, info


def _lossy(x: np.ndarray, h: np.ndarray, n: int) -> np.ndarray:
    """Intervals where a constant path acceleration loses the most time, largest first.

    Where the admissible path acceleration changes along the path, a constant one per
    interval falls short of the reachable ``x`` by about ``h |a_next - a|``. The shortfall
    carries along the accelerating (or braking) stretch it lies in, downstream (upstream)
    until the stretch's peak, and there costs ``sum dt / (2 x)`` time per unit of ``x``. The
    intervals returned carry the largest estimated losses until what is left is below
    ``_ACC_TOL`` of the duration."""
    sig = np.sqrt(x)
    a = (x[1:] - x[:-1]) / (2.0 * h)
    da = np.zeros(n)
    if n > 1:
        d = np.abs(np.diff(a))
        da[:-1] = d
        da[1:] = np.maximum(da[1:], d)
    ssum = np.maximum(sig[1:] + sig[:-1], 1e-300)
    dt = 2.0 * h / ssum
    xm = np.maximum(0.25 * ssum * ssum, 1e-300)
    w = dt / (2.0 * xm)  # time per unit of x on every interval
    up = a > 0.0
    # sums of w over the rest of each accelerating stretch (downstream) or over the braking
    # stretch before each interval (upstream)
    S = np.zeros(n)
    acc = 0.0
    for i in range(n - 1, -1, -1):
        acc = acc + w[i] if up[i] else 0.0
        if up[i]:
            S[i] = acc
    acc = 0.0
    for i in range(n):
        acc = acc + w[i] if not up[i] else 0.0
        if not up[i]:
            S[i] = acc
    e = np.nan_to_num(h * da * S, nan=0.0, posinf=0.0)
    total = float(dt.sum())
    order = np.argsort(-e, kind="stable")
    tail = np.cumsum(e[order][::-1])[::-1]  # loss left when splitting from here on
    k = int(np.searchsorted(-tail, -_ACC_TOL * total))
    return order[:k]


def _solve_feasible(chain, grid, lim, vs, ve, info, n_max, final=True):
    """Solve on ``grid``; split the intervals that exceed a limit between grid points by more
    than ``_REFINE_TOL`` and solve again (at most ``_MAX_REFINE`` times), then tighten what is
    left (:func:`_solve_repaired`; not when ``final`` is false: an intermediate solution only
    guides the next refinement)."""
    for rnd in range(_MAX_REFINE + 1):
        q1, q2 = _dense_pieces(chain, grid)
        s2_0 = float(q1[0, 0] @ q1[0, 0])
        s2_e = float(q1[-1, -1] @ q1[-1, -1])
        x0 = _speed_to_x("v_start", vs, s2_0, "start")
        xe = _speed_to_x("v_end", ve, s2_e, "end")
        caps = _caps_at(q1[:, :: _SUB // 2], lim) * (1.0 - _MARGIN)  # (n, 3)
        C = caps.copy()
        C[grid.stop, 0] = 0.0
        C[np.flatnonzero(grid.stop[1:]), 2] = 0.0
        A = np.broadcast_to(lim.a_max * (1.0 - _MARGIN), (grid.n, chain.dim)).copy()
        scale = float(np.abs(q1).max())
        if scale == 0.0:
            raise PlanningError("path: the path does not move (zero derivative everywhere)")
        tiny = 1e-10 * scale
        q1c, q2c, hh = q1[:, :: _SUB // 2], q2[:, :: _SUB // 2], grid.h

        def lines(A_, C_, r_, q1c=q1c, q2c=q2c, hh=hh, tiny=tiny):
            return _lines_at(q1c[r_], q2c[r_], hh[r_], A_[r_], C_[r_], tiny)

        solver = _Solver(grid.h, lines, x0, xe)
        last = rnd == _MAX_REFINE or grid.n >= n_max
        if not last:
            sol = solver.solve(A, C)
            if x0 > sol.X[0] * (1.0 + 1e-9) + 1e-300:
                vmax0 = math.sqrt(sol.X[0] * s2_0)
                raise PlanningError(
                    f"v_start: above what the path allows at its start; allowed [0, {vmax0!r}]"
                )
            chk = _check((q1, q2), sol.x, lim, grid.h)
            if chk.worst <= 1.0 + _ACCEPT:
                info["worst_ratio"] = chk.worst
                return grid, sol, s2_e, xe
            excess = np.maximum(chk.acc.max(axis=1, initial=0.0), chk.speed) - 1.0
            bad = np.flatnonzero(excess > _REFINE_TOL)
            if not final and not len(bad):
                return grid, sol, s2_e, xe
            if len(bad):
                info["refinements"] += 1.0
                # the excess falls with h^2: enough parts for about a tenth of _REFINE_TOL
                parts = np.clip(np.ceil(np.sqrt(excess[bad] / (0.1 * _REFINE_TOL))), 2, 8)
                grid = _split(grid, bad, parts.astype(int))
                continue
        sol = _solve_repaired(solver, (q1, q2), lim, grid.h, A, C, (s2_0, s2_e), info)
        return grid, sol, s2_e, xe
    raise AssertionError("unreachable")  # pragma: no cover


def _speed_to_x(name: str, speed: float, s2: float, where: str) -> float:
    if speed == 0.0:
        return 0.0
    if s2 == 0.0:
        raise PlanningError(
            f"{name}: the path has a zero tangent at its {where}; allowed [0, 0], got {speed!r}"
        )
    return speed * speed / s2


def _stops_of(chain: Chain, stops: str) -> list[Junction]:
    """The junctions where the path must be passed at rest; PlanningError when ``stops`` is
    ``"forbid"`` and there is one."""
    found = [j for j in chain.junctions() if j.stop]
    if found and stops == "forbid":
        j = found[0]
        what = (
            f"a tangent jump of {math.degrees(j.deflection):.6g} deg"
            if math.isfinite(j.deflection) and j.deflection > 0.0
            else "a zero tangent on one side"
            if not math.isfinite(j.deflection)
            else f"a jump of |dp/du| by the factor {j.speed_ratio!r}"
        )
        raise PlanningError(
            f"path: {what} at u={j.u!r} (position {j.point.tolist()!r}) needs an exact stop, "
            f"but stops='forbid' ({len(found)} such point{'s' if len(found) > 1 else ''}); "
            "round the corner (blend_corners) or allow stops"
        )
    return found


def _concat(parts: list[PathTrajectory], path: Path, offsets: list[float]) -> PathTrajectory:
    """The trajectories of consecutive sub-paths (each from and to rest) as one along
    ``path`` (``offsets``: the sub-paths' start parameters)."""
    t_off = 0.0
    cols: dict[str, list[np.ndarray]] = {k: [] for k in ("t", "u", "du", "ddu", "dddu")}
    gu, gd, gm = [], [], []
    info: dict[str, float] = {}
    second = 0.0
    for k, (tr, off) in enumerate(zip(parts, offsets, strict=True)):
        law = tr.law
        cols["t"].append(law.t + t_off)
        cols["u"].append(law.u + off)
        cols["du"].append(law.du)
        cols["ddu"].append(law.ddu)
        cols["dddu"].append(law.dddu)
        t_off += law.duration
        second += tr.second_order_duration
        s = slice(0 if k == 0 else 1, None)
        gu.append(tr.grid_u[s] + off)
        gd.append(tr.grid_du[s])
        gm.append(tr.grid_du_max[s])
        for key, val in tr.info.items():
            info[key] = (
                max(info.get(key, val), val) if key == "worst_ratio" else (info.get(key, 0.0) + val)
            )
    law = SpeedLaw(
        *(np.concatenate(cols[k]) for k in ("t", "u", "du", "ddu", "dddu")),
        t_off,
        float(path.u_end),
    )
    info["stops"] = float(len(parts) - 1)
    return PathTrajectory(
        path,
        law,
        parts[0].order,
        np.concatenate(gu),
        np.concatenate(gd),
        np.concatenate(gm),
        second,
        info,
    )


def plan_path(
    path: Path,
    v_max: float | Sequence[float],
    a_max: float | Sequence[float],
    *,
    j_max: float | Sequence[float] | None = None,
    v_path: float | None = None,
    v_start: float = 0.0,
    v_end: float = 0.0,
    n_grid: int | None = None,
    stops: str = "allow",
) -> PathTrajectory:
    """The fastest motion along ``path`` within per-axis limits.

    Args:
        path: the geometric path (any :class:`Path`).
        v_max, a_max: per-axis velocity [m/s] and acceleration [m/s^2] limits (one value for
            every axis, or one per axis); ``v_max`` may be ``inf``.
        j_max: per-axis jerk limits [m/s^3]; ``None`` plans the second-order optimum (piecewise
            constant path acceleration), otherwise a jerk-limited motion (see
            :mod:`motionplc.planning.paths.topp_jerk`).
        v_path: limit of the path speed ``|dp/dt|`` [m/s], or ``None``.
        v_start, v_end: path speed ``|dp/dt|`` [m/s] at the start and the end.
        n_grid: number of grid intervals along ``u`` (default :data:`DEFAULT_GRID`); the
            second-order planner puts grid points on every break of the path's pieces and
            refines the grid where the path turns quickly or a limit would be exceeded
            between grid points.
        stops: ``"allow"`` (default): the path is passed at rest wherever its tangent jumps
            (an unblended corner, a reversal, a junction where one side has a zero tangent);
            ``"forbid"``: such a point is a :class:`PlanningError` naming its ``u`` and
            position.

    Returns:
        An immutable :class:`PathTrajectory`. Every velocity, acceleration (and jerk) limit holds
        everywhere along it, not only at grid points (checked on sub-intervals with a
        conservative bound at construction; see the module docstring).

    Raises:
        PlanningError: naming the field and the allowed range for bad input, a start speed above
            what the path allows, or an end speed that cannot be reached.
    """
    lim, vs, ve, n = _validate(path, v_max, a_max, j_max, v_path, v_start, v_end, n_grid)
    if stops not in ("allow", "forbid"):
        raise PlanningError(f"stops: must be 'allow' or 'forbid', got {stops!r}")
    chain = Chain(path)
    found = _stops_of(chain, stops)
    if lim.j_max is not None:
        from motionplc.planning.paths.topp_jerk import plan_jerk_limited

        if not found:
            return plan_jerk_limited(path, lim, vs, ve, n)
        # exact stops: every part between two of them is planned from and to rest
        cuts = [0, *(j.index for j in found), chain.n_pieces]
        parts, offsets = [], []
        for k in range(len(cuts) - 1):
            sub = SubPath(chain, cuts[k], cuts[k + 1])
            n_k = min(n, max(_MIN_PART_GRID, round(n * sub.u_end / chain.u_end)))
            v0 = vs if k == 0 else 0.0
            v1 = ve if k == len(cuts) - 2 else 0.0
            parts.append(plan_jerk_limited(sub, lim, v0, v1, n_k))
            offsets.append(float(chain.u0[cuts[k]]))
        return _concat(parts, path, offsets)
    u, x, mvc, info = _solve_on_pieces(chain, lim, vs, ve, n, {j.index for j in found})
    info["stops"] = float(len(found))
    h = np.diff(u)
    law = _law_second_order(x, h, float(path.u_end), u[:-1])
    return PathTrajectory(
        path, law, 2, u, np.sqrt(x), np.sqrt(np.maximum(mvc, 0.0)), law.duration, info
    )
