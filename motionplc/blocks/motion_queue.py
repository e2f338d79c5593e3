"""The command queue of one axis or axes group: handles, job container, junction velocities.

Shared by single axes (:class:`~motionplc.blocks.axis.Axis`) and axes groups. What a job moves
(a 1-D profile chain, a path segment) is the owner's business; this module only needs a job's
``handle`` (:class:`Handle`), its ``cmd.mode`` (:class:`~motionplc.blocks.enums.BufferMode`)
and its ``waiting`` flag (queued behind other motion when it was submitted).

Life of a command (the owner drives it, in the kernel step of its cycle):

* ``submit`` (program phase): the owner checks it, then :meth:`MotionQueue.admit` puts the job in
  the *inbox* (Aborting / idle: started in this cycle's kernel step; else ``waiting``, counted
  against the queue depth: :meth:`MotionQueue.full`).
* kernel step: :meth:`MotionQueue.take_inbox` hands the inbox over; the owner starts a job
  (:attr:`MotionQueue.active`, after :meth:`MotionQueue.abort_motion` for Aborting) or appends
  it to :attr:`MotionQueue.queue`; when the active job ends, :meth:`MotionQueue.pop_next` gives
  the next queued one.
* ContinuousUpdate values and failures of busy commands wait in :attr:`MotionQueue.pending`
  (:meth:`MotionQueue.take_pending`); MC_Stop handles in :attr:`MotionQueue.stops`.
* an axis error, power off: :meth:`MotionQueue.fail_all`.

Every status change is written to the job's :class:`Handle` (the FB reads it at its next call).
The queue's attributes are plain (no properties): the owner's per-cycle path reads them directly.
"""

from __future__ import annotations

from collections import deque
from collections.abc import Callable
from enum import IntEnum
from typing import Any, Generic, Protocol, TypeVar

from motionplc.blocks._axis_core import QueueCore
from motionplc.blocks.enums import BufferMode, ErrorID

__all__ = [
    "Handle",
    "MotionQueue",
    "QueuedJob",
    "ReplanBudget",
    "Status",
    "junction_velocity",
]


class Status(IntEnum):
    """Life cycle of a submitted command."""

    QUEUED = 0  # accepted, waiting (FB Busy)
    ACTIVE = 1  # controls the axis (FB Busy + Active)
    DONE = 2
    ABORTED = 3
    ERROR = 4


class Handle:
    """The axis' side of one FB command; written by the axis only."""

    __slots__ = ("status", "error_id", "in_target", "end_velocity", "hold", "kind", "reason")

    def __init__(self, kind: str) -> None:
        self.kind = kind
        self.status = Status.QUEUED
        self.error_id = ErrorID.OK
        self.reason = ""  # why the command ended with Error (shown as the FB's error_text)
        self.in_target = False  # InVelocity (velocity jobs)
        self.end_velocity = 0.0  # effective velocity at the end position (blending)
        self.hold = True  # MC_Stop: Execute still TRUE

    @property
    def terminal(self) -> bool:
        """Done, aborted or failed."""
        return self.status >= Status.DONE

    def _finish(self, status: Status, error_id: ErrorID = ErrorID.OK, reason: str = "") -> None:
        if self.status < Status.DONE:
            self.status = status
            self.error_id = error_id
            self.reason = reason
            self.in_target = False if status is not Status.DONE else self.in_target


class ReplanBudget:
    """How many blending re-plans of running moves the axes of a runtime may still do in the
    current cycle (reset by the runtime every tick; axes step in declaration order, so which
    axis waits is deterministic)."""

    __slots__ = ("per_cycle", "left")

    def __init__(self, per_cycle: int) -> None:
        self.per_cycle = per_cycle
        self.left = per_cycle


def junction_velocity(mode: BufferMode, v_first: float, v_second: float) -> float:
    """The requested speed at the junction of two blended commands (PLCopen BufferMode):
    BlendingLow the lower of the two Velocity inputs, BlendingPrevious the first one's,
    BlendingNext the second one's, BlendingHigh the higher. Other modes raise ValueError (they
    stop at the junction)."""
    if mode is BufferMode.BLENDING_LOW:
        return min(v_first, v_second)
    if mode is BufferMode.BLENDING_PREVIOUS:
        return v_first
    if mode is BufferMode.BLENDING_NEXT:
        return v_second
    if mode is BufferMode.BLENDING_HIGH:
        return max(v_first, v_second)
    raise ValueError(f"mode must be a blending BufferMode, got {mode!r}")


class _HasMode(Protocol):
    @property
    def mode(self) -> BufferMode: ...


class QueuedJob(Protocol):
    """What :class:`MotionQueue` needs of a job (any object with these attributes)."""

    handle: Handle
    waiting: bool  # queued behind other motion at submission (counts against the depth)

    @property
    def cmd(self) -> _HasMode: ...


