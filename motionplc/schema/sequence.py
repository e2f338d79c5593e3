"""The schema of a motion sequence file (YAML, SFC-like steps).

The keys of the top level, of a step and of a condition (``TOP``, ``STEP``, ``COND``: the
tables :mod:`motionplc.sequence` checks) and the inputs of every FB type, derived from the FB
classes themselves (their ``INPUTS`` and the type of each input's default: boolean, enum,
number, group point). Names of axes, groups, tasks and blocks come from the machine
configuration and the sequence itself: the validator checks them, the JSON Schema cannot.
"""

from __future__ import annotations

from enum import Enum
from functools import cache
from typing import Any

from motionplc.schema.nodes import (
    NAME_PATTERN,
    Bool,
    Choice,
    FileSchema,
    Integer,
    Key,
    ListOf,
    MapOf,
    Node,
    Number,
    Obj,
    OneOf,
    Ref,
    Scalar,
    String,
)

__all__ = [
    "AXIS_FIELDS",
    "COND",
    "GROUP_ADMIN",
    "GROUP_FIELDS",
    "POINT_PINS",
    "RADIUS",
    "REF_PINS",
    "STEP",
    "SYNC_MOVE",
    "TOP",
    "fb_types",
    "sequence_schema",
    "target_pin",
]

AXIS_FIELDS = ("position", "actual_position", "velocity", "following_error", "state")
GROUP_FIELDS = ("state", "path_velocity")
SYNC_MOVE = "SyncMoveAbsolute"
# group FBs not offered in sequences: the members are fixed by the configuration
GROUP_ADMIN = ("MC_AddAxisToGroup", "MC_RemoveAxisFromGroup", "MC_UngroupAllAxes")
# group FB inputs that are points (one value per member)
POINT_PINS = ("position", "distance", "end_point", "aux_point")
# FB inputs that name another object of the machine (resolved when the call is issued): what
# they name -- an axis, a cam table of the configuration's `cams:`, the output of a block
REF_PINS = {"master": "axis", "cam_table": "cam", "cam_table_id": "block"}


def target_pin(cls: type) -> str:
    """The input naming the axis an axis FB commands: `slave` for master/slave FBs
    (MC_GearIn, MC_CamIn, ...), else `axis`."""
    inputs = cls.INPUTS  # type: ignore[attr-defined]
    return "slave" if "slave" in inputs and "axis" not in inputs else "axis"


