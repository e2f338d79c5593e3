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
from typing import Final

_MAX_ITER: Final = 64
_EPS: Final = 2.220446049250313e-16


# cube root: a cubic fit of u^(1/3) on [0.5, 4) (within 1 % there), refined below
_CB3: Final = 0.011621201522066615
_CB2: Final = -0.1171410869348481
_CB1: Final = 0.5406693762288409
_CB0: Final = 0.5588937456952309


_TWO48: Final = 281474976710656.0  # 2^48 = 8^16
_TWO_M48: Final = 3.552713678800501e-15  # 2^-48
_TWO_M45: Final = 2.842170943040401e-14  # 2^-45 = 0.5 / 8^15


def cbrt(x: float) -> float:
    """The cube root of ``x >= 0``, within one ulp (the nearest double in ~92 % of cases).

    Its bits do not depend on the platform's ``pow`` or numpy's: ``x = u 8^q`` exactly (u in
    [0.5, 4): ``frexp``'s mantissa times 2^(e - 3q), q = e // 3; found here by scaling with
    powers of two, which is exact, without the cost of a call of ``frexp``/``ldexp``), a cubic
    fit of ``u^(1/3)``, two Halley steps and a Newton step, all in IEEE basic arithmetic
    (correctly rounded everywhere), then ``* 2^q`` (exact), so ``batch.cbrt_array`` computes
    the same bits with numpy's frexp/ldexp (numpy 2.4's SIMD power differs from C's pow in the
    last bit of about 5 % of ``x ** (1/3)``). ``0``, ``inf`` and NaN map to themselves."""
    if not 0.0 < x < math.inf:
        return x
    u = x
    q = 0
    while u < _TWO_M45:  # (scaling up is exact, also from a subnormal; u stays < 8)
        u *= _TWO48
        q -= 16
    while u >= _TWO48:  # (the result stays >= 1: exact)
        u *= _TWO_M48
        q += 16
    while u >= 4.0:  # (stays >= 0.5)
        u *= 0.125
        q += 1
    while u < 0.5:  # (stays < 4)
        u *= 8.0
        q -= 1
    y = _CB0 + u * (_CB1 + u * (_CB2 + u * _CB3))
    y3 = y * y * y
    y = y * (y3 + 2.0 * u) / (2.0 * y3 + u)  # Halley: 1e-2 -> 1e-6
    y3 = y * y * y
    y = y * (y3 + 2.0 * u) / (2.0 * y3 + u)  # -> rounding
    y = y + (u / (y * y) - y) / 3.0  # Newton: within one ulp
    # y * 2^q (|q| <= 359, y near 1: a normal result, every scaling exact)
    while q >= 16:
        y *= 65536.0
        q -= 16
    while q <= -16:
        y *= 1.52587890625e-05  # 2^-16
        q += 16
    while q > 0:
        y *= 2.0
        q -= 1
    while q < 0:
        y *= 0.5
        q += 1
    return y


def _quadratic(a: float, b: float, c: float) -> tuple[int, float, float]:
    """:func:`quadratic_roots` as (number of roots, the roots ascending) without a list (a
    compiled build returns the floats unboxed); unused roots are 0."""
    if a == 0.0:
        if b == 0.0:
            return 0, 0.0, 0.0
        return 1, -c / b, 0.0
    disc = b * b - 4.0 * a * c
    if disc < 0.0:
        # a tiny negative discriminant is a rounded double root
        if disc > -1e-14 * (b * b + abs(4.0 * a * c)):
            return 1, -b / (2.0 * a), 0.0
        return 0, 0.0, 0.0
    s = math.sqrt(disc)
    q = -0.5 * (b + s) if b >= 0.0 else -0.5 * (b - s)
    r1 = q / a
    r2 = c / q if q != 0.0 else r1
    return (2, r1, r2) if r1 <= r2 else (2, r2, r1)


