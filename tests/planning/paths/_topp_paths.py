"""Paths for the path-following tests and benchmarks (independent of the geometry modules)."""

from __future__ import annotations

import numpy as np

from motionplc.planning.paths.base import Path, as_param


class FuncPath(Path):
    """A path from vectorised callables for p, p', p'', p''' over ``[0, u_end]``."""

    __slots__ = ("_f", "_u_end", "_dim")

    def __init__(self, funcs, u_end: float, dim: int) -> None:
        object.__setattr__(self, "_f", tuple(funcs))
        object.__setattr__(self, "_u_end", float(u_end))
        object.__setattr__(self, "_dim", int(dim))

    @property
    def dim(self) -> int:
        return self._dim

    @property
    def u_end(self) -> float:
        return self._u_end

    def arc_length(self, u):  # not needed by the planner
        raise NotImplementedError

    @property
    def length(self) -> float:
        u = np.linspace(0.0, self._u_end, 20001)
        sp = np.linalg.norm(self.evaluate(u, 1), axis=1)
        return float(np.sum(0.5 * (sp[1:] + sp[:-1]) * np.diff(u)))

    def evaluate(self, u, order: int = 0):
        arr = as_param(u, self._u_end)
        out = np.asarray(self._f[order](np.atleast_1d(arr)), dtype=float).reshape(-1, self._dim)
        return out[0] if arr.ndim == 0 else out


def line(p0, p1) -> FuncPath:
    p0 = np.asarray(p0, float)
    p1 = np.asarray(p1, float)
    L = float(np.linalg.norm(p1 - p0))
    d = (p1 - p0) / L
    z = np.zeros_like(d)
    return FuncPath(
        [
            lambda u: p0 + u[:, None] * d,
            lambda u: np.broadcast_to(d, (len(u), len(d))),
            lambda u: np.broadcast_to(z, (len(u), len(d))),
            lambda u: np.broadcast_to(z, (len(u), len(d))),
        ],
        L,
        len(d),
    )


def circle(center, radius: float, turns: float = 1.0, phase: float = 0.0) -> FuncPath:
    """A circle in the plane parametrised by arc length."""
    cx, cy = center
    r = float(radius)

    def f(k):
        def g(u):
            w = u / r + phase
            c, s = np.cos(w), np.sin(w)
            sc = r ** (1 - k)
            # derivatives of (cos, sin) cycle: (c, s) -> (-s, c) -> (-c, -s) -> (s, -c)
            cyc = [(c, s), (-s, c), (-c, -s), (s, -c)][k]
            out = np.stack([sc * cyc[0], sc * cyc[1]], axis=1)
            if k == 0:
                out = out + np.array([cx, cy])
            return out

        return g

    return FuncPath([f(0), f(1), f(2), f(3)], 2 * np.pi * r * turns, 2)


def spline(ss, way_pts, bc_type="not-a-knot") -> FuncPath:
    """scipy's CubicSpline through the waypoints (the same one toppra's SplineInterpolator uses)."""
    from scipy.interpolate import CubicSpline

    cs = CubicSpline(np.asarray(ss, float), np.asarray(way_pts, float), bc_type=bc_type)
    ds = [cs, cs.derivative(1), cs.derivative(2), cs.derivative(3)]
    w = np.asarray(way_pts, float)
    return FuncPath(ds, float(ss[-1]), w.shape[1])


def wiggly(n_waves: int = 6, length: float = 1.0) -> FuncPath:
    """A 3-axis curve with many curvature changes (sum of sines; parameter in [0, length])."""
    L = float(length)
    fr = np.array([2.0, 3.0, 5.0]) * np.pi * n_waves / 6.0 / L
    ph = np.array([0.0, 0.4, 1.1])
    amp = np.array([0.3, 0.2, 0.15]) * L

    def f(k):
        def g(u):
            w = u[:, None] * fr + ph
            if k == 0:
                return amp * np.sin(w) + u[:, None] * np.array([1.0, 0.5, 0.0])
            base = [np.cos, lambda z: -np.sin(z), lambda z: -np.cos(z)][k - 1](w)
            out = amp * fr**k * base
            if k == 1:
                out = out + np.array([1.0, 0.5, 0.0])
            return out

        return g

    return FuncPath([f(0), f(1), f(2), f(3)], L, 3)


# Seed 000 §5.1: start, two arcs (the vector is the arc's start tangent), two lines.
SEED000_POINTS = [
    ([0, 0, 0], 0),
    ([1, 1, 1], [1, -1, -1]),
    ([2, 2, 2], [-1, 1, 1]),
    ([3, 3, 3], 1),
    ([4, 4, 2], 1),
]


def seed000_blended(tolerance: float = 0.05):
    """Seed 000's line/arc path (the colleagues' ``join``) with G2 corner blends."""
    from motionplc.planning.paths import Transition, blend_corners, join

    return blend_corners(join(SEED000_POINTS), Transition.max_corner_deviation(tolerance))


def bspline_through(points, degree: int = 3):
    """The colleagues' interpolating clamped B-spline through ``points``."""
    from motionplc.planning.paths import BSplinePath

    return BSplinePath.interpolate(np.asarray(points, float), degree)


BSPLINE_POINTS = [
    [0.0, 0.0, 0.0],
    [0.4, 0.3, 0.1],
    [0.7, 0.0, 0.3],
    [1.2, 0.5, 0.2],
    [1.5, 0.2, 0.0],
]
