"""Planner calls of the motion kernels (axes and groups): counted.

Every profile a kernel plans goes through :func:`guarded`: it counts the call (the runtime reads
:func:`planner_calls` to find quiet cycles for planning ahead). A planner's documented failure is
a :class:`~motionplc.planning.PlanningError` (inputs that cannot be planned, and the planners' own
"planner defect" reports of a numerical failure): the kernels turn it into PLANNING_FAILED.
Anything else (a TypeError, an AttributeError...) is a programming error: it propagates
unchanged to the fault barrier of the FB or the kernel, which reports INTERNAL_ERROR naming the
exception (README "Faults, limits and bounds"), never disguised as a planning failure.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TypeVar

__all__ = ["guarded", "planner_calls"]

T = TypeVar("T")

_planner_calls = 0  # planner calls made by the motion kernels (all axes), see planner_calls()


def planner_calls() -> int:
    """Number of profiles planned so far by all axes (the runtime budgets planning ahead)."""
    return _planner_calls


def guarded(fn: Callable[..., T], *args: object) -> T:
    """Call a planner for the kernel, counted. Its PlanningError goes to the kernel's handlers;
    any other exception is a defect and propagates as it is (to INTERNAL_ERROR)."""
    global _planner_calls
    _planner_calls += 1
    return fn(*args)
