"""The soft-PLC runtime: axes, cyclic tasks, the scheduler loop and the trace.

Per base tick ``k`` (virtual time ``t = k * cycle``), for every task due in that tick, in the
order (priority, declaration):

1. READ INPUTS   - latch the I/O image; every axis of the task reads its drive feedback;
2. PROGRAM       - ``program(ctx)`` calls the FB instances (they submit commands to the axes);
3. MOTION KERNEL - every axis of the task steps its command queue and samples its profile
   (re-plans of running moves for a newly queued blending successor: at most
   ``blend_replans_per_cycle`` per tick, the others in the next ticks in axis order);
4. WRITE OUTPUTS - every axis writes its setpoints to its drive; the output image is published;
   if no axis planned in step 3, one axis plans a queued move's start profile ahead
   (``Axis.plan_ahead``: spreads the planning of axes that hand over in the same cycle);
5. STATISTICS    - execution time, lateness, overruns, watchdog.

Then the trace records one row (all axes) and the per-cycle hooks (invariant checks) run.
Kernel events of step 3 are seen by the FBs at their next call, so FB outputs do not depend on
the order in which a program calls its FB instances.
"""

from __future__ import annotations

import gc
import inspect
import math
import os
import struct
import traceback
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

from motionplc._fastinit import slot_setters
from motionplc.blocks.axis import ReplanBudget, planner_calls
from motionplc.blocks.axis_job import Command
from motionplc.blocks.enums import AxisState as S
from motionplc.blocks.enums import ErrorID, GroupState
from motionplc.blocks.motion_queue import Status
from motionplc.errors import ProgramError
from motionplc.runtime.clock import Clock, SimClock
from motionplc.runtime.context import CycleContext, ProcessImage
from motionplc.runtime.task import Program, Task, TaskStats
from motionplc.runtime.trace import AXIS_DTYPES, AXIS_FIELDS, GROUP_DTYPES, TRACE_BYTES, Trace

if TYPE_CHECKING:
    from motionplc.blocks.axis import Axis
    from motionplc.blocks.group import AxesGroup
    from motionplc.fieldbus.base import Drive

CycleHook = Callable[["Runtime", int], None]

STOP_MARGIN = 0.5  # [s] beyond twice the estimated stop time: the bound of a controlled stop
DISABLE_TIME = 0.5  # [s] for the drives to report disabled after the stop


@dataclass
class StopReport:
    """What :meth:`Runtime.shutdown` did: ``reason`` (why the run ended), ``quick`` (a quick
    stop was requested during the stop), ``cycles`` / ``seconds`` of the stop and of the
    power-off, ``bound`` [s] (the longest the stop was allowed), ``not_at_rest`` (axes still
    moving when the bound ran out: stopped by their drives' own reaction), ``not_disabled``
    (drives that did not report disabled in time: left to their own reaction), ``errors``
    (axes in ErrorStop at the end, with their ErrorID name and reason)."""

    reason: str = ""
    quick: bool = False
    cycles: int = 0
    seconds: float = 0.0
    bound: float = 0.0
    not_at_rest: list[str] = field(default_factory=list)
    not_disabled: list[str] = field(default_factory=list)
    errors: dict[str, str] = field(default_factory=dict)

    @property
    def ok(self) -> bool:
        """Every axis at rest and every drive disabled within the bound."""
        return not self.not_at_rest and not self.not_disabled

    def lines(self) -> list[str]:
        """A human-readable account (one line, plus one per problem)."""
        kind = "quick stop" if self.quick else "controlled stop"
        drives = (
            "every drive reported disabled"
            if not self.not_disabled
            else f"{len(self.not_disabled)} drives not disabled"
        )
        out = [
            f"{kind} ({self.reason}): {self.cycles} cycles, {self.seconds:.3f} s "
            f"(bound {self.bound:.3f} s), {drives}"
        ]
        for name in self.not_at_rest:
            out.append(f"axis {name!r} not at rest within the bound: left to its drive's reaction")
        for name in self.not_disabled:
            out.append(f"drive of axis {name!r} did not report disabled: left to its own reaction")
        return out


