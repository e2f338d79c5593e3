"""plan_batch row by row on plain floats (compiled with mypyc together with the planning core).

:func:`plan_rows` plans a list of problems one row at a time: rest to rest with a finite jerk
limit by :func:`rest_row` (the closed forms of ``batch._rest_to_rest`` / ``batch._families``,
operation for operation on floats, so the same bits as the numpy path), every other row by the
core (``plan.position_phases``, called directly in C when compiled), and integrates each
profile as ``Profile.__init__`` does (the same operations: the same bits as :func:`plan`); the
numpy path sends it its core rows too. It reads its inputs from bytes and writes its segments
to ``librt.strings`` byte writers, as little-endian doubles, which mypyc compiles to inline C:
no Python float per value. It never touches numpy: :mod:`motionplc.planning.batch` reads the
bytes as arrays.

Compiled, a row costs a few hundred nanoseconds beyond the core's own solver time (no State,
Profile or phase-array objects per row); as plain Python the same code runs unchanged.
"""

from __future__ import annotations

import math
from typing import Final

from motionplc.errors import PlanningError
from motionplc.planning.limits import LIMIT_MAX, LIMIT_MIN, STATE_MAX
from motionplc.planning.plan import MAX_DURATION, arrived, position_phases
from motionplc.planning.roots import cbrt

try:  # inline C when compiled (no Python float per value); the stand-in without librt
    from librt.strings import BytesWriter, read_f64_le, write_f64_le
except ImportError:  # pragma: no cover - librt is a dependency on CPython
    from motionplc.planning._f64io import (  # type: ignore[assignment]
        BytesWriter,
        read_f64_le,
        write_f64_le,
    )

_INF: Final = math.inf
_NAN: Final = math.nan
_EPS: Final = 2.220446049250313e-16
_KEEP: Final = 1.0 - 1e-12  # time_optimal: a later family must be faster by more than rounding
_T_TOL: Final = 1e-12  # _third._T_TOL
_LIM_TOL: Final = 1e-12  # _third._LIM_TOL

# Kind codes of the rest-to-rest rows solved in closed form (Profile.kind as plan names them);
# code + 1: mirrored (d < 0)
KIND_NAMES: Final[tuple[str, ...]] = (  # (a tuple object: indexed without boxing)
    "none-rest", "none-rest", "vel", "vel-down", "acc0_acc1", "acc0_acc1-down",
    "none", "none-down", "acc0", "acc0-down", "acc1", "acc1-down",
    "second-order", "first-order",
)  # fmt: skip
NR: Final = 0
VEL: Final = 2
ACC: Final = 4
NONE: Final = 6
ACC0: Final = 8
ACC1: Final = 10
SECOND: Final = 12
FIRST: Final = 13


def _min(a: float, b: float) -> float:
    """min(a, b) on floats (the first unless the second is smaller), without boxing."""
    return b if b < a else a


def _max(a: float, b: float) -> float:
    """max(a, b) on floats (the first unless the second is larger), without boxing."""
    return b if b > a else a


def _pos(x: float) -> float:
    """np.maximum(x, 0.0) on a float (NaN stays NaN)."""
    return 0.0 if x < 0.0 else x


RestRow = tuple[
    bool, float, float, float, float, float, float, float, float, float, float, int, bool
]
_NO_REST: Final = (False, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0, False)


