"""G-code programs on an axes group: ``motionplc run CONFIG program.ngc [--group NAME]``.

The program (:mod:`motionplc.gcode`: parser and resolver) runs on one configured axes group;
its X, Y, Z words address the group's members in group order (the identity Cartesian mapping:
``groups: {xyz: [x, y, z]}``). :class:`GcodeRunner` is a task program (``runner(ctx)`` every
cycle, the same outcome interface as the sequence and Python-program runners):

1. **Power**: one ``MC_Power`` per member axis with Enable TRUE, called every cycle (as a
   sequence's power step does); the runner waits for every ``status``.
2. **Enable**: ``MC_GroupEnable`` if the group is GroupDisabled (GroupStandby: nothing to do;
   any other state fails the run). If the members' set position differs from the one the
   program was resolved from, the program is resolved again from there (its errors then fail
   the run before any motion).
3. **Moves**: every G-code move becomes one group FB call (an ``MC_MoveLinearAbsolute`` or an
   ``MC_MoveCircularAbsolute``), fed so that the group's queue stays filled: at most
   ``per_cycle`` (default 1) new FBs per cycle (each is planned in the cycle it is queued)
   and at most ``window`` FBs in flight (default: the group's ``queue_depth``). FB instances
   are reused once their move is Done.
4. **End**: every move Done and the group at rest (GroupStandby) -> ``finished``.

Mapping of the moves (all decided before the run starts, by :func:`group_moves`):

* ``G0``: a line at the axes' limits (``velocity`` 1e9: the path caps of the group hold);
  ``G1``: a line at ``F``.
* ``G2``/``G3`` in the XY plane (or any arc of a 2-axis group): CircMode CENTER with the
  arc's centre, PathChoice CLOCKWISE / COUNTER_CLOCKWISE, at ``F``. A full circle (and each
  extra turn of ``P``) is run as equal arcs of at most 180 degrees (a CENTER arc cannot end
  where it starts), joined smoothly (BLENDING_LOW, TM_NONE: passed at speed).
* ``G2``/``G3`` in the ZX (G18) or YZ (G19) plane of a 3-axis group: CircMode BORDER through the
  arc's midpoint (the group's CENTER arcs lie in planes parallel to XY), split into equal arcs
  of at most 180 degrees.
* **Not expressible**: a helix (an arc that also moves along its plane's normal, or with the
  off-plane word); it is a located :class:`~motionplc.gcode.GcodeError`
  ``FILE:LINE: G2: ...`` raised before the run, never skipped. So is a move whose end point or
  arc leaves a member's software limits, and a feed above the path-speed range of the FBs.
* Corners, as in LinuxCNC (the path-control mode in force on a line decides how that line ends):
  the move after a line run under ``G64 P<tol>`` gets BLENDING_LOW with
  TM_MAX_CORNER_DEVIATION(tol); under ``G64`` without P, TM_MAX_CORNER_DEVIATION(0) (the
  group's default ``tolerance``); under ``G61`` BUFFERED with TM_NONE (exact stop). The first
  move starts from rest (BUFFERED).

A move that fails at run time (FB Error) fails the run with ``FILE:LINE: WORD: <FB> failed
with <ErrorID> (0x....): <text>`` (and the axis error that caused it, if any); the group is
then halted along its path (MC_GroupHalt). ``report()`` gives the lines run and the times.
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from motionplc.blocks.enums import (
    BufferMode,
    CircMode,
    ErrorID,
    GroupState,
    PathChoice,
    TransitionMode,
)
from motionplc.errors import ConfigError, PlanningError
from motionplc.gcode import GcodeError, GcodeMove, GcodeProgram, load_gcode, move_path
from motionplc.planning.paths import Arc

if TYPE_CHECKING:
    from motionplc.blocks.group import AxesGroup
    from motionplc.config import Config, Machine
    from motionplc.runtime import CycleContext

__all__ = [
    "GCODE_SUFFIXES",
    "GcodeJob",
    "GcodeRunner",
    "GroupMove",
    "choose_group",
    "group_moves",
    "is_gcode",
    "load_gcode_job",
]

GCODE_SUFFIXES = (".ngc", ".nc", ".gcode", ".tap")
"""File suffixes ``motionplc run`` treats as G-code programs."""

RAPID_VELOCITY = 1e9
"""Path velocity of G0 [m/s]: the largest the group FBs take; the path caps (axis limits) hold."""

DEFAULT_TIMEOUT = 3600.0
"""[s] of (virtual) time a program may take by default."""

_WORD = {"rapid": "G0", "linear": "G1", "arc_cw": "G2", "arc_ccw": "G3"}
_HALF_TURN = math.pi * (1.0 + 1e-9)  # arcs up to this angle are one FB (CENTER or BORDER)
_SAME_START_ATOL = 1e-9  # [m] a start position within this of the resolved one is the same


def is_gcode(path: str | Path) -> bool:
    """True if ``path`` has a G-code suffix (:data:`GCODE_SUFFIXES`, any case)."""
    return Path(path).suffix.lower() in GCODE_SUFFIXES


def choose_group(config: Config, path: str | Path, group: str | None = None) -> str:
    """The group a G-code program runs on: ``group`` if given, else the only configured one.

    Raises :class:`~motionplc.errors.ConfigError` naming the configured groups otherwise.
    """
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


@dataclass(frozen=True, slots=True)
class GcodeJob:
    """A parsed G-code program bound to a configured group (validated before anything is
    built): ``axes`` are the group members X, Y, Z map to; ``task`` the members' task."""

    path: str
    program: GcodeProgram
    group: str
    axes: tuple[str, ...]
    task: str
    timeout: float = DEFAULT_TIMEOUT


