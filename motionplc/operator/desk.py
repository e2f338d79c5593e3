"""The operator's desk: the part of the operator interfaces that lives inside the cycle.

Two things cross between the cycle and an operator server (OPC UA, the web HMI), each one way:

* **Snapshot** (cycle -> server): after every ``publish_every``-th tick a cycle hook builds one
  immutable :class:`Snapshot` of every axis, group, task and the running program (plain floats,
  ints and strings, copied from the live objects in that hook) and swaps it into
  :attr:`OperatorDesk.snapshot` (one reference assignment: atomic). A server only ever reads the
  last published snapshot, never the live axes, so everything it shows belongs to one cycle.
* **Requests** (server -> cycle): :meth:`OperatorDesk.submit` appends a :class:`Request` to the
  queue of the task that owns its axis or group (a ``collections.deque``: append/popleft are
  atomic). The desk's program, attached to every task after the task's own programs, takes
  the requests out in its program phase and drives its own FB instances with them (MC_Power,
  MC_Reset, MC_Jog, MC_Halt, MC_Stop, MC_SetOverride, MC_GroupInterrupt / Continue / Halt /
  Stop / SetOverride, a G-code MDI line): the same FB input checks and state machine as a
  program's call, and their output edges are in the trace (FB names ``op.<target>.<FB>``).
  The outcome of the FB's first scan answers the request (:meth:`Request.reply`, called in the
  cycle; the server turns it into the method's status).

Nothing here blocks: the cycle never waits for a server and never takes a lock a server holds.
"""

from __future__ import annotations

import logging
import math
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from motionplc.blocks.enums import AxisState, ErrorID, GroupState, JogMode

if TYPE_CHECKING:
    from motionplc.config import Machine
    from motionplc.runtime import CycleContext, Runtime

__all__ = [
    "AXIS_METHODS",
    "GROUP_METHODS",
    "PROGRAM_METHODS",
    "AxisView",
    "GroupView",
    "OperatorDesk",
    "ProgramView",
    "Request",
    "Snapshot",
    "TaskView",
]

LOG = logging.getLogger("motionplc.operator")

# the operator methods by target kind: name -> the arguments (name, type, description)
AXIS_METHODS: dict[str, tuple[tuple[str, str, str], ...]] = {
    "Power": (("Enable", "bool", "true: switch the axis on, false: off (MC_Power.Enable)"),),
    "Reset": (),
    "Jog": (
        ("Direction", "int", "+1 or -1"),
        ("Distance", "float", "the inching step [m or rad] (> 0)"),
        ("Velocity", "float", "[m/s or rad/s]; 0: the axis' slow jog velocity"),
    ),
    "Halt": (),
    "Stop": (),
    "SetOverride": (("Factor", "float", "velocity factor (MC_SetOverride.VelFactor)"),),
}
GROUP_METHODS: dict[str, tuple[tuple[str, str, str], ...]] = {
    "FeedHold": (),
    "FeedContinue": (),
    "Halt": (),
    "Stop": (),
    "SetOverride": (("Factor", "float", "path velocity factor in [0.001, 1]"),),
    "Mdi": (("Line", "str", "one G-code line, run on this group"),),
}
PROGRAM_METHODS: dict[str, tuple[tuple[str, str, str], ...]] = {
    "Start": (),
    "Stop": (),
}


def of_kind(kind: str, x: Any) -> bool:
    """Is ``x`` a value of an argument kind of the method tables ("bool", "int", "float",
    "str")? (A bool is not an int here.)"""
    if kind == "bool":
        return isinstance(x, bool)
    if kind == "int":
        return isinstance(x, int) and not isinstance(x, bool)
    if kind == "float":
        return isinstance(x, (int, float)) and not isinstance(x, bool)
    return isinstance(x, str)


# ------------------------------------------------------------------------------ snapshot
@dataclass(frozen=True, slots=True)
class AxisView:
    """One axis at the end of a cycle (set values, feedback, PLCopen state, error)."""

    name: str
    state: int  # AxisState
    set_position: float
    set_velocity: float
    set_acceleration: float
    actual_position: float
    actual_velocity: float
    actual_acceleration: float
    following_error: float
    error_id: int  # ErrorID of the axis error (0: none)
    error_text: str
    powered: bool
    override: float