_TIME = Number(ge=0.0, unit="s", description="Seconds in the step.")
COND = Obj(
    title="condition",
    description="The step's transition condition: every key given must hold.",
    keys=(
        Key(
            "done",
            OneOf(
                description="Blocks that must be Done (enable FBs: Valid/Status): `done` or "
                "`true` = every block issued in the step, a block name, or a list of names.",
                variants=(
                    Choice(options=("done", True), description="Every block issued in the step."),
                    String(pattern=r"^[^.]+$", description="A block name."),
                    ListOf(item=String(pattern=r"^[^.]+$"), min_items=1),
                ),
                checks=("blocks declared by an earlier or this step's call",),
            ),
        ),
        Key("time", _TIME),
        Key(
            "position",
            MapOf(
                value=Obj(
                    title="position window",
                    keys=(
                        Key("min", Number(default=float("-inf"), description="Lower bound.")),
                        Key("max", Number(default=float("inf"), description="Upper bound.")),
                    ),
                    checks=("at least one of min, max",),
                ),
                example={"x": {"min": 0.1}},
                description="Axis name -> window its commanded position must be in.",
                checks=("axes of the configuration",),
            ),
        ),
        Key(
            "state",
            MapOf(
                value=String(description="An AxisState or GroupState name."),
                example={"x": "STANDSTILL"},
                description="Axis or group name -> the state it must be in.",
                checks=("axes and groups of the configuration; their state names",),
            ),
        ),
    ),
)
_UNTIL = OneOf(
    default="done",
    description="When the step ends: `done` (every block issued in this step is Done) or a "
    "mapping of conditions. A step without `until` waits for its blocks.",
    variants=(Choice(options=("done",), description="Every issued block is Done."), COND),
)
_EXPECT = MapOf(
    key=String(
        pattern=r"^(within|[^.]+\.[A-Za-z_][A-Za-z0-9_]*)$",
        what="`AXIS.FIELD`, `GROUP.FIELD`, `BLOCK.OUTPUT` or `within`",
    ),
    value=Scalar(
        description="Expected value: a number (within `within`), a state name or a boolean."
    ),
    example={"x.position": 0.5, "x.state": "STANDSTILL", "within": 1e-9},
    description="Checked when the condition holds: `AXIS.FIELD` (fields "
    + ", ".join(AXIS_FIELDS)
    + "), `GROUP.FIELD` ("
    + ", ".join(GROUP_FIELDS)
    + "), `BLOCK.OUTPUT`, and `within` (tolerance of numbers, >= 0, default 1e-06).",
    checks=(
        "targets name axes, groups or blocks of the sequence; axis and group fields as listed; "
        "state names of AxisState / GroupState; `within` a number >= 0",
    ),
)
EXPECT_WITHIN = Number(ge=0.0, default=1e-6, description="Tolerance of numeric expectations.")
STEP = Obj(
    title="step",
    description="A step: FB calls (or a wait, or parallel branches), its transition condition, "
    "its expectations.",
    keys=(
        Key("name", String(default_text="step N", description="Name in messages.")),
        Key(
            "call",
            OneOf(
                description="The FB calls of the step (one call or a list).",
                variants=(
                    ListOf(item=Ref(name="call"), min_items=1),
                    Ref(name="call"),
                ),
            ),
        ),
        Key("until", _UNTIL),
        Key(
            "timeout",
            Number(
                gt=0.0, unit="s", description="Fail the run if the condition is not met in time."
            ),
        ),
        Key("expect", _EXPECT),
        Key("wait", Number(ge=0.0, unit="s", description="A step that only waits this long.")),
        Key(
            "parallel",
            MapOf(
                value=Ref(name="steps"),
                min_items=1,
                key=String(description="A branch name."),
                description="Branches (name -> list of steps) run side by side; the step ends "
                "when every branch has.",
            ),
        ),
    ),
    checks=("one of `call`, `wait`, `parallel`",),
)
STEPS = ListOf(item=STEP, min_items=1, description="The steps, in order.")
TOP = Obj(
    title="sequence",
    keys=(
        Key(
            "task",
            String(
                default_text="the first task",
                description="The task that runs the sequence.",
                checks=("a task of the configuration",),
            ),
        ),
        Key(
            "timeout",
            Number(
                gt=0.0,
                default=600.0,
                unit="s",
                description="(Virtual) time for the whole sequence.",
            ),
        ),
        Key("steps", Ref(name="steps"), True),
    ),
)

