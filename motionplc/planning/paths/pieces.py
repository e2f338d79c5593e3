# ruff: noqa: N806 - the math names of the module docstring (V, A, J, U)
"""Path pieces for the axes-group kernel: fast scalar evaluation and path-speed caps.

A group moves along a chain of *pieces* (a line, an arc or helix, a corner blend, a span of a
curve). Each piece is a geometric curve ``p(u)``, ``u`` in ``[0, U]``, and the group runs a
one-dimensional jerk-limited profile ``u(t)`` on it (see :mod:`motionplc.planning.paths.lookahead`).
By the chain rule the axis values are::

    v = p' du
    a = p' ddu + p'' du^2
    j = p' dddu + 3 p'' du ddu + p''' du^3

so with per-axis bounds ``B1_i >= |p_i'|``, ``B2_i >= |p_i''|``, ``B3_i >= |p_i'''|`` over the
piece, constant caps ``du <= V``, ``|ddu| <= A``, ``|dddu| <= J`` keep axis ``i`` within
``v_i, a_i, j_i`` when::

    B1 V <= v_i,   B1 A + B2 V^2 <= a_i,   B1 J + 3 B2 V A + B3 V^3 <= j_i

(:func:`path_caps` chooses ``V, A, J`` under these inequalities). The bounds are exact for lines
(``B1 = |direction_i|``, ``B2 = B3 = 0``), closed-form upper bounds for arcs and helices, and
dense maxima of the closed-form polynomial (times a margin) for the line-line corner blend.

A :class:`RunPiece` is a chain of such pieces joined with equal curvature (``|p'| = 1`` at the
joints) as one piece: one profile runs through the joints (the group's runs).

Pieces evaluate at one parameter value with plain floats (no numpy on the per-cycle path):
:meth:`Piece.at` returns ``(p, d1, d2, d3)`` as tuples, one value per axis.
"""

from __future__ import annotations

import math
from bisect import bisect_right
from collections.abc import Sequence

import numpy as np

from motionplc.errors import PlanningError
from motionplc.planning.paths.base import Path
from motionplc.planning.paths.geometry import Line, _Circular

__all__ = [
    "BlendPiece",
    "CircularPiece",
    "CurvePiece",
    "LinePiece",
    "RunPiece",
    "SubPiece",
    "Piece",
    "path_caps",
    "piece_for",
]

Vec = tuple[float, ...]

_BLEND_SAMPLES = 257  # dense samples of a blend's derivative polynomials (bounds)
_BOUND_MARGIN = 1e-6  # relative margin on sampled bounds (the polynomials are smooth)


class Piece:
    """One piece of a group's path: ``p(u)`` for ``u`` in ``[0, U]``; immutable.

    Attributes: ``dim``, ``U`` (parameter length), ``length`` (arc length), ``b1, b2, b3``
    (per-axis bounds of ``|p'|, |p''|, |p'''|`` over the piece), ``g0, g1`` (``|p'|`` at the
    start and at the end: path speed = ``g du`` there), ``start``, ``end`` (points).
    """

    __slots__ = ("dim", "U", "length", "b1", "b2", "b3", "g0", "g1", "gmax", "start", "end")

    dim: int
    U: float
    length: float
    b1: Vec
    b2: Vec
    b3: Vec
    g0: float
    g1: float
    gmax: float  # an upper bound of |p'| over the piece (path speed = |p'| du)
    start: Vec
    end: Vec

    def at(self, u: float) -> tuple[Vec, Vec, Vec, Vec]:  # pragma: no cover - abstract
        """``(p, p', p'', p''')`` at ``u`` (clamped to ``[0, U]``)."""
        raise NotImplementedError

    def point(self, u: float) -> Vec:
        """``p(u)``."""
        return self.at(u)[0]

    def tangent_out(self) -> Vec:
        """Unit tangent at the end."""
        d1 = self.at(self.U)[1]
        n = math.sqrt(sum(x * x for x in d1))
        return tuple(x / n for x in d1)

    def tangent_in(self) -> Vec:
        """Unit tangent at the start."""
        d1 = self.at(0.0)[1]
        n = math.sqrt(sum(x * x for x in d1))
        return tuple(x / n for x in d1)

    def accel_in(self) -> Vec:
        """``p''(0) / g0^2``: the acceleration per squared path speed at the start (ddu = 0)."""
        d2 = self.at(0.0)[2]
        g = self.g0 * self.g0
        return tuple(x / g for x in d2)

    def accel_out(self) -> Vec:
        """``p''(U) / g1^2`` (see :meth:`accel_in`)."""
        d2 = self.at(self.U)[2]
        g = self.g1 * self.g1
        return tuple(x / g for x in d2)

    def _finish(self) -> None:
        p0 = self.at(0.0)
        p1 = self.at(self.U)
        self.start = p0[0]
        self.end = p1[0]
        self.g0 = math.sqrt(sum(x * x for x in p0[1]))
        self.g1 = math.sqrt(sum(x * x for x in p1[1]))


