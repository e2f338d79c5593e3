"""Fixed-duration third-order profiles in closed form (Ruckig's step 2, per profile family).

Given an axis after its brake prefix -- start (v0, a0), remaining distance d, target (vf, af),
limits and jerk limit J -- and a duration T (at least the axis' minimum, not blocked), each
function here solves one profile family *for T*: with the duration fixed, the family's
unknowns reduce to the real roots of a polynomial; every root in the family's admissible
range is turned into phases and verified by integration (end state, velocity and acceleration
limits, :func:`motionplc.planning._third._verify`), and the first verified profile whose
duration is T within the synchronisation tolerance is returned. A family that yields nothing
returns None; :func:`motionplc.planning.sync` then tries the next one and finally its jerk
bisection (seed 004), which stays the documented fallback.

Families (the order of :func:`solve` is by how often each one answers the random cases of
``tools/bench_planning.py``):

* ``none-j``: three ramps of one reduced jerk j (|j| <= J), a0 -> P -> Q -> af, no plateau --
  the time-optimal NONE profile of a lower jerk limit, i.e. exactly what the jerk bisection
  lands on in most cases. With s = T - (time left) at the two corners the acceleration,
  velocity and position equations reduce to one quartic in j (derivation below); j < 0 is the
  mirrored ("down") shape, so one quartic serves both.
* ``vel-j``: cruise at v_max (or v_min) between two velocity changes of a reduced jerk j; the
  duration is a closed-form, strictly monotone function of j on each branch of the halves,
  solved by a safeguarded secant in log j (no planning inside the loop).
* ``acc0_acc1-j``: plateaus at a_max and a_min joined by ramps of a reduced jerk j: with
  s = 1/j the plateau times are linear in s and the distance is a cubic in s.
* ``acc0-j`` / ``acc1-j``: a plateau at a_max (a_min) and a free trough (peak), ramps of a
  reduced jerk j = 1/s: for a given s the duration fixes the plateau and the velocity change
  is a quadratic in the free corner, so the distance error is an explicit function of s; its
  sign changes over 16 samples of log s are refined by regula falsi (Illinois) -- a root of
  a closed form, no planning inside the loop.
* ``cruise-vp``: a cruise at a free velocity vp between the two time-optimal velocity changes
  of the full jerk (each in closed form), the cruise time T minus the changes (Ruckig's VEL
  profiles of step 2 with every combination of plateaus and shapes of the two halves); the
  distance error is explicit in vp and solved the same way on 24 samples.

Every family is tried in both orientations (the mirrored problem p -> -p for "-down"), the
first verified profile wins. With the random cases of the benchmark the closed forms answer
all but about 0.1 % of the axes that need slowing; the rest fall back to the bisection.

Derivation of ``none-j``: with R2, R3 the time remaining at the two corners (T >= R2 >= R3 >=
0) and jerks +j, -j, +j, integrating the jerk against (T - t)^k / k! gives

    j (T   - 2 R2   + 2 R3  ) = af - a0                 =: D
    j (T^2 - 2 R2^2 + 2 R3^2) = 2 (vf - v0 - a0 T)       =: 2 E
    j (T^3 - 2 R2^3 + 2 R3^3) = 6 (d - v0 T - a0 T^2/2)  =: 6 F

With delta = R2 - R3 = (T - D/j)/2 and sigma = R2 + R3 = (T^2 - 2E/j) / (2 delta), the third
equation becomes 8 delta T^3 - 3 (T^2 - 2E/j)^2 - 4 delta^4 = 48 F delta / j; times j^4:

    -3 T^4 j^4 + (12 D T^3 - 48 E T^2 + 96 F T) j^3 + (6 D^2 T^2 + 48 E^2 - 96 F D) j^2
    - 4 D^3 T j + D^4 = 0.

Rest to rest (D = E = 0, F = d) gives j = 32 d / T^3, the familiar t, 2t, t ramps.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Final

from motionplc.planning._third import _verify
from motionplc.planning._velocity import velocity_third
from motionplc.planning.roots import quadratic_roots, quartic_roots_in

Phases = list[tuple[float, ...]]
_INF: Final = math.inf  # (Final: no lookup of the module's globals per use)


def _cubic_max_root(b: float, c: float, d: float) -> float:
    """The largest real root of m^3 + b m^2 + c m + d (Cardano / trigonometric form, polished
    by Newton steps)."""
    P = c - b * b / 3.0
    Q = (2.0 * b * b / 27.0 - c / 3.0) * b + d
    disc = 0.25 * Q * Q + P * P * P / 27.0
    if disc > 0.0:
        sq = math.sqrt(disc)
        w = -0.5 * Q - sq if Q > 0.0 else -0.5 * Q + sq
        u = math.copysign(abs(w) ** (1.0 / 3.0), w)
        t = u - P / (3.0 * u) if u != 0.0 else 0.0
    elif P < 0.0:
        r = math.sqrt(-P / 3.0)
        cos3 = max(-1.0, min(1.0, -0.5 * Q / (r * r * r)))
        t = 2.0 * r * math.cos(math.acos(cos3) / 3.0)
    else:
        t = 0.0
    m = t - b / 3.0
    for _it in range(2):
        f = ((m + b) * m + c) * m + d
        df = (3.0 * m + 2.0 * b) * m + c
        if df == 0.0:
            break
        m -= f / df
    return m


def quartic_real_roots(c3: float, c2: float, c1: float, c0: float) -> list[float]:
    """Real roots of the monic quartic x^4 + c3 x^3 + c2 x^2 + c1 x + c0, ascending, by
    Ferrari's factorisation into two quadratics and Newton steps to convergence per root on
    the quartic (fast; near-double roots are only good to about sqrt(eps), which the caller's
    verification judges -- :func:`motionplc.planning.roots.quartic_roots_in` is the robust
    solver)."""
    sh = 0.25 * c3
    # depressed y^4 + p y^2 + q y + r with x = y - c3 / 4
    p = c2 - 6.0 * sh * sh
    q = c1 - 2.0 * c2 * sh + 8.0 * sh * sh * sh
    r = c0 - c1 * sh + c2 * sh * sh - 3.0 * sh * sh * sh * sh
    ys: list[float] = []
    m = _cubic_max_root(p, 0.25 * p * p - r, -0.125 * q * q)
    if m > 1e-14 * (abs(p) + 1e-300) and m > 0.0:
        sr = math.sqrt(2.0 * m)
        k = q / (2.0 * sr)
        ys.extend(quadratic_roots(1.0, -sr, 0.5 * p + m + k))
        ys.extend(quadratic_roots(1.0, sr, 0.5 * p + m - k))
    else:
        for y2 in quadratic_roots(1.0, p, r):
            if y2 >= 0.0:
                y = math.sqrt(y2)
                ys.extend((-y, y))
    out: list[float] = []
    for y in ys:
        x = y - sh
        for _it in range(12):  # Newton to convergence (quadratic for a simple root)
            f = (((x + c3) * x + c2) * x + c1) * x + c0
            df = ((4.0 * x + 3.0 * c3) * x + 2.0 * c2) * x + c1
            if df == 0.0:
                break
            step = f / df
            x -= step
            if abs(step) <= 4e-16 * abs(x):
                break
        out.append(x)
    out.sort()
    return out


def _dur_tol(T: float) -> float:
    """The synchronisation tolerance on a duration (as in ``sync``): 2e-10 s or 1e-13 T."""
    return max(2e-10, 1e-13 * T)


def _accept(
    ph: Phases,
    T: float,
    v0: float,
    a0: float,
    d: float,
    vf: float,
    af: float,
    vmax: float,
    vmin: float,
    amax: float,
    amin: float,
) -> Phases | None:
    """``ph`` verified (end state and limits) and lasting T within the tolerance, else None."""
    ver = _verify(ph, v0, a0, d, vf, af, vmax, vmin, amax, amin)
    if ver is None or abs(ver[0] - T) > _dur_tol(T):
        return None
    return list(ver[1])


def none_free_jerk(
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
    T: float,
) -> Phases | None:
    """Three ramps of one jerk j (0 < |j| <= J) lasting exactly T, or None (see the module
    docstring for the quartic). Guarantees: the phases end at (d, vf, af), hold the limits and
    last T within 2e-10 s (1e-13 T) -- checked by integration, not assumed."""
    if not T > 0.0:
        return None
    D = af - a0
    E = vf - v0 - a0 * T
    F = d - T * (v0 + 0.5 * a0 * T)
    # work in the acceleration z = j T: D, e = E / T and f = F / T^2 are accelerations too,
    # so the quartic in z is scale-free
    e = E / T
    f = F / (T * T)
    # -3 z^4 + (12 D - 48 e + 96 f) z^3 + (6 D^2 + 48 e^2 - 96 f D) z^2 - 4 D^3 z + D^4 = 0
    c3 = -(12.0 * D - 48.0 * e + 96.0 * f) / 3.0
    c2 = -(6.0 * D * D + 48.0 * e * e - 96.0 * f * D) / 3.0
    c1 = 4.0 * D * D * D / 3.0
    c0 = -(D * D * D * D) / 3.0
    zmax = J * T * (1.0 + 1e-12)
    fast = quartic_real_roots(c3, c2, c1, c0)
    tried = False
    for z in fast:
        if z == 0.0 or not -zmax <= z <= zmax:
            continue
        tried = True
        out = _none_phases(z, T, D, E, v0, a0, d, vf, af, vmax, vmin, amax, amin, J)
        if out is not None:
            return out
    if not tried:
        return None
    # a root in range that failed: perhaps a near-double root the fast solver got only to
    # sqrt(eps); the robust solver decides
    for z in quartic_roots_in(c3, c2, c1, c0, -zmax, zmax):
        if z == 0.0:
            continue
        out = _none_phases(z, T, D, E, v0, a0, d, vf, af, vmax, vmin, amax, amin, J)
        if out is not None:
            return out
    return None


def _none_phases(
    z: float,
    T: float,
    D: float,
    E: float,
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
) -> Phases | None:
    """The three ramps of jerk j = z / T of :func:`none_free_jerk`, verified, or None."""
    j = z / T
    if abs(j) > J:
        j = J if j > 0.0 else -J  # a rounding error beyond the limit
    delta = 0.5 * (T - D / j)
    if not delta > 0.0:
        return None
    sigma = (T * T - 2.0 * E / j) / (2.0 * delta)
    r2 = 0.5 * (sigma + delta)
    r3 = 0.5 * (sigma - delta)
    tol = 1e-12 * T
    if r3 < -tol or r2 > T + tol:
        return None
    r3 = max(r3, 0.0)
    r2 = min(r2, T)
    t1 = T - r2
    t2 = r2 - r3
    ph: Phases = [(t1, j), (t2, -j), (r3, j)]
    return _accept(ph, T, v0, a0, d, vf, af, vmax, vmin, amax, amin)


def _vel_duration(
    v0: float,
    a0: float,
    d: float,
    vf: float,
    af: float,
    vc: float,
    amax: float,
    amin: float,
    j: float,
) -> tuple[float, Phases] | None:
    """Cruise at vc (> every velocity the halves pass) between the two time-optimal velocity
    changes of jerk j: (duration, phases) in closed form, or None if the halves do not fit."""
    # half 1: (v0, a0) -> (vc, 0), shape up-down, peak P >= max(a0, 0)
    rad = j * (vc - v0) + 0.5 * a0 * a0
    if rad < 0.0:
        return None
    P = math.sqrt(rad)
    if P < a0:
        return None
    h1 = 0.0
    if P > amax:
        P = amax
        h1 = ((vc - v0) - (2.0 * amax * amax - a0 * a0) / (2.0 * j)) / amax
        if h1 < 0.0:
            return None
    # half 2: (vc, 0) -> (vf, af), shape down-up, trough Q <= min(0, af)
    rad = 0.5 * af * af - j * (vf - vc)
    if rad < 0.0:
        return None
    Q = -math.sqrt(rad)
    if Q > af:
        return None
    h2 = 0.0
    if Q < amin:
        Q = amin
        h2 = ((vf - vc) - (af * af - 2.0 * amin * amin) / (2.0 * j)) / amin
        if h2 < 0.0:
            return None
    t1, t3, t5, t7 = (P - a0) / j, P / j, -Q / j, (af - Q) / j
    v1 = v0 + t1 * (a0 + 0.5 * t1 * j)
    v2 = v1 + h1 * P
    d1 = t1 * (v0 + t1 * (0.5 * a0 + t1 * j / 6.0)) + h1 * (v1 + 0.5 * h1 * P)
    d1 += t3 * (v2 + t3 * (0.5 * P - t3 * j / 6.0))
    v5 = vc - 0.5 * t5 * t5 * j
    v6 = v5 + h2 * Q
    d2 = t5 * (vc - t5 * t5 * j / 6.0) + h2 * (v5 + 0.5 * h2 * Q)
    d2 += t7 * (v6 + t7 * (0.5 * Q + t7 * j / 6.0))
    cruise = (d - d1 - d2) / vc
    if cruise < 0.0:
        return None
    ph: Phases = [
        (t1, j),
        (h1, 0.0, P),
        (t3, -j),
        (cruise, 0.0, 0.0, vc),
        (t5, -j),
        (h2, 0.0, Q),
        (t7, j),
    ]
    return t1 + h1 + t3 + cruise + t5 + h2 + t7, ph


def vel_free_jerk(
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
    T: float,
) -> Phases | None:
    """A cruise at v_max (``up`` orientation; the caller mirrors for v_min) between velocity
    changes of one reduced jerk j <= J, lasting exactly T, or None. The duration of this shape
    falls as j rises (every ramp is 1/j long, the cruise absorbs the distance), so a bracket
    [j_lo, J] is searched by a safeguarded secant in log j on the closed form."""
    if vmax == _INF or vmax <= 0.0 or not T > 0.0:
        return None
    r = _vel_duration(v0, a0, d, vf, af, vmax, amax, amin, J)
    if r is None or r[0] > T + _dur_tol(T):
        return None
    tol = _dur_tol(T)
    if abs(r[0] - T) <= tol:
        return _accept(r[1], T, v0, a0, d, vf, af, vmax, vmin, amax, amin)
    # bracket from below: the ramps alone scale as 1/j
    x_hi, f_hi = 0.0, r[0] - T  # f < 0 at j = J
    x_lo = 3.0 * math.log(max(r[0], 1e-300) / T)
    f_lo: float | None = None
    for _it in range(60):
        rr = _vel_duration(v0, a0, d, vf, af, vmax, amax, amin, J * math.exp(x_lo))
        if rr is None:
            # the cruise vanished (j too low): the bracket's low end is between
            x_lo = 0.5 * (x_lo + x_hi)
            if x_hi - x_lo < 1e-12:
                return None
            continue
        f_lo = rr[0] - T
        if abs(f_lo) <= tol:
            return _accept(rr[1], T, v0, a0, d, vf, af, vmax, vmin, amax, amin)
        if f_lo > 0.0:
            break
        x_hi, f_hi = x_lo, f_lo
        x_lo -= 1.0
    if f_lo is None or f_lo <= 0.0:
        return None
    side = 0
    for _it in range(100):
        x = x_hi - f_hi * (x_hi - x_lo) / (f_hi - f_lo)
        if not x_lo < x < x_hi:
            x = 0.5 * (x_lo + x_hi)
        rr = _vel_duration(v0, a0, d, vf, af, vmax, amax, amin, J * math.exp(x))
        if rr is None:
            return None
        fx = rr[0] - T
        if abs(fx) <= tol:
            return _accept(rr[1], T, v0, a0, d, vf, af, vmax, vmin, amax, amin)
        if fx > 0.0:
            x_lo, f_lo = x, fx
            if side == 1:
                f_hi *= 0.5  # Illinois
            side = 1
        else:
            x_hi, f_hi = x, fx
            if side == -1:
                f_lo *= 0.5
            side = -1
        if x_hi - x_lo <= 1e-15 * (1.0 + abs(x)):
            return None
    return None


def acc0_acc1_free_jerk(
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
    T: float,
) -> Phases | None:
    """Plateaus at a_max (h1) and a_min (h2), ramps of one reduced jerk j = 1/s <= J:
    a0 -> a_max -> a_min -> af, lasting exactly T, or None.

    Ramp times are c_k s; h1 + h2 = T - c s and a_max h1 + a_min h2 = dv - g s give h1, h2
    linear in s, and the distance is then a cubic in s, solved exactly (its coefficients are
    found by evaluating the closed-form distance at four points, which is exact for a cubic up
    to rounding, and the cubic's roots by the quartic solver on (s - s_far) * cubic)."""
    if amax == _INF or amin == -_INF or not T > 0.0 or amax <= amin:
        return None
    if a0 > amax or af < amin:
        return None
    c1, c2, c3 = amax - a0, amax - amin, af - amin
    c = c1 + c2 + c3
    g = 0.5 * (amax * amax - a0 * a0 + amax * amax - amin * amin + af * af - amin * amin)
    dv = vf - v0
    s_min = 1.0 / J
    s_max = T / c if c > 0.0 else _INF
    if not s_max >= s_min:
        return None

    def profile(s: float) -> tuple[float, Phases] | None:
        S = T - c * s
        # a_max h1 + a_min (S - h1) = dv - g s
        h1 = (dv - g * s - amin * S) / (amax - amin)
        h2 = S - h1
        j = 1.0 / s
        ph: Phases = [
            (c1 * s, j),
            (h1, 0.0, amax),
            (c2 * s, -j),
            (h2, 0.0, amin),
            (c3 * s, j),
        ]
        p, v, a = 0.0, v0, a0
        for dur, jj, *rest in ph:
            if rest:
                a = rest[0]
            p += dur * (v + dur * (0.5 * a + dur * jj / 6.0))
            v += dur * (a + 0.5 * dur * jj)
            a += dur * jj
        return p - d, ph

    # the residual times s^0 is a cubic in s on (0, inf); fit it on four points of [s_min, s_hi]
    s_hi = s_max if s_max != _INF else 4.0 * s_min + T
    xs = [s_min + (s_hi - s_min) * k / 3.0 for k in range(4)]
    if xs[0] == xs[3]:
        r = profile(s_min)
        return None if r is None else _accept(r[1], T, v0, a0, d, vf, af, vmax, vmin, amax, amin)
    ys = []
    for x in xs:
        r = profile(x)
        if r is None:
            return None
        ys.append(r[0])
    # Newton divided differences -> monomial coefficients in t = (s - s_min) / (s_hi - s_min)
    w = (s_hi - s_min) / 3.0
    d1 = [(ys[k + 1] - ys[k]) for k in range(3)]
    d2 = [(d1[k + 1] - d1[k]) / 2.0 for k in range(2)]
    d3 = (d2[1] - d2[0]) / 3.0
    # y(u) with u = (s - s_min) / w: y0 + d1[0] u + d2[0] u (u - 1) + d3 u (u - 1)(u - 2)
    k3 = d3
    k2 = d2[0] - 3.0 * d3
    k1 = d1[0] - d2[0] + 2.0 * d3
    k0 = ys[0]
    roots: list[float]
    if k3 != 0.0 and abs(k3) > 1e-14 * (abs(k2) + abs(k1) + abs(k0)):
        # multiply by (u - far) with far outside [0, 3] to use the quartic solver
        far = -10.0
        q3 = k2 / k3 - far
        q2 = k1 / k3 - far * k2 / k3
        q1 = k0 / k3 - far * k1 / k3
        q0 = 10.0 * k0 / k3  # -far (spelled out: mypyc folds -far into C's "--10.0")
        roots = quartic_roots_in(q3, q2, q1, q0, 0.0, 3.0)
    else:
        roots = [u for u in quadratic_roots(k2, k1, k0) if 0.0 <= u <= 3.0]
    for u in roots:
        s = s_min + u * w
        if not s_min * (1.0 - 1e-12) <= s <= s_max * (1.0 + 1e-12):
            continue
        s = min(max(s, s_min), s_max)
        r = profile(s)
        if r is None:
            continue
        ph = [(max(x[0], 0.0) if x[0] > -1e-12 * T else x[0], *x[1:]) for x in r[1]]
        out = _accept(ph, T, v0, a0, d, vf, af, vmax, vmin, amax, amin)
        if out is not None:
            return out
    return None


Residual = Callable[[float], "tuple[float, Phases] | None"]


def _root_1d(
    resid: Residual,
    lo: float,
    hi: float,
    n: int,
    T: float,
    args: tuple[float, ...],
) -> Phases | None:
    """A verified profile of duration T where the explicit residual ``resid(x)`` (distance
    error, phases; None where the shape does not exist) changes sign in [lo, hi]: ``n``
    samples, then the Illinois variant of regula falsi on each sign change (no planning inside
    the loop: every evaluation is a closed form). ``args`` are :func:`_accept`'s state and
    limits."""
    if not lo < hi:
        return None
    d = args[2]
    f_tol = 1e-13 * max(1.0, abs(d))
    prev: tuple[float, float] | None = None
    for k in range(n + 1):
        x = lo + (hi - lo) * k / n
        r = resid(x)
        if r is None:
            prev = None
            continue
        f = r[0]
        if abs(f) <= f_tol:
            out = _accept(r[1], T, *args)
            if out is not None:
                return out
        if prev is not None and (prev[1] < 0.0) != (f < 0.0):
            out = _illinois(resid, prev[0], prev[1], x, f, f_tol, T, args)
            if out is not None:
                return out
        prev = (x, f)
    return None


def _illinois(
    resid: Residual,
    a: float,
    fa: float,
    b: float,
    fb: float,
    f_tol: float,
    T: float,
    args: tuple[float, ...],
) -> Phases | None:
    side = 0
    for _it in range(80):
        x = b - fb * (b - a) / (fb - fa)
        if not (a < x < b or b < x < a):
            x = 0.5 * (a + b)
        r = resid(x)
        if r is None:
            return None
        fx = r[0]
        if abs(fx) <= f_tol or abs(b - a) <= 4e-16 * max(1.0, abs(x)):
            return _accept(r[1], T, *args)
        if (fx < 0.0) == (fb < 0.0):
            b, fb = x, fx
            if side == -1:
                fa *= 0.5
            side = -1
        else:
            a, fa = x, fx
            if side == 1:
                fb *= 0.5
            side = 1
    return None


def _distance(ph: Phases, v0: float, a0: float) -> float:
    """The distance the phases travel from (v0, a0) (exact values they carry applied)."""
    p, v, a = 0.0, v0, a0
    for x in ph:
        dur, j = x[0], x[1]
        if len(x) > 2:
            a = x[2]
            if len(x) > 3:
                v = x[3]
        p += dur * (v + dur * (0.5 * a + dur * j / 6.0))
        v += dur * (a + 0.5 * dur * j)
        a += dur * j
    return p


def acc0_free_jerk(
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
    T: float,
) -> Phases | None:
    """Plateau at a_max, trough Q free, ramps of one reduced jerk j = 1/s <= J, lasting T:
    a0 -> a_max (h1) -> Q -> af. For a given s the duration gives h1 and the velocity change a
    quadratic in Q (closed form); the distance residual is then explicit in s and solved by
    :func:`_root_1d` in log s."""
    if amax == _INF or not T > 0.0 or a0 > amax:
        return None
    dv = vf - v0
    c0 = 0.5 * (af * af - a0 * a0) - amax * amax + amax * (a0 - af)
    rhs = dv - amax * T
    args = (v0, a0, d, vf, af, vmax, vmin, amax, amin)

    def resid(x: float) -> tuple[float, Phases] | None:
        sv = math.exp(x) / J
        rad = amax * amax + c0 - rhs / sv
        if rad < 0.0:
            return None
        Q = amax - math.sqrt(rad)
        if Q > af or Q < amin:
            return None
        h1 = T - (2.0 * amax - a0 + af - 2.0 * Q) * sv
        if h1 < 0.0:
            return None
        j = 1.0 / sv
        ph: Phases = [
            ((amax - a0) * sv, j),
            (h1, 0.0, amax),
            ((amax - Q) * sv, -j),
            ((af - Q) * sv, j),
        ]
        return _distance(ph, v0, a0) - d, ph

    width = max(2.0 * amax - a0 - af, 1e-9 * max(amax, 1e-300))
    x_hi = min(math.log(J * T / width), 40.0)
    return _root_1d(resid, 0.0, x_hi, 16, T, args)


def acc1_free_jerk(
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
    T: float,
) -> Phases | None:
    """Peak P free, plateau at a_min, ramps of one reduced jerk j = 1/s <= J, lasting T:
    a0 -> P -> a_min (h2) -> af; as :func:`acc0_free_jerk` with P from the quadratic."""
    if amin == -_INF or not T > 0.0 or af < amin:
        return None
    dv = vf - v0
    c1 = amin * amin + amin * (a0 - af) + 0.5 * (af * af - a0 * a0)
    rhs = dv - amin * T
    args = (v0, a0, d, vf, af, vmax, vmin, amax, amin)

    def resid(x: float) -> tuple[float, Phases] | None:
        sv = math.exp(x) / J
        rad = amin * amin - c1 + rhs / sv
        if rad < 0.0:
            return None
        P = amin + math.sqrt(rad)
        if P < a0 or P > amax:
            return None
        h2 = T - (2.0 * P - a0 - 2.0 * amin + af) * sv
        if h2 < 0.0:
            return None
        j = 1.0 / sv
        ph: Phases = [
            ((P - a0) * sv, j),
            ((P - amin) * sv, -j),
            (h2, 0.0, amin),
            ((af - amin) * sv, j),
        ]
        return _distance(ph, v0, a0) - d, ph

    width = max(af + a0 - 2.0 * amin, 1e-9 * max(-amin, 1e-300))
    x_hi = min(math.log(J * T / width), 40.0)
    return _root_1d(resid, 0.0, x_hi, 16, T, args)


def cruise_free_velocity(
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
    T: float,
) -> Phases | None:
    """A cruise at a free velocity vp between the two time-optimal velocity changes of the
    full jerk (closed form each, ``_velocity.velocity_third``), lasting T: the cruise time is
    T minus the changes, the distance residual is explicit in vp and solved by
    :func:`_root_1d` (Ruckig's step-2 VEL families with a free cruise velocity)."""
    if not T > 0.0:
        return None
    span = abs(v0) + abs(vf) + 4.0 * abs(d) / T + 1.0
    lo = max(vmin, -span)
    hi = min(vmax, span)
    args = (v0, a0, d, vf, af, vmax, vmin, amax, amin)

    def resid(vp: float) -> tuple[float, Phases] | None:
        t1, ph1 = velocity_third(v0, a0, vp, 0.0, amax, amin, J)
        t2, ph2 = velocity_third(vp, 0.0, vf, af, amax, amin, J)
        c = T - t1 - t2
        if c < 0.0:
            return None
        ph: Phases = [*ph1, (c, 0.0, 0.0, vp), *ph2]
        return _distance(ph, v0, a0) - d, ph

    return _root_1d(resid, lo, hi, 24, T, args)


def _mirror(ph: tuple[float, ...]) -> tuple[float, ...]:
    return (ph[0], *(-x for x in ph[1:]))


def solve(
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
    T: float,
) -> tuple[Phases, str] | None:
    """The first verified profile of duration T over the closed-form families (in the order
    of the module docstring, each in both orientations), as (phases, kind), or None when no
    family yields one (the caller's fallback then decides)."""
    if J == _INF or not T > 0.0:
        return None
    up = (v0, a0, d, vf, af, vmax, vmin, amax, amin, J, T)
    ph = none_free_jerk(*up)
    if ph is not None:
        return ph, "none-j"
    down = (-v0, -a0, -d, -vf, -af, -vmin, -vmax, -amin, -amax, J, T)
    for fam, name in _ORDER:
        if fam is cruise_free_velocity:  # covers both orientations itself
            ph = fam(*up)
            if ph is not None:
                return ph, name
            continue
        ph = fam(*up)
        if ph is not None:
            return ph, name
        ph = fam(*down)
        if ph is not None:
            return [_mirror(x) for x in ph], name + "-down"
    return None


# The families after none_free_jerk (which covers both orientations itself), by how often
# they answer the benchmark's random cases and what a miss costs: none-j 89 %, cruise-vp 6 %,
# vel-j 2.3 %, acc0_acc1-j 1.6 %, acc0-j 0.5 %, acc1-j 0.2 % of the slowed axes; the cheap
# closed forms first, the sampled residuals last.
_ORDER: tuple[tuple[Callable[..., Phases | None], str], ...] = (
    (vel_free_jerk, "vel-j"),
    (acc0_acc1_free_jerk, "acc0_acc1-j"),
    (cruise_free_velocity, "cruise-vp"),
    (acc0_free_jerk, "acc0-j"),
    (acc1_free_jerk, "acc1-j"),
)
