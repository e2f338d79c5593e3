"""The numerical core of the third-order (jerk-limited) path parameterisation.

See :mod:`motionplc.planning.paths.topp_jerk` for the method and what is proven. This module
holds the pieces: the model of ``x(u) = du^2`` as a uniform quadratic B-spline on the grid
(:class:`Model`, constraint rows per grid interval), a banded primal-dual interior-point solver
for ``min sum w_k x_k^-1/2`` under those linear rows (:func:`solve_ipm`), the exact time law
through the node states (:func:`law_from_nodes`, two constant-jerk pieces per interval) and
its dense check (:func:`check_law`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.linalg.lapack import dpbtrf, dpbtrs

from motionplc.planning.paths.base import Path
from motionplc.planning.paths.trajectory import SpeedLaw

REST_INTERVALS = 1

# uniform quadratic B-spline basis on one interval, at the check points theta
THETA = np.array([0.0, 0.5, 1.0])


def _basis(th: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Values and first derivatives (per unit theta) of the three basis functions."""
    b = np.stack([(1.0 - th) ** 2 / 2.0, (-2.0 * th**2 + 2.0 * th + 1.0) / 2.0, th**2 / 2.0], -1)
    d = np.stack([-(1.0 - th), 1.0 - 2.0 * th, th], -1)
    return b, d


BETA, DBETA = _basis(THETA)  # (3 points, 3 slots)
DDBETA = np.array([1.0, -2.0, 1.0])


@dataclass(frozen=True, slots=True)
class Limits3:
    """Per-axis limits, positive and negative side as positive magnitudes (arrays (dim,))."""

    v_hi: np.ndarray
    v_lo: np.ndarray
    a_hi: np.ndarray
    a_lo: np.ndarray
    j_hi: np.ndarray
    j_lo: np.ndarray
    v_path: float


@dataclass(frozen=True, slots=True)
class Boundary:
    """Boundary state of the path parameter: ``x = du^2`` and ``ddu`` at the start and end."""

    x0: float
    a0: float
    xe: float
    ae: float

    @property
    def rest_start(self) -> bool:
        return self.x0 == 0.0 and self.a0 == 0.0

    @property
    def rest_end(self) -> bool:
        return self.xe == 0.0 and self.ae == 0.0


