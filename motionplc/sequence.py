"""Scripted motion sequences (YAML, SFC-like) and their runner.

A sequence is a list of steps. A step issues FB calls, waits for its transition condition,
checks its expectations, then the next step starts::

    task: motion            # optional: the task that runs the sequence (default: the first)
    timeout: 60             # optional: [s] of (virtual) time for the whole sequence
    steps:
      - name: power on
        call:
          - {block: pwr_x, type: MC_Power, axis: x, enable: true}
        until: {done: pwr_x}                 # MC_Power: status; enable FBs: valid
      - name: move
        call:
          - {block: mx, type: MC_MoveAbsolute, axis: x, position: 1.0, velocity: 0.5}
          - {block: mx2, type: MC_MoveRelative, axis: x, distance: -0.5, velocity: 0.5,
             buffer_mode: BLENDING_PREVIOUS}
        until: done                          # every block issued in this step is Done
        expect: {x.position: 0.5, within: 1.0e-9}
      - wait: 0.2                            # a step that only waits
      - parallel:                            # branches run side by side; joined when all end
          x: [{call: [{block: mx, position: 0.0}]}]
          y: [{call: [{block: my, type: MC_MoveAbsolute, axis: y, position: 0.3,
                       velocity: 0.2}]}]

Calls: ``block`` names an FB instance (created on first use with ``type`` and ``axis``; later
calls reuse it, and re-issuing an Execute FB gives it a new rising edge). Inputs are the FB's
pins (snake_case PLCopen names); enums by member name (``buffer_mode: BUFFERED``,
``direction: POSITIVE``). ``type: SyncMoveAbsolute`` with ``group`` and ``position: {axis:
target}`` moves the axes of a group so that they start and arrive together (each axis' own
time-optimal move, time-scaled to the slowest one; the axes must be at rest).

Axes groups (``groups:`` of the configuration; PLCopen Part 4): a group FB takes ``group``
instead of ``axis``: ``{block: m1, type: MC_MoveLinearAbsolute, group: xyz, position: {x: 0.1,
y: 0.2, z: 0.0}, velocity: 0.5, buffer_mode: BLENDING_LOW, transition_mode:
TM_MAX_CORNER_DEVIATION, transition_parameter: 0.001}``. Points (``position``, ``distance``,
``end_point``, ``aux_point``) are a mapping by member axis (every member exactly once) or a list
in member order; ``aux_point`` may be a number (the radius, CircMode RADIUS); ``points`` (the
passing points of MC_MovePassingPoints / MC_MoveBSpline) is a list of points. Enum inputs by
name (``circ_mode: CENTER``, ``path_choice: CLOCKWISE``). Types: MC_GroupEnable / Disable /
Reset / Stop / Halt / Interrupt / Continue / SetOverride / ReadStatus / ReadError /
ReadActualPosition / ReadActualVelocity, MC_MoveLinear* / MC_MoveCircular* / MC_MoveDirect*,
MC_MovePassingPoints, MC_MoveBSpline (the group's members are fixed by the configuration:
MC_AddAxisToGroup and its kin are not offered). The members must be powered (MC_Power) before
MC_GroupEnable. ``{block: st, execute: false}`` lets an Execute FB's input fall (e.g. to end an
MC_GroupStop's hold) without issuing a command.

Conditions (``until``; several keys must all hold): ``done`` (a block, a list of blocks, or
``done`` alone = every block issued in the step), ``time`` (seconds in the step), ``position:
{x: {min: a, max: b}}``, ``state: {x: STANDSTILL, xyz: GROUP_STANDBY}``. A step without
``until`` waits for its blocks (``done``). ``timeout`` of a step fails the run when the
condition is not met in time.
``expect: {x.position: 1.0, x.state: STANDSTILL, xyz.state: GROUP_STANDBY, mx.done: true,
within: 1.0e-6}`` is checked when the step's condition holds (groups: ``state``,
``path_velocity``); a mismatch fails the run with a clear message, as does an FB error, an axis
going to ErrorStop or a group going to GroupErrorStop.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from enum import Enum
from pathlib import Path
from typing import TYPE_CHECKING, Any

from motionplc.config import Checker, Config, YamlList, YamlMap, _tname, join, load_yaml
from motionplc.schema import sequence as _schema

if TYPE_CHECKING:
    from motionplc.config import Machine
    from motionplc.runtime import CycleContext

__all__ = [
    "AXIS_FIELDS",
    "GROUP_FIELDS",
    "Call",
    "Condition",
    "Expectation",
    "Sequence",
    "SequenceRunner",
    "Step",
    "load_sequence",
    "parse_sequence",
]

AXIS_FIELDS = _schema.AXIS_FIELDS
GROUP_FIELDS = _schema.GROUP_FIELDS


def _target_fields(kind: str) -> tuple[str, tuple[str, ...], Any] | None:
    """What an expectation may name on an axis or a group: (kind, fields, state enum)."""
    from motionplc.blocks.enums import AxisState, GroupState  # (lazy, as the FB imports)

    if kind == "axis":
        return kind, AXIS_FIELDS, AxisState
    if kind == "group":
        return kind, GROUP_FIELDS, GroupState
    return None


# the key tables come from the schema (motionplc.schema.sequence): the validator and the
# reference (docs/reference/sequence.md, docs/schema/sequence.schema.json) cannot drift
SYNC_MOVE = _schema.SYNC_MOVE
# group FBs not offered in sequences: the members are fixed by the configuration
_GROUP_ADMIN = _schema.GROUP_ADMIN
# group FB inputs that are points (one value per member)
_POINT_PINS = _schema.POINT_PINS
_REF_PINS = _schema.REF_PINS
_TOP = _schema.TOP.table()
_STEP = _schema.STEP.table()
_COND = _schema.COND.table()


def _fb_types() -> dict[str, type]:
    import motionplc.blocks as blocks

    return {n: getattr(blocks, n) for n in blocks.__all__ if n.startswith("MC_")}


def _group_fb_types() -> dict[str, type]:
    from motionplc.blocks import group_blocks

    return {
        n: getattr(group_blocks, n)
        for n in group_blocks.__all__
        if n.startswith("MC_") and n not in _GROUP_ADMIN
    }


def _is_enable_fb(cls: type) -> bool:
    return "enable" in cls.INPUTS  # type: ignore[attr-defined]


def _is_number(x: Any) -> bool:
    return isinstance(x, (int, float)) and not isinstance(x, bool)


# ------------------------------------------------------------------------ dataclasses
@dataclass(frozen=True, slots=True)
class Call:
    """One FB call of a step: inputs to set (execute FBs also get a rising edge).

    ``path`` is the call's key path in the file (``steps[2].parallel.x[0].call[1]``);
    ``lines`` the line of each input and of each value inside a point (``position``,
    ``position.x`` or ``position[0]``, ``points[1].y``), for located messages; ``complete``
    is False when the call itself had errors (then only its given inputs are checked
    against the machine, not the values it would keep from before).
    """

    block: str
    inputs: tuple[tuple[str, Any], ...]
    line: int
    path: str = ""
    lines: tuple[tuple[str, int], ...] = ()
    complete: bool = True


@dataclass(frozen=True, slots=True)
class Condition:
    """Transition condition: all given parts must hold. ``done = ("*",)``: every issued block."""

    done: tuple[str, ...] = ("*",)
    time: float | None = None
    positions: tuple[tuple[str, float, float], ...] = ()
    states: tuple[tuple[str, str], ...] = ()


@dataclass(frozen=True, slots=True)
class Expectation:
    target: str  # "axis.field" or "block.output"
    value: Any
    within: float
    line: int


@dataclass(frozen=True, slots=True)
class Step:
    name: str
    line: int
    calls: tuple[Call, ...] = ()
    until: Condition = field(default_factory=Condition)
    timeout: float | None = None
    expects: tuple[Expectation, ...] = ()
    branches: tuple[tuple[str, tuple[Step, ...]], ...] = ()


@dataclass(frozen=True, slots=True)
class BlockDecl:
    """An FB instance of the sequence: ``type`` (an MC_* name or SyncMoveAbsolute), its axis
    (or group: ``group`` is True for the Part 4 group FBs)."""

    name: str
    type: str
    axis: str
    line: int
    group: bool = False


@dataclass(frozen=True, slots=True)
class InputRef:
    """An FB input naming another object of the machine, resolved when the call is issued:
    ``kind`` "axis" (a master axis), "cam" (a cam table of ``cams:``) or "block" (the
    ``cam_table_id`` output of an MC_CamTableSelect block)."""

    kind: str
    name: str


@dataclass(frozen=True, slots=True)
class Sequence:
    path: str
    task: str
    timeout: float
    blocks: tuple[BlockDecl, ...]
    steps: tuple[Step, ...]
    warnings: tuple[str, ...] = ()  # ``FILE:LINE: key.path: warning: ...`` (plausibility)


# ------------------------------------------------------------------------ parsing
class _Parser:
    def __init__(self, c: Checker, config: Config) -> None:
        self.c = c
        self.config = config
        self.types = _fb_types()
        self.group_types = _group_fb_types()
        self.blocks: dict[str, BlockDecl] = {}
        self.anon = 0
        self.axes = [a.name for a in config.axes]
        self.groups = config.group_map
        self.lines: dict[str, int] = {}  # of the inputs of the call being parsed

    def steps(self, seq: Any, line: int, path: str) -> tuple[Step, ...]:
        c = self.c
        if not isinstance(seq, YamlList) or not seq:
            c.error(line, path, f"got {_tname(seq)}", "a non-empty list of steps")
            return ()
        out = []
        for i, body in enumerate(seq):
            st = self.step(body, seq.line_of(i), join(path, i), i)
            if st is not None:
                out.append(st)
        return tuple(out)

    def step(self, body: Any, line: int, path: str, index: int) -> Step | None:
        c = self.c
        m = c.mapping(body, line, path, _STEP)
        if m is None:
            return None
        name = c.string(m, "name", path, f"step {index + 1}") or f"step {index + 1}"
        kinds = [k for k in ("call", "wait", "parallel") if k in m]
        if len(kinds) > 1:
            c.error(
                m.key_lines[kinds[1]],
                join(path, kinds[1]),
                f"a step has one of call, wait, parallel; this one also has {kinds[0]}",
                "call, wait, parallel",
            )
        calls: list[Call] = []
        if "call" in m:
            cl = m["call"]
            cp = join(path, "call")
            if isinstance(cl, YamlMap):  # a single call
                cl_list = YamlList()
                cl_list.append(cl)
                cl_list.item_lines.append(m.line_of("call"))
                cl = cl_list
            if not isinstance(cl, YamlList) or not cl:
                c.error(m.line_of("call"), cp, f"got {_tname(cl)}", "a list of FB calls")
            else:
                for j, item in enumerate(cl):
                    call = self.call(item, cl.line_of(j), join(cp, j))
                    if call is not None:
                        calls.append(call)
        until = Condition()
        if "wait" in m:
            w = c.number(m, "wait", path, None, ge=0.0)
            until = Condition(done=(), time=w)
        if "until" in m:
            until = self.condition(m, path, bool(calls))
        elif not calls and "wait" not in m:
            until = Condition(done=())
        timeout = c.number(m, "timeout", path, None, gt=0.0)
        branches: list[tuple[str, tuple[Step, ...]]] = []
        if "parallel" in m:
            pp = join(path, "parallel")
            pm = c.mapping(m["parallel"], m.line_of("parallel"), pp, None)
            if pm is not None:
                if not pm:
                    c.error(pm.line, pp, "no branch", "one or more named branches")
                for bname, blist in pm.items():
                    branches.append(
                        (str(bname), self.steps(blist, pm.line_of(bname), join(pp, bname)))
                    )
            if "until" not in m:
                until = Condition(done=())
        expects = self.expects(m, path) if "expect" in m else ()
        return Step(name, line, tuple(calls), until, timeout, expects, tuple(branches))

    def call(self, body: Any, line: int, path: str) -> Call | None:
        c = self.c
        errors_before = len(c.errors)
        m = c.mapping(body, line, path, None)
        if m is None:
            return None
        bname = m.get("block")
        if "block" in m and (not isinstance(bname, str) or not bname or "." in bname):
            c.error(
                m.line_of("block"),
                join(path, "block"),
                f"got {_tname(bname)}",
                "a name without '.'",
            )
            return None
        decl = self.blocks.get(bname) if isinstance(bname, str) else None
        fb_type = m.get("type")
        type_names = [*self.types, *self.group_types, SYNC_MOVE]
        # the types to suggest: those of the call's target (axis or group), else all
        if "group" in m and "axis" not in m and "slave" not in m:
            shown = [*self.group_types, SYNC_MOVE]
        elif "slave" in m and "group" not in m:
            shown = [n for n, k in self.types.items() if _schema.target_pin(k) == "slave"]
        elif "axis" in m and "group" not in m:
            shown = [n for n, k in self.types.items() if _schema.target_pin(k) == "axis"]
            shown.append(SYNC_MOVE)
        else:
            shown = type_names
        if decl is None:
            if fb_type is None:
                c.error(
                    m.line,
                    join(path, "type"),
                    "missing (first use of the block)",
                    ", ".join(shown),
                )
                return None
            if fb_type not in type_names:
                c.error(
                    m.line_of("type"),
                    join(path, "type"),
                    f"got {_tname(fb_type)}",
                    ", ".join(shown),
                )
                return None
            on_group = fb_type == SYNC_MOVE or fb_type in self.group_types
            target_key = "group" if on_group else _schema.target_pin(self.types[fb_type])
            target = m.get(target_key)
            options = list(self.groups) if on_group else self.axes
            if target not in options:
                problem = "missing" if target is None else f"unknown {target_key} {target!r}"
                c.error(
                    m.line_of(target_key),
                    join(path, target_key),
                    problem,
                    ", ".join(options) or f"no {target_key} is defined",
                )
                return None
            if bname is None:
                self.anon += 1
                bname = f"{fb_type}_{self.anon}"
            decl = BlockDecl(bname, fb_type, target, m.line, fb_type in self.group_types)
            self.blocks[bname] = decl
        else:
            if fb_type is not None and fb_type != decl.type:
                c.error(
                    m.line_of("type"),
                    join(path, "type"),
                    f"block {bname!r} is a {decl.type} (line {decl.line})",
                    decl.type,
                )
            key = self.target_key(decl)
            if key in m and m[key] != decl.axis:
                c.error(
                    m.line_of(key),
                    join(path, key),
                    f"block {bname!r} is bound to {decl.axis!r} (line {decl.line})",
                    decl.axis,
                )
        self.lines = {}
        inputs = self.inputs(m, path, decl)
        complete = len(c.errors) == errors_before
        return Call(decl.name, inputs, line, path, tuple(self.lines.items()), complete)

    def target_key(self, decl: BlockDecl) -> str:
        """The key naming the block's axis or group: axis, slave or group."""
        if decl.type == SYNC_MOVE or decl.group:
            return "group"
        return _schema.target_pin(self.types[decl.type])

    def ref(self, val: Any, line: int, path: str, pin: str, decl: BlockDecl) -> InputRef | None:
        """An input naming an axis (``master``), a cam table or a block's output."""
        c = self.c
        kind = _REF_PINS[pin]
        if kind == "axis":
            options = [a for a in self.axes if a != decl.axis]
            what = f"an axis other than the slave {decl.axis!r}"
        elif kind == "cam":
            options = [cam.name for cam in self.config.cams]
            what = "a cam of cams:" if options else "a cam of cams: (the configuration has none)"
        else:
            options = [b.name for b in self.blocks.values() if b.type == "MC_CamTableSelect"]
            what = (
                "an MC_CamTableSelect block used before"
                if options
                else "an MC_CamTableSelect block used before (there is none so far)"
            )
        if not isinstance(val, str) or val not in options:
            c.error(line, path, f"got {_tname(val)}", ", ".join(options) or what)
            return None
        return InputRef(kind, val)

    def inputs(self, m: YamlMap, path: str, decl: BlockDecl) -> tuple[tuple[str, Any], ...]:
        c = self.c
        if decl.type == SYNC_MOVE:
            allowed = ["block", "type", "group", "position"]
            c.keys(m, path, {k: False for k in allowed})
            pos = m.get("position")
            members = self.groups[decl.axis]
            if pos is None:
                return ()
            pm = c.mapping(
                pos, m.line_of("position"), join(path, "position"), {a: False for a in members}
            )
            out: dict[str, float] = {}
            self.lines["position"] = m.line_of("position")
            if pm is not None:
                for a in members:
                    v = c.number(pm, a, join(path, "position"), None)
                    if v is not None:
                        out[a] = v
                        self.lines[f"position.{a}"] = pm.line_of(a)
            return (("position", tuple(out.items())),)
        cls = self.group_types[decl.type] if decl.group else self.types[decl.type]
        ref = "axes_group" if decl.group else _schema.target_pin(cls)
        pins = [p for p in cls.INPUTS if p not in (ref, "execute")]  # type: ignore[attr-defined]
        has_execute = "execute" in cls.INPUTS  # type: ignore[attr-defined]
        target = "group" if decl.group else ref
        keys = ["block", "type", target, *pins]
        checked = m
        if has_execute and "execute" in m:  # accepted, documented, not listed among the inputs
            checked = YamlMap()
            checked.line = m.line
            for k in m:
                if k != "execute":
                    checked[k] = m[k]
                    checked.key_lines[k] = m.key_lines[k]
        c.keys(checked, path, {k: False for k in keys})
        proto = cls()
        out_inputs: list[tuple[str, Any]] = []
        if has_execute and "execute" in m:
            if m["execute"] is not False:
                c.error(
                    m.line_of("execute"),
                    join(path, "execute"),
                    f"got {_tname(m['execute'])}",
                    "false (lets Execute fall; a call without it issues the command)",
                )
            else:
                extra = [k for k in m if k not in ("block", "type", target, "execute")]
                if extra:
                    c.error(
                        m.key_lines[extra[0]],
                        join(path, extra[0]),
                        "inputs are latched at Execute's rising edge, not with execute: false",
                        f"block, type, {target}, execute",
                    )
                out_inputs.append(("execute", False))
        members = self.groups.get(decl.axis, ()) if decl.group else ()
        for pin in pins:
            if pin not in m:
                continue
            default = getattr(proto, pin)
            val = m[pin]
            line = m.line_of(pin)
            p = join(path, pin)
            self.lines[pin] = line
            if not decl.group and pin in _REF_PINS:
                r = self.ref(val, line, p, pin, decl)
                if r is None:
                    continue
                val = r
            elif decl.group and pin in _POINT_PINS:
                if pin == "aux_point" and _is_number(val):
                    # the radius (CircMode RADIUS): in the schema's range (negative: long arc)
                    if not any(n.accepts(float(val)) for n in _schema.RADIUS):
                        c.error(
                            line,
                            p,
                            f"got {val!r}",
                            "a point, or a radius "
                            + " or ".join(n.range_text() for n in _schema.RADIUS)
                            + " (negative: the arc longer than half a circle)",
                        )
                        continue
                    val = (float(val),)
                else:
                    pt = self.point(val, line, p, members, pin)
                    if pt is None:
                        continue
                    val = pt
            elif decl.group and pin == "points":
                pts = self.points(val, line, p, members)
                if pts is None:
                    continue
                val = pts
            elif isinstance(default, bool):
                if not isinstance(val, bool):
                    c.error(line, p, f"got {_tname(val)}", "true, false")
                    continue
            elif isinstance(default, Enum):
                enum = type(default)
                names = [e.name for e in enum]
                if val not in names:
                    c.error(line, p, f"got {_tname(val)}", ", ".join(names))
                    continue
                val = enum[val]
            elif isinstance(default, int):  # INT inputs (gear ratios, parameter numbers)
                if isinstance(val, bool) or not isinstance(val, int):
                    c.error(line, p, f"got {_tname(val)}", "an integer")
                    continue
            elif isinstance(default, (int, float)):
                if val is None:  # (Checker.number takes null for "not given")
                    c.error(line, p, "got null", "a number")
                    continue
                num = c.number(m, pin, path, None)
                if num is None:
                    continue
                val = num
            out_inputs.append((pin, val))
        return tuple(out_inputs)

    def point(
        self, val: Any, line: int, path: str, members: tuple[str, ...], key: str = ""
    ) -> tuple[float, ...] | None:
        """A group point: ``{axis: value}`` with every member once, or a list in member
        order; None (and an error) otherwise. ``key``: where the values' lines are recorded
        (``key.x`` / ``key[0]`` in ``self.lines``)."""
        c = self.c
        allowed = (
            "{" + ", ".join(f"{a}: ..." for a in members) + "} (every member once) or a list "
            f"of {len(members)} numbers in member order"
        )
        if isinstance(val, YamlMap):
            pm = c.mapping(val, line, path, {a: True for a in members})
            if pm is None or any(a not in pm for a in members) or any(k not in members for k in pm):
                return None
            out = []
            for a in members:
                v = c.number(pm, a, path, None, ge=-1e12, le=1e12)
                if v is None:
                    return None
                out.append(v)
                if key:
                    self.lines[f"{key}.{a}"] = pm.line_of(a)
            return tuple(out)
        if isinstance(val, YamlList):
            if len(val) != len(members):
                c.error(line, path, f"got a list of {len(val)} values", allowed)
                return None
            out = []
            for i, x in enumerate(val):
                if not _is_number(x) or not abs(float(x)) <= 1e12:
                    c.error(
                        val.line_of(i),
                        join(path, i),
                        f"got {_tname(x)}",
                        "a number >= -1e+12 and <= 1e+12",
                    )
                    return None
                out.append(float(x))
                if key:
                    self.lines[f"{key}[{i}]"] = val.line_of(i)
            return tuple(out)
        c.error(line, path, f"got {_tname(val)}", allowed)
        return None

    def points(
        self, val: Any, line: int, path: str, members: tuple[str, ...]
    ) -> tuple[tuple[float, ...], ...] | None:
        """A non-empty list of group points."""
        if not isinstance(val, YamlList) or not val:
            self.c.error(line, path, f"got {_tname(val)}", "a non-empty list of points")
            return None
        out = []
        key = path.rpartition(".")[2]
        for i, item in enumerate(val):
            self.lines[f"{key}[{i}]"] = val.line_of(i)
            pt = self.point(item, val.line_of(i), join(path, i), members, f"{key}[{i}]")
            if pt is None:
                return None
            out.append(pt)
        return tuple(out)

    def condition(self, m: YamlMap, path: str, has_calls: bool) -> Condition:
        c = self.c
        up = join(path, "until")
        u = m["until"]
        if u == "done":
            return Condition()
        cm = c.mapping(u, m.line_of("until"), up, _COND, "done, or a mapping of conditions")
        if cm is None:
            return Condition()
        done: tuple[str, ...] = ()
        if "done" in cm:
            d = cm["done"]
            names = [d] if isinstance(d, str) else d
            if d == "done" or d is True:
                done = ("*",)
            elif not isinstance(names, list) or not names:
                c.error(
                    cm.line_of("done"),
                    join(up, "done"),
                    f"got {_tname(d)}",
                    "a block name or a list of block names",
                )
            else:
                ok = []
                for name in names:
                    if name not in self.blocks:
                        c.error(
                            cm.line_of("done"),
                            join(up, "done"),
                            f"unknown block {name!r}",
                            ", ".join(self.blocks) or "no block is declared yet",
                        )
                    else:
                        ok.append(name)
                done = tuple(ok)
        t = c.number(cm, "time", up, None, ge=0.0)
        positions = []
        if "position" in cm:
            pp = join(up, "position")
            pm = c.mapping(
                cm["position"], cm.line_of("position"), pp, {a: False for a in self.axes}
            )
            for a, spec in (pm or {}).items():
                if a not in self.axes:
                    continue
                ap = join(pp, a)
                sm = c.mapping(spec, pm.line_of(a), ap, {"min": False, "max": False})
                if sm is not None:
                    lo = c.number(sm, "min", ap, -math.inf)
                    hi = c.number(sm, "max", ap, math.inf)
                    if "min" not in sm and "max" not in sm:
                        c.error(sm.line, ap, "no bound", "min, max")
                    positions.append(
                        (a, lo if lo is not None else -math.inf, hi if hi is not None else math.inf)
                    )
        states = []
        if "state" in cm:
            from motionplc.blocks.enums import AxisState, GroupState

            sp = join(up, "state")
            sm2 = c.mapping(
                cm["state"],
                cm.line_of("state"),
                sp,
                {a: False for a in [*self.axes, *self.groups]},
            )
            names = tuple(s.name for s in AxisState)
            gnames = tuple(s.name for s in GroupState)
            for a in sm2 or {}:
                if a in self.axes or a in self.groups:
                    st = c.choice(sm2, a, sp, names if a in self.axes else gnames, None)
                    if st is not None:
                        states.append((a, st))
        return Condition(done, t, tuple(positions), tuple(states))

    def expects(self, m: YamlMap, path: str) -> tuple[Expectation, ...]:
        c = self.c
        ep = join(path, "expect")
        em = c.mapping(m["expect"], m.line_of("expect"), ep, None)
        if em is None:
            return ()
        within = c.number(em, "within", ep, 1e-6, ge=0.0)
        within = 1e-6 if within is None else within
        out = []
        allowed_axes = ", ".join(
            [f"{a}.{f}" for a in self.axes for f in AXIS_FIELDS]
            + [f"{g}.{f}" for g in self.groups for f in GROUP_FIELDS]
        )
        for key, val in em.items():
            if key == "within":
                continue
            kp = join(ep, key)
            line = em.line_of(key)
            obj, _, attr = str(key).partition(".")
            target = _target_fields(
                "axis" if obj in self.axes else "group" if obj in self.groups else ""
            )
            if target is not None:
                kind, fields, states = target
                if attr not in fields:
                    c.error(
                        em.key_lines[key], kp, f"unknown {kind} field {attr!r}", ", ".join(fields)
                    )
                    continue
                if attr == "state":
                    names = tuple(s.name for s in states)
                    if val not in names:
                        c.error(line, kp, f"got {_tname(val)}", ", ".join(names))
                        continue
                elif isinstance(val, bool) or not isinstance(val, (int, float)):
                    c.error(line, kp, f"got {_tname(val)}", "a number")
                    continue
            elif obj in self.blocks and attr:
                if not isinstance(val, (bool, int, float)):
                    c.error(line, kp, f"got {_tname(val)}", "a boolean or a number")
                    continue
            else:
                c.error(
                    em.key_lines[key],
                    kp,
                    f"unknown target {key!r}",
                    f"{allowed_axes}, BLOCK.OUTPUT, within",
                )
                continue
            out.append(Expectation(str(key), val, within, line))
        return tuple(out)


