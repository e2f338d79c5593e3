"""Time-optimal third-order (jerk-limited) position profiles from a state inside the limits.

Structure (see seeds 003/004 and Berscheid & Kroeger 2021): a time-optimal profile is
bang-zero-bang in jerk with at most seven phases. Its acceleration is a zig-zag of three
ramps of slope +-J, either "up" (a0 -> P -> Q -> af with P >= Q, shape U D U, jerk
+J, -J, +J) or "down" (the mirror image). Plateaus of zero jerk sit at the corners only where
the corner is an acceleration limit (P = a_max with duration h1, Q = a_min with duration h2),
and a cruise of zero acceleration sits inside the middle ramp only where the velocity is at
its limit (v = v_max for "up").

Which limits are active gives the families solved here for the "up" shape (the "down" shape
is the same code on the mirrored problem p -> -p):

* VEL: cruise at v_max. The halves (v0, a0) -> (v_max, 0) and (v_max, 0) -> (vf, af) are
  independent velocity changes in closed form; the cruise time follows from the distance.
* NONE: P and Q free. With u = P - Q the velocity equation gives P + Q = K / (2u) and the
  position equation a depressed quartic in u.
* ACC0: P = a_max, plateau h1 >= 0, Q free: a quartic in Q.
* ACC1: Q = a_min, plateau h2 >= 0, P free: a quartic in P.
* ACC0_ACC1: both plateaus: a quadratic in h2.

The polynomials were derived symbolically from the phase equations (the derivation is in
``tools/derive_third_order.py``). Every root in the family's admissible interval is turned
into phases, and every candidate is verified by integrating its phases: it must end at the
target and stay within the limits. The fastest verified candidate wins.
"""

from __future__ import annotations

import math
from typing import Final

from motionplc.planning.roots import _quadratic, cbrt, quartic_roots_in

# A candidate is (duration, phases) with phases a list of (duration, jerk).
# (duration, jerk[, exact acceleration at the phase start[, exact velocity]]): the planner
# passes exact plateau/cruise values so that rounding does not drift over long phases.
Phases = list[tuple[float, ...]]
_NO_PHASES: Final[Phases] = []  # _check's phases of a failed candidate (never mutated)

# (Final: a compiled build uses the values, not a lookup of the module's globals per use)
_T_TOL: Final = 1e-12  # relative tolerance on a negative phase duration from rounding
_NEG_TOL: Final = 1e-11  # ... of a phase the verification drops (it checks the end state after it)
_P_TOL: Final = 1e-8
_V_TOL: Final = 1e-8
_A_TOL: Final = 1e-10
_LIM_TOL: Final = 1e-12  # relative margin on the limits for rounding


def _cube(x: float) -> float:
    """``x ** 3`` as two products (odd in ``x`` bit for bit, as the mirrored problem needs;
    no call of C's pow, which costs ~250 instructions and whose last bit is the platform's)."""
    return x * x * x


def _fourth(x: float) -> float:
    """``x ** 4`` as ``(x x)(x x)`` (even in ``x`` bit for bit; see :func:`_cube`)."""
    s = x * x
    return s * s


