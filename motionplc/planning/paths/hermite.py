"""Cubic Hermite curves through ordered passing points (seed 002, the controller-system patent).

The curve passes through ``W[0], W[1], ..., W[n-1]`` (n >= 2 distinct points in R^dim, dim >= 1)
one section per pair, section ``k`` from ``W[k]`` to ``W[k+1]``:

    P(t) = (2t³-3t²+1) W[k] + (t³-2t²+t) V[k] + (-2t³+3t²) W[k+1] + (t³-t²) V[k+1],  t in [0, 1]

so ``P(0) = W[k]``, ``P(1) = W[k+1]``, ``P'(0) = V[k]``, ``P'(1) = V[k+1]``; consecutive sections
share the velocity vector of their common point, so the curve is C¹ in its parameter. The Path
parameter is the sections' own parameter: ``u in [0, n - 1]``, section ``k`` on ``[k, k + 1]``
with ``t = u - k`` (``u_end = n - 1``; passing point ``i`` is at ``u = i``). Derivatives are with
respect to ``u`` (= ``t``). The seed's numbering variant (A), a start coordinate S and an end
coordinate E apart from the passing points, is ``HermitePath(points, start=S, end=E)``; variant
(B) (p1 is the start) is ``HermitePath(points)``.

Velocity vector ``V[i]`` at an interior point (the seed's rule, §3): with ``a = W[i-1] - W[i]``,
``b = W[i+1] - W[i]`` and the passing angle ``θ = angle(a, b)`` in [0, π] (180° = straight
through, 0° = full turn-back), ``r`` the prescribed value and ``θ_th`` the prescribed angle:

* ``θ >= θ_th`` and ``θ >= 90°`` (obtuse, 90° included): ``|V| = r``, direction
  ``unit(W[i+1] - W[i-1])``;
* ``θ_th <= θ < 90°`` (acute): ``|V| = r (1 + cos θ)`` (OCR correction of the seed:
  "r(1 cosθ)" is r plus the first coefficient r·cos θ), same direction;
* ``θ < θ_th`` (turn-back): ``|V| = r (1 + cos θ)``, direction orthogonal to
  ``d = W[i+1] - W[i]`` pointing away from ``W[i+2]``: ``-unit(w - (w·d̂) d̂)`` with
  ``w = W[i+2] - W[i]`` (the form that works in any dimension).

End points: ``V[0] = r unit(W[1] - W[0])`` and ``V[n-1] = r unit(W[n-1] - W[n-2])`` unless
``v_start`` / ``v_end`` are given.

Choices where the seed is incomplete (each documented and tested, none produces NaN):

* ``theta_th`` (the prescribed angle, printed only as "1"): default **1° = π/180 rad**, a
  parameter in (0, π/2]. ``θ == θ_th`` takes the normal branches ("≥ prescribed angle").
* ``r`` (the prescribed value; one global value as in the seed): default ``None`` = the mean
  chord length ``mean |W[k+1] - W[k]|`` (the seed's example uses 50 on its own coordinates; a
  value much larger than the chords gives loops and overshoot, a limitation of the method).
* The passing angle is computed as ``2 atan2(|â - b̂|, |â + b̂|)`` (accurate near 0 and 180°).
* Turn-back with no ``W[i+2]`` (the point before the last), or ``W[i+2]`` on the line
  ``W[i] W[i+1]`` (``|w⊥| <= 1e-12 |w|``): the normal points away from the side of the
  previous point ``W[i-1]`` (``-unit(a⊥)``): the seed turns away from where the curve goes
  next; with nothing there, turning away from where it came from lets the incoming section
  reach ``W[i]`` without crossing the line ``W[i] W[i+1]``. If ``W[i-1]`` is on that line too
  (an exact reversal), the normal is ``unit(e - (e·d̂) d̂)`` for the coordinate axis ``e`` least
  aligned with ``d``. In 1-D no normal exists: the velocity at a turn-back is zero.
* Duplicate consecutive points (zero-length ``a`` or ``b``, zero path derivative): points closer
  than ``1e-12 * max(1, max|coordinate|)`` to their predecessor are **dropped** (the first of
  the run is kept); :attr:`HermitePath.source_index` maps the kept points to the input. Fewer
  than 2 distinct points is a :class:`~motionplc.errors.PlanningError`.
* Source inconsistency ¶[0128]/¶[0139]: the worked example says "from p2 towards p3" for an
  obtuse point where the general rule (stated four times) gives p2 → p4. The general rule is
  used; ``patent_example_direction=True`` switches the obtuse branch to the example's literal
  wording ``unit(W[i] - W[i-1])`` so the difference can be seen.

Coefficients (the seed's ¶[0161] table, formula (1) missing in the source): per section and
axis ``x(t) = a t³ + b t² + c t + d`` with ``a = 2x0 - 2x1 + v0 + v1``,
``b = -3x0 + 3x1 - 2v0 - v1``, ``c = v0``, ``d = x0`` — :attr:`HermitePath.coefficients` has
shape ``(n - 1, dim, 4)`` in the order ``(a, b, c, d)``.

Arc length: :class:`~motionplc.planning.paths.arclength.ArcLengthTable` on the sections, also
split where the speed ``|p'|`` has a (near-)zero, i.e. a kink (adaptive 8-point Gauss–Legendre,
estimated error <= ``rtol * length``, default 1e-10);
:meth:`HermitePath.arc_length` and the inverse :meth:`HermitePath.u_at_arc_length` are
vectorised. Everything is computed in the constructor; the object is immutable.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from motionplc.errors import PlanningError
from motionplc.planning.paths._ppoly import (
    PiecewisePoly,
    check_points,
    check_scalar,
    check_vector,
    drop_duplicates,
)
from motionplc.planning.paths.arclength import ArcLengthTable, TabulatedCurve

__all__ = ["HermitePath", "hermite_velocities"]

ArrayLike = Sequence[float] | Sequence[Sequence[float]] | np.ndarray

OBTUSE = "obtuse"
ACUTE = "acute"
TURN_BACK = "turn_back"
_COLLINEAR_RTOL = 1e-12


def _unit(v: np.ndarray) -> np.ndarray:
    return v / np.linalg.norm(v)


def _passing_angle(a: np.ndarray, b: np.ndarray) -> float:
    ua, ub = _unit(a), _unit(b)
    return 2.0 * math.atan2(float(np.linalg.norm(ua - ub)), float(np.linalg.norm(ua + ub)))


def _perp(w: np.ndarray, d: np.ndarray) -> np.ndarray | None:
    """The unit part of ``w`` orthogonal to the unit vector ``d``, or None if (nearly) parallel."""
    wp = w - float(w @ d) * d
    n = float(np.linalg.norm(wp))
    if not n > _COLLINEAR_RTOL * float(np.linalg.norm(w)):
        return None
    return wp / n


def _turn_back_normal(W: np.ndarray, i: int) -> np.ndarray:
    d = _unit(W[i + 1] - W[i])
    if W.shape[1] == 1:
        return np.zeros(1)  # no normal in 1-D: stop at the turn-back point
    if i + 2 < len(W):
        n = _perp(W[i + 2] - W[i], d)
        if n is not None:
            return -n  # away from W[i+2] (the seed's rule)
    n = _perp(W[i - 1] - W[i], d)
    if n is not None:
        return -n  # away from the side of the previous point (no usable W[i+2])
    e = np.zeros_like(d)
    e[int(np.argmin(np.abs(d)))] = 1.0
    n = _perp(e, d)
    assert n is not None  # the least aligned axis is never parallel to d (dim >= 2)
    return n


def hermite_velocities(
    points: np.ndarray,
    r: float,
    theta_th: float,
    *,
    patent_example_direction: bool = False,
) -> tuple[np.ndarray, np.ndarray, tuple[str, ...]]:
    """The interior velocity vectors of seed 002's rule for distinct consecutive ``points``.

    Returns ``(V, theta, branch)`` for the interior points ``1..n-2``: ``V`` of shape
    ``(n-2, dim)``, the passing angles ``theta`` [rad] and the branch taken at each
    (``"obtuse"``, ``"acute"`` or ``"turn_back"``). ``points`` must already be checked
    (finite, no duplicate consecutive points); :class:`HermitePath` does that.
    """
    W = points
    n = len(W)
    V = np.zeros((max(n - 2, 0), W.shape[1]))
    theta = np.zeros(max(n - 2, 0))
    branch: list[str] = []
    for i in range(1, n - 1):
        th = _passing_angle(W[i - 1] - W[i], W[i + 1] - W[i])
        theta[i - 1] = th
        if th >= theta_th:
            if th >= 0.5 * math.pi:
                mag, kind = r, OBTUSE
                if patent_example_direction:
                    direction = _unit(W[i] - W[i - 1])
                else:
                    direction = _unit(W[i + 1] - W[i - 1])
            else:
                mag, kind = r * (1.0 + math.cos(th)), ACUTE
                direction = _unit(W[i + 1] - W[i - 1])
        else:
            mag, kind = r * (1.0 + math.cos(th)), TURN_BACK
            direction = _turn_back_normal(W, i)
        V[i - 1] = mag * direction
        branch.append(kind)
    return V, theta, tuple(branch)


class HermitePath(TabulatedCurve):
    """C¹ piecewise cubic Hermite curve through ordered passing points (seed 002); immutable.

    Guarantees: passes through every (kept) point at ``u = i``; ``evaluate(i, 1) == V[i]``
    (bitwise, from the right; the left limit agrees to rounding); ``V`` follows the seed's rule
    (module docstring); arc length from the adaptive table (estimated error <= ``rtol *
    length``). Bad input raises :class:`~motionplc.errors.PlanningError` naming the field.
    """

    __slots__ = (
        "points",
        "source_index",
        "velocities",
        "passing_angles",
        "branches",
        "r",
        "theta_th",
        "_poly",
        "_table",
    )

    points: np.ndarray
    source_index: np.ndarray
    velocities: np.ndarray
    passing_angles: np.ndarray
    branches: tuple[str, ...]
    r: float
    theta_th: float
    _poly: PiecewisePoly
    _table: ArcLengthTable

    def __init__(
        self,
        points: ArrayLike,
        *,
        r: float | None = None,
        theta_th: float = math.radians(1.0),
        start: ArrayLike | None = None,
        end: ArrayLike | None = None,
        v_start: ArrayLike | None = None,
        v_end: ArrayLike | None = None,
        patent_example_direction: bool = False,
        rtol: float = 1e-10,
    ) -> None:
        """Build the curve.

        ``points``: the ordered passing points, shape ``(n, dim)`` (a flat list means 1-D
        points); ``start`` / ``end``: optional separate start and end coordinates (variant A,
        prepended/appended); ``r`` > 0: the prescribed value (default: mean chord length);
        ``theta_th`` in (0, π/2]: the prescribed angle [rad] (default 1°); ``v_start`` /
        ``v_end``: end velocity vectors (default ``r`` along the first/last chord); ``rtol``:
        relative tolerance of the arc-length table.
        """
        W = check_points("points", points, min_count=1)
        dim = W.shape[1]
        if start is not None:
            W = np.vstack((check_vector("start", start, dim), W))
        if end is not None:
            W = np.vstack((W, check_vector("end", end, dim)))
        if len(W) < 2:
            raise PlanningError(f"points: need at least 2 points (with start/end), got {len(W)}")
        W, idx = drop_duplicates(W)
        if len(W) < 2:
            raise PlanningError(
                "points: need at least 2 distinct points (duplicates of the previous point "
                "are dropped), got 1"
            )
        chords = np.linalg.norm(np.diff(W, axis=0), axis=1)
        r_val = float(np.mean(chords)) if r is None else check_scalar("r", r, low=0.0)
        th_val = check_scalar("theta_th", theta_th, low=0.0, high=0.5 * math.pi)
        if not isinstance(patent_example_direction, bool):
            raise PlanningError(
                f"patent_example_direction: must be a bool, got {patent_example_direction!r}"
            )
        Vi, theta, branch = hermite_velocities(
            W, r_val, th_val, patent_example_direction=patent_example_direction
        )
        v0 = (
            r_val * _unit(W[1] - W[0]) if v_start is None else check_vector("v_start", v_start, dim)
        )
        v1 = r_val * _unit(W[-1] - W[-2]) if v_end is None else check_vector("v_end", v_end, dim)
        V = np.vstack((v0[None, :], Vi, v1[None, :]))
        P0, P1, V0, V1 = W[:-1], W[1:], V[:-1], V[1:]
        a = 2.0 * P0 - 2.0 * P1 + V0 + V1
        b = -3.0 * P0 + 3.0 * P1 - 2.0 * V0 - V1
        coeffs = np.stack((P0, V0, b, a), axis=1)  # ascending powers of t
        breaks = np.arange(len(W), dtype=float)
        poly, table = self._tabulate(breaks, coeffs, rtol)
        self._freeze(
            points=W,
            source_index=idx,
            velocities=V,
            passing_angles=theta,
            branches=branch,
            r=r_val,
            theta_th=th_val,
            _poly=poly,
            _table=table,
        )

    # -- Path interface ------------------------------------------------------------------------

    @property
    def dim(self) -> int:
        return int(self.points.shape[1])

    @property
    def u_end(self) -> float:
        return float(len(self.points) - 1)

    # -- curve data ----------------------------------------------------------------------------

    @property
    def sections(self) -> int:
        """Number of sections (``len(points) - 1``)."""
        return len(self.points) - 1

    @property
    def point_params(self) -> np.ndarray:
        """``u`` of each kept passing point (``0, 1, ..., n - 1``)."""
        return np.arange(len(self.points), dtype=float)

    @property
    def coefficients(self) -> np.ndarray:
        """The seed's coefficient table: shape ``(sections, dim, 4)``, ``(a, b, c, d)`` per axis
        with ``x(t) = a t³ + b t² + c t + d`` on each section (``t = u - k``)."""
        return np.ascontiguousarray(self._poly.coeffs[:, ::-1, :].transpose(0, 2, 1))

    def __repr__(self) -> str:
        return (
            f"HermitePath(points={len(self.points)}, dim={self.dim}, r={self.r!r}, "
            f"theta_th={self.theta_th!r}, length={self.length!r})"
        )