def parse_sequence(data: Any, file: str | Path, config: Config) -> Sequence:
    """Validate a loaded sequence document against ``config``; raise one ConfigError.

    Besides its structure, every literal FB input is checked against the machine (the axis'
    limits, software limits and modulo, the group's members; :mod:`motionplc.sequence_check`)
    with the FBs' own input checks: a sequence that loads issues no command its FB would
    refuse for an input range (what depends on the state at run time is left to the run).
    """
    c = Checker(file)
    top = c.mapping(data, getattr(data, "line", 1), "(top level)", _TOP)
    if top is None:
        c.raise_if_any()
        raise AssertionError("unreachable")
    tasks = tuple(t.name for t in config.runtime.tasks)
    task = c.choice(top, "task", "", tasks, tasks[0])
    timeout = c.number(top, "timeout", "", 600.0, gt=0.0) or 600.0
    p = _Parser(c, config)
    steps = p.steps(top.get("steps"), top.line_of("steps"), "steps") if "steps" in top else ()
    seq = Sequence(str(file), task, timeout, tuple(p.blocks.values()), steps)
    from motionplc.sequence_check import check_sequence

    check_sequence(seq, config, c)
    # every problem of the file at once, in the order of its lines
    prefix = len(c.file) + 1
    c.errors.sort(key=lambda e: int(e[prefix:].partition(":")[0] or 0))
    c.raise_if_any()
    return replace(seq, warnings=tuple(c.warnings)) if c.warnings else seq