def _check(
    phases: Phases,
    v0: float,
    a0: float,
    d: float,
    vf: float,
    af: float,
    vmax: float,
    vmin: float,
    amax: float,
    amin: float,
) -> tuple[bool, float, Phases]:
    """Integrate the phases; (True, duration, phases) when they reach the target within
    tolerance and respect the limits, else (False, 0, []) -- a plain tuple (the compiled build
    returns it unboxed; :func:`_verify` is the optional form). Durations a rounding error
    below zero are accepted (Profile drops non-positive phases)."""
    # relative margins; infinite limits stay infinite
    vhi = vmax + _LIM_TOL * (vmax if vmax > 1.0 else 1.0)
    vlo = vmin - _LIM_TOL * (-vmin if vmin < -1.0 else 1.0)
    ahi = amax + _LIM_TOL * (amax if amax > 1.0 else 1.0)
    alo = amin - _LIM_TOL * (-amin if amin < -1.0 else 1.0)
    p = 0.0
    v = v0
    a = a0
    t = 0.0
    pmax = 0.0
    vmag = abs(v0)
    for ph in phases:
        dur = ph[0]
        if dur <= 0.0:
            if dur < 0.0:
                # a phase a root's rounding below zero (near a double root the roots are only
                # good to ~sqrt(eps)): dropped; the end state below decides whether the rest
                # still reaches the target
                total = sum(abs(x[0]) for x in phases)
                if dur < -_NEG_TOL * (total if total > 1.0 else 1.0):
                    return False, 0.0, _NO_PHASES
            continue
        j = ph[1]
        if len(ph) > 2:
            a = ph[2]
            if len(ph) > 3:
                v = ph[3]
        if j != 0.0:
            a1 = a + dur * j
            if (a < 0.0) != (a1 < 0.0):
                tz = -a / j
                vz = v + tz * (a + 0.5 * tz * j)
                if vz > vhi or vz < vlo:
                    return False, 0.0, _NO_PHASES
            p += dur * (v + dur * (0.5 * a + dur * j / 6.0))
            v += dur * (a + 0.5 * dur * j)
            a = a1
        else:
            p += dur * (v + 0.5 * dur * a)
            v += dur * a
        t += dur
        if v > vhi or v < vlo or a > ahi or a < alo:
            return False, 0.0, _NO_PHASES
        if p > pmax:
            pmax = p
        elif -p > pmax:
            pmax = -p
        if v > vmag:
            vmag = v
        elif -v > vmag:
            vmag = -v
    # tolerances: absolute for ordinary moves, growing with the excursion for huge ones
    # (double precision cannot end within 1e-8 of a target after travelling 1e9)
    e = p - d
    if e > 0.0 and e > _P_TOL * max(1.0, abs(d)) + 1e-13 * pmax:
        return False, 0.0, _NO_PHASES
    if e < 0.0 and -e > _P_TOL * max(1.0, abs(d)) + 1e-13 * pmax:
        return False, 0.0, _NO_PHASES
    if abs(v - vf) > _V_TOL * max(1.0, abs(vf)) + 1e-13 * vmag:
        return False, 0.0, _NO_PHASES
    if abs(a - af) > _A_TOL * max(1.0, abs(af)):
        return False, 0.0, _NO_PHASES
    # Drop phases of no duration: in a jerk-limited profile the acceleration is continuous, so
    # the exact plateau value such a phase carries must not act as a jump (it may differ by a
    # rounding error from where a skipped, rounding-negative ramp left the acceleration).
    for ph in phases:
        if ph[0] <= 0.0:
            return True, t, [x for x in phases if x[0] > 0.0]
    return True, t, phases


def _verify(
    phases: Phases,
    v0: float,
    a0: float,
    d: float,
    vf: float,
    af: float,
    vmax: float,
    vmin: float,
    amax: float,
    amin: float,
) -> tuple[float, Phases] | None:
    """:func:`_check` as (duration, phases), or None where it fails."""
    ok, t, ph = _check(phases, v0, a0, d, vf, af, vmax, vmin, amax, amin)
    return (t, ph) if ok else None


def _up_phases(a0: float, af: float, P: float, h1: float, Q: float, h2: float, J: float) -> Phases:
    return [((P - a0) / J, J), (h1, 0.0, P), ((P - Q) / J, -J), (h2, 0.0, Q), ((af - Q) / J, J)]


def _half_up(v0: float, a0: float, v1: float, amax: float, J: float) -> tuple[bool, float, float]:
    """Velocity change (v0, a0) -> (v1, 0) with shape up-down: (found, peak P >= max(a0, 0),
    plateau h); a plain tuple of primitives (a compiled build returns it unboxed)."""
    dv = v1 - v0
    rad = J * dv + 0.5 * a0 * a0
    # a start a rounding error beyond v1 (or one whose acceleration overshoots it by a
    # rounding error) still gets the half: the verification bounds the overshoot
    slack = 1e-12 * J * max(1.0, abs(v1))
    if rad < -slack:
        return False, 0.0, 0.0
    P = math.sqrt(max(rad, 0.0))
    if P < a0 and a0 * a0 - P * P > 2.0 * slack:
        return False, 0.0, 0.0
    P = max(P, a0)
    if P <= amax:
        return True, P, 0.0
    h = (dv - (2.0 * amax * amax - a0 * a0) / (2.0 * J)) / amax
    return True, amax, max(h, 0.0)


