"""``_batchrow.rows_valid`` (the small batches' one-pass check) never passes what plan_batch's
vectorised checks reject: random rows near every bound (states, limits, target velocity and
acceleration inside the limits and reachable, infinite jerk or velocity limits, NaN), one row
at a time; and it does pass ordinary general and rest-to-rest rows (else the small path pays
for the vectorised checks)."""

from __future__ import annotations

import math
import struct

import numpy as np

from motionplc.errors import PlanningError
from motionplc.planning._batchrow import rows_valid
from motionplc.planning.batch import _validate_arrays
from tests.planning._cases import generate_cases

INF = math.inf


def _vectorised_ok(row: list[float]) -> bool:
    p0, v0, a0, pf, vf, af, vmax, vmin, amax, amin, jm = row
    arrs = [np.array([x]) for x in (p0, v0, a0, pf, vf, af, vmax, amax, jm, vmin, amin)]
    try:
        _validate_arrays(arrs, True, True)
    except PlanningError:
        return False
    return True


def _random_row(rng: np.random.Generator) -> list[float]:
    def pick(*xs: float) -> float:  # the first (ordinary) value half of the time
        return float(xs[0] if rng.random() < 0.5 else xs[int(rng.integers(len(xs)))])

    vmax = pick(float(rng.uniform(0.1, 3.0)), 2.0, INF, 1e-13, 1e13, math.nan, -1.0)
    vmin = pick(-2.0, -INF, -vmax, float(-rng.uniform(0.1, 3.0)), 0.5)
    amax = pick(3.0, INF, float(rng.uniform(0.1, 3.0)), 1e-13)
    amin = pick(-3.0, -amax, -INF, float(-rng.uniform(0.1, 3.0)))
    jm = pick(5.0, INF, float(rng.uniform(0.1, 10.0)), 0.0)
    vf = pick(float(rng.uniform(-3.0, 3.0)), 0.0, -0.0, vmax, vmin, 2e12)
    af = pick(float(rng.uniform(-3.0, 3.0)), 0.0, amax, amin, math.nan)
    if rng.random() < 0.3 and math.isfinite(jm) and jm > 0 and math.isfinite(af):  # the edge
        half = 0.5 * af * af / jm
        vf = (vmax - half) if af < 0 else (vmin + half)
        vf *= pick(1.0, 1.0 + 1e-12, 1.0 + 3e-12, 1.0 - 3e-12)
    p0, v0, a0, pf = (pick(float(rng.uniform(-5, 5)), 0.0, 2e12, -INF) for _ in range(4))
    return [p0, v0, a0, pf, vf, af, vmax, vmin, amax, amin, jm]


def test_never_passes_a_rejected_row() -> None:
    rng = np.random.default_rng(515)
    passed = rejected = 0
    for _ in range(6000):
        row = _random_row(rng)
        fast = rows_valid(struct.pack("<11d", *row), 1)
        ok = _vectorised_ok(row)
        assert not (fast and not ok), row
        passed += fast
        rejected += not ok
    assert passed > 300 and rejected > 1000, (passed, rejected)


def test_passes_ordinary_rows() -> None:
    for case in generate_cases(300, 9):
        row = [case.p0, case.v0, case.a0, case.pf, case.vf, case.af, case.v_max, case.lo_v,
               case.a_max, case.lo_a, case.j_max]  # fmt: skip
        assert _vectorised_ok(row)
        assert rows_valid(struct.pack("<11d", *row), 1), case


def test_a_table_fails_by_its_one_bad_row_wherever_it_is() -> None:
    """Many rows in one table: each row read at its own offset (one bad field of any row, at
    any place, fails the table; the table itself passes)."""
    rows = []
    for case in generate_cases(60, 10):
        rows.append([case.p0, case.v0, case.a0, case.pf, case.vf, case.af, case.v_max,
                     case.lo_v, case.a_max, case.lo_a, case.j_max])  # fmt: skip
    flat = [x for row in rows for x in row]
    assert rows_valid(struct.pack(f"<{len(flat)}d", *flat), len(rows))
    bad_values = (3e12, 3e12, 3e12, 3e12, 2e12, 2e12, -1.0, 1.0, INF, -INF, 0.0)
    for k in (0, 1, 30, 59):
        for q, bad in enumerate(bad_values):
            broken = list(flat)
            broken[11 * k + q] = bad
            assert not rows_valid(struct.pack(f"<{len(flat)}d", *broken), len(rows)), (k, q)
    assert rows_valid(struct.pack(f"<{len(flat)}d", *flat), len(rows) - 1)  # n rows only