def quadratic_roots(a: float, b: float, c: float) -> list[float]:
    """Real roots of a*x^2 + b*x + c, ascending (numerically stable form)."""
    n, r1, r2 = _quadratic(a, b, c)
    if n == 0:
        return []
    if n == 1:
        return [r1]
    return [r1, r2]


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
    # (max of two at a time: the builtin's left-to-right order, compiled without boxing)
    bound = 1.0 + max(max(max(abs(c3), abs(c2)), abs(c1)), abs(c0))
    if lo < -bound:
        lo = -bound
    if hi > bound:
        hi = bound
    if lo > hi:
        return []
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
    # The points that split [lo, hi], in order: the inflection points (roots of f'') inside
    # it, where f' is monotone between them, and before each of them (and before hi) the
    # critical point where f' changes sign on the way there (bisection on f'); each piece
    # between consecutive points is scanned for a root as soon as its right end is known.
    n_infl, q1, q2 = _quadratic(12.0, 6.0 * c3, 2.0 * c2)
    m = 0
    p1 = p2 = 0.0
    if n_infl >= 1 and lo < q1 < hi:
        p1 = q1
        m = 1
    if n_infl == 2 and lo < q2 < hi:
        if m == 0:
            p1 = q2
        else:
            p2 = q2
        m += 1
    prev = lo
    d0 = ((4.0 * lo + 3.0 * c3) * lo + 2.0 * c2) * lo + c1
    for i in range(m + 1):
        x1 = hi if i == m else (p1 if i == 0 else p2)
        d1 = ((4.0 * x1 + 3.0 * c3) * x1 + 2.0 * c2) * x1 + c1
        if (d0 < 0.0) != (d1 < 0.0) and d0 != 0.0 and d1 != 0.0:
            xc = _critical(c3, c2, c1, prev, x1, d0)
            f0 = _piece(c3, c2, c1, c0, ac3, ac2, ac1, ac0, x0, f0, xc, False, roots)
            x0 = xc
        f0 = _piece(c3, c2, c1, c0, ac3, ac2, ac1, ac0, x0, f0, x1, i == m, roots)
        x0 = x1
        prev = x1
        d0 = d1
    return roots


def _piece(
    c3: float,
    c2: float,
    c1: float,
    c0: float,
    ac3: float,
    ac2: float,
    ac1: float,
    ac0: float,
    x0: float,
    f0: float,
    x1: float,
    last: bool,
    roots: list[float],
) -> float:
    """One monotone piece [x0, x1] of :func:`quartic_roots_in` (f0: the quartic at x0, 0 if a
    root was taken there): appends its root (or x1 as a root or, at the interval's end
    ``last``, a near-root) to ``roots``; returns the quartic at x1 (0 if a root was taken)."""
    f1 = (((x1 + c3) * x1 + c2) * x1 + c1) * x1 + c0
    ax = abs(x1)
    scale = (((ax + ac3) * ax + ac2) * ax + ac1) * ax + ac0
    if abs(f1) <= 1e-13 * scale:
        # a root at the end, or a (near-)double root at a critical point
        if not roots or x1 - roots[-1] > 1e-12 * max(1.0, ax):
            roots.append(x1)
        return 0.0
    if f0 != 0.0 and (f0 < 0.0) != (f1 < 0.0):
        r = _newton_piece(c3, c2, c1, c0, x0, x1, f0)
        if not roots or r - roots[-1] > 1e-12 * max(1.0, abs(r)):
            roots.append(r)
    if last and abs(f1) <= 1e-7 * scale:
        if not roots or x1 - roots[-1] > 1e-12 * max(1.0, ax):
            roots.append(x1)
    return f1


def _critical(c3: float, c2: float, c1: float, lo: float, hi: float, dlo: float) -> float:
    """The root of f' in (lo, hi), where f' is monotone and changes sign (Newton in a bracket)."""
    neg_lo = dlo < 0.0
    x = 0.5 * (lo + hi)
    for _it in range(_MAX_ITER):  # (not '_': typed object, boxed per step)
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
    for _it in range(_MAX_ITER):  # (not '_': typed object, boxed per step)
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
