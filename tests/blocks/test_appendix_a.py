"""Spec Appendix A timing examples (Fig. 56-63), trapezoidal profiles (no Jerk input).

Pinned timing: Busy rises in the scan of Execute's rising edge; Active (and the previous FB's
CommandAborted) one scan later, when the kernel has started the motion; Done of block n and
Active of block n+1 rise in the same scan; a Done after a one-scan Execute pulse lasts exactly
one scan. Expected durations are computed by hand from the example parameters.
"""

from __future__ import annotations

import numpy as np
import pytest

from motionplc.blocks import BufferMode, MC_MoveAbsolute
from motionplc.blocks.axis import planner_calls
from tests.runtime.helpers import Bench

B = BufferMode
DT = 0.001
FB1 = dict(position=1000.0, velocity=100.0, acceleration=100.0, deceleration=100.0)


def rise(b: Bench, fb, out: str) -> list[int]:
    return [c for c, v in b.edges(fb, out) if v]


def fall(b: Bench, fb, out: str) -> list[int]:
    return [c for c, v in b.edges(fb, out) if not v]


def v_at(b: Bench, position: float) -> float:
    """Set velocity where the set position crosses ``position`` (linear interpolation)."""
    p = b.col("x.position")
    v = b.col("x.velocity")
    i = int(np.searchsorted(p, position))
    w = (position - p[i - 1]) / (p[i] - p[i - 1])
    return float(v[i - 1] + w * (v[i] - v[i - 1]))


def near(cycle: int, expected_seconds: float) -> bool:
    return abs(cycle - round(expected_seconds / DT)) <= 1


def check_monotonic(b: Bench) -> None:
    p = b.col("x.position")
    assert (np.diff(p) >= -1e-9).all()
    assert (b.col("x.velocity") >= -1e-9).all()


def scenario(
    mode2, fb2: dict, mode3=None, fb3: dict | None = None, t2: float = 2.0, t3: float = 14.0
):
    b = Bench(v_max=200.0, a_max=400.0).powered()
    m1, m2, m3 = b.add(
        MC_MoveAbsolute(**FB1), MC_MoveAbsolute(**fb2, buffer_mode=mode2), MC_MoveAbsolute()
    )
    if fb3 is not None:
        m3.position, m3.velocity, m3.acceleration, m3.deceleration = (
            fb3["position"],
            fb3["velocity"],
            fb3["acceleration"],
            fb3["deceleration"],
        )
        m3.buffer_mode = mode3
    c1 = b.pulse(m1)
    b.run(round(t2 / DT) - 1)
    c2 = b.pulse(m2)
    c3 = None
    if fb3 is not None:
        b.run(round((t3 - t2) / DT) - 1)
        c3 = b.pulse(m3)
    b.run_until_idle()
    b.run(5)
    check_monotonic(b)
    return b, (m1, m2, m3), (c1, c2, c3)


def check_chain(b: Bench, fbs, starts) -> None:
    """Common output rules of the buffered/blending examples."""
    for fb, c in zip(fbs, starts, strict=True):
        if c is None:
            continue
        assert rise(b, fb, "busy") == [c]
        assert rise(b, fb, "command_aborted") == []
        [d] = rise(b, fb, "done")
        assert fall(b, fb, "done") == [d + 1]  # one-cycle pulse (Execute already low)
        assert fall(b, fb, "busy") == [d]
        assert fall(b, fb, "active") == [d]
    m1 = fbs[0]
    assert rise(b, m1, "active") == [starts[0] + 1]
    for a, nxt, c in zip(fbs, fbs[1:], starts[1:], strict=False):
        if c is None:
            continue
        assert rise(b, nxt, "active") == rise(b, a, "done")  # same cycle


def test_example_1_standard() -> None:
    b = Bench(v_max=200.0, a_max=400.0).powered()
    m1, m2 = b.add(
        MC_MoveAbsolute(**FB1),
        MC_MoveAbsolute(position=2000.0, velocity=50.0, acceleration=100.0, deceleration=100.0),
    )
    c1 = b.pulse(m1)
    b.run_until_idle()
    [d1] = rise(b, m1, "done")
    assert near(d1 - c1, 11.0)
    assert fall(b, m1, "done") == [d1 + 1]
    assert b.x.p == 1000.0 and b.x.v == 0.0
    c2 = b.pulse(m2)
    b.run_until_idle()
    b.run(3)
    [d2] = rise(b, m2, "done")
    assert near(d2 - c2, 0.5 + 19.5 + 0.5)  # trapezoid 1000 u at V 50, A = D = 100
    assert rise(b, m1, "command_aborted") == rise(b, m2, "command_aborted") == []
    assert b.x.p == 2000.0
    check_monotonic(b)


