"""Corner blending: round the corners of a joined path with G2 (curvature-continuous) blends.

The blend
---------
At the corner ``C`` between segment ``a`` (ending at ``C``) and segment ``b`` (starting at
``C``), a :class:`CornerBlend` replaces the last ``d`` metres of ``a`` and the first ``d`` metres
of ``b`` (``d`` = the *corner distance*, measured along each segment). With ``A(s)`` the removed
piece of ``a`` and ``B(s)`` the removed piece of ``b`` (``s`` in ``[0, d]``, arc length), the
blend over its own parameter ``t`` in ``[0, 2d]`` (``sigma = t / 2d``) is::

    p(t) = (1 - w(sigma)) A(s) + w(sigma) B(s),    s = 2d h(sigma),
    w(sigma) = 10 sigma^3 - 15 sigma^4 + 6 sigma^5,     h(sigma) = sigma - w(sigma) / 2.

Both pieces are traversed simultaneously while the weight moves from ``a`` to ``b``; ``h``
slows the traversal so that ``|p'| = 1`` for a straight continuation (and
``|p'| >= cos(deflection / 2)`` at a line-line corner). Because ``w' = w'' = 0`` and ``h' = 1``,
``h'' = 0`` at both ends, ``p, p', p''`` equal those of ``a`` at the start and of ``b`` at the
end: the blended path is C2 in its parameter with unit speed at the junctions, hence tangent-
AND curvature-continuous (G2) — for any neighbours (lines, arcs, helices, in any dimension),
no jump of the curvature vector, so no forced acceleration jump at constant path speed. (The
third derivative jumps at the junctions: the path jerk at constant speed changes there.)

For a line-line corner of deflection ``theta`` the blend is planar, convex (the curvature keeps
its sign), symmetric, and its point nearest to the corner is its midpoint
``C + (d/4)(b' - a')``: the deviation is exactly ``d sin(theta/2) / 2``.

Modes (PLCopen Part 4 ``TransitionMode``)
----------------------------------------
* ``MAX_CORNER_DEVIATION`` (TMMaxCornerDeviation): the corner distance is the largest found
  with deviation ``<= parameter``, where *deviation* is the distance from the programmed corner
  to the blend curve (computed by dense sampling plus Newton refinement; for line-line corners
  it equals the closed form above). Guarantee: ``deviation <= parameter``; when the cap below
  does not bind, ``deviation >= (1 - 1e-9) * parameter`` (the whole tolerance is used).
* ``CORNER_DISTANCE`` (TMCornerDistance): ``d = parameter``; the deviation is reported.
* ``NONE`` (TMNone), or a parameter of 0: the corner is kept exact.
* ``START_VELOCITY`` / ``CONSTANT_VELOCITY`` depend on the motion, not on the geometry: the
  motion planner must translate them into a corner distance; here they are a PlanningError.

Caps and special corners
------------------------
* A blend never takes more than half of a neighbouring segment (``d <= length / 2`` on both
  sides), so blends of consecutive corners never overlap; a segment consumed completely by
  its two blends disappears from the result.
* Already smooth junctions (deflection ``<= 1e-9`` rad and equal curvature vectors, e.g.
  collinear lines) need no blend (:attr:`CornerKind.SMOOTH`). A tangent-continuous junction
  with a curvature jump (a line running tangentially into an arc) *is* blended: the blend is a
  curvature transition.
* Reversals: a direction reversal cannot be rounded within a deviation bound by a curve of
  bounded curvature. Corners deflecting by more than ``max_deflection`` (default 179 deg) are
  left as exact-stop corners (:attr:`CornerKind.STOP`): the path keeps the corner and a path
  follower must come to rest there.
* Zero-length segments cannot occur: :class:`~motionplc.planning.paths.geometry.Line` rejects
  them and :func:`~motionplc.planning.paths.composite.polyline` drops repeated points.

Every corner's outcome (kind, corner distance, achieved deviation, parameter range of the
blend) is reported in :attr:`BlendedPath.corners`.

Parametrisation and arc length
------------------------------
Lines, arcs and helices keep their arc-length parameter; inside a blend the parameter is the
blend's ``t`` (``|p'|`` is 1 at its ends and close to 1 on gentle corners). A blend's arc length
is integrated with adaptive 16-point Gauss-Legendre panels at construction (relative accuracy
``1e-12``); :meth:`CornerBlend.arc_length` is exact up to that tolerance too.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from enum import Enum, IntEnum

import numpy as np

from motionplc.errors import PlanningError
from motionplc.planning.paths.base import Path
from motionplc.planning.paths.composite import DEFAULT_GAP_TOL, CompositePath, _angle, polyline
from motionplc.planning.paths.geometry import (
    ArrayLike,
    Immutable,
    PathSegment,
    as_scalar,
    check_order,
    freeze,
    param_1d,
)

__all__ = [
    "BlendedPath",
    "Corner",
    "CornerBlend",
    "CornerKind",
    "DEFAULT_MAX_DEFLECTION",
    "Transition",
    "TransitionMode",
    "blend_corners",
    "blend_polyline",
]

DEFAULT_MAX_DEFLECTION = math.radians(179.0)
"""Corners deflecting more than this [rad] are exact-stop corners (not blended)."""
_MAX_DEFLECTION_LIMIT = math.radians(179.9)
_SMOOTH_ANGLE = 1e-9  # [rad] below this (with equal curvature) a junction needs no blend
_ARC_RTOL = 1e-12  # relative accuracy of the blend's arc length

_GL_X, _GL_W = np.polynomial.legendre.leggauss(16)
_GL_X.setflags(write=False)
_GL_W.setflags(write=False)


class TransitionMode(IntEnum):
    """PLCopen Part 4 ``MC_TRANSITION_MODE`` (values as in the standard)."""

    NONE = 0
    START_VELOCITY = 1
    CONSTANT_VELOCITY = 2
    CORNER_DISTANCE = 3
    MAX_CORNER_DEVIATION = 4


@dataclass(frozen=True, slots=True)
class Transition:
    """How one corner is rounded: a :class:`TransitionMode` and its parameter [m] (>= 0)."""

    mode: TransitionMode = TransitionMode.NONE
    parameter: float = 0.0

    def __post_init__(self) -> None:
        try:
            mode = TransitionMode(self.mode)
        except ValueError:
            allowed = ", ".join(f"{m.value} ({m.name})" for m in TransitionMode)
            raise PlanningError(
                f"Transition.mode: must be one of {allowed}, got {self.mode!r}"
            ) from None
        par = as_scalar("Transition.parameter", self.parameter, low=0.0, low_open=False)
        object.__setattr__(self, "mode", mode)
        object.__setattr__(self, "parameter", par)

    @classmethod
    def none(cls) -> Transition:
        """Keep the corner exact (TMNone)."""
        return cls(TransitionMode.NONE, 0.0)

    @classmethod
    def corner_distance(cls, distance: float) -> Transition:
        """Blend from ``distance`` [m] before to ``distance`` after the corner."""
        return cls(TransitionMode.CORNER_DISTANCE, distance)

    @classmethod
    def max_corner_deviation(cls, deviation: float) -> Transition:
        """Blend as widely as possible within ``deviation`` [m] of the corner."""
        return cls(TransitionMode.MAX_CORNER_DEVIATION, deviation)


class CornerKind(Enum):
    """What became of a corner."""

    BLENDED = "blended"  #: rounded by a CornerBlend
    SMOOTH = "smooth"  #: the junction was already G2; nothing to do
    EXACT = "exact"  #: kept as programmed (TransitionMode.NONE or parameter 0)
    STOP = "stop"  #: deflection above max_deflection (reversal): kept, exact stop


@dataclass(frozen=True, slots=True, eq=False)
class Corner:
    """The outcome at the junction of source segments ``index`` and ``index + 1``.

    ``distance`` is the arc length removed from each neighbour, ``deviation`` the distance from
    the programmed corner ``point`` to the path (both 0 unless blended); ``u_start``/``u_end``
    are the global parameters where the blend begins and ends (both the corner's parameter
    when not blended). ``deflection`` is the tangent angle [rad] of the programmed corner.
    """

    index: int
    point: tuple[float, ...]
    kind: CornerKind
    deflection: float
    transition: Transition
    distance: float
    deviation: float
    u_start: float
    u_end: float

    @property
    def needs_stop(self) -> bool:
        """True where the path keeps a tangent jump (a follower must come to rest here)."""
        return self.kind in (CornerKind.EXACT, CornerKind.STOP) and self.deflection > 0.0


def _weights(sig: np.ndarray, m: int) -> tuple[list[np.ndarray], list[np.ndarray]]:
    """``w`` and ``h`` and their sigma-derivatives up to order ``m``."""
    s2 = sig * sig
    one = 1.0 - sig
    w = [s2 * sig * (10.0 - 15.0 * sig + 6.0 * s2)]
    if m >= 1:
        w.append(30.0 * s2 * one * one)
    if m >= 2:
        w.append(60.0 * sig * one * (1.0 - 2.0 * sig))
    if m >= 3:
        w.append(60.0 * (1.0 - 6.0 * sig + 6.0 * s2))
    h = [sig - 0.5 * w[0]]
    if m >= 1:
        h.append(1.0 - 0.5 * w[1])
    h.extend(-0.5 * wk for wk in w[2:])
    return w, h


class CornerBlend(Immutable, Path):
    """G2 blend from the end of ``incoming`` into the start of ``outgoing`` (see the module).

    Replaces the last ``distance`` of ``incoming`` and the first ``distance`` of ``outgoing``
    (``0 < distance <= min(lengths)``); parameter ``t`` in ``[0, 2 distance]``. ``p, p', p''``
    equal those of ``incoming`` at ``t = 0`` and of ``outgoing`` at ``t = 2 distance``.
    """

    __slots__ = ("_a", "_b", "_d", "_corner", "_edges", "_cum")

    def __init__(self, incoming: PathSegment, outgoing: PathSegment, distance: float) -> None:
        for name, seg in (("incoming", incoming), ("outgoing", outgoing)):
            if not isinstance(seg, PathSegment):
                raise PlanningError(
                    f"{name}: must be an arc-length segment (Line, Arc, Helix), "
                    f"got {type(seg).__name__}"
                )
        if incoming.dim != outgoing.dim:
            raise PlanningError(
                f"outgoing: dimension {outgoing.dim} differs from incoming ({incoming.dim})"
            )
        cap = min(incoming.length, outgoing.length)
        d = as_scalar("distance", distance, low=0.0, low_open=True, high=cap)
        self._setup(incoming, outgoing, d)
        edges, cum = self._arc_table()
        freeze(self, _edges=edges, _cum=cum)

    def _setup(self, incoming: PathSegment, outgoing: PathSegment, d: float) -> None:
        a = incoming.trim(incoming.length - d, incoming.length) if d < incoming.length else incoming
        b = outgoing.trim(0.0, d) if d < outgoing.length else outgoing
        freeze(self, _a=a, _b=b, _d=d, _corner=np.asarray(incoming.end, dtype=float))

    @classmethod
    def _probe(cls, incoming: PathSegment, outgoing: PathSegment, d: float) -> CornerBlend:
        """A blend for geometric queries only (no arc-length table; inputs already checked)."""
        obj = object.__new__(cls)
        obj._setup(incoming, outgoing, d)
        return obj

    # -- interface -------------------------------------------------------------------------------

    @property
    def dim(self) -> int:
        return self._a.dim

    @property
    def u_end(self) -> float:
        return 2.0 * self._d

    @property
    def distance(self) -> float:
        """Corner distance: arc length replaced on each neighbour [m]."""
        return self._d

    @property
    def corner(self) -> np.ndarray:
        """The programmed corner (end of ``incoming``; read-only)."""
        return self._corner

    @property
    def length(self) -> float:
        return float(self._cum[-1])

    def evaluate(self, u: float | np.ndarray, order: int = 0) -> np.ndarray:
        """The ``order``-th derivative (0..3) with respect to the blend parameter ``t``."""
        return self.derivatives_of(u, (check_order(order),))[0]

    def derivatives(self, u: float | np.ndarray, n: int = 2) -> tuple[np.ndarray, ...]:
        check_order(n)
        return self.derivatives_of(u, tuple(range(n + 1)))

    def derivatives_of(
        self, u: float | np.ndarray, orders: Sequence[int]
    ) -> tuple[np.ndarray, ...]:
        """The derivatives of the given orders at ``u`` (neighbours evaluated once)."""
        orders = tuple(check_order(k) for k in orders)
        uu, scalar = param_1d(u, self.u_end)
        out = self._eval_orders(uu, orders)
        return tuple(o[0] for o in out) if scalar else out

    def _eval_orders(self, t: np.ndarray, orders: tuple[int, ...]) -> tuple[np.ndarray, ...]:
        """Unchecked evaluation of 1-D ``t`` (already in range) for several orders."""
        vals = self._derivs(t, max(orders))
        return tuple(vals[k] for k in orders)

    def _derivs(self, t: np.ndarray, m: int) -> list[np.ndarray]:
        two_d = 2.0 * self._d
        sig = t / two_d
        w, h = _weights(sig, m)
        s = np.clip(two_d * h[0], 0.0, self._d)
        A = [self._a._eval(s, k) for k in range(m + 1)]
        B = [self._b._eval(s, k) for k in range(m + 1)]
        W0 = w[0][:, None]
        out = [A[0] + W0 * (B[0] - A[0])]
        if m == 0:
            return out
        D = [bk - ak for ak, bk in zip(A, B, strict=True)]
        s1 = h[1][:, None]
        W1 = w[1][:, None] / two_d
        Ad1, Dd1 = A[1] * s1, D[1] * s1
        out.append(Ad1 + W1 * D[0] + W0 * Dd1)
        if m == 1:
            return out
        s2 = h[2][:, None] / two_d
        W2 = w[2][:, None] / two_d**2
        Ad2 = A[2] * s1 * s1 + A[1] * s2
        Dd2 = D[2] * s1 * s1 + D[1] * s2
        out.append(Ad2 + W2 * D[0] + 2.0 * W1 * Dd1 + W0 * Dd2)
        if m == 2:
            return out
        s3 = h[3][:, None] / two_d**2
        W3 = w[3][:, None] / two_d**3
        Ad3 = A[3] * s1**3 + 3.0 * A[2] * s1 * s2 + A[1] * s3
        Dd3 = D[3] * s1**3 + 3.0 * D[2] * s1 * s2 + D[1] * s3
        out.append(Ad3 + W3 * D[0] + 3.0 * W2 * Dd1 + 3.0 * W1 * Dd2 + W0 * Dd3)
        return out

    def _speed(self, t: np.ndarray) -> np.ndarray:
        return np.linalg.norm(self._derivs(t, 1)[1], axis=1)

    def _gl(self, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
        """16-point Gauss-Legendre integral of |p'| over [lo, hi] (arrays)."""
        half = 0.5 * (hi - lo)
        nodes = (lo + half)[:, None] + half[:, None] * _GL_X[None, :]
        sp = self._speed(nodes.ravel()).reshape(nodes.shape)
        return half * (sp @ _GL_W)

    def _arc_table(self) -> tuple[np.ndarray, np.ndarray]:
        """Adaptive panels: split until halves agree with the whole to ``_ARC_RTOL``."""
        edges = np.linspace(0.0, self.u_end, 9)
        for _ in range(40):
            lo, hi = edges[:-1], edges[1:]
            mid = 0.5 * (lo + hi)
            whole = self._gl(lo, hi)
            halves = self._gl(lo, mid) + self._gl(mid, hi)
            total = float(np.sum(halves))
            bad = np.abs(whole - halves) > _ARC_RTOL * total / 4.0
            if not np.any(bad):
                break
            edges = np.sort(np.concatenate((edges, mid[bad])))
        cum = np.concatenate(([0.0], np.cumsum(self._gl(edges[:-1], edges[1:]))))
        return edges, cum

    def arc_length(self, u: float | np.ndarray) -> float | np.ndarray:
        """Arc length from 0 to ``u`` (Gauss-Legendre on the adaptive panels, ~1e-12 rel.)."""
        uu, scalar = param_1d(u, self.u_end)
        k = np.clip(np.searchsorted(self._edges, uu, side="right") - 1, 0, self._edges.size - 2)
        out = self._cum[k] + self._gl(self._edges[k], uu)
        return float(out[0]) if scalar else out

    def distance_to(self, point: ArrayLike) -> tuple[float, float]:
        """``(distance, t)``: the distance from ``point`` to the blend and where it is attained.

        Dense sampling (257 values) followed by a safeguarded Newton iteration on
        ``(p - point) . p' = 0`` in the neighbourhood of the nearest sample.
        """
        q = np.asarray(point, dtype=float)
        t = np.linspace(0.0, self.u_end, 257)
        d2 = np.sum((self._derivs(t, 0)[0] - q) ** 2, axis=1)
        k = int(np.argmin(d2))
        lo, hi = t[max(k - 1, 0)], t[min(k + 1, t.size - 1)]
        x = t[k]
        best_x, best = x, float(d2[k])
        for _ in range(50):
            p0, p1, p2 = (v[0] for v in self._derivs(np.array([x]), 2))
            r = p0 - q
            g = float(r @ p1)
            gp = float(p1 @ p1 + r @ p2)
            if g > 0.0:
                hi = x
            elif g < 0.0:
                lo = x
            else:
                break
            nx = x - g / gp if gp > 0.0 else 0.5 * (lo + hi)
            if not lo < nx < hi:
                nx = 0.5 * (lo + hi)
            if abs(nx - x) <= 1e-15 * self.u_end:
                x = nx
                break
            x = nx
            dx = float(np.sum((self._derivs(np.array([x]), 0)[0][0] - q) ** 2))
            if dx < best:
                best_x, best = x, dx
        dx = float(np.sum((self._derivs(np.array([x]), 0)[0][0] - q) ** 2))
        if dx < best:
            best_x, best = x, dx
        return math.sqrt(best), float(best_x)

    def __repr__(self) -> str:
        return f"CornerBlend(corner={self._corner.tolist()!r}, distance={self._d!r})"