def rest_row(
    p0: float, d: float, vmax: float, vmin: float, amax: float, amin: float, J: float
) -> RestRow:
    """One rest-to-rest row (finite J, d beyond ``arrived``) as ``batch._rest_to_rest`` and
    ``batch._families`` compute it, operation for operation on floats (the same bits): (True,
    the seven phase durations, P, Q, cruise velocity, kind code, down), or (False, ...) where
    no closed form accepts the row (it goes to the core). A tuple of primitives: compiled, it
    is returned unboxed."""
    tr = cbrt(abs(d) / (2.0 * J))  # _third.time_optimal's and batch's cube root
    down = d < 0.0
    if J * tr <= _min(amax, -amin) and J * tr * tr <= _min(vmax, -vmin):
        return True, tr, 0.0, 2.0 * tr, 0.0, 0.0, 0.0, tr, 0.0, 0.0, 0.0, NR, down
    if down:
        D, Vmax, Amax, Amin = -d, -vmin, -amin, -amax
    else:
        D, Vmax, Amax, Amin = d, vmax, amax, amin
    # vel
    P = math.sqrt(J * Vmax)
    if P <= Amax:
        h1 = 0.0
    else:
        h1 = _pos((Vmax - 2.0 * Amax * Amax / (2.0 * J)) / Amax)
        P = Amax
    Q = -math.sqrt(J * Vmax)
    if Q >= Amin:
        h2 = 0.0
    else:
        h2 = _pos((-Vmax - (0.0 - 2.0 * Amin * Amin) / (2.0 * J)) / Amin)
        Q = Amin
    t1 = P / J
    t5 = -Q / J
    v1 = t1 * (0.5 * t1 * J)
    v2 = v1 + h1 * P
    d1 = t1 * (t1 * (t1 * J / 6.0)) + h1 * (v1 + 0.5 * h1 * P)
    d1 = d1 + t1 * (v2 + t1 * (0.5 * P - t1 * J / 6.0))
    v5 = Vmax - 0.5 * t5 * t5 * J
    v6 = v5 + h2 * Q
    d2 = t5 * (Vmax - t5 * t5 * J / 6.0) + h2 * (v5 + 0.5 * h2 * Q)
    d2 = d2 + t5 * (v6 + t5 * (0.5 * Q + t5 * J / 6.0))
    cruise = (D - d1 - d2) / Vmax
    vel = Vmax != _INF and cruise >= -_T_TOL * _max(1.0, abs(D / Vmax))
    cruise = _pos(cruise)
    t_best = (t1 + h1 + t1 + cruise + t5 + h2 + t5) * _KEEP if vel else _INF
    # acc0_acc1
    acc = False
    acc_h1 = 0.0
    acc_h2 = 0.0
    if Amax != _INF and (2.0 * Amax - 2.0 * Amin) / J < t_best:
        ramps = (2.0 * Amax - 2.0 * Amin) / J
        A2 = Amax * Amax
        N2 = Amin * Amin
        JJ = J * J
        tA = Amax / J
        tB = (Amax - Amin) / J
        tC = (0.0 - Amin) / J
        b = -(0.0 - Amax * Amin + 2.0 * N2) / (J * Amin)
        c = (
            24.0 * JJ * Amax * D
            - 12.0 * A2 * N2
            + 24.0 * Amax * (Amin * Amin * Amin)
            - 12.0 * N2 * N2
        ) / (12.0 * JJ * Amin * (Amax - Amin))  # fmt: skip
        vhi = Vmax + _LIM_TOL * (Vmax if Vmax > 1.0 else 1.0)
        # batch._quadratic_roots(b, c)
        disc = b * b - 4.0 * c
        if disc < 0.0:
            lo = -b / 2.0 if disc > -1e-14 * (b * b + abs(4.0 * c)) else _NAN
            hi = _NAN
        else:
            sq = math.sqrt(disc)
            q = -0.5 * (b + sq) if b >= 0.0 else -0.5 * (b - sq)
            r2 = c / q if q != 0.0 else q
            if q != q or r2 != r2:
                lo = hi = _NAN
            else:
                lo, hi = (q, r2) if q <= r2 else (r2, q)
        for i in range(2):  # (lo, hi) without a tuple of boxed floats
            r = lo if i == 0 else hi
            if not r >= -_T_TOL:  # NaN: no root
                continue
            r = _pos(r)
            hh1 = (0.0 - 2.0 * A2 + 2.0 * N2 - 2.0 * J * Amin * r) / (2.0 * J * Amax)
            if not hh1 >= -_T_TOL:
                continue
            hh1 = _pos(hh1)
            if not ramps + hh1 + r < t_best:
                continue
            vz = tA * (0.5 * tA * J)
            if hh1 > 0.0:
                az = Amax
                vz = vz + hh1 * az
            else:
                az = tA * J
            tz = -az / -J
            vz = vz + tz * (az + 0.5 * tz * -J)
            if vz > vhi:
                continue
            tt = tA + hh1 + tB + r + tC
            if tt < t_best:
                acc, acc_h1, acc_h2, t_best = True, hh1, r, tt
        if acc:
            return True, tA, acc_h1, tB, 0.0, 0.0, acc_h2, tC, Amax, Amin, Vmax, ACC + down, down
    if vel:
        return True, t1, h1, t1, cruise, t5, h2, t5, P, Q, Vmax, VEL + down, down
    # no cruise, at most one plateau (asymmetric limits)
    Br = -Amin
    vtol = Vmax * (1.0 + 1e-12)
    sJ = math.sqrt(J)
    if J * tr <= Amax and J * tr <= Br and J * tr * tr <= vtol:
        return True, tr, 0.0, 2.0 * tr, 0.0, 0.0, 0.0, tr, 0.0, 0.0, Vmax, NONE + down, down
    bb = Amax / sJ
    cc = math.sqrt(2.0 * Amax * D)
    s0 = 2.0 * cc / (bb + math.sqrt(bb * bb + 4.0 * cc))
    V0 = s0 * s0
    q0 = sJ * s0
    h0 = V0 / Amax - Amax / J
    if (
        h0 >= -_T_TOL * _max(1.0, Amax / J)
        and q0 <= Br * (1.0 + 1e-12)
        and V0 <= vtol
    ):  # fmt: skip
        c0, c1, c2, c6 = Amax / J, _pos(h0), (Amax + q0) / J, q0 / J
        return True, c0, c1, c2, 0.0, 0.0, 0.0, c6, Amax, -q0, Vmax, ACC0 + down, down
    bb = Br / sJ
    cc = math.sqrt(2.0 * Br * D)
    s1 = 2.0 * cc / (bb + math.sqrt(bb * bb + 4.0 * cc))
    V1 = s1 * s1
    p1 = sJ * s1
    h1r = V1 / Br - Br / J
    if (
        h1r >= -_T_TOL * _max(1.0, Br / J)
        and p1 <= Amax * (1.0 + 1e-12)
        and V1 <= vtol
    ):  # fmt: skip
        c0, c2, c5, c6 = p1 / J, (p1 + Br) / J, _pos(h1r), Br / J
        return True, c0, 0.0, c2, 0.0, 0.0, c5, c6, p1, -Br, Vmax, ACC1 + down, down
    return _NO_REST


