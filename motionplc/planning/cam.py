"""Cam tables: a piecewise function master x -> slave y with VDI 2143 motion laws.

A :class:`CamTable` is built from points (master, slave, optionally the slope dy/dx and the
curvature d2y/dx2 at the point) and one motion law per segment (the segment from point i to
point i + 1):

* ``linear``: constant velocity (slope = rise / length, no curvature);
* ``poly5`` (3-4-5 polynomial) and ``poly7`` (4-5-6-7 polynomial): rest to rest they are the
  normalised VDI 2143 laws; with non-zero slope or curvature at an end they are the quintic
  (septic) Hermite polynomial meeting position, slope and curvature at both ends (poly7:
  and zero jerk);
* ``modified_sine``, ``modified_trapezoid``, ``cycloid``, ``harmonic``: the normalised VDI 2143
  rest-to-rest laws (slope 0 at both ends; ``harmonic`` has a non-zero curvature at its ends,
  so the acceleration jumps there unless the neighbouring segment matches it).

The boundary conditions at each point come from the point (an explicit ``slope`` /
``curvature``) or from a neighbouring segment whose law fixes them (``linear`` and the
normalised laws); a point with neither is at rest (slope 0, curvature 0). A ``poly5`` / ``poly7``
segment takes them over, so the table is C2 (continuous slope and curvature, i.e. continuous
slave velocity and acceleration at constant master speed) wherever the laws allow. A point
whose requested slope a law cannot meet (a normalised law starting at a non-zero slope, two
linear segments of different slopes meeting, an explicit slope that contradicts a linear
segment) is refused with a :class:`CamTableError` naming the point, the field and the law.
Curvature jumps that the laws force (``harmonic`` next to a rest) are allowed and reported
(:attr:`CamTable.curvature_jumps`, :meth:`CamTable.periodic_gaps`).

With ``periodic=True`` the first and last point are resolved as one point, so that the table
repeats C2 where the laws allow (a lift ``slave_end - slave_start`` is allowed: the slave
advances by it every period).

Evaluation: :meth:`CamTable.at` (plain floats, about 1 microsecond; the cycle calls it),
:meth:`CamTable.sample` (vectorised), :meth:`CamTable.slave_bounds` /
:meth:`CamTable.slave_peaks` (the exact signed extremes / maxima of the slave's velocity,
acceleration and jerk over the table for a master moving at a given velocity, acceleration and
jerk: every section's ends and the roots of the derivative), :meth:`CamTable.slave_peaks_bound`
(a cheap monotone upper bound of the peaks for per-cycle supervision) and
:meth:`CamTable.periodic_gaps` (what a periodic use sees at the seam).

Internally every segment is split into sections on which
``y(t) = P(t) + B sin(W t + phi)``, ``t = x - x_section_start``, with ``P`` a polynomial of
degree <= 7 (``B = 0``) or of degree <= 2 (the sinusoidal pieces of the trigonometric laws).
"""

from __future__ import annotations

import math
import numbers
import reprlib
from bisect import bisect_right
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Any, NamedTuple

import numpy as np

from motionplc.errors import PlanningError
from motionplc.planning.roots import quadratic_roots

#: Every motion law a segment may use.
LAWS: tuple[str, ...] = (
    "cycloid",
    "harmonic",
    "linear",
    "modified_sine",
    "modified_trapezoid",
    "poly5",
    "poly7",
)
#: Laws that meet arbitrary boundary slopes and curvatures (Hermite polynomials).
FLEXIBLE_LAWS: tuple[str, ...] = ("poly5", "poly7")

#: |master|, |slave| of a point (SI: m or rad).
COORD_MAX = 1e12
#: |slope| at a point (slave units per master unit).
SLOPE_MAX = 1e9
#: |curvature| at a point (slave units per master unit squared).
CURVATURE_MAX = 1e15
#: The shortest segment (master units).
SEGMENT_MIN = 1e-9

_TWO_PI = 2.0 * math.pi


def _flat_point(p: Any) -> bool:
    """``p`` is a sequence of 2 to 4 items none of which is a container (checked without
    building an array: a nested hostile value is never expanded)."""
    if isinstance(p, np.ndarray):
        return p.ndim == 1 and 2 <= len(p) <= 4
    if not isinstance(p, Sequence) or isinstance(p, (str, bytes)) or not 2 <= len(p) <= 4:
        return False
    return not any(
        isinstance(v, (Sequence, np.ndarray, Mapping)) and not isinstance(v, str) for v in p
    )


def _short(x: Any, limit: int = 80) -> str:
    """``repr(x)`` cut to ``limit`` characters (a hostile value does not make a huge message;
    the repr of a large container is not even built)."""
    if isinstance(x, (list, tuple, dict, np.ndarray)) and len(x) > 8:
        return f"a {type(x).__name__} of {len(x)} items"
    text = reprlib.repr(x)
    return text if len(text) <= limit else text[:limit] + "..."


class CamTableError(PlanningError):
    """A malformed cam table. ``index`` is the point (or segment) index, ``field`` the field
    (``master``, ``slave``, ``slope``, ``curvature``, ``law``, ``points``); the message names
    both and the allowed range."""

    def __init__(self, message: str, index: int | None = None, field: str = "") -> None:
        super().__init__(message)
        self.index = index
        self.field = field


@dataclass(frozen=True, slots=True)
class CamPoint:
    """One point of a cam table: master position, slave position, and optionally the slope
    dy/dx and curvature d2y/dx2 the table must have there (None: taken from a neighbouring
    segment's law, else 0), and the law of the segment starting at this point (None: the
    table's default law)."""

    master: float
    slave: float
    slope: float | None = None
    curvature: float | None = None
    law: str | None = None


