"""Kinematic limits of one axis, validated on construction."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Final

from motionplc.errors import PlanningError

_INF = math.inf

# The supported input envelope of the planner (SI units). A finite limit is in
# [LIMIT_MIN, LIMIT_MAX] (or infinite: no limit), a state value (position, velocity,
# acceleration, target velocity) is within +-STATE_MAX. Inside it the solver's arithmetic stays
# far from overflow and underflow (measured: every combination of limits at 1e-15, 1 and 1e15
# and of states at 0, +-1e-12, +-1 and +-1e12 plans or raises PlanningError, see
# tests/planning/test_degenerate_inputs.py); profiles longer than the supported durations
# (``plan.MAX_DURATION`` for one axis, ``sync.MAX_SYNC_DURATION`` synchronised) are rejected.
LIMIT_MIN: Final = 1e-15
LIMIT_MAX: Final = 1e15
STATE_MAX: Final = 1e12
_RANGE = f"[{LIMIT_MIN:g}, {LIMIT_MAX:g}] or inf (the supported part of (0, inf])"
_NEG_RANGE = f"[{-LIMIT_MAX:g}, {-LIMIT_MIN:g}] or -inf (the supported part of [-inf, 0))"


def _check_positive(name: str, value: float) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise PlanningError(f"Limits.{name} must be a number in {_RANGE}, got {value!r}")
    value = float(value)
    if value != _INF and not LIMIT_MIN <= value <= LIMIT_MAX:
        raise PlanningError(f"Limits.{name} must be in {_RANGE}, got {value!r}")
    return value


def _check_negative(name: str, value: float) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise PlanningError(f"Limits.{name} must be a number in {_NEG_RANGE}, got {value!r}")
    value = float(value)
    if value != -_INF and not -LIMIT_MAX <= value <= -LIMIT_MIN:
        raise PlanningError(f"Limits.{name} must be in {_NEG_RANGE}, got {value!r}")
    return value


@dataclass(frozen=True, slots=True)
class Limits:
    """Velocity, acceleration and jerk limits (SI units; ``math.inf`` = no limit).

    ``v_min`` and ``a_min`` default to ``-v_max`` and ``-a_max``. The jerk limit is symmetric.
    A finite limit must lie in [``LIMIT_MIN``, ``LIMIT_MAX``] = [1e-15, 1e15] (minima: the
    negated range); anything else (NaN, 0, a sign error, 1e-300, 1e300) raises
    :class:`PlanningError` naming the field and the range.
    An infinite ``j_max`` gives second-order (trapezoidal velocity) profiles, an infinite
    ``a_max`` with infinite ``j_max`` first-order ones. At least one of ``v_max``, ``a_max``,
    ``j_max`` must be finite for a position move.
    """

    v_max: float = _INF
    a_max: float = _INF
    j_max: float = _INF
    v_min: float | None = None
    a_min: float | None = None

    def __post_init__(self) -> None:
        v_max = _check_positive("v_max", self.v_max)
        a_max = _check_positive("a_max", self.a_max)
        j_max = _check_positive("j_max", self.j_max)
        v_min = -v_max if self.v_min is None else _check_negative("v_min", self.v_min)
        a_min = -a_max if self.a_min is None else _check_negative("a_min", self.a_min)
        if math.isinf(a_max) != math.isinf(a_min):
            raise PlanningError(
                f"Limits.a_min and Limits.a_max must both be finite or both infinite, "
                f"got a_min={a_min!r}, a_max={a_max!r}"
            )
        object.__setattr__(self, "v_max", v_max)
        object.__setattr__(self, "a_max", a_max)
        object.__setattr__(self, "j_max", j_max)
        object.__setattr__(self, "v_min", v_min)
        object.__setattr__(self, "a_min", a_min)

    def reversed(self) -> Limits:
        """The limits seen by the mirrored axis (p -> -p): minima and maxima swap."""
        return Limits(
            v_max=-self.v_min,  # type: ignore[operator]
            a_max=-self.a_min,  # type: ignore[operator]
            j_max=self.j_max,
            v_min=-self.v_max,
            a_min=-self.a_max,
        )