ROW_BYTES: Final = 88  # an input row of plan_rows: eleven little-endian doubles
WIDTH: Final = 7  # segments per row in the ``seg`` output (batch.MIN_WIDTH)

# The output of plan_rows, little-endian doubles (batch._rows and batch._core_rows read it):
# ``seg``: per row its first WIDTH segments (start time, duration, jerk, p, v, a), padded to
# WIDTH with (duration, 0, 0, end state); ``ends``: per row (end p, v, a, duration, segment
# count); ``wide``: the segments beyond WIDTH of the rows listed in ``wide_rows``.


def _write_segment(
    w: BytesWriter, t: float, x: float, j: float, p: float, v: float, a: float
) -> None:
    write_f64_le(w, t)
    write_f64_le(w, x)
    write_f64_le(w, j)
    write_f64_le(w, p)
    write_f64_le(w, v)
    write_f64_le(w, a)


def _end_row(
    seg: BytesWriter, ends: BytesWriter, n: int, p: float, v: float, a: float, t: float
) -> None:
    """A row's padding (to WIDTH segments) and its end state, duration and segment count."""
    for _k in range(n, WIDTH):  # (not '_': typed object, boxed per step)
        _write_segment(seg, t, 0.0, 0.0, p, v, a)
    write_f64_le(ends, p)
    write_f64_le(ends, v)
    write_f64_le(ends, a)
    write_f64_le(ends, t)
    write_f64_le(ends, float(n))


def rest_segments(
    p0: float, r: RestRow, J: float, seg: BytesWriter
) -> tuple[int, float, float, float, float]:
    """``batch._rest_to_rest``'s integration of one :func:`rest_row` on floats (the same
    operations): the segments of the phases of positive duration (at most seven) written to
    ``seg``; returns (their count, the end state, the duration)."""
    s = -1.0 if r[12] else 1.0
    P = r[8]
    Q = r[9]
    VC = r[10]
    sj = s * J
    zj = s * 0.0
    st = (0, 0.0, p0, 0.0, 0.0)  # (segments, t, p, v, a)
    st = _rest_ramp(r[1], sj, st, seg)
    st = _rest_plateau(r[2], s * P, zj, st, seg)
    st = _rest_ramp(r[3], -sj, st, seg)
    if r[4] > 0.0:  # the cruise: zero acceleration, the exact velocity
        m, t, p, v, a = st
        st = _rest_plateau(r[4], zj, zj, (m, t, p, s * VC, a), seg)
    st = _rest_ramp(r[5], -sj, st, seg)
    st = _rest_plateau(r[6], s * Q, zj, st, seg)
    m, t, p, v, a = _rest_ramp(r[7], sj, st, seg)
    return m, p, v, a, t


