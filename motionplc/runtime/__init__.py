"""motionplc.runtime: the cyclic soft-PLC runtime.

from motionplc.runtime import Runtime
rt = Runtime(cycle=0.001)          # simulated clock; RealtimeClock() for wall-clock runs
"""

from motionplc.runtime.clock import Clock, RealtimeClock, SimClock
from motionplc.runtime.context import CycleContext, ProcessImage
from motionplc.runtime.runtime import Runtime
from motionplc.runtime.task import Task, TaskStats
from motionplc.runtime.trace import Trace, TraceEvent

__all__ = [
    "Clock",
    "CycleContext",
    "ProcessImage",
    "RealtimeClock",
    "Runtime",
    "SimClock",
    "Task",
    "TaskStats",
    "Trace",
    "TraceEvent",
]
