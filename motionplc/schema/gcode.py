"""The ``gcode:`` block of a machine configuration: the machine a G-code program runs on and
its start-up state (read by :func:`motionplc.gcode_runner.setup_from_config`)."""

from __future__ import annotations

from motionplc.schema.nodes import Bool, Choice, Integer, Key, ListOf, MapOf, Number, Obj, String

_LETTER = String(pattern=r"^[XYZABCUVW]$", what="an axis letter X Y Z A B C U V W")
_SYSTEM = Choice(
    options=("G54", "G55", "G56", "G57", "G58", "G59", "G59.1", "G59.2", "G59.3"),
    default_text="G54",
    description="The work offset at start-up.",
)

GCODE = Obj(
    title="G-code machine",
    description="The machine of G-code programs (RS274/NGC, LinuxCNC's meanings) and its "
    "start-up state.",
    keys=(
        Key(
            "axes",
            MapOf(
                key=_LETTER,
                value=String(what="a member of the group"),
                description="Axis letter -> group member (default: X, Y, Z on the members in "
                "order; a member in rad is rotary: A, B or C, in degrees in the program).",
                example={"X": "x", "Y": "y", "Z": "z", "A": "a"},
            ),
        ),
        Key(
            "units",
            Choice(options=("mm", "inch"), default_text="mm", description="Units at start-up."),
        ),
        Key(
            "plane",
            Choice(
                options=("G17", "G18", "G19"), default_text="G17", description="Plane at start-up."
            ),
        ),
        Key(
            "path_control",
            Choice(
                options=("G64", "G61", "G61.1"),
                default_text="G64",
                description="Path control at start-up (LinuxCNC's: G64, as fast as possible).",
            ),
        ),
        Key("coordinate_system", _SYSTEM),
        Key(
            "work_offsets",
            MapOf(
                key=String(pattern=r"^G5[4-9](\.[1-3])?$", what="G54 .. G59.3"),
                value=MapOf(key=_LETTER, value=Number(unit="m or rad")),
                description="Work offsets at start-up [m, rad] by system.",
                example={"G54": {"X": 0.1, "Y": 0.05}},
            ),
        ),
        Key(
            "tool_table",
            String(
                what="a file",
                description="LinuxCNC tool table (relative to this file; "
                "values in the start-up units).",
            ),
        ),
        Key("spindle", String(what="an axis", description="The spindle axis (M3/M4/M5, S).")),
        Key(
            "coolant",
            Obj(
                keys=(
                    Key("mist", String(what="an output name", description="M7 output.")),
                    Key("flood", String(what="an output name", description="M8 output.")),
                ),
                description="Named digital outputs of the coolant.",
            ),
        ),
        Key(
            "outputs",
            ListOf(
                item=String(what="an output name"),
                max_items=64,
                description="Digital outputs of M62-M65 (P0, P1, ...).",
            ),
        ),
        Key("block_delete", Bool(default_text="true", description="Skip lines starting with /.")),
        Key("optional_stop", Bool(default_text="false", description="M1 pauses.")),
        Key(
            "max_blocks",
            Integer(
                lo=1,
                hi=10**10,
                description="Blocks a program may execute (default 100000 + 10 per line).",
            ),
        ),
    ),
)