J = TypeVar("J", bound=QueuedJob)


class MotionQueue(QueueCore, Generic[J]):
    """The commands of one axis or group: the inbox (submitted in this cycle's program phase),
    the active job, the queue behind it, MC_Stop handles and pending ContinuousUpdate values.

    Mutable, owned by one axis or group; only its owner's kernel changes it. The attributes
    are read and written directly on the hot path (``q.active``, ``q.queue``, ``q.inbox``).
    """

    # the fields are declared by QueueCore (C fields when compiled: the axis kernel's fast path)

    def __init__(self) -> None:
        self.inbox: list[J] = []  # submitted, not yet taken by the kernel
        self.active: J | None = None  # the job controlling the motion
        self.queue: deque[J] = deque()  # waiting behind the active job, in order
        self.stops: list[Handle] = []  # MC_Stop commands in force (released by Execute FALSE)
        self.pending: list[tuple[Handle, Any]] = []  # ContinuousUpdate values / failures

    def __repr__(self) -> str:
        return (
            f"MotionQueue(active={self.active!r}, queued={len(self.queue)}, "
            f"inbox={len(self.inbox)}, stops={len(self.stops)}, pending={len(self.pending)})"
        )

    def idle(self) -> bool:
        """Nothing active, queued or in the inbox."""
        return self.active is None and not self.queue and not self.inbox

    def tail(self) -> J | None:
        """The job a new buffered command follows: the last submitted one, else the last
        queued one, else the active one (None: nothing)."""
        if self.inbox:
            return self.inbox[-1]
        if self.queue:
            return self.queue[-1]
        return self.active

    def waiting_count(self) -> int:
        """Jobs counted against the queue depth: the queue and the waiting jobs of the inbox."""
        return len(self.queue) + sum(1 for j in self.inbox if j.waiting)

    def full(self, depth: int) -> bool:
        """True if one more waiting job would exceed ``depth`` (the command is refused with
        QUEUE_FULL)."""
        return self.waiting_count() >= depth

    def admit(self, job: J) -> None:
        """Put an accepted job into the inbox (the kernel takes it in this cycle's step)."""
        self.inbox.append(job)

    def take_inbox(self) -> list[J]:
        """The inbox, in submission order; the queue keeps a new, empty one."""
        inbox = self.inbox
        self.inbox = []
        return inbox

    def take_pending(self) -> list[tuple[Handle, Any]]:
        """The pending updates / failures, in order; the queue keeps a new, empty list."""
        pending = self.pending
        self.pending = []
        return pending

    def jobs(self) -> list[J]:
        """Every job: the active one, the queued ones, the inbox (in this order)."""
        out: list[J] = [self.active] if self.active is not None else []
        out.extend(self.queue)
        out.extend(self.inbox)
        return out

    def find(self, handle: Handle) -> J | None:
        """The job of ``handle`` (active, queued or in the inbox), None if there is none."""
        act = self.active
        if act is not None and act.handle is handle:
            return act
        for job in self.queue:
            if job.handle is handle:
                return job
        for job in self.inbox:
            if job.handle is handle:
                return job
        return None

    def remove(self, job: J) -> bool:
        """Take a queued or submitted ``job`` out (not the active one); False if not there."""
        if job in self.queue:
            self.queue.remove(job)
            return True
        if job in self.inbox:
            self.inbox.remove(job)
            return True
        return False

    def pop_next(self) -> J | None:
        """The first queued job, removed from the queue (None if the queue is empty)."""
        return self.queue.popleft() if self.queue else None

    def abort_motion(
        self,
        keep: Callable[[J], bool] | None = None,
        status: Status = Status.ABORTED,
        error_id: ErrorID = ErrorID.OK,
    ) -> None:
        """End the queued jobs and the active one with ``status`` (CommandAborted by default;
        ``keep(active)`` True: the active job's handle is left as it is); the queue is empty
        and nothing is active afterwards. The inbox is not touched."""
        for q in self.queue:
            q.handle._finish(status, error_id)
        self.queue.clear()
        act = self.active
        if act is not None and (keep is None or not keep(act)):
            act.handle._finish(status, error_id)
        self.active = None

    def fail_all(self, error_id: ErrorID, status: Status = Status.ERROR) -> None:
        """End every command (inbox, queue, active, stops) with ``status`` / ``error_id`` and
        drop the pending updates: the queue is empty afterwards."""
        jobs = list(self.inbox) + list(self.queue)
        if self.active is not None:
            jobs.append(self.active)
        for job in jobs:
            job.handle._finish(status, error_id)
        for h in self.stops:
            h._finish(status, error_id)
        self.inbox.clear()
        self.queue.clear()
        self.stops.clear()
        self.pending.clear()
        self.active = None
