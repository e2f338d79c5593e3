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

from motionplc.planning._third import time_optimal

Phases = list[tuple[float, float]]


def _advance(v: float, a: float, t: float, j: float) -> tuple[float, float]:
    return v + t * (a + 0.5 * t * j), a + t * j


def _velocity_brake_upper(
    v: float, a: float, vmax: float, vmin: float, amin: float, J: float, out: Phases
) -> tuple[float, float]:
    """Full negative jerk until the velocity is back at v_max on its falling side, or until
    braking further would make an undershoot of v_min inevitable; hold a_min if it is hit."""
    t_v = (a + math.sqrt(max(a * a + 2.0 * J * (v - vmax), 0.0))) / J
    if vmin != -math.inf:
        # switching point from which +J lands exactly at (v_min, 0)
        t_l = (a + math.sqrt(max(0.5 * a * a + J * (v - vmin), 0.0))) / J
        t_stop = max(min(t_v, t_l), 0.0)
    else:
        t_stop = t_v
    t_a = (a - amin) / J if amin != -math.inf else math.inf
    if t_stop <= t_a:
        out.append((t_stop, -J))
        v, a = _advance(v, a, t_stop, -J)
        if t_stop < t_v:
            # The velocity range is too narrow for this acceleration: from this switching
            # point only full positive jerk avoids undershooting v_min; it lands at (v_min, 0).
            out.append((-a / J, J))
            return vmin, 0.0
        return v, a
    if t_a > 0.0:
        out.append((t_a, -J))
    v, a = _advance(v, a, t_a, -J)
    a = amin
    t_h = (vmax - v) / amin
    landing = False
    if vmin != -math.inf:
        t_hl = 0.5 * amin / J + (vmin - v) / amin
        if t_hl < t_h:
            t_h, landing = t_hl, True
    if t_h > 0.0:
        out.append((t_h, 0.0))
        v += t_h * amin
    if landing:
        out.append((-amin / J, J))
        return vmin, 0.0
    return v, a


def needs_upper_brake(v: float, a: float, vmax: float, J: float) -> bool:
    """Above v_max, or above it inevitably (beyond a rounding margin)."""
    lim = vmax + 1e-12 * max(1.0, abs(vmax))
    return v > lim or (a > 0.0 and v + 0.5 * a * a / J > lim)


def needs_lower_brake(v: float, a: float, vmin: float, J: float) -> bool:
    """Below v_min, or below it inevitably (beyond a rounding margin)."""
    lim = vmin - 1e-12 * max(1.0, abs(vmin))
    return v < lim or (a < 0.0 and v - 0.5 * a * a / J < lim)


def acceleration_brake(
    v: float, a: float, amax: float, amin: float, J: float, out: Phases, margin: float = 0.0
) -> tuple[float, float]:
    """Full jerk until an acceleration beyond [amin, amax] (by more than ``margin`` relative)
    is back at the limit; appends the phase to ``out`` and returns the state after it."""
    if a > amax + margin * max(1.0, abs(amax)):
        t = (a - amax) / J
        out.append((t, -J))
        v, a = _advance(v, a, t, -J)
        a = amax
    elif a < amin - margin * max(1.0, abs(amin)):
        t = (amin - a) / J
        out.append((t, J))
        v, a = _advance(v, a, t, J)
        a = amin
    return v, a


def brake(
    v: float, a: float, vmax: float, vmin: float, amax: float, amin: float, J: float
) -> tuple[Phases, float, float]:
    """Phases (duration, jerk) that bring (v, a) inside the limits, and the state after them."""
    out: Phases = []
    v, a = acceleration_brake(v, a, amax, amin, J, out, 1e-12)
    upper = needs_upper_brake(v, a, vmax, J)
    lower = needs_lower_brake(v, a, vmin, J)
    if upper and lower:
        # e.g. above v_max but decelerating so hard that v_min will be undershot: the
        # acceleration is the danger, so brake against it
        upper = a > 0.0
        lower = not upper
    if upper:
        v, a = _velocity_brake_upper(v, a, vmax, vmin, amin, J, out)
    elif lower:
        mirrored: Phases = []
        v, a = _velocity_brake_upper(-v, -a, -vmin, -vmax, -amax, J, mirrored)
        v, a = -v, -a
        out.extend((t, -j) for t, j in mirrored)
    return out, v, a


def brake_prefix(
    v0: float,
    a0: float,
    d: float,
    vf: float,
    af: float,
    vmax: float,
    vmin: float,
    amax: float,
    amin: float,
    J: float,
) -> tuple[Phases, float, float, float, float]:
    """The brake a position move needs before its time-optimal part: (phases, v and a after
    them, the distance left, their duration); no phases when none is needed.

    A start inside the limits that brakes only because an overshoot looks inevitable gets no
    brake when a profile within the limits reaches the target first (one whose own
    continuation overshoots too)."""
    out, v, a = brake(v0, a0, vmax, vmin, amax, amin, J)
    if not out:
        return out, v0, a0, d, 0.0
    if vmin <= v0 <= vmax and amin <= a0 <= amax:
        if time_optimal(v0, a0, d, vf, af, vmax, vmin, amax, amin, J) is not None:
            return [], v0, a0, d, 0.0
    pb = 0.0
    t_brake = 0.0
    vb, ab = v0, a0
    for dur, j in out:
        pb += dur * (vb + dur * (0.5 * ab + dur * j / 6.0))
        vb += dur * (ab + 0.5 * dur * j)
        ab += dur * j
        t_brake += dur
    return out, v, a, d - pb, t_brake
