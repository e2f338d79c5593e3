"""The two clocks of the scheduler behind one interface.

* :class:`SimClock` - virtual time: waiting returns at once, the time is exactly the deadline
  (plus whatever a program declared with ``ctx.spend``). Same inputs give the same trace.
* :class:`RealtimeClock` - sleeps to absolute deadlines on the monotonic clock (no drift), with a
  short busy-wait before each deadline to cut the wake-up latency of ``time.sleep``.

This is the only module of motionplc that reads the clock or sleeps.
"""

from __future__ import annotations

import ctypes
import ctypes.util
import os
import time
from collections.abc import Iterable
from typing import Protocol

_MCL_CURRENT = 1
_MCL_FUTURE = 2


class Clock(Protocol):
    """Time source of the scheduler. All times are integer nanoseconds since :meth:`start`."""

    realtime: bool

    def start(self) -> None:
        """Set time zero (called once before the first cycle)."""

    def wait_until(self, deadline_ns: int) -> int:
        """Block until ``deadline_ns``; return the time at which the wait ended."""

    def now_ns(self) -> int:
        """Current time."""

    def spend(self, ns: int) -> None:
        """Virtual clocks: advance time by ``ns`` (simulated CPU time); real clocks ignore it."""


class SimClock:
    """Virtual time; never sleeps."""

    realtime = False

    def __init__(self) -> None:
        self._now = 0

    def start(self) -> None:
        self._now = 0

    def wait_until(self, deadline_ns: int) -> int:
        if deadline_ns > self._now:
            self._now = deadline_ns
        return self._now

    def now_ns(self) -> int:
        return self._now

    def spend(self, ns: int) -> None:
        if ns > 0:
            self._now += ns


class RealtimeClock:
    """Wall-clock time: sleeps to absolute deadlines of ``time.monotonic_ns``.

    ``spin_ns``: the last part of each wait is a busy loop (the OS sleep typically wakes 50-100
    us late). A larger value lowers lateness and costs CPU. ``fifo_priority``: if given, the
    process switches to ``SCHED_FIFO`` with that priority at :meth:`start` (Linux; needs the
    privilege, otherwise it stays as it is and ``fifo_active`` is False). ``cpus``: pin the
    process to that set of CPUs (``os.sched_setaffinity``; ``affinity_active``; a CPU this
    machine lacks makes the pinning refused); ``cpu``: the same for one CPU (``cpu=2`` is
    ``cpus={2}``; both given: their union). ``lock_memory``:
    ``mlockall(MCL_CURRENT | MCL_FUTURE)`` through the C library, so no page of the process is
    paged out (``mlock_active``; needs the privilege or a large enough RLIMIT_MEMLOCK). Each
    setting stays for the rest of the process; a refused one is reported, never raised.
    """

    realtime = True

    def __init__(
        self,
        spin_ns: int = 200_000,
        fifo_priority: int | None = None,
        *,
        cpu: int | None = None,
        cpus: Iterable[int] | None = None,
        lock_memory: bool = False,
    ) -> None:
        self.spin_ns = spin_ns
        self.fifo_priority = fifo_priority
        self.cpu = cpu
        wanted = set(cpus) if cpus is not None else set()
        if cpu is not None:
            wanted.add(cpu)
        self.cpus: frozenset[int] = frozenset(wanted)
        self.lock_memory = lock_memory
        self.fifo_active = False
        self.affinity_active = False
        self.mlock_active = False
        self._t0 = 0

    def start(self) -> None:
        if self.fifo_priority is not None and not self.fifo_active:
            try:
                param = os.sched_param(self.fifo_priority)
                os.sched_setscheduler(0, os.SCHED_FIFO, param)
                self.fifo_active = True
            except (OSError, AttributeError):
                self.fifo_active = False
        if self.cpus and not self.affinity_active:
            try:
                os.sched_setaffinity(0, set(self.cpus))
                self.affinity_active = True
            except (OSError, AttributeError, ValueError):
                self.affinity_active = False
        if self.lock_memory and not self.mlock_active:
            self.mlock_active = _mlockall()
        self._t0 = time.monotonic_ns()  # noqa: TID251 - the one place that reads the clock

    def now_ns(self) -> int:
        return time.monotonic_ns() - self._t0  # noqa: TID251

    def wait_until(self, deadline_ns: int) -> int:
        target = self._t0 + deadline_ns
        mono = time.monotonic_ns  # noqa: TID251
        remaining = target - mono()
        if remaining > self.spin_ns:
            time.sleep((remaining - self.spin_ns) * 1e-9)  # noqa: TID251
        now = mono()
        while now < target:
            now = mono()
        return now - self._t0

    def spend(self, ns: int) -> None:
        """Real time cannot be faked: ignored."""


def wall_time() -> float:
    """Seconds since the epoch (``time.time``): only the time stamp python-can's ``virtual``
    bus puts on a frame it delivers (``motionplc.fieldbus.fastcan.send_frame`` does the
    same); never a time the cycle computes with."""
    return time.time()  # noqa: TID251


def _mlockall() -> bool:
    """Lock all current and future pages of the process in RAM; False if refused."""
    name = ctypes.util.find_library("c")
    if name is None:
        return False
    try:
        libc = ctypes.CDLL(name, use_errno=True)
        return int(libc.mlockall(_MCL_CURRENT | _MCL_FUTURE)) == 0
    except (OSError, AttributeError):
        return False