def test_example_2_aborting() -> None:
    fb2 = dict(position=2000.0, velocity=50.0, acceleration=200.0, deceleration=200.0)
    b, (m1, m2, _), (c1, c2, _) = scenario(B.ABORTING, fb2, t2=1.0)
    assert rise(b, m1, "command_aborted") == [c2 + 1]
    assert fall(b, m1, "command_aborted") == [c2 + 2]  # one cycle: Start_1 is already low
    assert fall(b, m1, "busy") == fall(b, m1, "active") == [c2 + 1]
    assert rise(b, m2, "busy") == [c2] and rise(b, m2, "active") == [c2 + 1]
    assert rise(b, m1, "done") == []
    v = b.col("x.velocity")
    assert v[c2 - 1] == pytest.approx(100.0)
    assert v.max() <= 100.0 + 1e-9
    # 100 -> 50 with D = 200 takes 0.25 s, then cruise at 50
    assert v[c2 + 250] == pytest.approx(50.0, abs=1e-9)
    assert v[c2 + 240] > 50.0
    [d2] = rise(b, m2, "done")
    # after the abort: 0.25 s braking (18.75 u), 0.25 s final braking (6.25 u), cruise at 50
    rest = 2000.0 - 50.0 - 18.75 - 6.25
    assert near(d2 - c2, 0.5 + rest / 50.0)
    assert b.x.p == 2000.0


def test_example_3_buffered() -> None:
    fb2 = dict(position=2000.0, velocity=50.0, acceleration=200.0, deceleration=200.0)
    b, fbs, (c1, c2, _) = scenario(B.BUFFERED, fb2)
    check_chain(b, fbs[:2], (c1, c2))
    [d1] = rise(b, fbs[0], "done")
    assert near(d1 - c1, 11.0)
    v = b.col("x.velocity")
    p = b.col("x.position")
    # the velocity reaches 0 at 1000 and FB2 starts without delay
    k = int(np.searchsorted(p, 1000.0))
    assert p[k] == pytest.approx(1000.0, abs=1e-9) and v[k] == pytest.approx(0.0, abs=1e-6)
    assert v[k + 1] > 0.0
    assert fbs[0].end_velocity == 0.0
    [d2] = rise(b, fbs[1], "done")
    assert near(d2 - d1, 0.25 + 19.75 + 0.25)


BLEND = {
    # mode: (FB2 dynamics, junction velocities, durations T1, T2, T3) - see the module doc
    B.BLENDING_LOW: ((50.0, 50.0), (50.0, 50.0), (10.625, 20.0, 10.625)),
    B.BLENDING_PREVIOUS: ((200.0, 200.0), (100.0, 50.0), (10.5, 19.875, 10.625)),
    B.BLENDING_NEXT: ((50.0, 50.0), (50.0, 100.0), (10.625, 19.5, 10.5)),
    B.BLENDING_HIGH: ((200.0, 200.0), (100.0, 100.0), (10.5, 19.75, 10.5)),
}


@pytest.mark.parametrize("mode", list(BLEND), ids=lambda m: m.name)
def test_examples_4_to_7_blending(mode: BufferMode) -> None:
    (acc2, dec2), (vj1, vj2), (t1, t2, t3) = BLEND[mode]
    fb2 = dict(position=2000.0, velocity=50.0, acceleration=acc2, deceleration=dec2)
    fb3 = dict(position=3000.0, velocity=100.0, acceleration=100.0, deceleration=100.0)
    b, fbs, starts = scenario(mode, fb2, mode, fb3)
    m1, m2, m3 = fbs
    check_chain(b, fbs, starts)
    assert m1.end_velocity == pytest.approx(vj1, abs=1e-9)
    assert m2.end_velocity == pytest.approx(vj2, abs=1e-9)
    assert m3.end_velocity == 0.0
    assert v_at(b, 1000.0) == pytest.approx(vj1, abs=0.2)  # within a_max * dt of sampling
    assert v_at(b, 2000.0) == pytest.approx(vj2, abs=0.2)
    [d1] = rise(b, m1, "done")
    [d2] = rise(b, m2, "done")
    [d3] = rise(b, m3, "done")
    c1 = starts[0]
    assert near(d1 - c1, t1)
    assert near(d2 - d1, t2)
    assert near(d3 - d2, t3)
    assert b.x.p == 3000.0
    v = b.col("x.velocity")
    p = b.col("x.position")
    # velocity changes happen inside the FB that is active: FB1 reaches vj1 exactly at 1000
    k1 = int(np.searchsorted(p, 1000.0))
    assert abs(v[k1 - 1] - vj1) <= 0.11 and abs(v[k1] - vj1) <= 0.11
    if mode is B.BLENDING_NEXT:  # FB2 exceeds its own Velocity before 2000
        k2 = int(np.searchsorted(p, 1990.0))
        assert v[k2] > 55.0
    if mode is B.BLENDING_LOW:  # FB1 decelerates (100 -> 50, D = 100) from 962.5 to 1000
        assert v[int(np.searchsorted(p, 960.0))] == pytest.approx(100.0)
        assert v[int(np.searchsorted(p, 990.0))] == pytest.approx((2500 + 2000) ** 0.5, abs=0.2)


