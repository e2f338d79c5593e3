"""Independent numerical checks of the geometric paths (finite differences, quadrature)."""

from __future__ import annotations

import numpy as np

from motionplc.planning.paths.base import Path


def fd_derivative_error(path: Path, u: np.ndarray, order: int) -> float:
    """Largest relative error of ``evaluate(u, order + 1)`` against a central difference of
    ``evaluate(u, order)`` (``u`` kept a step away from the ends)."""
    h = 1e-5 * max(path.u_end, 1e-3)
    u = np.clip(u, h, path.u_end - h)
    fd = (path.evaluate(u + h, order) - path.evaluate(u - h, order)) / (2.0 * h)
    an = path.evaluate(u, order + 1)
    scale = max(1.0, float(np.abs(an).max()), float(np.abs(fd).max()))
    return float(np.abs(fd - an).max()) / scale


def integrated_length(path: Path, u0: float = 0.0, u1: float | None = None) -> float:
    """Arc length by adaptive quadrature of ``|p'|`` (scipy), independent of the path code."""
    from scipy.integrate import quad

    u1 = path.u_end if u1 is None else u1
    if u1 <= u0:
        return 0.0
    val, _ = quad(
        lambda x: float(np.linalg.norm(path.evaluate(x, 1))),
        u0,
        u1,
        epsabs=1e-15,
        epsrel=1e-13,
        limit=400,
    )
    return float(val)


def curvature_vector(d1: np.ndarray, d2: np.ndarray) -> np.ndarray:
    """Curvature vector from p', p'' (computed here, not by the code under test)."""
    sq = float(d1 @ d1)
    return (d2 - (d2 @ d1) / sq * d1) / sq