def load_gcode_job(
    path: str | Path,
    config: Config,
    group: str | None = None,
    timeout: float = DEFAULT_TIMEOUT,
) -> GcodeJob:
    """Parse a G-code file for a group of ``config`` (see :func:`choose_group`).

    Raises :class:`~motionplc.gcode.GcodeError` listing every syntax and modal error of the
    file (``FILE:LINE: WORD: ...``), or :class:`~motionplc.errors.ConfigError` for the group.
    """
    name = choose_group(config, path, group)
    spec = config.group(name)
    if not 1 <= len(spec.axes) <= 3:
        raise ConfigError(
            f"{path}: group {name!r} has {len(spec.axes)} axes "
            f"({', '.join(spec.axes)}) (allowed: 1 to 3 axes, mapped to X, Y, Z)"
        )
    if not (isinstance(timeout, (int, float)) and timeout > 0 and math.isfinite(timeout)):
        raise ConfigError(f"{path}: timeout: got {timeout!r} (allowed: a number > 0)")
    program = load_gcode(path, spec.axes)
    task = config.axis(spec.axes[0]).task or config.runtime.tasks[0].name
    return GcodeJob(str(path), program, name, spec.axes, task, float(timeout))


# ------------------------------------------------------------------------------ mapping
@dataclass(frozen=True, slots=True)
class GroupMove:
    """One group FB call of a program: ``kind`` ``"linear"`` (MC_MoveLinearAbsolute) or
    ``"circular"`` (MC_MoveCircularAbsolute); ``line``/``word``/``text`` locate it in the
    file; ``index`` is the G-code move it belongs to (a split arc has several GroupMoves,
    ``last`` on its final one). The other fields are the FB's inputs (SI units)."""

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
        return {
            "end_point": self.position,
            "aux_point": self.aux_point,
            "circ_mode": self.circ_mode,
            "path_choice": self.path_choice,
            **common,
        }


def _transition(prev: GcodeMove | None) -> tuple[BufferMode, TransitionMode, float]:
    """How the corner at the end of ``prev`` is passed (LinuxCNC: the mode of that line)."""
    if prev is None or prev.exact_stop:
        return BufferMode.BUFFERED, TransitionMode.TM_NONE, 0.0
    tol = 0.0 if prev.tolerance is None else float(prev.tolerance)
    return BufferMode.BLENDING_LOW, TransitionMode.TM_MAX_CORNER_DEVIATION, tol


def _fmt(x: float) -> str:
    return f"{x:.9g}"