@dataclass(frozen=True, slots=True)
class GroupView:
    """One axes group at the end of a cycle."""

    name: str
    state: int  # GroupState
    path_velocity: float
    position: tuple[float, ...]
    error_id: int
    error_text: str
    override: float


@dataclass(frozen=True, slots=True)
class TaskView:
    """The statistics of one task (execution times and lateness in s)."""

    name: str
    cycle_count: int
    exec_last: float
    exec_max: float
    exec_mean: float
    lateness_max: float
    overruns: int


@dataclass(frozen=True, slots=True)
class ProgramView:
    """The loaded program: ``kind`` (gcode, sequence, python, mdi, none), ``state`` (idle,
    running, stopped, finished, failed), the G-code line of the last move started, moves run
    of the total (``progress`` in [0, 1])."""

    kind: str = "none"
    path: str = ""
    state: str = "idle"
    line: int = 0
    lines_run: int = 0
    lines_total: int = 0
    progress: float = 0.0
    message: str = ""


@dataclass(frozen=True, slots=True)
class Snapshot:
    """Everything an operator sees, from one cycle: ``cycle`` (the tick), ``t`` (its virtual
    time [s]), ``clock_ns`` (the runtime clock when it was published: real time, ns since the
    start of the run), ``seq`` (1, 2, ... per publication)."""

    seq: int
    cycle: int
    t: float
    clock_ns: int
    axes: tuple[AxisView, ...]
    groups: tuple[GroupView, ...]
    tasks: tuple[TaskView, ...]
    program: ProgramView


# ------------------------------------------------------------------------------ requests
@dataclass(slots=True)
class Request:
    """One operator action: ``method`` on ``target`` (``axis:<name>``, ``group:<name>`` or
    ``program``), its arguments, the ``user`` (for the log). ``on_reply(ok, error_id, text,
    cycle)`` is called once, in the cycle that acts on it (or by :meth:`OperatorDesk.close`)."""

    target: str
    method: str
    args: tuple[Any, ...] = ()
    user: str = ""
    on_reply: Callable[[bool, int, str, int], None] | None = None
    cycle: int = -1  # the cycle that acted on it
    clock_ns: int = -1  # the runtime clock at that cycle's program phase
    ok: bool | None = None
    error_id: int = 0
    text: str = ""

    def reply(self, ok: bool, error_id: int, text: str, cycle: int, clock_ns: int) -> None:
        if self.ok is not None:
            return
        self.ok, self.error_id, self.text = ok, int(error_id), text
        self.cycle, self.clock_ns = cycle, clock_ns
        if self.on_reply is not None:
            try:
                self.on_reply(ok, int(error_id), text, cycle)
            except Exception:  # noqa: BLE001 - a server's callback never fails the cycle
                LOG.exception("operator reply callback failed")


class _RefusedError(Exception):
    """A request refused before an FB was called (unknown target, bad argument type)."""

    def __init__(self, error_id: ErrorID, text: str) -> None:
        super().__init__(text)
        self.error_id = error_id


def _arg(req: Request, i: int, kind: str, name: str) -> Any:
    if len(req.args) <= i:
        raise _RefusedError(ErrorID.INTERNAL_ERROR, f"{req.method}: argument {name} is missing")
    v = req.args[i]
    if kind == "bool":
        if not isinstance(v, bool):
            raise _RefusedError(ErrorID.INTERNAL_ERROR, f"{name} must be a Boolean, got {v!r}")
        return v
    if kind == "int":
        if isinstance(v, bool) or not isinstance(v, int):
            raise _RefusedError(ErrorID.INVALID_DIRECTION, f"{name} must be an integer, got {v!r}")
        return v
    if kind == "float":
        if isinstance(v, bool) or not isinstance(v, (int, float)):
            raise _RefusedError(ErrorID.INTERNAL_ERROR, f"{name} must be a number, got {v!r}")
        return float(v)
    if not isinstance(v, str):
        raise _RefusedError(ErrorID.INTERNAL_ERROR, f"{name} must be a string, got {v!r}")
    return v


