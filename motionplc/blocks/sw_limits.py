"""Software limits: braking distances and the stop exactly at a limit.

Pure functions of an axis' configuration and set state (the axis acts on their results, see
``Axis._sw_guard``):

* :func:`stop_distance` / :func:`stop_speed`: the shortest jerk-limited brake from a speed and
  its inverse (also used to cap a blending junction speed at the successor's stopping speed);
* :func:`reach` / :func:`exact_reach`: how far the axis still travels braking now;
* :func:`crossed_limit`: the limit a step went too far towards (braking from the new set state
  could no longer stop at it);
* :func:`limit_stop_profile`: the jerk-limited brake from the previous set state to rest
  exactly at that limit (None if there is none);
* :func:`target_refused` / :func:`point_refused`: the limit a move's target (single axis) or a
  group path point lies beyond, refused at Execute (the checks of a sequence before the run use
  them; tests hold them equal to the axis' and the group's own verdicts).
"""

from __future__ import annotations

import math

from motionplc.blocks.axis_config import AxisConfig
from motionplc.blocks.planner_guard import guarded
from motionplc.planning import Limits, PlanningError, Profile, State, plan, plan_velocity

__all__ = [
    "crossed_limit",
    "exact_reach",
    "limit_stop_profile",
    "point_refused",
    "reach",
    "stop_distance",
    "stop_speed",
    "target_refused",
]

_INF = math.inf


def stop_distance(v: float, a: float, j: float) -> float:
    """Shortest distance to stop from speed ``v`` >= 0 at zero acceleration, braking with at
    most ``a`` and jerk ``j`` (either may be inf): the brake's acceleration is a symmetric
    trapezoid (triangle if ``a`` is not reached), so the distance is v * duration / 2."""
    if v <= 0.0:
        return 0.0
    if j == _INF:
        return 0.0 if a == _INF else v * v / (2.0 * a)
    if a == _INF or v * j < a * a:
        return v * math.sqrt(v / j)
    return 0.5 * v * (v / a + a / j)


def stop_speed(room: float, a: float, j: float) -> float:
    """Highest speed from which :func:`stop_distance` is at most ``room`` (its inverse)."""
    if room <= 0.0:
        return 0.0
    if j == _INF:
        return _INF if a == _INF else math.sqrt(2.0 * a * room)
    if a != _INF:
        # with the acceleration plateau: v^2 + (a^2 / j) v - 2 a room = 0
        b = a * a / j
        v = 0.5 * (math.sqrt(b * b + 8.0 * a * room) - b)
        if v * j >= a * a:
            return v
    return (room * room * j) ** (1.0 / 3.0)  # a jerk-only brake: room = v sqrt(v / j)


def reach(cfg: AxisConfig, v: float, a: float, s: float) -> float:
    """How far an axis with limits ``cfg`` still travels in direction ``s`` (+1 / -1) from set
    velocity ``v`` and acceleration ``a`` if it brakes now as hard as its own limits allow (0 if
    it does not move that way). Exact for s*a >= 0; for s*a < 0 (braking already) an upper bound
    (:func:`exact_reach` then)."""
    vs, as_ = s * v, s * a
    brake = cfg.a_neg if s > 0.0 else cfg.a_max
    jerk = cfg.j_max
    if jerk == _INF:
        return vs * vs / (2.0 * brake) if vs > 0.0 else 0.0
    if as_ > 0.0:
        # jerk -J brings the acceleration to 0 (exactly the start of the optimal brake)
        t1 = as_ / jerk
        v1 = vs + 0.5 * as_ * t1
        if v1 <= 0.0:
            return 0.0
        d1 = vs * t1 + as_ * as_ * as_ / (3.0 * jerk * jerk)
        return max(0.0, d1 + stop_distance(v1, brake, jerk))
    return stop_distance(vs, brake, jerk) if vs > 0.0 else 0.0


