"""Checks of a sequence against the machine, before anything runs.

:func:`check_sequence` (called by :func:`motionplc.sequence.parse_sequence`, so by
``motionplc validate CONFIG SEQUENCE`` and by ``motionplc run`` before the first cycle) checks
every literal FB input of a sequence against what the axis or group and the block accept, and
adds one located line per problem::

    seq.yaml:12: steps[1].call[0].velocity: got 3.0, above the axis' v_max 0.5 of axis 'x'
    (allowed: [5e-07, 0.5])

What is checked, with the FBs' own code where the FB checks the input (``_in_<pin>`` methods,
:class:`motionplc.blocks.motion.InputChecks`; MC_SetOverride / MC_SetPosition through their own
Execute/Enable path), so this check and the FB at Execute cannot disagree:

* every input range of the README ("Input ranges"): a move's Velocity (> 0, at most the
  axis' speed limit v_top, at least 1e-6 v_top), MC_MoveVelocity's signed Velocity after its
  Direction (within [v_min, v_max]; with Direction CURRENT the sign is only known at run time,
  so a velocity fitting either direction passes), Acceleration / Deceleration / Jerk (0 or
  within the axis' ranges), positions (within +-1e12; on a modulo axis in [0, modulo)),
  override factors, group path dynamics, transition mode and parameter, circle inputs;
* inputs that are not given but whose value the FB keeps (IEC: an omitted input keeps its
  previous value, else the FB's default) are checked too: an MC_MoveAbsolute without
  ``velocity`` is refused at Execute (its default 0 is not a velocity), and so is it here;
* enumerations: a name that does not exist, or one the block does not accept (Direction
  SHORTEST on MC_MoveVelocity; a TransitionMode other than TM_NONE with ABORTING/BUFFERED).
  Every FB with a ``buffer_mode`` input takes every BufferMode (blending into MC_Halt,
  MC_MoveVelocity or MC_Home is defined by the kernel: junction speed of the previous move,
  or Buffered); blocks without one (MC_Stop, MC_GroupStop, MC_GroupInterrupt, ...) refuse the
  key as an unknown input (the parser);
* software limits: an MC_MoveAbsolute target beyond a limit (the axis is taken to be within
  its limits where its position is not known: an axis starts there); SyncMoveAbsolute
  targets; group move targets, end points, BORDER via points and passing points beyond a
  member's limit (the arc or curve between them is checked at run time: its bulge depends on
  the geometry planned then);
* relative moves (MC_MoveRelative, MC_MoveAdditive, the relative group moves) where the
  sequence's previous positions are known literally: the target from there against the
  software limits (see "Known positions"); MC_MoveRelative's distance at its Velocity must
  not take longer than 1e4 s (SUPPORTED_DURATION; also MC_MoveAbsolute from a known start);
* group path speed, acceleration, deceleration and jerk above what the members together can
  ever reach (sqrt of the sum of the squared axis limits; MC_MoveDirect*: the fastest
  member's limit). The kernel would cap them; a sequence states them within the machine.

Known positions: an axis on a simulated (or ideal) drive starts at 0; an external drive's start
is unknown. A step that waits for all its blocks (``until: done``, the default) leaves its
axes at the end of their last move (MC_MoveAbsolute, a relative move from a known start,
SyncMoveAbsolute, group moves, MC_Home with set-position homing, MC_SetPosition), applied in
the order the sequence's FBs are scanned (declaration order) with the kernel's rules (an
ABORTING relative move counts from the set position at the step's start, a buffered or
blending one from the previous move's target, MC_MoveAdditive from the last target).
Anything else makes the position unknown: MC_MoveVelocity, MC_Halt, MC_Stop, the group's halt
/ stop / interrupt / continue, a step that goes on before its moves are done (``until:
time`` / ``position`` / ``state`` / some blocks only), modulo axes, an axis moved in two
parallel branches. Unknown positions are left to run time (the FB refuses the move there).

Not literal, so left to run time: none today (every input of a YAML sequence is a literal);
what depends on the state when the block executes (axis state, queue depth, direction
enables, an axis standing at a software limit, the arc's geometry).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

from motionplc.config import Checker, Config

if TYPE_CHECKING:
    from motionplc.blocks.axis_config import AxisConfig
    from motionplc.sequence import Call, Sequence, Step

__all__ = ["CheckReport", "check_sequence"]

_ABS_GROUP = ("MC_MoveLinearAbsolute", "MC_MoveDirectAbsolute")
_REL_GROUP = ("MC_MoveLinearRelative", "MC_MoveDirectRelative")
_CIRC = ("MC_MoveCircularAbsolute", "MC_MoveCircularRelative")
_CURVES = ("MC_MovePassingPoints", "MC_MoveBSpline")
_GROUP_STOPS = ("MC_GroupHalt", "MC_GroupStop", "MC_GroupInterrupt", "MC_GroupContinue")
_GROUP_DYN = ("velocity", "acceleration", "deceleration", "jerk")


@dataclass
class CheckReport:
    """What :func:`check_sequence` did: ``checks`` (input values checked), ``problems``."""

    checks: int = 0
    problems: int = 0


class _GroupStub:
    """What the group FBs' input checks read of a group: its dimension."""

    def __init__(self, dim: int) -> None:
        self.dim = dim