class LinePiece(Piece):
    """``p(u) = start + u d`` for ``u`` in ``[0, length]`` (``|d| = 1``)."""

    __slots__ = ("_p0", "_d", "_zero")

    def __init__(self, start: Sequence[float], direction: Sequence[float], length: float) -> None:
        self._p0 = tuple(float(x) for x in start)
        self._d = tuple(float(x) for x in direction)
        self.dim = len(self._p0)
        self.U = self.length = float(length)
        self._zero = (0.0,) * self.dim
        self.b1 = tuple(abs(x) for x in self._d)
        self.b2 = self.b3 = self._zero
        self.gmax = 1.0
        self._finish()

    @classmethod
    def between(cls, a: Sequence[float], b: Sequence[float]) -> LinePiece:
        """The line from ``a`` to ``b`` (PlanningError if they coincide)."""
        d = [float(y) - float(x) for x, y in zip(a, b, strict=True)]
        n = math.sqrt(sum(x * x for x in d))
        if not n > 0.0:
            raise PlanningError("end: a line needs end != start")
        return cls(a, [x / n for x in d], n)

    def at(self, u: float) -> tuple[Vec, Vec, Vec, Vec]:
        u = 0.0 if u < 0.0 else (self.U if u > self.U else u)
        p = tuple(x + u * d for x, d in zip(self._p0, self._d, strict=True))
        return p, self._d, self._zero, self._zero

    def trimmed(self, u0: float, u1: float) -> LinePiece:
        """The part ``[u0, u1]`` (re-parametrised from 0)."""
        p = self.at(u0)[0]
        out = LinePiece(p, self._d, u1 - u0)
        if u1 >= self.U:  # keep the programmed end point exactly
            out.end = self.end
        return out

    @property
    def direction(self) -> Vec:
        return self._d


class CircularPiece(Piece):
    """An arc or helix (the closed form of :class:`~motionplc.planning.paths.geometry.Arc` /
    ``Helix``) by arc length: ``p(u) = base + r (cos(ku) x + sin(ku) y) + c k u n``."""

    __slots__ = ("_base", "_x", "_y", "_n", "_r", "_c", "_k", "_exact_end")

    def __init__(self, seg: _Circular, end: Sequence[float] | None = None) -> None:
        self._base = tuple(float(v) for v in seg._base)
        self._x = tuple(float(v) for v in seg._x)
        self._y = tuple(float(v) for v in seg._y)
        self._n = tuple(float(v) for v in seg._n)
        self._r = float(seg._r)
        self._c = float(seg._c)
        self._k = float(seg._k)
        self.dim = len(self._base)
        self.U = self.length = float(seg._length)
        self._exact_end = None if end is None else tuple(float(v) for v in end)
        r, c, k = self._r, self._c, self._k
        w = [math.hypot(a, b) for a, b in zip(self._x, self._y, strict=True)]
        self.b1 = tuple(r * k * wi + abs(c * k * ni) for wi, ni in zip(w, self._n, strict=True))
        self.b2 = tuple(r * k * k * wi for wi in w)
        self.b3 = tuple(r * k**3 * wi for wi in w)
        self.gmax = 1.0  # arc length
        self._finish()
        if self._exact_end is not None:
            self.end = self._exact_end

    def at(self, u: float) -> tuple[Vec, Vec, Vec, Vec]:
        u = 0.0 if u < 0.0 else (self.U if u > self.U else u)
        k, r, c = self._k, self._r, self._c
        th = k * u
        cs, sn = math.cos(th), math.sin(th)
        x, y, n, b = self._x, self._y, self._n, self._base
        rk, rk2, rk3, ck = r * k, r * k * k, r * k * k * k, c * k
        p = tuple(
            bi + r * (cs * xi + sn * yi) + ck * u * ni
            for bi, xi, yi, ni in zip(b, x, y, n, strict=True)
        )
        d1 = tuple(rk * (cs * yi - sn * xi) + ck * ni for xi, yi, ni in zip(x, y, n, strict=True))
        d2 = tuple(-rk2 * (cs * xi + sn * yi) for xi, yi in zip(x, y, strict=True))
        d3 = tuple(rk3 * (sn * xi - cs * yi) for xi, yi in zip(x, y, strict=True))
        return p, d1, d2, d3


