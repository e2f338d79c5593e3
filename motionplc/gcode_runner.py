"""G-code programs on an axes group: ``motionplc run CONFIG program.ngc [--group NAME]``.

The program (:mod:`motionplc.gcode`, the RS274/NGC interpreter) runs on one configured axes
group; the machine (:class:`~motionplc.gcode.MachineSetup`) comes from the configuration: the
group's members are the axes X, Y, Z in group order unless ``gcode.axes`` maps letters to
members (``{X: x, Y: y, Z: z, A: a}``; a member in rad is a rotary axis, A/B/C in degrees in
the program), start-up units, plane, work offsets, tool table file, the spindle axis and the
coolant / digital outputs (``gcode:`` block, :func:`setup_from_config`).

:class:`GcodeRunner` is a task program (``runner(ctx)`` every cycle):

1. **Power** every member (MC_Power, and the spindle axis if any), **Enable** the group
   (MC_GroupEnable if GroupDisabled).
2. **Moves**, streaming: the interpreter runs as the group consumes the moves (at most
   ``window`` group FBs in flight, ``per_cycle`` new per cycle; nothing holds the whole
   program's moves). Each G-code move is **one** group FB: a line MC_MoveLinearAbsolute; an arc
   in the XY plane of the first two members without turns or rise MC_MoveCircularAbsolute
   (CircMode CENTER); any other arc -- full circles, turns (P), helices, G18/G19 planes, rotary
   axes moving with the arc -- one MC_MoveCircularAbsolute carrying the exact arc / helix
   (:class:`GcodeArcFB`, one path segment whatever the number of turns).
3. **Corners** (LinuxCNC: the path-control mode of a line decides how that line ends): after
   G61.1 exact stop BUFFERED; after G61 exact path BLENDING_LOW with TM_NONE (tangent joins at
   speed, corners at rest); after G64 P<tol> BLENDING_LOW with TM_MAX_CORNER_DEVIATION(tol);
   after G64 / G64 P0 (as fast as possible) TM_MAX_CORNER_DEVIATION with
   :data:`AS_FAST_AS_POSSIBLE` (the blend bounded by the segments only). G64 Q<tol>: runs of
   collinear feed lines (every point within Q of the merged line) become one line (LinuxCNC's
   naive-CAM detector).
4. **Machine events** in program order: spindle (MC_MoveVelocity / MC_Halt on the spindle axis,
   rev/min to rad/s), coolant and M62-M65 outputs (named outputs: the cycle's output image
   ``ctx.outputs[name]`` and an edge in the trace, FB ``gcode``), tool change, dwell (the group
   at rest for P s), pauses (M0, M1 with the optional stop on, M60: noted, the program goes on:
   there is no operator), messages. A synchronised event waits until the group is at rest.

A move that fails at run time fails the run with ``FILE:LINE: WORD: <FB> failed with
<ErrorID>...``, and the group is halted along its path (MC_GroupHalt). ``report()`` gives the
lines run and the times.
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, NamedTuple

from motionplc.blocks.enums import (
    BufferMode,
    CircMode,
    ErrorID,
    GroupState,
    PathChoice,
    TransitionMode,
)
from motionplc.blocks.group_blocks import MC_MoveCircularAbsolute
from motionplc.errors import ConfigError
from motionplc.gcode import (
    AXES,
    GcodeError,
    GcodeEvent,
    GcodeMove,
    GcodeProgram,
    MachineSetup,
    arc_path,
    load_gcode,
    read_tool_table,
    validate,
)

if TYPE_CHECKING:
    from motionplc.blocks.group import AxesGroup, Handle
    from motionplc.config import Config, Machine
    from motionplc.runtime import CycleContext

__all__ = [
    "AS_FAST_AS_POSSIBLE",
    "GCODE_SUFFIXES",
    "GcodeArcFB",
    "GcodeJob",
    "GcodeRunner",
    "GroupMove",
    "choose_group",
    "group_moves",
    "is_gcode",
    "iter_group_moves",
    "load_gcode_job",
    "setup_from_config",
]

GCODE_SUFFIXES = (".ngc", ".nc", ".gcode", ".tap")
"""File suffixes ``motionplc run`` treats as G-code programs."""

RAPID_VELOCITY = 1e9
"""Path velocity of G0 [m/s]: the largest the group FBs take; the path caps (axis limits) hold."""

AS_FAST_AS_POSSIBLE = 1e3
"""[m] corner deviation of G64 without P (or P0): no tolerance, the blend is bounded by the
segments' lengths only (LinuxCNC: "best possible speed")."""