# ------------------------------------------------------------------------------ FB drivers
class _Pulse:
    """An Execute FB driven by requests: the rising edge in the request's cycle, Execute held
    until Done / Error / CommandAborted, then one scan with Execute FALSE."""

    def __init__(self, fb: Any) -> None:
        self.fb = fb
        self.on = False

    def fire(self, **inputs: Any) -> Any:
        fb = self.fb
        if self.on:  # a re-trigger: release first (the next scan is the new rising edge)
            fb(execute=False)
        fb(execute=True, **inputs)
        self.on = True
        return fb

    def step(self) -> None:
        if not self.on:
            return
        fb = self.fb
        if fb.done or fb.error or getattr(fb, "command_aborted", False):
            fb(execute=False)
            self.on = False
        else:
            fb()


class _Enable:
    """An Enable FB held at the operator's last value (called every cycle once used)."""

    def __init__(self, fb: Any) -> None:
        self.fb = fb
        self.used = False

    def set(self, **inputs: Any) -> Any:
        self.used = True
        return self.fb(**inputs)

    def step(self) -> None:
        if self.used:
            self.fb()


class _AxisDesk:
    def __init__(self, ax: Any) -> None:
        from motionplc.blocks import MC_Halt, MC_Jog, MC_Power, MC_Reset, MC_SetOverride, MC_Stop

        n = ax.name
        self.axis = ax
        self.power = _Enable(MC_Power(name=f"op.{n}.MC_Power", axis=ax))
        self.override = _Enable(MC_SetOverride(name=f"op.{n}.MC_SetOverride", axis=ax))
        self.reset = _Pulse(MC_Reset(name=f"op.{n}.MC_Reset", axis=ax))
        self.halt = _Pulse(MC_Halt(name=f"op.{n}.MC_Halt", axis=ax))
        self.stop = _Pulse(MC_Stop(name=f"op.{n}.MC_Stop", axis=ax))
        self.jog = MC_Jog(name=f"op.{n}.MC_Jog", axis=ax, mode=JogMode.INCHING)
        self.jogging = False

    def step(self) -> None:
        self.power.step()
        self.override.step()
        self.reset.step()
        self.halt.step()
        self.stop.step()
        if self.jogging:
            j = self.jog
            if j.done or j.error or j.command_aborted:
                j(jog_forward=False, jog_backward=False)
                self.jogging = False
            else:
                j()

    def act(self, req: Request) -> Any:
        m = req.method
        if m == "Power":
            return self.power.set(enable=_arg(req, 0, "bool", "Enable"))
        if m == "Reset":
            return self.reset.fire()
        if m == "Halt":
            return self.halt.fire()
        if m == "Stop":
            return self.stop.fire()
        if m == "SetOverride":
            f = _arg(req, 0, "float", "Factor")
            return self.override.set(enable=True, vel_factor=f)
        if m == "Jog":
            return self._jog(req)
        raise _RefusedError(ErrorID.INTERNAL_ERROR, f"axis {self.axis.name!r} has no method {m!r}")

    def _jog(self, req: Request) -> Any:
        from motionplc.blocks.jog import jog_velocity

        d = _arg(req, 0, "int", "Direction")
        dist = _arg(req, 1, "float", "Distance")
        vel = _arg(req, 2, "float", "Velocity") if len(req.args) > 2 else 0.0
        if d not in (1, -1):
            raise _RefusedError(ErrorID.INVALID_DIRECTION, f"Direction must be +1 or -1, got {d!r}")
        if vel == 0.0:
            vel = jog_velocity(self.axis.cfg, JogMode.STANDARD_SLOW, float(d))
        j = self.jog
        if self.jogging:  # one step at a time: release, the new press next
            j(jog_forward=False, jog_backward=False)
        j(
            jog_forward=d > 0,
            jog_backward=d < 0,
            mode=JogMode.INCHING,
            position=dist,
            velocity=vel,
        )
        self.jogging = True
        return j