def _blend_tables() -> tuple[list[list[float]], list[list[float]], np.ndarray, np.ndarray]:
    """The blend's universal polynomials in ``sigma`` (blend.py's weights
    ``w = 10 s^3 - 15 s^4 + 6 s^5``, ``h = s - w / 2``): ``Fa = (1 - w)(2h - 1)`` and
    ``Fb = 2 w h`` with their derivatives 0..4 (coefficient lists, highest power first), and
    their dense samples (orders 1..4) for the bounds."""
    w = np.poly1d([6.0, -15.0, 10.0, 0.0, 0.0, 0.0])
    h = np.poly1d([1.0, 0.0]) - 0.5 * w
    fa = (1.0 - w) * (2.0 * h - 1.0)
    fb = 2.0 * w * h
    ca, cb = [], []
    for _ in range(5):
        ca.append([float(c) for c in fa.coeffs])
        cb.append([float(c) for c in fb.coeffs])
        fa, fb = fa.deriv(), fb.deriv()
    sig = np.linspace(0.0, 1.0, _BLEND_SAMPLES)
    sa = np.stack([np.polyval(ca[k], sig) for k in range(5)])
    sb = np.stack([np.polyval(cb[k], sig) for k in range(5)])
    sa.setflags(write=False)
    sb.setflags(write=False)
    return ca, cb, sa, sb


_FA, _FB, _SA, _SB = _blend_tables()
_GL_X, _GL_W = np.polynomial.legendre.leggauss(24)


