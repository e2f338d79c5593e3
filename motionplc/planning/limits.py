"""Kinematic limits of one axis, validated on construction."""

from __future__ import annotations

import math
from dataclasses import dataclass

from motionplc.errors import PlanningError

_INF = math.inf


def _check_positive(name: str, value: float) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise PlanningError(f"Limits.{name} must be a number in (0, inf], got {value!r}")
    value = float(value)
    if math.isnan(value) or value <= 0.0:
        raise PlanningError(f"Limits.{name} must be in (0, inf], got {value!r}")
    return value


def _check_negative(name: str, value: float) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise PlanningError(f"Limits.{name} must be a number in [-inf, 0), got {value!r}")
    value = float(value)
    if math.isnan(value) or value >= 0.0:
        raise PlanningError(f"Limits.{name} must be in [-inf, 0), got {value!r}")
    return value


@dataclass(frozen=True, slots=True)
class Limits:
    """Velocity, acceleration and jerk limits (SI units; ``math.inf`` = no limit).

    ``v_min`` and ``a_min`` default to ``-v_max`` and ``-a_max``. The jerk limit is symmetric.
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
