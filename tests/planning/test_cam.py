"""CamTable: the VDI 2143 motion laws against their published characteristic values and
closed forms, the Hermite laws against numpy.polynomial and scipy's BPoly, derivatives
against finite differences, C2 continuity at every interior point over random tables
(hypothesis), the boundary-condition rules, the peaks against dense sampling, and every
malformed table.

Published characteristic values (dimensionless peaks Cv = max s', Ca = max |s''|,
Cj = max |s'''| of the normalised law s(u), u, s in [0, 1]):

* modified sine: Cv 1.76, Ca 5.53, Cj 69.47, jerk at the crossover -23.15 -- PSMotion,
  MechDesigner reference "Modified-Sinusoid Motion-Law",
  http://mechdesigner.support/motion-cam-law-modified-sinusoid.htm ;
* the others: R. L. Norton, *Cam Design and Manufacturing Handbook* (2nd ed., 2009), the
  table comparing the standard rise functions, and H. A. Rothbart, *Cam Design Handbook*
  (2004), ch. 3: poly 3-4-5 1.875 / 5.77 / 60; poly 4-5-6-7 2.19 / 7.52 / 52.5;
  cycloidal 2 / 6.28 (2 pi) / 39.5 (4 pi^2); modified trapezoid 2.0 / 4.888 / 61.4; simple
  harmonic 1.57 (pi/2) / 4.93 (pi^2/2) / 15.5 (pi^3/2, plus an infinite jerk at the ends).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from numpy.polynomial import Polynomial

from motionplc.planning import CamPoint, CamTable, CamTableError, PlanningError
from motionplc.planning.cam import FLEXIBLE_LAWS, LAWS
from tests.planning._strategies import hsettings

PI = math.pi

# law: (Cv, Ca, Cj, tolerance of the published figure)
PUBLISHED = {
    "modified_sine": (1.76, 5.53, 69.47, 0.005),
    "poly5": (1.875, 5.7735, 60.0, 1e-4),
    "poly7": (2.1875, 7.5132, 52.5, 1e-4),
    "cycloid": (2.0, 2.0 * PI, 4.0 * PI * PI, 1e-9),
    "modified_trapezoid": (2.0, 4.888, 61.4, 0.03),
    "harmonic": (PI / 2.0, PI * PI / 2.0, PI**3 / 2.0, 1e-9),
}


def _unit(law: str) -> CamTable:
    return CamTable.from_points([(0.0, 0.0), (1.0, 1.0)], law=law)


@pytest.mark.parametrize("law", sorted(PUBLISHED))
def test_characteristic_values(law: str) -> None:
    cv, ca, cj, tol = PUBLISHED[law]
    t = _unit(law)
    assert t.peak_slope == pytest.approx(cv, abs=tol)
    assert t.peak_curvature == pytest.approx(ca, abs=tol)
    assert t.peak_jerk == pytest.approx(cj, abs=tol * 10)
    # the peaks are exact maxima: dense sampling never exceeds them and comes close
    s = t.sample(np.linspace(0.0, 1.0, 200_001))
    for peak, arr in ((t.peak_slope, s.dy), (t.peak_curvature, s.d2y), (t.peak_jerk, s.d3y)):
        m = float(np.max(np.abs(arr)))
        assert m <= peak * (1 + 1e-12)
        assert m >= peak * (1 - 1e-6)


def test_modified_sine_crossover_jerk() -> None:
    assert _unit("modified_sine").at(0.5)[3] == pytest.approx(-23.15, abs=0.01)


def _textbook(law: str, u: float) -> tuple[float, float, float, float]:
    """The closed forms as printed in the textbooks (not derived from cam.py)."""
    if law == "cycloid":
        w = 2 * PI
        return (
            u - math.sin(w * u) / w,
            1 - math.cos(w * u),
            w * math.sin(w * u),
            w * w * math.cos(w * u),
        )
    if law == "harmonic":
        return (
            (1 - math.cos(PI * u)) / 2,
            PI / 2 * math.sin(PI * u),
            PI**2 / 2 * math.cos(PI * u),
            -(PI**3) / 2 * math.sin(PI * u),
        )
    if law == "modified_sine":  # Rothbart, Cam Design Handbook, modified sine
        k = 1.0 / (4.0 + PI)
        if u <= 0.125 or u >= 0.875:
            c = 0.0 if u <= 0.125 else 4.0
            return (
                k * (c + PI * u - 0.25 * math.sin(4 * PI * u)),
                k * (PI - PI * math.cos(4 * PI * u)),
                k * 4 * PI**2 * math.sin(4 * PI * u),
                k * 16 * PI**3 * math.cos(4 * PI * u),
            )
        th = PI / 3 + 4 * PI * u / 3
        return (
            k * (2 + PI * u - 2.25 * math.sin(th)),
            k * (PI - 3 * PI * math.cos(th)),
            k * 4 * PI**2 * math.sin(th),
            k * 16 * PI**3 / 3 * math.cos(th),
        )
    if law == "poly5":
        return (
            10 * u**3 - 15 * u**4 + 6 * u**5,
            30 * u**2 - 60 * u**3 + 30 * u**4,
            60 * u - 180 * u**2 + 120 * u**3,
            60 - 360 * u + 360 * u**2,
        )
    if law == "poly7":
        return (
            35 * u**4 - 84 * u**5 + 70 * u**6 - 20 * u**7,
            140 * u**3 - 420 * u**4 + 420 * u**5 - 140 * u**6,
            420 * u**2 - 1680 * u**3 + 2100 * u**4 - 840 * u**5,
            840 * u - 5040 * u**2 + 8400 * u**3 - 4200 * u**4,
        )
    raise AssertionError(law)


@pytest.mark.parametrize("law", ["cycloid", "harmonic", "modified_sine", "poly5", "poly7"])
def test_closed_forms_scaled(law: str) -> None:
    """A rise h over a master length L at an offset: y = y0 + h s(u), y' = h/L s', ..."""
    x0, length, y0, h = 3.0, 2.5, -1.0, 0.4
    t = CamTable.from_points([(x0, y0), (x0 + length, y0 + h)], law=law)
    for u in np.linspace(0.0, 1.0, 161):
        s = _textbook(law, float(u))
        got = t.at(x0 + float(u) * length)
        want = (y0 + h * s[0], h / length * s[1], h / length**2 * s[2], h / length**3 * s[3])
        for k in range(4):
            assert got[k] == pytest.approx(want[k], abs=1e-12 * 10**k)


def test_modified_trapezoid_shape() -> None:
    """Acceleration: sine ramps of 1/8 of the rise, plateaus of +-Ca over 1/4, a cosine
    crossover (Norton's construction); symmetric; s(1/2) = 1/2."""
    t = _unit("modified_trapezoid")
    ca = t.peak_curvature
    for u in (0.125, 0.2, 0.3, 0.375):
        assert t.at(u)[2] == pytest.approx(ca, rel=1e-12)
        assert t.at(1 - u)[2] == pytest.approx(-ca, rel=1e-12)
    assert t.at(0.0625)[2] == pytest.approx(ca * math.sin(PI / 4), rel=1e-12)
    assert t.at(0.5)[0] == pytest.approx(0.5, abs=1e-15)
    assert t.at(0.5)[1] == pytest.approx(2.0, abs=1e-12)
    for u in np.linspace(0, 1, 41):
        a, b = t.at(float(u)), t.at(1 - float(u))
        assert a[0] == pytest.approx(1 - b[0], abs=1e-14)
        assert a[1] == pytest.approx(b[1], abs=1e-12)


@pytest.mark.parametrize("law", LAWS)
def test_derivatives_against_finite_differences(law: str) -> None:
    pts = [(0.0, 0.2), (0.7, 1.5), (2.0, 1.5), (2.5, -0.5)]
    laws = [law, "poly5", law] if law != "linear" else ["linear", "linear", "linear"]
    if law == "linear":
        pts = [(0.0, 0.2), (0.7, 0.9), (2.0, 2.2), (2.5, 2.7)]  # one slope throughout
    t = CamTable.from_points(pts, laws=laws)
    eps = 1e-5
    xs = np.linspace(eps, 2.5 - eps, 997)
    s = t.sample(xs)
    sp, sm = t.sample(xs + eps), t.sample(xs - eps)
    for k, df in enumerate((s.dy, s.d2y, s.d3y)):
        fd = (sp[k] - sm[k]) / (2 * eps)
        scale = 1.0 + float(np.max(np.abs(df)))
        # skip the samples whose difference straddles a section boundary of a derivative that
        # is only piecewise smooth there (d3y of the trig laws and of poly5 at the points)
        smooth = np.abs(sp[k + 1] - sm[k + 1]) <= 2 * eps * (1 + np.max(np.abs(s.d3y))) * 50
        err = np.abs(fd - df)[smooth]
        assert err.size > 900
        assert float(np.max(err)) <= 1e-5 * scale * (1 + 10 * k)


def _peer_polynomial(
    law: str, x0: float, x1: float, y0: float, y1: float, b0: tuple, b1: tuple
) -> Polynomial:
    """The Hermite polynomial by numpy: solve the boundary conditions in t = x - x0."""
    deg = 5 if law == "poly5" else 7
    m = 3 if deg == 5 else 4
    basis = [Polynomial.basis(k) for k in range(deg + 1)]
    rows, rhs = [], []
    for tt, vals in ((0.0, (y0, *b0)), (x1 - x0, (y1, *b1))):
        for d in range(m):
            rows.append([b.deriv(d)(tt) if d else b(tt) for b in basis])
            rhs.append(vals[d])
    return Polynomial(np.linalg.solve(np.array(rows), np.array(rhs)))


@pytest.mark.parametrize("law", FLEXIBLE_LAWS)
def test_hermite_laws_against_numpy_polynomial(law: str) -> None:
    pts = [
        CamPoint(0.0, 0.0, slope=0.0, curvature=0.0),
        CamPoint(0.8, 0.5, slope=1.2, curvature=-3.0),
        CamPoint(1.5, 0.6, slope=-0.4, curvature=2.0),
        CamPoint(3.0, 2.0, slope=0.3, curvature=0.0),
    ]
    t = CamTable(tuple(pts), (law,))
    for i in range(3):
        p, q = pts[i], pts[i + 1]
        b0 = (p.slope, p.curvature) + ((0.0,) if law == "poly7" else ())
        b1 = (q.slope, q.curvature) + ((0.0,) if law == "poly7" else ())
        peer = _peer_polynomial(law, p.master, q.master, p.slave, q.slave, b0, b1)
        for x in np.linspace(p.master, q.master, 57)[:-1]:
            got = t.at(float(x))
            tt = float(x) - p.master
            for k in range(4):
                want = peer.deriv(k)(tt) if k else peer(tt)
                assert got[k] == pytest.approx(want, abs=1e-10 * 10**k)


@given(
    st.lists(
        st.tuples(st.floats(0.05, 2.0), st.floats(-3, 3), st.floats(-2, 2), st.floats(-10, 10)),
        min_size=2,
        max_size=8,
    ),
    st.sampled_from(FLEXIBLE_LAWS),
)
@hsettings(40)
def test_hermite_tables_against_scipy_bpoly(rows: list[tuple], law: str) -> None:
    """scipy's BPoly.from_derivatives (Bernstein-basis Hermite interpolation) is an
    independent implementation of the same piecewise polynomial: position, slope, curvature
    (and zero jerk for poly7) given at every point."""
    interpolate = pytest.importorskip("scipy.interpolate")
    xs = np.cumsum([0.0] + [r[0] for r in rows[1:]])
    pts = [CamPoint(float(x), r[1], r[2], r[3]) for x, r in zip(xs, rows, strict=True)]
    t = CamTable(tuple(pts), (law,))
    extra = [0.0] if law == "poly7" else []
    peer = interpolate.BPoly.from_derivatives(
        xs, [[p.slave, p.slope, p.curvature, *extra] for p in pts]
    )
    grid = np.linspace(xs[0], xs[-1], 2001)
    s = t.sample(grid)
    for k, got in enumerate((s.y, s.dy, s.d2y, s.d3y)):
        want = peer(grid, nu=k)
        scale = 1.0 + float(np.max(np.abs(want)))
        assert float(np.max(np.abs(got - want))) <= 1e-9 * scale


@given(
    st.lists(st.tuples(st.floats(0.05, 2.0), st.floats(-3, 3)), min_size=3, max_size=12),
    st.floats(-2, 2),
    st.floats(-2, 2),
)
@hsettings(40)
def test_smooth_points_follow_the_clamped_cubic_spline(
    rows: list[tuple[float, float]], m0: float, m1: float
) -> None:
    """``smooth``: the free interior points get the slope and curvature of the clamped cubic
    spline through the points (scipy's CubicSpline as the peer); between two free points the
    table is that cubic; the table is C2 everywhere."""
    interpolate = pytest.importorskip("scipy.interpolate")
    xs = np.cumsum([0.0] + [r[0] for r in rows[1:]])
    ys = [r[1] for r in rows]
    pts = [CamPoint(float(xs[0]), ys[0], m0)]
    pts += [CamPoint(float(x), y) for x, y in zip(xs[1:-1], ys[1:-1], strict=True)]
    pts += [CamPoint(float(xs[-1]), ys[-1], m1)]
    t = CamTable(tuple(pts), ("poly5",), smooth=True)
    peer = interpolate.CubicSpline(xs, ys, bc_type=((1, m0), (1, m1)))
    scale = 1.0 + float(np.max(np.abs(peer(xs, 1)))) + float(np.max(np.abs(peer(xs, 2))))
    for i in range(1, len(xs) - 1):
        slope, curv = t.boundary[i]
        assert slope == pytest.approx(float(peer(xs[i], 1)), abs=1e-9 * scale)
        assert curv == pytest.approx(float(peer(xs[i], 2)), abs=1e-8 * scale)
    if len(xs) >= 4:  # segments between free points: the cubic itself
        grid = np.linspace(xs[1], xs[-2], 501)
        s = t.sample(grid)
        assert float(np.max(np.abs(s.y - peer(grid)))) <= 1e-9 * (1 + scale)
    assert t.c2
    for x in xs[1:-1]:
        a, b = t.at(float(x)), t.at(math.nextafter(float(x), -math.inf))
        assert a[2] == pytest.approx(b[2], abs=1e-8 * scale)


def test_smooth_keeps_constrained_points() -> None:
    """Explicit slopes, rigid neighbours and the ends follow the usual rules; only free runs
    are splined (each clamped to its own ends)."""
    t = CamTable.from_points(
        [(0, 0), (1, 1), (2, 1.5, 0.0), (3, 1.0), (4, 0.0), (5, 0.0), (6, 0.5), (7, 0.2)],
        laws=["poly5", "poly5", "poly5", "poly5", "cycloid", "poly5", "poly5"],
        smooth=True,
    )
    assert t.boundary[0] == (0.0, 0.0) and t.boundary[-1] == (0.0, 0.0)
    assert t.boundary[2] == (0.0, 0.0)  # explicit slope 0, curvature at rest
    assert t.boundary[4] == (0.0, 0.0) and t.boundary[5] == (0.0, 0.0)  # cycloid's ends
    assert t.boundary[1][0] > 0 and t.boundary[3][0] < 0 and t.boundary[6][0] != 0
    rest = CamTable.from_points(
        [(0, 0), (1, 1), (2, 1.5, 0.0), (3, 1.0), (4, 0.0), (5, 0.0), (6, 0.5), (7, 0.2)],
        laws=["poly5", "poly5", "poly5", "poly5", "cycloid", "poly5", "poly5"],
    )
    assert rest.boundary[1] == (0.0, 0.0) and rest != t


def test_linear_neighbours_give_their_slope_to_poly5() -> None:
    """A constant-velocity section entered and left through poly5: C2, slope taken over."""
    t = CamTable.from_points(
        [(0, 0), (1, 0.5), (2, 1.5), (3, 2.5), (4, 3.0)],
        laws=["poly5", "linear", "linear", "poly5"],
    )
    assert t.boundary[1] == (1.0, 0.0) and t.boundary[3] == (1.0, 0.0)
    assert t.boundary[0] == (0.0, 0.0) and t.boundary[4] == (0.0, 0.0)
    for x in (1.0, 3.0):
        a, b = t.at(x), t.at(math.nextafter(x, -1.0))
        assert a[1] == pytest.approx(b[1], abs=1e-12) and abs(a[2] - b[2]) < 1e-10
    assert t.c2


def test_harmonic_curvature_jump_is_flagged_and_poly5_adopts_it() -> None:
    # harmonic between rests: the acceleration jumps at both ends
    t = CamTable.from_points(
        [(0, 0), (1, 0), (2, 1), (3, 1)], laws=["linear", "harmonic", "linear"]
    )
    assert not t.c2
    assert [i for i, _ in t.curvature_jumps] == [1, 2]
    assert t.curvature_jumps[0][1] == pytest.approx(PI**2 / 2)
    assert t.slave_peaks(1.0).j == math.inf
    assert t.slave_peaks(0.0).j == 0.0
    # with poly5 neighbours the table adopts the harmonic's end curvature: C2
    t2 = CamTable.from_points([(0, 0), (1, 0), (2, 1), (3, 1)], laws=["poly5", "harmonic", "poly5"])
    assert t2.c2
    for x in (1.0, 2.0):
        a, b = t2.at(x), t2.at(math.nextafter(x, -1.0))
        assert a[2] == pytest.approx(b[2], abs=1e-9)


def test_periodic_seam() -> None:
    pts = [(0.0, 0.0), (PI / 2, 0.0), (PI, 0.3), (3 * PI / 2, 0.3), (2 * PI, 0.0)]
    t = CamTable.from_points(pts, laws=["linear", "poly5", "modified_sine", "poly5"])
    g = t.periodic_gaps()
    assert abs(g.slope) < 1e-12 and abs(g.curvature) < 1e-12 and g.lift == 0.0
    # a lift with a constant-velocity start and end: periodic=True carries the slope over
    lift = [(0.0, 0.0), (1.0, 1.0), (2.0, 1.5), (3.0, 3.0)]
    open_ = CamTable.from_points(lift, laws=["linear", "poly5", "poly5"])
    assert open_.periodic_gaps().slope == pytest.approx(-1.0)
    per = CamTable.from_points(lift, laws=["linear", "poly5", "poly5"], periodic=True)
    g = per.periodic_gaps()
    assert abs(g.slope) < 1e-12 and abs(g.curvature) < 1e-12 and g.lift == 3.0
    assert per.boundary[-1] == (1.0, 0.0)
    # a periodic seam between two rigid laws of different slopes is refused
    with pytest.raises(CamTableError, match=r"points\[0\] / points\[3\]\.slope") as ei:
        CamTable.from_points(lift, laws=["linear", "poly5", "linear"], periodic=True)
    assert ei.value.field == "slope"


def test_slave_peaks_against_sampling() -> None:
    t = CamTable.from_points(
        [(0, 0), (1, 0), (2, 1), (3, 2), (3.5, 2.5), (4, 2.5), (2 * PI, 0)],
        laws=["linear", "poly5", "linear", "poly5", "modified_sine", "modified_trapezoid"],
    )
    # a dense grid plus both sides of every section boundary (where jerk peaks sit)
    edges = np.array(t._starts[1:])
    xs = np.concatenate([np.linspace(0, 2 * PI, 400_001), edges, np.nextafter(edges, -1)])
    s = t.sample(xs)
    for vm, am, jm in ((2.0, 0.0, 0.0), (2.0, 3.0, 0.0), (-1.5, 4.0, -20.0), (0.5, -2.0, 7.0)):
        pk = t.slave_peaks(vm, am, jm)
        v = np.abs(s.dy * vm)
        a = np.abs(s.d2y * vm * vm + s.dy * am)
        j = np.abs(s.d3y * vm**3 + 3 * s.d2y * vm * am + s.dy * jm)
        for got, arr in ((pk.v, v), (pk.a, a), (pk.j, j)):
            m = float(np.max(arr))
            assert m <= got * (1 + 1e-12) + 1e-12
            assert m >= got * (1 - 1e-6)
        bd = t.slave_bounds(vm, am, jm)
        for lo, hi, arr in (
            (bd.v_min, bd.v_max, s.dy * vm),
            (bd.a_min, bd.a_max, s.d2y * vm * vm + s.dy * am),
            (bd.j_min, bd.j_max, s.d3y * vm**3 + 3 * s.d2y * vm * am + s.dy * jm),
        ):
            span = hi - lo
            assert float(np.min(arr)) >= lo - 1e-12 * span
            assert float(np.max(arr)) <= hi + 1e-12 * span
            assert float(np.min(arr)) <= lo + 1e-6 * span
            assert float(np.max(arr)) >= hi - 1e-6 * span
    with pytest.raises(ValueError, match="master_v"):
        t.slave_peaks(math.nan)
    with pytest.raises(ValueError, match="master_a"):
        t.slave_bounds(1.0, math.inf)


@given(
    st.floats(-5, 5),
    st.floats(-50, 50),
    st.floats(-500, 500),
    st.floats(0.0, 1.0),
)
@hsettings(60)
def test_peaks_bound_is_a_monotone_upper_bound(vm: float, am: float, jm: float, f: float) -> None:
    t = CamTable.from_points(
        [(0, 0), (1, 0), (2, 1), (3, 2), (3.5, 2.5), (4, 2.5), (2 * PI, 0)],
        laws=["linear", "poly5", "linear", "poly7", "modified_sine", "cycloid"],
    )
    exact, bound = t.slave_peaks(vm, am, jm), t.slave_peaks_bound(vm, am, jm)
    for e, b in zip(exact, bound, strict=True):
        assert e <= b * (1 + 1e-12) + 1e-12
    assert t.slave_peaks_bound(vm) == t.slave_peaks(vm)
    inner = t.slave_peaks_bound(f * vm, -f * am, -f * jm)  # inside the envelope, signs flipped
    assert all(i <= b for i, b in zip(inner, bound, strict=True))
    assert all(
        e <= b * (1 + 1e-12) + 1e-12
        for e, b in zip(t.slave_peaks(f * vm, -f * am, -f * jm), bound, strict=True)
    )


def test_periodic_steps_in_bounds() -> None:
    # slope 0 at the start, 1 at the end: used periodically the slave's velocity steps
    t = CamTable.from_points([(0, 0), (1, 0.5), (2, 1.5)], laws=["poly5", "linear"])
    assert t.periodic_gaps().slope == pytest.approx(1.0)
    assert math.isfinite(t.slave_peaks(1.0).a)
    pk = t.slave_peaks(1.0, periodic=True)
    assert pk.a == math.inf and pk.j == math.inf and math.isfinite(pk.v)
    assert t.slave_peaks(0.0, periodic=True) == (0.0, 0.0, 0.0)


def test_at_range_and_sample_agree() -> None:
    t = CamTable.from_points([(0, 0), (1, 1), (2, 0)], laws=["cycloid", "modified_sine"])
    with pytest.raises(ValueError, match=r"x: must be in \[0.0, 2.0\]"):
        t.at(2.0000001)
    with pytest.raises(ValueError):
        t.at(math.nan)
    with pytest.raises(ValueError, match=r"xs\[2\]"):
        t.sample([0.0, 1.0, -0.5])
    assert t.at(0.0)[0] == 0.0 and t.at(1.0)[0] == 1.0 and t.at(2.0)[0] == 0.0
    xs = np.linspace(0, 2, 1001)
    s = t.sample(xs.reshape(7, 143))
    assert s.y.shape == (7, 143)
    for x, y, dy in zip(xs, s.y.ravel(), s.dy.ravel(), strict=True):
        got = t.at(float(x))
        assert got[0] == pytest.approx(y, abs=1e-15) and got[1] == pytest.approx(dy, abs=1e-13)


def test_immutable_and_hashable() -> None:
    t = CamTable.from_points([(0, 0), (1, 1)])
    with pytest.raises(AttributeError):
        t.periodic = True  # type: ignore[misc]
    assert t == CamTable.from_points([CamPoint(0, 0), CamPoint(1, 1)], laws=["poly5"])
    assert hash(t) == hash(CamTable((CamPoint(0, 0), CamPoint(1, 1))))
    assert t != CamTable.from_points([(0, 0), (1, 1)], law="cycloid")


@pytest.mark.parametrize(
    ("points", "laws", "index", "field", "match"),
    [
        ([(0, 0)], None, None, "points", "at least 2 points"),
        ([], None, None, "points", "at least 2 points"),
        ([(0, 0), (0, 1)], None, 1, "master", r"points\[1\]\.master: must be at least 1e-09"),
        ([(0, 0), (1, 1), (0.5, 2)], None, 2, "master", "strictly increasing"),
        ([(0, 0), (math.nan, 1)], None, 1, "master", r"finite number in \[-1e\+12, 1e\+12\]"),
        ([(0, 0), (1, math.inf)], None, 1, "slave", r"points\[1\]\.slave"),
        ([(0, 0), (1, 1, 2e9)], None, 1, "slope", r"\[-1e\+09, 1e\+09\]"),
        ([(0, 0), (1, 1, 0.0, math.nan)], None, 1, "curvature", "curvature"),
        ([(0, 0), (1, "a")], None, 1, "slave", "allowed: a number"),
        ([(0, 0), (1, True)], None, 1, "slave", "allowed: a number"),
        ([(0, 0), (1, 1)], ["spline"], 0, "law", "unknown motion law 'spline'"),
        ([(0, 0), (1, 1), (2, 2)], ["poly5", "poly5", "poly5"], None, "laws", "one law per"),
        ([(0, 0), (1, 1), (2, 3)], ["linear", "linear"], 1, "slope", "segment 1"),
        ([(0, 0), (1, 1, 0.5), (2, 3)], ["modified_sine", "poly5"], 1, "slope", "modified_sine"),
        ([(0, 0, 0.3), (1, 1)], ["cycloid"], 0, "slope", "cycloid"),
        ([(0, 0), (1, 1, 2.0), (2, 2)], ["linear", "poly5"], 1, "slope", "linear"),
        ([(0, 0), (1, 1, None, 1.0), (2, 2)], ["linear", "poly5"], 1, "curvature", "linear"),
        ([(0, 0), (1, 1, None, 0.0), (2, 2)], ["harmonic", "poly5"], 1, "curvature", "harmonic"),
        ([(0, 0), (1, 1, 1, 1, 1)], None, 1, "points", r"\[master, slave\]"),
        ([(0, 0), {"master": 1}], None, 1, "slave", "missing"),
        ([(0, 0), {"master": 1, "slave": 2, "speed": 1}], None, 1, "speed", "unknown key"),
    ],
)
def test_malformed_tables(
    points: list, laws: list | None, index: int | None, field: str, match: str
) -> None:
    with pytest.raises(CamTableError, match=match) as ei:
        CamTable.from_points(points, laws=laws)
    assert ei.value.index == index
    assert ei.value.field == field
    assert isinstance(ei.value, ValueError) and isinstance(ei.value, PlanningError)


def test_numpy_points() -> None:
    arr = np.array([[0.0, 0.0], [1.0, 2.0], [2.0, 2.0]], dtype=np.float32)
    t = CamTable.from_points(arr, law="cycloid")
    assert t == CamTable.from_points([(0, 0), (1, 2), (2, 2)], law="cycloid")
    with pytest.raises(CamTableError, match=r"points\[1\]\.slave: got .* \(allowed: a number"):
        CamTable.from_points([(0, 0), (1, np.bool_(True))])


def test_direct_constructor_checks_points() -> None:
    with pytest.raises(CamTableError, match=r"points\[1\]: must be a CamPoint"):
        CamTable((CamPoint(0, 0), (1, 1)))  # type: ignore[arg-type]


# ---- random tables ---------------------------------------------------------------------

RIGID = tuple(law for law in LAWS if law not in FLEXIBLE_LAWS)


@st.composite
def tables(draw: st.DrawFn) -> tuple[CamTable, list[CamPoint]]:
    n = draw(st.integers(2, 7))
    xs = [draw(st.floats(-10, 10))]
    for _ in range(n - 1):
        xs.append(xs[-1] + draw(st.floats(0.05, 3.0)))
    ys = [draw(st.floats(-5, 5)) for _ in range(n)]
    laws = [draw(st.sampled_from(LAWS)) for _ in range(n - 1)]
    # a linear segment next to another rigid law would have to match its slope: make it poly5
    for s, law in enumerate(laws):
        if law == "linear":
            left = laws[s - 1] if s > 0 else None
            right = laws[s + 1] if s + 1 < len(laws) else None
            if any(nb in RIGID for nb in (left, right)):
                laws[s] = "poly5"
    pts = []
    for i in range(n):
        nbs = [laws[s] for s in (i - 1, i) if 0 <= s < n - 1]
        free = all(law in FLEXIBLE_LAWS for law in nbs)
        slope = draw(st.one_of(st.none(), st.floats(-3, 3))) if free else None
        curv = draw(st.one_of(st.none(), st.floats(-20, 20))) if free else None
        pts.append(CamPoint(xs[i], ys[i], slope, curv))
    return CamTable(tuple(pts), tuple(laws), smooth=draw(st.booleans())), pts


@given(tables())
@hsettings(150)
def test_random_tables_are_c2_where_the_laws_allow(tp: tuple[CamTable, list[CamPoint]]) -> None:
    t, pts = tp
    tol = [1e-9 * (1 + abs(p)) for p in (10.0, t.peak_slope, t.peak_curvature)]
    jump_at = dict(t.curvature_jumps)
    for i, p in enumerate(pts):
        y, dy, d2y, _ = t.at(p.master)
        assert y == pytest.approx(p.slave, abs=tol[0])
        if p.slope is not None:
            assert dy == pytest.approx(p.slope, abs=tol[1])
        if p.curvature is not None:
            assert d2y == pytest.approx(p.curvature, abs=tol[2])
        if 0 < i < len(pts) - 1:
            before = t.at(math.nextafter(p.master, -math.inf))
            assert before[0] == pytest.approx(y, abs=tol[0])
            assert before[1] == pytest.approx(dy, abs=tol[1])
            expected_jump = jump_at.get(i, 0.0)
            assert d2y - before[2] == pytest.approx(expected_jump, abs=tol[2] + 1e-9 * abs(d2y))
            if i in jump_at:  # only a harmonic next to a rigid law forces a jump
                segs = (t.segment_laws[i - 1], t.segment_laws[i])
                assert "harmonic" in segs and all(s in RIGID for s in segs)
    # continuity inside the trigonometric laws (their section boundaries)
    for x in t._starts[1:]:
        a, b = t.at(x), t.at(math.nextafter(x, -math.inf))
        if any(math.isclose(x, p.master, abs_tol=1e-12) for p in pts):
            continue
        for k in range(3):
            assert a[k] == pytest.approx(b[k], abs=tol[k] + 1e-12 * abs(a[k]))
    # the peaks bound a dense sample
    s = t.sample(np.linspace(t.master_start, t.master_end, 4001))
    assert float(np.max(np.abs(s.dy))) <= t.peak_slope * (1 + 1e-12) + 1e-15
    assert float(np.max(np.abs(s.d2y))) <= t.peak_curvature * (1 + 1e-12) + 1e-15


@given(tables(), st.floats(-3, 3), st.floats(-30, 30), st.floats(-300, 300))
@hsettings(60)
def test_random_slave_bounds_are_exact(
    tp: tuple[CamTable, list[CamPoint]], vm: float, am: float, jm: float
) -> None:
    """The signed extremes contain a dense sample (plus both sides of every section
    boundary) and are reached by it to 2e-3 of their span (the grid's resolution on the
    sharpest random segments; the fixed table above: 1e-6)."""
    t, _ = tp
    edges = np.array(t._starts[1:])
    xs = np.concatenate(
        [np.linspace(t.master_start, t.master_end, 20_001), edges, np.nextafter(edges, -np.inf)]
    )
    s = t.sample(xs)
    bd = t.slave_bounds(vm, am, jm)
    combos = (
        (bd.v_min, bd.v_max, s.dy * vm),
        (bd.a_min, bd.a_max, s.d2y * vm * vm + s.dy * am),
        (bd.j_min, bd.j_max, s.d3y * vm**3 + 3 * s.d2y * vm * am + s.dy * jm),
    )
    for k, (lo, hi, arr) in enumerate(combos):
        if k == 2 and t.curvature_jumps and vm != 0.0:
            assert lo == -math.inf and hi == math.inf
            continue
        span = hi - lo
        assert float(np.min(arr)) >= lo - 1e-9 * span - 1e-12
        assert float(np.max(arr)) <= hi + 1e-9 * span + 1e-12
        assert float(np.min(arr)) <= lo + 2e-3 * span + 1e-12
        assert float(np.max(arr)) >= hi - 2e-3 * span - 1e-12