def _rest_ramp(
    x: float, jj: float, st: tuple[int, float, float, float, float], seg: BytesWriter
) -> tuple[int, float, float, float, float]:
    """One ramp of :func:`rest_segments` (jerk ``jj``; none without a positive duration)."""
    m, t, p, v, a = st
    if not x > 0.0:  # no duration: changes nothing, no segment
        return st
    _write_segment(seg, t, x, jj, p, v, a)
    xj = x * jj
    p = p + x * (v + x * (0.5 * a + xj / 6.0))
    v = v + x * (a + 0.5 * xj)
    a = a + xj
    return m + 1, t + x, p, v, a


def _rest_plateau(
    x: float, a: float, zj: float, st: tuple[int, float, float, float, float], seg: BytesWriter
) -> tuple[int, float, float, float, float]:
    """One plateau of :func:`rest_segments` at the exact acceleration ``a`` (zero jerk
    ``zj``); none (and nothing set) without a positive duration."""
    m, t, p, v, _a = st
    if not x > 0.0:
        return st
    _write_segment(seg, t, x, zj, p, v, a)
    p = p + x * (v + x * (0.5 * a))
    v = v + x * a
    return m + 1, t + x, p, v, a


def phase_segments(
    p0: float,
    v0: float,
    a0: float,
    phases: list[tuple[float, ...]],
    seg: BytesWriter,
    wide: BytesWriter,
) -> tuple[int, float, float, float, float]:
    """``batch._integrate_phases`` (Profile.__init__'s operations) for one phase list on
    floats: the first WIDTH segments written to ``seg``, the others to ``wide``; returns
    (their count, the end state, the duration)."""
    t = 0.0
    p = p0
    v = v0
    a = a0
    m = 0
    for ph in phases:
        x = ph[0]
        jj = ph[1]
        if len(ph) > 2:
            a = ph[2]
            if len(ph) > 3:
                v = ph[3]
        if x > 0.0:
            _write_segment(seg if m < WIDTH else wide, t, x, jj, p, v, a)
            m += 1
            p = p + x * (v + x * (0.5 * a + x * jj / 6.0))
            v2 = v + x * (a + 0.5 * x * jj)
            a = a + x * jj
            v = v2
            t = t + x
    return m, p, v, a, t


def _too_long(i: int, T: float) -> PlanningError:
    return PlanningError(
        f"problem {i}: the profile would last {T:.6g} s, beyond the supported "
        f"{MAX_DURATION:g} s (limits far too small for the states: double precision cannot keep "
        "its end state and continuity)"
    )


def _row_failure(i: int, exc: Exception) -> PlanningError:
    """The error of problem ``i`` whose planning raised ``exc`` (a PlanningError or, a planner
    defect, an ArithmeticError), chained to it."""
    if isinstance(exc, PlanningError):
        err = PlanningError(f"problem {i}: {exc}")
    else:
        err = PlanningError(
            f"plan_batch: internal numerical failure ({type(exc).__name__}: {exc}) "
            f"for problem {i} (planner defect: please report these inputs)"
        )
    err.__cause__ = exc
    return err