def _half_down_from(
    v1: float, vf: float, af: float, amin: float, J: float
) -> tuple[bool, float, float]:
    """Velocity change (v1, 0) -> (vf, af) with shape down-up: (found, trough Q <= min(0, af),
    plateau h)."""
    dv = vf - v1
    rad = 0.5 * af * af - J * dv
    slack = 1e-12 * J * max(1.0, abs(v1))
    if rad < -slack:
        return False, 0.0, 0.0
    Q = -math.sqrt(max(rad, 0.0))
    if Q > af and af * af - Q * Q > 2.0 * slack:
        return False, 0.0, 0.0
    Q = min(Q, af)
    if Q >= amin:
        return True, Q, 0.0
    h = (dv - (af * af - 2.0 * amin * amin) / (2.0 * J)) / amin
    return True, amin, max(h, 0.0)


def _plateau_domain(lo: float, hi: float, m: float) -> tuple[float, float]:
    """Hull of {x in [lo, hi] : x^2 >= m} (a plateau duration is >= 0 exactly there); a bound
    set by the plateau condition is widened by a rounding margin, the natural bounds are kept
    exact so that a profile ending on a family boundary is found at the interval's end."""
    if m > 0.0:
        r = math.sqrt(m)
        margin = 1e-9 * (r + 1.0)
        if lo > -r:  # the left part [lo, -r] is empty
            lo = max(lo, r - margin)
        if hi < r:  # the right part [r, hi] is empty
            hi = min(hi, -r + margin)
    return lo, hi


Candidate = tuple[float, Phases, str]


def _fam_vel(
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
    t_best: float,
    out: list[Candidate] | None = None,
) -> Candidate | None:
    """Cruise at v_max between two closed-form velocity changes."""
    if vmax == math.inf:
        return None
    up, P, h1 = _half_up(v0, a0, vmax, amax, J)
    if not up:
        return None
    down, Q, h2 = _half_down_from(vmax, vf, af, amin, J)
    if not down:
        return None
    t1 = (P - a0) / J
    t3 = P / J
    t5 = -Q / J
    t7 = (af - Q) / J
    t_ramps = t1 + h1 + t3 + t5 + h2 + t7
    if t_ramps >= t_best and out is None:
        return None
    # distances of the two halves (v1 is the velocity after the first ramp, etc.)
    v1 = v0 + t1 * (a0 + 0.5 * t1 * J)
    v2 = v1 + h1 * P
    d1 = t1 * (v0 + t1 * (0.5 * a0 + t1 * J / 6.0)) + h1 * (v1 + 0.5 * h1 * P)
    d1 += t3 * (v2 + t3 * (0.5 * P - t3 * J / 6.0))
    v5 = vmax - 0.5 * t5 * t5 * J
    v6 = v5 + h2 * Q
    d2 = t5 * (vmax - t5 * t5 * J / 6.0) + h2 * (v5 + 0.5 * h2 * Q)
    d2 += t7 * (v6 + t7 * (0.5 * Q + t7 * J / 6.0))
    cruise = (d - d1 - d2) / vmax
    if cruise < -_T_TOL * max(1.0, abs(d / vmax)):
        return None
    if t_ramps + cruise >= t_best and out is None:
        return None
    ph: Phases = [
        (t1, J),
        (h1, 0.0, P),
        (t3, -J),
        (max(cruise, 0.0), 0.0, 0.0, vmax),
        (t5, -J),
        (h2, 0.0, Q),
        (t7, J),
    ]
    ok, t, ph = _check(ph, v0, a0, d, vf, af, vmax, vmin, amax, amin)
    if not ok:
        return None
    cand = (t, ph, "vel")
    if out is not None:
        out.append(cand)
    return cand if t < t_best else None


