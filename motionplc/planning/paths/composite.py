"""Concatenation of paths into one path with a global parameter (seed 000's "joiner").

:class:`CompositePath` joins segments end to start. Its global parameter ``u`` runs over the
segments one after the other (``u_end`` is the sum of the segments' ``u_end``), so on lines,
arcs and helices ``u`` *is* the arc length and ``length`` is exact (a sum of closed forms).
Position continuity (G0) is checked at construction: a gap larger than ``gap_tol`` is a
:class:`~motionplc.errors.PlanningError` naming the segment index and the gap. Tangent jumps are
allowed (seed 000 joins lines and arcs with C0 continuity only); :attr:`CompositePath.deflections`
reports them, and :func:`~motionplc.planning.paths.blend.blend_corners` rounds them.

Evaluation is vectorised: the segment of every parameter value is found with one
``numpy.searchsorted`` and each segment evaluates all of its values in one call (one Python
iteration per *segment*, never per point).

:func:`join` builds a path from seed 000's point list, :func:`polyline` from a list of points.
"""

from __future__ import annotations

import math
from collections.abc import Iterator, Sequence

import numpy as np

from motionplc.errors import PlanningError
from motionplc.planning.paths.base import Path, as_param
from motionplc.planning.paths.geometry import (
    Arc,
    ArrayLike,
    Immutable,
    Line,
    PathSegment,
    as_scalar,
    as_vector,
    check_order,
    freeze,
    param_1d,
)

__all__ = ["CompositePath", "join", "polyline"]

DEFAULT_GAP_TOL = 1e-9
"""Default largest position gap [m] accepted between consecutive segments. The default is
scale-aware: the gap accepted is also at most :data:`GAP_RTOL` of the shorter neighbouring
segment (see :class:`CompositePath`); a ``gap_tol`` other than this is taken as given."""
GAP_RTOL = 1e-9
"""Largest position gap relative to the shorter of the two segments it joins (plus 16 ulp of the
coordinates): an absolute tolerance alone would accept, at small scales, a gap as large as the
segments themselves, i.e. a different path."""
_ULP16 = 16.0 * float(np.finfo(float).eps)


def _allowed_gap(tol: float, len_a: float, len_b: float, point: np.ndarray) -> float:
    """The gap accepted between segments of lengths ``len_a``, ``len_b`` meeting at ``point``
    (``tol`` as given unless it is the scale-aware default)."""
    if tol != DEFAULT_GAP_TOL:
        return tol
    scale = float(np.max(np.abs(point), initial=0.0))
    return min(tol, GAP_RTOL * min(len_a, len_b) + _ULP16 * scale)


