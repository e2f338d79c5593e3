"""plan_batch against plan, problem by problem.

Every row of a BatchPlan must be the Profile that ``plan`` returns for the same problem: the
duration, every knot (start time, p, v, a, jerk), every segment duration, the end state and the
family name, compared with ``==`` (so bit-identical up to the sign of zero). The exception are
the rest-to-rest rows that plan solves with quartic roots (families none, acc0, acc1 with
asymmetric limits) and plan_batch in closed form: for them the segment count, jerks and kind
must match exactly and the times and states within REL_TOL (measured: below 1e-15 relative to
the duration or the excursion). Cases: random
(Ruckig's distributions, rest to rest with symmetric and asymmetric limits, starts outside the
limits, second order) and on edge cases (tiny and huge distances, infinite limits, family
boundaries a few ulp either side, zero distance, both directions); hypothesis draws
rest-to-rest problems over many decades. The sampler is compared with Profile.sample, the
errors with plan's and Limits'.
"""

from __future__ import annotations

import contextlib
import math
import sys
from collections.abc import Callable, Iterator

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from motionplc.planning import BatchPlan, Limits, PlanningError, Profile, State, plan, plan_batch
from motionplc.planning import batch as batch_module
from tests.planning._cases import Case, generate_cases
from tests.planning._strategies import hsettings

INF = math.inf
# the row-by-row path's size in these tests (plan_batch takes it for every compiled batch and
# for pure-Python batches of at most 64 problems; numpy_path() forces the numpy path)
SMALL = 64


@contextlib.contextmanager
def numpy_path() -> Iterator[None]:
    """plan_batch through the numpy path for every batch (the vectorised rest-to-rest closed
    forms, core rows by batch._core_rows), as the pure-Python core plans batches of more than
    64 problems."""
    saved = batch_module._SMALL
    batch_module._SMALL = 0
    try:
        yield
    finally:
        batch_module._SMALL = saved


@contextlib.contextmanager
def rows_path() -> Iterator[None]:
    """plan_batch row by row for every batch (as the compiled core plans every batch)."""
    saved = batch_module._SMALL
    batch_module._SMALL = sys.maxsize
    try:
        yield
    finally:
        batch_module._SMALL = saved


def _columns(cases: list[Case]) -> list[np.ndarray]:
    cols = [np.array([getattr(c, f) for c in cases], dtype=float) for f in Case.__slots__[:9]]
    cols.append(np.array([c.lo_v for c in cases]))
    cols.append(np.array([c.lo_a for c in cases]))
    return cols


def _rest(rng: np.random.Generator, n: int, asymmetric: bool) -> list[Case]:
    u = lambda: float(rng.uniform(0.08, 16.0))  # noqa: E731
    out = []
    for _ in range(n):
        p0, pf = (float(x) for x in rng.normal(0.0, 4.0, 2))
        vmax, amax, jmax = u(), u(), u()
        out.append(
            Case(
                p0, 0.0, 0.0, pf, 0.0, 0.0, vmax, amax, jmax,
                -u() if asymmetric else None, -u() if asymmetric else None,
            )
        )  # fmt: skip
    return out


REL_TOL = 1e-12
# rest-to-rest families plan finds as quartic roots and plan_batch in closed form
CLOSED_FORM = {"none", "acc0", "acc1", "none-down", "acc0-down", "acc1-down"}


def _same(x: float, y: float, scale: float, exact: bool) -> bool:
    return x == y if exact else abs(x - y) <= REL_TOL * scale