def stop_time(v: float, a: float, a_max: float, j_max: float) -> float:
    """An upper estimate [s] of a jerk-limited stop from velocity ``v`` and acceleration ``a``
    with deceleration ``a_max`` and jerk ``j_max`` (inf: no jerk limit)."""
    if not a_max > 0.0 or not math.isfinite(a_max):
        return 0.0
    t_j = 0.0 if not math.isfinite(j_max) or j_max <= 0.0 else a_max / j_max
    t_a = 0.0 if t_j == 0.0 else abs(a) / j_max
    v_eff = abs(v) + (0.0 if t_j == 0.0 else a * a / (2.0 * j_max))
    return t_a + v_eff / a_max + 2.0 * t_j


OVERRUN_POLICIES = ("skip", "catch_up")

_new = object.__new__
try:
    (_sc, _st, _sd, _sk, _si, _ss), _ = slot_setters(
        CycleContext, ("cycle", "t", "dt", "task", "image", "_spend")
    )

    def _context(
        cycle: int,
        t: float,
        dt: float,
        task: str,
        image: ProcessImage,
        spend: Callable[[float], None],
    ) -> CycleContext:
        """``CycleContext(cycle, t, dt, task, image, spend)``, built cheaply (once per task
        and cycle; see ``motionplc._fastinit``)."""
        ctx = _new(CycleContext)
        _sc(ctx, cycle)
        _st(ctx, t)
        _sd(ctx, dt)
        _sk(ctx, task)
        _si(ctx, image)
        _ss(ctx, spend)
        return ctx

except TypeError:  # CycleContext changed: the normal constructor (slower, same values)
    _context = CycleContext  # type: ignore[assignment]

_PACK_HEAD = struct.Struct("=2d").pack_into  # trace row: cycle, t
_AXIS_ROW = 8 * len(AXIS_FIELDS)  # bytes of one axis' trace row part
_GROUP_PACK = struct.Struct(f"={len(GROUP_DTYPES)}d").pack_into
_GROUP_ROW = 8 * len(GROUP_DTYPES)


def _ticks(name: str, seconds: float, tick_ns: int) -> int:
    if not (isinstance(seconds, (int, float)) and math.isfinite(seconds) and seconds > 0):
        raise ValueError(f"{name} must be a positive number of seconds, got {seconds!r}")
    ns = round(seconds * 1e9)
    n = round(ns / tick_ns)
    if n < 1 or abs(n * tick_ns - ns) > 1:
        raise ValueError(
            f"{name} = {seconds!r} s must be a multiple of the base cycle {tick_ns * 1e-9!r} s"
        )
    return n


def _drive_failed(ax: Axis, phase: str, exc: Exception) -> None:
    """A drive backend raised in the cycle (a bug or an I/O error it did not turn into a
    value): the axis goes to ErrorStop with COMMUNICATION_LOST naming the exception, the cycle
    and every other axis go on."""
    ax.raise_axis_error("COMMUNICATION_LOST", f"drive {phase} failed: {type(exc).__name__}: {exc}")