DEFAULT_TIMEOUT = 3600.0
"""[s] of (virtual) time a program may take by default."""

_SAME_START_ATOL = 1e-9  # [m] a start position within this of the validated one is the same


def is_gcode(path: str | Path) -> bool:
    """True if ``path`` has a G-code suffix (:data:`GCODE_SUFFIXES`, any case)."""
    return Path(path).suffix.lower() in GCODE_SUFFIXES


def choose_group(config: Config, path: str | Path, group: str | None = None) -> str:
    """The group a G-code program runs on: ``group`` if given, else the only configured one."""
    names = [g.name for g in config.groups]
    if group is not None:
        if group not in names:
            raise ConfigError(
                f"{path}: --group: unknown group {group!r} "
                f"(allowed: {', '.join(names) or 'no group is configured in ' + config.path})"
            )
        return group
    if len(names) == 1:
        return names[0]
    if not names:
        raise ConfigError(
            f"{path}: a G-code program needs an axes group, and {config.path} has none "
            "(allowed: groups: {NAME: [x, y, z]} in the configuration)"
        )
    raise ConfigError(
        f"{path}: {config.path} has {len(names)} groups; choose one with --group "
        f"(allowed: {', '.join(names)})"
    )


def setup_from_config(config: Config, group: str, path: str | Path = "") -> MachineSetup:
    """The machine of a G-code program on ``group`` of ``config`` (its ``gcode:`` block)."""
    spec = config.group(group)
    members = tuple(spec.axes)
    g = getattr(config, "gcode", None) or {}
    where = f"{config.path}: gcode"
    amap = g.get("axes")
    if amap is None:
        if not 1 <= len(members) <= 3:
            raise ConfigError(
                f"{path}: group {group!r} has {len(members)} axes ({', '.join(members)}); "
                "map them to letters with gcode.axes (allowed: 1 to 3 axes mapped to X, Y, Z "
                "without it)"
            )
        axes = {AXES[i]: i for i in range(len(members))}
    else:
        axes = {}
        for letter, name in amap.items():
            if name not in members:
                raise ConfigError(
                    f"{where}.axes.{letter}: {name!r} is not a member of group {group!r} "
                    f"(allowed: {', '.join(members)})"
                )
            axes[letter] = members.index(name)
        missing = [m for i, m in enumerate(members) if i not in axes.values()]
        if missing:
            raise ConfigError(
                f"{where}.axes: members {missing} of group {group!r} have no letter "
                "(allowed: every member mapped)"
            )
    rotary = frozenset(c for c, i in axes.items() if config.axis(members[i]).units == "rad")
    for c in rotary:
        if c not in "ABC":
            raise ConfigError(
                f"{where}.axes.{c}: axis {members[axes[c]]!r} is in rad; a rotary axis must be "
                "A, B or C"
            )
    for c, i in axes.items():
        if c in "ABC" and c not in rotary:
            raise ConfigError(
                f"{where}.axes.{c}: axis {members[i]!r} is in m; A, B, C are rotary "
                "(allowed: an axis with units: rad)"
            )
    tools = {}
    units = g.get("units", "mm")
    if g.get("tool_table"):
        tt = Path(config.path).parent / g["tool_table"]
        tools = read_tool_table(tt, 0.0254 if units == "inch" else 0.001)
    offsets: dict[int, dict[str, float]] = {}
    systems = {
        "G54": 1,
        "G55": 2,
        "G56": 3,
        "G57": 4,
        "G58": 5,
        "G59": 6,
        "G59.1": 7,
        "G59.2": 8,
        "G59.3": 9,
    }
    for key, offs in (g.get("work_offsets") or {}).items():
        offsets[systems[str(key).upper()]] = {str(k).upper(): float(v) for k, v in offs.items()}
    limits = tuple((config.axis(a).sw_limit_min, config.axis(a).sw_limit_max) for a in members)
    cs = {
        "G54": 1,
        "G55": 2,
        "G56": 3,
        "G57": 4,
        "G58": 5,
        "G59": 6,
        "G59.1": 7,
        "G59.2": 8,
        "G59.3": 9,
    }[str(g.get("coordinate_system", "G54")).upper()]
    coolant = tuple(k for k in ("mist", "flood") if (g.get("coolant") or {}).get(k))
    return MachineSetup(
        axes=axes,
        names=members,
        rotary=rotary,
        units=units,
        plane={"G17": "XY", "G18": "ZX", "G19": "YZ"}[str(g.get("plane", "G17")).upper()],
        path_control=str(g.get("path_control", "G64")).upper(),
        coordinate_system=cs,
        work_offsets=offsets,
        tools=tools,
        spindle=bool(g.get("spindle")),
        coolant=coolant,
        outputs=tuple(g.get("outputs") or ()),
        block_delete=bool(g.get("block_delete", True)),
        optional_stop=bool(g.get("optional_stop", False)),
        max_blocks=g.get("max_blocks"),
        limits=limits,
    )