def _row_equals_plan(b: BatchPlan, i: int, prof: Profile, *, exact: bool | None = None) -> str:
    """'' when row i of the batch is the profile (bit for bit, or for a closed-form row of
    rest to rest within REL_TOL of the duration / excursion), else what differs."""
    m = int(b.n_segments[i])
    knots = prof.knots
    if exact is None:
        exact = not (prof.kind in CLOSED_FORM and prof.start.v == 0.0 and prof.start.a == 0.0)
    if len(knots) != m:
        return f"{m} segments, plan has {len(knots)}"
    if prof.kind != b.kind[i]:
        return f"kind {b.kind[i]!r} != {prof.kind!r}"
    T = prof.duration
    (p_lo, p_hi), (v_lo, v_hi), (a_lo, a_hi) = prof.extrema()
    sp = max(1.0, abs(p_lo), abs(p_hi))
    sv = max(1.0, abs(v_lo), abs(v_hi))
    sa = max(1.0, abs(a_lo), abs(a_hi))
    if not _same(T, float(b.duration[i]), max(1.0, T), exact):
        return f"duration {b.duration[i]!r} != {T!r}"
    scales = (max(1.0, T), sp, sv, sa, 0.0, max(1.0, T))
    for c, (k, seg) in enumerate(zip(knots, prof.segments, strict=True)):
        row = (b.t[i, c], b.p[i, c], b.v[i, c], b.a[i, c], b.j[i, c], b.durations[i, c])
        ref = (*k, seg.duration)
        if not all(
            _same(float(x), y, sc, exact and q != 4) if q != 4 else x == y
            for q, (x, y, sc) in enumerate(zip(row, ref, scales, strict=True))
        ):
            return f"segment {c}: {row} != {ref}"
    e = prof.end
    got_end = (float(b.end_p[i]), float(b.end_v[i]), float(b.end_a[i]))
    ends = zip(got_end, (e.p, e.v, e.a), (sp, sv, sa), strict=True)
    if not all(_same(x, y, sc, exact) for x, y, sc in ends):
        return f"end {got_end} != {e}"
    if m == 0 and (b.p[i, 0], b.v[i, 0], b.a[i, 0]) != got_end:
        return "the state of a profile of no duration is not in column 0"
    # padding: no duration, no jerk, start time = duration, state = end state
    pad = slice(m, None)
    if (b.durations[i, pad] != 0.0).any() or (b.j[i, pad] != 0.0).any():
        return "padding with a duration or jerk"
    if (b.t[i, pad] != b.duration[i]).any():
        return "padding start time is not the duration"
    pad = slice(max(m, 1), None)
    if (
        (b.p[i, pad] != got_end[0]).any()
        or (b.v[i, pad] != got_end[1]).any()
        or (b.a[i, pad] != got_end[2]).any()
    ):
        return "padding state is not the end state"
    return ""


def _assert_batch_equals_plan(cases: list[Case]) -> BatchPlan:
    """Every row of plan_batch is plan's, through the numpy path and row by row (the row
    path's result is returned)."""
    refs = [plan(c.start(), c.target(), c.limits()) for c in cases]
    for path in (numpy_path, rows_path):
        with path():
            b = plan_batch(*_columns(cases))
        assert len(b) == len(cases)
        bad = []
        for i, c in enumerate(cases):
            why = _row_equals_plan(b, i, refs[i])
            if why:
                bad.append(f"{c.code()}: {why}")
        assert not bad, (
            f"{path.__name__}: {len(bad)} of {len(cases)} rows differ from plan, e.g.\n"
            + "\n".join(bad[:5])
        )
    return b


def _assert_rows_identical(b: BatchPlan, i: int, ref: BatchPlan, k: int) -> None:
    """Row i of b is row k of ref bit for bit (up to the sign of zero)."""
    for name in ("t", "durations", "j", "p", "v", "a"):
        x, y = getattr(b, name)[i], getattr(ref, name)[k]
        for u, z in ((x, y), (y, x)):  # a wider row's extra columns are padding
            assert not np.any(z[u.shape[0] :] != z[-1]), (name, i, k)
        m = min(x.shape[0], y.shape[0])
        assert np.array_equal(x[:m], y[:m]), (name, i, k, x, y)
    for name in ("duration", "end_p", "end_v", "end_a", "n_segments"):
        assert getattr(b, name)[i] == getattr(ref, name)[k], (name, i, k)
    assert b.kind[i] == ref.kind[k]


