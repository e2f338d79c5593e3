"""Arc-length parametrised primitives: straight lines, circular arcs and helices.

Every primitive here is a :class:`PathSegment`: ``u`` *is* the arc length, so ``u_end ==
length`` exactly, ``|p'(u)| == 1`` and the arc length from 0 to ``u`` is ``u`` (no numerical
integration anywhere). Position and the derivatives of order 1..3 with respect to ``u`` are
closed forms, evaluated vectorised over any 1-D array of parameters.

* :class:`Line` — ``p(u) = start + u * t``, any dimension >= 1.
* :class:`Arc` — a circular arc in a plane of R^n (n >= 2):
  ``p(u) = center + r (cos(u/r) x + sin(u/r) y)`` with orthonormal ``x`` (centre to start) and
  ``y`` (start tangent). Constructors: :meth:`Arc.from_center` (end points + centre, PLCopen
  CircMode CENTER), :meth:`Arc.from_three_points` (start, a point on the arc, end; BORDER),
  :meth:`Arc.from_radius` (end points + radius + plane; RADIUS), :meth:`Arc.from_tangent`
  (end points + start tangent: seed 000's circle, Reading A), :meth:`Arc.full_circle`.
* :class:`Helix` — circular motion about an axis combined with a linear advance along it (3-D).

Bad input raises :class:`~motionplc.errors.PlanningError` naming the field (NaN, mismatched
dimensions, zero radius, collinear points, ...). Everything is immutable.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from motionplc.errors import PlanningError
from motionplc.planning.paths.base import Path, as_param

__all__ = ["Arc", "Helix", "Line", "PathSegment"]

ArrayLike = Sequence[float] | np.ndarray

_TWO_PI = 2.0 * math.pi
# Relative tolerance of geometric consistency checks (point on circle, orthogonality).
_GEOM_RTOL = 1e-9


# ---------------------------------------------------------------------------------------------
# helpers shared by the path modules (private to the package)


def freeze(obj: object, **attrs: Any) -> None:
    """Set the slots of an immutable object (arrays are stored read-only)."""
    for name, value in attrs.items():
        if isinstance(value, np.ndarray):
            value = value.copy()
            value.setflags(write=False)
        object.__setattr__(obj, name, value)


class Immutable:
    """Mixin: attributes are set once in ``__init__`` (through :func:`freeze`)."""

    __slots__ = ()

    def __setattr__(self, name: str, value: object) -> None:
        raise AttributeError(f"{type(self).__name__} is immutable (cannot set {name!r})")

    def __delattr__(self, name: str) -> None:
        raise AttributeError(f"{type(self).__name__} is immutable (cannot delete {name!r})")


def as_vector(name: str, value: object, dim: int | None = None, min_dim: int = 1) -> np.ndarray:
    """``value`` as a finite 1-D float vector (``dim`` entries when given), else PlanningError."""
    try:
        arr = np.array(value, dtype=float)
    except (TypeError, ValueError):
        raise PlanningError(f"{name}: must be a vector of numbers, got {value!r}") from None
    if arr.ndim != 1 or arr.size < min_dim:
        raise PlanningError(
            f"{name}: must be a 1-D vector with at least {min_dim} entries, got shape {arr.shape}"
        )
    if dim is not None and arr.size != dim:
        raise PlanningError(f"{name}: must have {dim} entries (the path dimension), got {arr.size}")
    if not np.all(np.isfinite(arr)):
        raise PlanningError(f"{name}: entries must be finite, got {arr.tolist()!r}")
    return arr


def as_scalar(
    name: str, value: object, *, low: float, low_open: bool, high: float = math.inf
) -> float:
    """``value`` as a float in ``(low|[low, high]``, else PlanningError naming the range."""
    if isinstance(value, bool) or not isinstance(value, (int, float, np.floating, np.integer)):
        raise PlanningError(f"{name}: must be a number, got {value!r}")
    v = float(value)
    bracket = "(" if low_open else "["
    ok = math.isfinite(v) and (v > low if low_open else v >= low) and v <= high
    if not ok:
        raise PlanningError(f"{name}: must be in {bracket}{low!r}, {high!r}], got {v!r}")
    return v


def check_order(order: int) -> int:
    """The derivative order as an int in 0..3, else PlanningError naming ``order``."""
    if isinstance(order, bool) or not isinstance(order, (int, np.integer)) or not 0 <= order <= 3:
        raise PlanningError(f"order: derivative order must be 0, 1, 2 or 3, got {order!r}")
    return int(order)


def param_1d(u: float | np.ndarray, u_end: float) -> tuple[np.ndarray, bool]:
    """``u`` checked (:func:`as_param`) as a 1-D array, plus whether the input was a scalar."""
    arr = as_param(u, u_end)
    if arr.ndim > 1:
        raise PlanningError(f"u: must be a float or a 1-D array, got shape {arr.shape}")
    return np.atleast_1d(arr), arr.ndim == 0


def unit(name: str, v: np.ndarray) -> np.ndarray:
    n = float(np.linalg.norm(v))
    if not n > 0.0:
        raise PlanningError(f"{name}: must be a non-zero vector, got {v.tolist()!r}")
    return v / n


def _scale(*points: np.ndarray) -> float:
    return max(1.0, *(float(np.max(np.abs(p))) for p in points))


# ---------------------------------------------------------------------------------------------


class PathSegment(Immutable, Path):
    """A primitive parametrised by arc length: ``u_end == length`` and ``|p'(u)| == 1``.

    Guarantees: ``arc_length(u) == u`` exactly; :meth:`evaluate` is a closed form for orders
    0..3; :meth:`trim` returns a segment of the same kind covering ``[u0, u1]`` exactly
    (re-parametrised to start at 0).
    """

    __slots__ = ()

    @property
    def u_end(self) -> float:
        return self.length

    @property
    def length(self) -> float:
        return float(self._length)  # type: ignore[attr-defined]

    def u_at_arc_length(self, s: float | np.ndarray) -> float | np.ndarray:
        """The parameter at arc length ``s`` (identity: the parameter is the arc length)."""
        arr = as_param(s, self.length)
        return float(arr) if arr.ndim == 0 else arr

    def evaluate(self, u: float | np.ndarray, order: int = 0) -> np.ndarray:
        """The ``order``-th derivative (0..3) of the position with respect to arc length ``u``."""
        order = check_order(order)
        uu, scalar = param_1d(u, self.length)
        out = self._eval(uu, order)
        return out[0] if scalar else out

    def _eval(self, u: np.ndarray, order: int) -> np.ndarray:  # pragma: no cover - abstract
        raise NotImplementedError

    def _eval_orders(self, u: np.ndarray, orders: tuple[int, ...]) -> tuple[np.ndarray, ...]:
        """Unchecked evaluation of 1-D ``u`` (already in range) for several orders."""
        return tuple(self._eval(u, k) for k in orders)

    def trim(self, u0: float, u1: float) -> PathSegment:
        """The piece ``[u0, u1]`` of this segment (``0 <= u0 < u1 <= length``), same kind."""
        a = as_scalar("u0", u0, low=0.0, low_open=False, high=self.length)
        b = as_scalar("u1", u1, low=a, low_open=True, high=self.length)
        return self._trim(a, b)

    def _trim(self, u0: float, u1: float) -> PathSegment:  # pragma: no cover - abstract
        raise NotImplementedError


class Line(PathSegment):
    """Straight line from ``start`` to ``end`` (any dimension >= 1), parametrised by arc length.

    ``p(u) = start + u * direction`` for ``u`` in ``[0, |end - start|]``; ``p'`` is the unit
    direction, ``p'' = p''' = 0``. A zero-length line is a PlanningError naming ``end``.
    """

    __slots__ = ("_start", "_dir", "_length")

    def __init__(self, start: ArrayLike, end: ArrayLike) -> None:
        p0 = as_vector("start", start)
        p1 = as_vector("end", end, dim=p0.size)
        d = p1 - p0
        length = float(np.linalg.norm(d))
        if not length > 1e-15 * _scale(p0, p1):
            raise PlanningError(f"end: a line needs end != start, got both {p0.tolist()!r}")
        freeze(self, _start=p0, _dir=d / length, _length=length)

    @classmethod
    def _from_dir(cls, start: np.ndarray, direction: np.ndarray, length: float) -> Line:
        obj = object.__new__(cls)
        freeze(obj, _start=start, _dir=direction, _length=float(length))
        return obj

    @property
    def dim(self) -> int:
        return int(self._start.size)

    @property
    def direction(self) -> np.ndarray:
        """Unit direction (read-only)."""
        return self._dir

    def _eval(self, u: np.ndarray, order: int) -> np.ndarray:
        if order == 0:
            return self._start + u[:, None] * self._dir
        if order == 1:
            return np.broadcast_to(self._dir, (u.size, self.dim)).copy()
        return np.zeros((u.size, self.dim))

    def _trim(self, u0: float, u1: float) -> Line:
        return Line._from_dir(self._start + u0 * self._dir, self._dir, u1 - u0)

    def __repr__(self) -> str:
        return f"Line(start={self._start.tolist()!r}, end={self.end.tolist()!r})"


class _Circular(PathSegment):
    """Shared closed form of arcs and helices:

    ``p(u) = base + r (cos(k u) x + sin(k u) y) + c k u n`` with ``k = 1/sqrt(r^2 + c^2)``
    (``c = pitch / 2 pi``; ``c = 0`` for an arc, then ``n`` is unused).
    """

    __slots__ = ("_base", "_x", "_y", "_n", "_r", "_c", "_k", "_length")

    def _set(
        self,
        base: np.ndarray,
        x: np.ndarray,
        y: np.ndarray,
        n: np.ndarray | None,
        r: float,
        c: float,
        angle: float,
    ) -> None:
        k = 1.0 / math.hypot(r, c)
        freeze(
            self,
            _base=base,
            _x=x,
            _y=y,
            _n=np.zeros_like(base) if n is None else n,
            _r=float(r),
            _c=float(c),
            _k=k,
            _length=float(angle) / k,
        )

    @property
    def dim(self) -> int:
        return int(self._base.size)

    @property
    def radius(self) -> float:
        return self._r

    @property
    def angle(self) -> float:
        """Swept angle [rad] (> 0)."""
        return self._length * self._k

    @property
    def x_axis(self) -> np.ndarray:
        """Unit vector from the axis to the start point (read-only)."""
        return self._x

    @property
    def y_axis(self) -> np.ndarray:
        """Unit vector of the circular part of the start tangent (read-only)."""
        return self._y

    def _eval(self, u: np.ndarray, order: int) -> np.ndarray:
        k, r = self._k, self._r
        th = k * u
        c, s = np.cos(th)[:, None], np.sin(th)[:, None]
        x, y = self._x, self._y
        if order == 0:
            out = self._base + r * (c * x + s * y)
            if self._c:
                out = out + (self._c * k) * u[:, None] * self._n
            return out
        if order == 1:
            out = (r * k) * (c * y - s * x)
            if self._c:
                out = out + (self._c * k) * self._n
            return out
        if order == 2:
            return (-r * k * k) * (c * x + s * y)
        return (r * k**3) * (s * x - c * y)

    def _rotated(self, u0: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        th = self._k * u0
        c, s = math.cos(th), math.sin(th)
        x = c * self._x + s * self._y
        y = c * self._y - s * self._x
        base = self._base + (self._c * th) * self._n
        return base, x, y


class Arc(_Circular):
    """Circular arc in a plane of R^n (n >= 2), parametrised by arc length.

    ``p(u) = center + radius (cos(u/radius) x_axis + sin(u/radius) y_axis)`` for ``u`` in
    ``[0, radius * angle]``, with orthonormal ``x_axis`` (centre -> start) and ``y_axis``
    (start tangent). ``angle`` may exceed 2 pi (several turns). ``|p'| = 1``,
    ``|p''| = 1/radius`` (pointing to the centre), ``|p'''| = 1/radius^2``.

    The primary constructor takes the frame directly; ``x_axis`` and ``y_axis`` must be
    orthogonal (they are normalised). Most users want one of the classmethods.
    """

    __slots__ = ()

    def __init__(
        self,
        center: ArrayLike,
        radius: float,
        x_axis: ArrayLike,
        y_axis: ArrayLike,
        angle: float,
    ) -> None:
        c = as_vector("center", center, min_dim=2)
        r = as_scalar("radius", radius, low=0.0, low_open=True)
        x = unit("x_axis", as_vector("x_axis", x_axis, dim=c.size))
        y = unit("y_axis", as_vector("y_axis", y_axis, dim=c.size))
        if abs(float(x @ y)) > _GEOM_RTOL:
            raise PlanningError(
                f"y_axis: must be orthogonal to x_axis, got cos(angle) = {float(x @ y)!r}"
            )
        y = unit("y_axis", y - (x @ y) * x)
        phi = as_scalar("angle", angle, low=0.0, low_open=True)
        self._set(c, x, y, None, r, 0.0, phi)

    @property
    def center(self) -> np.ndarray:
        return self._base

    def _trim(self, u0: float, u1: float) -> Arc:
        base, x, y = self._rotated(u0)
        obj = object.__new__(Arc)
        obj._set(base, x, y, None, self._r, 0.0, (u1 - u0) * self._k)
        return obj

    def __repr__(self) -> str:
        return (
            f"Arc(center={self._base.tolist()!r}, radius={self._r!r}, "
            f"start={self.start.tolist()!r}, end={self.end.tolist()!r}, angle={self.angle!r})"
        )

    # -- constructors --------------------------------------------------------------------------

    @classmethod
    def from_center(
        cls,
        start: ArrayLike,
        end: ArrayLike,
        center: ArrayLike,
        *,
        normal: ArrayLike | None = None,
        clockwise: bool = False,
    ) -> Arc:
        """Arc from ``start`` to ``end`` about ``center`` (PLCopen CircMode CENTER), 2-D or 3-D.

        The arc turns counter-clockwise about ``normal`` (right-hand rule), or clockwise when
        ``clockwise`` is set. In 2-D ``normal`` is +z (do not pass it). In 3-D ``normal`` may be
        omitted when start, centre and end are not collinear: it is then
        ``(start - center) x (end - center)``, i.e. counter-clockwise is the short way (< pi).
        ``end`` must lie on the circle (``|end - center| = |start - center|`` to 1e-9
        relative); ``start == end`` is rejected (use :meth:`full_circle`).
        """
        p0 = as_vector("start", start, min_dim=2)
        p1 = as_vector("end", end, dim=p0.size)
        c = as_vector("center", center, dim=p0.size)
        r = float(np.linalg.norm(p0 - c))
        if not r > 1e-15 * _scale(p0, c):
            raise PlanningError("center: must differ from start (zero radius)")
        r1 = float(np.linalg.norm(p1 - c))
        if abs(r1 - r) > _GEOM_RTOL * max(r, 1.0):
            raise PlanningError(
                f"end: must lie on the circle, |end - center| = {r1!r} but radius "
                f"|start - center| = {r!r}"
            )
        if np.linalg.norm(p1 - p0) <= 1e-12 * r:
            raise PlanningError("end: must differ from start (use Arc.full_circle for a circle)")
        x = (p0 - c) / r
        e = (p1 - c) / r1
        nrm = _plane_normal(p0.size, normal, x, e)
        if nrm is not None and max(abs(float(x @ nrm)), abs(float(e @ nrm))) > _GEOM_RTOL:
            raise PlanningError("normal: must be orthogonal to start - center and end - center")
        y = _in_plane_perp(nrm, x)
        if clockwise:
            y = -y
        phi = math.atan2(float(e @ y), float(e @ x)) % _TWO_PI
        return cls(c, r, x, y, phi)

    @classmethod
    def from_three_points(cls, start: ArrayLike, via: ArrayLike, end: ArrayLike) -> Arc:
        """The arc from ``start`` through ``via`` to ``end`` (PLCopen CircMode BORDER), n >= 2.

        Collinear or coincident points are a PlanningError naming ``via`` (or ``end``).
        """
        p0 = as_vector("start", start, min_dim=2)
        pv = as_vector("via", via, dim=p0.size)
        p1 = as_vector("end", end, dim=p0.size)
        a, b = pv - p0, p1 - p0
        aa, bb, ab = float(a @ a), float(b @ b), float(a @ b)
        tiny = (1e-12 * _scale(p0, pv, p1)) ** 2
        if aa <= tiny:
            raise PlanningError("via: must differ from start")
        if bb <= tiny:
            raise PlanningError("end: must differ from start (use Arc.full_circle for a circle)")
        if float(np.dot(p1 - pv, p1 - pv)) <= tiny:
            raise PlanningError("via: must differ from end")
        b_perp = b - (ab / aa) * a
        gram = aa * float(b_perp @ b_perp)  # = aa bb - ab^2 without cancellation
        if gram <= (1e-9) ** 2 * aa * bb:
            raise PlanningError("via: start, via and end are collinear (no circle through them)")
        # circumcentre: p0 + alpha a + beta b with |c - p0| = |c - pv| = |c - p1|
        alpha = bb * (aa - ab) / (2.0 * gram)
        beta = aa * (bb - ab) / (2.0 * gram)
        c = p0 + alpha * a + beta * b
        r = float(np.linalg.norm(p0 - c))
        x = (p0 - c) / r
        v, e = (pv - c) / r, (p1 - c) / r
        # y: the in-plane perpendicular of x, oriented so that via comes before end
        ref = v - (v @ x) * x
        if np.linalg.norm(ref) < np.linalg.norm(e - (e @ x) * x):
            ref = e - (e @ x) * x
        y = ref / np.linalg.norm(ref)
        phi_v = math.atan2(float(v @ y), float(v @ x)) % _TWO_PI
        phi_e = math.atan2(float(e @ y), float(e @ x)) % _TWO_PI
        if phi_v > phi_e:
            y = -y
            phi_e = _TWO_PI - phi_e
        return cls(c, r, x, y, phi_e)

    @classmethod
    def from_radius(
        cls,
        start: ArrayLike,
        end: ArrayLike,
        radius: float,
        *,
        normal: ArrayLike | None = None,
        clockwise: bool = False,
        large: bool = False,
    ) -> Arc:
        """Arc of ``radius`` from ``start`` to ``end`` in the plane of ``normal`` (CircMode RADIUS).

        2-D: the plane is the plane itself (+z normal; do not pass ``normal``); 3-D: ``normal``
        is required and must be orthogonal to the chord. The arc turns counter-clockwise about
        the normal (clockwise when ``clockwise``); of the two such arcs the one shorter than a
        half circle is taken, the longer one when ``large``. ``radius`` must be at least half
        the chord.
        """
        p0 = as_vector("start", start, min_dim=2)
        p1 = as_vector("end", end, dim=p0.size)
        r = as_scalar("radius", radius, low=0.0, low_open=True)
        chord = p1 - p0
        cl = float(np.linalg.norm(chord))
        if not cl > 1e-12 * _scale(p0, p1):
            raise PlanningError("end: must differ from start (use Arc.full_circle for a circle)")
        if p0.size == 3 and normal is None:
            raise PlanningError("normal: required for a 3-D arc given by its radius (the plane)")
        ch = chord / cl
        nrm = _plane_normal(p0.size, normal, ch, None)
        if nrm is not None and abs(float(ch @ nrm)) > _GEOM_RTOL:
            raise PlanningError("normal: must be orthogonal to end - start")
        half = cl / 2.0
        if r < half * (1.0 - 1e-12):
            raise PlanningError(
                f"radius: must be at least half the chord |end - start| / 2 = {half!r}, got {r!r}"
            )
        left = _in_plane_perp(nrm, ch)  # rotated +90 deg about the normal
        h = math.sqrt(max(r * r - half * half, 0.0))
        side = 1.0 if (clockwise == large) else -1.0  # ccw short: centre on the left
        c = p0 + half * ch + side * h * left
        x = (p0 - c) / np.linalg.norm(p0 - c)
        y = _in_plane_perp(nrm, x)
        if clockwise:
            y = -y
        e = (p1 - c) / np.linalg.norm(p1 - c)
        phi = math.atan2(float(e @ y), float(e @ x)) % _TWO_PI
        return cls(c, float(np.linalg.norm(p0 - c)), x, y, phi)

    @classmethod
    def from_tangent(cls, start: ArrayLike, end: ArrayLike, tangent: ArrayLike) -> Arc:
        """The arc from ``start`` to ``end`` whose start tangent is ``tangent`` (any n >= 2).

        Seed 000's circle (its point list ``{P1, v}``), "Reading A": the local frame has x'
        from the centre to the start point and y' along ``v``, so ``v`` is the start tangent;
        only its direction matters. With chord ``c = end - start`` and ``c_perp`` its part
        orthogonal to ``v``: ``r = |c|^2 / (2 |c_perp|)``, swept angle
        ``2 atan2(|c_perp|, c . v/|v|)`` (in (0, 2 pi)). A tangent parallel to the chord has no
        circle (PlanningError naming ``tangent``).
        """
        p0 = as_vector("start", start, min_dim=2)
        p1 = as_vector("end", end, dim=p0.size)
        y = unit("tangent", as_vector("tangent", tangent, dim=p0.size))
        chord = p1 - p0
        cl = float(np.linalg.norm(chord))
        if not cl > 1e-12 * _scale(p0, p1):
            raise PlanningError("end: must differ from start")
        perp = chord - (chord @ y) * y
        pn = float(np.linalg.norm(perp))
        if pn <= 1e-9 * cl:
            raise PlanningError("tangent: is parallel to end - start (a straight line, no circle)")
        x = -perp / pn
        r = cl * cl / (2.0 * pn)
        phi = 2.0 * math.atan2(pn, float(chord @ y))
        return cls(p0 - r * x, r, x, y, phi)

    @classmethod
    def full_circle(
        cls,
        start: ArrayLike,
        center: ArrayLike,
        *,
        normal: ArrayLike | None = None,
        clockwise: bool = False,
        turns: float = 1.0,
    ) -> Arc:
        """A full circle (``turns`` turns, default 1) starting and ending at ``start``.

        2-D: counter-clockwise (clockwise when ``clockwise``); 3-D: ``normal`` is required,
        counter-clockwise about it, and must be orthogonal to ``start - center``.
        """
        p0 = as_vector("start", start, min_dim=2)
        c = as_vector("center", center, dim=p0.size)
        n_turns = as_scalar("turns", turns, low=0.0, low_open=True)
        r = float(np.linalg.norm(p0 - c))
        if not r > 1e-15 * _scale(p0, c):
            raise PlanningError("center: must differ from start (zero radius)")
        if p0.size == 3 and normal is None:
            raise PlanningError("normal: required for a 3-D full circle (the plane)")
        x = (p0 - c) / r
        nrm = _plane_normal(p0.size, normal, x, None)
        if nrm is not None and abs(float(x @ nrm)) > _GEOM_RTOL:
            raise PlanningError("normal: must be orthogonal to start - center")
        y = _in_plane_perp(nrm, x)
        if clockwise:
            y = -y
        return cls(c, r, x, y, _TWO_PI * n_turns)


def _plane_normal(
    dim: int, normal: ArrayLike | None, x: np.ndarray, e: np.ndarray | None
) -> np.ndarray | None:
    """The unit plane normal for 3-D (None in 2-D, where +z is implied)."""
    if dim == 2:
        if normal is not None:
            raise PlanningError("normal: not used for a 2-D arc (the plane is +z); omit it")
        return None
    if dim != 3:
        raise PlanningError(
            f"start: this constructor needs a 2-D or 3-D arc, got dimension {dim} "
            "(use Arc.from_three_points or the frame constructor)"
        )
    if normal is not None:
        return unit("normal", as_vector("normal", normal, dim=3))
    assert e is not None
    n = np.cross(x, e)
    nn = float(np.linalg.norm(n))
    if nn <= 1e-9:
        raise PlanningError(
            "normal: required when start, center and end are collinear (the plane is undefined)"
        )
    return n / nn


def _in_plane_perp(nrm: np.ndarray | None, x: np.ndarray) -> np.ndarray:
    """``x`` rotated by +90 degrees about the normal (2-D: about +z), unit."""
    if nrm is None:
        return np.array([-x[1], x[0]])
    y = np.cross(nrm, x)
    return y / np.linalg.norm(y)


class Helix(_Circular):
    """Helix in 3-D, parametrised by arc length.

    Turns ``angle`` radians counter-clockwise about ``axis`` (the right-hand rule; clockwise
    when ``clockwise``) around the axis line through ``center``, starting at ``start``, and
    advances ``pitch`` metres along ``axis`` per turn (negative: against it; 0: a circle).
    With ``rho = |start - center|`` measured orthogonally to the axis and
    ``c = pitch / (2 pi)``: ``u_end = angle * sqrt(rho^2 + c^2)`` exactly, ``|p'| = 1`` and the
    curvature is ``rho / (rho^2 + c^2)``.
    """

    __slots__ = ()

    def __init__(
        self,
        start: ArrayLike,
        center: ArrayLike,
        axis: ArrayLike,
        angle: float,
        pitch: float,
        *,
        clockwise: bool = False,
    ) -> None:
        p0 = as_vector("start", start, dim=3)
        c0 = as_vector("center", center, dim=3)
        n = unit("axis", as_vector("axis", axis, dim=3))
        phi = as_scalar("angle", angle, low=0.0, low_open=True)
        pitch_f = as_scalar("pitch", pitch, low=-math.inf, low_open=True)
        d = p0 - c0
        radial = d - (d @ n) * n
        r = float(np.linalg.norm(radial))
        if not r > 1e-15 * _scale(p0, c0):
            raise PlanningError("center: start lies on the helix axis (zero radius)")
        x = radial / r
        y = -np.cross(n, x) if clockwise else np.cross(n, x)
        self._set(p0 - r * x, x, y, n, r, pitch_f / _TWO_PI, phi)

    @property
    def axis(self) -> np.ndarray:
        return self._n

    @property
    def pitch(self) -> float:
        return self._c * _TWO_PI

    def _trim(self, u0: float, u1: float) -> Helix:
        base, x, y = self._rotated(u0)
        obj = object.__new__(Helix)
        obj._set(base, x, y, self._n, self._r, self._c, (u1 - u0) * self._k)
        return obj

    def __repr__(self) -> str:
        return (
            f"Helix(start={self.start.tolist()!r}, radius={self._r!r}, pitch={self.pitch!r}, "
            f"angle={self.angle!r})"
        )