@dataclass(frozen=True, slots=True)
class GcodeJob:
    """A checked G-code program bound to a configured group: ``axes`` the members,
    ``task`` the members' task, ``spindle``/``coolant``/``outputs`` the machine's."""

    path: str
    program: GcodeProgram
    group: str
    axes: tuple[str, ...]
    task: str
    timeout: float = DEFAULT_TIMEOUT
    spindle: str | None = None
    coolant: tuple[tuple[str, str], ...] = ()
    spindle_scale: float = 2.0 * math.pi / 60.0  # set value per rev/min (rad/s; rev/s in m)

    @property
    def setup(self) -> MachineSetup:
        return self.program.setup


def load_gcode_job(
    path: str | Path,
    config: Config,
    group: str | None = None,
    timeout: float = DEFAULT_TIMEOUT,
) -> GcodeJob:
    """Check a G-code file for a group of ``config`` (the whole program runs once, from the
    machine origin). Raises :class:`~motionplc.gcode.GcodeError` listing every error
    (``FILE:LINE: WORD: ...``), or :class:`~motionplc.errors.ConfigError` for the group."""
    name = choose_group(config, path, group)
    spec = config.group(name)
    if not (isinstance(timeout, (int, float)) and timeout > 0 and math.isfinite(timeout)):
        raise ConfigError(f"{path}: timeout: got {timeout!r} (allowed: a number > 0)")
    setup = setup_from_config(config, name, path)
    program = load_gcode(path, setup=setup)
    task = config.axis(spec.axes[0]).task or config.runtime.tasks[0].name
    g = getattr(config, "gcode", None) or {}
    spindle = g.get("spindle")
    scale = 2.0 * math.pi / 60.0
    if spindle is not None:
        if spindle not in {a.name for a in config.axes}:
            raise ConfigError(f"{config.path}: gcode.spindle: no axis {spindle!r}")
        if config.axis(spindle).units != "rad":
            scale = 1.0 / 60.0
    coolant = tuple((k, v) for k, v in (g.get("coolant") or {}).items() if v)
    return GcodeJob(
        str(path),
        program,
        name,
        tuple(spec.axes),
        task,
        float(timeout),
        spindle,
        coolant,
        scale,
    )


# ------------------------------------------------------------------------------ mapping
class GroupMove(NamedTuple):
    """One group FB call: ``kind`` ``"linear"`` (MC_MoveLinearAbsolute), ``"circular"``
    (MC_MoveCircularAbsolute, CENTER) or ``"segment"`` (:class:`GcodeArcFB`: ``segment`` the
    exact arc / helix); ``line``/``word``/``text`` locate it in the file; the other fields are
    the FB's inputs (SI). ``outputs``: M62/M63 outputs switched when it starts."""

    index: int
    line: int
    word: str
    text: str
    kind: str
    position: tuple[float, ...]
    velocity: float
    buffer_mode: BufferMode
    transition_mode: TransitionMode
    transition_parameter: float
    circ_mode: CircMode = CircMode.CENTER
    aux_point: tuple[float, ...] = ()
    path_choice: PathChoice = PathChoice.COUNTER_CLOCKWISE
    segment: Any = None
    outputs: tuple[tuple[int, bool], ...] = ()
    last: bool = True

    def inputs(self) -> dict[str, Any]:
        """The FB's inputs (keyword arguments of its call)."""
        common: dict[str, Any] = {
            "velocity": self.velocity,
            "buffer_mode": self.buffer_mode,
            "transition_mode": self.transition_mode,
            "transition_parameter": self.transition_parameter,
        }
        if self.kind == "linear":
            return {"position": self.position, **common}
        out = {
            "end_point": self.position,
            "aux_point": self.aux_point,
            "circ_mode": self.circ_mode,
            "path_choice": self.path_choice,
            **common,
        }
        if self.kind == "segment":
            out["segment"] = self.segment
        return out


