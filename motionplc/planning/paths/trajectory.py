"""Immutable time-parametrised motion along a :class:`~motionplc.planning.paths.base.Path`.

A :class:`PathTrajectory` is a path plus a *speed law* ``u(t)``: a piecewise cubic in time
(constant ``d3u/dt3`` on each piece; zero for the second-order profiles, whose ``d2u/dt2`` is
piecewise constant and jumps at the knots). Every piece stores its start time and the exact state
``(u, du/dt, d2u/dt2)`` there, so sampling costs one bisection and a cubic, whatever the planner
did. The axis values follow from the chain rule::

    p = q(u)
    v = q'(u) du
    a = q'(u) ddu + q''(u) du^2
    j = q'(u) dddu + 3 q''(u) du ddu + q'''(u) du^3

(``j`` is the jerk inside the pieces; a second-order profile also has acceleration steps at its
knots, which ``j`` does not show.)
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import NamedTuple

import numpy as np

from motionplc.planning.paths.base import Path

__all__ = ["PathSample", "PathSamples", "PathTrajectory", "SpeedLaw"]


class PathSample(NamedTuple):
    """The motion at one instant: per-axis arrays of shape ``(dim,)`` and the path parameter."""

    p: np.ndarray
    v: np.ndarray
    a: np.ndarray
    j: np.ndarray
    u: float
    du: float
    ddu: float


class PathSamples(NamedTuple):
    """The motion at many instants: per-axis arrays ``(dim, n)``; ``u, du, ddu``: ``(n,)``."""

    p: np.ndarray
    v: np.ndarray
    a: np.ndarray
    j: np.ndarray
    u: np.ndarray
    du: np.ndarray
    ddu: np.ndarray


class SpeedLaw:
    """``u(t)`` as pieces of constant ``d3u/dt3``; immutable.

    ``t``, ``u``, ``du``, ``ddu``, ``dddu`` are arrays with one entry per piece (start time and the
    state at the piece start, after any jump of ``ddu``); ``duration`` ends the last piece. ``u`` is
    clamped to ``[0, u_end]`` on evaluation (rounding only).
    """

    __slots__ = ("t", "u", "du", "ddu", "dddu", "duration", "u_end")

    t: np.ndarray
    u: np.ndarray
    du: np.ndarray
    ddu: np.ndarray
    dddu: np.ndarray
    duration: float
    u_end: float

    def __init__(
        self,
        t: np.ndarray,
        u: np.ndarray,
        du: np.ndarray,
        ddu: np.ndarray,
        dddu: np.ndarray,
        duration: float,
        u_end: float,
    ) -> None:
        setattr_ = object.__setattr__
        for name, arr in (("t", t), ("u", u), ("du", du), ("ddu", ddu), ("dddu", dddu)):
            a = np.array(arr, dtype=float)
            a.setflags(write=False)
            setattr_(self, name, a)
        setattr_(self, "duration", float(duration))
        setattr_(self, "u_end", float(u_end))

    def __setattr__(self, name: str, value: object) -> None:
        raise AttributeError("SpeedLaw is immutable")

    def evaluate(self, ts: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """``(u, du, ddu, dddu)`` at the times ``ts`` (clamped to ``[0, duration]``)."""
        tc = np.clip(np.asarray(ts, dtype=float), 0.0, self.duration)
        idx = np.searchsorted(self.t, tc, side="right") - 1
        idx = np.clip(idx, 0, len(self.t) - 1)
        dt = tc - self.t[idx]
        j = self.dddu[idx]
        a0 = self.ddu[idx]
        v0 = self.du[idx]
        u = self.u[idx] + dt * (v0 + dt * (0.5 * a0 + dt * j / 6.0))
        v = v0 + dt * (a0 + 0.5 * dt * j)
        a = a0 + dt * j
        return np.clip(u, 0.0, self.u_end), v, a, j.copy()


class PathTrajectory:
    """A path traversed in time; immutable, all planning done at construction.

    Attributes:
        path: the geometric path.
        law: the :class:`SpeedLaw` ``u(t)``.
        duration: total time [s].
        order: 2 (velocity/acceleration limited, piecewise-constant ``d2u/dt2``) or 3 (also
            jerk-limited, continuous ``d2u/dt2``).
        grid_u, grid_du, grid_du_max: the planner's grid, its path speed ``du/dt`` there and the
            maximum-velocity curve (largest admissible ``du/dt`` at each grid point) for phase-plane
            plots and diagnostics.
        second_order_duration: the duration of the second-order optimum under the same velocity and
            acceleration limits (equal to ``duration`` for ``order == 2``).
        info: free-form diagnostics (iterations, tightening, filter time, ...).
    """

    __slots__ = (
        "path",
        "law",
        "duration",
        "order",
        "grid_u",
        "grid_du",
        "grid_du_max",
        "second_order_duration",
        "info",
    )

    path: Path
    law: SpeedLaw
    duration: float
    order: int
    grid_u: np.ndarray
    grid_du: np.ndarray
    grid_du_max: np.ndarray
    second_order_duration: float
    info: dict[str, float]

    def __init__(
        self,
        path: Path,
        law: SpeedLaw,
        order: int,
        grid_u: np.ndarray,
        grid_du: np.ndarray,
        grid_du_max: np.ndarray,
        second_order_duration: float,
        info: dict[str, float] | None = None,
    ) -> None:
        setattr_ = object.__setattr__
        setattr_(self, "path", path)
        setattr_(self, "law", law)
        setattr_(self, "duration", law.duration)
        setattr_(self, "order", int(order))
        for name, arr in (("grid_u", grid_u), ("grid_du", grid_du), ("grid_du_max", grid_du_max)):
            a = np.array(arr, dtype=float)
            a.setflags(write=False)
            setattr_(self, name, a)
        setattr_(self, "second_order_duration", float(second_order_duration))
        setattr_(self, "info", dict(info or {}))

    def __setattr__(self, name: str, value: object) -> None:
        raise AttributeError("PathTrajectory is immutable")

    @property
    def dim(self) -> int:
        return self.path.dim

    def sample(self, ts: Sequence[float] | np.ndarray) -> PathSamples:
        """Vectorised :meth:`at`: per-axis arrays of shape ``(dim, len(ts))`` (as
        :meth:`motionplc.planning.Trajectory.sample`); times are clamped to ``[0, duration]``.

        ``v``, ``a``, ``j`` are the time derivatives of the positions ``p`` returned (the chain
        rule above): :func:`~motionplc.planning.paths.plan_path` passes every tangent jump of
        the path at rest, so no velocity step hides between two samples. At a break of the
        path (and at a knot of the law) the values are the right-hand ones."""
        t = np.atleast_1d(np.asarray(ts, dtype=float))
        u, du, ddu, dddu = self.law.evaluate(t)
        q, q1, q2, q3 = (self.path.evaluate(u, k) for k in range(4))
        du_ = du[:, None]
        ddu_ = ddu[:, None]
        v = q1 * du_
        a = q1 * ddu_ + q2 * du_**2
        j = q1 * dddu[:, None] + 3.0 * q2 * du_ * ddu_ + q3 * du_**3
        return PathSamples(q.T, v.T, a.T, j.T, u, du, ddu)

    def at(self, t: float) -> PathSample:
        """The motion at time ``t`` (clamped to ``[0, duration]``)."""
        s = self.sample(np.array([float(t)]))
        return PathSample(
            s.p[:, 0],
            s.v[:, 0],
            s.a[:, 0],
            s.j[:, 0],
            float(s.u[0]),
            float(s.du[0]),
            float(s.ddu[0]),
        )

    def __repr__(self) -> str:
        return (
            f"PathTrajectory(dim={self.dim}, duration={self.duration:.9g}, order={self.order}, "
            f"grid={len(self.grid_u) - 1})"
        )
