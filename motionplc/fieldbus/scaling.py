"""Conversion between SI values (m or rad, m/s, ...) and drive increments, at the fieldbus edge."""

from __future__ import annotations

import math
from dataclasses import dataclass

__all__ = ["INT32_MAX", "INT32_MIN", "Scaling", "saturate_i32"]

INT32_MIN = -(2**31)
INT32_MAX = 2**31 - 1


def saturate_i32(x: float) -> int:
    """Round to the nearest integer and saturate to the INT32 range (NaN -> 0)."""
    if math.isnan(x):
        return 0
    if x >= INT32_MAX:
        return INT32_MAX
    if x <= INT32_MIN:
        return INT32_MIN
    return int(round(x))


@dataclass(frozen=True, slots=True)
class Scaling:
    """``counts = position · counts_per_unit + offset_counts`` (velocity: no offset)."""

    counts_per_unit: float
    offset_counts: int = 0

    def __post_init__(self) -> None:
        if not (math.isfinite(self.counts_per_unit) and self.counts_per_unit != 0.0):
            raise ValueError(
                f"Scaling.counts_per_unit must be finite and non-zero, got {self.counts_per_unit}"
            )

    def position_to_counts(self, position: float) -> int:
        return saturate_i32(position * self.counts_per_unit + self.offset_counts)

    def position_to_si(self, counts: int) -> float:
        return (counts - self.offset_counts) / self.counts_per_unit

    def velocity_to_counts(self, velocity: float) -> int:
        return saturate_i32(velocity * self.counts_per_unit)

    def velocity_to_si(self, counts_per_s: int) -> float:
        return counts_per_s / self.counts_per_unit

    def distance_to_si(self, counts: float) -> float:
        """A position difference (following error, window) in SI."""
        return counts / self.counts_per_unit