class CamSamples(NamedTuple):
    """Vectorised samples of a cam table: y and its first three derivatives by x."""

    y: np.ndarray
    dy: np.ndarray
    d2y: np.ndarray
    d3y: np.ndarray


class PeriodicGaps(NamedTuple):
    """Jumps between the end and the start of a table used periodically: ``slope`` =
    y'(master_end) - y'(master_start), ``curvature`` = y''(master_end) - y''(master_start),
    ``lift`` = slave_end - slave_start (allowed: the slave advances by it every period)."""

    slope: float
    curvature: float
    lift: float


class SlavePeaks(NamedTuple):
    """Maxima of the slave's |velocity|, |acceleration|, |jerk| over a cam table."""

    v: float
    a: float
    j: float


class SlaveBounds(NamedTuple):
    """Signed extremes of the slave's velocity, acceleration and jerk over a cam table."""

    v_min: float
    v_max: float
    a_min: float
    a_max: float
    j_min: float
    j_max: float


# --------------------------------------------------------------------------------------------
# Normalised rest-to-rest laws, u in [0, 1] -> s in [0, 1]
#
# The trigonometric laws are given by their acceleration s''(u) = a + b sin(w u + phi) on
# sections [u0, u1]; s and s' are integrated in closed form from rest, then everything is
# scaled so that s(1) = 1 (VDI 2143 / Rothbart, Cam Design Handbook, ch. 3).
# --------------------------------------------------------------------------------------------


class _NormSection(NamedTuple):
    u0: float
    c0: float  # s = c0 + c1 tau + c2 tau^2 + bs sin(w tau + ph), tau = u - u0
    c1: float
    c2: float
    bs: float
    w: float
    ph: float


def _norm_law(raw: Sequence[tuple[float, float, float, float, float]]) -> tuple[_NormSection, ...]:
    """Integrate s'' = a + b sin(w u + phi) from rest over the sections (u0, a, b, w, phi),
    scaled to s(1) = 1."""
    secs: list[tuple[float, float, float, float, float, float, float]] = []
    s_k = v_k = 0.0
    bounds = [r[0] for r in raw] + [1.0]
    for (u0, a, b, w, phi), u1 in zip(raw, bounds[1:], strict=True):
        if b == 0.0:
            bs, ph, w_ = 0.0, 0.0, 0.0
            c0, c1 = s_k, v_k
        else:
            ph = w * u0 + phi
            bs = -b / (w * w)
            c0 = s_k + b / (w * w) * math.sin(ph)
            c1 = v_k + b / w * math.cos(ph)
            w_ = w
        c2 = a / 2.0
        secs.append((u0, c0, c1, c2, bs, w_, ph))
        tau = u1 - u0
        s_k = c0 + c1 * tau + c2 * tau * tau + (bs * math.sin(w_ * tau + ph) if bs else 0.0)
        v_k = c1 + 2.0 * c2 * tau + (bs * w_ * math.cos(w_ * tau + ph) if bs else 0.0)
    k = 1.0 / s_k
    return tuple(
        _NormSection(u0, c0 * k, c1 * k, c2 * k, bs * k, w, ph)
        for u0, c0, c1, c2, bs, w, ph in secs
    )


_PI = math.pi
_TRIG_LAWS: Mapping[str, tuple[_NormSection, ...]] = MappingProxyType(
    {
        # s'' = 2 pi sin(2 pi u): Cv 2, Ca 2 pi, Cj 4 pi^2
        "cycloid": _norm_law([(0.0, 0.0, 1.0, _TWO_PI, 0.0)]),
        # s = (1 - cos pi u) / 2: Cv pi/2, Ca pi^2/2 (at the ends: a jump from rest)
        "harmonic": _norm_law([(0.0, 0.0, 1.0, _PI, _PI / 2.0)]),
        # modified sine: quarter sine waves of period 1/2 at the ends, a sine of period 3/2 between
        "modified_sine": _norm_law(
            [
                (0.0, 0.0, 1.0, 4.0 * _PI, 0.0),
                (0.125, 0.0, 1.0, 4.0 * _PI / 3.0, _PI / 3.0),
                (0.875, 0.0, 1.0, 4.0 * _PI, 0.0),
            ]
        ),
        # modified trapezoid: sine ramps (period 1/2) and constant acceleration plateaus
        "modified_trapezoid": _norm_law(
            [
                (0.0, 0.0, 1.0, 4.0 * _PI, 0.0),
                (0.125, 1.0, 0.0, 0.0, 0.0),
                (0.375, 0.0, 1.0, 4.0 * _PI, -_PI),
                (0.625, -1.0, 0.0, 0.0, 0.0),
                (0.875, 0.0, 1.0, 4.0 * _PI, 0.0),
            ]
        ),
    }
)
del _PI

# Rest-to-rest polynomials (coefficients of u^0 .. u^n), exact integers.
_POLY_REST: Mapping[str, tuple[float, ...]] = MappingProxyType(
    {
        "poly5": (0.0, 0.0, 0.0, 10.0, -15.0, 6.0),
        "poly7": (0.0, 0.0, 0.0, 0.0, 35.0, -84.0, 70.0, -20.0),
    }
)


def _norm_ends(law: str) -> tuple[tuple[float, float, float], tuple[float, float, float]]:
    """(s', s'', s''') of a normalised trigonometric law at u = 0 and u = 1."""
    secs = _TRIG_LAWS[law]

    def d(sec: _NormSection, tau: float) -> tuple[float, float, float]:
        th = sec.w * tau + sec.ph
        w = sec.w
        return (
            sec.c1 + 2.0 * sec.c2 * tau + sec.bs * w * math.cos(th),
            2.0 * sec.c2 - sec.bs * w * w * math.sin(th),
            -sec.bs * w * w * w * math.cos(th),
        )

    start = d(secs[0], 0.0)
    end = d(secs[-1], 1.0 - secs[-1].u0)

    # the laws start and end at rest exactly (and all but harmonic with zero curvature);
    # remove the rounding residue of the integration
    def snap(v: float) -> float:
        return 0.0 if abs(v) < 1e-9 else v

    return (0.0, snap(start[1]), start[2]), (0.0, snap(end[1]), end[2])


