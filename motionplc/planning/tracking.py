"""Following a moving target (seed 003: a telescope mount tracking an object).

The target is measured every cycle as a kinematic state (position, velocity, acceleration);
a measurement may be ``latency`` cycles old. Between measurements the target is predicted
with constant acceleration. Two strategies, both from seed 003:

* ``"replan"`` (variant 1): every cycle plan from the commanded state toward the target's
  predicted state at the end of the cycle and take the first cycle of that plan. Simple and
  robust to targets whose acceleration changes, but it converges with the "dip" and ripple the
  seed reports.
* ``"predict"`` (variant 2): plan to *meet* the target: find the meeting time T with
  duration(plan(state -> target(T))) = T (a safeguarded secant search on T, exact to 1e-10 s,
  then a profile of exactly that duration), execute it, and re-plan only when a measurement
  disagrees with the prediction. After the meeting the commanded state follows a
  constant-acceleration target exactly (error at rounding level).

Latency: with ``compensate=True`` (default) the tracker extrapolates the measurement over the
``latency`` cycles; with ``compensate=False`` it treats the old measurement as current, which
shows the tracking error the delay causes.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from motionplc.errors import PlanningError
from motionplc.planning.limits import Limits
from motionplc.planning.plan import _check_state, plan
from motionplc.planning.profile import Profile, Sample
from motionplc.planning.state import State
from motionplc.planning.sync import check_dt, plan_fixed_duration


def _extrapolate(s: State, tau: float) -> State:
    return State(s.p + tau * (s.v + 0.5 * tau * s.a), s.v + tau * s.a, s.a)


class Tracker:
    """Cyclic tracker of a moving target for one axis."""

    def __init__(
        self,
        limits: Limits,
        dt: float,
        start: State | None = None,
        *,
        mode: str = "predict",
        latency: int = 0,
        compensate: bool = True,
    ) -> None:
        if not isinstance(limits, Limits):
            raise PlanningError(f"limits must be a Limits(...), got {type(limits).__name__}")
        dt = check_dt(dt)
        if start is not None:
            _check_state("start", start)
        if mode not in ("predict", "replan"):
            raise PlanningError(f"mode must be 'predict' or 'replan', got {mode!r}")
        if isinstance(latency, bool) or not isinstance(latency, int) or latency < 0:
            raise PlanningError(f"latency must be a whole number of cycles >= 0, got {latency!r}")
        self.limits = limits
        self.dt = float(dt)
        self.mode = mode
        self.latency = latency
        self.compensate = compensate
        self._state = State() if start is None else start
        self._plan: Profile | None = None
        self._plan_t = 0.0
        self._prediction: State | None = None  # target predicted for the current cycle
        self.replans = 0
        self.meeting_time: float | None = None  # of the last meeting plan

    @property
    def state(self) -> State:
        """Commanded state after the last update."""
        return self._state

    def update(self, measurement: State) -> Sample:
        """One cycle: ``measurement`` is the target's state ``latency`` cycles ago.
        Returns the setpoint for the end of this cycle."""
        dt = self.dt
        lag = self.latency * dt if self.compensate else 0.0
        now = _extrapolate(measurement, lag)  # the target now (as far as we know)
        if self.mode == "replan":
            self._plan = plan(self._state, _extrapolate(now, dt), self.limits)
            self._plan_t = 0.0
            self.replans += 1
        else:
            pred = self._prediction
            consistent = (
                pred is not None
                and self._plan is not None
                and abs(pred.p - now.p) <= 1e-9 * max(1.0, abs(now.p))
                and abs(pred.v - now.v) <= 1e-9 * max(1.0, abs(now.v))
                and abs(pred.a - now.a) <= 1e-9 * max(1.0, abs(now.a))
            )
            if not consistent:
                self._plan = self._meeting_plan(now)
                self._plan_t = 0.0
                self.replans += 1
            elif self._plan_t + dt > self._plan.duration + 1e-12:  # type: ignore[union-attr]
                # met: follow the predicted target over the next cycle
                self._plan = plan(self._state, _extrapolate(now, dt), self.limits)
                self._plan_t = 0.0
            self._prediction = _extrapolate(now, dt)
        self._plan_t += dt
        s = self._plan.at(self._plan_t)  # type: ignore[union-attr]
        self._state = State(s.p, s.v, s.a)
        return s

    def _meeting_plan(self, target: State) -> Profile:
        """Plan that ends on the predicted target exactly at the meeting time."""
        start = self._state
        lim = self.limits

        def duration(T: float) -> float:
            return plan(start, _extrapolate(target, T), lim).duration

        g0 = duration(0.0)
        if g0 <= 1e-12:
            return plan(start, _extrapolate(target, self.dt), lim)
        lo, glo = 0.0, g0
        hi = max(g0, self.dt)
        ghi = duration(hi) - hi
        k = 0
        while ghi > 0.0:
            lo, glo = hi, ghi
            hi *= 2.0
            k += 1
            if k > 40:
                raise PlanningError("the target escapes: it cannot be met within the limits")
            ghi = duration(hi) - hi
        side = 0
        T = hi
        for _ in range(100):
            T = (lo * ghi - hi * glo) / (ghi - glo)
            if not lo < T < hi:
                T = 0.5 * (lo + hi)
            gT = duration(T) - T
            if abs(gT) <= 1e-10 or hi - lo <= 1e-12:
                break
            if gT > 0.0:
                lo, glo = T, gT
                if side == 1:
                    ghi *= 0.5
                side = 1
            else:
                hi, ghi = T, gT
                if side == -1:
                    glo *= 0.5
                side = -1
        T = max(T, hi if duration(T) > T + 1e-9 else T)
        self.meeting_time = T
        fixed = plan_fixed_duration(start, _extrapolate(target, T), lim, T)
        if fixed is not None:
            return fixed
        return plan(start, _extrapolate(target, T), lim)


def track(
    tracker: Tracker, target: Callable[[float], State], seconds: float
) -> dict[str, np.ndarray]:
    """Run ``tracker`` against ``target(t)`` for ``seconds`` (simulated, no clock reads).

    Returns arrays ``t``, ``p``, ``v``, ``a`` (commanded), ``target_p``, ``target_v`` and
    ``error`` (commanded minus true target position) at the end of each cycle.
    """
    dt = tracker.dt
    n = int(math.ceil(seconds / dt - 1e-9))
    out = {k: np.empty(n) for k in ("t", "p", "v", "a", "target_p", "target_v", "error")}
    for k in range(n):
        t = k * dt
        meas = target(max(t - tracker.latency * dt, 0.0))
        s = tracker.update(meas)
        truth = target(t + dt)
        out["t"][k] = t + dt
        out["p"][k] = s.p
        out["v"][k] = s.v
        out["a"][k] = s.a
        out["target_p"][k] = truth.p
        out["target_v"][k] = truth.v
        out["error"][k] = s.p - truth.p
    return out