class _AdminStub:
    """An axis for MC_SetOverride / MC_SetPosition's own Enable/Execute path (no effect)."""

    def __init__(self, cfg: AxisConfig) -> None:
        self.cfg = cfg

    def set_override(self, *factors: float) -> None:
        """(checked already by the FB)"""

    def submit(self, cmd: Any) -> None:
        """(checked already by the FB)"""


def _axis_config(config: Config, name: str) -> AxisConfig | None:
    from motionplc.blocks.axis_config import AxisConfig

    ax = config.axis(name)
    lim = ax.limits
    try:
        return AxisConfig(
            name=name,
            v_max=lim.v_max,
            a_max=lim.a_max,
            j_max=lim.j_max,
            v_min=lim.v_min,
            a_min=lim.a_min,
            modulo=ax.modulo,
            following_error_limit=ax.following_error,
            sw_limit_pos=ax.sw_limit_max,
            sw_limit_neg=ax.sw_limit_min,
            queue_depth=ax.queue_depth,
            home_switch=ax.homing.switch if ax.homing.method == "switch" else None,
        )
    except ValueError:  # (the configuration loader reports it)
        return None


def _start_known(config: Config, name: str) -> bool:
    """Whether the axis starts at 0: an ideal drive or a simulated one."""
    drive = config.axis(name).drive
    if drive.kind == "ideal" or drive.bus is None:
        return True
    return config.bus(drive.bus).drives == "simulated"


def _g(x: float) -> str:
    return f"{x:g}"


def _got(value: Any) -> str:
    if hasattr(value, "name"):
        return f"got {value.name}"
    if isinstance(value, tuple):
        return "got (" + ", ".join(_g(v) for v in value) + ")"
    return f"got {value!r}"


def _sw_range(cfg: AxisConfig) -> str:
    lo, hi = cfg.sw_limit_neg, cfg.sw_limit_pos
    return f"[{'-inf' if lo is None else _g(lo)}, {'inf' if hi is None else _g(hi)}]"


def _speed_name(cfg: AxisConfig) -> str:
    if cfg.v_neg == cfg.v_max:
        return "v_max"
    return "v_max" if cfg.v_max >= cfg.v_neg else "|v_min|"


def _acc_name(cfg: AxisConfig) -> str:
    if cfg.a_neg == cfg.a_max:
        return "a_max"
    return "a_max" if cfg.a_max >= cfg.a_neg else "|a_min|"


@dataclass
class _StepState:
    """Per step: the position of each axis at its start (None: unknown) and the target of the
    last move admitted in this step (``tail``; None: unknown; absent: none yet)."""

    entry: dict[str, float | None]
    tail: dict[str, float | None] = field(default_factory=dict)
    discrete: dict[str, bool] = field(default_factory=dict)