_TRIG_ENDS = MappingProxyType({law: _norm_ends(law) for law in _TRIG_LAWS})


# --------------------------------------------------------------------------------------------
# Sections of a table
# --------------------------------------------------------------------------------------------


class _Section(NamedTuple):
    xs: float  # section start (master)
    xe: float  # section end
    c: tuple[float, ...]  # P(t), coefficients highest power first
    d1: tuple[float, ...]  # P'(t)
    d2: tuple[float, ...]
    d3: tuple[float, ...]
    b: float  # amplitude of the sine term
    w: float  # its angular rate per master unit
    ph: float  # its phase at t = 0


def _section(xs: float, xe: float, low: Sequence[float], b: float, w: float, ph: float) -> _Section:
    """A section from P's coefficients lowest power first."""
    c = [float(v) for v in low]
    while len(c) > 1 and c[-1] == 0.0:
        c.pop()
    d1 = [k * c[k] for k in range(1, len(c))] or [0.0]
    d2 = [k * d1[k] for k in range(1, len(d1))] or [0.0]
    d3 = [k * d2[k] for k in range(1, len(d2))] or [0.0]
    return _Section(
        xs,
        xe,
        tuple(reversed(c)),
        tuple(reversed(d1)),
        tuple(reversed(d2)),
        tuple(reversed(d3)),
        float(b),
        float(w),
        float(ph),
    )


def _hermite(
    law: str, h: float, bc0: tuple[float, float, float], bc1: tuple[float, float, float]
) -> tuple[float, ...]:
    """Coefficients (u^0 first) of the poly5 / poly7 on u in [0, 1] with s(0) = 0, s(1) = h and
    the derivatives by u (s', s'', s''') at both ends (poly5 ignores s''')."""
    v0, a0, j0 = bc0
    v1, a1, j1 = bc1
    if v0 == a0 == v1 == a1 == 0.0 and (law == "poly5" or j0 == j1 == 0.0):
        return tuple(h * c for c in _POLY_REST[law])
    if law == "poly5":
        return (
            0.0,
            v0,
            a0 / 2.0,
            10.0 * h - 6.0 * v0 - 4.0 * v1 - 1.5 * a0 + 0.5 * a1,
            -15.0 * h + 8.0 * v0 + 7.0 * v1 + 1.5 * a0 - a1,
            6.0 * h - 3.0 * v0 - 3.0 * v1 - 0.5 * a0 + 0.5 * a1,
        )
    # poly7: c0..c3 from the start, c4..c7 from s, s', s'', s''' at u = 1
    c0, c1, c2, c3 = 0.0, v0, a0 / 2.0, j0 / 6.0
    m = np.array(
        [
            [1.0, 1.0, 1.0, 1.0],
            [4.0, 5.0, 6.0, 7.0],
            [12.0, 20.0, 30.0, 42.0],
            [24.0, 60.0, 120.0, 210.0],
        ]
    )
    rhs = np.array(
        [
            h - (c0 + c1 + c2 + c3),
            v1 - (c1 + 2.0 * c2 + 3.0 * c3),
            a1 - (2.0 * c2 + 6.0 * c3),
            j1 - 6.0 * c3,
        ]
    )
    hi = np.linalg.solve(m, rhs)
    return (c0, c1, c2, c3, *(float(v) for v in hi))


def _eval_section(sec: _Section, x: float) -> tuple[float, float, float, float]:
    t = x - sec.xs
    y = dy = d2y = d3y = 0.0
    for k in sec.c:
        y = y * t + k
    for k in sec.d1:
        dy = dy * t + k
    for k in sec.d2:
        d2y = d2y * t + k
    for k in sec.d3:
        d3y = d3y * t + k
    b = sec.b
    if b:
        w = sec.w
        th = w * t + sec.ph
        s = math.sin(th)
        co = math.cos(th)
        y += b * s
        dy += b * w * co
        d2y -= b * w * w * s
        d3y -= b * w * w * w * co
    return y, dy, d2y, d3y