class GcodeArcFB(MC_MoveCircularAbsolute):
    """MC_MoveCircularAbsolute with one more input, ``segment``: the exact arc or helix
    (:func:`motionplc.gcode.move_path`), one path segment for any number of turns, any plane,
    with the other axes (normal, rotary) moving linearly with the angle. ``end_point`` must be
    the segment's end; the group checks that it starts where the move starts."""

    INPUTS = (*MC_MoveCircularAbsolute.INPUTS, "segment")

    def __init__(self, name: str | None = None, **inputs: Any) -> None:
        self.segment: Any = None
        super().__init__(name, **inputs)

    def _in_segment(self, group: Any) -> Any:
        return self.segment

    def _start_group(self, group: AxesGroup) -> Handle:
        from motionplc.blocks.group import GroupCommand

        common = self._common()
        end = self._in_end_point(group)
        return group.submit(
            GroupCommand(
                kind="circular",
                position=end,
                circ_mode=CircMode.CENTER,
                aux_point=end,
                segment=self.segment,
                **common,
            )
        )


def _transition(prev: GcodeMove | None) -> tuple[BufferMode, TransitionMode, float]:
    """How the corner at the end of ``prev`` is passed (LinuxCNC: the mode of that line)."""
    if prev is None or prev.exact_stop:
        return BufferMode.BUFFERED, TransitionMode.TM_NONE, 0.0
    if prev.exact_path:
        return BufferMode.BLENDING_LOW, TransitionMode.TM_NONE, 0.0
    tol = AS_FAST_AS_POSSIBLE if prev.tolerance is None else float(prev.tolerance)
    return BufferMode.BLENDING_LOW, TransitionMode.TM_MAX_CORNER_DEVIATION, tol


def _fmt(x: float) -> str:
    return f"{x:.9g}"


def _collinear(
    points: Sequence[tuple[float, ...]], a: tuple[float, ...], b: tuple[float, ...], tol: float
) -> bool:
    d = [y - x for x, y in zip(a, b, strict=True)]
    dd = sum(v * v for v in d)
    if dd <= 0.0:
        return False
    for p in points:
        q = [y - x for x, y in zip(a, p, strict=True)]
        t = sum(u * v for u, v in zip(q, d, strict=True)) / dd
        if not 0.0 <= t <= 1.0:
            return False
        if sum((qi - t * di) ** 2 for qi, di in zip(q, d, strict=True)) > tol * tol:
            return False
    return True


def _merge_naive(items: Iterator[GcodeMove | GcodeEvent]) -> Iterator[GcodeMove | GcodeEvent]:
    """G64 Q: runs of feed lines at one speed whose points lie within Q of the merged line
    become one line (at most 256 points per merge)."""
    run: list[GcodeMove] = []

    def flush() -> Iterator[GcodeMove]:
        if not run:
            return
        if len(run) == 1:
            yield run[0]
        else:
            first, last = run[0], run[-1]
            length = math.dist(first.start, last.end)
            dur = sum(m.duration or 0.0 for m in run)
            vel = length / dur if dur > 0.0 else last.velocity
            yield last._replace(start=first.start, velocity=vel, duration=dur)
        run.clear()

    for it in items:
        q = it.naive_tolerance if isinstance(it, GcodeMove) else None
        if (
            isinstance(it, GcodeMove)
            and q is not None
            and it.kind == "linear"
            and not it.outputs
            and it.velocity is not None
        ):
            if run and (
                abs((run[-1].velocity or 0.0) - it.velocity) <= 1e-9 * it.velocity
                and len(run) < 256
                and _collinear([m.end for m in run], run[0].start, it.end, q)
            ):
                run.append(it)
                continue
            yield from flush()
            run.append(it)
            continue
        yield from flush()
        yield it
    yield from flush()