def _assert_small_path_is_numpy_path(cases: list[Case], size: int = SMALL) -> None:
    """plan_batch row by row (plain floats) on chunks of ``size`` rows and on all of them
    gives the rows of one call through the numpy path bit for bit: the same arithmetic, the
    same dispatch."""
    with numpy_path():
        wide = plan_batch(*_columns(cases))
    with rows_path():
        whole = plan_batch(*_columns(cases))
        for k in range(len(whole)):
            _assert_rows_identical(whole, k, wide, k)
        for start in range(0, len(cases), size):
            part = plan_batch(*_columns(cases[start : start + size]))
            for k in range(len(part)):
                _assert_rows_identical(part, k, wide, start + k)


# -- equality with plan ----------------------------------------------------------------------
@pytest.mark.parametrize("asymmetric", [False, True], ids=["symmetric", "asymmetric"])
def test_rest_to_rest_random_equals_plan(asymmetric: bool, summary: Callable[[str], None]) -> None:
    cases = _rest(np.random.default_rng(15 + asymmetric), 3000, asymmetric)
    b = _assert_batch_equals_plan(cases)
    # how close the closed-form rows come (the others are bit-identical)
    closed = [i for i, k in enumerate(b.kind) if k in CLOSED_FORM]
    worst = 0.0
    identical = 0
    for i in closed:
        c = cases[i]
        ref = plan(c.start(), c.target(), c.limits())
        identical += _row_equals_plan(b, i, ref, exact=True) == ""
        worst = max(worst, abs(ref.duration - b.duration[i]) / ref.duration)
        for k, x in zip(ref.segments, b.durations[i], strict=False):
            worst = max(worst, abs(k.duration - x) / ref.duration)
    summary(
        f"{len(cases) - len(closed)} rows bit-identical to plan, {len(closed)} closed-form "
        f"rows ({identical} of them identical), worst relative difference {worst:.2g}"
    )
    assert worst <= REL_TOL
    kinds = set(b.kind)
    # the numpy families all occur (and, asymmetric, the core's quartic ones)
    assert {"none-rest", "vel", "vel-down", "acc0_acc1", "acc0_acc1-down"} <= kinds
    if asymmetric:
        assert {"acc0", "acc1", "none"} <= {k.removesuffix("-down") for k in kinds}


def test_rest_to_rest_without_jerk_limit_equals_plan_bit_for_bit() -> None:
    """Second order (one in seven also without an acceleration limit: first order)."""
    cases = []
    for k, c in enumerate(_rest(np.random.default_rng(151), 1500, True)):
        a = (INF, None) if k % 7 == 0 else (c.a_max, c.a_min)
        cases.append(Case(c.p0, 0.0, 0.0, c.pf, 0.0, 0.0, c.v_max, a[0], INF, c.v_min, a[1]))
    b = _assert_batch_equals_plan(cases)
    assert set(b.kind) == {"second-order", "first-order"}


@pytest.mark.parametrize(
    "kwargs",
    [
        {},
        {"nonzero": True, "asymmetric_fraction": 0.5},
        {"outside_fraction": 0.3, "boundary_fraction": 0.3},
        {"order": 2, "outside_fraction": 0.2},
    ],
    ids=["ruckig", "asymmetric", "outside", "second-order"],
)
def test_general_random_equals_plan_bit_for_bit(kwargs: dict[str, object]) -> None:
    _assert_batch_equals_plan(generate_cases(400, 1515, **kwargs))


