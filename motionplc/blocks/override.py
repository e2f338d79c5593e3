"""Override as time scaling (MC_SetOverride, MC_GroupSetOverride): :class:`TimeScale`.

A scaled job runs in its own trajectory time ``tau``; the override factor ``f(t)`` says how
fast ``tau`` advances in real time (``dtau/dt = f``). So the set values are the chain rule of
the job's trajectory ``x(tau)``:

    v = f x',   a = f^2 x'' + f' x',   j = f^3 x''' + 3 f f' x'' + f'' x'

``f`` does not jump to a new factor: it follows a jerk-limited ramp (a velocity profile of
``f``, planned once when the factor changes) whose bounds on ``f'`` and ``f''`` the owner
passes in (:func:`ramp_limits`: ``f' * v_top`` within the acceleration limit, ``f'' * v_top``
within the jerk limit), so the set values stay continuous and within the limits' scale.

Generic: it scales any trajectory time. An axis no longer ramps its own: the chain rule's
``f' x'`` and ``f'' x'`` terms took the differenced acceleration and jerk beyond the limits
while ``f`` ramped (issue 31 part 3), so MC_SetOverride re-plans the running move with a
velocity cap instead (``Axis.set_override``); the axis keeps an identity ``TimeScale``
(``f = 1``), which the compiled fast path, the couplings and superimposed motion read.
"""

from __future__ import annotations

import math

from motionplc.blocks._axis_core import ScaleCore
from motionplc.blocks.planner_guard import guarded
from motionplc.planning import Limits, Profile, State, plan_velocity

__all__ = ["TimeScale", "ramp_limits"]

_INF = math.inf


def ramp_limits(v_top: float, a_low: float, j_max: float) -> tuple[float, float]:
    """Bounds on ``f'`` and ``f''`` of the factor ramp for a trajectory with speed limit
    ``v_top`` (the faster direction), acceleration limit ``a_low`` (the tighter side) and jerk
    limit ``j_max`` (may be inf): ``f' v_top <= a_low``, ``f'' v_top <= j_max``."""
    return a_low / v_top, j_max / v_top


class TimeScale(ScaleCore):
    """The override factor ``f`` (with ``f'``, ``f''``) along its ramp, and the transforms
    between real time and a scaled job's trajectory time (mutable, owned by one axis/group).

    ``f``, ``fd``, ``fdd`` and ``prof`` (the running ramp, None when ``f`` is constant) are
    plain attributes, read directly on the per-cycle path.
    """

    # the fields are declared by ScaleCore (C fields when compiled: the axis kernel's fast path)

    def __init__(self) -> None:
        self.f = 1.0  # factor
        self.fd = 0.0  # its time derivative f'
        self.fdd = 0.0  # f''
        self.prof: Profile | None = None  # the ramp of f (a velocity profile: p unused, v = f)
        self.t = 0.0  # time since the ramp started
        self.target = 1.0  # the factor requested last (f at the ramp's end)

    def __repr__(self) -> str:
        return f"TimeScale(f={self.f!r}, fd={self.fd!r}, target={self.target!r})"

    @property
    def identity(self) -> bool:
        """True if trajectory time is real time (f = 1, not ramping)."""
        return self.f == 1.0 and self.fd == 0.0 and self.prof is None

    def set_factor(self, factor: float, df_max: float, ddf_max: float) -> None:
        """Ramp ``f`` from its current value (and slope) to ``factor`` with ``|f'| <= df_max``
        and ``|f''| <= ddf_max`` (inf: second order, the ramp starts with f' = 0).

        Raises PlanningError if the ramp cannot be planned; ``target`` is ``factor`` then
        anyway and the running ramp (if any) goes on to it.
        """
        self.target = factor
        lim = Limits(v_max=_INF, a_max=df_max, j_max=ddf_max)
        fd = self.fd if ddf_max != _INF else 0.0
        self.prof = guarded(plan_velocity, State(0.0, self.f, fd), factor, lim)
        self.t = 0.0

    def advance(self, dt: float) -> float:
        """Advance the ramp by real time ``dt``; returns the trajectory time increment (the
        trapezoidal integral of ``f`` over the step)."""
        prof = self.prof
        f0 = self.f
        if prof is None:
            return dt * f0
        self.t += dt
        s = prof.at(self.t)
        self.f, self.fd, self.fdd = s.v, s.a, s.j
        if self.t >= prof.duration:
            self.f = self.target
            self.fd = self.fdd = 0.0
            self.prof = None
        return 0.5 * (f0 + self.f) * dt

    def to_trajectory(self, p: float, v: float, a: float) -> State:
        """A set state (p, v, a) in real time as the start state of a new scaled job, in its
        trajectory time (inverse chain rule; at f ~ 0 the job starts from rest)."""
        f = self.f
        if f == 1.0 and self.fd == 0.0:
            return State(p, v, a)
        if f < 1e-9:
            return State(p, 0.0, 0.0)
        vt = v / f
        return State(p, vt, (a - self.fd * vt) / (f * f))

    def to_real(self, p: float, v: float, a: float, j: float) -> tuple[float, float, float, float]:
        """A trajectory sample (p, x', x'', x''') as set values in real time (chain rule)."""
        f, fd, fdd = self.f, self.fd, self.fdd
        return p, f * v, f * f * a + fd * v, f * f * f * j + 3.0 * f * fd * a + fdd * v