class _GroupDesk:
    def __init__(self, desk: OperatorDesk, group: Any) -> None:
        from motionplc.blocks.group_blocks import (
            MC_GroupContinue,
            MC_GroupHalt,
            MC_GroupInterrupt,
            MC_GroupSetOverride,
            MC_GroupStop,
        )

        n = group.name
        self.desk = desk
        self.group = group
        self.hold = _Pulse(MC_GroupInterrupt(name=f"op.{n}.MC_GroupInterrupt", axes_group=group))
        self.cont = _Pulse(MC_GroupContinue(name=f"op.{n}.MC_GroupContinue", axes_group=group))
        self.halt = _Pulse(MC_GroupHalt(name=f"op.{n}.MC_GroupHalt", axes_group=group))
        self.stop = _Pulse(MC_GroupStop(name=f"op.{n}.MC_GroupStop", axes_group=group))
        self.override = _Enable(
            MC_GroupSetOverride(name=f"op.{n}.MC_GroupSetOverride", axes_group=group)
        )

    def step(self) -> None:
        self.hold.step()
        self.cont.step()
        self.halt.step()
        self.stop.step()
        self.override.step()

    def act(self, req: Request, ctx: CycleContext) -> Any:
        m = req.method
        if m == "FeedHold":
            return self.hold.fire()
        if m == "FeedContinue":
            return self.cont.fire()
        if m == "Halt":
            return self.halt.fire()
        if m == "Stop":
            return self.stop.fire()
        if m == "SetOverride":
            return self.override.set(enable=True, vel_factor=_arg(req, 0, "float", "Factor"))
        if m == "Mdi":
            return self.desk._mdi(self.group.name, _arg(req, 0, "str", "Line"), ctx)
        raise _RefusedError(
            ErrorID.INTERNAL_ERROR, f"group {self.group.name!r} has no method {m!r}"
        )


class _Accepted:
    """The outcome of a request that is not an FB call (program start/stop, MDI)."""

    error = False
    error_id = ErrorID.OK
    error_text = ""


