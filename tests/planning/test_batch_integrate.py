"""``batch._integrate_into`` (in place, no compaction) against ``batch._integrate_arrays`` (the
general integration with compaction) and against ``Profile`` itself, bit for bit: random phase
tables in the core's layout (moving phases first, then phases of no duration) with exact
accelerations/velocities set by some phases, and tables with gaps (which take the fallback)."""

from __future__ import annotations

import numpy as np
import pytest

from motionplc.planning.batch import MIN_WIDTH, _integrate_arrays, _integrate_into
from motionplc.planning.profile import Profile
from motionplc.planning.state import State


def _integrate_rows(
    p0: np.ndarray,
    v0: np.ndarray,
    a0: np.ndarray,
    dur: np.ndarray,
    jerk: np.ndarray,
    ova: np.ndarray,
    ovv: np.ndarray,
    kinds: list[str],
) -> tuple[tuple[np.ndarray, ...], np.ndarray, np.ndarray, np.ndarray, list[str]]:
    """``_integrate_into`` with its own output arrays, laid out as ``batch._core_rows``
    returns them: (six (m, width) segment arrays, (3, m) end state, duration, counts, kinds)."""
    n_ph, m = dur.shape
    rec = np.empty((6, max(MIN_WIDTH, n_ph), m))
    ends = np.empty((4, m))
    cnt = np.empty(m, dtype=np.intp)
    with np.errstate(all="ignore"):
        _integrate_into(p0, v0, a0, dur, jerk, ova, ovv, rec, ends, cnt)
    w = max(MIN_WIDTH, int(cnt.max()) if m else 0)
    return tuple(rec[q, :w].T for q in range(6)), ends[:3], ends[3], cnt, kinds


def _table(rng: np.random.Generator, m: int, width: int, gaps: bool) -> tuple[np.ndarray, ...]:
    counts = rng.integers(0, width + 1, m)
    dur = rng.uniform(0.0, 2.0, (width, m)) * (np.arange(width)[:, None] < counts)
    if gaps:  # phases of no duration between moving ones in some rows
        dur[rng.random((width, m)) < 0.15] = 0.0
    jerk = rng.choice([-3.0, -0.0, 0.0, 2.5], (width, m)) * rng.uniform(0.5, 2.0, (width, m))
    ova = np.where(rng.random((width, m)) < 0.2, rng.uniform(-4.0, 4.0, (width, m)), np.nan)
    ovv = np.where(rng.random((width, m)) < 0.1, rng.uniform(-4.0, 4.0, (width, m)), np.nan)
    p0, v0, a0 = (rng.uniform(-5.0, 5.0, m) for _ in range(3))
    p0[:3] = -0.0  # signed zeros must survive phases of no duration
    return p0, v0, a0, dur, jerk, ova, ovv


def _reference(tab: tuple[np.ndarray, ...]) -> tuple[list[np.ndarray], np.ndarray, np.ndarray]:
    p0, v0, a0, dur, jerk, ova, ovv = tab
    *segs, pe, ve, ae, te, cnt = _integrate_arrays(p0, v0, a0, dur, jerk, ova, ovv)
    m, w = segs[0].shape
    if w < MIN_WIDTH:
        pad = MIN_WIDTH - w
        fill = (te, None, None, pe, ve, ae)
        segs = [
            np.hstack([x, np.zeros((m, pad)) if f is None else np.repeat(f[:, None], pad, 1)])
            for x, f in zip(segs, fill, strict=True)
        ]
    return segs, np.array([pe, ve, ae, te]), cnt


def _same(a: np.ndarray, b: np.ndarray) -> bool:
    return a.shape == b.shape and bool(np.all((a == b) & (np.signbit(a) == np.signbit(b))))


@pytest.mark.parametrize("gaps", [False, True], ids=["core-layout", "gaps"])
@pytest.mark.parametrize("width", [1, 5, 9, 12])
def test_integrate_rows_equals_integrate_arrays(width: int, gaps: bool) -> None:
    rng = np.random.default_rng(1000 * width + gaps)
    tab = _table(rng, 500, width, gaps)
    segs, e3, te, cnt, kinds = _integrate_rows(*tab, ["k"] * 500)
    ref, ends, ref_cnt = _reference(tab)
    assert kinds == ["k"] * 500
    assert (cnt == ref_cnt).all()
    for q, (x, y) in enumerate(zip(segs, ref, strict=True)):
        assert _same(np.asarray(x), y), q
    assert _same(e3, ends[:3]) and _same(te, ends[3])


def test_integrate_rows_equals_profile() -> None:
    """Each row's segments are those of the Profile built from the row's phases."""
    rng = np.random.default_rng(77)
    tab = _table(rng, 60, 6, False)
    p0, v0, a0, dur, jerk, ova, ovv = tab
    segs, e3, te, cnt, _ = _integrate_rows(*tab, ["k"] * 60)
    checked = 0
    for k in range(60):
        phases = []
        for c in range(dur.shape[0]):
            ph: tuple[float, ...] = (float(dur[c, k]), float(jerk[c, k]))
            if not np.isnan(ova[c, k]) or not np.isnan(ovv[c, k]):
                if np.isnan(ovv[c, k]):
                    ph += (float(ova[c, k]),)
                elif not np.isnan(ova[c, k]):
                    ph += (float(ova[c, k]), float(ovv[c, k]))
                else:
                    continue  # a velocity without an acceleration has no tuple form
            phases.append(ph)
        if len(phases) != dur.shape[0]:
            continue
        prof = Profile(State(float(p0[k]), float(v0[k]), float(a0[k])), phases)
        n = int(cnt[k])
        assert list(segs[0][k, :n]) == list(prof._t[:n])
        assert list(segs[3][k, :n]) == list(prof._p[:n])
        assert list(segs[4][k, :n]) == list(prof._v[:n])
        assert list(segs[5][k, :n]) == list(prof._a[:n])
        assert prof.duration == te[k]
        assert (prof.end.p, prof.end.v, prof.end.a) == tuple(e3[:, k])
        checked += 1
    assert checked >= 20, checked