def load_sequence(path: str | Path, config: Config) -> Sequence:
    """Load and validate a sequence file for ``config``."""
    return parse_sequence(load_yaml(path), path, config)


# ------------------------------------------------------------------------ running
class _Block:
    """Runtime side of one block: the FB, its pending inputs and latched outcome."""

    def __init__(self, decl: BlockDecl, fb: Any, enable_fb: bool) -> None:
        self.decl = decl
        self.fb = fb
        self.enable_fb = enable_fb
        # an Execute FB (an edge per call); FBs without Execute or Enable (MC_Jog: buttons)
        # take their inputs as they are
        self.edge = not enable_fb and "execute" in type(fb).INPUTS
        self.pending: dict[str, Any] = {}
        self.low_first = False  # give execute a falling edge before the rising one
        self.armed = False  # the rising edge has been delivered since the last issue
        self.done = False
        self.issued = False
        self.reported = False

    def call(self) -> None:
        if self.low_first:
            self.low_first = False
            self.fb(execute=False)
            return
        kw = self.pending
        self.pending = {}
        self.fb(**kw)
        if self.issued:
            self.armed = True

    def outcome(self) -> bool:
        fb = self.fb
        if not self.armed:
            return False
        if self.enable_fb:
            if hasattr(fb, "status"):  # MC_Power: the drive reports OPERATION ENABLED
                return bool(fb.status)
            return bool(getattr(fb, "valid", False) or getattr(fb, "enabled", False))
        if (
            getattr(fb, "in_velocity", False)
            or getattr(fb, "in_gear", False)
            or getattr(fb, "in_sync", False)
        ):
            return True
        if fb.done:
            self.done = True
        return self.done