def group_moves(
    program: GcodeProgram,
    start: Sequence[float],
    sw_limits: Sequence[tuple[float | None, float | None]] | None = None,
    *,
    skipped: list[str] | None = None,
) -> tuple[GroupMove, ...]:
    """Resolve ``program`` from the group position ``start`` and map every move to FB calls.

    ``sw_limits``: per member ``(min, max)`` (None: unlimited), checked on every end point and
    on the whole of every arc. Guarantees: the FB calls reproduce the program's path exactly
    (lines end at the programmed points, arcs have the programmed centre, radius and sense;
    split arcs join tangentially), each move's last call ends exactly at the resolved end
    point, no move is skipped except zero-length ones (listed in ``skipped``). Raises one
    :class:`~motionplc.gcode.GcodeError` listing every move that cannot be expressed or run
    (``FILE:LINE: WORD: ...``) up to the resolver's first geometric error (listed last: the
    moves after it have no defined start).
    """
    dim = len(program.axes)
    names = program.axes
    limits = list(sw_limits) if sw_limits is not None else [(None, None)] * dim
    out: list[GroupMove] = []
    errors: list[str] = []
    prev: GcodeMove | None = None
    resolved = program.moves(start, skipped=skipped)
    index = -1
    while True:
        try:
            mv = next(resolved)
        except StopIteration:
            break
        except GcodeError as exc:  # a geometric error: the moves after it have no start
            errors.extend(exc.errors)
            break
        index += 1
        word = _WORD[mv.kind]
        where = f"{program.path}:{mv.line}: {word}"
        mode, tm, tp = _transition(prev)
        prev = mv
        if mv.feed is not None and mv.feed > RAPID_VELOCITY:
            errors.append(
                f"{where}: feed {_fmt(mv.feed)} m/s is above the path-speed range of the group "
                f"blocks (allowed: F up to {_fmt(RAPID_VELOCITY)} m/s)"
            )
            continue
        velocity = RAPID_VELOCITY if mv.kind == "rapid" else float(mv.feed or 0.0)
        bad = _outside(mv, names, limits)
        if bad:
            errors.append(f"{where}: {bad}")
            continue
        if mv.kind in ("rapid", "linear"):
            out.append(
                GroupMove(index, mv.line, word, mv.text, "linear", mv.end, velocity, mode, tm, tp)
            )
            continue
        try:
            pieces = _arc_pieces(mv, dim)
        except _NotExpressibleError as exc:
            errors.append(f"{where}: {exc}")
            continue
        for i, (circ, aux, end) in enumerate(pieces):
            first = i == 0
            out.append(
                GroupMove(
                    index,
                    mv.line,
                    word,
                    mv.text,
                    "circular",
                    end,
                    velocity,
                    mode if first else BufferMode.BLENDING_LOW,
                    tm if first else TransitionMode.TM_NONE,
                    tp if first else 0.0,
                    circ,
                    aux,
                    PathChoice.CLOCKWISE if mv.kind == "arc_cw" else PathChoice.COUNTER_CLOCKWISE,
                    last=i == len(pieces) - 1,
                )
            )
    if errors:
        raise GcodeError(errors)
    return tuple(out)


class _NotExpressibleError(Exception):
    pass


def _arc_pieces(
    mv: GcodeMove, dim: int
) -> list[tuple[CircMode, tuple[float, ...], tuple[float, ...]]]:
    """(CircMode, aux_point, end_point) of the FB calls of one arc."""
    try:
        path = move_path(mv)
    except PlanningError as exc:  # pragma: no cover - the resolver gives consistent moves
        raise _NotExpressibleError(str(exc)) from None
    if not isinstance(path, Arc):
        ia, ib, inn = {"XY": (0, 1, 2), "ZX": (2, 0, 1), "YZ": (1, 2, 0)}[mv.plane]
        rise = mv.end[inn] - mv.start[inn]
        letter = "XYZ"[inn]
        raise _NotExpressibleError(
            f"helix (the arc in the {mv.plane} plane also moves {letter} by {_fmt(rise)} m"
            + (f", {mv.turns} extra turns" if mv.turns else "")
            + "): the group blocks have no helical move (allowed: arcs in one plane, lines; "
            "split the helix into lines)"
        )
    center_mode = dim == 2 or mv.plane == "XY"
    angle = path.angle
    if center_mode:
        n = 1 if angle < 2.0 * math.pi * (1.0 - 1e-9) else max(2, math.ceil(angle / _HALF_TURN))
    else:
        n = max(1, math.ceil(angle / _HALF_TURN))
    u_end = path.u_end
    pieces = []
    for k in range(n):
        if k == n - 1:
            end = tuple(float(x) for x in mv.end)
        else:
            end = tuple(float(x) for x in path.evaluate(u_end * (k + 1) / n))
        if center_mode:
            assert mv.center is not None
            pieces.append((CircMode.CENTER, tuple(float(x) for x in mv.center), end))
        else:
            via = tuple(float(x) for x in path.evaluate(u_end * (k + 0.5) / n))
            pieces.append((CircMode.BORDER, via, end))
    return pieces