class BlendedPath(CompositePath):
    """A path with rounded corners: trimmed source segments and :class:`CornerBlend` pieces.

    :attr:`corners` has one :class:`Corner` per junction of :attr:`source` (the segments as
    programmed). Continuity: G2 at every junction except the corners whose
    :attr:`Corner.needs_stop` is true (kept exact: TransitionMode.NONE or a reversal).

    Parameter: a blend of corner distance ``d`` has parameter length ``2 d``, exactly the
    programmed arc length it replaces, so ``u_end`` equals the programmed length and outside
    the blends ``u`` is the arc-length position on the programmed path (``length`` is the
    shorter blended length). ``u`` in ``[corner.u_start, corner.u_end]`` is inside a blend.
    """

    __slots__ = ("_corners", "_source")

    def __init__(
        self,
        pieces: Sequence[Path],
        corners: Sequence[Corner],
        source: Sequence[Path],
        *,
        gap_tol: float = DEFAULT_GAP_TOL,
    ) -> None:
        super().__init__(pieces, gap_tol=gap_tol)
        freeze(self, _corners=tuple(corners), _source=tuple(source))

    @property
    def corners(self) -> tuple[Corner, ...]:
        return self._corners

    @property
    def source(self) -> tuple[Path, ...]:
        """The segments as programmed (before blending)."""
        return self._source

    @property
    def max_deviation(self) -> float:
        """Largest corner deviation [m] (0 without blends)."""
        return max((c.deviation for c in self._corners), default=0.0)