_PIN_TEXT = {
    "execute": "Only `false`: lets Execute fall without issuing a command (a call issues the "
    "command with a rising edge of Execute).",
    "enable": "Enable input.",
    "enable_positive": "Motion in the positive direction allowed.",
    "enable_negative": "Motion in the negative direction allowed.",
    "continuous_update": "Inputs changed while Busy take effect.",
    "position": "Target position [m or rad].",
    "distance": "Distance [m or rad].",
    "velocity": "Velocity [m/s or rad/s].",
    "acceleration": "Acceleration [m/s² or rad/s²]; 0 = the axis' limit.",
    "deceleration": "Deceleration [m/s² or rad/s²]; 0 = the axis' limit.",
    "jerk": "Jerk [m/s³ or rad/s³]; 0 = the axis' limit.",
    "buffer_mode": "How the command joins the one before.",
    "direction": "Direction.",
    "relative": "`position` is relative.",
    "execution_mode": "Execution mode.",
    "vel_factor": "Velocity override factor.",
    "acc_factor": "Acceleration override factor.",
    "jerk_factor": "Jerk override factor.",
    "source": "Source of the values.",
    "acc_window": "Window of the acceleration estimate.",
    "transition_mode": "The corner between the move before and this one (PLCopen: the "
    "issued move's TransitionMode shapes its junction with the previous move): TM_NONE keeps "
    "the corner exact, the others blend it; only with a blending `buffer_mode` and after a "
    "line or arc.",
    "transition_parameter": "Parameter of this move's `transition_mode` (TM_CORNER_DISTANCE: "
    "the distance from the corner [m]; TM_MAX_CORNER_DEVIATION: the largest deviation [m], 0 = "
    "the group's tolerance; TM_START_VELOCITY / TM_CONSTANT_VELOCITY: the speed [m/s]).",
    "circ_mode": "How `aux_point` defines the arc.",
    "aux_point": (
        "Auxiliary point (or a number: the radius, CircMode RADIUS; negative: the arc longer "
        "than half a circle)."
    ),
    "end_point": "End point of the arc.",
    "path_choice": "Direction of the arc.",
    "points": "The passing points (a list of points).",
    "master": "The master axis (an axis of the configuration other than the slave).",
    "cam_table": "A cam table of the configuration's `cams:` section, by name.",
    "cam_table_id": "The cam selected by an MC_CamTableSelect block (its name): that "
    "block's `cam_table_id` output when this call is issued.",
    "ratio_numerator": "Gear ratio numerator (INT, may be negative).",
    "ratio_denominator": "Gear ratio denominator (UINT, > 0).",
    "parameter_number": "PLCopen parameter number (1-17), or a drive parameter (>= 0x10000, "
    "CODESYS SoftMotion's scheme): `index * 0x100 + subindex` of a CANopen object, `0x10000 + "
    "register` of a Modbus holding register, plus an optional type code `T * 0x1000000`.",
    "trigger_input": "The probe input: its number (rising edge) or `{probe: N, edge: rising | "
    "falling}`.",
    "window_only": "Only edges with the position inside [first_position, last_position] count.",
    "first_position": "Start of the window [m or rad] (inclusive; modulo windows may wrap).",
    "last_position": "End of the window [m or rad] (inclusive).",
    "jog_forward": "Jog button: move in the positive direction while TRUE (inching: a step per "
    "rising edge).",
    "jog_backward": "Jog button: move in the negative direction while TRUE.",
    "mode": "Jog mode (STANDARD_SLOW / STANDARD_FAST: the axis' jog velocities; CONTINUOUS: "
    "`velocity`; INCHING / INCHING_MODULO: steps of `position`).",
    "master_value_source": "The master's set or actual values.",
    "master_offset": "Table coordinate x = master_scaling x master + master_offset [m or rad].",
    "slave_offset": "Slave = slave_offset + slave_scaling x table value [m or rad].",
    "master_scaling": "Scaling of the master position into table coordinates (non-zero).",
    "slave_scaling": "Scaling of the table value (non-zero).",
    "master_start_distance": "The coupling starts when the master is this far before "
    "`master_sync_position` (in its direction of motion) [m or rad].",
    "master_sync_position": "Master position of the synchronisation point [m or rad].",
    "slave_sync_position": "Slave position at the synchronisation point [m or rad].",
    "sync_mode": "How the slave catches the synchronisation point.",
    "start_mode": "How the slave is brought onto the table.",
    "periodic": "The table repeats over the master (else it runs once).",
    "master_absolute": "The master's position is used as it is (else relative to the start).",
    "slave_absolute": "The table's slave values are absolute (else relative to the start).",
    "phase_shift": "Phase shift of the master as the slave sees it [m or rad].",
    "velocity_diff": "Velocity the correction adds at most [m/s or rad/s]; 0 = as the headroom "
    "allows.",
    "value": "The value to write.",
}
# texts of a pin that means something else in one FB type
_NO_TRANSITION = (
    "Accepted as PLCopen defines it, without effect: this move starts and ends at rest (a "
    "blending `buffer_mode` acts like BUFFERED), so no corner is blended into or out of it."
)
_PIN_TEXT_OF = {
    **{
        (fb, pin): _NO_TRANSITION
        for fb in (
            "MC_MoveDirectAbsolute",
            "MC_MoveDirectRelative",
            "MC_MovePassingPoints",
            "MC_MoveBSpline",
        )
        for pin in ("transition_mode", "transition_parameter")
    },
    ("MC_Jog", "position"): "Inching step [m or rad] (INCHING: the distance per press; "
    "INCHING_MODULO: the grid the axis moves to).",
    ("MC_Jog", "velocity"): "Velocity of modes CONTINUOUS and INCHING [m/s or rad/s].",
    ("MC_MoveSuperimposed", "distance"): "Distance added to the axis' motion [m or rad].",
    ("MC_GearInPos", "velocity"): "Velocity of the catch-up [m/s or rad/s]; 0 = the slave's limit.",
}