# ------------------------------------------------------------------------------ the desk
class OperatorDesk:
    """The in-cycle side of the operator interfaces of a :class:`~motionplc.config.Machine`.

    ``publish_every``: ticks between two snapshots (>= 1). ``program``: the loaded program's
    runner (a G-code, sequence or Python runner) that the operator starts and stops;
    ``program_task`` its task; ``autostart``: it runs from the first cycle (else it waits for
    the operator's Start). Call :meth:`install` before the first cycle.
    """

    def __init__(
        self,
        machine: Machine,
        *,
        publish_every: int = 10,
        program: Any = None,
        program_task: str | None = None,
        autostart: bool = True,
        audit_size: int = 10_000,
    ) -> None:
        if type(publish_every) is not int or publish_every < 1:
            raise ValueError(f"publish_every must be an integer >= 1, got {publish_every!r}")
        self.machine = machine
        self.rt: Runtime = machine.runtime
        self.publish_every = publish_every
        self.snapshot: Snapshot | None = None
        self._seq = 0
        self._queues: dict[str, deque[Request]] = {}
        self._task_of: dict[str, str] = {}
        self._axes: dict[str, _AxisDesk] = {}
        self._groups: dict[str, _GroupDesk] = {}
        self.audit: deque[tuple[int, str, str, str, tuple[Any, ...], bool, str]] = deque(
            maxlen=audit_size
        )
        self.program = program
        self.program_task = program_task
        self.program_state = "idle" if program is None else ("running" if autostart else "idle")
        self._mdi_runner: Any = None
        self._mdi_group = ""
        self._mdi_line = ""
        self._installed = False
        self._layout: Any = None
        self.publish_log: deque[tuple[int, int]] = deque(maxlen=100_000)  # (cycle, clock_ns)

    # -- set-up ------------------------------------------------------------------------------
    def install(self) -> None:
        """Attach the desk's program to every task (after the task's programs) and the
        snapshot hook to the runtime; publish the first snapshot."""
        if self._installed:
            return
        self._installed = True
        cfg = self.machine.config
        tasks = [t.name for t in cfg.runtime.tasks]
        first = tasks[0]
        for spec in cfg.axes:
            self._task_of[f"axis:{spec.name}"] = spec.task or first
        for g in cfg.groups:
            self._task_of[f"group:{g.name}"] = self._task_of.get(f"axis:{g.axes[0]}", first)
        self._task_of["program"] = self.program_task or first
        for name in tasks:
            self._queues[name] = deque()
            self.machine.attach(self._make_program(name), name)
        for name, ax in self.machine.axes.items():
            self._axes[name] = _AxisDesk(ax)
        for name, g in self.machine.axes_groups.items():
            self._groups[name] = _GroupDesk(self, g)
        self.rt.add_cycle_hook(self._hook)
        self._publish(self.rt.tick - 1)

    @property
    def layout(self) -> Any:
        """The machine's :class:`~motionplc.operator.board.Layout` (axes, groups, tasks in the
        snapshot's order; after :meth:`install`)."""
        if self._layout is None:
            from motionplc.operator.board import Layout

            assert self.snapshot is not None, "install the desk first"
            self._layout = Layout.of(self.machine, self.snapshot)
        return self._layout

    def task_of(self, target: str) -> str | None:
        return self._task_of.get(target)

    # -- the server side ---------------------------------------------------------------------
    def submit(self, req: Request) -> bool:
        """Queue ``req`` for the cycle (thread-safe, never blocks). False (and a reply) when
        the target is unknown."""
        task = self._task_of.get(req.target)
        if task is None:
            req.reply(False, ErrorID.INTERNAL_ERROR, f"no such target {req.target!r}", -1, -1)
            return False
        self._queues[task].append(req)
        return True

    def close(self, reason: str = "the machine stopped") -> None:
        """Answer every request still queued (the cycle will not run again)."""
        for q in self._queues.values():
            while q:
                q.popleft().reply(False, ErrorID.INTERNAL_ERROR, reason, -1, -1)

    # -- the cycle side ----------------------------------------------------------------------
    def _make_program(self, task: str) -> Callable[[CycleContext], None]:
        queue = self._queues[task]
        axes: list[_AxisDesk] = []
        groups: list[_GroupDesk] = []
        runs_program = self._task_of["program"] == task

        def program(ctx: CycleContext) -> None:
            if not axes and not groups:  # bound on the first call (the desks exist by then)
                axes.extend(d for n, d in self._axes.items() if self._task_of[f"axis:{n}"] == task)
                groups.extend(
                    d for n, d in self._groups.items() if self._task_of[f"group:{n}"] == task
                )
            if runs_program:
                self._run_program(ctx)
            for d in axes:
                d.step()
            for g in groups:
                g.step()
            while queue:
                self._act(queue.popleft(), ctx)

        return program

    def _act(self, req: Request, ctx: CycleContext) -> None:
        now = self.rt.clock.now_ns()
        try:
            kind, _, name = req.target.partition(":")
            if kind == "axis":
                fb = self._axes[name].act(req)
            elif kind == "group":
                fb = self._groups[name].act(req, ctx)
            else:
                fb = self._program_request(req, ctx)
        except _RefusedError as exc:
            ok, eid, text = False, exc.error_id, str(exc)
        except Exception as exc:  # noqa: BLE001 - an operator request never fails the cycle
            ok, eid, text = False, ErrorID.INTERNAL_ERROR, f"{type(exc).__name__}: {exc}"
        else:
            ok = not fb.error
            eid = fb.error_id if fb.error else ErrorID.OK
            text = fb.error_text if fb.error else ""
            if fb.error and not text:
                text = ErrorID(eid).name
        eid = ErrorID(int(eid)) if int(eid) in ErrorID._value2member_map_ else eid
        name = eid.name if isinstance(eid, ErrorID) else str(int(eid))
        if not ok and name not in text:
            text = f"{name} (0x{int(eid):04X}): {text}"
        self.audit.append((ctx.cycle, req.user, req.target, req.method, req.args, ok, text))
        LOG.info(
            "operator %s: %s.%s%s at cycle %d: %s",
            req.user or "?",
            req.target,
            req.method,
            req.args,
            ctx.cycle,
            "accepted" if ok else f"refused: {text}",
        )
        req.reply(ok, int(eid), text, ctx.cycle, now)

    # -- programs ----------------------------------------------------------------------------
    def load(self, program: Any, *, user: str = "", autostart: bool = False) -> Request:
        """Queue the loading of ``program`` (a runner: ``program(ctx)`` every cycle, ``over``
        once done) as the operator's program, replacing one that is not running; it takes
        effect in the next cycle (the returned request's ``ok`` says whether it was taken)."""
        req = Request("program", "Load", (program, bool(autostart)), user)
        self.submit(req)
        return req

    def _program_request(self, req: Request, ctx: CycleContext) -> Any:
        if req.method == "Load":
            if self.program_state == "running" or self._mdi_runner is not None:
                raise _RefusedError(ErrorID.INTERNAL_ERROR, "a program is running (stop it first)")
            self.program = req.args[0]
            self.program_state = "running" if req.args[1] else "idle"
            return _Accepted()
        if req.method == "Start":
            if self.program is None:
                raise _RefusedError(ErrorID.INTERNAL_ERROR, "no program is loaded")
            if self.program_state == "running":
                raise _RefusedError(ErrorID.INTERNAL_ERROR, "the program is already running")
            if self.program_state != "idle":
                raise _RefusedError(
                    ErrorID.INTERNAL_ERROR,
                    f"the program is {self.program_state}: it runs once (load it again)",
                )
            if self._mdi_runner is not None:
                raise _RefusedError(ErrorID.INTERNAL_ERROR, "an MDI line is running")
            self.program_state = "running"
            return _Accepted()
        if req.method == "Stop":
            if self.program_state != "running" and self._mdi_runner is None:
                raise _RefusedError(ErrorID.INTERNAL_ERROR, f"the program is {self.program_state}")
            if self._mdi_runner is not None:
                self._stop_program_axes(self._mdi_runner)
                self._mdi_runner = None
            if self.program_state == "running":
                self.program_state = "stopped"
                self._stop_program_axes(self.program)
            return _Accepted()
        raise _RefusedError(ErrorID.INTERNAL_ERROR, f"the program has no method {req.method!r}")

    def _stop_program_axes(self, runner: Any) -> None:
        """A stopped program: its group (or axes) stop under control (MC_GroupStop / MC_Stop
        of the desk), the program is no longer called."""
        group = getattr(getattr(runner, "group", None), "name", None)
        if group in self._groups:
            self._groups[group].stop.fire()
            return
        job = getattr(runner, "job", None) or getattr(runner, "sequence", None)
        for name in getattr(job, "axes", ()) or self._axes:
            if name in self._axes and self._axes[name].axis.state not in (
                AxisState.DISABLED,
                AxisState.STANDSTILL,
                AxisState.ERROR_STOP,
            ):
                self._axes[name].stop.fire()

    def _run_program(self, ctx: CycleContext) -> None:
        if self._mdi_runner is not None:
            r = self._mdi_runner
            r(ctx)
            if r.over:
                self._mdi_runner = None
                if r.failures:
                    LOG.warning("operator MDI %r failed: %s", self._mdi_line, r.failures[0])
        if self.program is not None and self.program_state == "running":
            p = self.program
            p(ctx)
            if getattr(p, "over", False):
                self.program_state = "failed" if getattr(p, "failed", False) else "finished"

    def _mdi(self, group: str, line: str, ctx: CycleContext) -> Any:
        from motionplc.gcode import GcodeError, parse_gcode
        from motionplc.gcode_runner import GcodeJob, GcodeRunner, setup_from_config

        if self.program_state == "running":
            raise _RefusedError(ErrorID.INTERNAL_ERROR, "a program is running (stop it first)")
        if self._mdi_runner is not None:
            raise _RefusedError(ErrorID.INTERNAL_ERROR, f"MDI line {self._mdi_line!r} still runs")
        if "\n" in line or "\r" in line or not line.strip():
            raise _RefusedError(ErrorID.INTERNAL_ERROR, "Line must be one non-empty G-code line")
        cfg = self.machine.config
        if self._task_of["program"] != self._task_of[f"group:{group}"]:
            raise _RefusedError(
                ErrorID.INTERNAL_ERROR, f"group {group!r} is not in the program's task"
            )
        try:
            setup = setup_from_config(cfg, group, "<mdi>")
            prog = parse_gcode(line, "<mdi>", setup=setup)
            spec = cfg.group(group)
            g = getattr(cfg, "gcode", None) or {}
            job = GcodeJob(
                "<mdi>",
                prog,
                group,
                tuple(spec.axes),
                self._task_of[f"group:{group}"],
                ctx.t + 3600.0,
                None,
                tuple((k, v) for k, v in (g.get("coolant") or {}).items() if v),
            )
            runner = GcodeRunner(job, self.machine)
        except GcodeError as exc:
            raise _RefusedError(ErrorID.INTERNAL_ERROR, f"G-code: {exc}") from None
        self._mdi_runner = runner
        self._mdi_group = group
        self._mdi_line = line
        runner(ctx)  # its first scan (powers, enables)
        if runner.failures:
            self._mdi_runner = None
            raise _RefusedError(ErrorID.INTERNAL_ERROR, runner.failures[0])
        return _Accepted()

    # -- the snapshot ------------------------------------------------------------------------
    def _hook(self, rt: Runtime, cycle: int) -> None:
        if cycle % self.publish_every == 0:
            self._publish(cycle)

    def _publish(self, cycle: int) -> None:
        rt = self.rt
        axes = []
        for ax in rt._axis_list if rt._started else rt.axes.values():
            eid = ax.axis_error
            axes.append(
                AxisView(
                    ax.name,
                    int(ax.state),
                    ax.p,
                    ax.v,
                    ax.a,
                    ax.act_p,
                    ax.act_v,
                    ax.act_a,
                    ax.following_error,
                    int(eid),
                    ax.axis_error_reason if eid else "",
                    bool(ax.power_request),
                    float(ax.override[0]),
                )
            )
        groups = []
        for g in rt.groups.values():
            groups.append(
                GroupView(
                    g.name,
                    int(g.state),
                    g.path_velocity,
                    tuple(g.position()),
                    int(g.error_id),
                    g.error_reason if g.error_id else "",
                    float(g.override),
                )
            )
        tasks = []
        for t in rt.tasks:
            n = t.cycle_count
            tasks.append(
                TaskView(
                    t.name,
                    n,
                    t.exec_last_ns * 1e-9,
                    t.exec_max_ns * 1e-9,
                    t.exec_sum_ns / n * 1e-9 if n else 0.0,
                    t.lat_max_ns * 1e-9 if n else 0.0,
                    t.overruns,
                )
            )
        self._seq += 1
        now = rt.clock.now_ns()
        self.snapshot = Snapshot(
            self._seq,
            cycle,
            max(cycle, 0) * rt.cycle,
            now,
            tuple(axes),
            tuple(groups),
            tuple(tasks),
            self._program_view(),
        )
        self.publish_log.append((cycle, now))

    def _program_view(self) -> ProgramView:
        r = self._mdi_runner
        if r is not None:
            return _runner_view(r, "mdi", "running", self._mdi_line)
        p = self.program
        if p is None:
            return ProgramView()
        return _runner_view(p, _kind(p), self.program_state, "")