def _curvature(seg: Path, u: float) -> np.ndarray:
    return np.asarray(seg.curvature_vector(u), dtype=float)


def _solve_deviation(
    a: PathSegment, b: PathSegment, tol: float, cap: float, theta: float
) -> CornerBlend | None:
    """The blend with the largest corner distance found in (0, cap] whose deviation <= tol.

    Bracketing (Illinois) iteration on deviation(d) - tol, keeping ``lo`` feasible; the
    returned blend always satisfies the bound. None if no blend is feasible.
    """
    corner = a.end
    # the blend needs d <= both lengths; a caller's cap is the room it trimmed a and b to, but
    # a trimmed piece's length is computed again (an arc's as radius * angle, a line's as
    # u1 - u0 of the trim points) and may be one rounding step short of it
    cap = min(cap, a.length, b.length)
    dev_top = CornerBlend._probe(a, b, cap).distance_to(corner)[0]
    if dev_top <= tol:
        return CornerBlend(a, b, cap)
    lo, f_lo = 0.0, -tol
    hi, f_hi = cap, dev_top - tol
    # first guess: the line-line closed form d = 2 tol / sin(theta/2)
    sin_half = math.sin(0.5 * theta)
    guess = 2.0 * tol / sin_half if sin_half > 0.0 else 0.5 * cap
    x = guess if 0.0 < guess < cap else 0.5 * cap
    side = 0
    for _ in range(100):
        f = CornerBlend._probe(a, b, x).distance_to(corner)[0] - tol
        if f <= 0.0:
            lo, f_lo = x, f
            if f >= -1e-10 * tol:
                break
            if side == -1:
                f_hi *= 0.5
            side = -1
        else:
            hi, f_hi = x, f
            if side == 1:
                f_lo *= 0.5
            side = 1
        if hi - lo <= 1e-13 * hi:
            break
        x = hi - f_hi * (hi - lo) / (f_hi - f_lo)
        if not lo < x < hi:
            x = 0.5 * (lo + hi)
    return CornerBlend(a, b, lo) if lo > 0.0 else None