class CompositePath(Immutable, Path):
    """Segments joined end to start, with a global parameter ``u`` in ``[0, sum(u_end_i)]``.

    Guarantees:

    * ``|segments[i].start - segments[i-1].end| <= gap_tol`` for every ``i`` (else
      PlanningError ``segments[i]: ... gap ...``), with the default ``gap_tol`` also ``<=
      GAP_RTOL * the shorter segment + 16 ulp of the coordinates`` (scale-aware: a gap is never
      a sizeable part of the segments it joins); all segments have the same dimension;
    * ``evaluate(u, k)`` is ``segments[i].evaluate(u - breaks[i], k)`` for ``u`` in
      ``[breaks[i], breaks[i+1])`` (the last segment also owns ``u_end``); a junction value
      belongs to the *following* segment;
    * ``arc_length(u)`` is the sum of the whole segments before ``u`` plus the segment's own
      ``arc_length``: exact when the segments are arc-length parametrised (then
      :attr:`is_arc_length` is true and ``u == arc_length(u)``).

    Nested composites are flattened into their segments.
    """

    __slots__ = ("_segments", "_breaks", "_cum", "_dim", "_arc_param")

    def __init__(self, segments: Sequence[Path], *, gap_tol: float = DEFAULT_GAP_TOL) -> None:
        tol = as_scalar("gap_tol", gap_tol, low=0.0, low_open=False)
        flat: list[Path] = []
        if isinstance(segments, Path) or not isinstance(segments, Sequence):
            raise PlanningError("segments: must be a sequence of Path objects")
        for i, seg in enumerate(segments):
            if not isinstance(seg, Path):
                raise PlanningError(f"segments[{i}]: must be a Path, got {type(seg).__name__}")
            flat.extend(seg.segments if isinstance(seg, CompositePath) else (seg,))
        if not flat:
            raise PlanningError("segments: at least one segment is required")
        dim = flat[0].dim
        for i, seg in enumerate(flat[1:], start=1):
            if seg.dim != dim:
                raise PlanningError(
                    f"segments[{i}]: dimension {seg.dim} differs from segments[0] ({dim})"
                )
            end = flat[i - 1].end
            gap = float(np.linalg.norm(seg.start - end))
            allowed = _allowed_gap(tol, flat[i - 1].length, seg.length, end)
            if not gap <= allowed:
                why = (
                    f"gap_tol = {tol:g} m"
                    if allowed == tol
                    else f"{allowed:.6g} m: the default gap_tol = {tol:g} m but at most "
                    f"{GAP_RTOL:g} x the shorter segment + rounding"
                )
                raise PlanningError(
                    f"segments[{i}]: starts {gap:.6g} m from the end of segments[{i - 1}] "
                    f"(a gap in position; allowed {why})"
                )
        breaks = np.concatenate(([0.0], np.cumsum([s.u_end for s in flat])))
        cum = np.concatenate(([0.0], np.cumsum([s.length for s in flat])))
        freeze(
            self,
            _segments=tuple(flat),
            _breaks=breaks,
            _cum=cum,
            _dim=int(dim),
            _arc_param=all(isinstance(s, PathSegment) for s in flat),
        )

    # -- properties ------------------------------------------------------------------------------

    @property
    def dim(self) -> int:
        return self._dim

    @property
    def u_end(self) -> float:
        return float(self._breaks[-1])

    @property
    def length(self) -> float:
        return float(self._cum[-1])

    @property
    def segments(self) -> tuple[Path, ...]:
        return self._segments

    @property
    def breaks(self) -> np.ndarray:
        """Global parameter at the start of every segment, plus ``u_end`` (read-only)."""
        return self._breaks

    @property
    def cumulative_lengths(self) -> np.ndarray:
        """Arc length at the start of every segment, plus ``length`` (read-only)."""
        return self._cum

    @property
    def is_arc_length(self) -> bool:
        """True when every segment is arc-length parametrised (``u`` is the arc length)."""
        return self._arc_param

    @property
    def deflections(self) -> np.ndarray:
        """Angle [rad] between the end tangent of segment i and the start tangent of i+1.

        One value per junction (``len(segments) - 1``); 0 where the path is tangent-continuous,
        pi at a reversal. A path follower must stop at a junction with a non-zero deflection.
        """
        out = np.zeros(len(self._segments) - 1)
        for i in range(out.size):
            a = self._segments[i].evaluate(self._segments[i].u_end, 1)
            b = self._segments[i + 1].evaluate(0.0, 1)
            out[i] = _angle(a, b)
        return out

    def __len__(self) -> int:
        return len(self._segments)

    def __iter__(self) -> Iterator[Path]:
        return iter(self._segments)

    def __repr__(self) -> str:
        return (
            f"{type(self).__name__}({len(self._segments)} segments, dim={self._dim}, "
            f"length={self.length!r})"
        )

    # -- evaluation ------------------------------------------------------------------------------

    def locate(self, u: float | np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Segment index and local parameter of every ``u`` (1-D arrays, also for a float)."""
        uu, _ = param_1d(u, self.u_end)
        return self._locate(uu)

    def _locate(self, uu: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        n = len(self._segments)
        idx = np.searchsorted(self._breaks, uu, side="right") - 1
        np.clip(idx, 0, n - 1, out=idx)
        local = uu - self._breaks[idx]
        return idx, local

    def _groups(self, idx: np.ndarray) -> Iterator[tuple[int, np.ndarray | slice]]:
        """(segment, selection) for every segment that owns some of the values."""
        n = len(self._segments)
        if idx.size == 0:
            return
        if idx.size == 1 or bool(np.all(idx[1:] >= idx[:-1])):
            bounds = np.searchsorted(idx, np.arange(n + 1))
            for k in range(n):
                if bounds[k + 1] > bounds[k]:
                    yield k, slice(int(bounds[k]), int(bounds[k + 1]))
            return
        order = np.argsort(idx, kind="stable")
        bounds = np.searchsorted(idx[order], np.arange(n + 1))
        for k in range(n):
            if bounds[k + 1] > bounds[k]:
                yield k, order[bounds[k] : bounds[k + 1]]

    def evaluate(self, u: float | np.ndarray, order: int = 0) -> np.ndarray:
        """The ``order``-th derivative (0..3) of the position with respect to the global ``u``."""
        return self.derivatives_of(u, (check_order(order),))[0]

    def derivatives(self, u: float | np.ndarray, n: int = 2) -> tuple[np.ndarray, ...]:
        """Position and the first ``n`` (0..3) derivatives at ``u``, segments located once."""
        check_order(n)
        return self.derivatives_of(u, tuple(range(n + 1)))

    def derivatives_of(
        self, u: float | np.ndarray, orders: Sequence[int]
    ) -> tuple[np.ndarray, ...]:
        """The derivatives of the given ``orders`` at ``u`` (one segment lookup for all)."""
        orders = tuple(check_order(k) for k in orders)
        uu, scalar = param_1d(u, self.u_end)
        idx, local = self._locate(uu)
        outs = tuple(np.empty((uu.size, self._dim)) for _ in orders)
        for k, sel in self._groups(idx):
            seg = self._segments[k]
            loc = np.clip(local[sel], 0.0, seg.u_end)
            fast = getattr(seg, "_eval_orders", None)  # checked segments of this package
            if fast is not None:
                vals = fast(loc, orders)
            else:
                vals = tuple(seg.evaluate(loc, o) for o in orders)
            for out, v in zip(outs, vals, strict=True):
                out[sel] = v
        if scalar:
            return tuple(o[0] for o in outs)
        return outs

    def arc_length(self, u: float | np.ndarray) -> float | np.ndarray:
        """Arc length from 0 to ``u``; exact on arc-length parametrised segments."""
        uu, scalar = param_1d(u, self.u_end)
        if self._arc_param:
            out = uu.copy()
        else:
            idx, local = self._locate(uu)
            out = np.empty(uu.size)
            for k, sel in self._groups(idx):
                seg = self._segments[k]
                loc = np.clip(local[sel], 0.0, seg.u_end)
                out[sel] = self._cum[k] + np.asarray(seg.arc_length(loc), dtype=float)
        return float(out[0]) if scalar else out

    def u_at_arc_length(self, s: float | np.ndarray) -> float | np.ndarray:
        """The parameter ``u`` at arc length ``s`` (inverse of :meth:`arc_length`)."""
        arr = as_param(s, self.length)
        if arr.ndim > 1:
            raise PlanningError(f"s: must be a float or a 1-D array, got shape {arr.shape}")
        ss = np.atleast_1d(arr)
        if self._arc_param:
            out = ss.copy()
        else:
            n = len(self._segments)
            idx = np.clip(np.searchsorted(self._cum, ss, side="right") - 1, 0, n - 1)
            out = np.empty(ss.size)
            for k, sel in self._groups(idx):
                seg = self._segments[k]
                loc = np.clip(ss[sel] - self._cum[k], 0.0, seg.length)
                out[sel] = self._breaks[k] + np.asarray(seg.u_at_arc_length(loc), dtype=float)
        return float(out[0]) if arr.ndim == 0 else out


def _angle(a: np.ndarray, b: np.ndarray) -> float:
    """Angle between two non-zero vectors, accurate for tiny and near-pi angles."""
    na, nb = float(np.linalg.norm(a)), float(np.linalg.norm(b))
    if na == 0.0 or nb == 0.0:
        return math.nan
    a, b = a / na, b / nb
    return 2.0 * math.atan2(float(np.linalg.norm(a - b)), float(np.linalg.norm(a + b)))


def polyline(points: Sequence[ArrayLike], *, gap_tol: float = DEFAULT_GAP_TOL) -> CompositePath:
    """Straight lines through ``points`` (at least two distinct points, any dimension).

    Repeated points are dropped, so they never produce NaN tangents: a point is a repetition
    of the previous kept point when it lies within ``gap_tol`` of it; with the default
    ``gap_tol`` within ``min(gap_tol, GAP_RTOL * extent + 16 ulp of the coordinates)``,
    ``extent`` being the largest distance of any point from the first (scale-aware: points
    1e-9 m apart on a path of that size are distinct points, never merged into a different
    path). A corner left where a point was dropped is a corner like
    any other (an exact stop for :func:`~motionplc.planning.paths.plan_path`).
    """
    tol = as_scalar("gap_tol", gap_tol, low=0.0, low_open=False)
    if isinstance(points, np.ndarray):
        points = list(points)
    if not isinstance(points, Sequence) or len(points) < 2:
        raise PlanningError("points: at least two points are required")
    first = as_vector("points[0]", points[0])
    pts = [first] + [
        as_vector(f"points[{i}]", p, dim=first.size) for i, p in enumerate(points[1:], start=1)
    ]
    arr = np.array(pts)
    extent = float(np.max(np.linalg.norm(arr - first, axis=1)))
    ulp = _ULP16 * float(np.max(np.abs(arr)))
    dup = min(tol, GAP_RTOL * extent + ulp) if tol == DEFAULT_GAP_TOL else tol
    kept = [first]
    for q in pts[1:]:
        if float(np.linalg.norm(q - kept[-1])) > dup:
            kept.append(q)
    if len(kept) < 2:
        raise PlanningError("points: all points coincide (no segment of non-zero length)")
    return CompositePath(
        [Line(kept[i], kept[i + 1]) for i in range(len(kept) - 1)], gap_tol=gap_tol
    )


def join(points: Sequence[Sequence[object]], *, gap_tol: float = DEFAULT_GAP_TOL) -> CompositePath:
    """Seed 000's joiner: lines and arcs from its point list ``[(xyz, interp), ...]``.

    ``interp`` tells how the *previous* point is connected to this one: ``0`` only for the
    first point, ``1`` a straight line, a vector ``v`` a circular arc whose start tangent is
    ``v`` (:meth:`Arc.from_tangent`, the seed's "Reading A"). The seed's ``2`` (B-spline) is
    not a line/arc and is rejected here. Extra entries of a point (the seed's orientation) are
    ignored. Consecutive segments share their end points, so the result is G0 (tangent jumps
    remain at the junctions, as in the seed).
    """
    if not isinstance(points, Sequence) or len(points) < 2:
        raise PlanningError("points: at least two points are required")
    segs: list[PathSegment] = []
    prev: np.ndarray | None = None
    for i, entry in enumerate(points):
        if not isinstance(entry, Sequence) or isinstance(entry, str) or len(entry) < 2:
            raise PlanningError(f"points[{i}]: must be (xyz, interp), got {entry!r}")
        xyz = as_vector(f"points[{i}].xyz", entry[0], dim=None if prev is None else prev.size)
        interp = entry[1]
        if prev is None:
            if not _is_code(interp, 0):
                raise PlanningError(f"points[{i}].interp: the first point must have interp 0")
            prev = xyz
            continue
        if _is_code(interp, 1):
            segs.append(Line(prev, xyz))
        elif _is_code(interp, 2):
            raise PlanningError(
                f"points[{i}].interp: 2 (B-spline) is not a line/arc segment; build the spline "
                "with the spline paths"
            )
        elif np.ndim(interp) == 1:
            v = as_vector(f"points[{i}].interp", interp, dim=xyz.size)
            segs.append(Arc.from_tangent(prev, xyz, v))
        else:
            raise PlanningError(
                f"points[{i}].interp: must be 1 (line) or a tangent vector (arc), got {interp!r}"
            )
        prev = xyz
    return CompositePath(segs, gap_tol=gap_tol)


def _is_code(value: object, code: int) -> bool:
    return (
        not isinstance(value, bool)
        and isinstance(value, (int, float, np.integer, np.floating))
        and float(value) == code
    )