def _section_range(sec: _Section, k1: float, k2: float, k3: float) -> tuple[float, float]:
    """(min, max) of k1 y' + k2 y'' + k3 y''' over the section: the ends and every root of
    the derivative inside (polynomial roots, or closed form for the sine pieces)."""
    length = sec.xe - sec.xs
    cand = [0.0, length]
    if sec.b == 0.0:
        # f' = k1 P'' + k2 P''' + k3 P'''' (a polynomial; coefficients highest power first)
        d3 = sec.d3
        n3 = len(d3)
        d4 = tuple(c * (n3 - 1 - i) for i, c in enumerate(d3[:-1])) or (0.0,)
        fp = [0.0] * len(sec.d2)
        for coeffs, k in ((sec.d2, k1), (d3, k2), (d4, k3)):
            if k:
                off = len(fp) - len(coeffs)
                for i, c in enumerate(coeffs):
                    fp[off + i] += k * c
        # drop leading terms that are negligible on [0, length] (a tiny master acceleration
        # or jerk): they would only add roots far outside, or overflow the companion matrix
        mags = [abs(c) * length ** (len(fp) - 1 - i) for i, c in enumerate(fp)]
        big = max(mags)
        while len(fp) > 1 and mags[0] <= 1e-14 * big:
            del fp[0]
            del mags[0]
        if len(fp) == 2:
            roots = [-fp[1] / fp[0]]
        elif len(fp) == 3:
            roots = quadratic_roots(fp[0], fp[1], fp[2])
        elif len(fp) > 3:
            # a candidate that is no extremum only adds a sample of f: keep near-real roots
            tol = 1e-6 * max(1.0, length)
            roots = [float(r.real) for r in np.roots(fp) if abs(r.imag) <= tol]
        else:
            roots = []
        cand.extend(t for t in roots if 0.0 < t < length)
    else:
        # P of degree <= 2: f' = 2 p2 k1 + (k3 B W^4 - k1 B W^2) sin(th) - k2 B W^3 cos(th)
        p2 = sec.c[-3] if len(sec.c) >= 3 else 0.0
        b, w = sec.b, sec.w
        kk = 2.0 * p2 * k1
        ss = k3 * b * w**4 - k1 * b * w * w
        cc = -k2 * b * w**3
        r = math.hypot(ss, cc)
        if r > 0.0 and abs(kk) <= r:
            delta = math.atan2(cc, ss)  # ss sin th + cc cos th = r sin(th + delta)
            base = math.asin(max(-1.0, min(1.0, -kk / r)))
            th0, th1 = sec.ph, w * length + sec.ph
            n_lo = math.floor((min(th0, th1) + delta - math.pi) / _TWO_PI) - 1
            n_hi = math.ceil((max(th0, th1) + delta + math.pi) / _TWO_PI) + 1
            for n in range(n_lo, n_hi + 1):
                for psi in (base + n * _TWO_PI, math.pi - base + n * _TWO_PI):
                    t = (psi - delta - sec.ph) / w
                    if 0.0 < t < length:
                        cand.append(t)
    lo, hi = math.inf, -math.inf
    for t in cand:
        _, dy, d2y, d3y = _eval_section(sec, sec.xs + t)
        f = k1 * dy + k2 * d2y + k3 * d3y
        lo, hi = min(lo, f), max(hi, f)
    return lo, hi


def _num(value: Any, index: int, name: str, bound: float) -> float:
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, numbers.Real):
        raise CamTableError(
            f"points[{index}].{name}: got {value!r} (allowed: a number in [{-bound:g}, {bound:g}])",
            index,
            name,
        )
    v = float(value)
    if not -bound <= v <= bound:
        raise CamTableError(
            f"points[{index}].{name}: got {v!r} (allowed: a finite number in [{-bound:g}, "
            f"{bound:g}])",
            index,
            name,
        )
    return v


def _spline_slopes(
    xs: list[float], ys: list[float], bcs: list[tuple[float, float, float]], free: list[bool]
) -> None:
    """Give every run of free points the slope and curvature of the C2 cubic spline through
    the points, clamped to the slopes of the points that bound the run (in place)."""
    n = len(xs)
    i = 1
    while i < n - 1:
        if not free[i]:
            i += 1
            continue
        a = i - 1
        b = i
        while free[b]:
            b += 1
        # unknown slopes m[a+1 .. b-1]; h_k m_{k-1} + 2 (h_{k-1} + h_k) m_k + h_{k-1} m_{k+1}
        # = 3 (h_k d_{k-1} + h_{k-1} d_k), the Thomas algorithm (diagonally dominant)
        ks = range(a + 1, b)
        h = [xs[k + 1] - xs[k] for k in range(a, b)]
        d = [(ys[k + 1] - ys[k]) / (xs[k + 1] - xs[k]) for k in range(a, b)]
        diag, upper, rhs = [], [], []
        for j, k in enumerate(ks):
            hl, hr = h[j], h[j + 1]
            lo_c, di, up = hr, 2.0 * (hl + hr), hl
            r = 3.0 * (hr * d[j] + hl * d[j + 1])
            if k == a + 1:
                r -= lo_c * bcs[a][0]
            if k == b - 1:
                r -= up * bcs[b][0]
            if j:
                w = lo_c / diag[-1]
                di -= w * upper[-1]
                r -= w * rhs[-1]
            diag.append(di)
            upper.append(up)
            rhs.append(r)
        m = [0.0] * len(diag)
        m[-1] = rhs[-1] / diag[-1]  # its upper term (the known m_b) is in rhs
        for j in range(len(diag) - 2, -1, -1):
            m[j] = (rhs[j] - upper[j] * m[j + 1]) / diag[j]
        slopes = [bcs[a][0], *m, bcs[b][0]]
        for j, k in enumerate(ks, start=1):
            hk, dk = h[j], d[j]
            curv = (6.0 * dk - 4.0 * slopes[j] - 2.0 * slopes[j + 1]) / hk
            bcs[k] = (slopes[j], curv, 0.0)
        i = b


def _close(a: float, b: float) -> bool:
    return math.isclose(a, b, rel_tol=1e-9, abs_tol=1e-12)