def _fam_acc0_acc1(
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
    t_best: float,
    out: list[Candidate] | None = None,
) -> Candidate | None:
    """Plateaus at a_max and a_min: a quadratic in the second plateau duration h2."""
    if amax == math.inf:
        return None
    ramps = (2.0 * amax - a0 - 2.0 * amin + af) / J
    if ramps >= t_best and out is None:
        return None
    K = 2.0 * J * (vf - v0) + a0 * a0 - af * af
    A2 = amax * amax
    N2 = amin * amin
    JJ = J * J
    denom = 12.0 * JJ * amin * (amax - amin)
    b = -(2.0 * J * vf - amax * amin + 2.0 * N2 - af * af) / (J * amin)
    c = (
        24.0 * JJ * amax * d
        + 12.0 * JJ * (v0 * v0 - vf * vf)
        - 12.0 * J * a0 * a0 * v0
        + 24.0 * J * a0 * amax * v0
        - 12.0 * J * A2 * (v0 + vf)
        + 48.0 * J * amax * amin * vf
        - 24.0 * J * amax * af * vf
        - 24.0 * J * N2 * vf
        + 12.0 * J * af * af * vf
        + 3.0 * _fourth(a0)
        - 8.0 * _cube(a0) * amax
        + 6.0 * a0 * a0 * A2
        - 12.0 * A2 * N2
        + 6.0 * A2 * af * af
        + 24.0 * amax * _cube(amin)
        - 24.0 * amax * amin * af * af
        + 8.0 * amax * _cube(af)
        - 12.0 * N2 * N2
        + 12.0 * N2 * af * af
        - 3.0 * _fourth(af)
    ) / denom
    best: Candidate | None = None
    n_roots, q1, q2 = _quadratic(1.0, b, c)  # quadratic_roots' roots, ascending, unboxed
    for i in range(n_roots):
        h2 = q1 if i == 0 else q2
        if h2 < -_T_TOL:
            continue
        h2 = max(h2, 0.0)
        h1 = (K - 2.0 * A2 + 2.0 * N2 - 2.0 * J * amin * h2) / (2.0 * J * amax)
        if h1 < -_T_TOL:
            continue
        h1 = max(h1, 0.0)
        if ramps + h1 + h2 >= t_best:
            continue
        ph = _up_phases(a0, af, amax, h1, amin, h2, J)
        ok, t, ph = _check(ph, v0, a0, d, vf, af, vmax, vmin, amax, amin)
        if ok:
            if out is not None:
                out.append((t, ph, "acc0_acc1"))
            if t < t_best and out is None:
                best = (t, ph, "acc0_acc1")
                t_best = t
    return best


def _fam_none(
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
    t_best: float,
    out: list[Candidate] | None = None,
) -> Candidate | None:
    """No acceleration plateau: a depressed quartic in u = P - Q. The duration
    (2u + af - a0) / J grows with u, so the smallest valid root is the family's best."""
    K = 2.0 * J * (vf - v0) + a0 * a0 - af * af
    # admissible u: P <= a_max and Q >= a_min, i.e. u^2 - 2 a_max u + K/2 <= 0 and
    # u^2 + 2 a_min u - K/2 <= 0 (u > 0); slightly widened, the verification decides
    u_lo = 0.0
    u_hi = math.inf
    if amax != math.inf:
        r1 = amax * amax - 0.5 * K
        r2 = amin * amin + 0.5 * K
        if r1 < 0.0 or r2 < 0.0:
            return None
        s1 = math.sqrt(r1)
        s2 = math.sqrt(r2)
        u_lo = max(max(0.0, amax - s1), -amin - s2)  # pairwise: the builtin's order
        u_hi = min(amax + s1, -amin + s2)
        u_lo -= 1e-9 * (u_hi + 1.0)
        u_hi += 1e-9 * (u_hi + 1.0)
        if u_hi <= 0.0:
            return None
    # P >= a0 and Q <= af: u^2 - 2 a0 u + K/2 >= 0 and u^2 + 2 af u - K/2 >= 0; where the
    # excluded interval of either reaches down to u = 0 it raises the lower end
    r3 = a0 * a0 - 0.5 * K
    if r3 > 0.0:
        s3 = math.sqrt(r3)
        if a0 - s3 <= 0.0:
            u_lo = max(u_lo, (a0 + s3) * (1.0 - 1e-9) - 1e-12)
    r4 = af * af + 0.5 * K
    if r4 > 0.0:
        s4 = math.sqrt(r4)
        if -af - s4 <= 0.0:
            u_lo = max(u_lo, (-af + s4) * (1.0 - 1e-9) - 1e-12)
    base = af - a0
    if (2.0 * max(u_lo, 0.0) + base) / J >= t_best:
        return None
    if t_best != math.inf:
        u_hi = min(u_hi, 0.5 * (J * t_best - base) * (1.0 + 1e-9))
        if u_hi < u_lo:
            return None
    B = 2.0 * J * (v0 + vf) - a0 * a0 - af * af
    C = -(4.0 / 3.0) * (
        3.0 * J * J * d + 3.0 * J * (a0 * v0 - af * vf) - a0 * a0 * a0 + af * af * af
    )
    for u in quartic_roots_in(0.0, 2.0 * B, C, -0.25 * K * K, u_lo, u_hi):
        if u <= 0.0:
            continue
        if (2.0 * u + base) / J >= t_best:
            break
        w = K / (2.0 * u)
        ph = _up_phases(a0, af, 0.5 * (w + u), 0.0, 0.5 * (w - u), 0.0, J)
        ok, t, ph = _check(ph, v0, a0, d, vf, af, vmax, vmin, amax, amin)
        if ok:
            if out is not None:
                out.append((t, ph, "none"))
            elif t < t_best:
                return t, ph, "none"
    return None