class BlendPiece(Piece):
    """The G2 corner blend of two lines (exactly
    :class:`~motionplc.planning.paths.blend.CornerBlend` for line-line corners) as polynomials:
    with ``sigma = t / 2d`` and ``s = 2d h(sigma)``::

        p(t) = C + (1 - w)(s - d) ta + w s tb = C + d (Fa(sigma) ta + Fb(sigma) tb)

    ``ta``, ``tb``: unit directions of the incoming and outgoing line, ``C`` the corner, ``d`` the
    corner distance; ``t`` in ``[0, 2d]``, ``|p'| = 1`` at both ends. Deviation from the corner:
    ``d sin(theta / 2) / 2`` (``theta`` the deflection). Bounds: dense maxima of the derivative
    polynomials plus half a sample step times the next order's maximum (a true upper bound).
    """

    __slots__ = ("_c", "_ta", "_tb", "_d", "_scale", "_absd", "deflection")

    def __init__(
        self, corner: Sequence[float], ta: Sequence[float], tb: Sequence[float], d: float
    ) -> None:
        self._c = tuple(float(x) for x in corner)
        self._ta = tuple(float(x) for x in ta)
        self._tb = tuple(float(x) for x in tb)
        self._d = d = float(d)
        self.dim = len(self._c)
        self.U = 2.0 * d
        dot = sum(a * b for a, b in zip(self._ta, self._tb, strict=True))
        self.deflection = math.acos(max(-1.0, min(1.0, dot)))
        inv = 1.0 / (2.0 * d)
        self._scale = tuple(d * inv**k for k in range(5))  # order k: d (2d)^-k
        ta_a, tb_a = np.asarray(self._ta), np.asarray(self._tb)
        absd = np.abs(_SA[1:, :, None] * ta_a + _SB[1:, :, None] * tb_a)  # (4, samples, dim)
        self._absd = absd
        self.b1, self.b2, self.b3 = self._bounds(0, _BLEND_SAMPLES - 1)
        speed = np.linalg.norm(_SA[1][:, None] * ta_a + _SB[1][:, None] * tb_a, axis=1)
        half = 0.5 / (_BLEND_SAMPLES - 1)
        acc = np.linalg.norm(absd[1], axis=1).max()  # bounds |d^2 p / d sigma^2|
        self.gmax = float(speed.max() + half * acc * 1.01) * self._scale[1] * (1.0 + _BOUND_MARGIN)
        self._finish()
        # arc length: Gauss-Legendre on |p'| over 8 panels (|p'| dips sharply in the middle
        # of a near-reversal blend)
        sg = ((_GL_X[None, :] + 1.0) * 0.5 + np.arange(8)[:, None]) / 8.0
        va = np.polyval(_FA[1], sg.ravel())
        vb = np.polyval(_FB[1], sg.ravel())
        speed = np.linalg.norm(va[:, None] * ta_a + vb[:, None] * tb_a, axis=1) * self._scale[1]
        self.length = float(d / 8.0 * (np.tile(_GL_W, 8) @ speed))

    def _bounds(self, i0: int, i1: int) -> tuple[Vec, Vec, Vec]:
        """Bounds of the first three derivatives over the samples ``i0..i1`` (sigma =
        i / (samples - 1)), plus half a sample step times the next order's maximum there."""
        comb = self._absd[:, i0 : i1 + 1, :].max(axis=1)  # (4, dim), orders 1..4 in sigma
        half = 0.5 / (_BLEND_SAMPLES - 1)
        m = 1.0 + _BOUND_MARGIN
        sc = self._scale
        return tuple(
            tuple(float(x) * sc[k + 1] * m for x in comb[k] + half * comb[k + 1] * 1.01)
            for k in range(3)
        )  # type: ignore[return-value]

    def split(self, n: int) -> list[Piece]:
        """The blend as ``n`` consecutive parts (``n`` divides 256), each with the bounds of
        its own part: the speed caps rise where the curvature and its change are small."""
        if n == 1:
            return [self]
        step = (_BLEND_SAMPLES - 1) // n
        out: list[Piece] = []
        for i in range(n):
            i0, i1 = i * step, (i + 1) * step
            u0, u1 = self.U * i0 / (_BLEND_SAMPLES - 1), self.U * i1 / (_BLEND_SAMPLES - 1)
            out.append(SubPiece(self, u0, u1 if i < n - 1 else self.U, self._bounds(i0, i1)))
        return out

    @property
    def distance(self) -> float:
        """Corner distance ``d``."""
        return self._d

    @property
    def corner(self) -> Vec:
        """The programmed corner."""
        return self._c

    @property
    def deviation(self) -> float:
        """Distance from the corner to the blend: ``d sin(theta / 2) / 2``."""
        return 0.5 * self._d * math.sin(0.5 * self.deflection)

    def at(self, u: float) -> tuple[Vec, Vec, Vec, Vec]:
        u = 0.0 if u < 0.0 else (self.U if u > self.U else u)
        s = u / self.U
        ta, tb, sc = self._ta, self._tb, self._scale
        out = []
        for k in range(4):
            fa = 0.0
            for c in _FA[k]:
                fa = fa * s + c
            fb = 0.0
            for c in _FB[k]:
                fb = fb * s + c
            fa *= sc[k]
            fb *= sc[k]
            out.append(tuple(fa * a + fb * b for a, b in zip(ta, tb, strict=True)))
        p = tuple(ci + x for ci, x in zip(self._c, out[0], strict=True))
        return p, out[1], out[2], out[3]


class SubPiece(Piece):
    """The part ``[u0, u1]`` of another piece, re-parametrised to start at 0 (bounds: those of
    the whole piece, an upper bound)."""

    __slots__ = ("_base", "_u0")

    def __init__(
        self, base: Piece, u0: float, u1: float, bounds: tuple[Vec, Vec, Vec] | None = None
    ) -> None:
        if bounds is None:
            bounds = (base.b1, base.b2, base.b3)
        if isinstance(base, SubPiece):  # flatten
            u0, u1 = u0 + base._u0, u1 + base._u0
            base = base._base
        self._base = base
        self._u0 = float(u0)
        self.dim = base.dim
        self.U = float(u1) - float(u0)
        self.b1, self.b2, self.b3 = bounds
        self.gmax = base.gmax
        self._finish()
        if u1 >= base.U:
            self.end = base.end
        # arc length: proportional estimate refined by Gauss-Legendre on |p'|
        x, w = _GL_X, _GL_W
        tot = 0.0
        for xi, wi in zip(x, w, strict=True):
            d1 = self.at(0.5 * (xi + 1.0) * self.U)[1]
            tot += wi * math.sqrt(sum(v * v for v in d1))
        self.length = 0.5 * self.U * tot

    def at(self, u: float) -> tuple[Vec, Vec, Vec, Vec]:
        u = 0.0 if u < 0.0 else (self.U if u > self.U else u)
        return self._base.at(self._u0 + u)