def blend_corners(
    path: CompositePath | Sequence[Path],
    transitions: Transition | Sequence[Transition],
    *,
    max_deflection: float = DEFAULT_MAX_DEFLECTION,
    gap_tol: float = DEFAULT_GAP_TOL,
) -> BlendedPath:
    """Round the corners of ``path`` (segments joined end to start) with G2 blends.

    ``transitions`` is one :class:`Transition` for every corner, or one per junction
    (``len(segments) - 1``). Corners to blend need arc-length segments (Line, Arc, Helix) on
    both sides. See the module documentation for the guarantees (deviation bound, half-segment
    cap, G2 continuity, reversals). Raises PlanningError naming the field for bad input.
    """
    segs = tuple(path.segments if isinstance(path, CompositePath) else path)
    source = CompositePath(segs, gap_tol=gap_tol)  # validates dimensions and gaps
    segs = source.segments
    n = len(segs) - 1
    if isinstance(transitions, Transition):
        trans = (transitions,) * n
    else:
        if isinstance(transitions, (str, bytes)) or not isinstance(transitions, Sequence):
            raise PlanningError("transitions: must be a Transition or a sequence of them")
        trans = tuple(transitions)
        if len(trans) != n:
            raise PlanningError(
                f"transitions: one per corner is needed ({n} for {len(segs)} segments), "
                f"got {len(trans)}"
            )
        for i, tr in enumerate(trans):
            if not isinstance(tr, Transition):
                raise PlanningError(f"transitions[{i}]: must be a Transition, got {tr!r}")
    max_defl = as_scalar(
        "max_deflection", max_deflection, low=0.0, low_open=False, high=_MAX_DEFLECTION_LIMIT
    )
    for i, tr in enumerate(trans):
        if tr.mode in (TransitionMode.START_VELOCITY, TransitionMode.CONSTANT_VELOCITY):
            raise PlanningError(
                f"transitions[{i}].mode: {tr.mode.name} depends on the motion; the geometry "
                "supports NONE, CORNER_DISTANCE and MAX_CORNER_DEVIATION"
            )

    blends: list[CornerBlend | None] = []
    kinds: list[CornerKind] = []
    deflections: list[float] = []
    for i in range(n):
        a, b = segs[i], segs[i + 1]
        tr = trans[i]
        ta, tb = a.evaluate(a.u_end, 1), b.evaluate(0.0, 1)
        theta = _angle(np.asarray(ta), np.asarray(tb))
        deflections.append(theta)
        ka, kb = _curvature(a, a.u_end), _curvature(b, 0.0)
        dk = float(np.linalg.norm(ka - kb))
        blend: CornerBlend | None = None
        if theta <= _SMOOTH_ANGLE and dk <= 1e-9 * max(np.linalg.norm(ka), np.linalg.norm(kb)):
            kind = CornerKind.SMOOTH
        elif tr.mode == TransitionMode.NONE or tr.parameter == 0.0:
            kind = CornerKind.EXACT
        elif theta > max_defl:
            kind = CornerKind.STOP
        else:
            for j, seg in ((i, a), (i + 1, b)):
                if not isinstance(seg, PathSegment):
                    raise PlanningError(
                        f"segments[{j}]: corner {i} is blended, which needs arc-length segments "
                        f"(Line, Arc, Helix) on both sides, got {type(seg).__name__}"
                    )
            assert isinstance(a, PathSegment) and isinstance(b, PathSegment)
            cap = 0.5 * min(a.length, b.length)
            if tr.mode == TransitionMode.CORNER_DISTANCE:
                blend = CornerBlend(a, b, min(tr.parameter, cap))
            else:
                blend = _solve_deviation(a, b, tr.parameter, cap, theta)
            kind = CornerKind.BLENDED if blend is not None else CornerKind.EXACT
        blends.append(blend)
        kinds.append(kind)

    pieces: list[Path] = []
    u_ranges: list[tuple[float, float]] = []
    u = 0.0
    for j, seg in enumerate(segs):
        cut0 = blends[j - 1].distance if j > 0 and blends[j - 1] is not None else 0.0
        cut1 = blends[j].distance if j < n and blends[j] is not None else 0.0
        if cut0 == 0.0 and cut1 == 0.0:
            pieces.append(seg)
            u += seg.u_end
        else:
            assert isinstance(seg, PathSegment)
            end = seg.length - cut1
            if end - cut0 > 1e-12 * seg.length:
                piece = seg.trim(cut0, end)
                pieces.append(piece)
                u += piece.u_end
        if j < n:
            bl = blends[j]
            if bl is None:
                u_ranges.append((u, u))
            else:
                pieces.append(bl)
                u_ranges.append((u, u + bl.u_end))
                u += bl.u_end

    corners = []
    for i in range(n):
        bl = blends[i]
        point = tuple(float(x) for x in segs[i].end)
        corners.append(
            Corner(
                index=i,
                point=point,
                kind=kinds[i],
                deflection=deflections[i],
                transition=trans[i],
                distance=0.0 if bl is None else bl.distance,
                deviation=0.0 if bl is None else bl.distance_to(segs[i].end)[0],
                u_start=u_ranges[i][0],
                u_end=u_ranges[i][1],
            )
        )
    result = BlendedPath(pieces, corners, segs, gap_tol=gap_tol)
    # the u bookkeeping above must agree with the composite's own breaks
    if abs(result.u_end - u) > 1e-9 * max(1.0, u):  # pragma: no cover - internal consistency
        raise AssertionError("blend_corners: parameter bookkeeping mismatch")
    return result


def blend_polyline(
    points: Sequence[ArrayLike],
    transitions: Transition | Sequence[Transition],
    *,
    max_deflection: float = DEFAULT_MAX_DEFLECTION,
    gap_tol: float = DEFAULT_GAP_TOL,
) -> BlendedPath:
    """:func:`~motionplc.planning.paths.composite.polyline` through ``points`` with its corners
    rounded by :func:`blend_corners` (repeated points are dropped first, so a per-corner
    ``transitions`` sequence refers to the corners that remain)."""
    return blend_corners(
        polyline(points, gap_tol=gap_tol),
        transitions,
        max_deflection=max_deflection,
        gap_tol=gap_tol,
    )