def _fam_acc0(
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
    t_best: float,
    out: list[Candidate] | None = None,
) -> Candidate | None:
    """Plateau at P = a_max, trough Q free: a quartic in Q. The duration
    T(Q) = const + Q^2/(J a_max) - 2Q/J falls with Q up to a_max, so the largest valid root
    is the family's best and T(q_hi) bounds the family from below."""
    if amax == math.inf:
        return None
    K = 2.0 * J * (vf - v0) + a0 * a0 - af * af
    A2 = amax * amax
    q_lo, q_hi = _plateau_domain(amin, min(af, amax), A2 - 0.5 * K)
    if q_lo > q_hi:
        return None
    t_const = (2.0 * amax - a0 + af) / J + (K - 2.0 * A2) / (2.0 * J * amax)
    qb = min(q_hi, amax)
    if t_const + qb * qb / (J * amax) - 2.0 * qb / J >= t_best:
        return None
    JJ = J * J
    t2 = 2.0 * J * vf - af * af
    c0 = (
        -(
            24.0 * JJ * amax * d
            + 12.0 * JJ * (v0 * v0 - vf * vf)
            - 12.0 * J * a0 * a0 * v0
            + 24.0 * J * a0 * amax * v0
            - 12.0 * J * A2 * (v0 + vf)
            - 24.0 * J * amax * af * vf
            + 12.0 * J * af * af * vf
            + 3.0 * _fourth(a0)
            - 8.0 * _cube(a0) * amax
            + 6.0 * a0 * a0 * A2
            + 6.0 * A2 * af * af
            + 8.0 * amax * _cube(af)
            - 3.0 * _fourth(af)
        )
        / 12.0
    )
    roots = quartic_roots_in(-2.0 * amax, t2 + A2, -2.0 * amax * t2, c0, q_lo, q_hi)
    for Q in reversed(roots):
        h1 = (K - 2.0 * A2 + 2.0 * Q * Q) / (2.0 * J * amax)
        if h1 < -_T_TOL:
            continue
        ph = _up_phases(a0, af, amax, max(h1, 0.0), Q, 0.0, J)
        ok, t, ph = _check(ph, v0, a0, d, vf, af, vmax, vmin, amax, amin)
        if ok:
            if out is not None:
                out.append((t, ph, "acc0"))
            elif t < t_best:
                return t, ph, "acc0"
    return None