_POINT = OneOf(
    description="A point: `{axis: value}` with every member once, or a list in member order.",
    variants=(
        MapOf(value=Number(ge=-1e12, le=1e12), min_items=1),
        ListOf(item=Number(ge=-1e12, le=1e12), min_items=1),
    ),
    checks=("every member of the group exactly once",),
)


# aux_point as a number: the radius of CircMode RADIUS (MC_MoveCircular*), as the FB takes it
# (aux_point[0]): positive for the arc shorter than half a circle, negative for the longer one
RADIUS = (
    Number(gt=0.0, le=1e12, description="The radius: the arc shorter than half a circle."),
    Number(ge=-1e12, lt=0.0, description="Minus the radius: the arc longer than half a circle."),
)


def fb_types() -> tuple[dict[str, type], dict[str, type]]:
    """The FB classes a sequence may use: (axis FBs, group FBs) by name."""
    import motionplc.blocks as blocks
    from motionplc.blocks import group_blocks

    axis = {n: getattr(blocks, n) for n in blocks.__all__ if n.startswith("MC_")}
    group = {
        n: getattr(group_blocks, n)
        for n in group_blocks.__all__
        if n.startswith("MC_") and n not in GROUP_ADMIN
    }
    return axis, group


def _pin_node(cls: type, pin: str, default: Any, group: bool) -> Node:
    text = _PIN_TEXT_OF.get((cls.__name__, pin)) or _PIN_TEXT.get(
        pin, pin.replace("_", " ").capitalize() + "."
    )
    if pin == "execute":
        return Choice(options=(False,), description=text)
    if group and pin in POINT_PINS:
        if pin == "aux_point":
            return OneOf(
                description=text, variants=(*_POINT.variants, *RADIUS), checks=_POINT.checks
            )
        return OneOf(description=text, variants=_POINT.variants, checks=_POINT.checks)
    if group and pin == "points":
        return ListOf(item=_POINT, min_items=1, description=text)
    if pin == "master":
        return String(pattern=NAME_PATTERN, description=text, checks=("an axis, not the slave",))
    if pin == "cam_table":
        return String(pattern=NAME_PATTERN, description=text, checks=("a cam of `cams:`",))
    if pin == "cam_table_id":
        return String(
            pattern=r"^[^.]+$",
            description=text,
            checks=("an MC_CamTableSelect block used before",),
        )
    if pin == "trigger_input":
        return OneOf(
            description=text,
            variants=(
                Integer(lo=1, description="The probe input (rising edge)."),
                Obj(
                    keys=(
                        Key("probe", Integer(lo=1, default=1, description="The probe input.")),
                        Key(
                            "edge",
                            Choice(
                                options=("rising", "falling"),
                                default="rising",
                                description="The edge that latches.",
                            ),
                        ),
                    ),
                ),
            ),
        )
    if isinstance(default, bool):
        return Bool(default=default, description=text)
    if isinstance(default, int) and not isinstance(default, Enum):
        return Integer(default=default, description=text)
    if isinstance(default, Enum):
        return Choice(
            options=tuple(e.name for e in type(default)),
            default=default.name,
            description=text,
        )
    if isinstance(default, (int, float)):
        return Number(default=float(default), description=text)
    return Scalar(description=text)


def _inputs(cls: type, group: bool) -> tuple[Key, ...]:
    ref = "axes_group" if group else target_pin(cls)
    proto = cls()
    return tuple(
        Key(pin, _pin_node(cls, pin, getattr(proto, pin), group))
        for pin in cls.INPUTS  # type: ignore[attr-defined]
        if pin != ref
    )