class _Check:
    def __init__(self, seq: Sequence, config: Config, c: Checker) -> None:
        from motionplc.sequence import _fb_types, _group_fb_types

        self.seq = seq
        self.config = config
        self.c = c
        self.report = CheckReport()
        self.types = {**_fb_types(), **_group_fb_types()}
        self.decls = {d.name: d for d in seq.blocks}
        self.order = {d.name: i for i, d in enumerate(seq.blocks)}
        self.cfgs = {a.name: _axis_config(config, a.name) for a in config.axes}
        self.trackers: dict[str, Any] = {}  # PLCopen parameter writes per axis (ConfigTracker)
        self.homing_by_drive = {a.name: a.homing.method == "drive" for a in config.axes}
        self.groups = config.group_map
        self.effective: dict[str, dict[str, Any]] = {}  # latched inputs of each block
        self.reported: dict[str, set[tuple[str, str]]] = {}

    # -- reporting ----------------------------------------------------------------------
    def error(self, call: Call, key: str, problem: str, allowed: str | None = None) -> None:
        lines = dict(call.lines)
        line = lines.get(key, lines.get(key.split(".")[0].split("[")[0], call.line))
        self.report.problems += 1
        self.c.error(line, f"{call.path}.{key}", problem, allowed)

    # -- the walk -----------------------------------------------------------------------
    def run(self) -> CheckReport:
        known: dict[str, float | None] = {
            a.name: (0.0 if _start_known(self.config, a.name) else None) for a in self.config.axes
        }
        for name, cfg in self.cfgs.items():
            if cfg is None or cfg.modulo is not None:
                known[name] = None
        self.steps(self.seq.steps, known)
        return self.report

    def steps(self, steps: tuple[Step, ...], known: dict[str, float | None]) -> set[str]:
        """Walk a list of steps from ``known`` (updated in place); returns the axes moved."""
        touched: set[str] = set()
        for st in steps:
            if st.branches:
                after: dict[str, list[float | None]] = {}
                for _, sub in st.branches:
                    k = dict(known)
                    for a in self.steps(sub, k):
                        after.setdefault(a, []).append(k[a])
                for a, vals in after.items():
                    known[a] = vals[0] if len(vals) == 1 else None
                    touched.add(a)
                continue
            touched |= self.step(st, known)
        return touched

    def step(self, st: Step, known: dict[str, float | None]) -> set[str]:
        ss = _StepState(dict(known))
        calls = sorted(st.calls, key=lambda cl: self.order.get(cl.block, 0))
        issued = []
        for call in calls:
            if self.call(call, ss):
                issued.append(call.block)
        waits_all = st.until.done == ("*",) or set(issued) <= set(st.until.done)
        moved = set(ss.tail)
        for a in moved:
            cfg = self.cfgs.get(a)
            known[a] = ss.tail[a] if waits_all and cfg is not None and cfg.modulo is None else None
        return moved

    # -- one call -----------------------------------------------------------------------
    def call(self, call: Call, ss: _StepState) -> bool:
        """Check one call; returns whether it issues a command."""
        from motionplc.sequence import SYNC_MOVE

        decl = self.decls.get(call.block)
        if decl is None:
            return False
        given = dict(call.inputs)
        if given.get("execute") is False:
            return False
        self.plausibility(call, decl, given)
        if decl.type == SYNC_MOVE:
            self.sync_move(call, decl.axis, dict(given.get("position", ())), ss)
            return True
        eff = self.effective.setdefault(call.block, {})
        eff.update(given)
        cls = self.types[decl.type]
        if decl.group:
            self.group_call(call, cls, decl.type, decl.axis, eff, given, ss)
        else:
            self.axis_call(call, cls, decl.type, decl.axis, eff, given, ss)
        return True

    def plausibility(self, call: Call, decl: Any, given: dict[str, Any]) -> None:
        """Warn on a velocity, acceleration, deceleration or jerk input beyond any machine
        for the axis' units (a group's: its first member's)."""
        from motionplc.plausibility import warning

        name = self.groups.get(decl.axis, (decl.axis,))[0]
        spec = next((a for a in self.config.axes if a.name == name), None)
        if spec is None:
            return
        lines = dict(call.lines)
        for pin, qty in (
            ("velocity", "velocity"),
            ("acceleration", "acceleration"),
            ("deceleration", "acceleration"),
            ("jerk", "jerk"),
        ):
            value = given.get(pin)
            if isinstance(value, bool) or not isinstance(value, (int, float)):
                continue
            text = warning(float(value), spec.units, qty, pin)
            if text is not None:
                self.c.warn(lines.get(pin, call.line), f"{call.path}.{pin}", text)

    def fb(self, cls: type, eff: dict[str, Any]) -> Any:
        fb = cls()
        fb.__dict__.update(eff)  # the latched inputs (names checked by the parser)
        return fb

    def problems(self, call: Call, fb: Any, target: Any, given: dict[str, Any]) -> dict[str, Any]:
        from motionplc.blocks.motion import InputChecks

        if not isinstance(fb, InputChecks):
            return {}
        from motionplc.sequence import InputRef

        checked = [p for p in type(fb).INPUTS if hasattr(fb, f"_in_{p}")]
        self.report.checks += len(checked)
        probs = fb.input_problems(target)
        # inputs naming a master axis, a cam or a block's output: the parser checked the
        # names; what they hold is known at run time only
        return {p: e for p, e in probs.items() if not isinstance(getattr(fb, p, None), InputRef)}

    def report_problems(
        self,
        call: Call,
        fb: Any,
        probs: dict[str, Any],
        given: dict[str, Any],
        describe: Any,
    ) -> None:
        seen = self.reported.setdefault(call.block, set())
        present = dict(call.lines)
        for pin, exc in probs.items():
            if pin not in given and (pin in present or not call.complete):
                continue  # the call's own errors are reported: its given inputs only
            value = getattr(fb, pin, None)
            problem, allowed = describe(pin, value, exc)
            if pin in given:
                self.error(call, pin, problem, allowed)
                seen.add((pin, str(exc)))
            elif (pin, str(exc)) not in seen:
                seen.add((pin, str(exc)))
                if pin in self.effective.get(call.block, {}):
                    src = "not given here, kept from an earlier call: "
                else:
                    src = "not given, the block's default: "
                self.error(call, pin, src + problem.removeprefix("got "), allowed)

    # -- single axis ----------------------------------------------------------------------
    def axis_call(
        self,
        call: Call,
        cls: type,
        kind: str,
        axis: str,
        eff: dict[str, Any],
        given: dict[str, Any],
        ss: _StepState,
    ) -> None:
        from motionplc.blocks.base import MotionFB
        from motionplc.blocks.enums import BufferMode, Direction
        from motionplc.blocks.motion import StaticAxis

        cfg = self.cfgs.get(axis)
        if cfg is None:
            return
        fb = self.fb(cls, eff)
        if kind in ("MC_SetOverride", "MC_SetPosition"):
            self.admin(call, cls, kind, cfg, eff, given, ss, axis)
            return
        probs = self.problems(call, fb, StaticAxis(cfg), given)
        if kind == "MC_MoveVelocity" and fb.direction is Direction.CURRENT and "velocity" in probs:
            # the sign comes from the set velocity at run time: fine if either direction fits
            if "velocity" not in fb.input_problems(StaticAxis(cfg, -1.0)):
                del probs["velocity"]
        self.report_problems(
            call, fb, probs, given, lambda p, v, e: self.describe_axis(kind, cfg, fb, p, v, e)
        )
        if kind in ("MC_WriteParameter", "MC_WriteBoolParameter") and not probs:
            self.parameter_write(axis, cfg, fb)
            return
        # where the axis goes (known positions) and the software limits of the target
        mode = getattr(fb, "buffer_mode", BufferMode.ABORTING)
        mode = mode if isinstance(mode, BufferMode) else BufferMode.ABORTING
        has_tail = axis in ss.tail
        prev = ss.tail.get(axis)
        immediate = mode is BufferMode.ABORTING or not has_tail
        if kind == "MC_MoveAbsolute":
            if "position" in probs:
                ss.tail[axis] = None
                return
            target = float(fb.position)
            base = ss.entry.get(axis) if immediate else prev
            ok = self.target_check(call, cfg, axis, "position", target, base, fb, probs, None)
            ss.tail[axis] = target if ok and not probs and cfg.modulo is None else None
            ss.discrete[axis] = True
        elif kind in ("MC_MoveRelative", "MC_MoveAdditive"):
            if "distance" in probs:
                ss.tail[axis] = None
                return
            d = float(fb.distance)
            if kind == "MC_MoveAdditive" and has_tail and ss.discrete.get(axis):
                base = prev  # the last commanded target
            else:
                base = ss.entry.get(axis) if immediate else prev
            ok = self.duration_check(call, "distance", abs(d), fb, probs)
            if base is None or cfg.modulo is not None:
                ss.tail[axis] = None
                return
            ok = self.target_check(call, cfg, axis, "distance", base + d, base, fb, probs, d) and ok
            ss.tail[axis] = base + d if ok and not probs else None
            ss.discrete[axis] = True
        elif kind == "MC_Home":
            by_drive = self.homing_by_drive.get(axis, False)  # ends where the drive's method does
            homed = (
                cfg.home_switch is None
                and not by_drive
                and "position" not in probs
                and cfg.modulo is None
            )
            ss.tail[axis] = float(fb.position) if homed else None
            ss.discrete[axis] = False
        elif kind in ("MC_MoveVelocity", "MC_Halt", "MC_Stop") or issubclass(cls, MotionFB):
            # any other motion (gearing, camming, superimposed, jog, ...): the position after
            # it is not known statically
            ss.tail[axis] = None
            ss.discrete[axis] = False

    def parameter_write(self, axis: str, cfg: AxisConfig, fb: Any) -> None:
        """A literal write of a PLCopen parameter (1-17): the later calls of the sequence are
        checked against the configuration it leaves (e.g. a software limit switched off, a
        lower MaxVelocityAppl), as MC_WriteParameter applies it at run time."""
        from motionplc.blocks.axis_params import PARAMETERS, ConfigTracker
        from motionplc.blocks.base import InputError

        n = fb.parameter_number
        if isinstance(n, bool) or not isinstance(n, int) or n not in PARAMETERS:
            return  # a drive parameter: nothing the checks know of
        tracker = self.trackers.setdefault(axis, ConfigTracker(cfg))
        try:
            tracker.write(n, fb.value)
        except InputError:
            return  # refused at run time as well (the FB's own checks report the input)
        self.cfgs[axis] = tracker.cfg

    def admin(
        self,
        call: Call,
        cls: type,
        kind: str,
        cfg: AxisConfig,
        eff: dict[str, Any],
        given: dict[str, Any],
        ss: _StepState,
        axis: str,
    ) -> None:
        """MC_SetOverride / MC_SetPosition: their own check path, one input at a time (the
        others at their valid defaults)."""
        from motionplc.blocks.base import InputError
        from motionplc.blocks.enums import ExecutionMode

        pins = (
            ("vel_factor", "acc_factor", "jerk_factor")
            if kind == "MC_SetOverride"
            else ("position", "execution_mode")
        )
        probs: dict[str, Any] = {}
        for pin in pins:
            if pin not in eff:
                continue
            self.report.checks += 1
            fb = self.fb(cls, {pin: eff[pin]})
            try:
                if kind == "MC_SetOverride":
                    fb._update(_AdminStub(cfg))
                else:
                    fb._start(_AdminStub(cfg))
            except InputError as exc:
                probs[pin] = exc
        fb = self.fb(cls, eff)
        self.report_problems(
            call, fb, probs, given, lambda p, v, e: self.describe_axis(kind, cfg, fb, p, v, e)
        )
        if kind == "MC_SetPosition":
            immediate = fb.execution_mode is ExecutionMode.IMMEDIATELY
            if probs or not immediate or axis in ss.tail or cfg.modulo is not None:
                ss.tail[axis] = None
                return
            base = ss.entry.get(axis)
            if fb.relative:
                ss.tail[axis] = None if base is None else base + float(fb.position)
            else:
                ss.tail[axis] = float(fb.position)
            ss.discrete[axis] = False

    def target_check(
        self,
        call: Call,
        cfg: AxisConfig,
        axis: str,
        key: str,
        target: float,
        base: float | None,
        fb: Any,
        probs: dict[str, Any],
        distance: float | None,
    ) -> bool:
        """The target against the software limits (and the move's duration from a known
        start); False if the FB would refuse it."""
        from motionplc.blocks.sw_limits import target_refused

        self.report.checks += 1
        limit = target_refused(cfg, target, base)
        if limit is not None and distance is not None:
            # a relative target from a position summed up here: not refused for a rounding
            tol = 1e-9 * (1.0 + abs(limit))
            if abs(target - limit) <= tol:
                limit = None
        lo, hi = cfg.sw_limit_neg, cfg.sw_limit_pos
        side = "max" if limit is not None and limit == hi and target > limit else "min"
        rng = _sw_range(cfg)
        if limit is not None:
            if distance is None:
                self.error(
                    call,
                    key,
                    f"got {target!r}, beyond the software limit {side} {_g(limit)} of axis "
                    f"{axis!r}",
                    f"a position in {rng}",
                )
            else:
                assert base is not None
                lo_d = "-inf" if lo is None else _g(lo - base)
                hi_d = "inf" if hi is None else _g(hi - base)
                self.error(
                    call,
                    key,
                    f"got {distance!r}: from {base:.9g} (where the sequence left axis {axis!r}) "
                    f"the target {target:.9g} is beyond the software limit {side} {_g(limit)}",
                    f"a distance in [{lo_d}, {hi_d}] from there",
                )
            return False
        if base is not None and cfg.modulo is None and distance is None:
            return self.duration_check(call, key, abs(target - base), fb, probs)
        return True

    def duration_check(
        self, call: Call, key: str, dist: float, fb: Any, probs: dict[str, Any]
    ) -> bool:
        """A move over ``dist`` at the FB's Velocity must not last longer than the supported
        duration; False (and an error) if it would."""
        from motionplc.blocks.axis_config import SUPPORTED_DURATION

        if "velocity" in probs:
            return False
        self.report.checks += 1
        v = float(fb.velocity)
        if dist > v * SUPPORTED_DURATION:
            self.error(
                call,
                "velocity" if "velocity" in dict(call.inputs) else key,
                f"got {fb.velocity!r}: too low for the distance {dist:.9g}, the move would last "
                f"more than the supported {SUPPORTED_DURATION:g} s",
                f"a velocity >= {_g(dist / SUPPORTED_DURATION)} for this move",
            )
            return False
        return True

    def describe_axis(
        self, kind: str, cfg: AxisConfig, fb: Any, pin: str, value: Any, exc: Exception
    ) -> tuple[str, str | None]:
        from motionplc.blocks.axis_config import OVERRIDE_MIN, POSITION_MAX, VELOCITY_RATIO_MIN
        from motionplc.blocks.enums import Direction

        num = isinstance(value, (int, float)) and not isinstance(value, bool)
        got = _got(value)
        name = cfg.name
        if pin == "velocity" and kind == "MC_MoveVelocity" and num:
            d = fb.direction
            v = -value if d is Direction.NEGATIVE else value
            rng = f"[{_g(-cfg.v_neg)}, {_g(cfg.v_max)}] after the direction"
            if isinstance(d, Direction) and d is not Direction.SHORTEST and math.isfinite(v):
                where = (
                    f"above the axis' v_max {_g(cfg.v_max)}"
                    if v > cfg.v_max
                    else f"below the axis' v_min {_g(-cfg.v_neg)}"
                )
                after = f" ({d.name}: {v!r})" if d is Direction.NEGATIVE else ""
                return f"{got}{after}, {where} of axis {name!r}", rng
            return f"{got}, {exc}", rng
        if pin == "velocity" and num:
            lo, hi = cfg.velocity_range()
            if not value > 0:
                why = "a move's velocity must be > 0 (the target gives the direction)"
            elif value > hi:
                why = f"above the axis' {_speed_name(cfg)} {_g(hi)} of axis {name!r}"
            else:
                why = f"below {_g(VELOCITY_RATIO_MIN)} x the axis' {_speed_name(cfg)}"
            return f"{got}, {why}", f"[{_g(lo)}, {_g(hi)}]"
        if pin in ("acceleration", "deceleration", "jerk") and num:
            lo, hi = cfg.jerk_range() if pin == "jerk" else cfg.acceleration_range()
            lim = "j_max" if pin == "jerk" else _acc_name(cfg)
            if value < 0:
                why = "negative"
            elif value > hi:
                why = f"above the axis' {lim} {_g(hi)} of axis {name!r}"
            else:
                why = f"below the lowest supported {_g(lo)} (a change over 1e4 s at most)"
            return f"{got}, {why}", f"0 (the axis' limit) or [{_g(lo)}, {_g(hi)}]"
        if pin in ("position", "distance") and num:
            m = cfg.modulo
            if m is not None and pin == "position":
                return f"{got}, outside the modulo axis' range", f"[0, {_g(m)})"
            return (
                f"{got}, outside the supported positions",
                f"[{_g(-POSITION_MAX)}, {_g(POSITION_MAX)}]",
            )
        if pin == "direction":
            return f"{got}, not accepted by {kind}", "POSITIVE, NEGATIVE, CURRENT"
        if pin in ("vel_factor", "acc_factor", "jerk_factor"):
            rng = f"[{_g(OVERRIDE_MIN)}, 1]"
            return f"{got}, outside the override range", (
                f"0 or {rng}" if pin == "vel_factor" else rng
            )
        return str(exc), None

    # -- SyncMoveAbsolute ---------------------------------------------------------------
    def sync_move(self, call: Call, group: str, targets: dict[str, float], ss: _StepState) -> None:
        from motionplc.blocks.sw_limits import target_refused

        for a, x in targets.items():
            cfg = self.cfgs.get(a)
            if cfg is None:
                continue
            self.report.checks += 1
            limit = target_refused(cfg, x, ss.entry.get(a))
            if limit is not None:
                side = "max" if x > limit else "min"
                self.error(
                    call,
                    f"position.{a}",
                    f"got {x!r}, beyond the software limit {side} {_g(limit)} of axis {a!r}",
                    f"a position in {_sw_range(cfg)}",
                )
            ss.tail[a] = x
            ss.discrete[a] = True

    # -- groups ---------------------------------------------------------------------------
    def group_call(
        self,
        call: Call,
        cls: type,
        kind: str,
        group: str,
        eff: dict[str, Any],
        given: dict[str, Any],
        ss: _StepState,
    ) -> None:
        from motionplc.blocks.enums import BufferMode, CircMode

        members = self.groups.get(group, ())
        cfgs = [self.cfgs.get(a) for a in members]
        if any(c is None for c in cfgs):
            return
        fb = self.fb(cls, eff)
        probs = self.problems(call, fb, _GroupStub(len(members)), given)
        self.report_problems(call, fb, probs, given, lambda p, v, e: (str(e), None))
        # path dynamics above what the members can ever reach together
        for pin in _GROUP_DYN:
            if pin in given and pin not in probs and hasattr(fb, pin):
                self.group_dynamics(call, kind, pin, float(given[pin]), cfgs)
        if kind in _GROUP_STOPS:
            for a in members:
                ss.tail[a] = None
            return
        if not (kind in _ABS_GROUP or kind in _REL_GROUP or kind in _CIRC or kind in _CURVES):
            return
        mode = fb.buffer_mode if isinstance(fb.buffer_mode, BufferMode) else BufferMode.ABORTING
        has_tail = any(a in ss.tail for a in members)
        if not has_tail:
            base_l = [ss.entry.get(a) for a in members]
        elif mode is BufferMode.ABORTING:
            base_l = [None] * len(members)  # (where the abort leaves the path: run time)
        else:
            base_l = [ss.tail.get(a) for a in members]
        base = None if any(b is None for b in base_l) else tuple(float(b) for b in base_l)  # type: ignore[arg-type]
        relative = kind in _REL_GROUP or kind == "MC_MoveCircularRelative"

        def place(pt: tuple[float, ...]) -> tuple[float, ...] | None:
            if not relative:
                return pt
            if base is None:
                return None
            return tuple(b + d for b, d in zip(base, pt, strict=True))

        end: tuple[float, ...] | None = None
        ok = not probs
        if kind in _ABS_GROUP or kind in _REL_GROUP:
            pin = "distance" if kind in _REL_GROUP else "position"
            if pin not in probs:
                end = place(tuple(getattr(fb, pin)))
                if end is not None:
                    ok &= self.points_check(call, pin, end, members, cfgs, relative)
        elif kind in _CIRC:
            if "end_point" not in probs:
                end = place(tuple(fb.end_point))
                if end is not None:
                    ok &= self.points_check(call, "end_point", end, members, cfgs, relative)
            if fb.circ_mode is CircMode.BORDER and "aux_point" not in probs:
                via = place(tuple(fb.aux_point))
                if via is not None:
                    ok &= self.points_check(call, "aux_point", via, members, cfgs, relative)
        elif "points" not in probs:
            pts = tuple(tuple(p) for p in fb.points)
            for i, p in enumerate(pts):
                ok &= self.points_check(call, f"points[{i}]", p, members, cfgs, False)
            end = pts[-1] if pts else None
        for i, a in enumerate(members):
            ss.tail[a] = None if end is None or not ok else end[i]

    def points_check(
        self,
        call: Call,
        key: str,
        pt: tuple[float, ...],
        members: tuple[str, ...],
        cfgs: list[Any],
        relative: bool,
    ) -> bool:
        """Each member's value of a group point against its software limits; False (and an
        error per member) if any is beyond."""
        from motionplc.blocks.sw_limits import point_refused

        lines = dict(call.lines)
        ok = True
        for i, (a, cfg, x) in enumerate(zip(members, cfgs, pt, strict=True)):
            self.report.checks += 1
            limit = point_refused(cfg, x)
            if limit is None:
                continue
            ok = False
            sub = f"{key}.{a}" if f"{key}.{a}" in lines else f"{key}[{i}]"
            if sub not in lines:
                sub = key
            side = "max" if x > limit else "min"
            rng = _sw_range(cfg)
            what = (
                f"ends at {x:.9g} (from where the sequence left the group)"
                if relative
                else (f"got {x!r}")
            )
            self.error(
                call,
                sub,
                f"{what}, beyond the software limit {side} {_g(limit)} of axis {a!r}",
                f"a position of {a} in {rng}",
            )
        return ok

    def group_dynamics(
        self, call: Call, kind: str, pin: str, value: float, cfgs: list[Any]
    ) -> None:
        self.report.checks += 1
        if value == 0.0:
            return
        if pin == "velocity":
            per = [c.v_top for c in cfgs]
        elif pin == "jerk":
            per = [c.j_max for c in cfgs]
        else:
            per = [c.a_top for c in cfgs]
        if kind.startswith("MC_MoveDirect"):
            top = max(per)
            what = f"the fastest member's limit {_g(top)}"
        else:
            top = math.sqrt(sum(x * x for x in per))
            what = f"what the members reach together {_g(top)} (sqrt of the sum of squares)"
        if not math.isfinite(top) or value <= top * (1.0 + 1e-12):
            return
        self.error(
            call,
            pin,
            f"got {value!r}, above {what}",
            f"(0, {_g(top)}]" if pin == "velocity" else f"0 (the axes' limits) or (0, {_g(top)}]",
        )


def check_sequence(seq: Sequence, config: Config, c: Checker) -> CheckReport:
    """Check every literal FB input of ``seq`` against ``config``'s axes and groups; add one
    located error to ``c`` per problem (``FILE:LINE: steps[i].call[j].pin: got ..., why
    (allowed: ...)``). Returns how many values were checked and how many problems found."""
    return _Check(seq, config, c).run()
