"""The planner's cube root (``roots.cbrt``) and its numpy twin (``batch.cbrt_array``).

Rest-to-rest profiles that reach no limit are four ramps of ``cbrt(|d| / 2J)``; ``plan`` and
``plan_batch``'s numpy path must give the same bits, whatever the platform's ``pow`` (numpy
2.4's SIMD power differs from C's pow in the last bit of about 5 % of ``x ** (1/3)``).
"""

from __future__ import annotations

import math
from fractions import Fraction

import numpy as np
from hypothesis import given
from hypothesis import strategies as st

from motionplc.planning.batch import cbrt_array
from motionplc.planning.roots import cbrt


def _within_ulp(x: float, y: float) -> bool:
    """Is the cube root of ``x`` between ``y``'s neighbours (exact rational arithmetic)?"""
    X = Fraction(x)
    lo = Fraction(math.nextafter(y, 0.0))
    hi = Fraction(math.nextafter(y, math.inf))
    return lo**3 <= X <= hi**3


def _nearest(x: float, y: float) -> bool:
    """Is ``y`` the double nearest to the cube root of ``x``?"""
    X, Y = Fraction(x), Fraction(y)
    lo = Fraction(math.nextafter(y, 0.0))
    hi = Fraction(math.nextafter(y, math.inf))
    return ((lo + Y) / 2) ** 3 <= X <= ((Y + hi) / 2) ** 3


def _inputs() -> np.ndarray:
    rng = np.random.default_rng(2026)
    special = [0.0, 5e-324, 1e-310, 2.2250738585072014e-308, 1e-300, 0.125, 1.0, 8.0, 27.0]
    special += [1e300, 1.7976931348623157e308, math.inf, math.nan, 3.0, 0.5, 4.0]
    return np.concatenate(
        [rng.uniform(0.0, 10.0, 20_000), 10.0 ** rng.uniform(-300.0, 300.0, 20_000), special]
    )


def test_numpy_twin_gives_the_same_bits() -> None:
    x = _inputs()
    a = cbrt_array(x)
    s = np.array([cbrt(float(v)) for v in x])
    same = (a == s) | (np.isnan(a) & np.isnan(s))
    assert same.all(), [
        (float(v), float(p), float(q)) for v, p, q in zip(x, a, s, strict=True) if p != q
    ][:5]


def test_every_binade_edge_gives_the_twin_bits() -> None:
    """``cbrt`` finds x = u 8^q by scaling with powers of two (its loops switch at powers of
    two and eight), the twin with frexp: at every power of two of the double range and the
    doubles next to it, the same bits."""
    edges = [math.ldexp(1.0, k) for k in range(-1074, 1024)]
    x = np.array([y for e in edges for y in (math.nextafter(e, 0.0), e, math.nextafter(e, 9e307))])
    x = x[np.isfinite(x) & (x > 0.0)]
    a = cbrt_array(x)
    s = np.array([cbrt(float(v)) for v in x])
    assert np.array_equal(a, s), [
        (float(v), float(p), float(q)) for v, p, q in zip(x, a, s, strict=True) if p != q
    ][:5]


def test_exact_cubes_and_specials() -> None:
    for k in (0.5, 1.0, 2.0, 3.0, 7.0, 1e-5, 12345.0):
        assert cbrt(k * k * k) == k
    assert cbrt(0.0) == 0.0
    assert cbrt(math.inf) == math.inf
    assert math.isnan(cbrt(math.nan))


def test_within_one_ulp_mostly_nearest_on_random_inputs() -> None:
    x = [float(v) for v in _inputs()[:3000] if 0.0 < v < math.inf]
    bad = [v for v in x if not _within_ulp(v, cbrt(v))]
    assert not bad, bad[:5]
    nearest = sum(_nearest(v, cbrt(v)) for v in x)
    assert nearest >= 0.85 * len(x), nearest


@given(st.floats(min_value=0.0, max_value=1e300, allow_nan=False, allow_subnormal=True))
def test_nearest_and_twin_hypothesis(x: float) -> None:
    y = cbrt(x)
    assert float(cbrt_array(np.array([x]))[0]) == y
    if x > 0.0:
        assert _within_ulp(x, y)
