"""Interpolating clamped B-splines (seed 000 §4.6) and their deviation from a reference path
(seed 000 §4.10), implemented with numpy only.

* :class:`BSplinePath` — ``C(u) = sum_i N_{i,p}(u) P_i`` on ``u in [0, 1]`` with a clamped knot
  vector (first and last ``p + 1`` knots equal to 0 and 1), degree ``p`` in {3, 5}. The basis
  functions and their derivatives come from the Cox–de Boor recursion (Piegl & Tiller's
  ``DersBasisFuns``, 0/0 := 0, the last span owns ``u = 1``), vectorised over ``u``; at
  construction each knot span is converted to a polynomial, so evaluation (orders 0..3) is one
  ``searchsorted`` plus Horner's scheme. :meth:`BSplinePath.interpolate` solves the global
  interpolation system (4.2.7) ``[N_{j,p}(h_i)] P = Q``. The parameters ``h_i`` are the
  normalised cumulative chord lengths by default (``"centripetal"``: square roots of the
  chords, ``"uniform"``, or given), the interior knots are the averages of ``p`` consecutive
  ``h_i`` (de Boor / Piegl & Tiller (9.8)), which keeps the system non-singular
  (Schoenberg–Whitney). The seed's choices are not stated ("non-uniform depending on the point
  distances" is suggested); these are documented here. Consecutive duplicate points are dropped
  (as in :class:`~motionplc.planning.paths.hermite.HermitePath`); degree 3 needs >= 4 distinct
  points and degree 5 >= 6 (the interpolant needs ``n >= p + 1`` points; fewer is a
  PlanningError, not a silent lower degree). Arc length: the adaptive Gauss–Legendre table of
  :mod:`~motionplc.planning.paths.arclength` over the knot spans (also split where the speed
  has a (near-)zero, a kink of ``|C'|``).
* :func:`deviation` — the true largest distance of a curve from a reference path, for any two
  :class:`~motionplc.planning.paths.base.Path` objects: ``max_u min_v |C(u) - R(v)|`` (a
  one-sided Hausdorff distance; the seed's index-matched ``|B_k - Q_k|`` is not a distance
  between the curves). The nearest reference point of every curve sample is found on a dense
  reference grid and refined by golden-section search on ``v``; the largest distances (the
  largest of every interval between ``breaks`` and the largest local maxima) are refined by
  golden-section search on ``u`` around their samples.
* :func:`fit_bspline` — the seed's compensation loop: interpolate passing points taken on the
  reference, measure the deviation, insert the reference point nearest to the worst spline
  point (``mode="global"``, the seed's function 1) or one per interval between passing points
  whose deviation exceeds the tolerance (``mode="per_segment"``, function 2), re-fit, until the
  deviation is at most ``tolerance``; returns a :class:`BSplineFit` with the points added, the
  iterations and the deviation history.

Everything is immutable; bad input raises :class:`~motionplc.errors.PlanningError` naming the
field and the allowed range.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Literal

import numpy as np

from motionplc.errors import PlanningError
from motionplc.planning.paths._ppoly import (
    PiecewisePoly,
    check_int,
    check_order,
    check_points,
    check_scalar,
    drop_duplicates,
    param_1d,
)
from motionplc.planning.paths.arclength import ArcLengthTable, TabulatedCurve
from motionplc.planning.paths.base import Path

__all__ = ["BSplineFit", "BSplinePath", "Deviation", "deviation", "fit_bspline"]

ArrayLike = Sequence[float] | Sequence[Sequence[float]] | np.ndarray
Parametrization = Literal["chord", "centripetal", "uniform"]

DEGREES = (3, 5)
_INVPHI = (math.sqrt(5.0) - 1.0) / 2.0


def _check_degree(degree: object) -> int:
    if (
        isinstance(degree, bool)
        or not isinstance(degree, int | np.integer)
        or degree not in DEGREES
    ):
        raise PlanningError(f"degree: must be 3 or 5, got {degree!r}")
    return int(degree)


def _find_span(knots: np.ndarray, p: int, n_ctrl: int, u: np.ndarray) -> np.ndarray:
    """Knot span index ``i`` with ``knots[i] <= u < knots[i+1]`` (the last span owns u_end)."""
    return np.clip(np.searchsorted(knots, u, side="right") - 1, p, n_ctrl - 1)


def _ders_basis(knots: np.ndarray, p: int, span: np.ndarray, u: np.ndarray, nd: int) -> np.ndarray:
    """Non-zero basis functions and derivatives: shape ``(nd + 1, len(u), p + 1)``.

    ``out[k, m, j]`` is the k-th derivative of ``N_{span[m]-p+j, p}`` at ``u[m]`` (Piegl &
    Tiller, algorithm A2.3, vectorised over ``u``; all knot differences used are positive
    because every span is non-empty).
    """
    M = u.size
    ndu = np.zeros((p + 1, p + 1, M))
    ndu[0, 0] = 1.0
    left = np.zeros((p + 1, M))
    right = np.zeros((p + 1, M))
    for j in range(1, p + 1):
        left[j] = u - knots[span + 1 - j]
        right[j] = knots[span + j] - u
        saved = np.zeros(M)
        for r in range(j):
            ndu[j, r] = right[r + 1] + left[j - r]
            temp = ndu[r, j - 1] / ndu[j, r]
            ndu[r, j] = saved + right[r + 1] * temp
            saved = left[j - r] * temp
        ndu[j, j] = saved
    ders = np.zeros((nd + 1, M, p + 1))
    ders[0] = ndu[:, p].T
    a = np.zeros((2, p + 1, M))
    for r in range(p + 1):
        s1, s2 = 0, 1
        a[:] = 0.0
        a[0, 0] = 1.0
        for k in range(1, nd + 1):
            d = np.zeros(M)
            rk, pk = r - k, p - k
            if r >= k:
                a[s2, 0] = a[s1, 0] / ndu[pk + 1, rk]
                d = a[s2, 0] * ndu[rk, pk]
            j1 = 1 if rk >= -1 else -rk
            j2 = k - 1 if r - 1 <= pk else p - r
            for j in range(j1, j2 + 1):
                a[s2, j] = (a[s1, j] - a[s1, j - 1]) / ndu[pk + 1, rk + j]
                d = d + a[s2, j] * ndu[rk + j, pk]
            if r <= pk:
                a[s2, k] = -a[s1, k - 1] / ndu[pk + 1, r]
                d = d + a[s2, k] * ndu[r, pk]
            ders[k, :, r] = d
            s1, s2 = s2, s1
    fac = float(p)
    for k in range(1, nd + 1):
        ders[k] *= fac
        fac *= p - k
    return ders


def _check_knots(knots: object, p: int, n_ctrl: int) -> np.ndarray:
    U = np.array(knots, dtype=float).reshape(-1)
    need = n_ctrl + p + 1
    if U.size != need:
        raise PlanningError(
            f"knots: must have len(control_points) + degree + 1 = {need} entries, got {U.size}"
        )
    if not np.all(np.isfinite(U)) or np.any(np.diff(U) < 0):
        raise PlanningError("knots: must be finite and non-decreasing")
    if not (np.all(U[: p + 1] == 0.0) and np.all(U[-p - 1 :] == U[-1]) and U[-1] > 0.0):
        raise PlanningError(
            f"knots: must be clamped: the first {p + 1} equal to 0, the last {p + 1} equal to "
            f"the end value (> 0), got {U.tolist()!r}"
        )
    inner = U[p + 1 : -p - 1]
    if inner.size and (inner.min() <= 0.0 or inner.max() >= U[-1]):
        raise PlanningError("knots: interior knots must lie strictly inside (0, end)")
    _, counts = np.unique(inner, return_counts=True)
    if counts.size and counts.max() > p:
        raise PlanningError(f"knots: interior knot multiplicity must be <= degree ({p})")
    return U


class BSplinePath(TabulatedCurve):
    """A clamped B-spline curve of degree 3 or 5 in R^dim; immutable.

    Guarantees: ``evaluate(u, k)`` is the exact k-th derivative (0..3) of ``sum N_{i,p}(u) P_i``
    (up to rounding), C^{p-1} across simple interior knots; ``C(0) = P_0``, ``C(u_end) =
    P_last`` (clamped); splines from :meth:`interpolate` pass through their points at
    :attr:`point_params`; arc length from the adaptive table (estimated error <= ``rtol *
    length``).
    """

    __slots__ = (
        "knots",
        "control_points",
        "degree",
        "points",
        "point_params",
        "source_index",
        "_poly",
        "_table",
    )

    knots: np.ndarray
    control_points: np.ndarray
    degree: int
    points: np.ndarray | None
    point_params: np.ndarray | None
    source_index: np.ndarray | None
    _poly: PiecewisePoly
    _table: ArcLengthTable

    def __init__(
        self,
        knots: ArrayLike,
        control_points: ArrayLike,
        degree: int = 3,
        *,
        rtol: float = 1e-10,
        _data: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None,
    ) -> None:
        """A B-spline from its clamped ``knots`` and ``control_points`` (``(n, dim)``).

        ``len(knots) == n + degree + 1``; the knots start at 0 (``u_end`` is the last knot).
        """
        p = _check_degree(degree)
        P = check_points("control_points", control_points, min_count=p + 1)
        U = _check_knots(knots, p, len(P))
        spans = np.flatnonzero(np.diff(U) > 0)
        ders = _ders_basis(U, p, spans, U[spans], p)  # (p+1, S, p+1)
        idx = spans[:, None] - p + np.arange(p + 1)[None, :]  # (S, p+1)
        ctrl = P[idx]  # (S, p+1, dim)
        coeffs = np.einsum("ksj,sjd->skd", ders, ctrl)
        coeffs /= np.array([math.factorial(k) for k in range(p + 1)])[None, :, None]
        breaks = np.concatenate((U[spans], [U[-1]]))
        poly, table = self._tabulate(breaks, coeffs, rtol)
        pts, h, src = _data if _data is not None else (None, None, None)
        self._freeze(
            knots=U,
            control_points=P,
            degree=p,
            points=pts,
            point_params=h,
            source_index=src,
            _poly=poly,
            _table=table,
        )

    @classmethod
    def interpolate(
        cls,
        points: ArrayLike,
        degree: int = 3,
        *,
        params: ArrayLike | None = None,
        parametrization: Parametrization = "chord",
        rtol: float = 1e-10,
    ) -> BSplinePath:
        """The clamped B-spline of ``degree`` (3 or 5) through ``points`` (``(n, dim)``).

        ``params``: the parameters ``h_i`` of the (distinct) points, strictly increasing from
        0 to 1 (default: from ``parametrization``). Raises PlanningError for NaN, mismatched
        dimensions, a degree not in {3, 5} or too few distinct points.
        """
        p = _check_degree(degree)
        Q = check_points("points", points, min_count=2)
        Q, src = drop_duplicates(Q)
        if len(Q) < p + 1:
            raise PlanningError(
                f"points: degree {p} needs at least {p + 1} distinct points, got {len(Q)}"
            )
        if params is None:
            chords = np.linalg.norm(np.diff(Q, axis=0), axis=1)
            if parametrization == "chord":
                steps = chords
            elif parametrization == "centripetal":
                steps = np.sqrt(chords)
            elif parametrization == "uniform":
                steps = np.ones_like(chords)
            else:
                raise PlanningError(
                    "parametrization: must be 'chord', 'centripetal' or 'uniform', "
                    f"got {parametrization!r}"
                )
            h = np.concatenate(([0.0], np.cumsum(steps)))
            h /= h[-1]
        else:
            h = np.array(params, dtype=float).reshape(-1)
            if h.size != len(Q):
                raise PlanningError(
                    f"params: must have one value per distinct point ({len(Q)}), got {h.size}"
                )
            if not (np.all(np.isfinite(h)) and np.all(np.diff(h) > 0)):
                raise PlanningError("params: must be finite and strictly increasing")
            if h[0] != 0.0 or h[-1] != 1.0:
                raise PlanningError(f"params: must run from 0 to 1, got [{h[0]!r}, {h[-1]!r}]")
        h[-1] = 1.0
        n = len(Q)
        inner = np.array([np.mean(h[j : j + p]) for j in range(1, n - p)])
        U = np.concatenate((np.zeros(p + 1), inner, np.ones(p + 1)))
        A = _basis_matrix(U, p, n, h, 0)
        try:
            P = np.linalg.solve(A, Q)
        except np.linalg.LinAlgError:  # pragma: no cover - averaging knots keep A regular
            raise PlanningError("points: the interpolation system is singular") from None
        return cls(U, P, p, rtol=rtol, _data=(Q, h, src))

    # -- Path interface ------------------------------------------------------------------------

    @property
    def dim(self) -> int:
        return int(self.control_points.shape[1])

    @property
    def u_end(self) -> float:
        return float(self.knots[-1])

    # -- B-spline data -------------------------------------------------------------------------

    def basis(self, u: float | np.ndarray, order: int = 0) -> np.ndarray:
        """``[d^order N_{j,p}(u_i) / du^order]``: shape ``(len(u), n_ctrl)`` (``(n_ctrl,)``
        for a float); rows of order 0 sum to 1 (partition of unity)."""
        order = check_order(order, self.degree)
        uu, scalar = param_1d(u, self.u_end)
        out = _basis_matrix(self.knots, self.degree, len(self.control_points), uu, order)
        return out[0] if scalar else out

    def __repr__(self) -> str:
        return (
            f"BSplinePath(degree={self.degree}, control_points={len(self.control_points)}, "
            f"dim={self.dim}, length={self.length!r})"
        )


def _basis_matrix(U: np.ndarray, p: int, n_ctrl: int, u: np.ndarray, order: int) -> np.ndarray:
    span = _find_span(U, p, n_ctrl, u)
    ders = _ders_basis(U, p, span, u, order)[order]  # (M, p+1)
    out = np.zeros((u.size, n_ctrl))
    cols = span[:, None] - p + np.arange(p + 1)[None, :]
    np.put_along_axis(out, cols, ders, axis=1)
    return out


# ---------------------------------------------------------------------------------------------
# deviation from a reference path


def _readonly(a: np.ndarray) -> np.ndarray:
    a = np.array(a, dtype=float, copy=True)
    a.setflags(write=False)
    return a


@dataclass(frozen=True, slots=True)
class Deviation:
    """The largest distance of a curve from a reference path: ``max_u min_v |C(u) - R(v)|``.

    ``max`` [m] at curve parameter ``u`` (``point``); its nearest reference point is
    ``nearest`` at reference parameter ``v``. ``breaks`` split the curve's parameter interval
    (e.g. at the passing points); ``interval_max[k]``, ``interval_u[k]``, ``interval_v[k]`` are
    the same quantities on ``[breaks[k], breaks[k+1]]``. Arrays are read-only.
    """

    max: float
    u: float
    v: float
    point: np.ndarray
    nearest: np.ndarray
    breaks: np.ndarray
    interval_max: np.ndarray
    interval_u: np.ndarray
    interval_v: np.ndarray


class _Nearest:
    """Nearest point of a reference path: dense grid, then Newton's method on
    ``g(v) = (R(v) - q) . R'(v) = 0`` inside the bracket of the grid point's neighbours. Where
    a Newton step leaves the bracket or ``g' <= 0`` (e.g. the nearest point is a corner of the
    reference, where ``g`` jumps), the point switches to sectioning: ``g`` at 7 interior points
    of the bracket (in the same vectorised call as the Newton points) keeps the eighth where
    ``g`` changes sign."""

    _SECTIONS = 8

    def __init__(self, reference: Path, samples: int, xtol: float) -> None:
        self.ref = reference
        self.v = np.linspace(0.0, reference.u_end, samples)
        self.pts = np.atleast_2d(reference.evaluate(self.v))
        self.xtol = xtol * reference.u_end
        self.center = self.pts.mean(axis=0)
        self.pc = self.pts - self.center
        self.pc2 = np.einsum("md,md->m", self.pc, self.pc)

    def _g(self, v: np.ndarray, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        r0, r1, r2 = (np.atleast_2d(x) for x in self.ref.derivatives(v, 2))
        e = r0 - q
        g = np.einsum("kd,kd->k", e, r1)
        h = np.einsum("kd,kd->k", r1, r1) + np.einsum("kd,kd->k", e, r2)
        return g, h

    def __call__(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(distance, v)`` of the nearest reference point of every row of ``q``."""
        K = len(q)
        best = np.empty(K, dtype=np.intp)
        # |q - p|² = |q|² + |p|² - 2 q.p on centred coordinates (a matrix product); a near-tie
        # it resolves wrongly is within rounding of the true nearest grid point
        qc = q - self.center
        rows = max(1, 1_000_000 // len(self.v))
        for i in range(0, K, rows):
            blk = qc[i : i + rows]
            d2 = self.pc2[None, :] - 2.0 * (blk @ self.pc.T)
            best[i : i + rows] = np.argmin(d2, axis=1)
        last = len(self.v) - 1
        lo = self.v[np.maximum(best - 1, 0)]
        hi = self.v[np.minimum(best + 1, last)]
        v = self.v[best].copy()
        section = np.zeros(K, dtype=bool)
        active = np.arange(K)
        ns = self._SECTIONS
        frac = np.arange(1, ns) / ns
        for _ in range(200):
            newt = active[~section[active]]
            sect = active[section[active]]
            xs = lo[sect, None] + (hi[sect] - lo[sect])[:, None] * frac[None, :]
            g_all, h_all = self._g(
                np.concatenate((v[newt], xs.reshape(-1))),
                np.concatenate((q[newt], np.repeat(q[sect], ns - 1, axis=0))),
            )
            # Newton points
            g, h = g_all[: newt.size], h_all[: newt.size]
            va = v[newt]
            lo_n = np.where(g < 0.0, va, lo[newt])
            hi_n = np.where(g > 0.0, va, hi[newt])
            step = np.divide(g, h, out=np.zeros_like(g), where=h > 0.0)
            vn = va - step
            bad = ~((vn > lo_n) & (vn < hi_n)) | ~(h > 0.0)
            done_n = (g == 0.0) | (~bad & (np.abs(step) <= self.xtol)) | (hi_n - lo_n <= self.xtol)
            lo[newt], hi[newt] = lo_n, hi_n
            v[newt] = np.where(bad, va, vn)  # a last step inside the bracket is applied
            section[newt] = bad & ~done_n
            # sectioning points: keep the eighth where g changes sign
            gs = g_all[newt.size :].reshape(sect.size, ns - 1)
            pos = gs > 0.0
            j = np.where(pos.any(axis=1), np.argmax(pos, axis=1), ns - 1)  # first x with g > 0
            grid = np.concatenate((lo[sect, None], xs, hi[sect, None]), axis=1)
            rows_s = np.arange(sect.size)
            lo[sect], hi[sect] = grid[rows_s, j], grid[rows_s, j + 1]
            v[sect] = 0.5 * (lo[sect] + hi[sect])
            done_s = hi[sect] - lo[sect] <= self.xtol
            done = np.zeros(K, dtype=bool)
            done[newt] = done_n
            done[sect] = done_s
            active = active[~done[active]]
            if active.size == 0:
                break
        # the refined point, the bracket ends and the grid point compete (never worse than grid)
        cand = np.stack((v, lo, hi))
        f = np.empty((4, K))
        for j in range(3):
            e = np.atleast_2d(self.ref.evaluate(cand[j])) - q
            f[j] = np.einsum("kd,kd->k", e, e)
        e = self.pts[best] - q
        f[3] = np.einsum("kd,kd->k", e, e)
        cand = np.concatenate((cand, self.v[best][None, :]))
        k = np.argmin(f, axis=0)
        cols = np.arange(K)
        return np.sqrt(f[k, cols]), cand[k, cols]


def _golden(
    func: Callable[[np.ndarray], np.ndarray], lo: np.ndarray, hi: np.ndarray, xtol: float
) -> tuple[np.ndarray, np.ndarray]:
    """Vectorised golden-section minimisation of ``f`` on ``[lo, hi]`` (per row) to ``xtol``;
    the end points are candidates too. Returns ``(x, f(x))``."""
    lo, hi = lo.astype(float).copy(), hi.astype(float).copy()
    width = float(np.max(hi - lo)) if lo.size else 0.0
    iters = 0 if width <= xtol else int(math.ceil(math.log(xtol / width) / math.log(_INVPHI)))
    c = hi - _INVPHI * (hi - lo)
    d = lo + _INVPHI * (hi - lo)
    fc, fd = func(c), func(d)
    for _ in range(iters):
        left = fc < fd  # the minimum is in [lo, d]
        hi = np.where(left, d, hi)
        lo = np.where(left, lo, c)
        x_new = np.where(left, hi - _INVPHI * (hi - lo), lo + _INVPHI * (hi - lo))
        f_new = func(x_new)
        d, fd, c, fc = (
            np.where(left, c, x_new),
            np.where(left, fc, f_new),
            np.where(left, x_new, d),
            np.where(left, f_new, fd),
        )
    xs = np.stack((lo, c, d, hi))
    fs = np.stack((func(lo), fc, fd, func(hi)))
    k = np.argmin(fs, axis=0)
    cols = np.arange(lo.size)
    return xs[k, cols], fs[k, cols]


def deviation(
    curve: Path,
    reference: Path,
    *,
    breaks: ArrayLike | None = None,
    samples: int = 2001,
    reference_samples: int = 4001,
    xtol: float = 1e-10,
) -> Deviation:
    """The largest distance from points of ``curve`` to their nearest points on ``reference``.

    ``samples`` curve points (equidistant in ``u``, plus ``breaks``) and ``reference_samples``
    reference points give the first estimate; every sample's nearest reference point is refined
    by golden-section search on ``v`` between the neighbours of its nearest grid point, and the
    largest local maxima in ``u`` (at least the largest of every interval between ``breaks``)
    by golden-section search on ``u`` between the neighbouring samples, to ``xtol`` (``v``) and
    ``100 * xtol`` (``u``; the value error at a smooth maximum is of second order in it) times
    the parameter range. The result is never below the sampled maximum and converges to the
    true maximum as the samples resolve the curves' features. Works for any two paths of the
    same dimension.
    """
    if not isinstance(curve, Path) or not isinstance(reference, Path):
        raise PlanningError("curve, reference: must be Path objects")
    if curve.dim != reference.dim:
        raise PlanningError(
            f"reference: dimension {reference.dim} differs from the curve's ({curve.dim})"
        )
    samples = check_int("samples", samples, low=3, high=10**6)
    reference_samples = check_int("reference_samples", reference_samples, low=3, high=10**6)
    xtol = check_scalar("xtol", xtol, low=0.0, high=1e-3)
    u_end = curve.u_end
    if breaks is None:
        B = np.array([0.0, u_end])
    else:
        B = np.array(breaks, dtype=float).reshape(-1)
        if (
            B.size < 2
            or not np.all(np.isfinite(B))
            or np.any(np.diff(B) <= 0)
            or abs(B[0]) > 1e-12 * u_end
            or abs(B[-1] - u_end) > 1e-12 * u_end
        ):
            raise PlanningError(
                f"breaks: must increase strictly from 0 to the curve's u_end ({u_end!r})"
            )
        B[0], B[-1] = 0.0, u_end
    nearest = _Nearest(reference, reference_samples, xtol)
    u = np.union1d(np.linspace(0.0, u_end, samples), B)
    d, v = nearest(np.atleast_2d(curve.evaluate(u)))
    n_int = B.size - 1
    interval = np.clip(np.searchsorted(B, u, side="right") - 1, 0, n_int - 1)
    # candidates: the largest sample of every interval and the largest local maxima overall
    cand: set[int] = set()
    for k in range(n_int):
        members = np.flatnonzero((u >= B[k]) & (u <= B[k + 1]))
        cand.add(int(members[np.argmax(d[members])]))
    padded = np.concatenate(([-np.inf], d, [-np.inf]))
    local = np.flatnonzero((d >= padded[:-2]) & (d >= padded[2:]))
    cand.update(int(i) for i in local[np.argsort(d[local])[::-1][:16]])
    ci = np.array(sorted(cand))
    # bracket each candidate by its neighbouring samples, kept inside its interval
    ck = interval[ci]
    lo = np.maximum(u[np.maximum(ci - 1, 0)], B[ck])
    hi = np.minimum(u[np.minimum(ci + 1, u.size - 1)], B[ck + 1])

    def neg(x: np.ndarray) -> np.ndarray:
        return -nearest(np.atleast_2d(curve.evaluate(x)))[0]

    ur, fr = _golden(neg, lo, hi, 100.0 * xtol * u_end)
    dr, vr = nearest(np.atleast_2d(curve.evaluate(ur)))
    # per interval: best of its samples and of the refined candidates in it
    imax = np.full(n_int, -1.0)
    iu = np.zeros(n_int)
    iv = np.zeros(n_int)
    for k in range(n_int):
        members = np.flatnonzero((u >= B[k]) & (u <= B[k + 1]))
        j = members[np.argmax(d[members])]
        imax[k], iu[k], iv[k] = d[j], u[j], v[j]
    for m in range(ci.size):
        for k in range(n_int):
            if B[k] <= ur[m] <= B[k + 1] and dr[m] > imax[k]:
                imax[k], iu[k], iv[k] = dr[m], ur[m], vr[m]
    g = int(np.argmax(imax))
    point = np.atleast_1d(curve.evaluate(float(iu[g])))
    near = np.atleast_1d(reference.evaluate(float(iv[g])))
    return Deviation(
        max=float(imax[g]),
        u=float(iu[g]),
        v=float(iv[g]),
        point=_readonly(point),
        nearest=_readonly(near),
        breaks=_readonly(B),
        interval_max=_readonly(imax),
        interval_u=_readonly(iu),
        interval_v=_readonly(iv),
    )


# ---------------------------------------------------------------------------------------------
# compensation loop


@dataclass(frozen=True, slots=True)
class BSplineFit:
    """Result of :func:`fit_bspline`.

    ``spline``: the returned spline (the best one found: the smallest deviation); ``deviation``:
    its :class:`Deviation` from the reference; ``params``: the reference parameters of its
    passing points (sorted); ``added_params`` / ``added_points``: the passing points inserted by
    the loop, in insertion order (those of the returned spline only); ``iterations``: re-fits
    after the first fit; ``history``: the largest deviation after every fit (first fit
    included, also re-fits not kept); ``converged``: ``deviation.max <= tolerance``;
    ``reason``: ``"converged"``, ``"max_iterations"``, ``"increased"`` (stop_on_increase) or
    ``"stalled"`` (no new point could be placed); ``insertions``: the reference parameters
    inserted at every re-fit (``len(insertions) == iterations``; also re-fits not kept).
    """

    spline: BSplinePath
    deviation: Deviation
    params: np.ndarray
    added_params: np.ndarray
    added_points: np.ndarray
    iterations: int
    history: tuple[float, ...]
    converged: bool
    reason: str
    tolerance: float
    insertions: tuple[tuple[float, ...], ...]


def fit_bspline(
    reference: Path,
    tolerance: float,
    *,
    degree: int = 3,
    params: ArrayLike | None = None,
    mode: Literal["global", "per_segment"] = "global",
    max_iterations: int = 50,
    stop_on_increase: bool = False,
    parametrization: Parametrization = "chord",
    samples: int = 2001,
    reference_samples: int = 4001,
) -> BSplineFit:
    """Interpolate ``reference`` by a B-spline until its :func:`deviation` is <= ``tolerance``.

    ``params``: reference parameters of the initial passing points (the seed passes the
    segment junctions plus the arc apexes; default ``degree + 1`` equidistant values); ``0``
    and ``u_end`` are always included. Each iteration inserts, in ``"global"`` mode, the
    reference point nearest to the spline's worst point (the seed's function 1, with the true
    distance instead of the seed's index-matched one) or, in ``"per_segment"`` mode, one such
    point for every interval between passing points whose deviation exceeds ``tolerance`` (the
    seed's function 2; "segment" = spline interval between passing points). A new point closer
    than ``1e-6 * u_end`` (reference parameter) to a passing point is replaced by the
    reference point at the worst spline parameter mapped piecewise linearly between passing
    points (the seed's index matching); if that is close too, the loop stops ("stalled").
    With ``stop_on_increase`` the loop stops at the first re-fit whose deviation grows (the
    seed's rule, returning the spline before it); otherwise it runs on and returns the best
    spline (the seed's alternative rule). ``tolerance`` > 0 [m].
    """
    if not isinstance(reference, Path):
        raise PlanningError("reference: must be a Path")
    tol = check_scalar("tolerance", tolerance, low=0.0)
    p = _check_degree(degree)
    max_iterations = check_int("max_iterations", max_iterations, low=0, high=10_000)
    if mode not in ("global", "per_segment"):
        raise PlanningError(f"mode: must be 'global' or 'per_segment', got {mode!r}")
    if not isinstance(stop_on_increase, bool):
        raise PlanningError(f"stop_on_increase: must be a bool, got {stop_on_increase!r}")
    v_end = reference.u_end
    if params is None:
        v0 = np.linspace(0.0, v_end, p + 1)
    else:
        v0 = np.array(params, dtype=float).reshape(-1)
        if not np.all(np.isfinite(v0)) or v0.size and (v0.min() < 0.0 or v0.max() > v_end):
            raise PlanningError(f"params: reference parameters must be in [0, {v_end!r}]")
    v0 = np.union1d(v0, [0.0, v_end])
    min_gap = 1e-6 * v_end

    def fit(v: np.ndarray) -> tuple[BSplinePath, Deviation]:
        spline = BSplinePath.interpolate(
            np.atleast_2d(reference.evaluate(v)).reshape(len(v), -1),
            p,
            parametrization=parametrization,
        )
        if spline.source_index is not None and len(spline.source_index) != len(v):
            raise PlanningError("params: passing points on the reference must be distinct")
        dev = deviation(
            spline,
            reference,
            breaks=spline.point_params,
            samples=samples,
            reference_samples=reference_samples,
        )
        return spline, dev

    v = v0
    spline, dev = fit(v)
    history = [dev.max]
    inserted: list[float] = []
    insertions: list[tuple[float, ...]] = []
    best = (spline, dev, v, 0)
    reason = "max_iterations"
    iterations = 0
    while True:
        if dev.max <= tol:
            reason = "converged"
            break
        if iterations >= max_iterations:
            reason = "max_iterations"
            break
        assert spline.point_params is not None
        if mode == "global":
            worst = [(dev.u, dev.v)]
        else:
            worst = [
                (float(dev.interval_u[k]), float(dev.interval_v[k]))
                for k in range(dev.interval_max.size)
                if dev.interval_max[k] > tol
            ]
        new: list[float] = []
        for u_w, v_w in worst:
            cand = v_w
            if np.min(np.abs(np.concatenate((v, new)) - cand)) <= min_gap:
                cand = float(np.interp(u_w, spline.point_params, v))
                if np.min(np.abs(np.concatenate((v, new)) - cand)) <= min_gap:
                    continue
            new.append(cand)
        if not new:
            reason = "stalled"
            break
        v_next = np.union1d(v, new)
        spline_next, dev_next = fit(v_next)
        iterations += 1
        insertions.append(tuple(new))
        history.append(dev_next.max)
        if stop_on_increase and dev_next.max > dev.max:
            reason = "increased"
            break
        inserted.extend(new)
        spline, dev, v = spline_next, dev_next, v_next
        if dev.max < best[1].max:
            best = (spline, dev, v, len(inserted))
    b_spline, b_dev, b_v, n_added = best
    added = np.array(inserted[:n_added], dtype=float)
    added_pts = (
        np.atleast_2d(reference.evaluate(added)).reshape(n_added, -1)
        if n_added
        else np.zeros((0, reference.dim))
    )
    return BSplineFit(
        spline=b_spline,
        deviation=b_dev,
        params=_readonly(b_v),
        added_params=_readonly(added),
        added_points=_readonly(added_pts),
        iterations=iterations,
        history=tuple(history),
        converged=b_dev.max <= tol,
        reason=reason,
        tolerance=tol,
        insertions=tuple(insertions),
    )