def plan_rows(
    src: bytes,
    rows: int,
    base: int,
    seg: BytesWriter,
    ends: BytesWriter,
    wide: BytesWriter,
    wide_rows: list[int],
    kinds: list[str],
    errors: list[PlanningError | None],
    numbers: list[int] | None = None,
) -> None:
    """Validated problems: ``rows`` rows of eleven little-endian doubles in ``src`` (p0, v0,
    a0, pf, vf, af, v_max, v_min, a_max, a_min, j_max; row ``k`` is problem ``base + k``, or
    ``numbers[k]`` in error messages if given), row by row, written to ``seg``, ``ends`` and
    ``wide`` (see above; listed in ``wide_rows`` as ``base + k`` if wider than WIDTH), their
    kinds appended to ``kinds``. Rest to rest with a finite jerk limit:
    :func:`rest_row` (the numpy path's arithmetic); every other row by the core, as the numpy
    path dispatches them. A row that fails writes nothing: ``errors`` (three entries) keeps
    the first failure of each group of the numpy path's order (closed-form rest to rest, rest
    to rest without a jerk limit, the core's rows), for the caller to raise the first one."""
    eps = 8.0 * _EPS
    for k in range(rows):  # (rows, not m: compiled, range() reads its bound per step)
        o = ROW_BYTES * k
        i = base + k if numbers is None else numbers[k]
        p0 = read_f64_le(src, o)
        v0 = read_f64_le(src, o + 8)
        a0 = read_f64_le(src, o + 16)
        pf = read_f64_le(src, o + 24)
        vf = read_f64_le(src, o + 32)
        af = read_f64_le(src, o + 40)
        vmax = read_f64_le(src, o + 48)
        vmin = read_f64_le(src, o + 56)
        amax = read_f64_le(src, o + 64)
        amin = read_f64_le(src, o + 72)
        jm = read_f64_le(src, o + 80)
        d = pf - p0
        group = 2
        if (
            v0 == 0.0
            and a0 == 0.0
            and vf == 0.0
            and af == 0.0
            and not abs(d) <= _max(1e-15, eps * _max(abs(p0), abs(pf)))
        ):
            if jm == _INF:
                group = 1
            else:
                rr = rest_row(p0, d, vmax, vmin, amax, amin, jm)
                if rr[0]:
                    code = rr[11]
                    m, pe, ve, ae, te = rest_segments(p0, rr, jm, seg)
                    if not te <= MAX_DURATION and errors[0] is None:
                        errors[0] = _too_long(i, te)
                    _end_row(seg, ends, m, pe, ve, ae, te)
                    kinds.append(KIND_NAMES[code])
                    continue
        if arrived(p0, v0, a0, pf, vf, af):
            _end_row(seg, ends, 0, p0, vf, af, 0.0)
            kinds.append("arrived")
            continue
        try:
            T, phases, kind = position_phases(v0, a0, d, vf, af, vmax, vmin, amax, amin, jm)
        except (PlanningError, ArithmeticError) as exc:
            if errors[group] is None:
                errors[group] = _row_failure(i, exc)
            continue  # (nothing written: the caller raises the first error)
        if not T <= MAX_DURATION:
            if errors[group] is None:
                errors[group] = _too_long(i, T)
            continue
        m, pe, ve, ae, te = phase_segments(p0, v0, a0, phases, seg, wide)
        if m > WIDTH:
            wide_rows.append(base + k)
        _end_row(seg, ends, m, pe, ve, ae, te)
        kinds.append(kind)


def rows_valid(src: bytes, n: int) -> bool:
    """True when every row of ``src`` (``n`` rows of eleven little-endian doubles: p0, v0,
    a0, pf, vf, af, v_max, v_min, a_max, a_min, j_max) passes the usual checks (states in
    [-STATE_MAX, STATE_MAX], v_max and j_max in [LIMIT_MIN, LIMIT_MAX] or inf, v_min likewise
    negated, a_max and -a_min in range and finite; a target in motion inside the limits and
    reachable: ``batch._validate`` with its arithmetic); False (NaN included): let the
    vectorised checks of plan_batch decide and name the error. Never True where those
    checks would raise."""
    sm = float(STATE_MAX)
    lo = float(LIMIT_MIN)
    hi = float(LIMIT_MAX)
    for k in range(n):
        o = ROW_BYTES * k
        amax = read_f64_le(src, o + 64)
        amin = read_f64_le(src, o + 72)
        if not (
            -sm <= read_f64_le(src, o) <= sm
            and -sm <= read_f64_le(src, o + 8) <= sm
            and -sm <= read_f64_le(src, o + 16) <= sm
            and -sm <= read_f64_le(src, o + 24) <= sm
            and lo <= amax <= hi
            and -hi <= amin <= -lo
        ):
            return False
        vmax = read_f64_le(src, o + 48)
        if not (lo <= vmax <= hi or vmax == _INF):
            return False
        jm = read_f64_le(src, o + 80)
        if not (lo <= jm <= hi or jm == _INF):
            return False
        vmin = read_f64_le(src, o + 56)
        if not (-hi <= vmin <= -lo or vmin == -_INF):
            return False
        vf = read_f64_le(src, o + 32)
        af = read_f64_le(src, o + 40)
        if vf != 0.0 or af != 0.0:  # (a and j limits finite or j infinite: see _validate)
            if not (-sm <= vf <= sm and -sm <= af <= sm):
                return False
            if not (vmin <= vf <= vmax and amin <= af <= amax):
                return False
            if jm == _INF:
                if af != 0.0:
                    return False
            else:
                half = 0.5 * af * af / jm
                if af < 0.0 and vf + half > vmax * (1.0 + 1e-12):
                    return False
                if af > 0.0 and vf - half < vmin * (1.0 + 1e-12):
                    return False
    return True