def _outside(
    mv: GcodeMove, names: Sequence[str], limits: Sequence[tuple[float | None, float | None]]
) -> str:
    """Why the move leaves a member's software limits ('' if it does not)."""
    lo_hi = _extent(mv)
    for name, (lo, hi), (pmin, pmax) in zip(names, limits, lo_hi, strict=True):
        tol_hi = 1e-12 * (1.0 + abs(pmax))
        tol_lo = 1e-12 * (1.0 + abs(pmin))
        if (hi is not None and pmax > hi + tol_hi) or (lo is not None and pmin < lo - tol_lo):
            reach = pmax if hi is not None and pmax > hi + tol_hi else pmin
            what = "the arc" if mv.kind.startswith("arc") else "the move"
            return (
                f"{what} takes axis {name!r} to {_fmt(reach)} m, outside its software limits "
                f"[{'-inf' if lo is None else _fmt(lo)}, {'inf' if hi is None else _fmt(hi)}] m "
                "(allowed: a path within the limits)"
            )
    return ""


def _extent(mv: GcodeMove) -> list[tuple[float, float]]:
    """Per axis the smallest and largest coordinate the move reaches (exact for arcs)."""
    ext = [(min(a, b), max(a, b)) for a, b in zip(mv.start, mv.end, strict=True)]
    if not mv.kind.startswith("arc"):
        return ext
    try:
        path = move_path(mv)
    except PlanningError:  # pragma: no cover - reported by _arc_pieces
        return ext
    if not isinstance(path, Arc):
        return ext  # a helix: refused by _arc_pieces
    c, r, x, y, phi = path.center, path.radius, path.x_axis, path.y_axis, path.angle
    out = []
    for i, (lo, hi) in enumerate(ext):
        # p_i(t) = c_i + r (x_i cos t + y_i sin t): extremes at t* and t* + pi, if on the arc
        amp = math.hypot(float(x[i]), float(y[i]))
        if amp > 0.0:
            t_max = math.atan2(float(y[i]), float(x[i])) % (2.0 * math.pi)
            t_min = (t_max + math.pi) % (2.0 * math.pi)
            if t_max <= phi:
                hi = max(hi, float(c[i]) + r * amp)
            if t_min <= phi:
                lo = min(lo, float(c[i]) - r * amp)
        out.append((lo, hi))
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

    The program is resolved and mapped (:func:`group_moves`) from the group's set position
    when the runner is created, so a move that cannot be run is a
    :class:`~motionplc.gcode.GcodeError` before the first cycle. ``per_cycle``: new FBs per
    cycle (each is planned in its cycle: this bounds the cycle's planning work); ``window``:
    FBs in flight (at most the group's ``queue_depth``, its default). Outcome:
    ``finished``, ``failed``, ``failures``, ``over``, ``t_finished``; ``lines_run`` (G-code
    moves completed), ``t_motion`` (when the first move was queued) and :meth:`report`.
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
        self.skipped: list[str] = []
        self.start = group.position()
        self.moves = self._map(self.start)
        self.lines_total = len({m.index for m in self.moves})
        from motionplc.blocks import MC_Power
        from motionplc.blocks.group_blocks import MC_GroupEnable, MC_GroupHalt

        g = job.group
        self._powers = [
            MC_Power(name=f"{a}.gcode_power", axis=machine.axes[a], enable=True) for a in job.axes
        ]
        self._enable = MC_GroupEnable(name=f"{g}.gcode_enable", axes_group=group)
        self._halt = MC_GroupHalt(name=f"{g}.gcode_halt", axes_group=group)
        self._halting = False
        self._free: dict[str, list[_Slot]] = {"linear": [], "circular": []}
        self._flight: deque[_Slot] = deque()
        self._releasing: list[_Slot] = []
        self._n_fbs = {"linear": 0, "circular": 0}
        self._next = 0
        self.phase = "power"
        self.finished = False
        self.failures: list[str] = []
        self.t = 0.0
        self.t_finished: float | None = None
        self.t_motion: float | None = None
        self.lines_run = 0
        self.steps_done = 0

    def _map(self, start: Sequence[float]) -> tuple[GroupMove, ...]:
        limits = [(ax.cfg.sw_limit_neg, ax.cfg.sw_limit_pos) for ax in self.group.axes]
        self.skipped = []
        return group_moves(self.job.program, start, limits, skipped=self.skipped)

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
        skipped = f", {len(self.skipped)} zero-length skipped" if self.skipped else ""
        return (
            f"{self.job.path}: {self.lines_run} of {self.lines_total} lines run on group "
            f"{self.job.group!r} ({len(self.moves)} group moves{skipped}), {motion}"
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
        for p in self._powers:
            p()
        if self._halting:
            self._halt()
            return
        if self.over:
            return
        if ctx.t >= self.job.timeout - 1e-12:
            self._fail(
                f"{self.job.path}: timeout: the program did not finish within "
                f"{self.job.timeout:g} s ({self.lines_run} of {self.lines_total} lines run)"
            )
            return
        if self.phase == "power":
            self._power()
        if self.phase == "enable":
            self._enabling()
        if self.phase == "run":
            self._run()

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
            self._begin()
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
            self._begin()

    def _begin(self) -> None:
        pos = self.group.position()
        if max((abs(a - b) for a, b in zip(pos, self.start, strict=True)), default=0.0) > (
            _SAME_START_ATOL
        ):
            try:
                self.moves = self._map(pos)
            except GcodeError as exc:
                self._fail(
                    f"{self.job.path}: the group starts at {[round(x, 9) for x in pos]}, not "
                    f"at {[round(x, 9) for x in self.start]}; from there: {exc}"
                )
                return
            self.start = pos
            self.lines_total = len({m.index for m in self.moves})
        self.phase = "run"  # the moves start in this cycle (__call__ goes on to _run)

    def _slot(self, kind: str) -> _Slot:
        free = self._free[kind]
        if free:
            return free.pop()
        from motionplc.blocks.group_blocks import MC_MoveCircularAbsolute, MC_MoveLinearAbsolute

        self._n_fbs[kind] += 1
        cls = MC_MoveLinearAbsolute if kind == "linear" else MC_MoveCircularAbsolute
        name = f"{self.job.group}.gcode_{kind}{self._n_fbs[kind]}"
        return _Slot(cls(name=name, axes_group=self.group), kind)

    def _run(self) -> None:
        flight = self._flight
        # FBs Done in the last cycle: Execute falls now (Done was held one scan, so the trace
        # shows its edge), then the instance is free for the next move
        for slot in self._releasing:
            slot.fb(execute=False)
            self._free[slot.fb_kind].append(slot)
        self._releasing.clear()
        # outputs of the FBs in flight (oldest first); Done ones are released for reuse
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
        # feed: at most per_cycle new moves, at most window in flight
        moves = self.moves
        n = 0
        while self._next < len(moves) and n < self.per_cycle and len(flight) < self.window:
            mv = moves[self._next]
            slot = self._slot(mv.kind)
            slot.move = mv
            fb = slot.fb(execute=True, **mv.inputs())
            self._next += 1
            n += 1
            if self.t_motion is None:
                self.t_motion = self.t
            if fb.error:
                self._fail(self._fb_failure(fb, mv))
                return
            flight.append(slot)
        if self._next >= len(moves) and not flight and not g.moving:
            if g.state is GroupState.GROUP_STANDBY:
                self.finished = True
                self.t_finished = self.t
                if self.t_motion is None:
                    self.t_motion = self.t

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