def _edge_cases() -> list[Case]:
    """Distances over the whole range, infinite limits, zero distance, both directions and
    the family boundaries of rest to rest a few ulp either side."""
    out = []
    for d in (1e-15, 2e-15, 1e-12, 1e-9, 1e-6, 1e-3, 1.0, 1e3, 1e6, 1e9, 2e12):
        for s in (1.0, -1.0):
            for lim in ((1.0, 1.0, 1.0), (1e3, 1e3, 1e6), (1e-3, 1e-2, 1e-1), (1e6, 1e9, 1e15)):
                p0 = -1e12 if d == 2e12 and s > 0 else (1e12 if d == 2e12 else 0.25)
                out.append(Case(p0, 0.0, 0.0, p0 + s * d, 0.0, 0.0, *lim))
    for lim in ((INF, 2.0, 3.0), (2.0, INF, 3.0), (INF, INF, 3.0), (2.0, 3.0, INF)):
        for d in (-7.0, 1e-9, 5.0, 1e4):
            out.append(Case(1.0, 0.0, 0.0, 1.0 + d, 0.0, 0.0, *lim))
    for p in (0.0, 1.0, -3.5, 1e12, -1e12, 5e-324):  # zero distance: arrived
        out.append(Case(p, 0.0, 0.0, p, 0.0, 0.0, 1.0, 2.0, 3.0))
    # boundaries (v_max, a_max, j_max = 2, 3, 5): acceleration limit reached without cruise
    # at d = 2 A^3 / J^2, the cruise without plateaus at d = 2 V^1.5 / sqrt(J), the cruise
    # with plateaus at d = V (V / A + A / J); asymmetric: each side's own limit
    V, A, J = 2.0, 3.0, 5.0
    for d0 in (2 * A**3 / J**2, 2 * V**1.5 / math.sqrt(J), V * (V / A + A / J)):
        for k in range(-4, 5):
            d = d0 + k * math.ulp(d0)
            for s in (1.0, -1.0):
                out.append(Case(0.0, 0.0, 0.0, s * d, 0.0, 0.0, V, A, J))
                out.append(Case(0.0, 0.0, 0.0, s * d, 0.0, 0.0, V, A, J, -1.5 * V, -0.7 * A))
    V, A = 1.0, 2.0  # a_max^2 = j_max v_max: the plateau starts exactly at the cruise
    for d in (V * (V / A + A / J), 1.5, 3.0):
        out.append(Case(0.0, 0.0, 0.0, d, 0.0, 0.0, V, A, A * A / V))
    return out


@pytest.mark.parametrize("kind", ["symmetric", "asymmetric", "second-order", "general", "edge"])
def test_small_batches_equal_the_numpy_path_bit_for_bit(kind: str) -> None:
    """Batches planned row by row on floats (chunks of SMALL problems): every row equals
    the numpy path's (which equals plan) bit for bit, closed-form rows included."""
    rng = np.random.default_rng(1515)
    if kind == "edge":
        cases = []
        for c in _edge_cases():
            try:
                plan(c.start(), c.target(), c.limits())
            except PlanningError:
                continue
            cases.append(c)
    elif kind == "general":
        cases = generate_cases(300, 1516, nonzero=True, asymmetric_fraction=0.5)
    else:
        cases = _rest(rng, 600, kind == "asymmetric")
        if kind == "second-order":
            cases = [
                Case(c.p0, 0.0, 0.0, c.pf, 0.0, 0.0, c.v_max, INF if k % 5 == 0 else c.a_max, INF)
                for k, c in enumerate(cases)
            ]
    _assert_small_path_is_numpy_path(cases)


def test_rows_wider_than_seven_segments_alike_row_by_row_and_numpy() -> None:
    """Rows of more than seven segments (a brake first) are widened after planning (their
    extra segments kept aside), row by row as in the numpy path: in batches of 7 and 24 rows,
    with and without such a row, every row is the numpy path's."""
    rng = np.random.default_rng(1517)
    cases = generate_cases(300, 1518) + _rest(rng, 100, True)
    cases = [cases[k] for k in rng.permutation(len(cases))]
    widths = {plan_batch(*_columns(cases[s : s + 7])).t.shape[1] for s in range(0, 400, 7)}
    assert plan_batch(*_columns(cases)).t.shape[1] > 7 and 7 in widths and len(widths) > 1
    _assert_small_path_is_numpy_path(cases, 7)
    _assert_small_path_is_numpy_path(cases, 24)