def test_blending_junction_not_reachable_uses_highest_reachable() -> None:
    """FB2 too short to brake from the requested junction velocity (CODESYS rule)."""
    fb2 = dict(position=1010.0, velocity=100.0, acceleration=100.0, deceleration=100.0)
    b, (m1, m2, _), _ = scenario(B.BLENDING_HIGH, fb2)
    # FB2 can stop within 10 u from sqrt(2 * 100 * 10) = 44.72 u/s
    assert m1.end_velocity == pytest.approx((2 * 100.0 * 10.0) ** 0.5, rel=1e-6)
    assert b.x.p == 1010.0
    assert b.col("x.position").max() <= 1010.0 + 1e-9


@pytest.mark.parametrize("j_max", [float("inf"), 1000.0])
def test_unreachable_junction_is_capped_without_a_search(j_max: float) -> None:
    """The successor's stopping distance caps the junction speed in closed form: queueing it
    re-plans the running move once (not a bisection of ~30 plans in one cycle)."""
    b = Bench(v_max=200.0, a_max=400.0, j_max=j_max).powered()
    fb2 = dict(position=1010.0, velocity=100.0, acceleration=100.0, deceleration=100.0)
    m1, m2 = b.add(MC_MoveAbsolute(**FB1), MC_MoveAbsolute(**fb2, buffer_mode=B.BLENDING_HIGH))
    b.pulse(m1)
    b.run(1000)
    n0 = planner_calls()
    b.pulse(m2)
    assert planner_calls() - n0 == 1
    b.run_until_idle()
    # stopping within 10 u: sqrt(2 a d) without a jerk limit; with one, v^2 + (a^2/j) v = 2 a d
    vj = (
        (2 * 100.0 * 10.0) ** 0.5
        if j_max == float("inf")
        else 0.5 * ((10.0**2 + 8000.0) ** 0.5 - 10.0)
    )
    assert m1.end_velocity == pytest.approx(vj, rel=1e-12)
    assert b.x.p == 1010.0 and b.col("x.position").max() <= 1010.0 + 1e-9


def test_blending_into_opposite_direction_gives_zero_junction() -> None:
    fb2 = dict(position=500.0, velocity=100.0, acceleration=100.0, deceleration=100.0)
    b = Bench(v_max=200.0, a_max=400.0).powered()
    m1, m2 = b.add(MC_MoveAbsolute(**FB1), MC_MoveAbsolute(**fb2, buffer_mode=B.BLENDING_HIGH))
    b.pulse(m1)
    b.run(1000)
    b.pulse(m2)
    b.run_until_idle()
    assert m1.end_velocity == 0.0
    p = b.col("x.position")
    assert p.max() == pytest.approx(1000.0, abs=1e-9) and b.x.p == 500.0


@pytest.mark.parametrize("mode", list(BLEND), ids=lambda m: m.name)
def test_blending_jerk_limited(mode: BufferMode) -> None:
    """Same examples with j_max = 1000: junction velocities unchanged, acceleration continuous
    (checked every cycle by the invariants), monotonic motion."""
    (acc2, dec2), (vj1, vj2), _ = BLEND[mode]
    b = Bench(v_max=200.0, a_max=400.0, j_max=1000.0).powered()
    m1, m2, m3 = b.add(
        MC_MoveAbsolute(**FB1),
        MC_MoveAbsolute(
            position=2000.0, velocity=50.0, acceleration=acc2, deceleration=dec2, buffer_mode=mode
        ),
        MC_MoveAbsolute(
            position=3000.0,
            velocity=100.0,
            acceleration=100.0,
            deceleration=100.0,
            buffer_mode=mode,
        ),
    )
    b.pulse(m1)
    b.run(1999)
    b.pulse(m2)
    b.run(11999)
    b.pulse(m3)
    b.run_until_idle()
    check_monotonic(b)
    assert (m1.end_velocity, m2.end_velocity) == pytest.approx((vj1, vj2), abs=1e-9)
    assert v_at(b, 1000.0) == pytest.approx(vj1, abs=0.1)
    assert v_at(b, 2000.0) == pytest.approx(vj2, abs=0.1)
    assert rise(b, m2, "active") == rise(b, m1, "done")
    assert rise(b, m3, "active") == rise(b, m2, "done")
    assert b.x.p == 3000.0


def test_late_blending_command_is_best_effort_without_overshoot() -> None:
    """FB2 arrives while FB1 already brakes to 0: the junction velocity is what can still be
    reached at 1000 without reversal or overshoot."""
    b = Bench(v_max=200.0, a_max=400.0).powered()
    m1, m2 = b.add(
        MC_MoveAbsolute(**FB1),
        MC_MoveAbsolute(position=2000.0, velocity=100.0, buffer_mode=B.BLENDING_HIGH),
    )
    b.pulse(m1)
    b.run(10_600)  # FB1 brakes from t = 10 s; at 10.6 s v = 40 with 8 u to go
    v_now = b.x.v
    b.pulse(m2)
    b.run_until_idle()
    check_monotonic(b)
    assert 0.0 < m1.end_velocity < 100.0
    # cannot be faster than accelerating from v_now over the remaining distance... nor reverse
    assert m1.end_velocity <= (v_now**2 + 2 * 100.0 * 8.0) ** 0.5 + 1e-6
    assert b.x.p == 2000.0