def iter_group_moves(
    items: Iterator[GcodeMove | GcodeEvent], setup: MachineSetup
) -> Iterator[GroupMove | GcodeEvent]:
    """Map the interpreter's items to group FB calls (moves) and events, lazily."""
    dim = len(setup.names)
    xi, yi = setup.axes.get("X"), setup.axes.get("Y")
    center_ok = dim in (2, 3) and xi == 0 and yi == 1 and not setup.rotary
    prev: GcodeMove | None = None
    index = -1
    for mv in _merge_naive(items):
        if isinstance(mv, GcodeEvent):
            if mv.sync and mv.kind not in ("message", "note"):
                prev = None  # the next move starts from rest
            yield mv
            continue
        index += 1
        mode, tm, tp = _transition(prev)
        prev = mv
        if mv.kind in ("rapid", "linear"):
            v = RAPID_VELOCITY if mv.kind == "rapid" else float(mv.velocity or 0.0)
            yield GroupMove(
                index,
                mv.line,
                mv.word or ("G0" if mv.kind == "rapid" else "G1"),
                mv.text,
                "linear",
                mv.end,
                min(v, RAPID_VELOCITY),
                mode,
                tm,
                tp,
                outputs=mv.outputs,
            )
            continue
        choice = PathChoice.CLOCKWISE if mv.kind == "arc_cw" else PathChoice.COUNTER_CLOCKWISE
        v = min(float(mv.velocity or 0.0), RAPID_VELOCITY)
        assert mv.center is not None
        ia, ib = (setup.axes[c] for c in {"XY": "XY", "ZX": "ZX", "YZ": "YZ"}[mv.plane])
        simple = (
            center_ok
            and mv.plane == "XY"
            and mv.turns == 0
            and (dim == 2 or abs(mv.end[2] - mv.start[2]) <= 1e-12 * (1 + abs(mv.start[2])))
            and math.hypot(mv.end[0] - mv.start[0], mv.end[1] - mv.start[1]) > 1e-9
        )
        if simple:
            yield GroupMove(
                index,
                mv.line,
                mv.word,
                mv.text,
                "circular",
                mv.end,
                v,
                mode,
                tm,
                tp,
                CircMode.CENTER,
                mv.center,
                choice,
                outputs=mv.outputs,
            )
        else:
            seg = arc_path(mv, ia, ib)
            yield GroupMove(
                index,
                mv.line,
                mv.word,
                mv.text,
                "segment",
                mv.end,
                v,
                mode,
                tm,
                tp,
                CircMode.CENTER,
                mv.end,
                choice,
                seg,
                outputs=mv.outputs,
            )


def group_moves(
    program: GcodeProgram,
    start: Sequence[float] | None = None,
    sw_limits: Any = None,
    *,
    skipped: list[str] | None = None,
) -> tuple[GroupMove, ...]:
    """All FB calls of ``program`` from ``start`` (for tests and small programs: the runner
    streams them)."""
    interp = program.interpreter(start)
    out = tuple(
        m for m in iter_group_moves(interp.run(), program.setup) if isinstance(m, GroupMove)
    )
    if skipped is not None:
        skipped.extend(interp.skipped)
    return out


# ------------------------------------------------------------------------------ running
class _Slot:
    """A group FB instance and the move it runs (None: free)."""

    __slots__ = ("fb", "fb_kind", "move")

    def __init__(self, fb: Any, kind: str) -> None:
        self.fb = fb
        self.fb_kind = kind
        self.move: GroupMove | None = None