@pytest.mark.parametrize("n", [5, 200])
def test_input_types_give_the_same_rows_and_inputs_stay_untouched(n: int) -> None:
    """Float arrays of one length (used as they are), lists and broadcast scalars (converted
    first) give the same rows, small batches and numpy ones; the inputs are not written."""
    cols = _columns(_rest(np.random.default_rng(7), n, True))
    before = [c.copy() for c in cols]
    ref = plan_batch(*cols)
    assert all(np.array_equal(c, b) for c, b in zip(cols, before, strict=True))
    as_lists = plan_batch(*(c.tolist() for c in cols))
    scalars = plan_batch(*cols[:6], float(cols[6][0]), *cols[7:])
    lone = plan_batch(*(c[:1] for c in cols[:6]), *(float(c[0]) for c in cols[6:]))
    for i in range(n):
        _assert_rows_identical(as_lists, i, ref, i)
        assert (
            scalars.duration[i]
            == plan_batch(
                *(c[i : i + 1] for c in cols[:6]),
                float(cols[6][0]),
                *(c[i : i + 1] for c in cols[7:]),
            ).duration[0]
        )
    _assert_rows_identical(lone, 0, ref, 0)


def test_edge_cases_equal_plan_or_fail_alike() -> None:
    ok: list[Case] = []
    for c in _edge_cases():
        try:
            plan(c.start(), c.target(), c.limits())
        except PlanningError as exc:
            with pytest.raises(PlanningError) as info:
                plan_batch(*_columns([c]))
            assert "problem 0" in str(info.value) or "[0]" in str(info.value), (c, exc)
            continue
        ok.append(c)
    assert len(ok) > 200
    b = _assert_batch_equals_plan(ok)
    assert "arrived" in b.kind


@given(
    d=st.floats(-9.9e11, 9.9e11, allow_subnormal=False),
    p0=st.floats(-1e3, 1e3),
    v=st.floats(-15.0, 15.0),
    a=st.floats(-15.0, 15.0),
    j=st.floats(-15.0, 15.0),
    ratio_v=st.floats(-1.0, 1.0),
    ratio_a=st.floats(-1.0, 1.0),
)
@hsettings(300)
def test_rest_to_rest_hypothesis_equals_plan(
    d: float, p0: float, v: float, a: float, j: float, ratio_v: float, ratio_a: float
) -> None:
    """Limits over 30 decades, distances from zero to 1e12, minima within 10x of maxima."""
    c = Case(
        p0, 0.0, 0.0, p0 + d, 0.0, 0.0, 10.0**v, 10.0**a, 10.0**j,
        -(10.0 ** (v + ratio_v)), -(10.0 ** (a + ratio_a)),
    )  # fmt: skip
    try:
        prof = plan(c.start(), c.target(), c.limits())
    except PlanningError:
        with pytest.raises(PlanningError):
            plan_batch(*_columns([c]))
        return
    with rows_path():
        b = plan_batch(*_columns([c, c]))  # row by row (floats)
    assert _row_equals_plan(b, 1, prof) == ""
    with numpy_path():
        wide = plan_batch(*_columns([c] * 3))
    assert _row_equals_plan(wide, 2, prof) == ""
    _assert_rows_identical(wide, 2, b, 1)


def test_profile_of_a_row_is_the_row_and_plans_profile() -> None:
    cases = _rest(np.random.default_rng(3), 200, True) + generate_cases(200, 4, order=2)
    cases.append(Case(1.0, 0.0, 0.0, 1.0, 0.0, 0.0, 1.0, 1.0, 1.0))
    b = plan_batch(*_columns(cases))
    for i, c in enumerate(cases):
        got = b.profile(i)
        assert isinstance(got, Profile)
        assert _row_equals_plan(b, i, got, exact=True) == "", c  # the row itself, bit for bit
        ref = plan(c.start(), c.target(), c.limits())
        assert _row_equals_plan(b, i, ref) == "", c
        if ref.kind not in CLOSED_FORM:
            assert got.knots == ref.knots and got.segments == ref.segments, c
            assert (got.duration, got.end, got.kind, got.start) == (
                ref.duration,
                ref.end,
                ref.kind,
                ref.start,
            ), c
    assert b.profile(-1).kind == "arrived"
    for i in (len(b), -len(b) - 1, 1.0, True):
        with pytest.raises(IndexError, match="problem index"):
            b.profile(i)  # type: ignore[arg-type]