class RunPiece(Piece):
    """Consecutive pieces that join tangentially with ``|p'| = 1`` on both sides of every joint
    (lines, arcs, line-line blends and their parts) as one piece whose parameter is the sum of
    theirs: one profile runs through the joints with a continuous parameter speed and
    acceleration (the axes' velocity and acceleration are continuous where the pieces join
    with equal curvature). Bounds: the maxima of the parts' bounds."""

    __slots__ = ("parts", "ends")

    def __init__(self, parts: Sequence[Piece]) -> None:
        flat: list[Piece] = []
        for pc in parts:
            flat.extend(pc.parts if isinstance(pc, RunPiece) else (pc,))
        self.parts = tuple(flat)
        ends = []
        u = 0.0
        for pc in flat:
            u += pc.U
            ends.append(u)
        self.ends = tuple(ends)
        first, last = flat[0], flat[-1]
        self.dim = first.dim
        self.U = u
        self.length = math.fsum(pc.length for pc in flat)
        # (the bounds of the given parts: a run given as a part carries its own maxima)
        self.b1 = tuple(map(max, *(pc.b1 for pc in parts))) if len(parts) > 1 else first.b1
        self.b2 = tuple(map(max, *(pc.b2 for pc in parts))) if len(parts) > 1 else first.b2
        self.b3 = tuple(map(max, *(pc.b3 for pc in parts))) if len(parts) > 1 else first.b3
        self.gmax = max(pc.gmax for pc in parts)
        self.start, self.end = first.start, last.end
        self.g0, self.g1 = first.g0, last.g1

    def locate(self, u: float) -> tuple[int, float]:
        """The part holding parameter ``u`` and where that part starts."""
        ends = self.ends
        i = bisect_right(ends, u)
        if i >= len(ends):
            i = len(ends) - 1
        return i, (ends[i - 1] if i else 0.0)

    def at(self, u: float) -> tuple[Vec, Vec, Vec, Vec]:
        u = 0.0 if u < 0.0 else (self.U if u > self.U else u)
        i, base = self.locate(u)
        if u >= self.U:
            out = self.parts[i].at(self.parts[i].U)
            return self.end, out[1], out[2], out[3]
        return self.parts[i].at(u - base)


class CurvePiece(Piece):
    """The part ``[u0, u1]`` of any :class:`~motionplc.planning.paths.base.Path` (default: the
    whole path), re-parametrised to start at 0 and evaluated through the path (numpy; slower
    than the closed forms). Bounds: dense maxima of the derivatives plus half a sample step
    times the next order's maximum (the third derivative's change between samples bounds its
    own)."""

    __slots__ = ("_path", "_u0", "_u1", "_u1_in", "_fast")

    def __init__(
        self, path: Path, u0: float = 0.0, u1: float | None = None, samples: int = 2049
    ) -> None:
        self._path = path
        self._fast = _blend_evaluator(path)
        self._u0 = float(u0)
        u1 = float(path.u_end) if u1 is None else float(u1)
        self._u1 = u1
        self._u1_in = u1 - 1e-12 * (1.0 + abs(u1)) if u1 < float(path.u_end) else u1
        self.dim = int(path.dim)
        self.U = u1 - self._u0
        uu = np.linspace(self._u0, self._u1_in, samples)
        ders = path.derivatives(uu, 3)
        step = self.U / (samples - 1)
        m = 1.0 + _BOUND_MARGIN
        b = [np.abs(ders[k]).max(axis=0) for k in (1, 2, 3)]
        d3 = np.abs(np.diff(ders[3], axis=0)).max(axis=0)
        self.b1 = tuple(float(x) * m for x in b[0] + 0.5 * step * b[1] * 1.01)
        self.b2 = tuple(float(x) * m for x in b[1] + 0.5 * step * b[2] * 1.01)
        self.b3 = tuple(float(x) * m for x in b[2] + 0.5 * d3 * 1.01)
        sp = np.linalg.norm(ders[1], axis=1).max()
        self.gmax = float(sp + 0.5 * step * np.linalg.norm(b[1]) * 1.01) * m
        self._finish()
        speed = np.linalg.norm(ders[1], axis=1)
        self.length = (
            float(np.trapezoid(speed, uu))
            if hasattr(np, "trapezoid")
            else float(
                np.trapz(speed, uu)  # noqa: NPY201 - numpy < 2
            )
        )

    def at(self, u: float) -> tuple[Vec, Vec, Vec, Vec]:
        # one-sided at the end: a section boundary belongs to this piece, not the next one
        uu = self._u0 + (0.0 if u < 0.0 else u)
        if uu >= self._u1:
            uu = self._u1_in
        if self._fast is not None:
            return self._fast(uu)
        ders = self._path.derivatives(uu, 3)
        return tuple(tuple(float(x) for x in np.ravel(d)) for d in ders)  # type: ignore[return-value]