def _fam_acc1(
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
    t_best: float,
    out: list[Candidate] | None = None,
) -> Candidate | None:
    """Peak P free, plateau at Q = a_min: a quartic in P. The duration
    T(P) = const + 2P/J + P^2/(J |a_min|) grows with P >= a_min, so the smallest valid root
    is the family's best and T(p_lo) bounds the family from below."""
    if amax == math.inf:
        return None
    K = 2.0 * J * (vf - v0) + a0 * a0 - af * af
    N2 = amin * amin
    p_lo, p_hi = _plateau_domain(max(a0, amin), amax, N2 + 0.5 * K)
    if p_lo > p_hi:
        return None
    t_const = (-a0 - 2.0 * amin + af) / J + (K + 2.0 * N2) / (2.0 * J * amin)
    pb = max(p_lo, amin)
    if t_const + 2.0 * pb / J - pb * pb / (J * amin) >= t_best:
        return None
    JJ = J * J
    s2 = 2.0 * J * v0 - a0 * a0
    c0 = (
        24.0 * JJ * amin * d
        + 12.0 * JJ * (v0 * v0 - vf * vf)
        - 12.0 * J * a0 * a0 * v0
        + 24.0 * J * a0 * amin * v0
        + 12.0 * J * N2 * (v0 + vf)
        - 24.0 * J * amin * af * vf
        + 12.0 * J * af * af * vf
        + 3.0 * _fourth(a0)
        - 8.0 * _cube(a0) * amin
        - 6.0 * a0 * a0 * N2
        - 6.0 * N2 * af * af
        + 8.0 * amin * _cube(af)
        - 3.0 * _fourth(af)
    ) / 12.0
    for P in quartic_roots_in(-2.0 * amin, s2 + N2, -2.0 * amin * s2, c0, p_lo, p_hi):
        h2 = (K - 2.0 * P * P + 2.0 * N2) / (2.0 * J * amin)
        if h2 < -_T_TOL:
            continue
        ph = _up_phases(a0, af, P, 0.0, amin, max(h2, 0.0), J)
        ok, t, ph = _check(ph, v0, a0, d, vf, af, vmax, vmin, amax, amin)
        if ok:
            if out is not None:
                out.append((t, ph, "acc1"))
            elif t < t_best:
                return t, ph, "acc1"
    return None


# Cheapest families first: their durations bound the quartic families from above.
_FAMILIES = (_fam_vel, _fam_acc0_acc1, _fam_none, _fam_acc0, _fam_acc1)
_N_FAMILIES: Final = 5  # len(_FAMILIES), a constant for the compiled family loop


def _family(
    k: int,
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
    t_best: float,
    out: list[Candidate] | None = None,
) -> Candidate | None:
    """``_FAMILIES[k](...)`` as direct calls (a compiled build then passes the floats unboxed)."""
    if k == 0:
        return _fam_vel(v0, a0, d, vf, af, vmax, vmin, amax, amin, J, t_best, out)
    if k == 1:
        return _fam_acc0_acc1(v0, a0, d, vf, af, vmax, vmin, amax, amin, J, t_best, out)
    if k == 2:
        return _fam_none(v0, a0, d, vf, af, vmax, vmin, amax, amin, J, t_best, out)
    if k == 3:
        return _fam_acc0(v0, a0, d, vf, af, vmax, vmin, amax, amin, J, t_best, out)
    return _fam_acc1(v0, a0, d, vf, af, vmax, vmin, amax, amin, J, t_best, out)


def single_ramp(
    v0: float, a0: float, d: float, vf: float, af: float, J: float
) -> tuple[float, Phases, str] | None:
    """The target lies on one constant-jerk ramp (or is the start itself)."""
    if af == a0:
        j = 0.0
        if a0 == 0.0:
            if v0 == 0.0 or vf != v0:
                return (0.0, [], "hold") if d == 0.0 and vf == v0 else None
            t = d / v0
        else:
            t = (vf - v0) / a0
    else:
        j = J if af > a0 else -J
        t = (af - a0) / j
    if t < 0.0 or math.isinf(t) or math.isnan(t):  # (not isfinite: compiled without a lookup)
        return None
    p = t * (v0 + t * (0.5 * a0 + t * j / 6.0))
    v = v0 + t * (a0 + 0.5 * t * j)
    # the velocity within rounding (1e-12 relative): a target that misses the ramp's end
    # velocity by more is not on it (a looser tolerance accepts a ramp that leaves a real
    # velocity error behind, e.g. 2e-11 m/s next to a limit where the exact answer loops);
    # the position within the verification's tolerance, as the profile that led here
    v_tol = 1e-12 * max(max(1.0, abs(v0)), abs(vf))
    if abs(p - d) <= _P_TOL * max(1.0, abs(d)) and abs(v - vf) <= v_tol:
        return (t, [(t, j)] if t > 0.0 else [], "ramp")
    return None