# -- sampler ---------------------------------------------------------------------------------
def test_sample_equals_profile_sample() -> None:
    cases = _rest(np.random.default_rng(5), 150, True) + generate_cases(
        150, 6, outside_fraction=0.3
    )
    cases.append(Case(2.0, 0.0, 0.0, 2.0, 0.0, 0.0, 1.0, 1.0, 1.0))  # no duration
    b = plan_batch(*_columns(cases))
    profs = [b.profile(i) for i in range(len(cases))]  # plan's (test above)
    rng = np.random.default_rng(7)
    ts = np.concatenate([[-1.0, 0.0, 1e-9], rng.uniform(0.0, 1.2 * b.duration.max(), 200)])
    per_row = rng.uniform(-0.5, 1.0, (len(cases), 64)) * (1.2 * b.duration[:, None] + 0.5)
    per_row[:, 0] = b.duration  # exactly at the end
    per_row[:, 1] = np.nextafter(b.duration, 0.0)
    s1 = b.sample(ts)
    s2 = b.sample(per_row)
    for i, prof in enumerate(profs):
        for got, t in ((s1, ts), (s2, per_row[i])):
            ref = prof.sample(t)
            for name in ("p", "v", "a", "j"):
                assert np.array_equal(getattr(got, name)[i], getattr(ref, name)), (i, name)
        for t in (-0.1, 0.3, prof.duration, 1e9):
            s = b.sample(t)
            ref1 = prof.at(t)
            assert (s.p[i], s.v[i], s.a[i], s.j[i]) == tuple(ref1), (i, t)
    assert s1.p.shape == (len(cases), len(ts)) and b.sample(0.5).p.shape == (len(cases),)
    with pytest.raises(PlanningError, match="shape"):
        b.sample(np.zeros((len(cases) + 1, 3)))


# -- broadcasting, immutability --------------------------------------------------------------
def test_scalars_and_arrays_broadcast() -> None:
    pf = np.linspace(-3.0, 3.0, 7)
    b = plan_batch(0.0, 0, 0, pf, 0, 0, 2.0, 3.0, 5.0)
    assert len(b) == 7 and b.t.shape[0] == 7 and b.t.shape[1] >= 7
    for i, x in enumerate(pf):
        ref = plan(State(), State(float(x)), Limits(2.0, 3.0, 5.0))
        assert _row_equals_plan(b, i, ref) == ""
    one = plan_batch(0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 2.0, 3.0, 5.0)
    assert len(one) == 1 and one.duration[0] == plan(State(), State(1.0), Limits(2, 3, 5)).duration
    assert len(plan_batch([], 0, 0, [], 0, 0, 1, 1, 1)) == 0
    with pytest.raises(PlanningError, match="broadcast"):
        plan_batch([0.0, 1.0], 0, 0, [1.0, 2.0, 3.0], 0, 0, 1, 1, 1)


def test_batch_plan_is_immutable() -> None:
    b = plan_batch(0.0, 0.0, 0.0, [1.0, -2.0], 0.0, 0.0, 2.0, 3.0, 5.0)
    with pytest.raises(AttributeError):
        b.duration = np.zeros(2)  # type: ignore[misc]
    with pytest.raises(AttributeError):
        del b.t
    for name in ("duration", "t", "durations", "j", "p", "v", "a", "end_p", "n_segments"):
        arr = getattr(b, name)
        with pytest.raises(ValueError, match="read-only"):
            arr[0] = 1
    assert isinstance(b.kind, tuple)


