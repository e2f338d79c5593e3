"""Return from a state outside the limits as fast as the jerk allows.

First the acceleration is driven into [a_min, a_max] with full jerk. Then, if the velocity is
above v_max, or will inevitably pass it because of a positive acceleration, full negative jerk
is applied until the velocity is back at v_max with a non-positive acceleration; if the
acceleration reaches a_min first it is held there until the velocity is back at v_max. The
lower limit is the mirror image. The result is a state inside the limits from which the
time-optimal planner continues.
"""

from __future__ import annotations

import math

Phases = list[tuple[float, float]]


def _advance(v: float, a: float, t: float, j: float) -> tuple[float, float]:
    return v + t * (a + 0.5 * t * j), a + t * j


def _velocity_brake_upper(
    v: float, a: float, vmax: float, amin: float, J: float, out: Phases
) -> tuple[float, float]:
    # smallest t with v(t) = vmax on the falling side under jerk -J
    rad = a * a + 2.0 * J * (v - vmax)
    t_v = (a + math.sqrt(max(rad, 0.0))) / J
    t_a = (a - amin) / J if amin != -math.inf else math.inf
    if t_v <= t_a:
        out.append((t_v, -J))
        v, a = _advance(v, a, t_v, -J)
        return vmax, a
    out.append((t_a, -J))
    v, a = _advance(v, a, t_a, -J)
    t_h = (vmax - v) / amin
    if t_h > 0.0:
        out.append((t_h, 0.0))
    return vmax, amin


def needs_upper_brake(v: float, a: float, vmax: float, J: float) -> bool:
    return v > vmax or (a > 0.0 and v + 0.5 * a * a / J > vmax)


def needs_lower_brake(v: float, a: float, vmin: float, J: float) -> bool:
    return v < vmin or (a < 0.0 and v - 0.5 * a * a / J < vmin)


def brake(
    v: float, a: float, vmax: float, vmin: float, amax: float, amin: float, J: float
) -> tuple[Phases, float, float]:
    """Phases (duration, jerk) that bring (v, a) inside the limits, and the state after them."""
    out: Phases = []
    if a > amax:
        t = (a - amax) / J
        out.append((t, -J))
        v, a = _advance(v, a, t, -J)
        a = amax
    elif a < amin:
        t = (amin - a) / J
        out.append((t, J))
        v, a = _advance(v, a, t, J)
        a = amin
    if needs_upper_brake(v, a, vmax, J):
        v, a = _velocity_brake_upper(v, a, vmax, amin, J, out)
    elif needs_lower_brake(v, a, vmin, J):
        mirrored: Phases = []
        v, a = _velocity_brake_upper(-v, -a, -vmin, -amax, J, mirrored)
        v, a = -v, -a
        out.extend((t, -j) for t, j in mirrored)
    return out, v, a
