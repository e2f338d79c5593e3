"""Tracking a moving target (issue 3, rule 5; seed 003's telescope use case).

Targets: constant velocity, constant acceleration and a sine; both variants of seed 003
("replan": plan toward the target's state one cycle ahead, every cycle; "predict": plan to
meet the target's future state, solving for the meeting time); without latency and with a
measurement 3 cycles old, compensated (extrapolated) or not.

Figures measured with the scenarios below (motionplc at commit 8e68d90; the bounds asserted
leave a margin and say so):

* predict, constant velocity / acceleration: meets the target at the meeting time T* (1.4208 /
  1.2890 s, computed here independently) and the error stays <= 1e-15 afterwards (asserted
  <= 1e-9); with compensated latency the same, from T* + 3 cycles; uncompensated, the
  commanded motion follows the *delayed* target exactly: error = -(v L - a L^2 / 2), L = 3 dt.
* replan, constant velocity: does not converge to 1e-9. The error decays roughly like 1/t (a plan
  aims at the target's current state, so it catches up only by ~j (e/v)^2 / 4 per unit
  time): 1.2e-2 in the 6th second; constant acceleration: a steady lag of 1.6e-2.
  Compensated latency gives the same error (to 1e-14); uncompensated adds the lag v L.
* sine (0.5 sin(2 pi 0.2 t), dt = 10 ms), after 2 s: predict 3.8e-3, predict with compensated
  latency 1.5e-3, uncompensated 2.3e-2; replan 1.5e-2, 1.5e-2, 3.4e-2.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from functools import cache

import numpy as np
import pytest

from motionplc.planning import Limits, PlanningError, State, Tracker, plan, track

LIM = Limits(v_max=2.0, a_max=4.0, j_max=20.0)
LATENCY = 3  # cycles
SINE_AMPLITUDE = 0.5
SINE_OMEGA = 2.0 * math.pi * 0.2


def const_v(t: float) -> State:
    return State(1.0 + 0.5 * t, 0.5, 0.0)


def const_a(t: float) -> State:
    return State(1.0 + 0.2 * t + 0.05 * t * t, 0.2 + 0.1 * t, 0.1)


def sine(t: float) -> State:
    a, w = SINE_AMPLITUDE, SINE_OMEGA
    return State(a * math.sin(w * t), a * w * math.cos(w * t), -a * w * w * math.sin(w * t))


# name -> (target, dt, seconds simulated)
SCENARIOS: dict[str, tuple[Callable[[float], State], float, float]] = {
    "const-v": (const_v, 0.001, 6.0),
    "const-a": (const_a, 0.001, 6.0),
    "sine": (sine, 0.01, 4.0),  # predict re-plans every cycle here: ~5 ms per cycle
}
VARIANTS = [(0, True), (LATENCY, True), (LATENCY, False)]
VARIANT_IDS = ["no-latency", "latency-compensated", "latency-uncompensated"]


@dataclass(frozen=True)
class Run:
    t: np.ndarray
    p: np.ndarray
    v: np.ndarray
    a: np.ndarray
    error: np.ndarray
    dt: float
    replans: int


@cache
def run(name: str, mode: str, latency: int, compensate: bool) -> Run:
    target, dt, seconds = SCENARIOS[name]
    trk = Tracker(LIM, dt, mode=mode, latency=latency, compensate=compensate)
    out = track(trk, target, seconds)
    return Run(out["t"], out["p"], out["v"], out["a"], out["error"], dt, trk.replans)


def meeting_time(target: Callable[[float], State]) -> float:
    """Smallest T with duration(plan(rest at 0 -> target(T))) <= T (scan, then bisection)."""

    def g(t: float) -> float:
        return plan(State(), target(t), LIM).duration - t

    lo, hi = 0.0, 0.01
    while g(hi) > 0.0:
        lo, hi = hi, hi + 0.01
    for _ in range(100):
        mid = 0.5 * (lo + hi)
        if g(mid) > 0.0:
            lo = mid
        else:
            hi = mid
    return hi


def converged_after(r: Run, bound: float) -> float:
    """Time after which |error| stays <= bound (inf if it is above at the end)."""
    above = np.nonzero(np.abs(r.error) > bound)[0]
    if above.size == 0:
        return 0.0
    if above[-1] == r.error.size - 1:
        return math.inf
    return float(r.t[above[-1]])


def window(r: Run, t0: float, t1: float = math.inf) -> np.ndarray:
    return np.abs(r.error[(r.t > t0) & (r.t <= t1)])


def lag(name: str, r: Run, latency: int) -> np.ndarray:
    """How far the target moves in ``latency`` cycles: v L - a L^2 / 2 (exact for a constant
    acceleration)."""
    target = SCENARIOS[name][0]
    L = latency * r.dt
    return np.array([target(t).v * L - 0.5 * target(t).a * L * L for t in r.t])


# -- every run: a jerk-limited command inside the limits ---------------------------------------
@pytest.mark.parametrize("name", list(SCENARIOS))
@pytest.mark.parametrize("mode", ["predict", "replan"])
@pytest.mark.parametrize(("latency", "compensate"), VARIANTS, ids=VARIANT_IDS)
def test_command_is_jerk_limited(name: str, mode: str, latency: int, compensate: bool) -> None:
    r = run(name, mode, latency, compensate)
    da = np.abs(np.diff(np.r_[0.0, r.a]))
    assert da.max() <= LIM.j_max * r.dt * (1 + 1e-9) + 1e-12
    assert np.abs(r.a).max() <= LIM.a_max + 1e-9
    assert np.abs(r.v).max() <= LIM.v_max + 1e-9
    assert np.all(np.isfinite(r.p))


# -- prediction (variant 2) ---------------------------------------------------------------------
@pytest.mark.parametrize("name", ["const-v", "const-a"])
@pytest.mark.parametrize(("latency", "compensate"), VARIANTS[:2], ids=VARIANT_IDS[:2])
def test_predict_meets_polynomial_target_exactly(name: str, latency: int, compensate: bool) -> None:
    """After the meeting time the error stays <= 1e-9 (measured: <= 2e-15)."""
    r = run(name, "predict", latency, compensate)
    t_meet = meeting_time(SCENARIOS[name][0])
    assert t_meet == pytest.approx({"const-v": 1.4208333, "const-a": 1.2889679}[name], abs=1e-6)
    assert converged_after(r, 1e-9) <= t_meet + (latency + 1) * r.dt
    assert window(r, t_meet + (latency + 1) * r.dt).max() <= 1e-9
    assert window(r, 2.0).max() <= 1e-13
    # one meeting plan; with latency, the first cycles see target(0) extrapolated, which
    # disagrees with the later measurements until they are 3 cycles old
    assert r.replans <= latency + 1


@pytest.mark.parametrize("name", ["const-v", "const-a"])
def test_predict_with_uncompensated_latency_lags_by_v_times_latency(name: str) -> None:
    """Treating the 3-cycle-old measurement as current, the command follows the delayed
    target exactly: error = -(v L - a L^2 / 2), L = 3 dt (1.5e-3 for v = 0.5)."""
    r = run(name, "predict", LATENCY, False)
    t_meet = meeting_time(SCENARIOS[name][0])
    after = r.t > t_meet + (LATENCY + 1) * r.dt
    expected = -lag(name, r, LATENCY)
    assert np.abs(r.error[after] - expected[after]).max() <= 1e-9
    if name == "const-v":
        assert r.error[-1] == pytest.approx(-0.5 * LATENCY * r.dt, abs=1e-12)


def test_predict_sine_error_bound() -> None:
    """A sine's acceleration changes, so the prediction is never exact and every cycle
    re-plans. Measured after 2 s: 3.8e-3 (no latency), 1.5e-3 (compensated), 2.3e-2
    (uncompensated): asserted with a 30 % margin."""
    for (latency, compensate), bound in zip(VARIANTS, (5e-3, 2e-3, 3e-2), strict=True):
        r = run("sine", "predict", latency, compensate)
        assert window(r, 2.0).max() <= bound, (latency, compensate)
        assert r.replans == r.t.size  # never consistent with the prediction
    no_lat = window(run("sine", "predict", 0, True), 2.0).max()
    uncomp = window(run("sine", "predict", LATENCY, False), 2.0).max()
    assert uncomp > 3.0 * no_lat  # the delay costs accuracy unless compensated


# -- re-planning every cycle (variant 1) --------------------------------------------------------
def test_replan_const_velocity_converges_slowly() -> None:
    """Measured |error|: 4.4e-2 (3rd second), 2.3e-2, 1.6e-2, 1.2e-2 (6th): decaying like 1/t,
    never near 1e-9 within the run. Asserted: the per-second maxima decrease and the bounds
    below (~10 % margin)."""
    r = run("const-v", "replan", 0, True)
    per_second = [window(r, float(k), k + 1.0).max() for k in range(2, 6)]
    assert all(b < a for a, b in zip(per_second, per_second[1:], strict=False))
    assert per_second[-1] <= 1.35e-2
    assert converged_after(r, 5e-2) <= 2.1  # measured: 1.88 s
    assert math.isinf(converged_after(r, 1e-6))
    # roughly like 1/t: halving from 3 s to 6 s (measured: 2.46e-2 -> 9.8e-3, ratio 2.5)
    e3, e6 = window(r, 2.9, 3.0).max(), window(r, 5.9, 6.0).max()
    assert 1.5 < e3 / e6 < 3.0


def test_replan_const_acceleration_keeps_a_lag() -> None:
    """Measured: |error| 1.6e-2 in the 5th and 6th second (not decaying)."""
    r = run("const-a", "replan", 0, True)
    assert window(r, 4.0).max() <= 1.75e-2
    assert window(r, 4.0).min() >= 1.4e-2


@pytest.mark.parametrize("name", ["const-v", "const-a"])
def test_replan_latency(name: str) -> None:
    """Compensated latency: the same error as without (polynomial targets extrapolate
    exactly; measured difference <= 7e-15). Uncompensated: about v L more (measured within
    2.3e-6 / 1.9e-5 of the lag L v - a L^2/2 = 1.5e-3 / 2.4e-3; asserted within 2 %)."""
    r0 = run(name, "replan", 0, True)
    rc = run(name, "replan", LATENCY, True)
    ru = run(name, "replan", LATENCY, False)
    last = r0.t > 5.0
    assert np.abs(rc.error - r0.error)[last].max() <= 1e-12
    lag_ = lag(name, ru, LATENCY)
    assert np.abs(ru.error - rc.error + lag_)[last].max() <= 0.02 * lag_[last].min()


def test_replan_sine_error_bound() -> None:
    """Measured after 2 s: 1.5e-2 (no latency, compensated), 3.4e-2 (uncompensated)."""
    for (latency, compensate), bound in zip(VARIANTS, (2e-2, 2e-2, 4.5e-2), strict=True):
        r = run("sine", "replan", latency, compensate)
        assert window(r, 2.0).max() <= bound, (latency, compensate)
        assert r.replans == r.t.size


def test_predict_beats_replan_for_polynomial_targets() -> None:
    for name in ("const-v", "const-a"):
        assert window(run(name, "predict", 0, True), 3.0).max() < 1e-12
        assert window(run(name, "replan", 0, True), 3.0).min() > 1e-3


# -- input checks --------------------------------------------------------------------------------
@pytest.mark.parametrize(
    ("kwargs", "field"),
    [
        ({"mode": "guess"}, "mode"),
        ({"latency": -1}, "latency"),
        ({"latency": 1.5}, "latency"),
        ({"latency": True}, "latency"),
        ({"dt": 0.0}, "dt"),
    ],
)
def test_tracker_rejects_bad_input(kwargs: dict[str, object], field: str) -> None:
    args: dict[str, object] = {"limits": LIM, "dt": 0.001}
    args.update(kwargs)
    with pytest.raises(PlanningError, match=field):
        Tracker(**args)  # type: ignore[arg-type]
