"""The fallback of the jerk-limited planner: a smoothed second-order law (the planner of
motionplc before the third-order parameterisation of :mod:`topp_jerk`, kept unchanged as the
last resort when that one finds no solution; symmetric limits only).

Method: a
second-order time-optimal *base* law ``u_b(t)`` (see :mod:`motionplc.planning.paths.topp`)
under tightened limits, smoothed by a moving average of length ``T_f`` in time::

    u(t) = 1/T_f * integral_{t - T_f}^{t} u_b(s) ds

(the FIR jerk limiter of CNC interpolators, applied to the path parameter, so the path itself
is followed exactly). The base law is piecewise quadratic, so ``u`` is piecewise cubic with
``d3u/dt3 = (d2u_b(t) - d2u_b(t - T_f)) / T_f``: path jerk bounded, ``d2u/dt2`` continuous. Each
axis's jerk ``q' dddu + 3 q'' du ddu + q''' du^3`` is then checked on every piece (conservative
bound, as in the second-order planner); where a limit is exceeded, the base law is tightened
locally (lower path speed, lower path acceleration over the window that produced the sample)
and solved again. A few filter lengths around ``max(a_max / j_max)`` are tried and the fastest
feasible result is kept; it is never faster than the second-order optimum, and the result
reports that optimum (``second_order_duration``). The moving average is not time-optimal for
the third-order problem; it is a feasible, smooth, fast construction.

A non-zero start (end) speed is kept constant for ``T_f / 2`` at the start (end) of the base
law, so that the smoothed law starts (ends) exactly at that speed with zero path acceleration:
the base problem is solved only between those holds (whole grid intervals), from the start
speed to the end speed, and tightening never caps the speed below a boundary speed within one
filter length of its hold (there only the path acceleration is tightened).
"""

from __future__ import annotations

import math

import numpy as np

from motionplc.errors import PlanningError
from motionplc.planning.paths.base import Path
from motionplc.planning.paths.topp import (
    PathLimits,
    _boundary_x,
    _evaluate_grid,
    _Grid,
    _law_second_order,
    solve_second_order,
)
from motionplc.planning.paths.trajectory import PathTrajectory, SpeedLaw

__all__ = ["plan_filtered"]

_FILTER_FACTORS = (0.5, 1.0, 2.0)
_MAX_ITER = 10
_SUB = 8
_ACCEPT = 1e-9


