"""Kinematic state of one axis."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True, slots=True)
class State:
    """Position ``p`` [m or rad], velocity ``v`` [/s] and acceleration ``a`` [/s^2]."""

    p: float = 0.0
    v: float = 0.0
    a: float = 0.0