# -- validation ------------------------------------------------------------------------------
_GOOD = {
    "p0": [0.0, 0.0, 0.0],
    "v0": 0.0,
    "a0": 0.0,
    "pf": [1.0, 2.0, 3.0],
    "vf": 0.0,
    "af": 0.0,
    "v_max": 2.0,
    "a_max": 3.0,
    "j_max": 5.0,
}


@pytest.mark.parametrize(
    ("field", "bad", "message"),
    [
        ("p0", [0.0, math.nan, 0.0], r"p0\[1\] must be a finite number in \[-1e\+12, 1e\+12\]"),
        ("v0", [0.0, 0.0, INF], r"v0\[2\] must be a finite number in \[-1e\+12, 1e\+12\]"),
        ("a0", [2e12, 0.0, 0.0], r"a0\[0\] must be a finite number"),
        ("pf", [0.0, -1.1e12, 0.0], r"pf\[1\] must be a finite number"),
        ("v_max", [1.0, 0.0, 1.0], r"v_max\[1\] must be in \[1e-15, 1e\+15\] or inf"),
        ("a_max", [1.0, 1.0, -1.0], r"a_max\[2\] must be in \[1e-15, 1e\+15\] or inf"),
        ("j_max", [math.nan, 1.0, 1.0], r"j_max\[0\] must be in \[1e-15, 1e\+15\] or inf"),
        ("v_min", [-1.0, 1.0, -1.0], r"v_min\[1\] must be in \[-1e\+15, -1e-15\] or -inf"),
        ("a_min", [-1.0, -1.0, -1e16], r"a_min\[2\] must be in \[-1e\+15, -1e-15\] or -inf"),
        ("vf", [0.0, 0.0, 3.0], r"vf\[2\] = 3.0 is outside the allowed range \[-2.0, 2.0\]"),
        ("af", [0.0, -4.0, 0.0], r"af\[1\] = -4.0 is outside the allowed range \[-3.0, 3.0\]"),
        ("p0", True, r"p0 must be a number or a 1-D array"),
        ("pf", "x", r"pf must be a number or a 1-D array"),
        ("pf", [[1.0, 2.0, 3.0]], r"pf must be a number or a 1-D array"),
        ("v_max", [1.0, None, 1.0], r"v_max must be a number or a 1-D array"),
    ],
)
def test_bad_input_names_field_index_and_range(field: str, bad: object, message: str) -> None:
    kwargs = dict(_GOOD, **{field: bad})
    with pytest.raises(PlanningError, match=message):
        plan_batch(**kwargs)  # type: ignore[arg-type]


def test_bad_input_same_range_as_plan_and_limits() -> None:
    """The range texts are plan's and Limits' own."""
    for field, bad in (("p0", math.nan), ("v_max", 1e16), ("v_min", 0.5)):
        with pytest.raises(PlanningError) as batch_err:
            plan_batch(**dict(_GOOD, **{field: bad}))  # type: ignore[arg-type]
        with pytest.raises(PlanningError) as ref_err:
            if field == "p0":
                plan(State(p=bad), State(1.0), Limits(2.0, 3.0, 5.0))
            else:
                Limits(**{"v_max": 2.0, "a_max": 3.0, "j_max": 5.0, field: bad})
        range_text = str(ref_err.value).split(" in ")[1].split(", got")[0]
        assert range_text in str(batch_err.value)


