"""Real roots of low-degree polynomials, robust enough for the planner.

Quadratics are solved in closed form (numerically stable). A quartic is solved on an
interval: its inflection points (a quadratic) and then its critical points (found by a
bracketed Newton iteration on the monotone derivative between them) split the interval into
monotone pieces, and each piece with a sign change holds exactly one root, found by a
safeguarded Newton iteration (steps that stay inside a shrinking bracket, bisection
otherwise). This always terminates (at most ``_MAX_ITER`` steps per root) and cannot miss a
simple root in the interval; a double root shows up as a critical point where the polynomial
vanishes.
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


def quartic_roots_in(
    c3: float, c2: float, c1: float, c0: float, lo: float, hi: float
) -> list[float]:
    """Real roots of the monic quartic x^4 + c3 x^3 + c2 x^2 + c1 x + c0 in [lo, hi], ascending.

    The inflection and critical points split [lo, hi] into monotone pieces; a piece whose ends
    differ in sign holds exactly one root, found by Newton steps from the regula-falsi point
    inside the shrinking bracket. Infinite bounds are replaced by the Cauchy bound.
    Roots at (or a rounding error beyond) the ends of [lo, hi] and near-double roots at
    critical points are included.
    """
    bound = 1.0 + max(abs(c3), abs(c2), abs(c1), abs(c0))
    if lo < -bound:
        lo = -bound
    if hi > bound:
        hi = bound
    if lo > hi:
        return []
    # inflection points (roots of f'') split [lo, hi] into pieces where f' is monotone; a
    # piece holds a critical point only where f' changes sign, found by bisection on f'
    pts = [lo]
    for x in quadratic_roots(12.0, 6.0 * c3, 2.0 * c2):
        if lo < x < hi:
            pts.append(x)
    pts.append(hi)
    if len(pts) > 0:
        with_crit = [lo]
        d0 = ((4.0 * lo + 3.0 * c3) * lo + 2.0 * c2) * lo + c1
        for x1 in pts[1:]:
            d1 = ((4.0 * x1 + 3.0 * c3) * x1 + 2.0 * c2) * x1 + c1
            if (d0 < 0.0) != (d1 < 0.0) and d0 != 0.0 and d1 != 0.0:
                with_crit.append(_critical(c3, c2, c1, with_crit[-1], x1, d0))
            with_crit.append(x1)
            d0 = d1
        pts = with_crit
    ac3 = abs(c3)
    ac2 = abs(c2)
    ac1 = abs(c1)
    ac0 = abs(c0)
    roots: list[float] = []
    x0 = lo
    f0 = (((x0 + c3) * x0 + c2) * x0 + c1) * x0 + c0
    ax = abs(x0)
    scale = (((ax + ac3) * ax + ac2) * ax + ac1) * ax + ac0
    if abs(f0) <= 1e-13 * scale:
        roots.append(x0)
        f0 = 0.0
    elif abs(f0) <= 1e-7 * scale:
        # The ends of the interval are family boundaries: a near-root there is also offered
        # (the caller's verification by integration decides), so that a state a rounding error
        # away from a boundary gets the boundary profile and not a needless tiny extra phase.
        # The sign is kept, so a genuine root next to it is still bracketed.
        roots.append(x0)
    n = len(pts)
    for k in range(1, n):
        x1 = pts[k]
        f1 = (((x1 + c3) * x1 + c2) * x1 + c1) * x1 + c0
        ax = abs(x1)
        scale = (((ax + ac3) * ax + ac2) * ax + ac1) * ax + ac0
        if abs(f1) <= 1e-13 * scale:
            # a root at the end, or a (near-)double root at a critical point
            if not roots or x1 - roots[-1] > 1e-12 * max(1.0, ax):
                roots.append(x1)
            f1 = 0.0
        else:
            if f0 != 0.0 and (f0 < 0.0) != (f1 < 0.0):
                r = _newton_piece(c3, c2, c1, c0, x0, x1, f0)
                if not roots or r - roots[-1] > 1e-12 * max(1.0, abs(r)):
                    roots.append(r)
            if k == n - 1 and abs(f1) <= 1e-7 * scale:
                if not roots or x1 - roots[-1] > 1e-12 * max(1.0, ax):
                    roots.append(x1)
        x0 = x1
        f0 = f1
    return roots


def _critical(c3: float, c2: float, c1: float, lo: float, hi: float, dlo: float) -> float:
    """The root of f' in (lo, hi), where f' is monotone and changes sign (Newton in a bracket)."""
    neg_lo = dlo < 0.0
    x = 0.5 * (lo + hi)
    for _ in range(_MAX_ITER):
        d = ((4.0 * x + 3.0 * c3) * x + 2.0 * c2) * x + c1
        if d == 0.0:
            return x
        if (d < 0.0) == neg_lo:
            lo = x
        else:
            hi = x
        dd = (12.0 * x + 6.0 * c3) * x + 2.0 * c2
        xn = x - d / dd if dd != 0.0 else 0.5 * (lo + hi)
        if not lo < xn < hi:
            xn = 0.5 * (lo + hi)
        if abs(xn - x) <= 4.0 * _EPS * max(abs(x), 1e-300) or hi - lo <= 4.0 * _EPS * abs(x):
            return xn
        x = xn
    return x


def _newton_piece(
    c3: float, c2: float, c1: float, c0: float, lo: float, hi: float, flo: float
) -> float:
    """The single root in (lo, hi), where the quartic changes sign and is monotone and of one
    convexity: Newton steps from the regula-falsi point, kept inside the shrinking bracket
    (bisection if a step leaves it)."""
    fhi = (((hi + c3) * hi + c2) * hi + c1) * hi + c0
    neg_lo = flo < 0.0
    a = lo
    b = hi
    x = lo - flo * (hi - lo) / (fhi - flo) if fhi != flo else 0.5 * (lo + hi)
    for _ in range(_MAX_ITER):
        f = (((x + c3) * x + c2) * x + c1) * x + c0
        if f == 0.0:
            return x
        if (f < 0.0) == neg_lo:
            a = x
        else:
            b = x
        df = ((4.0 * x + 3.0 * c3) * x + 2.0 * c2) * x + c1
        xn = x - f / df if df != 0.0 else 0.5 * (a + b)
        if not a <= xn <= b:
            xn = 0.5 * (a + b)
        tol = 4.0 * _EPS * abs(xn) + 1e-300
        if abs(xn - x) <= tol or b - a <= tol:
            return xn
        x = xn
    return x