class _SyncBlock:
    """SyncMoveAbsolute: one MC_MoveAbsolute per group member, time-scaled to arrive together."""

    def __init__(self, decl: BlockDecl, members: dict[str, _Block]) -> None:
        self.decl = decl
        self.members = members
        self.issued = False

    def issue(self, targets: dict[str, float]) -> None:
        from motionplc.planning import Limits, State, plan

        durations: dict[str, float] = {}
        for name, blk in self.members.items():
            if name not in targets:
                continue
            ax = blk.fb.axis
            cfg = ax.cfg
            lim = Limits(
                v_max=cfg.v_max,
                a_max=cfg.a_max,
                j_max=cfg.j_max,
                v_min=-cfg.v_neg,
                a_min=-cfg.a_neg,
            )
            durations[name] = plan(State(ax.p, ax.v, ax.a), State(targets[name]), lim).duration
        t_max = max(durations.values(), default=0.0)
        for name, blk in self.members.items():
            blk.issued = False
            if name not in targets or t_max <= 0.0:
                continue
            ax = blk.fb.axis
            cfg = ax.cfg
            r = durations[name] / t_max
            if r <= 0.0:
                continue
            jerk = cfg.j_max * r**3 if math.isfinite(cfg.j_max) else 0.0
            # the limits of the move's direction (asymmetric axes): speeding up positively is
            # a > 0 (a_max), negatively a < 0 (|a_min|); slowing down the other way round
            fwd = targets[name] >= ax.p
            v_lim, a_up, a_down = (
                (cfg.v_max, cfg.a_max, cfg.a_neg) if fwd else (cfg.v_neg, cfg.a_neg, cfg.a_max)
            )
            _issue(
                blk,
                {
                    "position": targets[name],
                    "velocity": v_lim * r,
                    "acceleration": a_up * r * r,
                    "deceleration": a_down * r * r,
                    "jerk": min(jerk, cfg.j_max),
                },
            )
        self.issued = True

    def outcome(self) -> bool:
        return all(b.outcome() for b in self.members.values() if b.issued)


