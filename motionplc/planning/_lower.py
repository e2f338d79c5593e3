"""Second-order (infinite jerk) and first-order (infinite acceleration) position profiles.

Second order: the acceleration jumps between a_max, 0 and a_min (the trapezoidal velocity
profile PLCopen uses without a jerk limit). The time-optimal profile changes the velocity
to a peak (or trough) ``vp`` with one extreme acceleration, cruises there only if ``vp`` is
a velocity limit, and changes to the target velocity with the other extreme; ``vp`` follows
from the distance in closed form. First order: the velocity jumps to v_max (or v_min).
"""

from __future__ import annotations

import math

# phases as accepted by Profile: (duration, jerk, acceleration at phase start[, velocity])
Phases = list[tuple[float, ...]]


def _up_second(
    v0: float, d: float, vf: float, vmax: float, amax: float, amin: float
) -> tuple[float, Phases] | None:
    """Accelerate (a_max) to a peak vp >= max(v0, vf), cruise at vp = v_max, brake (a_min)."""
    alpha = 0.5 / amax - 0.5 / amin
    rhs = d + 0.5 * v0 * v0 / amax - 0.5 * vf * vf / amin
    if rhs < 0.0:
        return None
    vp = math.sqrt(rhs / alpha)
    lo = max(v0, vf)
    if vp < lo - 1e-12 * max(1.0, abs(lo)):
        return None
    cruise = 0.0
    if vp > vmax or vp < lo:
        # cruise at v_max; or vp a rounding below max(v0, vf), where the distance left after
        # the velocity changes must be a rounding error too (else the shape does not fit)
        vp = vmax if vp > vmax else lo
        if vp == 0.0:
            return (0.0, [(0.0, 0.0, 0.0)]) if d == 0.0 else None
        d_acc = (vp * vp - v0 * v0) / (2.0 * amax) + (vf * vf - vp * vp) / (2.0 * amin)
        cruise = (d - d_acc) / vp
        if cruise < -1e-12 * max(1.0, abs(d / vp)):
            return None
        cruise = max(cruise, 0.0)
    t1 = (vp - v0) / amax
    t3 = (vf - vp) / amin
    ph: Phases = [(t1, 0.0, amax), (cruise, 0.0, 0.0), (t3, 0.0, amin), (0.0, 0.0, 0.0)]
    return t1 + cruise + t3, ph


def second_order(
    v0: float, d: float, vf: float, vmax: float, vmin: float, amax: float, amin: float
) -> tuple[float, Phases]:
    """Fastest second-order profile from a velocity inside [vmin, vmax] (after any brake)."""
    best: tuple[float, Phases] | None = _up_second(v0, d, vf, vmax, amax, amin)
    down = _up_second(-v0, -d, -vf, -vmin, -amin, -amax)
    if down is not None:
        ph: Phases = [(t, j, -a) for t, j, a in down[1]]
        if best is None or down[0] < best[0]:
            best = (down[0], ph)
    if best is None:  # cannot happen for finite limits: one of the shapes always fits
        raise ArithmeticError("no second-order profile")
    return best


def first_order(d: float, vmax: float, vmin: float) -> tuple[float, Phases]:
    """Move at the velocity limit; velocity jumps at both ends."""
    if d == 0.0:
        return 0.0, [(0.0, 0.0, 0.0, 0.0)]  # the velocity jumps to the target's 0
    v = vmax if d > 0.0 else vmin
    t = d / v
    return t, [(t, 0.0, 0.0, v), (0.0, 0.0, 0.0, 0.0)]
