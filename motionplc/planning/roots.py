"""Real roots of low-degree polynomials, robust enough for the planner.

Quadratics and cubics are solved in closed form and polished with Newton steps. A quartic is
solved on an interval: the roots of its derivative split the interval into monotone pieces,
and each piece with a sign change holds exactly one root, found by a safeguarded Newton
iteration (Newton steps that stay inside a shrinking bracket, bisection otherwise). This
always terminates (at most ``_MAX_ITER`` steps per root) and cannot miss a simple root in the
interval; a double root shows up as a critical point where the polynomial vanishes.
"""

from __future__ import annotations

import math

_MAX_ITER = 64
_EPS = 2.220446049250313e-16


def quadratic_roots(a: float, b: float, c: float) -> list[float]:
    """Real roots of a*x^2 + b*x + c, ascending (numerically stable form)."""
    if a == 0.0:
        if b == 0.0:
            return []
        return [-c / b]
    disc = b * b - 4.0 * a * c
    if disc < 0.0:
        # a tiny negative discriminant is a rounded double root
        if disc > -1e-14 * (b * b + abs(4.0 * a * c)):
            return [-b / (2.0 * a)]
        return []
    s = math.sqrt(disc)
    q = -0.5 * (b + s) if b >= 0.0 else -0.5 * (b - s)
    r1 = q / a
    r2 = c / q if q != 0.0 else r1
    return [r1, r2] if r1 <= r2 else [r2, r1]


def cubic_roots(a: float, b: float, c: float, d: float) -> list[float]:
    """Real roots of a*x^3 + b*x^2 + c*x + d, ascending, polished by Newton steps."""
    if a == 0.0:
        return quadratic_roots(b, c, d)
    b /= a
    c /= a
    d /= a
    # depressed cubic t^3 + p t + q with x = t - b/3
    b3 = b / 3.0
    p = c - b * b3
    q = (2.0 * b3 * b3 - c) * b3 + d
    if p == 0.0 and q == 0.0:
        roots = [-b3]
    else:
        disc = (q * q) / 4.0 + (p * p * p) / 27.0
        if disc > 0.0:
            s = math.sqrt(disc)
            u = -0.5 * q + (s if q <= 0.0 else -s)
            u = math.copysign(abs(u) ** (1.0 / 3.0), u)
            t = u - p / (3.0 * u) if u != 0.0 else 0.0
            roots = [t - b3]
        else:
            m = 2.0 * math.sqrt(-p / 3.0)
            arg = 3.0 * q / (p * m) if p != 0.0 else 0.0
            arg = max(-1.0, min(1.0, arg))
            th = math.acos(arg) / 3.0
            roots = [
                m * math.cos(th) - b3,
                m * math.cos(th - 2.0943951023931957) - b3,
                m * math.cos(th - 4.1887902047863905) - b3,
            ]
    out = []
    for x in roots:
        for _ in range(3):
            f = ((x + b) * x + c) * x + d
            df = (3.0 * x + 2.0 * b) * x + c
            if df == 0.0:
                break
            dx = f / df
            x -= dx
            if abs(dx) <= 1e-16 * max(1.0, abs(x)):
                break
        out.append(x)
    out.sort()
    return out


def _quartic(c3: float, c2: float, c1: float, c0: float, x: float) -> float:
    return (((x + c3) * x + c2) * x + c1) * x + c0


def quartic_roots_in(
    c3: float, c2: float, c1: float, c0: float, lo: float, hi: float
) -> list[float]:
    """Real roots of the monic quartic x^4 + c3 x^3 + c2 x^2 + c1 x + c0 in [lo, hi].

    Infinite bounds are replaced by the Cauchy bound. Roots at (or a rounding error outside)
    the interval ends are included at the end, and near-double roots are reported once.
    """
    bound = 1.0 + max(abs(c3), abs(c2), abs(c1), abs(c0))
    if lo < -bound:
        lo = -bound
    if hi > bound:
        hi = bound
    if lo > hi:
        return []
    crit = cubic_roots(4.0, 3.0 * c3, 2.0 * c2, c1)
    pts = [lo]
    for x in crit:
        if lo < x < hi:
            pts.append(x)
    pts.append(hi)
    vals = [_quartic(c3, c2, c1, c0, x) for x in pts]
    roots: list[float] = []
    n = len(pts)
    for i in range(n):
        x = pts[i]
        f = vals[i]
        ax = abs(x)
        scale = (((ax + abs(c3)) * ax + abs(c2)) * ax + abs(c1)) * ax + abs(c0)
        if abs(f) <= 1e-13 * scale:
            # a root at an end or a (near-)double root at a critical point
            if not roots or abs(roots[-1] - x) > 1e-12 * max(1.0, ax):
                roots.append(x)
            continue
        if i + 1 < n:
            g = vals[i + 1]
            x1 = pts[i + 1]
            if (f < 0.0) != (g < 0.0):
                gx = abs(x1)
                gscale = (((gx + abs(c3)) * gx + abs(c2)) * gx + abs(c1)) * gx + abs(c0)
                if abs(g) <= 1e-13 * gscale:
                    continue  # the next point is itself the root
                r = _bracketed(c3, c2, c1, c0, x, x1, f)
                if not roots or abs(roots[-1] - r) > 1e-12 * max(1.0, abs(r)):
                    roots.append(r)
    return roots


def _bracketed(
    c3: float, c2: float, c1: float, c0: float, lo: float, hi: float, flo: float
) -> float:
    """The single root of the quartic in (lo, hi), where it changes sign and is monotone."""
    neg_lo = flo < 0.0
    x = 0.5 * (lo + hi)
    for _ in range(_MAX_ITER):
        f = (((x + c3) * x + c2) * x + c1) * x + c0
        if f == 0.0:
            return x
        if (f < 0.0) == neg_lo:
            lo = x
        else:
            hi = x
        df = ((4.0 * x + 3.0 * c3) * x + 2.0 * c2) * x + c1
        xn = x - f / df if df != 0.0 else 0.5 * (lo + hi)
        if not lo < xn < hi:
            xn = 0.5 * (lo + hi)
        if abs(xn - x) <= 4.0 * _EPS * max(1.0, abs(x)) or hi - lo <= 4.0 * _EPS * max(1.0, abs(x)):
            return xn
        x = xn
    return x