def _segment_evaluator(seg: Path):  # noqa: ANN202 - a closure
    """``u -> (p, d1, d2, d3)`` of a Line or an arc / helix with plain floats, the operations
    of the segment's numpy ``_eval`` element by element (None: another kind)."""
    if isinstance(seg, Line):
        p0 = tuple(float(x) for x in seg._start)  # noqa: SLF001
        dr = tuple(float(x) for x in seg._dir)  # noqa: SLF001
        zero = (0.0,) * len(p0)

        def line(u: float) -> tuple[Vec, Vec, Vec, Vec]:
            return tuple(a + u * b for a, b in zip(p0, dr, strict=True)), dr, zero, zero

        return line
    if isinstance(seg, _Circular):
        k, r, c = float(seg._k), float(seg._r), float(seg._c)  # noqa: SLF001
        base = tuple(float(v) for v in seg._base)  # noqa: SLF001
        xs = tuple(float(v) for v in seg._x)  # noqa: SLF001
        ys = tuple(float(v) for v in seg._y)  # noqa: SLF001
        ns = tuple(float(v) for v in seg._n)  # noqa: SLF001
        rk, rk2, rk3, ck = r * k, -r * k * k, r * k**3, c * k

        def circ(u: float) -> tuple[Vec, Vec, Vec, Vec]:
            th = k * u
            cs, sn = math.cos(th), math.sin(th)
            p = tuple(b + r * (cs * x + sn * y) for b, x, y in zip(base, xs, ys, strict=True))
            d1 = tuple(rk * (cs * y - sn * x) for x, y in zip(xs, ys, strict=True))
            if c:
                p = tuple(v + ck * u * n for v, n in zip(p, ns, strict=True))
                d1 = tuple(v + ck * n for v, n in zip(d1, ns, strict=True))
            d2 = tuple(rk2 * (cs * x + sn * y) for x, y in zip(xs, ys, strict=True))
            d3 = tuple(rk3 * (sn * x - cs * y) for x, y in zip(xs, ys, strict=True))
            return p, d1, d2, d3

        return circ
    return None


def _blend_evaluator(path: Path):  # noqa: ANN202 - a closure
    """A plain-float evaluation of a :class:`~motionplc.planning.paths.blend.CornerBlend`
    between lines and arcs (``CornerBlend._derivs`` for one parameter value, its operations in
    the same order): the per-cycle sampling of a curved corner blend without numpy (~0.5 ms
    per call through the path's vectorised evaluation). None for any other path."""
    from motionplc.planning.paths.blend import CornerBlend, _weights

    if type(path) is not CornerBlend:
        return None
    ea = _segment_evaluator(path._a)  # noqa: SLF001
    eb = _segment_evaluator(path._b)  # noqa: SLF001
    if ea is None or eb is None:
        return None
    d = float(path._d)  # noqa: SLF001
    two_d = 2.0 * d
    u_end = float(path.u_end)
    td2, td3 = two_d**2, two_d**3

    def blend(t: float) -> tuple[Vec, Vec, Vec, Vec]:
        t = 0.0 if t < 0.0 else (u_end if t > u_end else t)
        sig = t / two_d
        w, h = _weights(sig, 3)  # type: ignore[arg-type]
        s = two_d * h[0]
        s = 0.0 if s < 0.0 else (d if s > d else s)
        a0, a1, a2, a3 = ea(s)
        b0, b1, b2, b3 = eb(s)
        w0, s1 = w[0], h[1]
        w1, s2, w2 = w[1] / two_d, h[2] / two_d, w[2] / td2
        s3, w3 = h[3] / td2, w[3] / td3
        s1c = s1**3
        p, v, acc, jrk = [], [], [], []
        for A0, A1, A2, A3, B0, B1, B2, B3 in zip(a0, a1, a2, a3, b0, b1, b2, b3, strict=True):
            D0, D1, D2, D3 = B0 - A0, B1 - A1, B2 - A2, B3 - A3
            p.append(A0 + w0 * D0)
            Ad1, Dd1 = A1 * s1, D1 * s1
            v.append(Ad1 + w1 * D0 + w0 * Dd1)
            Ad2 = A2 * s1 * s1 + A1 * s2
            Dd2 = D2 * s1 * s1 + D1 * s2
            acc.append(Ad2 + w2 * D0 + 2.0 * w1 * Dd1 + w0 * Dd2)
            Ad3 = A3 * s1c + 3.0 * A2 * s1 * s2 + A1 * s3
            Dd3 = D3 * s1c + 3.0 * D2 * s1 * s2 + D1 * s3
            jrk.append(Ad3 + w3 * D0 + 3.0 * w2 * Dd1 + 3.0 * w1 * Dd2 + w0 * Dd3)
        return tuple(p), tuple(v), tuple(acc), tuple(jrk)

    return blend


