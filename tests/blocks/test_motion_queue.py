"""MotionQueue on its own, with a trivial job type (no axis, no planner): admission and depth,
tail, find/remove, abort, fail_all, pop order; and junction_velocity's BufferMode table.

The job type here only has what the queue needs (handle, cmd.mode, waiting), which shows the
queue is generic over what a job moves (1-D profiles for axes, path segments for groups).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from motionplc.blocks.axis import Axis
from motionplc.blocks.enums import BufferMode, ErrorID
from motionplc.blocks.motion_queue import (
    Handle,
    MotionQueue,
    Status,
    junction_velocity,
)

B = BufferMode


@dataclass(frozen=True)
class Cmd:
    mode: BufferMode = BufferMode.BUFFERED


@dataclass(eq=False)
class Job:
    """A job of a hypothetical segment queue: just the attributes MotionQueue uses."""

    name: str
    cmd: Cmd = field(default_factory=Cmd)
    waiting: bool = False
    handle: Handle = field(init=False)

    def __post_init__(self) -> None:
        self.handle = Handle(self.name)


def _queue(active: str | None, queued: list[str], inbox: list[str]) -> MotionQueue[Job]:
    q: MotionQueue[Job] = MotionQueue()
    if active is not None:
        q.active = Job(active)
        q.active.handle.status = Status.ACTIVE
    q.queue.extend(Job(n) for n in queued)
    for n in inbox:
        q.admit(Job(n, waiting=True))
    return q


def test_empty_queue_is_idle_without_tail() -> None:
    q: MotionQueue[Job] = MotionQueue()
    assert q.idle() and q.tail() is None and q.pop_next() is None
    assert q.waiting_count() == 0 and not q.full(1) and q.full(0)
    assert q.take_inbox() == [] and q.take_pending() == [] and q.jobs() == []


def test_admission_and_depth_count_only_waiting_jobs() -> None:
    q: MotionQueue[Job] = MotionQueue()
    q.admit(Job("immediate"))  # an Aborting / idle start: not counted against the depth
    assert not q.idle() and q.waiting_count() == 0
    q.admit(Job("w1", waiting=True))
    q.queue.append(Job("q1"))
    assert q.waiting_count() == 2
    assert q.full(2) and not q.full(3)
    inbox = q.take_inbox()
    assert [j.name for j in inbox] == ["immediate", "w1"] and q.inbox == []
    assert q.waiting_count() == 1


def test_tail_is_inbox_then_queue_then_active() -> None:
    q = _queue("a", ["q1", "q2"], ["i1"])
    assert q.tail() is q.inbox[-1]
    q.take_inbox()
    assert q.tail() is q.queue[-1]
    q.queue.clear()
    assert q.tail() is q.active
    assert not q.idle()


def test_find_remove_and_jobs_order() -> None:
    q = _queue("a", ["q1", "q2"], ["i1"])
    a, (q1, q2), (i1,) = q.active, list(q.queue), list(q.inbox)
    assert q.jobs() == [a, q1, q2, i1]
    for job in (a, q1, q2, i1):
        assert q.find(job.handle) is job
    assert q.find(Handle("other")) is None
    assert q.remove(q1) and list(q.queue) == [q2]
    assert q.remove(i1) and q.inbox == []
    assert not q.remove(q1)
    assert not q.remove(a) and q.active is a  # the active job is not removed this way


def test_pop_next_keeps_submission_order() -> None:
    q = _queue(None, ["q1", "q2", "q3"], [])
    assert [q.pop_next().name for _ in range(3)] == ["q1", "q2", "q3"]  # type: ignore[union-attr]
    assert q.pop_next() is None


def test_abort_motion_aborts_queue_and_active_but_not_the_inbox() -> None:
    q = _queue("a", ["q1", "q2"], ["i1"])
    a, queued, inbox = q.active, list(q.queue), list(q.inbox)
    q.abort_motion()
    assert q.active is None and not q.queue and q.inbox == inbox
    assert a is not None and a.handle.status is Status.ABORTED
    assert all(j.handle.status is Status.ABORTED for j in queued)
    assert inbox[0].handle.status is Status.QUEUED


def test_abort_motion_keep_and_error_status() -> None:
    q = _queue("stop", ["q1"], [])
    a, q1 = q.active, q.queue[0]
    q.abort_motion(keep=lambda job: job.name == "stop")
    assert q.active is None and a is not None and a.handle.status is Status.ACTIVE
    assert q1.handle.status is Status.ABORTED
    q = _queue("a", ["q1"], [])
    a, q1 = q.active, q.queue[0]
    q.abort_motion(status=Status.ERROR, error_id=ErrorID.DIRECTION_NOT_ENABLED)
    for job in (a, q1):
        assert job is not None
        assert job.handle.status is Status.ERROR
        assert job.handle.error_id is ErrorID.DIRECTION_NOT_ENABLED


def test_fail_all_ends_everything_and_drops_pending() -> None:
    q = _queue("a", ["q1"], ["i1"])
    stop = Handle("stop")
    q.stops.append(stop)
    q.pending.append((q.queue[0].handle, "update"))
    handles = [j.handle for j in q.jobs()] + [stop]
    q.fail_all(ErrorID.AXIS_ERROR_STOP)
    assert q.idle() and not q.stops and not q.pending
    assert all(h.status is Status.ERROR for h in handles)
    assert all(h.error_id is ErrorID.AXIS_ERROR_STOP for h in handles)


def test_finished_handles_keep_their_first_outcome() -> None:
    q = _queue("a", [], [])
    assert q.active is not None
    h = q.active.handle
    h._finish(Status.DONE)
    q.fail_all(ErrorID.AXIS_ERROR_STOP, Status.ABORTED)
    assert h.status is Status.DONE and h.error_id is ErrorID.OK and h.terminal


@settings(max_examples=200, deadline=None)
@given(
    ops=st.lists(
        st.tuples(st.sampled_from(["admit", "wait", "take", "pop", "abort"]), st.booleans()),
        max_size=30,
    ),
    depth=st.integers(0, 4),
)
def test_depth_bookkeeping_matches_a_model(ops: list[tuple[str, bool]], depth: int) -> None:
    """The queue against a list model: waiting_count / full / tail / idle after any sequence."""
    q: MotionQueue[Job] = MotionQueue()
    inbox: list[Job] = []
    queued: list[Job] = []
    active: Job | None = None
    for i, (op, flag) in enumerate(ops):
        if op in ("admit", "wait"):
            job = Job(f"j{i}", waiting=op == "wait")
            if job.waiting and q.full(depth):
                assert len(queued) + sum(j.waiting for j in inbox) >= depth
                continue
            q.admit(job)
            inbox.append(job)
        elif op == "take":  # the kernel step: first job starts if nothing runs, rest queue up
            taken = q.take_inbox()
            assert taken == inbox
            for job in taken:
                if active is None or flag:
                    active = q.active = job
                else:
                    q.queue.append(job)
                    queued.append(job)
            inbox = []
        elif op == "pop":
            nxt = q.pop_next()
            assert nxt is (queued.pop(0) if queued else None)
            if nxt is not None:
                active = q.active = nxt
        else:
            q.abort_motion()
            queued, active = [], None
        assert q.waiting_count() == len(queued) + sum(j.waiting for j in inbox)
        assert q.full(depth) == (q.waiting_count() >= depth)
        expected_tail = inbox[-1] if inbox else (queued[-1] if queued else active)
        assert q.tail() is expected_tail
        assert q.idle() == (active is None and not queued and not inbox)
        assert q.active is active and list(q.queue) == queued


@pytest.mark.parametrize(
    ("mode", "expected"),
    [
        (B.BLENDING_LOW, 50.0),
        (B.BLENDING_PREVIOUS, 100.0),
        (B.BLENDING_NEXT, 50.0),
        (B.BLENDING_HIGH, 100.0),
    ],
)
def test_junction_velocity_table(mode: BufferMode, expected: float) -> None:
    assert junction_velocity(mode, 100.0, 50.0) == expected
    # the table is symmetric where the spec says min / max
    swapped = {B.BLENDING_PREVIOUS: 50.0, B.BLENDING_NEXT: 100.0}.get(mode, expected)
    assert junction_velocity(mode, 50.0, 100.0) == swapped


@pytest.mark.parametrize("mode", [B.ABORTING, B.BUFFERED])
def test_junction_velocity_refuses_non_blending_modes(mode: BufferMode) -> None:
    with pytest.raises(ValueError, match="blending BufferMode"):
        junction_velocity(mode, 1.0, 2.0)


def test_axis_attributes_are_the_queue_s_own_objects() -> None:
    """The axis' public ``active`` / ``queue`` are views of its MotionQueue (same objects)."""
    from motionplc.blocks.axis import AxisConfig
    from motionplc.fieldbus.ideal import IdealDrive

    ax = Axis(AxisConfig(name="x", v_max=1.0, a_max=1.0), IdealDrive("x"))
    assert ax.queue is ax.mq.queue and ax.active is ax.mq.active is None
    job = Job("j")
    ax.active = job  # type: ignore[assignment]
    assert ax.mq.active is job
