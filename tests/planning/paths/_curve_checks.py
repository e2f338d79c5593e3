"""Independent checks for the curve tests (Hermite, B-spline): finite differences and
quadrature of the arc length with scipy (a test-only dependency, through toppra)."""

from __future__ import annotations

import numpy as np
import pytest

from motionplc.planning.paths import Path


def fd_error(path: Path, u: np.ndarray, order: int, h: float = 1e-6) -> float:
    """Largest relative difference between ``evaluate(u, order + 1)`` and the central
    difference of ``evaluate(., order)`` (points within ``h`` of a break are left out by the
    caller)."""
    d = (path.evaluate(u + h, order) - path.evaluate(u - h, order)) / (2.0 * h)
    ref = path.evaluate(u, order + 1)
    scale = max(1.0, float(np.max(np.abs(ref))))
    return float(np.max(np.abs(d - ref))) / scale


def quad_length(path: Path, breaks: np.ndarray, u_to: float | None = None) -> float:
    """Arc length by scipy's adaptive quadrature, piece by piece over ``breaks``."""
    integrate = pytest.importorskip("scipy.integrate")
    end = path.u_end if u_to is None else u_to
    total = 0.0
    for a, b in zip(breaks[:-1], breaks[1:], strict=True):
        if a >= end:
            break
        b = min(b, end)
        val, _ = integrate.quad(
            lambda x: float(np.linalg.norm(path.evaluate(x, 1))),
            a,
            b,
            epsabs=1e-13,
            epsrel=1e-11,
            limit=400,
        )
        total += val
    return total


def away_from(u: np.ndarray, breaks: np.ndarray, gap: float) -> np.ndarray:
    """The values of ``u`` farther than ``gap`` from every break."""
    d = np.min(np.abs(u[:, None] - np.asarray(breaks)[None, :]), axis=1)
    return u[d > gap]
