"""Private helpers of the curve modules (Hermite, B-spline, orientation).

* :class:`PiecewisePoly` — a vectorised piecewise polynomial in R^dim (power basis in the local
  variable ``x = u - breaks[k]``), evaluated by Horner's scheme with derivatives 0..3;
* :class:`Frozen` — attributes set once in ``__init__`` (arrays stored read-only);
* input checks that raise :class:`~motionplc.errors.PlanningError` naming the field and the
  allowed range.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from motionplc.errors import PlanningError

MAX_ORDER = 3


class Frozen:
    """Mixin: attributes are set once (through :meth:`_freeze`); arrays become read-only."""

    __slots__ = ()

    def _freeze(self, **attrs: Any) -> None:
        for name, value in attrs.items():
            if isinstance(value, np.ndarray):
                value = np.array(value, copy=True)
                value.setflags(write=False)
            object.__setattr__(self, name, value)

    def __setattr__(self, name: str, value: object) -> None:
        raise AttributeError(f"{type(self).__name__} is immutable (cannot set {name!r})")

    def __delattr__(self, name: str) -> None:
        raise AttributeError(f"{type(self).__name__} is immutable (cannot delete {name!r})")


# ---------------------------------------------------------------------------------------------
# input checks


def check_order(order: object, max_order: int = MAX_ORDER) -> int:
    """The derivative order as an int in ``0..max_order``, else PlanningError naming ``order``."""
    if isinstance(order, bool) or not isinstance(order, int | np.integer):
        raise PlanningError(
            f"order: derivative order must be an int in 0..{max_order}, got {order!r}"
        )
    if not 0 <= int(order) <= max_order:
        raise PlanningError(f"order: derivative order must be in 0..{max_order}, got {order!r}")
    return int(order)


def check_points(name: str, value: object, *, min_count: int = 2) -> np.ndarray:
    """``value`` as a finite ``(n, dim)`` float array with ``n >= min_count``, ``dim >= 1``."""
    try:
        arr = np.array(value, dtype=float)
    except (TypeError, ValueError):
        raise PlanningError(
            f"{name}: must be a sequence of points with the same number of coordinates "
            f"(mismatched dimensions or non-numbers), got {value!r}"
        ) from None
    if arr.ndim == 1 and arr.size >= 1:
        arr = arr[:, None]  # a list of scalars: 1-D points
    if arr.ndim != 2 or arr.shape[1] < 1:
        raise PlanningError(
            f"{name}: must be an (n, dim) array of points with dim >= 1, got shape {arr.shape}"
        )
    if arr.shape[0] < min_count:
        raise PlanningError(f"{name}: need at least {min_count} points, got {arr.shape[0]}")
    if not np.all(np.isfinite(arr)):
        bad = int(np.argwhere(~np.all(np.isfinite(arr), axis=1))[0, 0])
        raise PlanningError(
            f"{name}: coordinates must be finite (point {bad} is {arr[bad].tolist()!r})"
        )
    return arr


def check_vector(name: str, value: object, dim: int) -> np.ndarray:
    """``value`` as a finite vector of ``dim`` entries, else PlanningError naming ``name``."""
    try:
        arr = np.array(value, dtype=float).reshape(-1)
    except (TypeError, ValueError):
        raise PlanningError(f"{name}: must be a vector of {dim} numbers, got {value!r}") from None
    if arr.size != dim:
        raise PlanningError(f"{name}: must have {dim} entries (the path dimension), got {arr.size}")
    if not np.all(np.isfinite(arr)):
        raise PlanningError(f"{name}: entries must be finite, got {arr.tolist()!r}")
    return arr


def check_scalar(
    name: str,
    value: object,
    *,
    low: float,
    high: float = math.inf,
    low_open: bool = True,
    high_open: bool = False,
) -> float:
    """``value`` as a finite float in the given interval, else PlanningError naming the range."""
    if isinstance(value, bool) or not isinstance(value, int | float | np.floating | np.integer):
        raise PlanningError(f"{name}: must be a number, got {value!r}")
    v = float(value)
    ok_low = v > low if low_open else v >= low
    ok_high = v < high if high_open else v <= high
    if not (math.isfinite(v) and ok_low and ok_high):
        lb = "(" if low_open else "["
        hb = ")" if high_open or math.isinf(high) else "]"
        raise PlanningError(f"{name}: must be in {lb}{low!r}, {high!r}{hb}, got {v!r}")
    return v


def check_int(name: str, value: object, *, low: int, high: int | None = None) -> int:
    """``value`` as an int in ``[low, high]``, else PlanningError naming the range."""
    if isinstance(value, bool) or not isinstance(value, int | np.integer):
        raise PlanningError(f"{name}: must be an int, got {value!r}")
    v = int(value)
    if v < low or (high is not None and v > high):
        hi = "inf" if high is None else str(high)
        raise PlanningError(f"{name}: must be in [{low}, {hi}], got {v}")
    return v


def param_1d(u: float | np.ndarray, u_end: float, u_start: float = 0.0) -> tuple[np.ndarray, bool]:
    """``u`` checked to lie in ``[u_start, u_end]`` as a 1-D array, plus "was a scalar".

    Same rule as :func:`~motionplc.planning.paths.base.as_param`: NaN or a value outside by
    more than ``1e-9 * max(1, u_end - u_start)`` raises PlanningError naming ``u`` and the
    interval; a rounding outside is clipped. Plain floats take a fast path.
    """
    tol = 1e-9 * max(1.0, u_end - u_start)
    if isinstance(u, float | int | np.floating | np.integer) and not isinstance(u, bool):
        x = float(u)
        if not math.isfinite(x):
            raise PlanningError("u: path parameter must be finite")
        if not u_start - tol <= x <= u_end + tol:
            raise PlanningError(f"u: path parameter must be in [{u_start!r}, {u_end!r}], got {x!r}")
        return np.array([min(max(x, u_start), u_end)]), True
    arr = np.asarray(u, dtype=float)
    if arr.ndim > 1:
        raise PlanningError(f"u: must be a float or a 1-D array, got shape {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise PlanningError("u: path parameter must be finite")
    if arr.size and (arr.min() < u_start - tol or arr.max() > u_end + tol):
        raise PlanningError(
            f"u: path parameter must be in [{u_start!r}, {u_end!r}], got "
            f"[{float(arr.min())!r}, {float(arr.max())!r}]"
        )
    return np.atleast_1d(np.minimum(np.maximum(arr, u_start), u_end)), arr.ndim == 0


def drop_duplicates(points: np.ndarray, rtol: float = 1e-12) -> tuple[np.ndarray, np.ndarray]:
    """Consecutive points closer than ``rtol * max(1, max|coordinate|)`` are merged (first kept).

    Returns the kept points and their indices in the input.
    """
    scale = max(1.0, float(np.max(np.abs(points))))
    gaps = np.linalg.norm(np.diff(points, axis=0), axis=1)
    keep = np.concatenate(([True], gaps > rtol * scale))
    idx = np.flatnonzero(keep)
    return points[idx], idx


# ---------------------------------------------------------------------------------------------


class PiecewisePoly(Frozen):
    """``p(u) = sum_j c[k, j] (u - breaks[k])**j`` on ``[breaks[k], breaks[k+1]]``.

    ``coeffs`` has shape ``(K, deg + 1, dim)``. Evaluation is right-continuous at the breaks
    (the piece starting at a break is used there; the last piece at the end point).
    """

    __slots__ = ("breaks", "_coeffs")

    breaks: np.ndarray
    _coeffs: tuple[np.ndarray, ...]

    def __init__(self, breaks: np.ndarray, coeffs: np.ndarray) -> None:
        ders = [np.asarray(coeffs, dtype=float)]
        for _ in range(MAX_ORDER):
            c = ders[-1]
            if c.shape[1] > 1:
                j = np.arange(1, c.shape[1], dtype=float)
                ders.append(c[:, 1:, :] * j[None, :, None])
            else:
                ders.append(np.zeros_like(c))
        frozen = []
        for c in ders:
            c = np.ascontiguousarray(c)
            c.setflags(write=False)
            frozen.append(c)
        self._freeze(breaks=np.asarray(breaks, dtype=float), _coeffs=tuple(frozen))

    @property
    def coeffs(self) -> np.ndarray:
        """``(K, deg + 1, dim)`` coefficients, ascending powers of the local variable."""
        return self._coeffs[0]

    def piece(self, u: np.ndarray) -> np.ndarray:
        """Index of the piece used at each ``u`` (right-continuous, last piece at the end)."""
        k = np.searchsorted(self.breaks, u, side="right") - 1
        return np.minimum(np.maximum(k, 0), len(self.breaks) - 2)

    def __call__(self, u: np.ndarray, order: int = 0) -> np.ndarray:
        """Derivative ``order`` (0..3) at the 1-D array ``u``; shape ``(len(u), dim)``."""
        k = self.piece(u)
        x = (u - self.breaks[k])[:, None]
        c = self._coeffs[order][k]  # (M, deg+1, dim)
        out = c[:, -1, :].copy()
        for j in range(c.shape[1] - 2, -1, -1):
            out *= x
            out += c[:, j, :]
        return out

    def speed_breaks(self, rtol: float = 1e-6) -> np.ndarray:
        """The break points plus every interior local minimum of ``|p'|²`` that is below
        ``rtol`` times the largest ``|p'|²`` of its piece: where the speed ``|p'|`` may have
        a kink (``p' = 0``, always possible in 1-D, a cusp in n-D), so the arc-length
        quadrature can split there."""
        out = [self.breaks]
        c1 = self._coeffs[1]  # (K, deg, dim): p' in ascending powers
        for k in range(c1.shape[0]):
            width = self.breaks[k + 1] - self.breaks[k]
            q = np.zeros(max(2 * c1.shape[1] - 1, 1))
            for d in range(c1.shape[2]):
                q += np.convolve(c1[k, :, d], c1[k, :, d])  # |p'|² (ascending powers)
            dq = np.polynomial.polynomial.polyder(q)
            if not np.any(dq):
                continue
            roots = np.polynomial.polynomial.polyroots(np.trim_zeros(dq, "b"))
            x = roots.real[np.abs(roots.imag) <= 1e-9 * width]
            x = x[(x > 1e-9 * width) & (x < (1.0 - 1e-9) * width)]  # the ends are breaks
            if x.size == 0:
                continue
            grid = np.linspace(0.0, width, 17)
            top = float(np.max(np.polynomial.polynomial.polyval(grid, q)))
            low = np.polynomial.polynomial.polyval(x, q) <= rtol * top
            out.append(self.breaks[k] + x[low])
        b = np.unique(np.concatenate(out))
        keep = np.concatenate(([True], np.diff(b) > 1e-12 * (b[-1] - b[0])))
        keep[-1] = True
        b = b[keep]
        if b.size > 2 and b[-1] - b[-2] <= 1e-12 * (b[-1] - b[0]):
            b = np.delete(b, -2)
        return b

    def speed(self, u: np.ndarray) -> np.ndarray:
        """``|p'(u)|`` at the 1-D array ``u``."""
        d = self(u, 1)
        return np.sqrt(np.einsum("ij,ij->i", d, d))
