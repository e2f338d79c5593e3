"""Arc length of parametric curves and its inverse (seed 000 §4.7–4.8), vectorised.

* :class:`ArcLengthTable` — built once from the speed ``f(u) = |p'(u)|`` and the curve's break
  points (Hermite sections, B-spline knot spans, and the zeros of ``p'`` where ``|p'|`` has a
  kink: between them ``f`` is smooth, which the error estimate needs): every piece is split
  adaptively (8-point Gauss–Legendre on an interval against the sum over its two halves) until
  the error estimate of each leaf is below ``rtol * length * width / total width``; the sum of
  the estimates is therefore below ``rtol * length`` (default ``rtol = 1e-10``; the estimate is
  the error of the coarser rule and the halves are kept, so the real error is far smaller for
  smooth ``f``). ``s(u)`` is the table's cumulative value at the leaf start plus the same
  Gauss–Legendre rule on ``[leaf start, u]``; ``u(s)`` is Newton's method on that function,
  safeguarded by bisection inside the leaf (seed 000 inverts by pure bisection; Newton without a
  bracket "did not converge", the bracket fixes that), to ``|s(u) - s| <= 1e-13 * length``.
* :func:`adaptive_simpson` — the seed's recursive Simpson rule (5.5.3–5.5.4) for a scalar
  integral, kept as an independent reference (the tests check the table against it).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from motionplc.errors import PlanningError
from motionplc.planning.paths._ppoly import (
    Frozen,
    PiecewisePoly,
    check_int,
    check_order,
    check_scalar,
    param_1d,
)
from motionplc.planning.paths.base import Path, as_param

__all__ = ["ArcLengthTable", "adaptive_simpson"]

_GL_NODES, _GL_WEIGHTS = np.polynomial.legendre.leggauss(8)
_INV_RTOL = 1e-13

Speed = Callable[[np.ndarray], np.ndarray]


def _gauss(speed: Speed, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """8-point Gauss–Legendre integral of ``speed`` over each ``[a_i, b_i]`` (vectorised)."""
    half = 0.5 * (b - a)
    x = (0.5 * (a + b))[:, None] + half[:, None] * _GL_NODES[None, :]
    f = speed(x.reshape(-1)).reshape(x.shape)
    return half * (f @ _GL_WEIGHTS)


class ArcLengthTable(Frozen):
    """Cumulative arc length ``s(u) = integral_{u_start}^{u} f`` and its inverse; immutable.

    ``speed`` must be vectorised (1-D array in, 1-D array out) and non-negative; ``breaks`` are
    the strictly increasing points where ``f`` may be non-smooth (the first and last bound the
    parameter interval). Callers check ``u`` and ``s`` against the interval; the methods here
    take arrays.
    """

    __slots__ = ("_speed", "_a", "_b", "_cum", "length", "rtol", "leaves")

    _speed: Speed
    _a: np.ndarray
    _b: np.ndarray
    _cum: np.ndarray
    length: float
    rtol: float
    leaves: int

    def __init__(
        self, speed: Speed, breaks: np.ndarray, *, rtol: float = 1e-10, max_depth: int = 40
    ) -> None:
        rtol = check_scalar("rtol", rtol, low=0.0, high=1e-2)
        max_depth = check_int("max_depth", max_depth, low=1, high=60)
        breaks = np.asarray(breaks, dtype=float)
        if breaks.ndim != 1 or breaks.size < 2 or not np.all(np.diff(breaks) > 0):
            raise PlanningError("breaks: must be a strictly increasing 1-D array of >= 2 values")
        a, b = breaks[:-1], breaks[1:]
        rough = float(np.sum(_gauss(speed, a, b)))
        atol_per_width = rtol * max(rough, 1e-300) / (breaks[-1] - breaks[0])
        leaf_a: list[np.ndarray] = []
        leaf_b: list[np.ndarray] = []
        leaf_v: list[np.ndarray] = []
        for depth in range(max_depth):
            m = 0.5 * (a + b)
            whole = _gauss(speed, a, b)
            left = _gauss(speed, a, m)
            right = _gauss(speed, m, b)
            ok = np.abs(left + right - whole) <= atol_per_width * (b - a)
            if depth == max_depth - 1:
                ok[:] = True
            leaf_a += [a[ok], m[ok]]
            leaf_b += [m[ok], b[ok]]
            leaf_v += [left[ok], right[ok]]
            a, b = np.concatenate((a[~ok], m[~ok])), np.concatenate((m[~ok], b[~ok]))
            if a.size == 0:
                break
        la, lb, lv = (np.concatenate(x) for x in (leaf_a, leaf_b, leaf_v))
        order = np.argsort(la)
        cum = np.concatenate(([0.0], np.cumsum(lv[order])))
        self._freeze(
            _speed=speed,
            _a=la[order],
            _b=lb[order],
            _cum=cum,
            length=float(cum[-1]),
            rtol=rtol,
            leaves=int(la.size),
        )

    def _leaf(self, u: np.ndarray) -> np.ndarray:
        return np.clip(np.searchsorted(self._a, u, side="right") - 1, 0, self._a.size - 1)

    def s(self, u: np.ndarray) -> np.ndarray:
        """Arc length from the start to each ``u`` (1-D array inside the interval)."""
        j = self._leaf(u)
        return self._cum[j] + _gauss(self._speed, self._a[j], u)

    def u(self, s: np.ndarray) -> np.ndarray:
        """The parameter at arc length ``s`` (1-D array in ``[0, length]``); non-decreasing."""
        s = np.clip(np.asarray(s, dtype=float), 0.0, self.length)
        j = np.clip(np.searchsorted(self._cum, s, side="right") - 1, 0, self._a.size - 1)
        lo, hi = self._a[j].copy(), self._b[j].copy()
        start = self._a[j]
        target = s - self._cum[j]
        leaf_len = self._cum[j + 1] - self._cum[j]
        frac = np.divide(target, leaf_len, out=np.zeros_like(target), where=leaf_len > 0)
        u = lo + (hi - lo) * np.clip(frac, 0.0, 1.0)
        tol = _INV_RTOL * max(self.length, 1e-300)
        active = np.arange(u.size)
        for _ in range(100):
            ua = u[active]
            g = _gauss(self._speed, start[active], ua) - target[active]
            lo_a = np.where(g < 0.0, ua, lo[active])
            hi_a = np.where(g > 0.0, ua, hi[active])
            done = (np.abs(g) <= tol) | (hi_a - lo_a <= 4.0 * np.finfo(float).eps * np.abs(hi_a))
            f = self._speed(ua)
            step = np.divide(g, f, out=np.zeros_like(g), where=f > 0.0)
            un = ua - step
            bad = ~((un > lo_a) & (un < hi_a)) | ~(f > 0.0)
            un = np.where(bad, 0.5 * (lo_a + hi_a), un)
            lo[active], hi[active] = lo_a, hi_a
            u[active] = np.where(done, ua, un)
            active = active[~done]
            if active.size == 0:
                break
        return u


def adaptive_simpson(
    f: Callable[[np.ndarray], np.ndarray],
    a: float,
    b: float,
    tol: float,
    *,
    max_depth: int = 50,
) -> tuple[float, float]:
    """``(integral of f over [a, b], error estimate)`` by adaptive Simpson (seed 000 §4.7).

    Each interval is compared with its two halves, ``eps = |L13 + L32 - L12|``; it is accepted
    when ``eps <= 15 * tol`` (Lyness's criterion, the halves' error being ``eps / 15``),
    otherwise both halves are refined with ``tol / 2``. Accepted leaves return the Richardson
    value ``L13 + L32 + (L13 + L32 - L12) / 15``; values and error estimates are summed. The
    recursion stops at ``max_depth`` (it terminates for any ``f``). ``f`` is called with 1-D
    arrays.
    """
    tol = check_scalar("tol", tol, low=0.0)
    max_depth = check_int("max_depth", max_depth, low=1, high=200)
    a, b = float(a), float(b)

    def simpson(x0: float, x2: float, f0: float, f1: float, f2: float) -> float:
        return (x2 - x0) / 6.0 * (f0 + 4.0 * f1 + f2)

    fa, fm, fb = (float(v) for v in f(np.array([a, 0.5 * (a + b), b])))
    stack = [(a, b, fa, fm, fb, simpson(a, b, fa, fm, fb), tol, 0)]
    total = 0.0
    err = 0.0
    while stack:
        x0, x2, f0, f1, f2, whole, t, depth = stack.pop()
        x1 = 0.5 * (x0 + x2)
        fl, fr = (float(v) for v in f(np.array([0.5 * (x0 + x1), 0.5 * (x1 + x2)])))
        left = simpson(x0, x1, f0, fl, f1)
        right = simpson(x1, x2, f1, fr, f2)
        eps = abs(left + right - whole)
        if eps <= 15.0 * t or depth >= max_depth:
            total += left + right + (left + right - whole) / 15.0
            err += eps / 15.0
        else:
            stack.append((x0, x1, f0, fl, f1, left, 0.5 * t, depth + 1))
            stack.append((x1, x2, f1, fr, f2, right, 0.5 * t, depth + 1))
    return total, err


class TabulatedCurve(Frozen, Path):
    """A curve in its own parameter with an :class:`ArcLengthTable` (``_table``) and a
    vectorised ``_poly(u, order)`` evaluator: the Path interface shared by the Hermite and
    B-spline curves."""

    __slots__ = ()
    _table: ArcLengthTable
    _poly: PiecewisePoly

    @staticmethod
    def _tabulate(
        breaks: np.ndarray, coeffs: np.ndarray, rtol: float
    ) -> tuple[PiecewisePoly, ArcLengthTable]:
        """The curve's polynomial pieces and their arc-length table (``rtol`` checked)."""
        poly = PiecewisePoly(breaks, coeffs)
        table = ArcLengthTable(
            poly.speed, poly.speed_breaks(), rtol=check_scalar("rtol", rtol, low=0.0)
        )
        return poly, table

    @property
    def length(self) -> float:
        """Arc length of the whole curve (estimated error <= ``rtol * length``)."""
        return self._table.length

    def arc_length(self, u: float | np.ndarray) -> float | np.ndarray:
        """Arc length from ``u = 0`` to ``u`` (vectorised)."""
        uu, scalar = param_1d(u, self.u_end)
        s = self._table.s(uu)
        return float(s[0]) if scalar else s

    def u_at_arc_length(self, s: float | np.ndarray) -> float | np.ndarray:
        """The parameter ``u`` at arc length ``s`` in ``[0, length]`` (vectorised inverse)."""
        arr = as_param(s, self.length)
        uu = self._table.u(np.atleast_1d(arr))
        return float(uu[0]) if arr.ndim == 0 else uu

    def evaluate(self, u: float | np.ndarray, order: int = 0) -> np.ndarray:
        """The ``order``-th derivative (0..3) with respect to ``u``; (dim,) or (len(u), dim)."""
        order = check_order(order)
        uu, scalar = param_1d(u, self.u_end)
        out = self._poly(uu, order)
        return out[0] if scalar else out