class GcodeRunner:
    """Runs a :class:`GcodeJob` on its group of a :class:`~motionplc.config.Machine`.

    If the group does not start at the machine origin the program is checked again from its
    position when the runner is created (a :class:`~motionplc.gcode.GcodeError` before the
    first cycle). ``per_cycle``: new FBs per cycle; ``window``: FBs in flight (at most the
    group's ``queue_depth``, its default). Outcome: ``finished``, ``failed``, ``failures``,
    ``over``, ``t_finished``; ``lines_run`` (G-code moves completed), ``events`` (the machine
    events done, at most 10000 kept), ``outputs`` (name -> state) and :meth:`report`.
    """

    def __init__(
        self,
        job: GcodeJob,
        machine: Machine,
        *,
        per_cycle: int = 1,
        window: int | None = None,
    ) -> None:
        if type(per_cycle) is not int or per_cycle < 1:
            raise ValueError(f"per_cycle must be an integer >= 1, got {per_cycle!r}")
        group = machine.axes_groups.get(job.group)
        if group is None:
            raise ConfigError(f"{job.path}: group {job.group!r} is not in the machine")
        depth = group.cfg.queue_depth
        if window is not None and (type(window) is not int or not 1 <= window <= depth):
            raise ValueError(f"window must be an integer in 1..{depth} (queue_depth)")
        self.job = job
        self.machine = machine
        self.group: AxesGroup = group
        self.per_cycle = per_cycle
        self.window = window if window is not None else depth
        self.start = group.position()
        self.lines_total = job.program.n_moves
        if max((abs(v) for v in self.start), default=0.0) > _SAME_START_ATOL:
            self.lines_total, _, _ = validate(job.program, self.start)
        from motionplc.blocks import MC_Halt, MC_MoveVelocity, MC_Power
        from motionplc.blocks.group_blocks import MC_GroupEnable, MC_GroupHalt

        g = job.group
        self._powers = [
            MC_Power(name=f"{a}.gcode_power", axis=machine.axes[a], enable=True) for a in job.axes
        ]
        self._spindle_fb: Any = None
        self._spindle_halt: Any = None
        if job.spindle is not None:
            ax = machine.axes.get(job.spindle)
            if ax is None:
                raise ConfigError(f"{job.path}: gcode.spindle: no axis {job.spindle!r}")
            self._powers.append(MC_Power(name=f"{job.spindle}.gcode_power", axis=ax, enable=True))
            self._spindle_fb = MC_MoveVelocity(name=f"{job.spindle}.gcode_spindle", axis=ax)
            self._spindle_halt = MC_Halt(name=f"{job.spindle}.gcode_spindle_stop", axis=ax)
            self._spindle_scale = job.spindle_scale
        self._enable = MC_GroupEnable(name=f"{g}.gcode_enable", axes_group=group)
        self._halt = MC_GroupHalt(name=f"{g}.gcode_halt", axes_group=group)
        self._halting = False
        self._free: dict[str, list[_Slot]] = {"linear": [], "circular": [], "segment": []}
        self._flight: deque[_Slot] = deque()
        self._releasing: list[_Slot] = []
        self._n_fbs = {"linear": 0, "circular": 0, "segment": 0}
        self._interp = job.program.interpreter(self.start)
        self._items = iter_group_moves(self._interp.run(), job.setup)
        self._next: GroupMove | GcodeEvent | None = None
        self._exhausted = False
        self._dwell_until: float | None = None
        self._spindle_cmd: tuple[str, float] | None = None
        self.phase = "power"
        self.finished = False
        self.failures: list[str] = []
        self.t = 0.0
        self.cycle = 0
        self.t_finished: float | None = None
        self.t_motion: float | None = None
        self.lines_run = 0
        self.steps_done = 0
        self.moves_sent = 0
        self.events: list[tuple[float, str]] = []
        self.n_events = 0
        self.outputs: dict[str, bool] = {}
        self._ctx: Any = None

    @property
    def skipped(self) -> list[str]:
        return self._interp.skipped

    # -- outcome ---------------------------------------------------------------------------
    @property
    def failed(self) -> bool:
        return bool(self.failures)

    @property
    def over(self) -> bool:
        """Finished or failed: nothing more will happen."""
        return self.finished or self.failed

    def report(self) -> str:
        """One line: lines run, motion time and end time."""
        motion = (
            f"{self.t_finished - self.t_motion:.3f} s of motion"
            if self.t_finished is not None and self.t_motion is not None
            else "not finished"
        )
        n_skip = self._interp.n_skipped
        skipped = f", {n_skip} zero-length skipped" if n_skip else ""
        ev = f", {self.n_events} machine events" if self.n_events else ""
        return (
            f"{self.job.path}: {self.lines_run} of {self.lines_total} moves run on group "
            f"{self.job.group!r} ({self.moves_sent} group moves{skipped}{ev}), {motion}"
            + (f", ended at t = {self.t_finished:.3f} s" if self.t_finished is not None else "")
        )

    def _fail(self, msg: str) -> None:
        if not self.failures:
            self.failures.append(msg)
        g = self.group
        if g.moving and g.state is GroupState.GROUP_MOVING:
            self._halting = True
            self._halt(execute=True)

    # -- the program -----------------------------------------------------------------------
    def __call__(self, ctx: CycleContext) -> None:
        self.t = ctx.t
        self.cycle = ctx.cycle
        self._ctx = ctx
        for p in self._powers:
            p()
        if self._spindle_cmd is not None:
            self._spindle_step()
        if self._halting:
            self._halt()
            return
        if self.over:
            return
        if ctx.t >= self.job.timeout - 1e-12:
            self._fail(
                f"{self.job.path}: timeout: the program did not finish within "
                f"{self.job.timeout:g} s ({self.lines_run} of {self.lines_total} moves run)"
            )
            return
        if self.phase == "power":
            self._power()
        if self.phase == "enable":
            self._enabling()
        if self.phase == "run":
            try:
                self._run()
            except GcodeError as exc:  # pragma: no cover - validated before the run
                self._fail(str(exc))

    def _power(self) -> None:
        from motionplc.blocks import AxisState

        for p in self._powers:
            ax = p.axis
            if ax.state is AxisState.ERROR_STOP:
                self._fail(
                    f"{self.job.path}: axis {ax.name!r} is in ERROR_STOP ({_axis_error(ax)})"
                )
                return
            if p.error:
                self._fail(
                    f"{self.job.path}: MC_Power of axis {ax.name!r} failed with "
                    f"{p.error_id.name} (0x{int(p.error_id):04X})"
                )
                return
        if not all(p.status for p in self._powers):
            return
        g = self.group
        if g.state is GroupState.GROUP_STANDBY:
            self.phase = "run"
        elif g.state is GroupState.GROUP_DISABLED:
            self.phase = "enable"
            self._enable(execute=True)
        else:
            self._fail(
                f"{self.job.path}: group {g.name!r} is {g.state.name} "
                "(allowed at the start: GROUP_DISABLED or GROUP_STANDBY)"
            )

    def _enabling(self) -> None:
        fb = self._enable()
        if fb.error:
            self._fail(
                f"{self.job.path}: MC_GroupEnable of group {self.group.name!r} failed with "
                f"{fb.error_id.name} (0x{int(fb.error_id):04X}): {fb.error_text}"
            )
        elif fb.done:
            self._enable(execute=False)
            pos = self.group.position()
            if max(abs(a - b) for a, b in zip(pos, self.start, strict=True)) > _SAME_START_ATOL:
                self._fail(
                    f"{self.job.path}: the group moved from {[round(x, 9) for x in self.start]} "
                    f"to {[round(x, 9) for x in pos]} before the program started"
                )
                return
            self.phase = "run"

    def _slot(self, kind: str) -> _Slot:
        free = self._free[kind]
        if free:
            return free.pop()
        from motionplc.blocks.group_blocks import MC_MoveLinearAbsolute

        self._n_fbs[kind] += 1
        cls = {
            "linear": MC_MoveLinearAbsolute,
            "circular": MC_MoveCircularAbsolute,
            "segment": GcodeArcFB,
        }[kind]
        name = f"{self.job.group}.gcode_{kind}{self._n_fbs[kind]}"
        return _Slot(cls(name=name, axes_group=self.group), kind)

    def _peek(self) -> GroupMove | GcodeEvent | None:
        if self._next is None and not self._exhausted:
            try:
                self._next = next(self._items)
            except StopIteration:
                self._exhausted = True
        return self._next

    def _run(self) -> None:
        flight = self._flight
        for slot in self._releasing:
            slot.fb(execute=False)
            self._free[slot.fb_kind].append(slot)
        self._releasing.clear()
        for slot in list(flight):
            fb = slot.fb()
            mv = slot.move
            assert mv is not None
            if fb.error:
                self._fail(self._fb_failure(fb, mv))
                return
            if fb.command_aborted:
                self._fail(
                    f"{self.job.path}:{mv.line}: {mv.word}: {type(fb).__name__} was aborted "
                    f"(group {self.group.name!r}: {self.group.state.name})"
                )
                return
            if fb.done:
                flight.remove(slot)
                slot.move = None
                if slot.fb_kind == "segment":
                    slot.fb.segment = None
                self._releasing.append(slot)
                if mv.last:
                    self.lines_run += 1
                    self.steps_done = self.lines_run
        g = self.group
        if g.state is GroupState.GROUP_ERROR_STOP and not flight:
            self._fail(
                f"{self.job.path}: group {g.name!r} went to GROUP_ERROR_STOP "
                f"({g.error_id.name}: {g.error_reason}) at t = {self.t:.3f} s"
            )
            return
        if self._dwell_until is not None:
            if self.t < self._dwell_until - 1e-12:
                return
            self._dwell_until = None
        n = 0
        while n < self.per_cycle and len(flight) < self.window:
            item = self._peek()
            if item is None:
                break
            if isinstance(item, GcodeEvent):
                if item.sync and item.kind not in ("message", "note") and (flight or g.moving):
                    break  # wait until the motion before it is done
                self._next = None
                self._do_event(item)
                if self._dwell_until is not None:
                    return
                continue
            self._next = None
            slot = self._slot(item.kind)
            slot.move = item
            for idx, on in item.outputs:
                self._set_output(f"output{idx}", idx, on)
            fb = slot.fb(execute=True, **item.inputs())
            n += 1
            self.moves_sent += 1
            if self.t_motion is None:
                self.t_motion = self.t
            if fb.error:
                self._fail(self._fb_failure(fb, item))
                return
            flight.append(slot)
        if self._exhausted and self._next is None and not flight and not g.moving:
            if g.state is GroupState.GROUP_STANDBY:
                self.finished = True
                self.t_finished = self.t
                if self.t_motion is None:
                    self.t_motion = self.t

    # -- machine events --------------------------------------------------------------------
    def _log(self, text: str) -> None:
        self.n_events += 1
        if len(self.events) < 10_000:
            self.events.append((self.t, text))

    def _set_output(self, name: str, index: int, on: bool) -> None:
        outs = self.job.setup.outputs
        if name.startswith("output") and index < len(outs):
            name = outs[index]
        elif name.startswith("output"):
            return  # noted by the interpreter: the machine has no such output
        self.outputs[name] = on
        ctx = self._ctx
        if ctx is not None:
            ctx.outputs[name] = on
            trace = getattr(self.machine.runtime, "trace", None)
            if trace is not None:
                trace.event(self.cycle, "gcode", name, on)
        self._log(f"{name} {'on' if on else 'off'}")

    def _do_event(self, ev: GcodeEvent) -> None:
        k = ev.kind
        if k == "dwell":
            self._dwell_until = self.t + ev.value
            self._log(f"dwell {ev.value:g} s")
        elif k == "spindle":
            self._log(f"spindle {ev.value:g} rev/min")
            if self._spindle_fb is not None:
                self._spindle_cmd = ("stop", 0.0) if ev.value == 0.0 else ("run", ev.value)
                self._spindle_step(new=True)
        elif k == "coolant":
            names = dict(self.job.coolant)
            if ev.name in names:
                self._set_output(names[ev.name], 0, ev.value != 0.0)
        elif k == "output":
            self._set_output(f"output{ev.index}", ev.index, ev.value != 0.0)
        elif k == "tool_change":
            self._log(f"tool change T{ev.index}")
        elif k == "pause":
            self._log(f"pause M{ev.value:g} ({ev.text or 'no operator: continued'})")
        elif k == "end":
            self._log(ev.text or "end")
        else:
            self._log(f"{k}: {ev.text}")

    def _spindle_step(self, new: bool = False) -> None:
        """Call the spindle's FB of the current command every cycle (a new one: an edge)."""
        assert self._spindle_cmd is not None
        what, rpm = self._spindle_cmd
        from motionplc.blocks.enums import Direction

        fb = self._spindle_fb if what == "run" else self._spindle_halt
        if new:
            fb(execute=False)
            kw: dict[str, Any] = {}
            if what == "run":
                kw = {
                    "velocity": abs(rpm) * self._spindle_scale,
                    "direction": Direction.POSITIVE if rpm > 0 else Direction.NEGATIVE,
                }
            fb(execute=True, **kw)
        else:
            fb()

    def _fb_failure(self, fb: Any, mv: GroupMove) -> str:
        eid = fb.error_id
        text = f": {fb.error_text}" if fb.error_text else ""
        cause = ""
        if eid is ErrorID.AXIS_ERROR_STOP:
            from motionplc.blocks import AxisState

            bad = [ax for ax in self.group.axes if ax.state is AxisState.ERROR_STOP]
            if bad:
                cause = f"; axis {bad[0].name!r}: {_axis_error(bad[0])}"
        return (
            f"{self.job.path}:{mv.line}: {mv.word}: {type(fb).__name__} failed with "
            f"{eid.name} (0x{int(eid):04X}){text} at t = {self.t:.3f} s (line "
            f"{mv.text!r}){cause}"
        )


def _axis_error(axis: Any) -> str:
    from motionplc.sequence import axis_error_text

    return axis_error_text(axis)
