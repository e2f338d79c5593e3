"""The geometric path interface shared by every path kind and by the path-following planner.

A :class:`Path` is a curve ``p(u)`` in R^n over a parameter interval ``[0, u_end]``. Lines and
arcs (and their concatenation) are parametrised by arc length, so ``u_end == length`` and
``|p'(u)| == 1``; curves (Hermite, B-splines) keep their own parameter and report their arc
length separately (``length``, ``arc_length(u)``, with a documented tolerance).

Every evaluation is vectorised: ``u`` is a float or a 1-D array; the result has shape
``(dim,)`` for a float and ``(len(u), dim)`` for an array. Derivatives are with respect to
``u``. Paths are immutable; all construction work (blends, fits, arc-length tables) happens in
the constructor, never in a control cycle.
"""

from __future__ import annotations

from abc import ABC, abstractmethod

import numpy as np

from motionplc.errors import PlanningError

__all__ = ["Path", "as_param"]


def as_param(u: float | np.ndarray, u_end: float) -> np.ndarray:
    """``u`` as a float array, checked to lie in ``[0, u_end]`` (a rounding outside is clipped).

    Raises :class:`PlanningError` naming ``u`` for NaN or values clearly outside the interval
    (by more than ``1e-9 * u_end``: relative, so a short path never has a parameter far outside
    it clipped silently).
    """
    arr = np.asarray(u, dtype=float)
    if not np.all(np.isfinite(arr)):
        raise PlanningError("u: path parameter must be finite")
    tol = 1e-9 * abs(u_end)
    if arr.size and (arr.min() < -tol or arr.max() > u_end + tol):
        raise PlanningError(
            f"u: path parameter must be in [0, {u_end!r}], got "
            f"[{float(arr.min())!r}, {float(arr.max())!r}]"
        )
    return np.clip(arr, 0.0, u_end)


class Path(ABC):
    """A curve in R^dim over ``u`` in ``[0, u_end]``; immutable."""

    __slots__ = ()

    @property
    @abstractmethod
    def dim(self) -> int:
        """Number of coordinates (axes)."""

    @property
    @abstractmethod
    def u_end(self) -> float:
        """End of the parameter interval (the start is 0)."""

    @property
    def length(self) -> float:
        """Arc length of the whole path [m] (exact for lines/arcs)."""
        return float(self.arc_length(self.u_end))

    def arc_length(self, u: float | np.ndarray) -> float | np.ndarray:
        """Arc length from ``u = 0`` to ``u``. Default: arc-length parametrisation."""
        arr = as_param(u, self.u_end)
        return float(arr) if arr.ndim == 0 else arr

    @abstractmethod
    def evaluate(self, u: float | np.ndarray, order: int = 0) -> np.ndarray:
        """The ``order``-th derivative (0..3) of the position with respect to ``u``."""

    def derivatives(self, u: float | np.ndarray, n: int = 2) -> tuple[np.ndarray, ...]:
        """Position and the first ``n`` derivatives at ``u``: ``(p, p', p'', ...)``."""
        return tuple(self.evaluate(u, k) for k in range(n + 1))

    def unit_tangent(self, u: float | np.ndarray) -> np.ndarray:
        """Unit tangent ``p' / |p'|`` at ``u`` (shape as :meth:`evaluate`; NaN where p' = 0)."""
        d1 = np.asarray(self.evaluate(u, 1), dtype=float)
        with np.errstate(invalid="ignore", divide="ignore"):
            return d1 / np.linalg.norm(d1, axis=-1, keepdims=True)

    def curvature_vector(self, u: float | np.ndarray) -> np.ndarray:
        """Curvature vector ``kappa * N`` at ``u``, independent of the parametrisation.

        ``(p'' - (p'' . T) T) / |p'|^2`` with ``T = p'/|p'|``; its norm is the curvature
        [1/m] and it points to the centre of the osculating circle (0 on a line, NaN where
        ``p' = 0``). Continuity of this vector along a path is G2 continuity.
        """
        d1 = np.asarray(self.evaluate(u, 1), dtype=float)
        d2 = np.asarray(self.evaluate(u, 2), dtype=float)
        with np.errstate(invalid="ignore", divide="ignore"):
            sq = np.sum(d1 * d1, axis=-1, keepdims=True)
            return (d2 - np.sum(d2 * d1, axis=-1, keepdims=True) / sq * d1) / sq

    def u_at_arc_length(self, s: float | np.ndarray) -> float | np.ndarray:
        """The parameter at arc length ``s`` in ``[0, length]`` (inverse of :meth:`arc_length`).

        Default: bracketed Newton iteration on :meth:`arc_length` with ``|p'|`` as slope
        (bisection where a step leaves the bracket), to ``1e-12 * length``; paths
        parametrised by arc length return ``s`` itself.
        """
        total = self.length
        arr = as_param(s, total)
        ss = np.atleast_1d(arr).astype(float)
        if self.u_end == total and type(self).arc_length is Path.arc_length:
            return float(arr) if arr.ndim == 0 else ss
        lo = np.zeros_like(ss)
        hi = np.full_like(ss, self.u_end)
        u = ss / total * self.u_end if total > 0.0 else lo.copy()
        tol = 1e-12 * max(total, 1e-300)
        for _ in range(200):
            f = np.asarray(self.arc_length(u), dtype=float) - ss
            if np.all(np.abs(f) <= tol):
                break
            lo = np.where(f < 0.0, u, lo)
            hi = np.where(f > 0.0, u, hi)
            slope = np.linalg.norm(np.atleast_2d(self.evaluate(u, 1)), axis=-1)
            with np.errstate(invalid="ignore", divide="ignore"):
                step = u - f / slope
            ok = (step > lo) & (step < hi)
            u = np.where(np.abs(f) <= tol, u, np.where(ok, step, 0.5 * (lo + hi)))
        return float(u[0]) if arr.ndim == 0 else u

    @property
    def start(self) -> np.ndarray:
        return self.evaluate(0.0)

    @property
    def end(self) -> np.ndarray:
        return self.evaluate(self.u_end)
