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


# -- random paths of the second-order comparisons (tests and tools/bench_paths.py) ---------------


def _log_uniform(rng: np.random.Generator, lo: float, hi: float, size=None):
    return np.exp(rng.uniform(np.log(lo), np.log(hi), size))


def random_limits(rng: np.random.Generator, dim: int, spread: float = 1e3):
    """Per-axis velocity and acceleration limits log-uniform over ``spread`` (three orders of
    magnitude by default) around 1."""
    lo, hi = 1.0 / np.sqrt(spread), np.sqrt(spread)
    return _log_uniform(rng, lo, hi, dim), _log_uniform(rng, lo, hi, dim)


def random_blended_polyline(rng: np.random.Generator, dim: int | None = None):
    """A random polyline (2-6 axes, 4-10 segments of 0.05-2 m) with every corner rounded by a
    corner distance of 1e-4 to 1e-1 of its shorter neighbouring segment (log-uniform);
    deflections above 179 deg stay exact stops."""
    from motionplc.planning.paths import Transition, blend_polyline

    dim = int(rng.integers(2, 7)) if dim is None else dim
    n_seg = int(rng.integers(4, 11))
    lengths = _log_uniform(rng, 0.05, 2.0, n_seg)
    dirs = rng.normal(size=(n_seg, dim))
    dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
    pts = np.vstack([np.zeros(dim), np.cumsum(dirs * lengths[:, None], axis=0)])
    frac = _log_uniform(rng, 1e-4, 1e-1, n_seg - 1)
    trans = [
        Transition.corner_distance(float(f * min(lengths[i], lengths[i + 1])))
        for i, f in enumerate(frac)
    ]
    return blend_polyline(pts, trans)


def random_lines_and_arcs(rng: np.random.Generator, dim: int | None = None):
    """A tangent-continuous chain of lines and arcs (curvature jumps at every junction): a
    turtle in a random plane per arc, 2-6 axes, 3-8 pieces."""
    from motionplc.planning.paths import Arc, CompositePath, Line

    dim = int(rng.integers(2, 7)) if dim is None else dim
    p = np.zeros(dim)
    t = rng.normal(size=dim)
    t /= np.linalg.norm(t)
    segs = []
    kinds = ["line" if k % 2 == 0 else "arc" for k in range(int(rng.integers(3, 9)))]
    if rng.uniform() < 0.5:
        kinds = kinds[::-1]
    for kind in kinds:
        if kind == "line":
            L = float(_log_uniform(rng, 0.05, 2.0))
            seg = Line(p, p + L * t)
        else:
            w = rng.normal(size=dim)
            w -= (w @ t) * t
            w /= np.linalg.norm(w)
            r = float(_log_uniform(rng, 0.02, 1.0))
            phi = float(rng.uniform(0.2, 3.0))
            seg = Arc(p + r * w, r, -w, t, phi)
        segs.append(seg)
        p = np.asarray(seg.end, dtype=float)
        d = np.asarray(seg.evaluate(seg.u_end, 1), dtype=float)
        t = d / np.linalg.norm(d)
    return CompositePath(segs)


def random_bspline(rng: np.random.Generator, dim: int | None = None):
    """The package's interpolating cubic B-spline through 5-9 random points (2-6 axes)."""
    from motionplc.planning.paths import BSplinePath

    dim = int(rng.integers(2, 7)) if dim is None else dim
    pts = np.cumsum(rng.uniform(-0.5, 0.5, (int(rng.integers(5, 10)), dim)), axis=0)
    return BSplinePath.interpolate(pts, 3)