class Model:
    """The path's derivatives at the check points of every interval and the linear rows that do
    not depend on the linearisation (velocity, acceleration, positivity)."""

    def __init__(self, path: Path, n: int, lim: Limits3, bnd: Boundary) -> None:
        u_end = float(path.u_end)
        self.n = n
        self.h = u_end / n
        self.lim = lim
        self.bnd = bnd
        u = np.linspace(0.0, u_end, 2 * n + 1)
        idx = 2 * np.arange(n)[:, None] + np.arange(3)[None, :]  # (n, 3 points)
        qs = [np.asarray(path.evaluate(u, k), dtype=float).reshape(len(u), -1) for k in (1, 2, 3)]
        for k, q in enumerate(qs, 1):
            if not np.all(np.isfinite(q)):
                raise ValueError(f"derivative {k} not finite")
        self.u = u
        self.q1, self.q2, self.q3 = (q[idx] for q in qs)  # (n, 3, dim)
        self.dim = self.q1.shape[2]
        self.scale_acc = np.ones((n, self.dim))
        self.scale_jerk = np.ones((n, self.dim))
        self.scale_vel = np.ones(n)
        # intervals of the constant-jerk start / stop from / to rest (the solution grows like
        # u^(4/3) there, which the quadratic model does not follow)
        self.m = max(1, min(REST_INTERVALS, (n - 2) // 6))
        if (bnd.rest_start or bnd.rest_end) and n < 2 * self.m + 2:
            raise ValueError("grid too coarse for the constant-jerk start/stop")
        mm = 0.75 * self.m
        self.kappa = (mm - 0.5) / (mm + 0.5)  # c_m = kappa c_{m+1} makes x_m = 1.5 m h a_m
        # a small boundary speed (with zero path acceleration) behaves like rest: the quadratic
        # model could only leave it exponentially slowly (a_1 <= 6 x_0 / h). Its first (last)
        # interval gets the same shape, x_1 = x_0 + 1.5 h a_1 (one interval, m = 1)
        self.soft_start = self.soft_end = False
        if self.m == 1 and n >= 4:
            # (with a boundary acceleration that is zero up to rounding: the time law takes
            # the exact boundary state, the model's node acceleration is the free one)
            al = self.rest_amax(range(1), True)
            if bnd.x0 > 0.0 and abs(bnd.a0) <= 1e-9 * al:
                self.soft_start = bnd.x0 < 1.5 * self.h * al
            al = self.rest_amax(range(n - 1, n), False)
            if bnd.xe > 0.0 and abs(bnd.ae) <= 1e-9 * al:
                self.soft_end = bnd.xe < 1.5 * self.h * al
        self.special_start = bnd.rest_start or self.soft_start
        self.special_end = bnd.rest_end or self.soft_end

    # -- fixed and dependent coefficients ----------------------------------------------------

    def fixed(self) -> tuple[dict[int, float], dict[int, tuple[int, float, float]]]:
        """Coefficients fixed by the boundary state (or unused: those only the constant-jerk
        start/stop intervals see), and those tied to a free one (``c_g = f c_g2 + g0``)."""
        n, h, b, m = self.n, self.h, self.bnd, self.m
        fix: dict[int, float] = {}
        dep: dict[int, tuple[int, float, float]] = {}
        if self.special_start:
            fix.update({g: 0.0 for g in range(m)})
            dep[m] = (m + 1, self.kappa, (1.0 - self.kappa) * b.x0)
        else:
            fix[0] = b.x0 - h * b.a0
            fix[1] = b.x0 + h * b.a0
        if self.special_end:
            fix.update({g: 0.0 for g in range(n - m + 2, n + 2)})
            dep[n - m + 1] = (n - m, self.kappa, (1.0 - self.kappa) * b.xe)
        else:
            fix[n] = b.xe - h * b.ae
            fix[n + 1] = b.xe + h * b.ae
        return fix, dep

    def free_mask(self) -> np.ndarray:
        fix, dep = self.fixed()
        m = np.ones(self.n + 2, dtype=bool)
        m[list(fix) + list(dep)] = False
        return m

    def expand(self, c: np.ndarray) -> np.ndarray:
        """Fill fixed and dependent coefficients of ``c`` (a copy)."""
        c = c.copy()
        fix, dep = self.fixed()
        for g, v in fix.items():
            c[g] = v
        for g, (g2, f, g0) in dep.items():
            c[g] = f * c[g2] + g0
        return c

    def fold(self, G: np.ndarray, r: np.ndarray) -> None:
        """Fold fixed (into the right-hand side) and dependent coefficients (onto their free
        neighbour) of rows ``G`` (n, R, 3) ``<= r`` (n, R), in place."""
        fix, dep = self.fixed()
        n = self.n
        for g, v in fix.items():
            for k in range(max(0, g - 2), min(n, g + 1)):
                i = g - k
                r[k] -= G[k, :, i] * v
                G[k, :, i] = 0.0
        for g, (g2, f, g0) in dep.items():
            for k in range(max(0, g - 2), min(n, g + 1)):
                i, i2 = g - k, g2 - k
                if 0 <= i2 <= 2:
                    G[k, :, i2] += f * G[k, :, i]
                    r[k] -= G[k, :, i] * g0
                G[k, :, i] = 0.0

    # -- rows --------------------------------------------------------------------------------

    def rows(self, xr: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """All rows ``G c <= r`` per interval, the jerk rows linearised at ``xr`` ((n, 3) values
        of ``x`` at the check points): ``J / sqrt(x) >= J / sqrt(xr) * (3/2 - x / (2 xr))``."""
        n, h, lim = self.n, self.h, self.lim
        q1, q2, q3 = self.q1, self.q2, self.q3
        beta = BETA[None, :, None, :]  # (1, 3, 1, 3)
        dbeta = DBETA[None, :, None, :] / h
        ddbeta = DDBETA[None, None, None, :] / h**2
        Q1, Q2, Q3 = q1[..., None], q2[..., None], q3[..., None]  # (n, 3, dim, 1)
        GA = Q1 * dbeta / 2.0 + Q2 * beta  # axis acceleration (n, 3, dim, 3)
        GL = Q1 * ddbeta / 2.0 + 1.5 * Q2 * dbeta + Q3 * beta  # jerk / sqrt(x)
        sa, sj = self.scale_acc[:, None, :], self.scale_jerk[:, None, :]
        A_hi, A_lo = lim.a_hi * sa, lim.a_lo * sa  # (n, 1, dim)
        xr = np.maximum(xr, 1e-9 * float(np.max(xr)) + 1e-300)[:, :, None]  # (n, 3, 1)
        rs = 1.0 / np.sqrt(xr)
        Jh, Jl = lim.j_hi * sj, lim.j_lo * sj
        kap_h = (Jh * rs / (2.0 * xr))[..., None]
        kap_l = (Jl * rs / (2.0 * xr))[..., None]
        B = np.broadcast_to(beta, GA.shape)
        # velocity cap on x at the check points (n, 3)
        with np.errstate(divide="ignore", over="ignore"):
            vlim = np.where(q1 >= 0.0, lim.v_hi, lim.v_lo)
            cap = np.where(q1 == 0.0, np.inf, (vlim / np.abs(q1)) ** 2).min(axis=2)
            if math.isfinite(lim.v_path):
                sp2 = np.einsum("ijk,ijk->ij", q1, q1)
                cap = np.minimum(cap, np.where(sp2 > 0.0, lim.v_path**2 / sp2, np.inf))
        cap = cap * self.scale_vel[:, None]
        Gs = [
            GA,
            -GA,
            GL + kap_h * B,
            -GL + kap_l * B,
        ]
        rs_ = [
            np.broadcast_to(A_hi, GA.shape[:3]),
            np.broadcast_to(A_lo, GA.shape[:3]),
            np.broadcast_to(1.5 * Jh * rs, GA.shape[:3]),
            np.broadcast_to(1.5 * Jl * rs, GA.shape[:3]),
        ]
        G = np.concatenate([g.reshape(n, -1, 3) for g in Gs] + [BETA[None].repeat(n, 0)], axis=1)
        # x >= 0 at the middle; and the two-piece law exists (V^2 >= 4/3 h (a_1 - a_0), see
        # law_from_nodes), sufficiently as 4/3 h (a_1 - a_0) <= x_0 + x_1 (linear)
        law_row = np.array([[1.0 / 6.0, -7.0 / 3.0, 1.0 / 6.0]])
        G = np.concatenate([G, -BETA[None, 1:2].repeat(n, 0), law_row[None].repeat(n, 0)], axis=1)
        r = np.concatenate(
            [x.reshape(n, -1) for x in rs_] + [cap, np.zeros((n, 1)), np.zeros((n, 1))], axis=1
        )
        G = np.ascontiguousarray(G)
        r = np.ascontiguousarray(r, dtype=float)
        # constant-jerk start / stop intervals: a box on the acceleration at their inner node
        m = self.m
        if self.special_start:
            G[:m] = 0.0
            r[:m] = 1.0
            self._rest_rows(G, r, m - 1, 2, range(m))
        if self.special_end:
            G[n - m :] = 0.0
            r[n - m :] = 1.0
            self._rest_rows(G, r, n - m, 0, range(n - m, n))
        bad = ~np.isfinite(r)
        G[bad] = 0.0
        r[bad] = 1.0
        self.fold(G, r)
        return G, r

    def rest_amax(self, ints: range, start: bool) -> float:
        """Largest |ddu| at the inner node of a constant-jerk start (stop) over the intervals
        ``ints`` keeping every axis within its limits at their check points. With ``S`` their
        length and ``f`` the distance from the rest end over ``S``, the motion there is
        ``x = 1.5 S |ddu| f^(4/3)``, ``ddu = +-|ddu| f^(1/3)``, jerk of ``u`` ``|ddu|^1.5
        sqrt(1.5 S) / (3 S)``, so every axis value is ``|ddu|^k`` times a known coefficient."""
        lim = self.lim
        sl = slice(ints.start, ints.stop)
        q1, q2, q3 = self.q1[sl], self.q2[sl], self.q3[sl]  # (m, 3, dim)
        S = self.h * len(ints)
        k = np.arange(ints.start, ints.stop)[:, None] + THETA[None, :]
        f = (k * self.h / S if start else (self.n - k) * self.h / S)[:, :, None]
        sg = 1.0 if start else -1.0
        sa = self.scale_acc[sl].min(axis=0)
        sj = self.scale_jerk[sl].min(axis=0)
        c15 = math.sqrt(1.5 * S)
        cj = q1 * c15 / (3.0 * S) + sg * 3.0 * q2 * c15 * f + q3 * (1.5 * S) ** 1.5 * f**2
        ca = sg * q1 * np.cbrt(f) + q2 * 1.5 * S * f ** (4.0 / 3.0)
        cv2 = q1**2 * 1.5 * S * f ** (4.0 / 3.0)
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            jl = np.where(cj >= 0.0, lim.j_hi * sj, lim.j_lo * sj)
            al_j = np.where(cj != 0.0, (jl / np.abs(cj)) ** (2.0 / 3.0), np.inf)
            alim = np.where(ca >= 0.0, lim.a_hi * sa, lim.a_lo * sa)
            al_a = np.where(ca != 0.0, alim / np.abs(ca), np.inf)
            vl = np.where(q1 * sg >= 0.0, lim.v_hi, lim.v_lo) ** 2 * float(self.scale_vel[sl].min())
            al_v = np.where(cv2 > 0.0, vl / cv2, np.inf)
        out = float(min(al_j.min(), al_a.min(), al_v.min())) * (1.0 - 1e-6)
        if math.isfinite(lim.v_path):
            sp2 = (np.einsum("ijk,ijk->ij", q1, q1)[:, :, None] * 1.5 * S * f ** (4.0 / 3.0)).max()
            if sp2 > 0.0:
                out = min(out, lim.v_path**2 / float(sp2))
        return out

    def _rest_rows(self, G: np.ndarray, r: np.ndarray, k: int, slot: int, ints: range) -> None:
        """The box on |ddu| at the inner node of the constant-jerk start (stop), as rows of
        interval ``k`` on the free coefficient in ``slot``: |ddu| = (1 - kappa) c / (2 h)."""
        h = self.h
        x_b = self.bnd.x0 if slot == 2 else self.bnd.xe  # 0 at rest
        G[k, 0, slot] = (1.0 - self.kappa) / (2.0 * h)
        r[k, 0] = self.rest_amax(ints, slot == 2) + (1.0 - self.kappa) * x_b / (2.0 * h)
        G[k, 1, slot] = -1.0  # x >= 0 there
        r[k, 1] = 0.0

    # -- objective: sum_k w_k / sqrt(x_k) (trapezoid rule of the time), per interval ---------

    def objective_rows(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Node ``x`` as rows on the interval's coefficients: ``E`` (n, 2, 3), offsets (n, 2)
        and weights (n, 2) (slot 0: node k, slot 1: node k + 1, used by the last interval).

        The weights are the trapezoid rule of ``t = int du / sqrt(x)``; a constant-jerk start
        (stop) interval takes exactly ``3 h / v_1`` (from ``h = j T^3 / 6``, ``v_1 = j T^2 / 2``),
        given to its inner node. The boundary nodes are fixed (no weight)."""
        n, h = self.n, self.h
        wn = np.full(n + 1, h)
        wn[0] = wn[n] = 0.0
        m = self.m
        if self.special_start:  # from rest the start takes 3 m h / v_m (an upper bound else)
            wn[:m] = 0.0
            wn[m] = 0.5 * h + 3.0 * m * h
        if self.special_end:
            wn[n - m + 1 :] = 0.0
            wn[n - m] = 0.5 * h + 3.0 * m * h
        E = np.zeros((n, 2, 3))
        E[:, 0, 0] = E[:, 0, 1] = 0.5
        E[:, 1, 1] = E[:, 1, 2] = 0.5
        w = np.zeros((n, 2))
        w[:, 0] = wn[:-1]
        w[n - 1, 1] = wn[n]
        e0 = np.zeros((n, 2))
        self.fold(E, e0)
        return E, -e0, w  # x = E c + off

    def nodes(self, c: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Node states ``(x_k, ddu_k)`` of the (expanded) coefficients; on a constant-jerk
        start/stop ``x ~ u^(4/3)``, ``ddu ~ u^(1/3)`` from its inner node; the boundary
        states exact."""
        x = 0.5 * (c[:-1] + c[1:])
        a = (c[1:] - c[:-1]) / (2.0 * self.h)
        n, m, b = self.n, self.m, self.bnd
        if b.rest_start:
            f = np.arange(m) / m
            x[:m] = x[m] * f ** (4.0 / 3.0)
            a[:m] = a[m] * np.cbrt(f)
        if b.rest_end:
            f = (n - np.arange(n - m + 1, n + 1)) / m
            x[n - m + 1 :] = x[n - m] * f ** (4.0 / 3.0)
            a[n - m + 1 :] = a[n - m] * np.cbrt(f)
        x[0], a[0], x[-1], a[-1] = b.x0, b.a0, b.xe, b.ae
        return x, a

    def x_points(self, c: np.ndarray) -> np.ndarray:
        """``x`` at the check points (n, 3)."""
        tri = np.stack([c[:-2], c[1:-1], c[2:]], axis=1)  # (n, 3 slots)
        return tri @ BETA.T


def coefficients_from_nodes(x: np.ndarray) -> np.ndarray:
    """Quadratic B-spline coefficients whose node values approximate ``x`` (n + 1 nodes):
    ``c_k`` = x at the interval midpoints (``x_k = (c_k + c_{k+1}) / 2``)."""
    mid = 0.5 * (x[:-1] + x[1:])
    return np.concatenate([[x[0]], mid, [x[-1]]])


# -- the interior-point solver ---------------------------------------------------------------


@dataclass
class IpmResult:
    lam: np.ndarray
    c: np.ndarray
    iterations: int
    converged: bool
    mu: float
    primal_res: float


def _direction(fac, rd, rp, s, lam, rc, gmul, gtmul, notfree):
    """One Newton direction of the interior-point method from the factorised normal matrix."""
    rhs = -rd + gtmul((rc - lam * rp) / s)
    rhs[notfree] = 0.0
    dc, info = dpbtrs(fac, rhs)
    if info != 0:
        raise np.linalg.LinAlgError("banded solve failed")
    dc[notfree] = 0.0
    ds = -rp - gmul(dc)
    dl = (-rc - lam * ds) / s
    return dc, ds, dl


def solve_ipm(
    G: np.ndarray,
    r: np.ndarray,
    E: np.ndarray,
    off: np.ndarray,
    w: np.ndarray,
    free: np.ndarray,
    c0: np.ndarray,
    tol: float = 1e-9,
    max_iter: int = 60,
    gap: float = 1e-7,
) -> IpmResult:
    """``min sum w * (E c + off)^-1/2`` subject to ``G c <= r`` over the free coefficients.

    Mehrotra predictor-corrector primal-dual interior point method (infeasible start); the
    normal equations are pentadiagonal (every row touches three consecutive coefficients:
    ``G`` is (n, R, 3), ``E`` (n, 2, 3)) and are solved by a banded Cholesky factorisation,
    O(n R) per iteration. Row and variable scaling are the caller's.
    """
    n, R, _ = G.shape
    nc = n + 2
    m = n * R
    g0, g1, g2 = (np.ascontiguousarray(G[:, :, i]) for i in range(3))
    pairs = [(0, 0), (1, 1), (2, 2), (0, 1), (1, 2), (0, 2)]
    gl = (g0, g1, g2)
    gg = [gl[a] * gl[b] for a, b in pairs]
    e = [np.ascontiguousarray(E[:, :, i]) for i in range(3)]  # (n, 2)
    ee = [e[a] * e[b] for a, b in pairs]
    wpos = w > 0.0
    notfree = ~free

    def gmul(cv: np.ndarray) -> np.ndarray:
        return g0 * cv[:-2, None] + g1 * cv[1:-1, None] + g2 * cv[2:, None]

    def gtmul(y: np.ndarray) -> np.ndarray:
        out = np.zeros(nc)
        out[:-2] += np.einsum("nr,nr->n", g0, y)
        out[1:-1] += np.einsum("nr,nr->n", g1, y)
        out[2:] += np.einsum("nr,nr->n", g2, y)
        return out

    def xs(cv: np.ndarray) -> np.ndarray:
        return e[0] * cv[:-2, None] + e[1] * cv[1:-1, None] + e[2] * cv[2:, None] + off

    def band(Ms: list[np.ndarray]) -> np.ndarray:
        ab = np.zeros((3, nc))
        ab[2, :n] += Ms[0]
        ab[2, 1 : n + 1] += Ms[1]
        ab[2, 2:] += Ms[2]
        ab[1, 1 : n + 1] += Ms[3]
        ab[1, 2:] += Ms[4]
        ab[0, 2:] += Ms[5]
        return ab

    def step(v: np.ndarray, dv: np.ndarray) -> float:
        # the largest step <= 1 keeping v + step dv >= 0 (v > 0): 1 / max(-dv / v)
        t = float(np.max(-dv / v))
        return 1.0 if t <= 1.0 else 1.0 / t

    c = np.where(free, c0, 0.0)
    s = np.maximum(r - gmul(c), 1e-2)
    lam = 1e-2 / s
    it = 0
    converged = False
    mu = float(np.mean(s * lam))
    rp_norm = math.inf
    for it in range(1, max_iter + 1):  # noqa: B007 - the count is returned
        x = xs(c)
        xp = np.where(wpos, x, 1.0)
        f1 = np.where(wpos, -0.5 * w * xp**-1.5, 0.0)
        f2 = np.where(wpos, 0.75 * w * xp**-2.5, 0.0)
        grad = np.zeros(nc)
        grad[:-2] += np.einsum("nj,nj->n", f1, e[0])
        grad[1:-1] += np.einsum("nj,nj->n", f1, e[1])
        grad[2:] += np.einsum("nj,nj->n", f1, e[2])
        rd = grad + gtmul(lam)
        rd[notfree] = 0.0
        rp = gmul(c) + s - r
        mu = float(np.einsum("ij,ij->", s, lam)) / m
        rp_norm = float(np.abs(rp).max())
        rd_norm = float(np.abs(rd).max()) / (1.0 + float(np.abs(grad).max()))
        # primal feasibility, stationarity, and a duality gap m mu of ``gap`` of the (O(1))
        # objective: the duration to about that (below 1e-7 stalls on the conditioning)
        if rp_norm <= tol and mu * m <= gap and (rd_norm <= 1e-5 or mu * m <= 1e-3 * gap):
            converged = True
            break
        D = lam / s
        Ms = [np.einsum("nr,nr->n", D, gg[i]) + np.einsum("nj,nj->n", f2, ee[i]) for i in range(6)]
        ab = band(Ms)
        ab[2, notfree] = 1.0  # their rows and columns are zero (folded)
        ab[2] += 1e-14 * float(ab[2].max())
        fac, info = dpbtrf(ab, lower=0)
        if info != 0:
            break

        sl = s * lam
        dc, ds, dl = _direction(fac, rd, rp, s, lam, sl, gmul, gtmul, notfree)
        ap = step(s, ds)
        ad = step(lam, dl)
        mu_aff = float(np.einsum("ij,ij->", s + ap * ds, lam + ad * dl)) / m
        sigma = (mu_aff / mu) ** 3 if mu > 0 else 0.0
        rc = sl + ds * dl - sigma * mu
        dc, ds, dl = _direction(fac, rd, rp, s, lam, rc, gmul, gtmul, notfree)
        ap = 0.995 * step(s, ds)
        ad = 0.995 * step(lam, dl)
        dx = xs(dc) - off
        ax = step(np.where(wpos, x, 1.0), np.where(wpos, dx, 0.0))
        ap = min(ap, 0.995 * ax)
        c = c + ap * dc
        s = s + ap * ds
        lam = lam + ad * dl
    return IpmResult(lam, c, it, converged, mu, rp_norm)


# -- the time law through the node states ---------------------------------------------------


def law_from_nodes(u_nodes: np.ndarray, v: np.ndarray, a: np.ndarray, u_end: float) -> SpeedLaw:
    """The C2 speed law through the node states ``(u_k, du_k = v_k, ddu_k = a_k)``: two
    constant-jerk pieces of equal duration ``d`` per interval. With ``h`` the interval,
    ``V = v_k + v_{k+1}`` and ``Da = a_{k+1} - a_k`` the pieces match both node states iff
    ``h = V d - Da d^2 / 3`` (closed form; the smaller positive root). Raises ValueError when
    some interval has no such law (``V^2 < 4/3 Da h``)."""
    h = np.diff(u_nodes)
    V = v[:-1] + v[1:]
    da = a[1:] - a[:-1]
    disc = V * V - (4.0 / 3.0) * da * h
    disc = np.where((disc < 0.0) & (disc > -1e-12 * V * V), 0.0, disc)  # rounding
    if np.any(disc < 0.0) or np.any(~np.isfinite(disc)):
        raise ValueError("node states without a two-piece law")
    d = 2.0 * h / (V + np.sqrt(disc))
    if np.any(~(d > 0.0)) or np.any(~np.isfinite(d)):
        raise ValueError("non-positive piece duration")
    j1 = (v[1:] - v[:-1] - 2.0 * a[:-1] * d) / d**2 - da / (2.0 * d)
    j2 = da / d - j1
    um = u_nodes[:-1] + d * (v[:-1] + d * (a[:-1] / 2.0 + d * j1 / 6.0))
    vm = v[:-1] + d * (a[:-1] + d * j1 / 2.0)
    am = a[:-1] + d * j1
    n = len(h)
    t0 = np.concatenate([[0.0], np.cumsum(2.0 * d)])
    T = np.empty(2 * n)
    T[0::2] = t0[:-1]
    T[1::2] = t0[:-1] + d
    U = np.empty(2 * n)
    U[0::2] = u_nodes[:-1]
    U[1::2] = um
    DU = np.empty(2 * n)
    DU[0::2] = v[:-1]
    DU[1::2] = vm
    DDU = np.empty(2 * n)
    DDU[0::2] = a[:-1]
    DDU[1::2] = am
    J = np.empty(2 * n)
    J[0::2] = j1
    J[1::2] = j2
    return SpeedLaw(T, U, DU, DDU, J, float(t0[-1]), u_end)


def check_law(path: Path, law: SpeedLaw, lim: Limits3, sub: int = 8) -> dict[str, np.ndarray]:
    """Conservative worst ratios per piece (``v``, ``a``, ``j``; ``du`` the smallest path speed
    bound), from ``sub + 1`` samples per piece plus a quarter of the largest second difference
    (twice the interpolation error of a smooth function)."""
    n = len(law.t)
    ends = np.append(law.t[1:], law.duration)
    th = np.arange(sub + 1) / sub
    ts = law.t[:, None] + th[None, :] * (ends - law.t)[:, None]
    dt = ts - law.t[:, None]
    j0 = law.dddu[:, None]
    a0 = law.ddu[:, None]
    v0 = law.du[:, None]
    u = law.u[:, None] + dt * (v0 + dt * (a0 / 2.0 + dt * j0 / 6.0))
    du = v0 + dt * (a0 + dt * j0 / 2.0)
    ddu = a0 + dt * j0
    dddu = np.broadcast_to(j0, u.shape)
    uf = np.clip(u.ravel(), 0.0, float(path.u_end))
    q1, q2, q3 = (
        np.asarray(path.evaluate(uf, k), dtype=float).reshape(len(uf), -1) for k in (1, 2, 3)
    )
    d1 = du.ravel()[:, None]
    d2 = ddu.ravel()[:, None]
    d3 = dddu.ravel()[:, None]
    shape = (n, sub + 1, -1)
    v = (q1 * d1).reshape(shape)
    a = (q1 * d2 + q2 * d1**2).reshape(shape)
    j = (q1 * d3 + 3.0 * q2 * d1 * d2 + q3 * d1**3).reshape(shape)

    def bound(f: np.ndarray, hi: np.ndarray, lo: np.ndarray) -> np.ndarray:
        d2_ = np.abs(np.diff(f, 2, axis=1)).max(axis=1) * 0.25
        top = f.max(axis=1) + d2_
        bot = f.min(axis=1) - d2_
        with np.errstate(divide="ignore", invalid="ignore"):
            r = np.maximum(top / hi[None, :], -bot / lo[None, :])
        return np.nan_to_num(r, nan=0.0, posinf=np.inf).max(axis=1)

    out = {
        "v": bound(v, lim.v_hi, lim.v_lo),
        "a": bound(a, lim.a_hi, lim.a_lo),
        "j": bound(j, lim.j_hi, lim.j_lo),
    }
    if math.isfinite(lim.v_path):
        sp = np.sqrt(np.einsum("ijk,ijk->ij", v, v))[:, :, None]
        one = np.array([lim.v_path])
        out["v"] = np.maximum(out["v"], bound(sp, one, one))
    # du is quadratic in t on a piece: its exact minimum (ends, or the vertex inside)
    dur = ends - law.t
    lo = np.minimum(law.du, du[:, -1])
    with np.errstate(divide="ignore", invalid="ignore"):
        tv = -law.ddu / law.dddu
    inside = (law.dddu > 0.0) & (tv > 0.0) & (tv < dur)
    vert = law.du - law.ddu**2 / (2.0 * np.where(inside, law.dddu, 1.0))
    out["du"] = np.where(inside, np.minimum(lo, vert), lo)
    return out
