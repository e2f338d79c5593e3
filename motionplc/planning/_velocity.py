"""Time-optimal velocity interface: (v0, a0) -> (vf, af) with |j| <= J, a_min <= a <= a_max.

The profile is an acceleration ramp up to a peak P (plateau if P = a_max) and down to af, or
the mirror image (trough). Closed form.
"""

from __future__ import annotations

import math

Phases = list[tuple[float, float]]


def _up(
    v0: float, a0: float, vf: float, af: float, amax: float, J: float
) -> tuple[float, Phases] | None:
    dv = vf - v0
    rad = J * dv + 0.5 * (a0 * a0 + af * af)
    if rad < 0.0:
        return None
    P = math.sqrt(rad)
    lo = max(a0, af)
    if P < lo - 1e-12 * max(1.0, abs(lo)):
        return None
    P = max(P, lo)
    h = 0.0
    if P > amax:
        P = amax
        h = (dv - (2.0 * amax * amax - a0 * a0 - af * af) / (2.0 * J)) / amax
        h = max(h, 0.0)
    t1 = (P - a0) / J
    t3 = (P - af) / J
    return t1 + h + t3, [(t1, J), (h, 0.0), (t3, -J)]


def velocity_third(
    v0: float, a0: float, vf: float, af: float, amax: float, amin: float, J: float
) -> tuple[float, Phases]:
    """Fastest third-order velocity change from an acceleration inside [amin, amax]."""
    up = _up(v0, a0, vf, af, amax, J)
    down = _up(-v0, -a0, -vf, -af, -amin, J)
    cands = []
    if up is not None:
        cands.append(up)
    if down is not None:
        cands.append((down[0], [(t, -j) for t, j in down[1]]))
    if not cands:  # cannot happen: one of the shapes always fits
        raise ArithmeticError("no velocity profile")
    return min(cands, key=lambda c: c[0])