def exact_reach(cfg: AxisConfig, v: float, a: float, s: float) -> float:
    """:func:`reach` from the time-optimal brake to rest (its farthest position; one planner
    call)."""
    lim = Limits(v_max=_INF, a_max=cfg.a_max, j_max=cfg.j_max, v_min=-_INF, a_min=-cfg.a_neg)
    (pmin, pmax), _, _ = guarded(plan_velocity, State(0.0, v, a), 0.0, lim).extrema()
    return max(0.0, pmax if s > 0.0 else -pmin)


def crossed_limit(
    cfg: AxisConfig, p0: float, p: float, v: float, a: float
) -> tuple[float, float] | None:
    """``(s, limit)`` if braking from the new set state (p, v, a) as hard as the axis' limits
    allow could no longer stop at the software limit in direction ``s``, else None. Beyond a
    limit already (previous set position ``p0``), the bound is ``p0``: not further out."""
    for s, limit in ((1.0, cfg.sw_limit_pos), (-1.0, cfg.sw_limit_neg)):
        if limit is None or not (s * v > 0.0 or s * a > 0.0):
            continue
        bound = max(s * limit, s * p0)  # beyond the limit already: not further out
        tol = 1e-12 * (1.0 + abs(limit))
        if s * p + reach(cfg, v, a, s) <= bound + tol:
            continue
        if s * a < 0.0 and s * p + exact_reach(cfg, v, a, s) <= bound + tol:
            continue
        return s, limit
    return None


def limit_stop_profile(
    cfg: AxisConfig, s: float, limit: float, p0: float, v0: float, a0: float
) -> Profile | None:
    """The brake from (p0, v0, a0) to rest exactly at ``limit`` (direction ``s``) with the
    axis' own limits, never faster than now towards it; None if p0 is beyond the limit or the
    brake would overshoot it (then the axis stops as fast as possible instead)."""
    prof: Profile | None = None
    if s * p0 <= s * limit:
        jerk = cfg.j_max
        cap = max(s * v0, 0.0)
        if jerk != _INF and s * a0 > 0.0:
            cap += 0.5 * a0 * a0 / jerk
        cap = min(max(cap, 1e-12), cfg.v_max if s > 0.0 else cfg.v_neg)
        lim = Limits(
            v_max=cap if s > 0.0 else cfg.v_max,
            a_max=cfg.a_max,
            j_max=jerk,
            v_min=-cap if s < 0.0 else -cfg.v_neg,
            a_min=-cfg.a_neg,
        )
        try:
            prof = guarded(plan, State(p0, v0, a0), State(limit, 0.0, 0.0), lim)
            (pmin, pmax), _, _ = prof.extrema()
            far = pmax if s > 0.0 else -pmin
            if far > s * limit + 1e-10 * (1.0 + abs(limit)):
                prof = None  # cannot stop at the limit any more
        except PlanningError:
            prof = None
    return prof


def target_refused(cfg: AxisConfig, target: float, base: float | None) -> float | None:
    """The software limit a single-axis move from ``base`` to ``target`` is refused for at
    Execute (TARGET_OUTSIDE_SW_LIMITS), else None: a target beyond a limit is refused unless
    the axis stands beyond that limit already and the target lies back towards the allowed
    range (the rule of ``Axis._resolve``). ``base`` None: unknown, taken as within the limits
    (an axis starts there). Modulo axes have no software limits."""
    if cfg.modulo is not None:
        return None
    hi, lo = cfg.sw_limit_pos, cfg.sw_limit_neg
    if hi is not None and target > hi and (base is None or target > base):
        return hi
    if lo is not None and target < lo and (base is None or target < base):
        return lo
    return None


def point_refused(cfg: AxisConfig, x: float) -> float | None:
    """The software limit a group path point ``x`` of this member lies beyond (a group move's
    target or passing point is refused, TARGET_OUTSIDE_SW_LIMITS, with a tolerance of 1e-12
    relative, the rule of ``AxesGroup._check_limits``), else None."""
    hi, lo = cfg.sw_limit_pos, cfg.sw_limit_neg
    tol = 1e-12 * (1.0 + abs(x))
    if hi is not None and x > hi + tol:
        return hi
    if lo is not None and x < lo - tol:
        return lo
    return None