def _issue(blk: _Block, inputs: dict[str, Any]) -> None:
    blk.pending.update(inputs)
    blk.issued = True
    blk.armed = False
    blk.done = False
    blk.reported = False
    if blk.edge:
        if blk.fb.execute:
            blk.low_first = True
        blk.pending["execute"] = True


class _Cursor:
    """Position in a list of steps (the main list or a parallel branch)."""

    def __init__(self, steps: tuple[Step, ...], label: str) -> None:
        self.steps = steps
        self.label = label
        self.index = -1
        self.t_entered = 0.0
        self.issued: list[str] = []
        self.branches: list[_Cursor] = []

    @property
    def finished(self) -> bool:
        return self.index >= len(self.steps)

    @property
    def step(self) -> Step:
        return self.steps[self.index]


def axis_error_text(axis: Any) -> str:
    """``NAME (0xCODE): reason`` of an axis' error (the reason is the drive's or kernel's text).

    E.g. ``COMMUNICATION_LOST (0x4004): connection lost``; the name alone if no reason was given.
    """
    eid = axis.axis_error
    reason = axis.axis_error_reason
    return f"{eid.name} (0x{int(eid):04X})" + (f": {reason}" if reason else "")


class SequenceRunner:
    """Runs a :class:`Sequence` on a :class:`~motionplc.config.Machine` as a task program.

    Every scan it calls every FB instance of the sequence (declaration order), then evaluates
    the transition conditions; the calls of a step entered in scan k take effect in scan k+1.
    ``finished`` / ``failed`` / ``failures`` report the outcome.
    """

    def __init__(self, sequence: Sequence, machine: Machine) -> None:
        self.sequence = sequence
        self.machine = machine
        self.types = {**_fb_types(), **_group_fb_types()}
        self.blocks: dict[str, _Block | _SyncBlock] = {}
        self._scan_order: list[_Block] = []
        for decl in sequence.blocks:
            if decl.type == SYNC_MOVE:
                members = {}
                for a in machine.groups[decl.axis]:
                    sub = BlockDecl(f"{decl.name}.{a}", "MC_MoveAbsolute", a, decl.line)
                    members[a] = self._make(sub)
                self.blocks[decl.name] = _SyncBlock(decl, members)
            else:
                self.blocks[decl.name] = self._make(decl)
        self.root = _Cursor(sequence.steps, "")
        self.finished = False
        self.failures: list[str] = []
        self.t = 0.0
        self.t_finished: float | None = None
        self.steps_done = 0

    def _make(self, decl: BlockDecl) -> _Block:
        cls = self.types[decl.type]
        if decl.group:
            group = self.machine.axes_groups[decl.axis]
            fb = cls(name=f"{decl.axis}.{decl.name}", axes_group=group)
        else:
            target = {_schema.target_pin(cls): self.machine.axes[decl.axis]}
            fb = cls(name=f"{decl.axis}.{decl.name}", **target)
        blk = _Block(decl, fb, _is_enable_fb(cls))
        self._scan_order.append(blk)
        return blk

    @property
    def failed(self) -> bool:
        return bool(self.failures)

    @property
    def over(self) -> bool:
        """Finished or failed: nothing more will happen."""
        return self.finished or self.failed

    def _fail(self, msg: str) -> None:
        if not self.failures:
            self.failures.append(f"{self.sequence.path}: {msg}")

    # -- the program ------------------------------------------------------------------------
    def __call__(self, ctx: CycleContext) -> None:
        self.t = ctx.t
        if self.root.index < 0:
            self._enter(self.root, 0, ctx.t)
        for blk in self._scan_order:
            blk.call()
        if self.over:
            return
        self._check_errors()
        if self.failed:
            return
        if ctx.t >= self.sequence.timeout - 1e-12:
            self._fail(
                f"timeout: the sequence did not finish within {self.sequence.timeout:g} s "
                f"(at {self._where(self.root)})"
            )
            return
        self._advance(self.root, ctx.t)
        if self.root.finished and not self.failed:
            self.finished = True
            self.t_finished = ctx.t

    def _where(self, cur: _Cursor) -> str:
        if cur.finished:
            return "the end"
        st = cur.step
        where = f"step {st.name!r} (line {st.line})"
        if cur.label:
            where = f"branch {cur.label!r}, " + where
        inner = [self._where(b) for b in cur.branches if not b.finished]
        return where + (": " + "; ".join(inner) if inner else "")

    def _check_errors(self) -> None:
        from motionplc.blocks import AxisState, ErrorID

        for blk in self._scan_order:
            fb = blk.fb
            if blk.armed and fb.error and not blk.reported:
                blk.reported = True
                eid = fb.error_id
                text = f": {fb.error_text}" if fb.error_text else ""
                # an FB that failed because its axis stopped names the axis' own error
                cause = ""
                if blk.decl.group:
                    group = self.machine.axes_groups[blk.decl.axis]
                    bad = [a for a in group.axes if a.axis_error is not ErrorID.OK]
                    if eid is ErrorID.AXIS_ERROR_STOP and bad:
                        cause = f": axis {bad[0].name!r}: {axis_error_text(bad[0])}"
                    where = f"group {blk.decl.axis!r}"
                else:
                    ax = self.machine.axes[blk.decl.axis]
                    if eid is ErrorID.AXIS_ERROR_STOP and ax.axis_error is not ErrorID.OK:
                        cause = f": axis {blk.decl.axis!r}: {axis_error_text(ax)}"
                    where = f"axis {blk.decl.axis!r}"
                self._fail(
                    f"block {blk.decl.name!r} ({blk.decl.type} on {where}, "
                    f"line {blk.decl.line}) failed with {eid.name} (0x{int(eid):04X}){text} "
                    f"at t = {self.t:.3f} s in {self._where(self.root)}{cause}"
                )
                return
        for name, ax in self.machine.axes.items():
            if ax.state is AxisState.ERROR_STOP:
                self._fail(
                    f"axis {name!r} went to ERROR_STOP at t = {self.t:.3f} s "
                    f"({axis_error_text(ax)}) in {self._where(self.root)}"
                )
                return
        from motionplc.blocks.enums import GroupState

        for name, g in self.machine.axes_groups.items():
            if g.state is GroupState.GROUP_ERROR_STOP:
                self._fail(
                    f"group {name!r} went to GROUP_ERROR_STOP at t = {self.t:.3f} s "
                    f"({g.error_id.name} (0x{int(g.error_id):04X}): {g.error_reason}) in "
                    f"{self._where(self.root)}"
                )
                return

    def _enter(self, cur: _Cursor, index: int, t: float) -> None:
        cur.index = index
        cur.t_entered = t
        cur.issued = []
        cur.branches = []
        if cur.finished:
            return
        st = cur.step
        for call in st.calls:
            blk = self.blocks[call.block]
            inputs = {k: self._resolve(v) for k, v in call.inputs}
            if isinstance(blk, _SyncBlock):
                blk.issue(dict(inputs.get("position", ())))
            elif inputs.get("execute") is False:
                blk.pending["execute"] = False  # Execute falls: no command, nothing to wait for
                blk.low_first = False
                continue
            else:
                _issue(blk, inputs)
            cur.issued.append(call.block)
        for label, steps in st.branches:
            sub = _Cursor(steps, label)
            cur.branches.append(sub)
            self._enter(sub, 0, t)

    def _resolve(self, value: Any) -> Any:
        """An input as the FB takes it: a master axis, a cam table or a block's output for an
        :class:`InputRef` (the block's output as it is now), the value itself otherwise."""
        if not isinstance(value, InputRef):
            return value
        if value.kind == "axis":
            return self.machine.axes[value.name]
        if value.kind == "cam":
            return self.machine.cams[value.name]
        blk = self.blocks[value.name]
        return getattr(blk.fb, "cam_table_id", None) if isinstance(blk, _Block) else None

    def _advance(self, cur: _Cursor, t: float) -> None:
        while not cur.finished:
            for sub in cur.branches:
                self._advance(sub, t)
                if self.failed:
                    return
            st = cur.step
            if not all(b.finished for b in cur.branches) or not self._holds(cur, st, t):
                if st.timeout is not None and t - cur.t_entered >= st.timeout - 1e-12:
                    self._fail(
                        f"step {st.name!r} (line {st.line}) timed out after {st.timeout:g} s "
                        f"(condition not met: {self._describe(cur, st)})"
                    )
                return
            if not self._expectations(st):
                return
            self.steps_done += 1
            self._enter(cur, cur.index + 1, t)
            # the new step's calls take effect in the next scan: stop here unless it has none
            if not cur.finished and (cur.step.calls or cur.step.branches):
                return

    def _holds(self, cur: _Cursor, st: Step, t: float) -> bool:
        u = st.until
        if u.time is not None and t - cur.t_entered < u.time - 1e-12:
            return False
        names = cur.issued if u.done == ("*",) else u.done
        for name in names:
            if not self.blocks[name].outcome():
                return False
        axes = self.machine.axes
        for a, lo, hi in u.positions:
            if not lo <= axes[a].position <= hi:
                return False
        for a, state in u.states:
            if self._state(a) != state:
                return False
        return True

    def _state(self, name: str) -> str:
        """State name of an axis or a group."""
        if name in self.machine.axes:
            return self.machine.axes[name].state.name
        return self.machine.axes_groups[name].state.name

    def _describe(self, cur: _Cursor, st: Step) -> str:
        u = st.until
        parts = []
        names = cur.issued if u.done == ("*",) else u.done
        pending = [n for n in names if not self.blocks[n].outcome()]
        if pending:
            parts.append("not done: " + ", ".join(pending))
        for a, lo, hi in u.positions:
            p = self.machine.axes[a].position
            if not lo <= p <= hi:
                parts.append(f"{a}.position = {p:.6g} not in [{lo:g}, {hi:g}]")
        for a, state in u.states:
            s = self._state(a)
            if s != state:
                parts.append(f"{a}.state = {s}, waiting for {state}")
        return "; ".join(parts) or "time"

    def _value(self, target: str) -> Any:
        obj, _, attr = target.partition(".")
        if obj in self.machine.axes:
            ax = self.machine.axes[obj]
            if attr == "state":
                return ax.state.name
            if attr == "position":
                return ax.position
            if attr == "actual_position":
                return ax.actual_position
            if attr == "velocity":
                return ax.v
            return ax.following_error
        if obj in self.machine.axes_groups and obj not in self.blocks:
            g = self.machine.axes_groups[obj]
            return g.state.name if attr == "state" else g.path_velocity
        blk = self.blocks[obj]
        fb = blk.fb if isinstance(blk, _Block) else None
        if fb is None:
            return blk.outcome() if attr == "done" else None
        return getattr(fb, attr, None)

    def _expectations(self, st: Step) -> bool:
        for e in st.expects:
            actual = self._value(e.target)
            if isinstance(e.value, str) or isinstance(e.value, bool) or actual is None:
                ok = actual == e.value
                shown = f"{actual!r}"
            else:
                ok = isinstance(actual, (int, float)) and abs(actual - e.value) <= e.within
                shown = f"{actual:.12g} (error {actual - e.value:+.3g})" if ok is not None else ""
                if not isinstance(actual, (int, float)):
                    shown = repr(actual)
            if not ok:
                want = (
                    f"{e.value!r}"
                    if isinstance(e.value, (str, bool))
                    else f"{e.value:g} within {e.within:g}"
                )
                self._fail(
                    f"line {e.line}: expectation failed in step {st.name!r} at t = "
                    f"{self.t:.3f} s: {e.target} = {shown}, expected {want}"
                )
                return False
        return True


def runner_for(path: str | Path, machine: Machine) -> tuple[Callable[[Any], Any], str]:
    """Load a sequence (``.yaml``/``.yml``) or a Python program (``.py``) for ``machine``.

    Returns the program callable and the task it belongs to.
    """
    p = Path(path)
    if p.suffix == ".py":
        from motionplc.program import ProgramRunner, load_program

        prog = load_program(p)
        runner = ProgramRunner(prog, machine)
        return runner, prog.task or machine.config.runtime.tasks[0].name
    seq = load_sequence(p, machine.config)
    return SequenceRunner(seq, machine), seq.task