# --------------------------------------------------------------------------------------------
# The table
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True, slots=True)
class CamTable:
    """An immutable cam table master x -> slave y (see the module docstring for the laws and
    the boundary-condition rules).

    ``points`` (at least 2, master strictly increasing, each segment at least ``SEGMENT_MIN``
    long), ``laws`` (one per segment, from :data:`LAWS`; a point's own ``law`` wins over the
    entry here), ``periodic`` (resolve the first and last point's slope and curvature together,
    as one point, so that the table repeats C2 where the laws allow; the lift
    ``slave_end - slave_start`` may be non-zero), ``name`` (for messages), ``smooth``
    (interior points without an explicit slope or curvature between two poly5 / poly7 segments
    are not at rest but get the slope and curvature of the C2 cubic spline through the points,
    clamped to the slopes of the nearest other points: on segments between two such points the
    poly5 is that cubic; for point lists measured or taken from a drawing).
    Construction validates everything and raises :class:`CamTableError` (a ``ValueError``)
    naming the point index, the field and the allowed range.

    Guarantees: y, y' continuous everywhere in [master_start, master_end]; y'' continuous
    except at the points listed in :attr:`curvature_jumps`; ``at`` and ``sample`` agree to
    rounding; the peaks are exact maxima (ends and roots of the derivative of every section).
    """

    points: tuple[CamPoint, ...]
    laws: tuple[str, ...] = ()
    periodic: bool = False
    name: str = ""
    smooth: bool = False
    # derived
    master_start: float = field(init=False, compare=False)
    master_end: float = field(init=False, compare=False)
    slave_start: float = field(init=False, compare=False)
    slave_end: float = field(init=False, compare=False)
    segment_laws: tuple[str, ...] = field(init=False, compare=False)
    boundary: tuple[tuple[float, float], ...] = field(init=False, compare=False, repr=False)
    curvature_jumps: tuple[tuple[int, float], ...] = field(init=False, compare=False, repr=False)
    peak_slope: float = field(init=False, compare=False, repr=False)
    peak_curvature: float = field(init=False, compare=False, repr=False)
    peak_jerk: float = field(init=False, compare=False, repr=False)
    _secs: tuple[_Section, ...] = field(init=False, compare=False, repr=False)
    _starts: tuple[float, ...] = field(init=False, compare=False, repr=False)
    _arr: tuple[np.ndarray, ...] = field(init=False, compare=False, repr=False)
    _ranges: tuple[tuple[float, float], ...] = field(init=False, compare=False, repr=False)

    def __post_init__(self) -> None:
        pts = tuple(self.points) if not isinstance(self.points, tuple) else self.points
        if len(pts) < 2:
            raise CamTableError(
                f"points: a cam table needs at least 2 points, got {len(pts)}", None, "points"
            )
        for i, p in enumerate(pts):
            if not isinstance(p, CamPoint):
                raise CamTableError(
                    f"points[{i}]: must be a CamPoint, got {type(p).__name__} "
                    "(use CamTable.from_points for tuples and mappings)",
                    i,
                    "points",
                )
        xs = [_num(p.master, i, "master", COORD_MAX) for i, p in enumerate(pts)]
        ys = [_num(p.slave, i, "slave", COORD_MAX) for i, p in enumerate(pts)]
        for i in range(1, len(pts)):
            if not xs[i] - xs[i - 1] >= SEGMENT_MIN:
                raise CamTableError(
                    f"points[{i}].master: must be at least {SEGMENT_MIN:g} beyond "
                    f"points[{i - 1}].master = {xs[i - 1]!r} (master strictly increasing), "
                    f"got {xs[i]!r}",
                    i,
                    "master",
                )
        n = len(pts)
        laws = self._resolve_laws(pts)
        slopes = [
            None if p.slope is None else _num(p.slope, i, "slope", SLOPE_MAX)
            for i, p in enumerate(pts)
        ]
        curvs = [
            None if p.curvature is None else _num(p.curvature, i, "curvature", CURVATURE_MAX)
            for i, p in enumerate(pts)
        ]

        # the derivatives by x each rigid segment fixes at its start and end
        rigid: list[tuple[tuple[float, float, float], tuple[float, float, float]] | None] = []
        for s in range(n - 1):
            length, h = xs[s + 1] - xs[s], ys[s + 1] - ys[s]
            law = laws[s]
            if law == "linear":
                e = (h / length, 0.0, 0.0)
                rigid.append((e, e))
            elif law in _TRIG_LAWS:
                (v0, a0, j0), (v1, a1, j1) = _TRIG_ENDS[law]
                sc = (h / length, h / length**2, h / length**3)
                rigid.append(
                    (
                        (v0 * sc[0], a0 * sc[1], j0 * sc[2]),
                        (v1 * sc[0], a1 * sc[1], j1 * sc[2]),
                    )
                )
            else:
                rigid.append(None)

        # resolve (slope, curvature, jerk) at every point
        bcs: list[tuple[float, float, float]] = [(0.0, 0.0, 0.0)] * n
        jumps: list[tuple[int, float]] = []
        groups = [[i] for i in range(n)]
        if self.periodic:
            groups = [[0, n - 1]] + [[i] for i in range(1, n - 1)]
        for grp in groups:
            bc, jump = self._resolve_point(grp, n, laws, rigid, slopes, curvs)
            for i in grp:
                bcs[i] = bc
            if jump is not None and grp[0] != 0:
                jumps.append((grp[0], jump))
        if self.smooth:
            free = [
                0 < i < n - 1
                and slopes[i] is None
                and curvs[i] is None
                and laws[i - 1] in FLEXIBLE_LAWS
                and laws[i] in FLEXIBLE_LAWS
                for i in range(n)
            ]
            _spline_slopes(xs, ys, bcs, free)

        secs: list[_Section] = []
        for s in range(n - 1):
            x0, x1 = xs[s], xs[s + 1]
            length, h, y0 = x1 - x0, ys[s + 1] - ys[s], ys[s]
            law = laws[s]
            if law == "linear":
                secs.append(_section(x0, x1, (y0, h / length), 0.0, 0.0, 0.0))
            elif law in _TRIG_LAWS:
                nsecs = _TRIG_LAWS[law]
                bounds = [sec.u0 for sec in nsecs] + [1.0]
                for k, sec in enumerate(nsecs):
                    xs_k = x0 + sec.u0 * length if k else x0
                    xe_k = x0 + bounds[k + 1] * length if k + 1 < len(nsecs) else x1
                    low = (y0 + h * sec.c0, h * sec.c1 / length, h * sec.c2 / length**2)
                    if sec.bs:
                        secs.append(_section(xs_k, xe_k, low, h * sec.bs, sec.w / length, sec.ph))
                    else:
                        secs.append(_section(xs_k, xe_k, low, 0.0, 0.0, 0.0))
            else:
                (v0, a0, j0), (v1, a1, j1) = bcs[s], bcs[s + 1]
                cu = _hermite(
                    law,
                    h,
                    (v0 * length, a0 * length**2, j0 * length**3),
                    (v1 * length, a1 * length**2, j1 * length**3),
                )
                coeffs = [y0 + cu[0]] + [cu[k] / length**k for k in range(1, len(cu))]
                secs.append(_section(x0, x1, coeffs, 0.0, 0.0, 0.0))

        set_ = object.__setattr__
        # the validated values (floats), so that equal tables compare and hash equal
        set_(
            self,
            "points",
            tuple(CamPoint(xs[i], ys[i], slopes[i], curvs[i], p.law) for i, p in enumerate(pts)),
        )
        set_(self, "laws", tuple(laws))
        set_(self, "periodic", bool(self.periodic))
        set_(self, "master_start", xs[0])
        set_(self, "master_end", xs[-1])
        set_(self, "slave_start", ys[0])
        set_(self, "slave_end", ys[-1])
        set_(self, "segment_laws", tuple(laws))
        set_(self, "boundary", tuple((v, a) for v, a, _ in bcs))
        set_(self, "curvature_jumps", tuple(jumps))
        set_(self, "_secs", tuple(secs))
        set_(self, "_starts", tuple(s.xs for s in secs))
        deg = max(len(s.c) for s in secs)

        def mat(attr: str) -> np.ndarray:
            m = np.zeros((len(secs), deg))
            for r, s in enumerate(secs):
                c = getattr(s, attr)
                m[r, deg - len(c) :] = c
            return m

        set_(
            self,
            "_arr",
            (
                np.array(self._starts),
                mat("c"),
                mat("d1"),
                mat("d2"),
                mat("d3"),
                np.array([s.b for s in secs]),
                np.array([s.w for s in secs]),
                np.array([s.ph for s in secs]),
            ),
        )
        # exact (min, max) of y', y'', y''' over the table
        ranges = []
        for k1, k2, k3 in ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0)):
            rs = [_section_range(s, k1, k2, k3) for s in secs]
            ranges.append((min(r[0] for r in rs), max(r[1] for r in rs)))
        set_(self, "_ranges", tuple(ranges))
        set_(self, "peak_slope", max(-ranges[0][0], ranges[0][1]))
        set_(self, "peak_curvature", max(-ranges[1][0], ranges[1][1]))
        set_(self, "peak_jerk", max(-ranges[2][0], ranges[2][1]))

    # ---- construction helpers ----------------------------------------------------------

    def _resolve_laws(self, pts: tuple[CamPoint, ...]) -> list[str]:
        n = len(pts)
        given = tuple(self.laws)
        if given and len(given) not in (1, n - 1):
            raise CamTableError(
                f"laws: one law per segment ({n - 1}) or a single law for all, got {len(given)}",
                None,
                "laws",
            )
        default = given[0] if len(given) == 1 else "poly5"
        laws: list[str] = []
        for s in range(n - 1):
            law = pts[s].law
            if law is None:
                law = given[s] if len(given) == n - 1 else default
            if law not in LAWS:
                raise CamTableError(
                    f"points[{s}].law: unknown motion law {law!r} (allowed: {', '.join(LAWS)})",
                    s,
                    "law",
                )
            laws.append(law)
        return laws

    @staticmethod
    def _resolve_point(
        grp: list[int],
        n: int,
        laws: list[str],
        rigid: list[tuple[tuple[float, float, float], tuple[float, float, float]] | None],
        slopes: list[float | None],
        curvs: list[float | None],
    ) -> tuple[tuple[float, float, float], float | None]:
        """(slope, curvature, jerk) at a point (a group of indices for the periodic seam) and
        the curvature jump two rigid neighbours force there (None: none)."""
        where = " / ".join(f"points[{i}]" for i in grp)
        # neighbouring (segment, end) pairs: the segment ending here (end 1), starting here (0)
        ends: list[tuple[int, int]] = []
        for i in grp:
            if i > 0:
                ends.append((i - 1, 1))
            if i < n - 1:
                ends.append((i, 0))
        slope_c = [(slopes[i], f"{where}.slope = {slopes[i]!r}") for i in grp]
        curv_c = [(curvs[i], f"{where}.curvature = {curvs[i]!r}") for i in grp]
        explicit_s = [(v, d) for v, d in slope_c if v is not None]
        explicit_c = [(v, d) for v, d in curv_c if v is not None]
        rig_s: list[tuple[float, str]] = []
        rig_c: list[tuple[float, str]] = []
        for seg, end in ends:
            r = rigid[seg]
            if r is None:
                continue
            v, a, _ = r[end]
            side = "ends" if end else "starts"
            desc = f"segment {seg} (law {laws[seg]!r}) {side} with slope {v!r}"
            rig_s.append((v, desc))
            rig_c.append((a, f"segment {seg} (law {laws[seg]!r}) {side} with curvature {a!r}"))

        def fail(fieldname: str, a: tuple[float, str], b: tuple[float, str]) -> CamTableError:
            hint = (
                " (the law cannot meet this slope: use poly5 or poly7 for segments whose ends "
                "are not at rest, or add a transition segment)"
                if fieldname == "slope"
                else " (use poly5 or poly7 next to this point)"
            )
            return CamTableError(f"{where}.{fieldname}: {a[1]} but {b[1]}{hint}", grp[0], fieldname)

        cands_s = explicit_s + rig_s
        for c in cands_s[1:]:
            if not _close(c[0], cands_s[0][0]):
                raise fail("slope", cands_s[0], c)
        slope = cands_s[0][0] if cands_s else 0.0
        for e in explicit_c:
            for c in rig_c + explicit_c:
                if not _close(c[0], e[0]):
                    raise fail("curvature", e, c)
        jump = None
        if explicit_c:
            curv = explicit_c[0][0]
        elif rig_c:
            curv = rig_c[0][0]
            if len(rig_c) > 1 and not _close(rig_c[0][0], rig_c[1][0]):
                jump = rig_c[1][0] - rig_c[0][0]  # after the point minus before it
        else:
            curv = 0.0
        # poly7 ends with zero jerk (the 4-5-6-7 law's own condition): adopting a rigid
        # neighbour's jerk would make a long poly7 next to a short rise swing far out
        return (slope, curv, 0.0), jump

    @classmethod
    def from_points(
        cls,
        points: Iterable[CamPoint | Sequence[float] | Mapping[str, Any]],
        law: str = "poly5",
        laws: Sequence[str] | None = None,
        periodic: bool = False,
        name: str = "",
        smooth: bool = False,
    ) -> CamTable:
        """A table from points given as :class:`CamPoint`, ``(master, slave[, slope[,
        curvature]])`` sequences or mappings with the keys ``master``, ``slave`` and optionally
        ``slope``, ``curvature``, ``law``; ``law`` is the default law of every segment,
        ``laws`` (one per segment) overrides it, a point's own law overrides both;
        ``periodic`` and ``smooth`` as for :class:`CamTable`."""
        if isinstance(points, (str, bytes, Mapping)) or not isinstance(points, Iterable):
            raise CamTableError(
                "points: must be a list of at least 2 points ([master, slave[, slope[, "
                f"curvature]]] or mappings), got {_short(points)}",
                None,
                "points",
            )
        pts: list[CamPoint] = []
        for i, p in enumerate(points):
            if isinstance(p, CamPoint):
                pts.append(p)
            elif isinstance(p, Mapping):
                unknown = sorted(set(p) - {"master", "slave", "slope", "curvature", "law"})
                if unknown:
                    raise CamTableError(
                        f"points[{i}].{unknown[0]}: unknown key (allowed: master, slave, "
                        "slope, curvature, law)",
                        i,
                        str(unknown[0]),
                    )
                for key in ("master", "slave"):
                    if key not in p:
                        raise CamTableError(f"points[{i}].{key}: missing", i, key)
                pts.append(
                    CamPoint(
                        p["master"],
                        p["slave"],
                        p.get("slope"),
                        p.get("curvature"),
                        p.get("law"),
                    )
                )
            elif _flat_point(p):
                pts.append(CamPoint(*p))
            else:
                raise CamTableError(
                    f"points[{i}]: must be [master, slave], [master, slave, slope], "
                    f"[master, slave, slope, curvature] or a mapping, got {_short(p)}",
                    i,
                    "points",
                )
        if laws is not None:
            given: tuple[str, ...] = tuple(laws)
        else:
            given = (law,)
        return cls(tuple(pts), given, periodic, name, smooth)

    # ---- evaluation --------------------------------------------------------------------

    @property
    def lift(self) -> float:
        """slave_end - slave_start: what the slave advances per period when used periodically."""
        return self.slave_end - self.slave_start

    @property
    def c2(self) -> bool:
        """True when y'' is continuous at every interior point."""
        return not self.curvature_jumps

    def at(self, x: float) -> tuple[float, float, float, float]:
        """(y, dy/dx, d2y/dx2, d3y/dx3) at master position ``x`` in [master_start,
        master_end] (ValueError outside or NaN). At a point the segment starting there is
        used (y, y' are continuous; y'' too unless listed in ``curvature_jumps``); at
        ``master_end`` y is ``slave_end`` exactly."""
        if not self.master_start <= x <= self.master_end:
            raise ValueError(
                f"x: must be in [{self.master_start!r}, {self.master_end!r}] "
                f"(the cam table's master range), got {x!r}"
            )
        i = bisect_right(self._starts, x) - 1
        if x == self.master_end:
            _, dy, d2y, d3y = _eval_section(self._secs[i], x)
            return self.slave_end, dy, d2y, d3y
        return _eval_section(self._secs[i], x)

    def sample(self, xs: Any) -> CamSamples:
        """Vectorised :meth:`at`: arrays y, y', y'', y''' for the master positions ``xs``
        (any array shape; ValueError naming the first position outside the range)."""
        x = np.asarray(xs, dtype=float)
        ok = (x >= self.master_start) & (x <= self.master_end)
        if not bool(np.all(ok)):
            k = int(np.argmin(ok.ravel()))
            raise ValueError(
                f"xs[{k}]: must be in [{self.master_start!r}, {self.master_end!r}] "
                f"(the cam table's master range), got {float(x.ravel()[k])!r}"
            )
        starts, c, d1, d2, d3, b, w, ph = self._arr
        idx = np.searchsorted(starts, x, side="right") - 1
        t = x - starts[idx]
        out = []
        for m in (c, d1, d2, d3):
            rows = m[idx]
            acc = rows[..., 0].copy()
            for k in range(1, m.shape[1]):
                acc = acc * t + rows[..., k]
            out.append(acc)
        bb, ww = b[idx], w[idx]
        th = ww * t + ph[idx]
        s, co = np.sin(th), np.cos(th)
        y = np.where(x == self.master_end, self.slave_end, out[0] + bb * s)
        dy = out[1] + bb * ww * co
        d2y = out[2] - bb * ww * ww * s
        d3y = out[3] - bb * ww * ww * ww * co
        return CamSamples(y, dy, d2y, d3y)

    def periodic_gaps(self) -> PeriodicGaps:
        """Jumps of y' and y'' from the end of the table to its start, and the lift: what a
        periodic use of the table sees at each period boundary (all 0 but the lift for a
        table built with ``periodic=True`` from C2-capable laws)."""
        _, v0, a0, _ = self.at(self.master_start)
        _, v1, a1, _ = _eval_section(self._secs[-1], self.master_end)
        return PeriodicGaps(v1 - v0, a1 - a0, self.lift)

    def slave_bounds(
        self,
        master_v: float,
        master_a: float = 0.0,
        master_j: float = 0.0,
        periodic: bool = False,
    ) -> SlaveBounds:
        """Exact signed extremes over the table of the slave's v = y' vm,
        a = y'' vm^2 + y' am and j = y''' vm^3 + 3 y'' vm am + y' jm for a master at velocity
        ``master_v``, acceleration ``master_a`` and jerk ``master_j`` (each section's ends and
        the roots of the derivative inside). A curvature jump inside the table (or, with
        ``periodic``, at the seam) is an acceleration step: j = -inf / +inf when the master
        moves; a slope jump at the seam (``periodic``) is a velocity step: a and j infinite."""
        vm, am, jm = (
            _finite(master_v, "master_v"),
            _finite(master_a, "master_a"),
            _finite(master_j, "master_j"),
        )
        secs = self._secs
        (s1lo, s1hi), (s2lo, s2hi), (s3lo, s3hi) = self._ranges

        def scaled(lo: float, hi: float, k: float) -> tuple[float, float]:
            return (k * lo, k * hi) if k >= 0.0 else (k * hi, k * lo)

        b = [*scaled(s1lo, s1hi, vm), 0.0, 0.0, 0.0, 0.0]
        if am == 0.0:  # the exact ranges of y'' and y''' scaled: no roots to find
            b[2], b[3] = scaled(s2lo, s2hi, vm * vm)
        else:
            ra = [_section_range(s, am, vm * vm, 0.0) for s in secs]
            b[2], b[3] = min(r[0] for r in ra), max(r[1] for r in ra)
        if am == 0.0 and jm == 0.0:
            b[4], b[5] = scaled(s3lo, s3hi, vm**3)
        else:
            rj = [_section_range(s, jm, 3.0 * vm * am, vm**3) for s in secs]
            b[4], b[5] = min(r[0] for r in rj), max(r[1] for r in rj)
        if vm != 0.0:
            gaps = self.periodic_gaps() if periodic else None
            if self.curvature_jumps or (
                gaps is not None and abs(gaps.curvature) > 1e-9 * (1.0 + self.peak_curvature)
            ):
                b[4], b[5] = -math.inf, math.inf
            if gaps is not None and abs(gaps.slope) > 1e-9 * (1.0 + self.peak_slope):
                b[2], b[3], b[4], b[5] = -math.inf, math.inf, -math.inf, math.inf
        return SlaveBounds(*b)

    def slave_peaks(
        self,
        master_v: float,
        master_a: float = 0.0,
        master_j: float = 0.0,
        periodic: bool = False,
    ) -> SlavePeaks:
        """Exact maxima over the table of the slave's |v| = |y' vm|, |a| = |y'' vm^2 + y' am|,
        |j| = |y''' vm^3 + 3 y'' vm am + y' jm| (see :meth:`slave_bounds`; ``inf`` for the
        steps it reports)."""
        if master_a == 0.0 and master_j == 0.0 and not periodic:
            vm = abs(_finite(master_v, "master_v"))
            j = math.inf if self.curvature_jumps and vm != 0.0 else self.peak_jerk * vm**3
            return SlavePeaks(self.peak_slope * vm, self.peak_curvature * vm * vm, j)
        b = self.slave_bounds(master_v, master_a, master_j, periodic)
        return SlavePeaks(max(-b.v_min, b.v_max), max(-b.a_min, b.a_max), max(-b.j_min, b.j_max))

    def slave_peaks_bound(
        self, master_v: float, master_a: float = 0.0, master_j: float = 0.0
    ) -> SlavePeaks:
        """A cheap upper bound of :meth:`slave_peaks` (a few multiplications, for checks made
        every cycle): |v| <= Y1 |vm|, |a| <= Y2 vm^2 + Y1 |am|,
        |j| <= Y3 |vm|^3 + 3 Y2 |vm| |am| + Y1 |jm| with Y1, Y2, Y3 the exact peaks of |y'|,
        |y''|, |y'''|. Equal to :meth:`slave_peaks` when ``master_a`` = ``master_j`` = 0;
        never below it; non-decreasing in |vm|, |am|, |jm| (so a bound checked for a master
        envelope holds for every motion inside it, whatever the signs). Curvature jumps give
        j = inf as in :meth:`slave_peaks`."""
        vm = abs(_finite(master_v, "master_v"))
        am = abs(_finite(master_a, "master_a"))
        jm = abs(_finite(master_j, "master_j"))
        y1, y2, y3 = self.peak_slope, self.peak_curvature, self.peak_jerk
        j = y3 * vm**3 + 3.0 * y2 * vm * am + y1 * jm
        if self.curvature_jumps and vm != 0.0:
            j = math.inf
        return SlavePeaks(y1 * vm, y2 * vm * vm + y1 * am, j)


#: |master velocity|, |acceleration|, |jerk| accepted by the peak functions
MASTER_MAX = 1e15


def _finite(value: Any, name: str) -> float:
    ok = isinstance(value, (int, float)) and not isinstance(value, bool)
    if not ok or not -MASTER_MAX <= value <= MASTER_MAX:
        raise ValueError(
            f"{name}: must be a finite number in [{-MASTER_MAX:g}, {MASTER_MAX:g}], got {value!r}"
        )
    return float(value)
