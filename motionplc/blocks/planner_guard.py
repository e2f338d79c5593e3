"""Planner calls of the motion kernels (axes and groups): counted and guarded.

Every profile a kernel plans goes through :func:`guarded`: it counts the call (the runtime reads
:func:`planner_calls` to find quiet cycles for planning ahead) and turns any failure into a
:class:`~motionplc.planning.PlanningError`, which the kernels turn into an FB or axis error, so
nothing escapes the cycle.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TypeVar

from motionplc.planning import PlanningError

__all__ = ["guarded", "planner_calls"]

T = TypeVar("T")

_planner_calls = 0  # planner calls made by the motion kernels (all axes), see planner_calls()


def planner_calls() -> int:
    """Number of profiles planned so far by all axes (the runtime budgets planning ahead)."""
    return _planner_calls


def guarded(fn: Callable[..., T], *args: object) -> T:
    """Call a planner for the kernel: every failure is a PlanningError (the kernel's handlers
    turn it into an FB or axis error; nothing escapes the cycle)."""
    global _planner_calls
    _planner_calls += 1
    try:
        return fn(*args)
    except PlanningError:
        raise
    except Exception as exc:  # noqa: BLE001 - a planner defect must not end the cycle
        raise PlanningError(f"planner defect: {type(exc).__name__}: {exc}") from exc