@pytest.mark.parametrize(
    ("kwargs", "index", "message"),
    [
        ({"a_max": [1.0, INF, 1.0], "a_min": -1.0}, 1, r"a_min\[1\] and a_max\[1\] must both"),
        ({"v_max": INF, "a_max": INF, "j_max": [1.0, INF, 1.0]}, 1, r"limits\[1\]: at least"),
        ({"af": [0.0, 0.0, 1.0], "j_max": INF}, 2, r"af\[2\] = 1.0 must be 0 when j_max is"),
        ({"vf": [0.0, 1.0, 0.0], "a_max": INF, "j_max": INF}, 1, r"vf\[1\] = 1.0 must be 0"),
        ({"vf": 1.9, "af": [0.0, -2.0, 0.0]}, 1, r"target state 1 .* without exceeding v_max"),
        ({"vf": -1.9, "af": [2.0, 0.0, 0.0]}, 0, r"target state 0 .* without going below"),
        (
            {"pf": [1.0, 1e12, 3.0], "j_max": 1e-15, "v_max": INF, "a_max": INF},
            1,
            r"problem 1: the profile would last .* beyond the supported 1e\+08 s",
        ),
    ],
)
def test_unplannable_problems_raise_like_plan(
    kwargs: dict[str, object], index: int, message: str
) -> None:
    merged = dict(_GOOD, **kwargs)
    with pytest.raises(PlanningError, match=message):
        plan_batch(**merged)  # type: ignore[arg-type]
    # the same problem alone raises in Limits or plan
    c = {
        k: float(np.broadcast_to(np.asarray(v, dtype=float), (3,))[index])
        for k, v in merged.items()
    }
    with pytest.raises(PlanningError):
        lim = Limits(c["v_max"], c["a_max"], c["j_max"], c.get("v_min"), c.get("a_min"))
        plan(State(c["p0"], c["v0"], c["a0"]), State(c["pf"], c["vf"], c["af"]), lim)


@pytest.mark.parametrize("path", [rows_path, numpy_path])
@pytest.mark.parametrize("n", [2, 2 * (SMALL + 1), 3 * 4096])
def test_several_failures_raise_the_same_error_small_or_numpy(
    n: int, path: Callable[[], contextlib.AbstractContextManager[None]]
) -> None:
    """Row 0 (moving: the core) and row 1 (rest to rest in closed form) both last too long:
    either path names row 1, the numpy path's order (closed-form rows first), also when the
    rows come in chunks (batch._ROWS_CHUNK, 4096)."""
    k = n // 2
    kwargs = {
        "p0": 0.0,
        "v0": [1e-3, 0.0] * k,
        "a0": 0.0,
        "pf": [1e12, 1e12] * k,
        "vf": 0.0,
        "af": 0.0,
        "v_max": INF,
        "a_max": INF,
        "j_max": 1e-15,
    }
    with path(), pytest.raises(PlanningError, match=r"^problem 1: the profile would last"):
        plan_batch(**kwargs)  # type: ignore[arg-type]


@pytest.mark.parametrize("path", ["rows", "numpy"])
@pytest.mark.parametrize("rest_rows", [False, True], ids=["all-core", "mixed"])
def test_core_failure_past_the_first_chunk_names_its_problem(rest_rows: bool, path: str) -> None:
    """Both paths plan in chunks (row by row: batch._ROWS_CHUNK rows; the numpy path its core
    rows: batch._ROW_CHUNK): a row that fails in a later chunk is named by its own problem
    number, in a batch of core rows only (chunk-local numbers are offset) and beside
    rest-to-rest rows (the core rows' problem numbers)."""
    chunk = batch_module._ROWS_CHUNK if path == "rows" else batch_module._ROW_CHUNK
    choose = rows_path if path == "rows" else numpy_path
    n = 3 * chunk + 7
    bad = 2 * chunk + 5
    v0 = np.full(n, 0.5)
    if rest_rows:
        v0[1::3] = 0.0  # every third row at rest: the closed forms
        v0[bad] = 0.5  # (a core row)
    pf = np.full(n, 2.0)
    pf[bad] = 1e12
    j_max = np.full(n, 5.0)
    j_max[bad] = 1e-15  # the profile lasts beyond MAX_DURATION
    kwargs = dict(p0=0.0, v0=v0, a0=0.0, vf=0.0, af=0.0, v_max=INF, a_max=INF, j_max=j_max)
    with choose(), pytest.raises(PlanningError, match=rf"^problem {bad}: the profile would"):
        plan_batch(pf=pf, **kwargs)  # type: ignore[arg-type]
    pf[bad] = 2.0
    with choose():
        b = plan_batch(pf=pf, **kwargs)  # type: ignore[arg-type]
    assert len(b) == n and (b.kind[bad] != "arrived")