class Runtime:
    """A soft PLC: ``add_axis``, ``add_task``, then ``run``.

    ``cycle``: base tick [s]. ``clock``: :class:`SimClock` (default; deterministic virtual time)
    or :class:`RealtimeClock`. ``overrun_policy``: ``"skip"`` (a late cycle realigns to the tick
    grid and the missed cycles are counted as omitted) or ``"catch_up"`` (missed cycles run back
    to back). ``check_invariants`` runs the conformance invariants of the PLCopen spec notes
    (groups A, B, C, H) after every cycle and raises on a violation (used by the test suite).
    ``blend_replans_per_cycle``: at most this many running moves are re-planned to the junction
    with a newly queued blending successor per tick (the others in the next ticks, in axis
    order, from their set state then; None: no limit). Such a re-plan costs one or more full
    plans; the budget keeps axes that queue in lockstep from planning all in one cycle.
    ``trace_capacity`` / ``trace_bytes``: the trace keeps the most recent cycles, at most that
    many rows and bytes (57 B per axis and 16 B per cycle; see :mod:`motionplc.runtime.trace`).
    """

    def __init__(
        self,
        cycle: float = 0.001,
        clock: Clock | None = None,
        *,
        trace_capacity: int = 500_000,
        trace_bytes: int = TRACE_BYTES,
        trace_edges: bool = True,
        overrun_policy: str = "skip",
        check_invariants: bool = False,
        queue_depth: int = 8,
        blend_replans_per_cycle: int | None = 2,
    ) -> None:
        if not (isinstance(cycle, (int, float)) and math.isfinite(cycle) and cycle > 0):
            raise ValueError(f"cycle must be a positive number of seconds, got {cycle!r}")
        if overrun_policy not in OVERRUN_POLICIES:
            raise ValueError(
                f"overrun_policy must be one of {OVERRUN_POLICIES}, got {overrun_policy!r}"
            )
        if blend_replans_per_cycle is not None and not (
            type(blend_replans_per_cycle) is int and blend_replans_per_cycle >= 1
        ):
            raise ValueError(
                "blend_replans_per_cycle must be an integer >= 1 or None (no limit), got "
                f"{blend_replans_per_cycle!r}"
            )
        self._budget = (
            None if blend_replans_per_cycle is None else ReplanBudget(blend_replans_per_cycle)
        )
        self.tick_ns = round(cycle * 1e9)
        if self.tick_ns < 1000:
            raise ValueError(f"cycle must be >= 1 us, got {cycle!r}")
        self.cycle = self.tick_ns * 1e-9
        self.clock: Clock = clock if clock is not None else SimClock()
        self.image = ProcessImage()
        self.trace = Trace(capacity=trace_capacity, max_bytes=trace_bytes)
        self.trace_edges = trace_edges
        self.overrun_policy = overrun_policy
        self.queue_depth = queue_depth
        self.axes: dict[str, Axis] = {}
        self.groups: dict[str, AxesGroup] = {}
        self.tasks: list[Task] = []
        self._order: list[Task] = []
        self.tick = 0  # next base tick to run
        self._started = False
        self._hooks: list[CycleHook] = []
        self.last_due: list[str] = []  # names of the tasks run in the last tick, in run order
        self.error_reason = ""  # set when a watchdog tripped or a program raised
        self._failed_tasks: list[Task] = []  # programs that raised, their axes still stopping
        # the controlled stop at the end of a run (shutdown): programs are no longer called
        self._stopping = False
        self.stop_report: StopReport | None = None
        # set (by a signal handler, another thread) during shutdown: quick stop now
        self.quick_stop_requested = False
        # real time: garbage collection outside the cycle's work (see _loop / _idle_gc)
        self._gc_primed = False
        self._gc_tick = 0
        self._gc_every = max(1, round(1.0 / self.cycle))  # ticks between idle collections
        # real time: the tasks' watchdogs arm after this many cycles (start-up: _warm_up)
        self.startup_cycles = max(10, round(0.05 / self.cycle))
        self.gc_stats = {"collections": 0, "freed": 0, "max_ns": 0, "total_ns": 0}
        if check_invariants:
            from motionplc.runtime.invariants import InvariantChecker

            self._hooks.append(InvariantChecker())

    # -- configuration -----------------------------------------------------------------------
    def add_axis(
        self,
        name: str,
        v_max: float,
        a_max: float,
        j_max: float = math.inf,
        *,
        v_min: float | None = None,
        a_min: float | None = None,
        drive: Drive | None = None,
        task: str | None = None,
        **options: Any,
    ) -> Axis:
        """Create an axis (AXIS_REF) with its drive (an ideal in-process drive by default).

        ``v_min`` / ``a_min`` (< 0): asymmetric limits of the negative side (default
        ``-v_max`` / ``-a_max``); the axis plans with them as given.

        ``task``: name of the task whose cycle steps this axis (default: the first task
        declared). ``options`` are :class:`~motionplc.blocks.axis.AxisConfig` fields
        (``modulo``, ``following_error_limit``, ``sw_limit_pos``, ``sw_limit_neg``,
        ``home_switch``, ``home_velocity``, ``queue_depth``, ``blend_after_continuous``).
        """
        from motionplc.blocks.axis import Axis, AxisConfig
        from motionplc.fieldbus.ideal import IdealDrive

        if self._started:
            raise RuntimeError("axes must be added before the first run")
        if not isinstance(name, str) or not name or "." in name or name in self.axes:
            raise ValueError(f"axis name must be a new non-empty string without '.', got {name!r}")
        options.setdefault("queue_depth", self.queue_depth)
        cfg = AxisConfig(
            name=name, v_max=v_max, a_max=a_max, j_max=j_max, v_min=v_min, a_min=a_min, **options
        )
        ax = Axis(cfg, drive if drive is not None else IdealDrive(name))
        ax.task_name = task
        ax.replan_budget = self._budget
        self.axes[name] = ax
        self.trace.add_columns([f"{name}.{f}" for f in AXIS_FIELDS], AXIS_DTYPES)
        from motionplc.blocks.enums import AxisState

        self.trace.set_formatter(f"{name}.state", lambda x: AxisState(int(x)).name)
        return ax

    def add_group(self, name: str, axes: Sequence[str], **options: Any) -> AxesGroup:
        """Create an axes group (AXES_GROUP_REF, PLCopen Part 4) of existing axes.

        The group steps in the task of its axes (all members must share one task), after them,
        and records ``<name>.state`` (GroupState) and ``<name>.path_velocity`` in the trace.
        ``options`` are :class:`~motionplc.blocks.group.GroupConfig` fields (``queue_depth``,
        ``tolerance``, ``v_share``). The group starts in GroupDisabled with ``axes`` as members
        (MC_AddAxisToGroup / MC_RemoveAxisFromGroup change them while it is disabled).
        """
        from motionplc.blocks.enums import GroupState
        from motionplc.blocks.group import AxesGroup, GroupConfig

        if self._started:
            raise RuntimeError("groups must be added before the first run")
        if (
            not isinstance(name, str)
            or not name
            or "." in name
            or name in self.groups
            or name in self.axes
        ):
            raise ValueError(
                f"group name must be a new non-empty string without '.', not an axis name, "
                f"got {name!r}"
            )
        members = []
        for a in axes:
            if a not in self.axes:
                raise ValueError(f"group {name!r}: unknown axis {a!r}")
            members.append(self.axes[a])
        group = AxesGroup(GroupConfig(name=name, **options), [])
        for ax in members:
            err = group.add_axis(ax)
            if err:
                raise ValueError(f"group {name!r}: axis {ax.name!r} cannot join ({err.name})")
        self.groups[name] = group
        self.trace.add_columns([f"{name}.state", f"{name}.path_velocity"], GROUP_DTYPES)
        self.trace.set_formatter(f"{name}.state", lambda x: GroupState(int(x)).name)
        return group

    def add_task(
        self,
        name: str,
        program: Program,
        period: float | None = None,
        priority: int = 0,
        *,
        watchdog_time: float | None = None,
        watchdog_sensitivity: int = 1,
    ) -> Task:
        """Declare a cyclic task calling ``program(ctx)`` every ``period`` seconds.

        ``period`` defaults to the base cycle and must be a multiple of it.
        """
        if self._started:
            raise RuntimeError("tasks must be added before the first run")
        if any(t.name == name for t in self.tasks):
            raise ValueError(f"duplicate task name {name!r}")
        if not callable(program):
            raise TypeError(f"task {name!r}: program must be callable(ctx)")
        n = 1 if period is None else _ticks(f"task {name!r} period", period, self.tick_ns)
        task = Task(
            name,
            program,
            n,
            n * self.cycle,
            priority,
            len(self.tasks),
            watchdog_time,
            watchdog_sensitivity,
        )
        self.tasks.append(task)
        return task

    def add_cycle_hook(self, hook: CycleHook) -> None:
        """Call ``hook(runtime, cycle)`` after every base tick (after the trace row)."""
        self._hooks.append(hook)

    def _start(self) -> None:
        if self._started:
            return
        names = {t.name for t in self.tasks}
        for ax in self.axes.values():
            if ax.task_name is None:
                if not self.tasks:
                    raise RuntimeError(f"axis {ax.name!r} has no task: add a task first")
                ax.task_name = self.tasks[0].name
            elif ax.task_name not in names:
                raise ValueError(f"axis {ax.name!r}: unknown task {ax.task_name!r}")
            task = next(t for t in self.tasks if t.name == ax.task_name)
            task.axes.append(ax)
            ax.task_axes = task.axes  # re-sorted in place: masters step before their slaves
            bind = getattr(ax.drive, "bind_clock", None)
            if bind is not None:
                bind(self.clock.realtime)
            ax.open()
        for g in self.groups.values():
            tasks = {ax.task_name for ax in g.axes}
            if len(tasks) > 1:
                raise ValueError(
                    f"group {g.name!r}: its axes run in different tasks {sorted(tasks)}"
                )
            task_name = next(iter(tasks)) if tasks else self.tasks[0].name
            next(t for t in self.tasks if t.name == task_name).groups.append(g)
        for task in self.tasks:
            # no axes group: each axis steps and writes its drive in one go (Axis.step_write;
            # a group steps after all its task's axes and before their outputs)
            task.fused = not task.groups
        self._order = sorted(self.tasks, key=lambda t: t.sort_key)
        # every task runs every tick (the common case): no per-tick selection
        self._all_every_tick = all(t.period_ticks == 1 for t in self._order)
        self._all_names = [t.name for t in self._order]
        self._axis_list = list(self.axes.values())
        self._group_list = list(self.groups.values())
        self._started = True

    # -- running -----------------------------------------------------------------------------
    @property
    def time(self) -> float:
        """Virtual time of the next tick [s]."""
        return self.tick * self.cycle

    def run(self, seconds: float | None = None, cycles: int | None = None) -> None:
        """Run ``cycles`` base ticks, or ``seconds`` of (virtual or real) time.

        A program that raises halts its task: the task's axes go to ErrorStop (INTERNAL_ERROR)
        with a controlled stop, the cycles go on until they are at rest (or the run's end),
        then :class:`~motionplc.errors.ProgramError` is raised (the program's exception as its
        ``__cause__``). The task stays halted; the other tasks and axes run on.
        """
        if (seconds is None) == (cycles is None):
            raise TypeError("run() takes exactly one of seconds= or cycles=")
        n = round(seconds / self.cycle) if seconds is not None else int(cycles)  # type: ignore[arg-type]
        if n < 0:
            raise ValueError("run() needs a non-negative duration")
        self._loop(self.tick + n, None)

    def run_until(self, predicate: Callable[..., bool], max_seconds: float = 3600.0) -> bool:
        """Run until ``predicate()`` (or ``predicate(runtime)``) is true after a tick.

        Returns False if ``max_seconds`` elapsed first.
        """
        try:
            nparams = len(inspect.signature(predicate).parameters)
        except (TypeError, ValueError):
            nparams = 0
        pred = (lambda: predicate(self)) if nparams >= 1 else predicate
        return self._loop(self.tick + round(max_seconds / self.cycle), pred)

    def _loop(self, end_tick: int, pred: Callable[[], bool] | None) -> bool:
        self._start()
        if not self.clock.realtime:
            return self._cycles(end_tick, pred)
        # Real time: the collector never runs on its own inside the loop (a full collection
        # of a loaded process takes ~10 ms: a stalled bus). One full collection before the
        # first real-time run only (not before every run: a caller running in slices would
        # stall the bus at each slice), everything alive then frozen out of later collections,
        # and young garbage collected in the idle slack of a cycle (see _idle_gc).
        if not self._gc_primed:
            self._warm_up()
            gc.collect()
            self._gc_primed = True
        gc.freeze()
        was_enabled = gc.isenabled()
        gc.disable()
        try:
            return self._cycles(end_tick, pred)
        finally:
            if was_enabled:
                gc.enable()
            gc.unfreeze()

    def _warm_up(self) -> None:
        """Real time, before the first cycle: the start-up work that would otherwise land in
        the first cycles - the modules the kernel imports on first use, a first plan per axis
        (the planner's code paths), then one full collection (``_loop``) - and the tasks'
        watchdogs arm only after ``startup_cycles`` cycles (their first FB scans, drive
        state machines and first plans are the start-up, not the cycle time)."""
        import motionplc.blocks.cam_select  # noqa: F401 - imported by the kernel on first use
        import motionplc.blocks.superimposed  # noqa: F401
        import motionplc.blocks.sync_job  # noqa: F401
        from motionplc.planning import Limits, State, plan, plan_velocity

        for ax in self._axis_list:
            cfg = ax.cfg
            lim = Limits(cfg.v_max, cfg.a_max, cfg.j_max, v_min=-cfg.v_neg, a_min=-cfg.a_neg)
            try:  # (thrown away: only the code paths are warmed)
                plan(State(ax.p, 0.0, 0.0), State(ax.p + 1e-3 * cfg.v_max, 0.0, 0.0), lim)
                plan_velocity(State(ax.p, 0.0, 0.0), 0.5 * cfg.v_max, lim)
            except Exception:  # noqa: BLE001 - a warm-up never fails a run
                pass
        for task in self.tasks:
            task.arm_after = max(task.arm_after, self.startup_cycles)

    def _idle_gc(self, now: int, next_deadline: int) -> None:
        """Real time, called once ``_gc_every`` ticks (one second) have passed since the last
        collection: collect the youngest generation (what the cycles allocated since; reference
        cycles would otherwise pile up while the collector is off), only when at least half a
        tick of slack is left before the next deadline. Its cost is in :attr:`gc_stats`."""
        if next_deadline - now < self.tick_ns // 2:
            return
        self._gc_tick = self.tick
        freed = gc.collect(0)
        spent = self.clock.now_ns() - now
        st = self.gc_stats
        st["collections"] += 1
        st["freed"] += freed
        st["max_ns"] = max(st["max_ns"], spent)
        st["total_ns"] += spent

    def _cycles(self, end_tick: int, pred: Callable[[], bool] | None) -> bool:
        clock = self.clock
        tick_ns = self.tick_ns
        base = self.tick
        clock.start()
        while self.tick < end_tick:
            k = self.tick
            deadline = (k - base) * tick_ns
            start = clock.wait_until(deadline)
            self._run_tick(k, deadline, start)
            self.tick = k + 1
            for hook in self._hooks:
                hook(self, k)
            if clock.realtime or self.overrun_policy == "skip":
                now = clock.now_ns()
                nxt = (self.tick - base) * tick_ns
                if now > nxt and self.overrun_policy == "skip":
                    # realign to the first grid point not yet passed; count omitted cycles
                    k_new = base + -(-now // tick_ns)
                    for task in self.tasks:
                        pt = task.period_ticks
                        skipped = (k_new - 1) // pt - (self.tick - 1) // pt
                        task.omitted_cycles += max(0, skipped)
                    self.tick = min(k_new, end_tick)
                elif clock.realtime and self.tick - self._gc_tick >= self._gc_every:
                    self._idle_gc(now, nxt)
            if self._failed_tasks:  # a program raised: run on until its axes are at rest
                if self._failed_tasks_at_rest():
                    failed, self._failed_tasks = self._failed_tasks, []
                    raise failed[0].program_error  # type: ignore[misc]
                continue
            if pred is not None and pred():
                return True
        if self._failed_tasks:  # the stop goes on in the next run
            failed = self._failed_tasks[0]
            self._failed_tasks = []
            raise failed.program_error  # type: ignore[misc]
        return pred is None

    def _run_tick(self, k: int, deadline: int, start: int) -> None:
        clock = self.clock
        image = self.image
        if self._all_every_tick:
            due = self._order
            self.last_due = self._all_names
        else:
            due = [t for t in self._order if k % t.period_ticks == 0]
            self.last_due = [t.name for t in due]
        t_virtual = k * self.cycle
        budget = self._budget
        if budget is not None:
            budget.left = budget.per_cycle
        for task in due:
            t0 = clock.now_ns()
            lateness = t0 - deadline
            prev = task.last_tick
            dt = task.period if prev is None else (k - prev) * self.cycle
            task.last_tick = k
            ctx = _context(k, t_virtual, dt, task.name, image, self._spend)
            image.latch_inputs()
            axes = task.axes
            for ax in axes:
                try:
                    ax.read_inputs(t_virtual)
                except Exception as exc:  # noqa: BLE001 - a drive never ends the cycle
                    _drive_failed(ax, "read", exc)
            if task.program_error is None and not self._stopping:
                try:
                    task.program(ctx)
                except Exception as exc:  # noqa: BLE001 - the task halts, the axes stop
                    self._program_failed(task, exc)
            n_plans = planner_calls()
            if task.fused:
                for ax in axes:
                    try:
                        ax.step_write(dt, t_virtual)  # step has its own fault barrier
                    except Exception as exc:  # noqa: BLE001 - a drive never ends the cycle
                        _drive_failed(ax, "write", exc)
            else:
                for ax in axes:
                    ax.step(dt)
                for g in task.groups:
                    g.step(dt)
                for ax in axes:
                    if ax._lg_after_group is not None:  # the limit supervision of members
                        ax.guard_after_group(dt)
                    try:
                        ax.write_outputs(t_virtual)
                    except Exception as exc:  # noqa: BLE001 - a drive never ends the cycle
                        _drive_failed(ax, "write", exc)
            if planner_calls() == n_plans:
                # a quiet cycle: plan (at most) one queued move's start profile ahead of its
                # hand-over, so axes handing over in the same cycle do not plan all at once
                for ax in axes:
                    if ax._ahead and ax.plan_ahead():
                        break
            image.publish_outputs()
            t1 = clock.now_ns()
            overrun = t1 > deadline + task.period_ticks * self.tick_ns
            reason = task.record(lateness, t1 - t0, overrun)
            if reason is not None:
                self.error_reason = reason
                for ax in axes:
                    ax.raise_axis_error("WATCHDOG", reason)
        # the trace row, packed straight into the trace's staging block (no row list)
        trace = self.trace
        buf, off = trace.reserve_row()
        try:
            _PACK_HEAD(buf, off, k, t_virtual)
            off += 16
            edges = trace if self.trace_edges else None
            for ax in self._axis_list:
                ax.trace_cycle(buf, off, edges, k)  # its row part, then its FB edges
                off += _AXIS_ROW
            for g in self._group_list:
                _GROUP_PACK(buf, off, *g.trace_values())
                off += _GROUP_ROW
        except BaseException:  # (Ctrl-C inside the row): no half-written row in the trace
            trace.unreserve_row()
            raise
        if edges is not None:
            for g in self._group_list:
                g.emit_fb_edges(trace, k)

    def _program_failed(self, task: Task, exc: Exception) -> None:
        """A program raised: halt its task (the program is not called again), put the task's
        axes in ErrorStop with a controlled stop, and have ``run`` raise once they are at
        rest."""
        where = ""
        package = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
        for frame in reversed(traceback.extract_tb(exc.__traceback__)):
            if not os.path.abspath(frame.filename).startswith(package + os.sep):
                where = f"{frame.filename}:{frame.lineno}"
                break
        reason = f"task {task.name!r}: program raised {type(exc).__name__}: {exc}" + (
            f" ({where})" if where else ""
        )
        task.program_error = ProgramError(reason, task.name, where)
        task.program_error.__cause__ = exc
        self.error_reason = self.error_reason or reason
        self._failed_tasks.append(task)
        for ax in task.axes:
            ax.raise_axis_error("INTERNAL_ERROR", reason)

    def _failed_tasks_at_rest(self) -> bool:
        return all(
            ax.active is None and ax.v == 0.0 for task in self._failed_tasks for ax in task.axes
        )

    # -- the controlled stop at the end of a run ---------------------------------------------
    def shutdown(
        self,
        reason: str = "end of run",
        *,
        margin: float = STOP_MARGIN,
        disable_time: float = DISABLE_TIME,
    ) -> StopReport:
        """End the run under control: bring every axis and group to standstill, then switch
        the drives off, cycling on (programs are no longer called; the trace, the drives and
        the invariant checks see those cycles as any other).

        1. Stop: every group in motion gets an MC_GroupStop (along its path, the members'
           limits), every other axis in motion an MC_Stop with its own deceleration and jerk
           limits (a_max / |a_min|, j_max; couplings and superimposed motion end, the slave
           brakes within its own limits); an ErrorStop ramp runs on. Cycles until every axis
           is at rest, at most ``2 x`` the estimated stop time ``+ margin``.
        2. Power off: the groups are disabled, every axis is switched off (MC_Power off: a
           CiA 402 drive goes Operation Enabled -> Switched On -> Ready to Switch On through
           its controlword, a Modbus drive the same through its command register); cycles
           until every drive reports disabled or has lost communication, at most
           ``disable_time``.

        ``quick_stop_requested`` (set by a signal handler; a ``KeyboardInterrupt`` during the
        stop sets it too) turns the running stops into quick stops: every axis still moving
        goes to ErrorStop QUICK_STOP (its error ramp: its own limits, no MC_Stop to release),
        every group in motion to GroupErrorStop QUICK_STOP (along its path), the bound is
        that stop time, and the drives are switched off as soon as the axes are at rest.
        Axes still moving or drives still enabled at a bound are reported (``StopReport``)
        and left to their drives' own reaction. Idempotent: a second call returns the first
        report. Returns the report (also ``stop_report``)."""
        if self.stop_report is not None:
            return self.stop_report
        report = StopReport(reason=reason)
        self.stop_report = report
        if not self._started or not self.axes:
            return report
        self._stopping = True
        self._failed_tasks = []  # the stop below covers every axis
        first = self.tick
        quick = False

        def moving() -> bool:
            return any(
                ax.active is not None or ax.v != 0.0 or ax.a != 0.0 for ax in self._axis_list
            ) or any(g.moving for g in self._group_list)

        bound = self._issue_stops(False) * 2.0 + margin
        report.bound = bound
        end = self.tick + max(1, math.ceil(bound / self.cycle))
        while moving() and self.tick < end:
            if self.quick_stop_requested and not quick:
                quick = report.quick = True
                bound = (self.tick - first) * self.cycle + self._issue_stops(True) + 2 * self.cycle
                report.bound = bound
                end = first + max(1, math.ceil(bound / self.cycle))
                continue
            try:
                self._loop(
                    end, lambda q=quick: not moving() or (self.quick_stop_requested and not q)
                )
            except KeyboardInterrupt:  # (a second Ctrl-C without a handler): quick stop
                self.quick_stop_requested = True
            except ProgramError:  # (cannot happen: no program runs) - defensive
                pass
        report.not_at_rest = [
            ax.name
            for ax in self._axis_list
            if ax.state is not S.DISABLED and (ax.active is not None or ax.v != 0.0)
        ]
        # power off, in order: the groups, then every axis (the drives' shutdown sequence)
        for g in self._group_list:
            if g.state is not GroupState.GROUP_DISABLED and not g.moving:
                g.disable()
        for ax in self._axis_list:
            ax.set_power(False)
        end_off = self.tick + max(2, math.ceil(disable_time / self.cycle))

        def enabled() -> list[str]:
            return [ax.name for ax in self._axis_list if ax.drive_enabled and ax.comm_ok]

        while enabled() and self.tick < end_off:
            try:
                self._loop(end_off, lambda: not enabled())
            except KeyboardInterrupt:
                break
        report.not_disabled = enabled()
        report.errors = {
            ax.name: f"{ax.axis_error.name}: {ax.axis_error_reason}"
            for ax in self._axis_list
            if ax.axis_error is not ErrorID.OK
        }
        report.cycles = self.tick - first
        report.seconds = report.cycles * self.cycle
        return report

    def _issue_stops(self, quick: bool) -> float:
        """Command the stops of :meth:`shutdown` (quick: the fastest within the system
        limits); returns the longest estimated stop time [s]."""
        from motionplc.blocks.group import GroupCommand

        longest = 0.0
        for g in self._group_list:
            if g.moving or g.state in (GroupState.GROUP_MOVING, GroupState.GROUP_STOPPING):
                if g.state is not GroupState.GROUP_ERROR_STOP and (
                    quick or g.state is not GroupState.GROUP_STOPPING
                ):
                    if quick:
                        g.raise_group_error(ErrorID.QUICK_STOP, "quick stop requested")
                    else:
                        h = g.submit(GroupCommand(kind="stop"))
                        h.hold = False
            for ax in g.axes:
                cfg = ax.cfg_system
                longest = max(longest, stop_time(ax.v, ax.a, min(cfg.a_max, cfg.a_neg), cfg.j_max))
        for ax in self._axis_list:
            cfg = ax.cfg_system
            longest = max(longest, stop_time(ax.v, ax.a, min(cfg.a_max, cfg.a_neg), cfg.j_max))
            group = ax.group
            if group is not None and group.enabled:
                continue  # stopped along its group's path
            if ax.state is S.DISABLED:
                continue
            still = ax.active is None and ax.v == 0.0 and ax.sup is None and not ax.mq.queue
            if quick:
                if not still and ax.state is not S.ERROR_STOP:
                    ax.raise_axis_error("QUICK_STOP", "quick stop requested during the stop")
                continue
            if still or ax.state is S.ERROR_STOP:
                continue  # at rest, or its ErrorStop ramp runs
            if ax.state is S.STOPPING and ax.active is not None:
                for h in ax.mq.stops:
                    h.hold = False  # an MC_Stop brakes already: released at rest
                continue
            h = ax.submit(Command(kind="stop"))
            h.hold = False
            if h.terminal and h.status is not Status.DONE:  # refused: the axis' own error stop
                ax.raise_axis_error(
                    "INTERNAL_ERROR", f"end of run: MC_Stop refused ({h.error_id.name})"
                )
        return longest

    def _spend(self, seconds: float) -> None:
        self.clock.spend(round(seconds * 1e9))

    # -- introspection -----------------------------------------------------------------------
    def stats(self) -> dict[str, TaskStats]:
        """Timing statistics per task."""
        return {t.name: t.stats() for t in self.tasks}

    def close(self) -> None:
        """Close every drive (idempotent)."""
        for ax in self.axes.values():
            ax.close()

    def __enter__(self) -> Runtime:
        return self

    def __exit__(self, *exc: object) -> None:
        """``with Runtime(...) as rt:``: the end of the block (also by an exception) is a
        controlled stop (:meth:`shutdown`), then the drives close."""
        try:
            if self._started:
                why = "end of block" if exc[0] is None else f"exception {exc[0].__name__}"  # type: ignore[union-attr]
                self.shutdown(why)
        finally:
            self.close()
