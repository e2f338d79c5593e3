"""Cyclic tasks and their timing statistics."""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from motionplc.runtime.context import CycleContext

Program = Callable[[CycleContext], Any]

_HIST_BIN_NS = 1_000  # lateness histogram: 1 us bins
_HIST_BINS = 20_000  # up to 20 ms; later values go into the last bin


@dataclass(frozen=True, slots=True)
class TaskStats:
    """Snapshot of one task's timing statistics (times in seconds).

    ``lateness`` = actual start - scheduled start (jitter); ``exec`` = program + motion kernel +
    I/O time of the task's cycle. In virtual time every lateness is 0 and execution times are
    what the programs declared with ``ctx.spend``.
    """

    name: str
    cycle_count: int
    exec_last: float
    exec_min: float
    exec_max: float
    exec_mean: float
    lateness_min: float
    lateness_max: float
    lateness_p50: float
    lateness_p99: float
    overruns: int
    omitted_cycles: int
    cycle_time_exceeded: bool
    watchdog_tripped: bool
    exec_p50: float = 0.0
    exec_p99: float = 0.0

    def as_dict(self) -> dict[str, Any]:
        """Plain dict (JSON-ready)."""
        return {f: getattr(self, f) for f in self.__dataclass_fields__}


class Task:
    """A cyclic task: a program called every ``period_ticks`` base ticks.

    Order of tasks due in the same tick: ``priority`` (0 = highest) then declaration order.
    An overrun is a cycle that ends after the task's next release time. Watchdog (CODESYS
    semantics): ``watchdog_sensitivity`` consecutive cycles whose execution time exceeds
    ``watchdog_time``, or one cycle longer than ``watchdog_sensitivity * watchdog_time``, trip
    it; the axes of the task then go to ErrorStop (use ``watchdog_time = period`` to trip on
    consecutive overruns). It arms after ``arm_after`` cycles (the runtime sets it in real
    time: the start-up cycles, whose first-time work is not the program's cycle time).
    """

    def __init__(
        self,
        name: str,
        program: Program,
        period_ticks: int,
        period: float,
        priority: int,
        order: int,
        watchdog_time: float | None = None,
        watchdog_sensitivity: int = 1,
    ) -> None:
        if period_ticks < 1:
            raise ValueError(f"task {name!r}: period must be >= one base tick")
        if not 0 <= priority <= 31:
            raise ValueError(f"task {name!r}: priority must be in [0, 31], got {priority}")
        if watchdog_time is not None and not watchdog_time > 0.0:
            raise ValueError(f"task {name!r}: watchdog_time must be > 0 s, got {watchdog_time}")
        if watchdog_sensitivity < 1:
            raise ValueError(
                f"task {name!r}: watchdog_sensitivity must be >= 1, got {watchdog_sensitivity}"
            )
        self.name = name
        self.program = program
        self.period_ticks = period_ticks
        self.period = period
        self.priority = priority
        self.order = order
        self.watchdog_time = watchdog_time
        self.watchdog_sensitivity = watchdog_sensitivity
        self.axes: list[Any] = []
        self.groups: list[Any] = []  # axes groups stepped after the task's axes
        self.last_tick: int | None = None  # base tick of the task's last cycle
        self.fused = False  # set by the runtime at start: no groups, Axis.step_write per axis
        # statistics
        self.cycle_count = 0
        self.exec_last_ns = 0
        self.exec_min_ns = math.inf
        self.exec_max_ns = 0
        self.exec_sum_ns = 0
        self.lat_min_ns = math.inf
        self.lat_max_ns = 0
        # lateness histogram (1 us bins); a list: a numpy item increment per cycle costs more
        self._lat_counts = [0] * (_HIST_BINS + 1)
        self._exec_counts = [0] * (_HIST_BINS + 1)  # execution time histogram (1 us bins)
        self.overruns = 0
        self.omitted_cycles = 0
        self.consecutive_overruns = 0
        self.cycle_time_exceeded = False
        self.watchdog_tripped = False
        self.watchdog_reason = ""
        # the watchdog arms after this many cycles (real time: the start-up cycles, see
        # Runtime.startup_cycles); 0 = from the first cycle
        self.arm_after = 0
        self.program_error: Exception | None = None  # the task is halted (see Runtime.run)

    @property
    def sort_key(self) -> tuple[int, int]:
        """Execution order of tasks due in the same tick."""
        return (self.priority, self.order)

    def record(self, lateness_ns: int, exec_ns: int, overrun: bool) -> str | None:
        """Account one cycle; returns a watchdog reason when the watchdog trips now."""
        self.cycle_count += 1
        self.exec_last_ns = exec_ns
        if exec_ns < self.exec_min_ns:
            self.exec_min_ns = exec_ns
        if exec_ns > self.exec_max_ns:
            self.exec_max_ns = exec_ns
        self.exec_sum_ns += exec_ns
        if lateness_ns < self.lat_min_ns:
            self.lat_min_ns = lateness_ns
        if lateness_ns > self.lat_max_ns:
            self.lat_max_ns = lateness_ns
        b = lateness_ns // _HIST_BIN_NS
        self._lat_counts[b if 0 <= b < _HIST_BINS else (0 if b < 0 else _HIST_BINS)] += 1
        b = exec_ns // _HIST_BIN_NS
        self._exec_counts[b if b < _HIST_BINS else _HIST_BINS] += 1
        self.cycle_time_exceeded = overrun
        if overrun:
            self.overruns += 1
        if self.watchdog_time is None or self.watchdog_tripped:
            return None
        if self.cycle_count <= self.arm_after:  # the start-up cycles (Runtime._warm_up)
            return None
        n = self.watchdog_sensitivity
        wd_ns = self.watchdog_time * 1e9
        if exec_ns > wd_ns:
            self.consecutive_overruns += 1
        else:
            self.consecutive_overruns = 0
        reason = None
        if exec_ns > n * wd_ns:
            reason = (
                f"watchdog: task {self.name!r} cycle took {exec_ns / 1e6:.3f} ms "
                f"> {n} x {self.watchdog_time * 1e3:.3f} ms"
            )
        elif self.consecutive_overruns >= n:
            reason = (
                f"watchdog: task {self.name!r} exceeded {self.watchdog_time * 1e3:.3f} ms in "
                f"{self.consecutive_overruns} consecutive cycles"
            )
        if reason is not None:
            self.watchdog_tripped = True
            self.watchdog_reason = reason
        return reason

    @property
    def lat_hist(self) -> np.ndarray:
        """Lateness histogram: counts per 1 us bin (the last bin collects everything later)."""
        return np.asarray(self._lat_counts, dtype=np.int64)

    def lateness_percentile(self, q: float) -> float:
        """Lateness [s] below which a fraction ``q`` of the cycles started (1 us resolution)."""
        return self._lat_percentile(q)

    @property
    def exec_hist(self) -> np.ndarray:
        """Execution time histogram: counts per 1 us bin (the last bin collects the rest)."""
        return np.asarray(self._exec_counts, dtype=np.int64)

    def exec_percentile(self, q: float) -> float:
        """Execution time [s] within which a fraction ``q`` of the cycles ran (1 us bins)."""
        return _percentile(self.exec_hist, q, self.exec_min_ns, self.exec_max_ns)

    def _lat_percentile(self, q: float) -> float:
        return _percentile(self.lat_hist, q, self.lat_min_ns, self.lat_max_ns)

    def stats(self) -> TaskStats:
        """Current statistics."""
        n = self.cycle_count
        return TaskStats(
            name=self.name,
            cycle_count=n,
            exec_last=self.exec_last_ns * 1e-9,
            exec_min=0.0 if n == 0 else self.exec_min_ns * 1e-9,
            exec_max=self.exec_max_ns * 1e-9,
            exec_mean=0.0 if n == 0 else self.exec_sum_ns / n * 1e-9,
            lateness_min=0.0 if n == 0 else self.lat_min_ns * 1e-9,
            lateness_max=self.lat_max_ns * 1e-9,
            lateness_p50=self._lat_percentile(0.5),
            lateness_p99=self._lat_percentile(0.99),
            overruns=self.overruns,
            omitted_cycles=self.omitted_cycles,
            cycle_time_exceeded=self.cycle_time_exceeded,
            watchdog_tripped=self.watchdog_tripped,
            exec_p50=self.exec_percentile(0.5),
            exec_p99=self.exec_percentile(0.99),
        )


def _percentile(hist: np.ndarray, q: float, lo_ns: float, hi_ns: float) -> float:
    """Upper edge of the 1 us bin holding the ceil(q * n)-th sample, clamped to [lo, hi] (the
    overflow bin: the maximum)."""
    total = int(hist.sum())
    if total == 0:
        return 0.0
    idx = int(np.searchsorted(np.cumsum(hist), math.ceil(q * total)))
    edge = (idx + 1) * _HIST_BIN_NS if idx < _HIST_BINS else hi_ns
    return float(min(max(edge, lo_ns), hi_ns)) * 1e-9