def _kind(p: Any) -> str:
    name = type(p).__name__
    return {"GcodeRunner": "gcode", "SequenceRunner": "sequence"}.get(name, "python")


def _runner_view(p: Any, kind: str, state: str, message: str) -> ProgramView:
    job = getattr(p, "job", None)
    path = str(getattr(job, "path", "") or getattr(getattr(p, "sequence", None), "path", ""))
    run = int(getattr(p, "lines_run", getattr(p, "steps_done", 0)) or 0)
    total = int(getattr(p, "lines_total", 0) or 0)
    line = 0
    flight = getattr(p, "_flight", None)
    if flight:
        mv = getattr(flight[0], "move", None)
        line = int(getattr(mv, "line", 0) or 0)
    fails = getattr(p, "failures", None)
    if fails:
        message = str(fails[0])[:500]
    progress = run / total if total > 0 else (1.0 if state == "finished" else 0.0)
    return ProgramView(kind, path, state, line, run, total, min(progress, 1.0), message)


def state_name(kind: str, value: int) -> str:
    """The PLCopen state name of an AxisState / GroupState value."""
    try:
        return (AxisState if kind == "axis" else GroupState)(value).name
    except ValueError:
        return str(value)


def finite(x: float) -> float:
    """``x``, or 0.0 when not finite (OPC UA clients show NaN badly)."""
    return x if math.isfinite(x) else 0.0