def time_optimal(
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
) -> Candidate | None:
    """Fastest verified profile over both shapes, or None if no family yields one."""
    best = single_ramp(v0, a0, d, vf, af, J)
    if best is None and v0 == 0.0 and a0 == 0.0 and vf == 0.0 and af == 0.0 and d != 0.0:
        # rest to rest without reaching a limit: four ramps of t = cbrt(|d| / (2J)) -- in
        # closed form, which also serves distances so small that the polynomials underflow
        t = cbrt(abs(d) / (2.0 * J))  # the same bits as batch's numpy (not pow's)
        if J * t <= min(amax, -amin) and J * t * t <= min(vmax, -vmin):
            s = J if d > 0.0 else -J
            ph: Phases = [(t, s), (2.0 * t, -s), (t, s)]
            ok, tv, pv = _check(ph, 0.0, 0.0, d, 0.0, 0.0, vmax, vmin, amax, amin)
            if ok:
                return tv, pv, "none-rest"
    # A later candidate replaces the best so far only if it is faster by more than rounding
    # (1e-12 relative): the ramp and the families in their order (cruise first) win ties.
    # Found: a cruise at v_min "beaten" by 2e-17 s by a dip a rounding beyond v_min.
    keep = 1.0 - 1e-12
    t_best = best[0] * keep if best is not None else math.inf
    best_down = False
    for k in range(_N_FAMILIES):
        c = _family(k, v0, a0, d, vf, af, vmax, vmin, amax, amin, J, t_best)
        if c is not None:
            best, t_best, best_down = c, c[0] * keep, False
        c = _family(k, -v0, -a0, -d, -vf, -af, -vmin, -vmax, -amin, -amax, J, t_best)
        if c is not None:
            best, t_best, best_down = c, c[0] * keep, True
    if best is None or not best_down:
        return best
    return best[0], [mirror(x) for x in best[1]], best[2] + "-down"


def mirror(ph: tuple[float, ...]) -> tuple[float, ...]:
    """The phase of the mirrored axis (p -> -p): jerk and exact values change sign."""
    n = len(ph)  # the usual lengths spelled out (a compiled build then makes no generator)
    if n == 2:
        return (ph[0], -ph[1])
    if n == 3:
        return (ph[0], -ph[1], -ph[2])
    if n == 4:
        return (ph[0], -ph[1], -ph[2], -ph[3])
    return (ph[0], *(-x for x in ph[1:]))


def extremal_profiles(
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
) -> list[Candidate]:
    """Every verified extremal profile of both shapes, sorted by duration, near-duplicates
    (the same profile found by two neighbouring families) removed.

    The fastest is the time-optimal profile. Durations between the 2nd and 3rd (and the 4th
    and 5th) are blocked: no profile within the limits takes them (Kroeger and Wahl 2009;
    Berscheid and Kroeger 2021).
    """
    cands: list[Candidate] = []
    sr = single_ramp(v0, a0, d, vf, af, J)
    # A constant-acceleration piece (zero jerk) is not an extremal profile: it lies inside a
    # range of feasible durations, and counting it would misplace the blocked intervals. It
    # stays only when it is the only profile (a start that is already on the target's path).
    if sr is not None and (not sr[1] or sr[1][0][1] != 0.0):
        cands.append(sr)
    for k in range(_N_FAMILIES):  # each family up, then down (direct calls, see _family)
        _family(k, v0, a0, d, vf, af, vmax, vmin, amax, amin, J, math.inf, cands)
        mirrored: list[Candidate] = []
        _family(k, -v0, -a0, -d, -vf, -af, -vmin, -vmax, -amin, -amax, J, math.inf, mirrored)
        for t, ph, name in mirrored:
            cands.append((t, [mirror(x) for x in ph], name + "-down"))
    if not cands and sr is not None:
        cands.append(sr)
    cands.sort(key=lambda c: c[0])
    unique: list[Candidate] = []
    for c in cands:
        if unique and c[0] - unique[-1][0] <= 1e-12 * max(1.0, c[0]):
            continue
        unique.append(c)
    if sr is not None and unique and unique[0] is not sr:
        # the fastest is as fast as the constant-acceleration piece up to rounding (e.g. a dip
        # a rounding past v_min beside a cruise at v_min): the piece is the optimum, as in
        # time_optimal (the durations, and so the blocked intervals, stay as they are)
        if abs(unique[0][0] - sr[0]) <= 1e-12 * max(1.0, sr[0]):
            unique[0] = sr
    return unique