@cache
def sequence_schema() -> FileSchema:
    """The schema of a sequence file, with the inputs of every FB type of the FB classes."""
    axis_fbs, group_fbs = fb_types()
    names = (*axis_fbs, *group_fbs, SYNC_MOVE)
    cases: list[tuple[Any, tuple[Key, ...]]] = []
    for name, cls in axis_fbs.items():
        cases.append((name, _inputs(cls, False)))
    for name, cls in group_fbs.items():
        cases.append((name, _inputs(cls, True)))
    cases.append(
        (
            SYNC_MOVE,
            (
                Key(
                    "position",
                    MapOf(
                        value=Number(),
                        description="Member axis -> target; the axes start and arrive together.",
                        checks=("members of the group",),
                    ),
                ),
            ),
        )
    )
    call = Obj(
        title="call",
        description="One FB call. `block` names an FB instance, created on its first use with "
        "`type` and `axis` (or `group`); later calls reuse it (and re-issuing an Execute FB "
        "gives it a new rising edge). The other keys are the FB's inputs (snake_case PLCopen "
        "names; enums by member name).",
        keys=(
            Key(
                "block",
                String(
                    pattern=r"^[^.]+$",
                    default_text="TYPE_N (an anonymous block)",
                    description="The FB instance's name.",
                ),
            ),
            Key(
                "type",
                Choice(
                    options=names,
                    description="The FB type (`SyncMoveAbsolute`: the axes of a group move "
                    "together, each its own time-optimal move time-scaled to the slowest).",
                    checks=("required on a block's first use; the same type on later uses",),
                ),
            ),
            Key(
                "axis",
                String(
                    pattern=NAME_PATTERN,
                    description="The axis of a single-axis FB.",
                    checks=("an axis of the configuration; the block's axis on later uses",),
                ),
            ),
            Key(
                "slave",
                String(
                    pattern=NAME_PATTERN,
                    description="The slave axis of a master/slave FB (MC_GearIn, MC_CamIn, "
                    "MC_CamTableSelect, ...): the axis it commands.",
                    checks=("an axis of the configuration; the block's axis on later uses",),
                ),
            ),
            Key(
                "group",
                String(
                    pattern=NAME_PATTERN,
                    description="The axes group of a group FB or SyncMoveAbsolute.",
                    checks=("a group of the configuration",),
                ),
            ),
        ),
        switch="type",
        cases=tuple(cases),
        checks=(
            "`axis` for single-axis FBs, `slave` for master/slave FBs, `group` for group FBs",
            "with `execute: false` no other input",
        ),
    )
    return FileSchema(
        kind="sequence",
        title="Motion sequence",
        root=TOP,
        intro="A sequence is a list of steps, run as a task program on a machine configuration "
        "(`motionplc run CONFIG SEQUENCE`; `motionplc validate CONFIG SEQUENCE` checks it). A "
        "step issues FB calls, waits for its transition condition (`until`), checks its "
        "expectations (`expect`), then the next step starts. Calls of a step entered in one "
        "scan take effect in the next.",
        example=EXAMPLE,
        defs={"steps": STEPS, "call": call},
    )


EXAMPLE = """\
task: motion            # optional: the task that runs the sequence (default: the first)
timeout: 60             # optional: [s] of (virtual) time for the whole sequence
steps:
  - name: power on
    call:
      - {block: pwr_x, type: MC_Power, axis: x, enable: true}
    until: {done: pwr_x}
  - name: move
    call:
      - {block: mx, type: MC_MoveAbsolute, axis: x, position: 1.0, velocity: 0.5}
      - {block: mx2, type: MC_MoveRelative, axis: x, distance: -0.5, velocity: 0.5,
         buffer_mode: BLENDING_PREVIOUS}
    until: done
    expect: {x.position: 0.5, within: 1.0e-9}
  - wait: 0.2
  - parallel:
      a: [{call: [{block: mx, position: 0.0}]}]
"""