def piece_for(seg: Path) -> Piece:
    """The fastest piece implementation for a path segment."""
    if isinstance(seg, Line):
        return LinePiece(seg.start, seg.direction, seg.length)
    if isinstance(seg, _Circular):
        return CircularPiece(seg, seg.end)
    return CurvePiece(seg)


def path_caps(
    piece: Piece,
    v_max: Sequence[float],
    a_max: Sequence[float],
    j_max: Sequence[float],
    v_prog: float = math.inf,
    a_prog: float = math.inf,
    j_prog: float = math.inf,
    v_share: float = 0.7,
    j_split: float = 0.5,
) -> tuple[float, float, float]:
    """Constant caps ``(V, A, J)`` of ``du, |ddu|, |dddu|`` on ``piece`` that keep every axis
    within its limits (the inequalities of the module docstring), and within the programmed
    path speed, acceleration and jerk (``v_prog`` etc.; converted with the bound of ``|p'|``,
    1 on the arc-length pieces).

    ``V`` is the highest speed at which the curvature terms use at most ``v_share`` of every
    axis' acceleration and jerk budget (``B2 V^2 <= v_share a``, ``B3 V^3 <= v_share j``): at
    ``v_share = 0.95`` a blend is passed at ``0.95^(1/3)`` (jerk-bound) or ``0.95^(1/2)``
    (acceleration-bound) of the highest constant speed the bounds allow. ``A`` takes what is
    left of the acceleration budget and ``(1 - j_split)`` of the jerk left for the mixed term
    ``3 B2 V A``; ``J`` the rest. On straight pieces (``B2 = B3 = 0``) the whole budgets go to
    ``A`` and ``J``. All caps are > 0 (a PlanningError if a limit leaves no motion).
    """
    gmax = piece.gmax
    V = v_prog / gmax if v_prog != math.inf else math.inf
    for b1, b2, b3, v, a, j in zip(piece.b1, piece.b2, piece.b3, v_max, a_max, j_max, strict=True):
        if b1 > 0.0:
            V = min(V, v / b1)
        if b2 > 0.0:
            V = min(V, math.sqrt(v_share * a / b2))
        if b3 > 0.0 and j != math.inf:
            V = min(V, (v_share * j / b3) ** (1.0 / 3.0))
    A = a_prog / gmax if a_prog != math.inf else math.inf
    for b1, b2, b3, a, j in zip(piece.b1, piece.b2, piece.b3, a_max, j_max, strict=True):
        if b1 > 0.0:
            A = min(A, (a - b2 * V * V) / b1)
        if b2 > 0.0 and j != math.inf and V > 0.0:
            A = min(A, (1.0 - j_split) * (j - b3 * V**3) / (3.0 * b2 * V))
    J = j_prog / gmax if j_prog != math.inf else math.inf
    for b1, b2, b3, j in zip(piece.b1, piece.b2, piece.b3, j_max, strict=True):
        if b1 > 0.0 and j != math.inf:
            J = min(J, (j - 3.0 * b2 * V * A - b3 * V**3) / b1)
    if not (V > 0.0 and A > 0.0 and J > 0.0) or math.isinf(V) and math.isinf(A):
        raise PlanningError(
            f"the axis limits leave no motion on this piece (V={V:g}, A={A:g}, J={J:g})"
        )
    return V, A, J