class _Base:
    """The base law as arrays, evaluable at any (also negative or late) time."""

    def __init__(self, law: SpeedLaw, u_end: float, s_start: float, s_end: float) -> None:
        self.t = np.append(law.t, law.duration)
        self.u = law.u
        self.s = law.du
        self.a = law.ddu
        self.te = law.duration
        self.u_end = u_end
        d = np.diff(self.t)
        self.se = s_end  # exact boundary speeds (the pieces reproduce them up to rounding)
        self.s0 = s_start
        piece = self.u * d + self.s * d**2 / 2.0 + self.a * d**3 / 6.0
        self.F = np.concatenate([[0.0], np.cumsum(piece)])

    def eval(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """(F, u, du, ddu) at base times ``t`` (F: integral of u from 0)."""
        te = self.te
        tc = np.clip(t, 0.0, te)
        i = np.clip(np.searchsorted(self.t, tc, side="right") - 1, 0, len(self.u) - 1)
        dt = tc - self.t[i]
        u0, s0, a0 = self.u[i], self.s[i], self.a[i]
        F = self.F[i] + dt * (u0 + dt * (s0 / 2.0 + dt * a0 / 6.0))
        u = u0 + dt * (s0 + dt * a0 / 2.0)
        s = s0 + dt * a0
        a = a0.copy()
        before = t < 0.0
        after = t > te
        tb = np.where(before, t, 0.0)
        F = np.where(before, self.s0 * tb**2 / 2.0, F)
        u = np.where(before, self.s0 * tb, u)
        s = np.where(before, self.s0, s)
        a = np.where(before, 0.0, a)
        ta = np.where(after, t - te, 0.0)
        F = np.where(after, self.F[-1] + self.u_end * ta + self.se * ta**2 / 2.0, F)
        u = np.where(after, self.u_end + self.se * ta, u)
        s = np.where(after, self.se, s)
        a = np.where(after, 0.0, a)
        return F, u, s, a


def _filtered(base: _Base, tf: float) -> SpeedLaw:
    ts = tf / 2.0 if base.s0 > 0.0 else 0.0
    t_stop = base.te + tf - (tf / 2.0 if base.se > 0.0 else 0.0)
    bp = np.concatenate([base.t, base.t + tf, [ts, t_stop]])
    bp = np.unique(bp[(bp >= ts) & (bp <= t_stop)])
    keep = np.concatenate([[True], np.diff(bp) > 1e-12 * max(t_stop, 1e-300)])
    bp = bp[keep]
    if bp[-1] < t_stop:
        bp = np.append(bp, t_stop)
    bp[-1] = t_stop
    starts = bp[:-1]
    mid = 0.5 * (bp[:-1] + bp[1:])
    F1, u1, s1, a1 = base.eval(starts)
    F0, u0, s0, a0 = base.eval(starts - tf)
    _, _, _, am1 = base.eval(mid)
    _, _, _, am0 = base.eval(mid - tf)
    uf = (F1 - F0) / tf
    sf = (u1 - u0) / tf
    af = (s1 - s0) / tf
    jf = (am1 - am0) / tf
    return SpeedLaw(starts - ts, uf, sf, af, jf, t_stop - ts, base.u_end)


def _check(path: Path, law: SpeedLaw, lim: PathLimits, jm: np.ndarray):
    """Per piece and sample, the worst ratio of each kind; returns (worst speed ratio, worst
    acceleration ratio, worst jerk ratio) per piece (conservative) and the piece start times."""
    n = len(law.t)
    ends = np.append(law.t[1:], law.duration)
    th = np.arange(_SUB + 1) / _SUB
    ts = law.t[:, None] + th[None, :] * (ends - law.t)[:, None]
    u, du, ddu, dddu = law.evaluate(ts.ravel())
    # pieces have constant jerk: use that piece's own jerk also at its end point
    dddu = np.repeat(law.dddu, _SUB + 1)
    q1, q2, q3 = (path.evaluate(u, k) for k in (1, 2, 3))
    du_ = du[:, None]
    ddu_ = ddu[:, None]
    v = (q1 * du_).reshape(n, _SUB + 1, -1)
    a = (q1 * ddu_ + q2 * du_**2).reshape(n, _SUB + 1, -1)
    j = (q1 * dddu[:, None] + 3.0 * q2 * du_ * ddu_ + q3 * du_**3).reshape(n, _SUB + 1, -1)

    def bound(f: np.ndarray, limit: np.ndarray) -> np.ndarray:
        d2 = np.abs(np.diff(f, 2, axis=1)).max(axis=1) * 0.25
        hi = f.max(axis=1) + d2
        lo = f.min(axis=1) - d2
        with np.errstate(divide="ignore", invalid="ignore"):
            r = np.maximum(hi, -lo) / limit[None, :]
        return np.nan_to_num(r, nan=0.0).max(axis=1)

    rv = bound(v, lim.v_max)
    if math.isfinite(lim.v_path):
        sp = np.sqrt(np.einsum("ijk,ijk->ij", v, v))[:, :, None]
        rv = np.maximum(rv, bound(sp, np.array([lim.v_path])))
    ra = bound(a, lim.a_max)
    rj = bound(j, jm)
    return rv, ra, rj


def _window_mask(grid: _Grid, base: _Base, law: SpeedLaw, pieces: np.ndarray, tf: float):
    """Half-grid points and intervals whose base motion fed the given output pieces."""
    ts = base.s0 > 0.0 and tf / 2.0 or 0.0
    t1 = np.append(law.t[1:], law.duration)[pieces] + ts
    t0 = law.t[pieces] + ts - tf
    _, ua, _, _ = base.eval(t0)
    _, ub, _, _ = base.eval(t1)
    u = grid.u
    h = grid.h
    mask = np.zeros(len(u), dtype=bool)
    lo = np.searchsorted(u, ua - h, side="left")
    hi = np.searchsorted(u, ub + h, side="right")
    diff = np.zeros(len(u) + 1, dtype=int)
    np.add.at(diff, lo, 1)
    np.add.at(diff, hi, -1)
    mask = np.cumsum(diff[:-1]) > 0
    imask = mask[0:-1:2] | mask[1::2] | mask[2::2]
    return mask, imask


def plan_filtered(path: Path, lim: PathLimits, vs: float, ve: float, n: int) -> PathTrajectory:
    """Jerk-limited motion along ``path`` (validated limits; see the module docstring)."""
    jm = lim.j_max
    assert jm is not None
    grid = _evaluate_grid(path, n)
    x0 = _boundary_x("v_start", vs, grid, 0)
    xe = _boundary_x("v_end", ve, grid, 2 * n)
    dim = grid.q1.shape[1]
    sol2, _, _ = solve_second_order(path, lim, x0, xe, n, grid)
    law2 = _law_second_order(sol2.x, grid.h, float(path.u_end))
    t2 = law2.duration
    # speed cap from the curvature term of the jerk (q''' du^3 alone within the limit)
    q3 = np.asarray(path.evaluate(grid.u, 3), dtype=float).reshape(len(grid.u), -1)
    with np.errstate(divide="ignore"):
        jcap = ((jm[None, :] / np.abs(q3)) ** (2.0 / 3.0)).min(axis=1)
    # the start/end speeds must be admissible for the jerk at constant speed
    for name, x, k in (("v_start", x0, 0), ("v_end", xe, 2 * n)):
        if x > jcap[k]:
            allowed = math.sqrt(jcap[k] * grid.speed2[k])
            raise PlanningError(
                f"{name}: above what the jerk limits allow at the path's "
                f"{'start' if k == 0 else 'end'}; allowed [0, {allowed!r}]"
            )
    tau0 = float(np.max(lim.a_max / jm))
    best: tuple[float, SpeedLaw, np.ndarray, float] | None = None
    tried = 0
    for fac in _FILTER_FACTORS:
        tf = fac * tau0
        cap = jcap.copy()
        # the base law holds the boundary speeds for tf/2 on whole grid intervals; the
        # second-order problem is solved between those holds (span)
        i0 = math.ceil((math.sqrt(x0) * tf / 2.0) / grid.h * (1.0 + 1e-12)) if x0 > 0.0 else 0
        i1 = n - math.ceil((math.sqrt(xe) * tf / 2.0) / grid.h * (1.0 + 1e-12)) if xe > 0.0 else n
        if not 0 <= i0 < i1 <= n:
            continue  # the path is too short to hold the boundary speeds this long
        acc_scale = np.ones((n, dim))
        for _ in range(_MAX_ITER):
            tried += 1
            try:
                sol, _, _ = solve_second_order(
                    path, lim, x0, xe, n, grid, extra_cap=cap, acc_scale=acc_scale, span=(i0, i1)
                )
            except PlanningError:
                break
            blaw = _law_second_order(sol.x, grid.h, float(path.u_end))
            base = _Base(blaw, float(path.u_end), math.sqrt(x0), math.sqrt(xe))
            if (x0 > 0.0 and not _holds(base, tf / 2.0, start=True)) or (
                xe > 0.0 and not _holds(base, tf / 2.0, start=False)
            ):
                break
            law = _filtered(base, tf)
            if best is not None and law.duration >= best[0]:
                break  # tightening only slows it down further
            rv, ra, rj = _check(path, law, lim, jm)
            worst = max(rv.max(), ra.max(), rj.max())
            if worst <= 1.0 + _ACCEPT:
                best = (law.duration, law, sol.x, tf)
                break
            bad = np.flatnonzero(np.maximum(np.maximum(rv, ra), rj) > 1.0 + _ACCEPT)
            # tighten over the windows that fed the bad pieces, by twice the excess
            xb = np.interp(grid.u, grid.u[::2], sol.x)
            for kind, r in (("v", rv), ("a", ra), ("j", rj)):
                sel = bad[r[bad] > 1.0 + _ACCEPT]
                if not len(sel):
                    continue
                f = float(r[sel].max())
                mask, imask = _window_mask(grid, base, law, sel, tf)
                g = 1.0 / (2.0 * f - 1.0)
                if kind == "v":
                    cap[mask] = np.minimum(cap[mask], xb[mask] * g * g)
                elif kind == "a":
                    cap[mask] = np.minimum(cap[mask], xb[mask] * g)
                    acc_scale[imask] *= g
                else:
                    acc_scale[imask] *= g
                    cap[mask] = np.minimum(cap[mask], xb[mask] * g ** (2.0 / 3.0))
            # the spans' ends keep their boundary speeds (violations there are fixed elsewhere)
            # and for one filter length beyond them (a speed cap below the boundary speed
            # right after a hold would ask for an instant brake; there only the path
            # acceleration is tightened)
            if x0 > 0.0:
                near = grid.u <= grid.u[2 * i0] + math.sqrt(x0) * tf
                cap[near] = np.maximum(cap[near], x0)
            if xe > 0.0:
                near = grid.u >= grid.u[2 * i1] - math.sqrt(xe) * tf
                cap[near] = np.maximum(cap[near], xe)
    # a simple feasible candidate: a 1-D jerk-limited profile of u under constant limits that
    # give every term of the chain rule its share (kept when it passes the same check)
    ref = _reference_law(path, grid, lim, jm, math.sqrt(x0), math.sqrt(xe))
    if ref is not None and (best is None or ref.duration < best[0]):
        rv, ra, rj = _check(path, ref, lim, jm)
        if max(rv.max(), ra.max(), rj.max()) <= 1.0 + _ACCEPT:
            xs = np.interp(grid.u[::2], *ref.evaluate(np.linspace(0, ref.duration, 4 * n))[:2])
            best = (ref.duration, ref, xs**2, 0.0)
    if best is None:
        raise PlanningError(
            "j_max: no jerk-limited motion found along this path within the limits "
            f"(tried {tried} base profiles); allowed: larger j_max or a finer n_grid"
        )
    dur, law, xb, tf = best
    info = {"filter_time": tf, "base_solves": float(tried), "second_order_duration": t2}
    return PathTrajectory(
        path, law, 3, grid.u[::2], np.sqrt(xb), np.sqrt(np.maximum(sol2.mvc, 0.0)), t2, info
    )


def _reference_law(
    path: Path, grid: _Grid, lim: PathLimits, jm: np.ndarray, s0: float, se: float
) -> SpeedLaw | None:
    from motionplc.planning import Limits, State, plan

    g1, g2 = np.abs(grid.q1).max(axis=0), np.abs(grid.q2).max(axis=0)
    g3 = np.abs(np.asarray(path.evaluate(grid.u, 3), dtype=float)).max(axis=0)
    with np.errstate(divide="ignore"):
        sig = min(
            float(np.min(lim.v_max / g1)),
            float(np.min(np.sqrt(lim.a_max / (2 * g2)))),
            float(np.min((jm / (3 * g3)) ** (1 / 3))),
        )
        if math.isfinite(lim.v_path):
            sig = min(sig, lim.v_path / math.sqrt(float(grid.speed2.max())))
        acc = min(float(np.min(lim.a_max / (2 * g1))), float(np.min(jm / (9 * g2 * sig))))
        jrk = float(np.min(jm / (3 * g1)))
    if not (0 < sig < math.inf and 0 < acc < math.inf and 0 < jrk < math.inf):
        return None
    if s0 > sig or se > sig:
        return None
    try:
        prof = plan(
            State(0.0, s0), State(float(path.u_end), se), Limits(v_max=sig, a_max=acc, j_max=jrk)
        )
    except Exception:  # noqa: BLE001 - the reference is optional
        return None
    k = prof.knots
    if not k:
        return None
    arr = np.array([[kn.t, kn.p, kn.v, kn.a, kn.j] for kn in k])
    return SpeedLaw(*arr.T, prof.duration, float(path.u_end))


def _holds(base: _Base, t_hold: float, start: bool) -> bool:
    """Whether the base law keeps its boundary speed (zero path acceleration) for ``t_hold``."""
    if start:
        sel = base.t[:-1] < t_hold
    else:
        sel = base.t[1:] > base.te - t_hold
    return bool(np.all(np.abs(base.a[sel]) <= 1e-9 * max(1.0, float(np.abs(base.a).max()))))
