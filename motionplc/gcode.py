"""An RS274/NGC interpreter with LinuxCNC's semantics, streaming, for axes groups.

:class:`Interpreter` reads a program line by line (never the whole file into memory; O-word
control flow seeks back in the file) and yields, in program order, :class:`GcodeMove` (one per
motion: a line, or one arc / helix with all of its turns) and :class:`GcodeEvent` (machine
actions: spindle, coolant, outputs, tool change, dwell, pauses, messages, the end). Moves are in
the group's **machine** coordinates, SI (m; rad for the rotary axes A, B, C), with every offset
applied (G5x work offsets, G92, tool length).

What is understood is the table :data:`WORDS` (the G-code reference page is generated from it,
``docs/reference/gcode.md``): modal groups and their conflicts as LinuxCNC checks them, G54-G59.3,
G10 L1/L2/L10/L11/L20, G92/G92.1/G92.2/G92.3, G53, G28/G30 (and .1), G43/G43.1/G43.2/G49 with a
tool table, G40 (G41/G42 are refused), G61/G61.1/G64 P Q, G4, G17-G19, G20/G21, G90/G91,
G90.1/G91.1, G93/G94/G95, G0-G3 with helices and turns (P), canned cycles G73 G81-G89 with G80
and G98/G99 (expanded into moves), ``#`` numbered and named parameters, expressions and
functions, O-word subroutines and control flow, block delete, M0/M1/M2/M30/M60, M3/M4/M5 and S,
M6/T, M7/M8/M9, M48/M49 and M50-M53 (understood, ignored with a note), M62-M65 digital outputs,
(MSG,...) and (DEBUG,...) messages. Everything else is a located :class:`GcodeError`
``FILE:LINE: WORD: what is wrong (what is allowed)``; input text in messages is escaped (no
control character of the file reaches the user's terminal).

Bounds (hostile files): a line is at most :data:`MAX_LINE` characters, a file at most
:data:`MAX_LINES` lines, expressions nest at most :data:`MAX_NESTING` deep, subroutine calls
:data:`MAX_CALL_DEPTH` deep, control structures :data:`MAX_CONTROL_DEPTH` deep, and a program
executes at most ``max_blocks`` blocks (a loop that does not end is an error, not a hang).
A while / do-while loop whose condition is true and reads only parameters that nothing in its
body sets (no break, return, call, M2/M30 in it) is refused at its line when it is entered,
and a repeat of more passes than blocks are left at its start. Lines with parameters or
expressions are compiled once (up to ``_MAX_COMPILED`` distinct lines) and evaluated each time
they run. Memory is flat in the file length (the O-word index holds one entry per O-word line).
"""

from __future__ import annotations

import io
import logging
import math
import re
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass, field
from pathlib import Path as FilePath
from typing import IO, Any, NamedTuple

import numpy as np

from motionplc.errors import ConfigError, PlanningError
from motionplc.planning.paths import Arc, Helix, Line, Path

__all__ = [
    "GcodeError",
    "GcodeEvent",
    "GcodeMove",
    "GcodeProgram",
    "Interpreter",
    "MachineSetup",
    "WORDS",
    "escape",
    "load_gcode",
    "move_path",
    "parse_gcode",
    "read_tool_table",
]

_log = logging.getLogger(__name__)

MM = 0.001  # metres per millimetre
INCH = 0.0254  # metres per inch
DEG = math.pi / 180.0
MAX_LINE = 1024
MAX_LINES = 20_000_000
MAX_NESTING = 64
MAX_CALL_DEPTH = 64
MAX_CONTROL_DEPTH = 256
MAX_ERRORS = 100
MAX_TURNS = 10**9
_MAX_VALUE = 1e15  # |number| in a word (1e15 mm = 1e12 m, the planner's position range)
# LinuxCNC's arc tolerances (interp_internal.hh), in program units
CENTER_ARC_RADIUS_TOLERANCE_INCH = 2 * 0.001 * math.sqrt(2.0)
CENTER_ARC_RADIUS_TOLERANCE_MM = 2 * 0.01 * math.sqrt(2.0)
RADIUS_TOLERANCE_INCH = 0.00005
RADIUS_TOLERANCE_MM = RADIUS_TOLERANCE_INCH * 25.4
SPIRAL_RELATIVE_TOLERANCE = 0.001
_TINY = 1e-12
_EQUAL = 1e-6  # EQ/NE of expressions (LinuxCNC's TOLERANCE_EQUAL)
_SAME_POINT_RTOL = 1e-12

AXES = "XYZABCUVW"  # LinuxCNC's axis order
ROTARY = frozenset("ABC")
_PLANES: dict[str, tuple[int, int, int]] = {"XY": (0, 1, 2), "ZX": (2, 0, 1), "YZ": (1, 2, 0)}
_PLANE_OF = {170: "XY", 180: "ZX", 190: "YZ"}
_PLANE_CODE = {"XY": "G17", "ZX": "G18", "YZ": "G19"}
_OFFSET_LETTER = "IJK"  # the centre offset along X, Y, Z


def escape(text: str, limit: int = 200) -> str:
    """``text`` with every control or non-printable character as ``\\xNN`` / ``\\uNNNN`` and
    cut to ``limit`` characters (``...`` marks the cut): safe to print on a terminal."""
    if len(text) > limit:
        text = text[:limit] + "..."
    if text.isprintable():
        return text
    return "".join(ch if ch.isprintable() else ascii(ch)[1:-1] for ch in text)


def _fmt(x: float) -> str:
    return f"{x:.9g}"


class GcodeError(ConfigError):
    """An invalid or unsupported G-code program.

    ``errors`` holds one line per problem, ``FILE:LINE: WORD: what is wrong (what is
    allowed)``. A :class:`~motionplc.errors.ConfigError` (a program is configuration input).
    """

    MAX_SHOWN = None  # this module caps and escapes its own messages
    MAX_LINE = None


class _Err(Exception):  # noqa: N818 - internal, always converted to GcodeError
    """An error of the line being executed (located by the interpreter)."""

    def __init__(self, word: str, message: str) -> None:
        super().__init__(message)
        self.word = word
        self.message = message


# ------------------------------------------------------------------------------- the word table
@dataclass(frozen=True, slots=True)
class Word:
    """One entry of the word table: ``code`` (``"G2"``, ``"M3"``, ``"F"``), its modal
    ``group`` (LinuxCNC's numbering; ``""`` for value words), ``meaning``."""

    code: str
    group: str
    meaning: str


def _w(code: str, group: str, meaning: str) -> Word:
    return Word(code, group, meaning)


WORDS: tuple[Word, ...] = (
    _w("G0", "G1 motion", "rapid move at the axes' limits"),
    _w("G1", "G1 motion", "line at the feed rate"),
    _w("G2", "G1 motion", "arc / helix clockwise (I J K centre or R radius, P turns)"),
    _w("G3", "G1 motion", "arc / helix counter-clockwise (I J K centre or R radius, P turns)"),
    _w("G4", "G0 non-modal", "dwell P seconds"),
    _w("G10", "G0 non-modal", "L1/L10/L11 tool table, L2/L20 work offsets (P system)"),
    _w("G17", "G2 plane", "XY plane"),
    _w("G18", "G2 plane", "ZX plane"),
    _w("G19", "G2 plane", "YZ plane"),
    _w("G20", "G6 units", "inch"),
    _w("G21", "G6 units", "millimetre"),
    _w("G28", "G0 non-modal", "rapid to the G28 position (through the axis words given)"),
    _w("G28.1", "G0 non-modal", "store the G28 position (#5161-#5169)"),
    _w("G30", "G0 non-modal", "rapid to the G30 position (through the axis words given)"),
    _w("G30.1", "G0 non-modal", "store the G30 position (#5181-#5189)"),
    _w("G40", "G7 cutter compensation", "cutter radius compensation off"),
    _w("G43", "G8 tool length", "tool length offset from the tool table (H, default the tool)"),
    _w("G43.1", "G8 tool length", "dynamic tool length offset (the axis words)"),
    _w("G43.2", "G8 tool length", "add the tool table offset of H"),
    _w("G49", "G8 tool length", "tool length offset off"),
    _w("G53", "G0 non-modal", "this G0/G1 in machine coordinates"),
    _w("G54", "G12 coordinate system", "work offset 1"),
    _w("G55", "G12 coordinate system", "work offset 2"),
    _w("G56", "G12 coordinate system", "work offset 3"),
    _w("G57", "G12 coordinate system", "work offset 4"),
    _w("G58", "G12 coordinate system", "work offset 5"),
    _w("G59", "G12 coordinate system", "work offset 6"),
    _w("G59.1", "G12 coordinate system", "work offset 7"),
    _w("G59.2", "G12 coordinate system", "work offset 8"),
    _w("G59.3", "G12 coordinate system", "work offset 9"),
    _w("G61", "G13 path control", "exact path (tangent joins at speed, stop at corners)"),
    _w("G61.1", "G13 path control", "exact stop at the end of every move"),
    _w(
        "G64",
        "G13 path control",
        "blending: P tolerance (none or 0: as fast as possible), Q naive-CAM collinear merge",
    ),
    _w("G73", "G1 motion", "drilling cycle with chip breaking (Q peck)"),
    _w("G80", "G1 motion", "cancel the canned cycle"),
    _w("G81", "G1 motion", "drilling cycle"),
    _w("G82", "G1 motion", "drilling cycle with dwell P"),
    _w("G83", "G1 motion", "peck drilling cycle (Q peck)"),
    _w("G84", "G1 motion", "tapping cycle (spindle reversed at the bottom)"),
    _w("G85", "G1 motion", "boring cycle, feed out"),
    _w("G86", "G1 motion", "boring cycle, spindle stop, rapid out"),
    _w("G87", "G1 motion", "back boring cycle (I J K offsets)"),
    _w("G88", "G1 motion", "boring cycle, spindle stop, pause, manual out"),
    _w("G89", "G1 motion", "boring cycle, dwell P, feed out"),
    _w("G90", "G3 distance", "absolute axis words"),
    _w("G90.1", "G4 arc distance", "absolute I J K"),
    _w("G91", "G3 distance", "incremental axis words"),
    _w("G91.1", "G4 arc distance", "incremental I J K (start state)"),
    _w("G92", "G0 non-modal", "coordinate offset: the current point gets the axis words"),
    _w("G92.1", "G0 non-modal", "G92 offsets off, parameters zeroed"),
    _w("G92.2", "G0 non-modal", "G92 offsets off, parameters kept"),
    _w("G92.3", "G0 non-modal", "G92 offsets from the parameters"),
    _w("G93", "G5 feed mode", "inverse time feed"),
    _w("G94", "G5 feed mode", "units per minute feed"),
    _w("G95", "G5 feed mode", "units per revolution feed"),
    _w("G97", "G14 spindle mode", "spindle RPM mode (start state)"),
    _w("G98", "G10 return mode", "canned cycles return to the initial level"),
    _w("G99", "G10 return mode", "canned cycles return to R"),
    _w("M0", "M4 stopping", "program pause"),
    _w("M1", "M4 stopping", "optional pause (only with the optional-stop switch on)"),
    _w("M2", "M4 stopping", "program end"),
    _w("M3", "M7 spindle", "spindle clockwise at S"),
    _w("M4", "M7 spindle", "spindle counter-clockwise at S"),
    _w("M5", "M7 spindle", "spindle stop"),
    _w("M6", "M6 tool change", "change to the tool selected by T"),
    _w("M7", "M8 coolant", "mist coolant on"),
    _w("M8", "M8 coolant", "flood coolant on"),
    _w("M9", "M8 coolant", "coolant off"),
    _w("M30", "M4 stopping", "program end"),
    _w("M48", "M9 overrides", "overrides enabled (no override input: noted, ignored)"),
    _w("M49", "M9 overrides", "overrides disabled (no override input: noted, ignored)"),
    _w("M50", "M9 overrides", "feed override control (noted, ignored)"),
    _w("M51", "M9 overrides", "spindle override control (noted, ignored)"),
    _w("M52", "M9 overrides", "adaptive feed (noted, ignored)"),
    _w("M53", "M9 overrides", "feed stop control (noted, ignored)"),
    _w("M60", "M4 stopping", "pallet change pause"),
    _w("M62", "M5 outputs", "digital output P on, with the next motion"),
    _w("M63", "M5 outputs", "digital output P off, with the next motion"),
    _w("M64", "M5 outputs", "digital output P on, now"),
    _w("M65", "M5 outputs", "digital output P off, now"),
    _w("F", "", "feed rate (units/min, 1/min in G93, units/rev in G95)"),
    _w("S", "", "spindle speed (rev/min)"),
    _w("T", "", "tool selection (M6 changes)"),
    _w("H", "", "tool length offset number (G43, G43.2)"),
    _w("D", "", "cutter compensation number (only with G41/G42: refused)"),
    _w("N", "", "line number (ignored)"),
    _w(
        "O",
        "",
        "O-words: sub endsub call return if elseif else endif while endwhile do "
        "repeat endrepeat break continue",
    ),
    _w("X Y Z", "", "linear axes (those of the machine)"),
    _w("A B C", "", "rotary axes in degrees (those of the machine)"),
    _w("U V W", "", "linear axes (those of the machine)"),
    _w("@ ^", "", "polar coordinates in G17: radius @ and angle ^ [deg] of X Y (G91: increments)"),
    _w("I J K", "", "arc centre offsets, G87 offsets"),
    _w("R", "", "arc radius, canned-cycle retract level, G10 L2 rotation (0 only)"),
    _w("P", "", "dwell time, turns, G10 system/tool, G64 tolerance, M62-M65 output"),
    _w("Q", "", "peck depth (G73, G83), G64 naive-CAM tolerance"),
    _w("L", "", "G10 form, canned-cycle repeats"),
)
_G_WORDS = {w.code: w for w in WORDS if w.code.startswith("G")}
_M_WORDS = {w.code: w for w in WORDS if w.code.startswith("M")}

# Known G/M codes that are refused, with the reason (the others are "unknown")
_REFUSED_G = {
    "G5": "cubic spline",
    "G5.1": "quadratic spline",
    "G5.2": "NURBS",
    "G5.3": "NURBS",
    "G7": "lathe diameter mode",
    "G8": "lathe radius mode",
    "G17.1": "UV plane",
    "G18.1": "WU plane",
    "G19.1": "VW plane",
    "G33": "spindle-synchronised motion",
    "G33.1": "rigid tapping",
    "G38.2": "probing",
    "G38.3": "probing",
    "G38.4": "probing",
    "G38.5": "probing",
    "G41": "cutter radius compensation (not implemented: program the tool centre path, G40)",
    "G42": "cutter radius compensation (not implemented: program the tool centre path, G40)",
    "G41.1": "dynamic cutter compensation (not implemented)",
    "G42.1": "dynamic cutter compensation (not implemented)",
    "G52": "local offset (use G92 or G10 L2)",
    "G70": "lathe finishing cycle",
    "G71": "lathe roughing cycle",
    "G72": "lathe facing cycle",
    "G74": "left-hand tapping cycle",
    "G76": "threading cycle",
    "G96": "constant surface speed",
}
_REFUSED_M = {
    "M19": "spindle orientation",
    "M61": "set the current tool (use T and M6)",
    "M66": "wait on input",
    "M67": "analog output, with motion",
    "M68": "analog output",
    "M70": "save modal state",
    "M71": "invalidate saved state",
    "M72": "restore modal state",
    "M73": "save and autorestore state",
}
# modal groups of the G codes (value*10 -> group); group 0 = non-modal
_G_GROUP: dict[int, int] = {}
for _code, _g in (
    (0, 1),
    (10, 1),
    (20, 1),
    (30, 1),
    (730, 1),
    (800, 1),
    (810, 1),
    (820, 1),
    (830, 1),
    (840, 1),
    (850, 1),
    (860, 1),
    (870, 1),
    (880, 1),
    (890, 1),
    (40, 0),
    (100, 0),
    (280, 0),
    (281, 0),
    (300, 0),
    (301, 0),
    (530, 0),
    (920, 0),
    (921, 0),
    (922, 0),
    (923, 0),
    (170, 2),
    (180, 2),
    (190, 2),
    (900, 3),
    (910, 3),
    (901, 4),
    (911, 4),
    (930, 5),
    (940, 5),
    (950, 5),
    (200, 6),
    (210, 6),
    (400, 7),
    (430, 8),
    (431, 8),
    (432, 8),
    (490, 8),
    (980, 10),
    (990, 10),
    (540, 12),
    (550, 12),
    (560, 12),
    (570, 12),
    (580, 12),
    (590, 12),
    (591, 12),
    (592, 12),
    (593, 12),
    (610, 13),
    (611, 13),
    (640, 13),
    (970, 14),
):
    _G_GROUP[_code] = _g
_M_GROUP = {
    0: 4,
    1: 4,
    2: 4,
    30: 4,
    60: 4,
    6: 6,
    3: 7,
    4: 7,
    5: 7,
    7: 8,
    8: 8,
    9: 8,
    48: 9,
    49: 9,
    50: 9,
    51: 9,
    52: 9,
    53: 9,
    62: 5,
    63: 5,
    64: 5,
    65: 5,
}
_CYCLES = (730, 810, 820, 830, 840, 850, 860, 870, 880, 890)
_AXIS_USERS_G0 = (100, 280, 300, 920)  # non-modal codes that take the axis words
_SYSTEM_OF = {540: 1, 550: 2, 560: 3, 570: 4, 580: 5, 590: 6, 591: 7, 592: 8, 593: 9}
_SYSTEM_NAME = {v: k for k, v in _SYSTEM_OF.items()}


def _g_label(tenths: int) -> str:
    return f"G{tenths // 10}" + (f".{tenths % 10}" if tenths % 10 else "")


def supported_codes() -> list[str]:
    """Every G and M code and value word the interpreter accepts (the word table's codes)."""
    out: list[str] = []
    for w in WORDS:
        out.extend(w.code.split())
    return out


# ------------------------------------------------------------------------------- results
class GcodeMove(NamedTuple):
    """One motion of a program, in the group's machine coordinates, SI (m, rad).

    ``kind`` ``"rapid"`` | ``"linear"`` | ``"arc_cw"`` | ``"arc_ccw"``; ``center`` the arc
    centre (the plane's two coordinates; the others are the start's), ``plane`` ``"XY"`` |
    ``"ZX"`` | ``"YZ"``, ``turns`` the extra full turns (P - 1; an arc whose end equals its
    start in the plane is a full circle); off-plane axes (the normal axis and rotary axes) move
    linearly with the angle (a helix). ``feed`` the programmed feed [m/s, or rad/s for a
    rotary-only move] (None for rapids), ``velocity`` the path speed along the whole group path
    that gives the programmed feed (LinuxCNC: the feed applies to X Y Z, else U V W, else A B
    C), ``duration`` the programmed time [s] (None for rapids). Path control of the line:
    ``exact_stop`` (G61.1), ``exact_path`` (G61), else blending with ``tolerance`` [m] (None:
    as fast as possible) and ``naive_tolerance`` (G64 Q [m], None: off). ``outputs``: the
    M62/M63 outputs switched with this motion (index, state).
    """

    line: int
    number: int | None
    text: str
    kind: str
    start: tuple[float, ...]
    end: tuple[float, ...]
    center: tuple[float, ...] | None
    plane: str
    turns: int
    feed: float | None
    exact_stop: bool
    tolerance: float | None
    velocity: float | None = None
    duration: float | None = None
    exact_path: bool = False
    naive_tolerance: float | None = None
    outputs: tuple[tuple[int, bool], ...] = ()
    word: str = ""


@dataclass(frozen=True, slots=True)
class GcodeEvent:
    """A machine action of a program, in order with the moves: ``kind`` one of
    ``spindle`` (``value`` rev/min, signed: + clockwise (M3), - counter-clockwise (M4), 0 stop),
    ``coolant`` (``name`` ``"mist"`` / ``"flood"``, ``value`` 1 on / 0 off), ``output``
    (``index``, ``value`` 1/0; ``name`` the machine's output), ``tool_change`` (``index`` the
    tool), ``dwell`` (``value`` s), ``pause`` (M0/M1/M60), ``end`` (M2/M30), ``message``
    (``text``), ``note`` (a word understood but without effect on this machine). ``sync``:
    the motion before it must be finished (LinuxCNC queues these with the motion)."""

    line: int
    kind: str
    value: float = 0.0
    name: str = ""
    index: int = 0
    text: str = ""
    sync: bool = True


# ------------------------------------------------------------------------------- machine setup
@dataclass(frozen=True, slots=True)
class Tool:
    """A tool table entry: ``offsets`` per axis letter [m] (LinuxCNC's X..W), ``diameter``."""

    number: int
    offsets: dict[str, float] = field(default_factory=dict)
    diameter: float = 0.0
    comment: str = ""


@dataclass(frozen=True, slots=True)
class MachineSetup:
    """The machine a program runs on and its start-up state.

    ``axes``: G-code axis letter -> index in the group (e.g. ``{"X": 0, "Y": 1, "Z": 2, "A":
    3}``); ``names`` the group members (for messages), ``rotary`` the letters whose members
    are in rad. Start-up state: ``units`` ``"mm"`` | ``"inch"``, ``plane`` ``"XY"`` | ``"ZX"``
    | ``"YZ"``, ``path_control`` ``"G64"`` (LinuxCNC's start: as fast as possible) |
    ``"G61"`` | ``"G61.1"``, ``coordinate_system`` 1..9 (G54..G59.3), ``work_offsets``
    {system: {letter: m}},
    ``tools`` {number: Tool}, ``spindle``/``coolant``/``outputs``: what the machine has (an M3
    on a machine without a spindle is a note, not an error), ``block_delete`` (lines starting
    with / are skipped), ``optional_stop`` (M1 pauses), ``max_blocks`` (None: 100000 + 10 per
    line of the file), ``limits`` per member (min, max) [m] (None: unlimited) checked on
    every move and the whole of every arc.
    """

    axes: dict[str, int] = field(default_factory=lambda: {"X": 0, "Y": 1, "Z": 2})
    names: tuple[str, ...] = ("x", "y", "z")
    rotary: frozenset[str] = frozenset()
    units: str = "mm"
    plane: str = "XY"
    path_control: str = "G64"
    coordinate_system: int = 1
    work_offsets: dict[int, dict[str, float]] = field(default_factory=dict)
    tools: dict[int, Tool] = field(default_factory=dict)
    spindle: bool = False
    coolant: tuple[str, ...] = ()  # "mist", "flood" present
    outputs: tuple[str, ...] = ()  # M62-M65 P index -> name
    block_delete: bool = True
    optional_stop: bool = False
    max_blocks: int | None = None
    limits: tuple[tuple[float | None, float | None], ...] | None = None

    @classmethod
    def for_axes(cls, names: Sequence[str], **kw: Any) -> MachineSetup:
        """X, Y, Z on the group members in order (1 to 3 linear axes)."""
        return cls(axes={AXES[i]: i for i in range(len(names))}, names=tuple(names), **kw)


def read_tool_table(path: str | FilePath, unit: float = MM) -> dict[int, Tool]:
    """A LinuxCNC tool table file (``T1 P1 Z12.5 D6 ;comment``), values in ``unit`` [m per
    unit]. Raises :class:`GcodeError` ``FILE:LINE: WORD: ...``."""
    p = FilePath(path)
    try:
        text = p.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise GcodeError(f"{p}: cannot read the tool table: {exc}") from None
    tools: dict[int, Tool] = {}
    errors: list[str] = []
    for no, raw in enumerate(text.splitlines()[:100_000], start=1):
        body, _, comment = raw.partition(";")
        if not body.strip():
            continue
        num: int | None = None
        offs: dict[str, float] = {}
        dia = 0.0
        for tok in body.split():
            letter, val = tok[:1].upper(), tok[1:]
            try:
                v = float(val)
            except ValueError:
                errors.append(f"{p}:{no}: {escape(tok)}: not a number (allowed: T1 P1 Z1.5 D6)")
                break
            if not math.isfinite(v) or abs(v) > _MAX_VALUE:
                errors.append(f"{p}:{no}: {escape(tok)}: out of range")
                break
            if letter == "T":
                num = int(v)
            elif letter in AXES:
                offs[letter] = v * (DEG if letter in ROTARY else unit)
            elif letter == "D":
                dia = v * unit
            elif letter in "PIJQ":
                pass
            else:
                errors.append(
                    f"{p}:{no}: {escape(tok)}: unknown tool table field (allowed: T P X..W D I J Q)"
                )
                break
        if num is None:
            errors.append(f"{p}:{no}: no T number (allowed: T<n> ...)")
            continue
        tools[num] = Tool(num, offs, dia, comment.strip())
    if errors:
        raise GcodeError(errors[:MAX_ERRORS])
    return tools


# ------------------------------------------------------------------------------- the source
class _Source:
    """A program file read line by line (bytes), with seeks for O-word control flow."""

    def __init__(self, stream: IO[bytes], path: str) -> None:
        self.f = stream
        self.path = path
        self.line_no = 0
        self.pos = 0  # byte offset of the next line

    def readline(self) -> tuple[int, str] | None:
        raw = self.f.readline(MAX_LINE * 4 + 2)
        if not raw:
            return None
        self.pos += len(raw)
        self.line_no += 1
        if self.line_no > MAX_LINES:
            raise GcodeError(
                f"{self.path}:{self.line_no}: the file has more than {MAX_LINES} lines "
                f"(allowed: up to {MAX_LINES})"
            )
        if not raw.endswith(b"\n") and len(raw) > MAX_LINE * 4:
            while True:  # skip the rest of an over-long line
                more = self.f.readline(1 << 16)
                self.pos += len(more)
                if not more or more.endswith(b"\n"):
                    break
            return self.line_no, "\x00LONG"
        try:
            text = raw.decode("utf-8")
        except UnicodeDecodeError:
            return self.line_no, "\x00UTF8"
        return self.line_no, text.rstrip("\r\n")

    def tell(self) -> tuple[int, int]:
        return self.pos, self.line_no

    def seek(self, where: tuple[int, int]) -> None:
        self.f.seek(where[0])
        self.pos = where[0]
        self.line_no = where[1]


# ------------------------------------------------------------------------------- lexing
_NUM = re.compile(r"\d+\.?\d*|\.\d+")
_SIMPLE = re.compile(r"(?:[A-NP-Z][-+]?(?:\d+\.?\d*|\.\d+))+")
_PAIRS = re.compile(r"([A-Z])([-+]?(?:\d+\.?\d*|\.\d+))")
_ALLOWED_CHARS = frozenset("ABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789.+-*/#[]<>=_@^")
_FUNCS = (
    "ABS",
    "ACOS",
    "ASIN",
    "ATAN",
    "COS",
    "EXISTS",
    "EXP",
    "FIX",
    "FUP",
    "LN",
    "ROUND",
    "SIN",
    "SQRT",
    "TAN",
)
_BINOPS = (  # (text, precedence)
    ("**", 4),
    ("*", 3),
    ("/", 3),
    ("MOD", 3),
    ("+", 2),
    ("-", 2),
    ("EQ", 1),
    ("NE", 1),
    ("GT", 1),
    ("GE", 1),
    ("LT", 1),
    ("LE", 1),
    ("AND", 0),
    ("OR", 0),
    ("XOR", 0),
)
_O_KEYWORDS = (
    "ENDSUB",
    "SUB",
    "CALL",
    "RETURN",
    "ELSEIF",
    "ENDIF",
    "ELSE",
    "IF",
    "ENDWHILE",
    "WHILE",
    "DO",
    "ENDREPEAT",
    "REPEAT",
    "BREAK",
    "CONTINUE",
)


_M_WORD = re.compile(r"M(\d+\.?\d*|\.\d+)")
_ASSIGNED = re.compile(r"#(\d+\.?\d*|<[^>]*>)=")
_READ = re.compile(r"#(\d+\.?\d*|<[^>]*>)")


def _param_key(text: str) -> Any:
    """``12`` -> 12, ``<Name>`` -> "name": a parameter as the interpreter keys it."""
    return text[1:-1].lower() if text.startswith("<") else int(float(text))


def _shape_word(m: re.Match[str]) -> str:
    """A word's letter (G/M: the whole code): lines of one shape pass the same checks."""
    letter = m.group(1)
    return m.group(0) if letter in "GM" else letter


def _split_comments(raw: str) -> tuple[str, list[str]]:
    """(the code without comments and spaces, upper case; the comments' texts)."""
    if "(" not in raw and ";" not in raw:
        return "".join(raw.split()).upper(), []
    code: list[str] = []
    comments: list[str] = []
    i, n = 0, len(raw)
    while i < n:
        ch = raw[i]
        if ch == "(":
            j = raw.find(")", i + 1)
            if j < 0:
                raise _Err("(", "unclosed comment (allowed: ( ... ) closed on its line)")
            body = raw[i + 1 : j]
            if "(" in body:
                raise _Err("(", "nested comment (allowed: ( ... ) without a second '(')")
            comments.append(body)
            i = j + 1
        elif ch == ";":
            comments.append(raw[i + 1 :])
            break
        else:
            j = i
            while j < n and raw[j] not in "(;":
                j += 1
            code.append(raw[i:j])
            i = j
    return "".join("".join(code).split()).upper(), comments


Value = float | Callable[[], float]  # a value of a line: known, or computed when the line runs
_Compiled = tuple[int | None, Any, list[tuple[Any, ...]], "_Err | None"]
_MAX_COMPILED = 4096  # lines kept compiled (a loop body lexed once); more are compiled each time


def _ev(v: Value) -> float:
    return v if type(v) is float else v()  # type: ignore[operator]


_EXPONENT = re.compile(r"([A-DF-Z])\s*([-+]?(?:\d+\.?\d*|\.\d+))E([-+]?\d+)", re.IGNORECASE)


def _exponent_error(b: _Block) -> None:
    """An E word right after a number (``F1e15``): a number written with an exponent, which
    G-code does not have (it reads ``F1`` and ``E15``): say so, with the value written out."""
    m = _EXPONENT.search(b.text)
    if m is None:
        return
    letter, mant, exp = m.groups()
    value = float(f"{mant}e{exp}")
    if not abs(value) < _MAX_VALUE:
        allowed = f"|value| < {_MAX_VALUE:g}, written out without an exponent"
    else:
        num = f"{value:.12g}"
        if "e" in num:
            num = f"{value:.15f}".rstrip("0")
        allowed = f"the number written out, e.g. {letter.upper()}{num}"
    raise _Err(
        m.group(0),
        f"G-code numbers have no exponent: {letter}{mant} and E{exp} (allowed: {allowed})",
    )


class _Block:
    """One line, its values evaluated."""

    __slots__ = (
        "line",
        "text",
        "words",
        "word_text",
        "gs",
        "ms",
        "assigns",
        "comments",
        "o_label",
        "o_keyword",
        "o_args",
        "number",
    )

    def __init__(self, line: int, text: str, comments: list[str]) -> None:
        self.line = line
        self.text = text
        self.words: dict[str, float] = {}
        self.word_text: dict[str, str] = {}
        self.gs: list[int] = []
        self.ms: list[int] = []
        self.assigns: list[tuple[Any, float]] = []
        self.comments = comments
        self.o_label: Any = None
        self.o_keyword = ""
        self.o_args: list[float] = []
        self.number: int | None = None


# ------------------------------------------------------------------------------- interpreter
_READ_ONLY_PARAMS = range(5400, 5429)
_MAX_PARAM = 5602


@dataclass(slots=True)
class _Frame:
    """A subroutine call: where to return, the saved #1-#30, the local named parameters."""

    ret: tuple[int, int] | None
    label: Any
    saved: dict[int, float]
    local: dict[str, float]
    control_depth: int
    call_line: int


@dataclass(slots=True)
class _Control:
    """An open if/while/do/repeat: ``kind``, ``label``, where it started, repeats left."""

    kind: str
    label: Any
    start: tuple[int, int]
    count: int = 0
    taken: bool = False


class Interpreter:
    """Runs a G-code program (see the module docstring) and yields its moves and events.

    ``source``: a path (read as a file, streamed) or the program text; ``setup`` the machine
    (:class:`MachineSetup`); ``start`` the group's machine position [m, rad] (default 0).
    Iterate :meth:`run` for the items; the first error raises :class:`GcodeError`. With
    ``collect=True`` errors are collected in :attr:`errors` (up to 100) and the line that
    failed is skipped (for ``validate``). :attr:`notes` lists words understood but without
    effect on this machine (each once), :attr:`skipped` the zero-length moves.
    """

    def __init__(
        self,
        source: str | FilePath,
        setup: MachineSetup | None = None,
        start: Sequence[float] | None = None,
        *,
        path: str | None = None,
        text: str | None = None,
        collect: bool = False,
    ) -> None:
        self.setup = setup if setup is not None else MachineSetup()
        s = self.setup
        self.collect = collect
        self.errors: list[str] = []
        self.n_errors = 0
        self.notes: list[str] = []
        self._noted: set[str] = set()
        self.skipped: list[str] = []
        self.n_skipped = 0
        if text is not None:
            self.path = path or str(source)
            self._stream: IO[bytes] = io.BytesIO(text.encode("utf-8", "surrogateescape"))
        else:
            self.path = path or str(source)
            try:
                self._stream = open(source, "rb")  # noqa: SIM115 - closed by close()
            except OSError as exc:
                raise GcodeError(f"{self.path}: cannot read: {exc.strerror or exc}") from None
        self.src = _Source(self._stream, self.path)
        n = len(s.names)
        self._members = [""] * n  # group index -> letter
        for letter, i in s.axes.items():
            if letter not in AXES or not 0 <= i < n:
                raise GcodeError(f"{self.path}: axes: bad mapping {letter!r} -> {i!r}")
            self._members[i] = letter
        self._member_idx = [AXES.index(letter) for letter in self._members]
        self.pos = [0.0] * 9
        if start is not None:
            vals = list(start)
            if len(vals) != n or not all(
                isinstance(v, (int, float)) and math.isfinite(v) for v in vals
            ):
                raise GcodeError(
                    f"{self.path}: start: must be {n} finite numbers (one per axis "
                    f"{', '.join(s.names)}), got {vals!r}"
                )
            for i, v in zip(self._member_idx, vals, strict=True):
                self.pos[i] = float(v)
        # modal state (LinuxCNC's start-up defaults, with the machine's units/plane/system)
        self.unit = INCH if s.units == "inch" else MM
        self.plane = s.plane
        self.incremental = False
        self.ijk_absolute = False
        self.feed_mode = 94
        self.feed_value = 0.0  # F in the current units per minute
        self.motion: int | None = None
        self.path_mode = {"G61": "exact_path", "G61.1": "exact_stop"}.get(s.path_control, "blend")
        self.p_tol: float | None = None
        self.q_tol: float | None = None
        self.retract_r = False  # G99
        self.cs = s.coordinate_system
        self.g5x = [[0.0] * 9 for _ in range(10)]
        for sys_no, offs in s.work_offsets.items():
            for letter, v in offs.items():
                self.g5x[sys_no][AXES.index(letter)] = float(v)
        self.g92 = [0.0] * 9
        self.g92_on = False
        self.g92_saved = [0.0] * 9
        self.tlo = [0.0] * 9
        self.tools = dict(s.tools)
        self.tool = 0
        self.selected = 0
        self.rpm = 0.0
        self.spindle_dir = 0
        self.mist = self.flood = False
        self.g28 = [0.0] * 9
        self.g30 = [0.0] * 9
        self.params: dict[int, float] = {}
        self.globals: dict[str, float] = {}
        self.frames: list[_Frame] = [_Frame(None, None, {}, {}, 0, 0)]
        self.controls: list[_Control] = []
        self.cycle: dict[str, float] = {}
        self.cycle_il: float | None = None  # the initial level of a series of cycles
        self._pending_outputs: list[tuple[int, bool]] = []
        self._dry = False
        self.blocks = 0
        self.max_blocks = s.max_blocks
        self.ended = False
        self.percent_open = False
        self.n_moves = 0
        self._o_index: dict[Any, list[tuple[str, int, int]]] | None = None
        self._line_no = 0
        self._text = ""
        self._first_move_seen = False
        self._out: list[GcodeMove | GcodeEvent] = []
        self._line_start = 0
        self._literal = True
        self._loops_checked: set[int] = set()
        self._compiled: dict[
            str, _Compiled
        ] = {}  # line code -> its compiled words  # loops found able to end (their offsets)

    # -- public ----------------------------------------------------------------------------
    def close(self) -> None:
        self._stream.close()

    def run(self) -> Iterator[GcodeMove | GcodeEvent]:
        """The program's moves and events, lazily (the prescan of the whole file, its syntax
        and O-word structure, happens at the first item)."""
        try:
            self._prescan()
            yield from self._execute()
        finally:
            self.close()

    def moves(self) -> Iterator[GcodeMove]:
        """Only the moves of :meth:`run`."""
        for item in self.run():
            if isinstance(item, GcodeMove):
                yield item

    # -- errors ----------------------------------------------------------------------------
    def _located(self, line: int, word: str, message: str) -> str:
        return f"{self.path}:{line}: {escape(word, 60)}: {message}"

    def _record(self, msg: str) -> None:
        self.n_errors += 1
        if len(self.errors) < MAX_ERRORS:
            self.errors.append(msg)
        if not self.collect:
            raise GcodeError(msg)

    def _note(self, key: str, message: str, line: int) -> None:
        if key in self._noted:
            return
        self._noted.add(key)
        msg = f"{self.path}:{line}: {message}"
        self.notes.append(msg)
        _log.info("%s", msg)

    def _final_errors(self) -> None:
        if self.errors:
            errs = list(self.errors)
            if self.n_errors > len(errs):
                errs.append(f"{self.path}: ... and {self.n_errors - len(errs)} more errors")
            raise GcodeError(errs)

    # -- prescan: syntax of every line, the O-word index -----------------------------------
    def _prescan(self) -> None:
        src = self.src
        index: dict[Any, list[tuple[str, int, int]]] = {}
        n_lines = 0
        self._dry = True
        errors: list[str] = []
        n_err = 0
        pct = 0
        shapes: set[str] = set()
        open_sub: tuple[Any, int] | None = None  # (label, line) of the sub being defined
        try:
            while True:
                here = src.pos
                item = src.readline()
                if item is None:
                    break
                no, raw = item
                n_lines = no
                try:
                    stripped = raw.strip()
                    if stripped.startswith("%"):
                        pct += 1
                        if pct >= 2:
                            break
                        continue
                    if "(" not in raw and ";" not in raw:
                        code = "".join(raw.split()).upper()
                        if _SIMPLE.fullmatch(code) and len(raw) <= MAX_LINE:
                            shape = _PAIRS.sub(_shape_word, code)
                            if shape in shapes:
                                continue
                            blk = self._parse(no, raw)
                            if blk is not None:
                                self._check_block(blk)
                            if len(shapes) < 4096:
                                shapes.add(shape)
                            continue
                    blk = self._parse(no, raw)
                    if blk is None:
                        continue
                    if blk.o_keyword:
                        index.setdefault(blk.o_label, []).append((blk.o_keyword, here, no - 1))
                        if blk.o_keyword == "SUB":
                            if open_sub is not None:
                                # LinuxCNC (interp_o_word.cc): "Nested subroutine definition"
                                raise _Err(
                                    f"O{blk.o_label}",
                                    f"subroutine definition inside O{open_sub[0]} sub of line "
                                    f"{open_sub[1]} (allowed: subroutines defined one after "
                                    "another, not nested)",
                                )
                            open_sub = (blk.o_label, no)
                        elif blk.o_keyword == "ENDSUB" and open_sub and open_sub[0] == blk.o_label:
                            open_sub = None
                    if not blk.assigns and self._literal:
                        self._check_block(blk)
                except _Err as exc:
                    n_err += 1
                    if len(errors) < MAX_ERRORS:
                        errors.append(self._located(no, exc.word, exc.message))
        finally:
            self._dry = False
        if errors:
            if n_err > len(errors):
                errors.append(f"{self.path}: ... and {n_err - len(errors)} more errors")
            raise GcodeError(errors)
        self._o_index = index
        if self.max_blocks is None:
            self.max_blocks = 100_000 + 10 * n_lines
        src.seek((0, 0))

    # -- parsing one line ------------------------------------------------------------------
    def _parse(self, no: int, raw: str) -> _Block | None:
        """The line's block (values evaluated; in the prescan with parameters read as 0), or
        None for an empty / deleted line. Raises _Err."""
        self._literal = True
        if raw and raw[0] == "\x00":
            if raw == "\x00LONG":
                raise _Err(
                    "line", f"line longer than {MAX_LINE} characters (allowed: up to {MAX_LINE})"
                )
            raise _Err("line", "not UTF-8 text (allowed: ASCII / UTF-8)")
        if len(raw) > MAX_LINE:
            raise _Err(
                "line", f"line longer than {MAX_LINE} characters (allowed: up to {MAX_LINE})"
            )
        code, comments = _split_comments(raw)
        if code.startswith("/"):
            if self.setup.block_delete:
                return None
            code = code[1:]
        if not code and not comments:
            return None
        blk = _Block(no, raw, comments)
        if not code:
            return blk
        if _SIMPLE.fullmatch(code):
            words = blk.words
            for letter, num in _PAIRS.findall(code):
                if letter in "GMN" or letter in words:
                    self._add_word(blk, letter, float(num), letter + num)
                else:
                    v = float(num)
                    if not abs(v) < _MAX_VALUE:
                        raise _Err(
                            letter + num, f"number out of range (allowed: |value| < {_MAX_VALUE:g})"
                        )
                    words[letter] = v
                    blk.word_text[letter] = letter + num
            return blk
        self._literal = False
        compiled = self._compiled.get(code)
        if compiled is None:
            bad = next((ch for ch in code if ch not in _ALLOWED_CHARS), None)
            if bad is not None:
                raise _Err(
                    bad,
                    f"unexpected character {escape(bad)!s} (allowed: words, comments, "
                    "# parameters, [expressions])",
                )
            compiled = self._compile_line(code)
            if len(self._compiled) < _MAX_COMPILED:
                self._compiled[code] = compiled
        number, o_word, items, error = compiled
        blk.number = number
        if o_word is not None:
            blk.o_label, blk.o_keyword, args = o_word
            blk.o_args = [a if type(a) is float else a() for a in args]
        for item in items:
            if item[0] == "#":
                key = item[1]
                if type(key) is not str and type(key) is not int:
                    key = key()
                val = item[2]
                blk.assigns.append((key, val if type(val) is float else val()))
            else:
                val = item[1]
                self._add_word(blk, item[0], val if type(val) is float else val(), item[2])
        if error is not None:
            raise error
        return blk

    def _add_word(self, blk: _Block, letter: str, value: float, text: str) -> None:
        if not abs(value) < _MAX_VALUE:
            raise _Err(text, f"number out of range (allowed: |value| < {_MAX_VALUE:g})")
        if letter == "G":
            t = round(value * 10.0)
            if abs(value * 10.0 - t) > 1e-6 or t < 0:
                raise _Err(text, "not a G code (allowed: see the G-code reference)")
            blk.gs.append(t)
        elif letter == "M":
            if value != int(value) or value < 0:
                raise _Err(text, "not an M code (allowed: see the G-code reference)")
            blk.ms.append(int(value))
        elif letter == "N":
            blk.number = int(value)
        else:
            if letter in blk.words:
                raise _Err(
                    text,
                    f"second {letter} word on the line ({blk.word_text[letter]} "
                    "already; allowed: one per line)",
                )
            blk.words[letter] = value
            blk.word_text[letter] = text

    def _compile_line(self, code: str) -> _Compiled:
        """A line with parameters, expressions or O-words, compiled once (its values as
        closures, evaluated each time the line runs: a loop body is lexed once). A syntax
        error comes after the words before it are evaluated, as when read left to right."""
        number = None
        o_word = None
        items: list[tuple[Any, ...]] = []
        i = 0
        n = len(code)
        try:
            if code[0] == "N":
                m = _NUM.match(code, 1)
                if m is not None:
                    number = int(float(m.group()))
                    i = m.end()
            if i < n and code[i] == "O":
                o_word = self._compile_o(code, i + 1)
                return number, o_word, items, None
            while i < n:
                ch = code[i]
                if ch == "#":
                    key, i = self._param_ref(code, i + 1, 0)
                    if i >= n or code[i] != "=":
                        raise _Err("#", "parameter without '=' (allowed: #1=2, #<name>=[1+2])")
                    val, i = self._value(code, i + 1, 0)
                    items.append(("#", key, val))
                    continue
                if "A" <= ch <= "Z" or ch in "@^":
                    if ch == "O":
                        raise _Err(
                            "O", "O-word not at the start of the line (allowed: o100 sub ...)"
                        )
                    j = i + 1
                    val, i = self._value(code, j, 0)
                    items.append((ch, val, ch + code[j:i]))
                    continue
                raise _Err(
                    code[i : i + 8],
                    "number without a letter (allowed: a letter before each number)",
                )
        except _Err as exc:
            return number, o_word, items, exc
        return number, o_word, items, None

    def _compile_o(self, code: str, i: int) -> tuple[Any, str, list[Value]]:
        n = len(code)
        if i < n and code[i] == "<":
            j = code.find(">", i)
            if j < 0:
                raise _Err("O<", "unclosed O-word name (allowed: o<name>)")
            label: Any = code[i + 1 : j].lower()
            i = j + 1
        else:
            m = _NUM.match(code, i)
            if m is None:
                raise _Err("O", "O-word without a number or <name> (allowed: o100, o<name>)")
            label = int(float(m.group()))
            i = m.end()
        for kw in _O_KEYWORDS:
            if code.startswith(kw, i):
                i += len(kw)
                break
        else:
            raise _Err(
                f"O{label}",
                "O-word without a keyword (allowed: sub endsub call return "
                "if elseif else endif while endwhile do repeat endrepeat break continue)",
            )
        args: list[Value] = []
        while i < n:
            if code[i] != "[":
                raise _Err(
                    code[i : i + 8],
                    f"after O{label} {kw}: only [expressions] (allowed: o100 call [1] [2])",
                )
            val, i = self._value(code, i, 0)
            args.append(val)
            if len(args) > 30:
                raise _Err(f"O{label}", "more than 30 arguments (allowed: #1-#30)")
        return label, kw, args

    # -- values and expressions: compiled to closures, evaluated when the line runs ----------
    def _value(self, code: str, i: int, depth: int) -> tuple[Value, int]:
        """A real value at ``code[i]``: number, #parameter, [expression], function, with an
        optional sign; a float, or a closure that evaluates it."""
        if depth > MAX_NESTING:
            raise _Err(
                "[", f"expression nested deeper than {MAX_NESTING} (allowed: up to {MAX_NESTING})"
            )
        n = len(code)
        if i >= n:
            raise _Err(
                code[max(0, i - 1) :],
                "letter without a number (allowed: e.g. X1.5, G1, X#1, X[1+2])",
            )
        ch = code[i]
        if ch in "+-":
            v, j = self._value(code, i + 1, depth + 1)
            if ch == "+":
                return v, j
            if type(v) is float:
                return -v, j
            f = v
            return (lambda: -f()), j  # type: ignore[operator]
        m = _NUM.match(code, i)
        if m is not None:
            return float(m.group()), m.end()
        if ch == "#":
            key, j = self._param_ref(code, i + 1, depth + 1)
            get = self._get_param
            if type(key) is str or type(key) is int:
                k = key
                return (lambda: get(k)), j
            kf = key
            return (lambda: get(kf())), j  # type: ignore[operator]
        if ch == "[":
            return self._expr(code, i + 1, depth + 1)
        if "A" <= ch <= "Z":
            for name in _FUNCS:
                if code.startswith(name, i):
                    return self._func(name, code, i + len(name), depth + 1)
        raise _Err(
            code[max(0, i - 1) : i + 8],
            "letter without a number (allowed: e.g. X1.5, G1, X#1, X[1+2])",
        )

    def _expr(self, code: str, i: int, depth: int) -> tuple[Value, int]:
        """An expression after its '['; returns after its ']'. The operators bind as
        LinuxCNC's (precedence climbing, left to right), the operands are evaluated left to
        right."""
        if depth > MAX_NESTING:
            raise _Err(
                "[", f"expression nested deeper than {MAX_NESTING} (allowed: up to {MAX_NESTING})"
            )
        vals: list[Value] = []
        ops: list[tuple[str, int]] = []
        v, i = self._value(code, i, depth)
        vals.append(v)
        n = len(code)
        while True:
            if i >= n:
                raise _Err("[", "unclosed expression (allowed: [ ... ] on one line)")
            if code[i] == "]":
                i += 1
                break
            for op, prec in _BINOPS:  # noqa: B007 - op/prec used after the loop
                if code.startswith(op, i):
                    break
            else:
                raise _Err(
                    code[i : i + 8],
                    "not an operator (allowed: ** * / MOD + - EQ NE GT GE LT LE AND OR XOR)",
                )
            i += len(op)
            while ops and ops[-1][1] >= prec:
                o, _ = ops.pop()
                b = vals.pop()
                vals.append(self._node(o, vals.pop(), b))
            ops.append((op, prec))
            v, i = self._value(code, i, depth)
            vals.append(v)
        while ops:
            o, _ = ops.pop()
            b = vals.pop()
            vals.append(self._node(o, vals.pop(), b))
        return vals[0], i

    def _node(self, op: str, a: Value, b: Value) -> Callable[[], float]:
        binop = self._binop
        if type(a) is float:
            if type(b) is float:
                return lambda: binop(op, a, b)  # type: ignore[arg-type]
            return lambda: binop(op, a, b())  # type: ignore[arg-type,operator]
        if type(b) is float:
            return lambda: binop(op, a(), b)  # type: ignore[arg-type,operator]
        return lambda: binop(op, a(), b())  # type: ignore[operator]

    def _func(self, name: str, code: str, i: int, depth: int) -> tuple[Value, int]:
        if i >= len(code) or code[i] != "[":
            raise _Err(name, f"{name} without [argument] (allowed: {name}[...])")
        if name == "EXISTS":
            j = i + 1
            if code.startswith("#<", j):
                k = code.find(">", j)
                if k < 0 or not code.startswith("]", k + 1):
                    raise _Err(name, "EXISTS needs [#<name>] or [#number]")
                nm = code[j + 2 : k].lower()
                exists = self._named_exists
                return (lambda: float(exists(nm))), k + 2
            if code.startswith("#", j):
                # LinuxCNC (interp_read.cc read_parameter, check_exists): EXISTS[#n] is 1 for a
                # parameter number in range, 0 outside it (the number itself may be #-valued)
                v, k = self._value(code, j + 1, depth + 1)
                if not code.startswith("]", k):
                    raise _Err(name, "EXISTS needs [#<name>] or [#number]")
                return (lambda: self._exists_number(_ev(v))), k + 1
            raise _Err(name, "EXISTS needs [#<name>] or [#number]")
        a, i = self._expr(code, i + 1, depth)
        if name == "ATAN":
            if not code.startswith("/[", i):
                raise _Err(name, "ATAN needs ATAN[y]/[x]")
            b, i = self._expr(code, i + 2, depth)
            return (lambda: math.degrees(math.atan2(_ev(a), _ev(b)))), i
        fn = self._apply
        return (lambda: fn(name, _ev(a))), i

    def _exists_number(self, v: float) -> float:
        if self._dry:
            return 0.0
        if v != int(v):
            raise _Err("EXISTS", f"EXISTS[#{_fmt(v)}]: the parameter number is not an integer")
        return float(1 <= v < _MAX_PARAM)

    def _apply(self, name: str, a: float) -> float:
        try:
            if name == "ABS":
                r = abs(a)
            elif name == "ACOS":
                r = math.degrees(math.acos(a))
            elif name == "ASIN":
                r = math.degrees(math.asin(a))
            elif name == "COS":
                r = math.cos(math.radians(a))
            elif name == "EXP":
                r = math.exp(a)
            elif name == "FIX":
                r = float(math.floor(a))
            elif name == "FUP":
                r = float(math.ceil(a))
            elif name == "LN":
                r = math.log(a)
            elif name == "ROUND":
                r = float(math.floor(a + 0.5)) if a >= 0 else -float(math.floor(-a + 0.5))
            elif name == "SIN":
                r = math.sin(math.radians(a))
            elif name == "SQRT":
                r = math.sqrt(a)
            else:  # TAN
                r = math.tan(math.radians(a))
        except (ValueError, OverflowError):
            if self._dry:
                return 0.0
            raise _Err(name, f"{name}[{_fmt(a)}] is not defined (allowed: its domain)") from None
        return r

    def _param_ref(self, code: str, i: int, depth: int) -> tuple[Any, int]:
        """The parameter after a '#': a name (lower case), a number, or a closure giving the
        number (computed, or out of range: checked when the line runs, never in the
        prescan, where parameters read as 0)."""
        if depth > MAX_NESTING:
            raise _Err("#", f"parameters nested deeper than {MAX_NESTING}")
        n = len(code)
        if i < n and code[i] == "<":
            j = code.find(">", i)
            if j < 0:
                raise _Err("#<", "unclosed parameter name (allowed: #<name>)")
            name = code[i + 1 : j].lower()
            if not name:
                raise _Err("#<>", "empty parameter name")
            return name, j + 1
        v, j = self._value(code, i, depth + 1)
        if type(v) is float and 1 <= v <= _MAX_PARAM and v == int(v):
            return int(v), j
        return (lambda: self._param_number(_ev(v))), j

    def _param_number(self, v: float) -> int:
        if self._dry:
            return 1
        if not 1 <= v <= _MAX_PARAM or v != int(v):
            raise _Err(
                f"#{_fmt(v)}", f"parameter number out of range (allowed: #1 to #{_MAX_PARAM})"
            )
        return int(v)

    def _binop(self, op: str, a: float, b: float) -> float:
        try:
            if op == "+":
                r = a + b
            elif op == "-":
                r = a - b
            elif op == "*":
                r = a * b
            elif op == "/":
                if b == 0.0:
                    if self._dry:
                        return 0.0
                    raise _Err("/", "division by zero (allowed: a non-zero divisor)")
                r = a / b
            elif op == "MOD":
                if b == 0.0:
                    if self._dry:
                        return 0.0
                    raise _Err("MOD", "MOD by zero (allowed: a non-zero divisor)")
                r = math.fmod(a, b)
                if r < 0.0:  # LinuxCNC: the result has the sign of the divisor's magnitude
                    r += abs(b)
            elif op == "**":
                if a < 0.0 and b != int(b):
                    if self._dry:
                        return 0.0
                    raise _Err("**", "negative base with a non-integer exponent")
                r = math.pow(a, b)
            elif op == "EQ":
                r = float(abs(a - b) < _EQUAL)
            elif op == "NE":
                r = float(abs(a - b) >= _EQUAL)
            elif op == "GT":
                r = float(a > b)
            elif op == "GE":
                r = float(a >= b)
            elif op == "LT":
                r = float(a < b)
            elif op == "LE":
                r = float(a <= b)
            elif op == "AND":
                r = float(a != 0.0 and b != 0.0)
            elif op == "OR":
                r = float(a != 0.0 or b != 0.0)
            else:  # XOR
                r = float((a != 0.0) != (b != 0.0))
        except (OverflowError, ValueError):
            if self._dry:
                return 0.0
            raise _Err(op, "the result is out of range") from None
        if not abs(r) < _MAX_VALUE * 1e3:
            if self._dry:
                return 0.0
            raise _Err(op, f"the result {r:g} is out of range (allowed: |value| < 1e18)")
        return r

    # -- parameters ------------------------------------------------------------------------
    def _named_exists(self, name: str) -> bool:
        if name.startswith("_"):
            return name in self.globals or self._predefined(name) is not None
        return name in self.frames[-1].local

    def _get_param(self, key: Any) -> float:
        if self._dry:
            return 0.0
        if isinstance(key, str):
            if key.startswith("_"):
                if key in self.globals:
                    return self.globals[key]
                v = self._predefined(key)
                if v is None:
                    raise _Err(
                        f"#<{key}>",
                        "named parameter not defined (allowed: set it first, #<_name>=...)",
                    )
                return v
            local = self.frames[-1].local
            if key not in local:
                raise _Err(
                    f"#<{key}>", "named parameter not defined (allowed: set it first, #<name>=...)"
                )
            return local[key]
        sysv = self._system_param(key)
        if sysv is not None:
            return sysv
        return self.params.get(key, 0.0)

    def _set_param(self, key: Any, value: float) -> None:
        if isinstance(key, str):
            if key.startswith("_"):
                if self._predefined(key) is not None and key not in self.globals:
                    raise _Err(f"#<{key}>", "read-only predefined parameter")
                self.globals[key] = value
            else:
                self.frames[-1].local[key] = value
            return
        if key in _READ_ONLY_PARAMS:
            raise _Err(f"#{key}", "read-only parameter (allowed: #1-#5399 except the system ones)")
        if self._set_system_param(key, value):
            return
        self.params[key] = value

    def _conv(self, letter_idx: int) -> float:
        return DEG if AXES[letter_idx] in ROTARY else self.unit

    def _system_param(self, key: int) -> float | None:
        if 5161 <= key <= 5169:
            return self.g28[key - 5161] / self._conv(key - 5161)
        if 5181 <= key <= 5189:
            return self.g30[key - 5181] / self._conv(key - 5181)
        if key == 5210:
            return 1.0 if any(self.g92) else 0.0
        if 5211 <= key <= 5219:
            return self.g92_saved[key - 5211] / self._conv(key - 5211)
        if key == 5220:
            return float(self.cs)
        if 5221 <= key <= 5400 - 11:
            sys_no, k = divmod(key - 5221, 20)
            if k < 9:
                return self.g5x[sys_no + 1][k] / self._conv(k)
            if k == 9:
                return 0.0  # rotation
            return None
        if key == 5400:
            return float(self.tool)
        if 5401 <= key <= 5409:
            return self.tlo[key - 5401] / self._conv(key - 5401)
        if key == 5410:
            t = self.tools.get(self.tool)
            return (t.diameter if t else 0.0) / self.unit
        if 5420 <= key <= 5428:
            k = key - 5420
            return self._prog(k) / self._conv(k)
        return None

    def _set_system_param(self, key: int, value: float) -> bool:
        if 5161 <= key <= 5169:
            self.g28[key - 5161] = value * self._conv(key - 5161)
            return True
        if 5181 <= key <= 5189:
            self.g30[key - 5181] = value * self._conv(key - 5181)
            return True
        if 5211 <= key <= 5219:
            self.g92_saved[key - 5211] = value * self._conv(key - 5211)
            return True
        if 5221 <= key <= 5389:
            sys_no, k = divmod(key - 5221, 20)
            if k < 9:
                self.g5x[sys_no + 1][k] = value * self._conv(k)
                return True
            if k == 9:
                if value != 0.0:
                    raise _Err(
                        f"#{key}", "coordinate system rotation is not supported (allowed: 0)"
                    )
                return True
        return False

    def _predefined(self, name: str) -> float | None:
        axes = {f"_{c.lower()}": i for i, c in enumerate(AXES)}
        if name in axes:
            k = axes[name]
            return self._prog(k) / self._conv(k)
        table = {
            "_metric": float(self.unit == MM),
            "_imperial": float(self.unit == INCH),
            "_absolute": float(not self.incremental),
            "_incremental": float(self.incremental),
            "_coord_system": float(_SYSTEM_NAME[self.cs]),
            "_current_tool": float(self.tool),
            "_selected_tool": float(self.selected),
            "_feed": self.feed_value,
            "_rpm": self.rpm,
            "_spindle_on": float(self.spindle_dir != 0),
            "_mist": float(self.mist),
            "_flood": float(self.flood),
            "_plane": float({"XY": 170, "ZX": 180, "YZ": 190}[self.plane]),
            "_motion_mode": float(self.motion if self.motion is not None else 800),
            "_line": float(self._line_no),
            "_ijk_absolute_mode": float(self.ijk_absolute),
            "_inverse_time": float(self.feed_mode == 93),
            "_units_per_minute": float(self.feed_mode == 94),
            "_units_per_rev": float(self.feed_mode == 95),
            "_retract_r_plane": float(self.retract_r),
            "_retract_old_z": float(not self.retract_r),
            "_value": self.globals.get("_value", 0.0),
            "_value_returned": self.globals.get("_value_returned", 0.0),
            "_task": 1.0,
        }
        return table.get(name)

    # -- coordinates -----------------------------------------------------------------------
    def _offset(self, k: int) -> float:
        return self.g5x[self.cs][k] + self.g92[k] + self.tlo[k]

    def _prog(self, k: int) -> float:
        """Current position of axis ``k`` in program coordinates [SI]."""
        return self.pos[k] - self._offset(k)

    # -- execution -------------------------------------------------------------------------
    def _execute(self) -> Iterator[GcodeMove | GcodeEvent]:
        src = self.src
        assert self.max_blocks is not None
        pct = 0
        while not self.ended:
            self._line_start = src.pos
            item = src.readline()
            if item is None:
                break
            no, raw = item
            self._line_no = no
            if raw.lstrip().startswith("%"):
                pct += 1
                if pct >= 2:
                    break
                continue
            self.blocks += 1
            if self.blocks > self.max_blocks:
                self.collect = False
                self._record(
                    self._located(
                        no,
                        "program",
                        f"more than {self.max_blocks} blocks executed "
                        "(a loop that does not end?; allowed: gcode.max_blocks in the "
                        "machine configuration)",
                    )
                )
            try:
                blk = self._parse(no, raw)
                if blk is not None:
                    self._text = blk.text = blk.text.strip()
                    self._run_block(blk)
            except _Err as exc:
                self._out = []
                self._record(self._located(no, exc.word, exc.message))
                continue
            if self._out:
                out, self._out = self._out, []
                yield from out
        if not self.ended:
            line = self.src.line_no
            if len(self.frames) > 1:
                fr = self.frames[-1]
                self._record(
                    self._located(
                        fr.call_line,
                        f"O{fr.label}",
                        "the file ends inside this subroutine call (allowed: endsub / return)",
                    )
                )
            for c in self.controls:
                self._record(
                    self._located(
                        line,
                        f"O{c.label}",
                        f"the file ends inside {c.kind.lower()} (allowed: its end)",
                    )
                )
            if pct == 1:
                self._record(
                    self._located(
                        line,
                        "%",
                        "the file ends without its closing % (allowed: % ... % or M2/M30)",
                    )
                )
            self._note("eof", "the program ends at the end of the file (no M2/M30)", line)
            yield GcodeEvent(line, "end", text="end of file")
        self._final_errors()

    # -- O-words ---------------------------------------------------------------------------
    def _find(self, label: Any, kinds: Sequence[str], after: int) -> tuple[str, int, int]:
        entries = self._o_index.get(label, ()) if self._o_index is not None else ()
        for kw, off, line in entries:
            if off > after and kw in kinds:
                return kw, off, line
        raise _Err(
            f"O{label}",
            f"no matching {'/'.join(k.lower() for k in kinds)} for O{label} "
            "(allowed: structures closed with the same O-word)",
        )

    def _here(self) -> int:
        """The offset of the start of the current line (just read)."""
        return self._line_start

    def _goto(self, entry: tuple[str, int, int], past: bool) -> None:
        _, off, line = entry
        self.src.seek((off, line))
        if past:
            self.src.readline()

    def _o_word(self, b: _Block) -> None:
        kw, label = b.o_keyword, b.o_label
        here = self._here()
        args = b.o_args
        top = self.controls[-1] if self.controls else None
        if kw == "SUB":
            self._goto(self._find(label, ("ENDSUB",), here), past=True)
        elif kw == "CALL":
            if len(self.frames) > MAX_CALL_DEPTH:
                raise _Err(
                    f"O{label}",
                    f"subroutine calls nested deeper than {MAX_CALL_DEPTH} "
                    f"(allowed: up to {MAX_CALL_DEPTH})",
                )
            entries = self._o_index.get(label, []) if self._o_index is not None else []
            sub = next((e for e in entries if e[0] == "SUB"), None)
            if sub is None:
                raise _Err(
                    f"O{label}",
                    "call of an undefined subroutine (allowed: o<name> sub "
                    "... o<name> endsub in this file)",
                )
            saved = {k: self.params.get(k, 0.0) for k in range(1, 31)}
            for k in range(1, 31):
                self.params[k] = args[k - 1] if k <= len(args) else 0.0
            self.frames.append(
                _Frame(self.src.tell(), label, saved, {}, len(self.controls), b.line)
            )
            self._goto(sub, past=True)
        elif kw in ("ENDSUB", "RETURN"):
            if len(self.frames) == 1:
                raise _Err(
                    f"O{label}", f"{kw.lower()} outside a subroutine call (allowed: in o... sub)"
                )
            fr = self.frames.pop()
            if args:
                self.globals["_value"] = args[0]
                self.globals["_value_returned"] = 1.0
            else:
                self.globals["_value_returned"] = 0.0
            self.params.update(fr.saved)
            del self.controls[fr.control_depth :]
            assert fr.ret is not None
            self.src.seek(fr.ret)
        elif kw == "IF":
            self._control_push(_Control("IF", label, (here, self.src.line_no)))
            if self._cond(b):
                self.controls[-1].taken = True
            else:
                self._goto(self._find(label, ("ELSEIF", "ELSE", "ENDIF"), here), past=False)
        elif kw == "ELSEIF":
            self._expect(top, "IF", label, kw)
            assert top is not None
            if top.taken:
                self._goto(self._find(label, ("ENDIF",), here), past=False)
            elif self._cond(b):
                top.taken = True
            else:
                self._goto(self._find(label, ("ELSEIF", "ELSE", "ENDIF"), here), past=False)
        elif kw == "ELSE":
            self._expect(top, "IF", label, kw)
            assert top is not None
            if top.taken:
                self._goto(self._find(label, ("ENDIF",), here), past=False)
            else:
                top.taken = True
        elif kw == "ENDIF":
            self._expect(top, "IF", label, kw)
            self.controls.pop()
        elif kw == "DO":
            self._control_push(_Control("DO", label, self.src.tell()))
        elif kw == "WHILE":
            if top is not None and top.kind == "DO" and top.label == label:
                if self._cond(b):
                    self._check_loop_ends(b, here, top.start[0], here)
                    if self.ended:
                        return
                    self.src.seek(top.start)
                else:
                    self.controls.pop()
            else:
                first = not (top is not None and top.kind == "WHILE" and top.label == label)
                if first:
                    self._control_push(_Control("WHILE", label, (here, self.src.line_no - 1)))
                if not self._cond(b):
                    self.controls.pop()
                    self._goto(self._find(label, ("ENDWHILE",), here), past=True)
                elif first:
                    _, end, _ = self._find(label, ("ENDWHILE",), here)
                    self._check_loop_ends(b, here, self.src.tell()[0], end)
                    if self.ended:
                        return
        elif kw == "ENDWHILE":
            self._expect(top, "WHILE", label, kw)
            assert top is not None
            self.src.seek(top.start)
        elif kw == "REPEAT":
            count = int(self._cond(b, need=True))
            if count <= 0:
                self._goto(self._find(label, ("ENDREPEAT",), here), past=True)
            else:
                assert self.max_blocks is not None
                left = self.max_blocks - self.blocks
                if count > left:  # every pass runs at least one block (its end or continue)
                    _, end, _ = self._find(label, ("ENDREPEAT",), here)
                    if self._loop_body(self.src.tell()[0], end) is not None:
                        self._fatal(
                            b,
                            f"repeat of {count} passes: more than the {left} blocks left to "
                            f"run (allowed: gcode.max_blocks = {self.max_blocks} blocks in "
                            "the machine configuration)",
                        )
                        return
                self._control_push(_Control("REPEAT", label, self.src.tell(), count))
        elif kw == "ENDREPEAT":
            self._expect(top, "REPEAT", label, kw)
            assert top is not None
            top.count -= 1
            if top.count > 0:
                self.src.seek(top.start)
            else:
                self.controls.pop()
        elif kw in ("BREAK", "CONTINUE"):
            frame_base = self.frames[-1].control_depth
            loop = None
            for k in range(len(self.controls) - 1, frame_base - 1, -1):
                c = self.controls[k]
                if c.label == label and c.kind in ("WHILE", "DO", "REPEAT"):
                    loop = k
                    break
            if loop is None:
                raise _Err(
                    f"O{label}",
                    f"{kw.lower()} outside a loop O{label} (allowed: in while / do / repeat)",
                )
            c = self.controls[loop]
            del self.controls[loop + 1 :]
            if kw == "BREAK":
                self.controls.pop()
                end = {"WHILE": ("ENDWHILE",), "DO": ("WHILE",), "REPEAT": ("ENDREPEAT",)}
                self._goto(self._find(label, end[c.kind], here), past=True)
            elif c.kind == "WHILE":
                self.src.seek(c.start)
            elif c.kind == "DO":
                self._goto(self._find(label, ("WHILE",), here), past=False)
            else:
                c.count -= 1
                if c.count > 0:
                    self.src.seek(c.start)
                else:
                    self.controls.pop()
                    self._goto(self._find(label, ("ENDREPEAT",), here), past=True)

    def _fatal(self, b: _Block, message: str) -> None:
        """An error at the O-word ``b`` after which the program cannot go on: the run ends
        here (with the errors found so far)."""
        self._record(self._located(b.line, f"O{b.o_label}", message))
        self.ended = True

    def _loop_body(self, start: int, end: int) -> set[Any] | None:
        """The parameters that the lines from byte ``start`` to ``end`` can set, or None when
        they can leave the loop or the program another way (break, return, call, M2/M30, %) or
        set a parameter whose number is computed. Reads the file there and comes back."""
        src = self.src
        back = src.tell()
        writes: set[Any] = set()
        try:
            src.seek((start, 0))
            while src.pos < end:
                item = src.readline()
                if item is None:
                    break
                raw = item[1]
                if raw.lstrip().startswith("%") or raw.startswith("\x00"):
                    return None
                code, _ = _split_comments(raw)
                if code.startswith(("O", "N")) and any(
                    k in code for k in ("CALL", "RETURN", "BREAK", "SUB")
                ):
                    return None
                if "M[" in code or "M#" in code:
                    return None
                if any(float(m) in (2.0, 30.0) for m in _M_WORD.findall(code)):
                    return None
                targets = _ASSIGNED.findall(code)
                if len(targets) != code.count("="):
                    return None  # #[...]= or ##1=: a computed parameter number
                writes.update(_param_key(t) for t in targets)
        except _Err:
            return None
        finally:
            src.seek(back)
        return writes

    def _check_loop_ends(self, b: _Block, line_start: int, start: int, end: int) -> None:
        """A while loop whose condition is true and reads nothing its body (``start`` to
        ``end``) can change never ends: a located error at the loop's line now, not after
        gcode.max_blocks blocks. Only where that is certain (the condition reads plain
        parameters, the body has no way out but the condition)."""
        if line_start in self._loops_checked:
            return
        self._loops_checked.add(line_start)
        code, _ = _split_comments(b.text)
        if "##" in code or "#[" in code:
            return
        reads = {_param_key(t) for t in _READ.findall(code)}
        for key in reads:
            if isinstance(key, str):
                if key.startswith("_") and self._predefined(key) is not None:
                    return  # the machine's state (a position, a mode)
            elif key >= 5000:
                return  # a system parameter (offsets, tool, positions)
        writes = self._loop_body(start, end)
        if writes is None or reads & writes:
            return
        names = ", ".join(sorted(f"#<{k}>" if isinstance(k, str) else f"#{k}" for k in reads))
        self._fatal(
            b,
            "this loop never ends: its condition is true and reads "
            + (f"{names}, which nothing in the loop sets" if names else "no parameter")
            + " (allowed: a condition on a parameter the loop changes, a break, M2/M30)",
        )

    def _control_push(self, c: _Control) -> None:
        if len(self.controls) >= MAX_CONTROL_DEPTH:
            raise _Err(
                f"O{c.label}",
                f"control structures nested deeper than "
                f"{MAX_CONTROL_DEPTH} (allowed: up to {MAX_CONTROL_DEPTH})",
            )
        self.controls.append(c)

    def _expect(self, top: _Control | None, kind: str, label: Any, kw: str) -> None:
        if (
            top is None
            or top.kind != kind
            or top.label != label
            or len(self.controls) <= (self.frames[-1].control_depth)
        ):
            raise _Err(
                f"O{label}",
                f"{kw.lower()} without its {kind.lower()} (allowed: "
                f"o{label} {kind.lower()} ... o{label} {kw.lower()})",
            )

    def _cond(self, b: _Block, need: bool = True) -> float:
        if not b.o_args:
            raise _Err(f"O{b.o_label}", f"{b.o_keyword.lower()} needs a [condition]")
        return b.o_args[0]

    # -- one block -------------------------------------------------------------------------
    def _check_block(self, b: _Block) -> tuple[dict[int, int], dict[int, int]]:
        """Codes known, one per modal group, letters of the machine; (G groups, M groups)."""
        groups: dict[int, int] = {}
        for t in b.gs:
            label = _g_label(t)
            if t not in _G_GROUP:
                if label in _REFUSED_G:
                    raise _Err(
                        label,
                        f"{label} ({_REFUSED_G[label]}) is not supported (allowed: "
                        "the codes of the G-code reference)",
                    )
                raise _Err(label, "unknown G code (allowed: the codes of the G-code reference)")
            g = _G_GROUP[t]
            if g == 1 and g in groups and 800 in (t, groups[g]):
                # LinuxCNC (interp_read.cc read_g): G80 beside another motion code on one
                # line is dropped, the other code is the line's motion ("G80 G0" is a G0)
                if t != 800:
                    groups[g] = t
                continue
            if g in groups:
                raise _Err(
                    label,
                    f"{_g_label(groups[g])} and {label} on one line are of the same "
                    "modal group (allowed: one per group)",
                )
            groups[g] = t
        mgroups: dict[int, int] = {}
        if len(b.ms) > 4:
            raise _Err(f"M{b.ms[4]}", "more than 4 M codes on one line (allowed: 4)")
        for m in b.ms:
            label = f"M{m}"
            if m not in _M_GROUP:
                if label in _REFUSED_M:
                    raise _Err(
                        label,
                        f"{label} ({_REFUSED_M[label]}) is not supported (allowed: "
                        "the codes of the G-code reference)",
                    )
                if 100 <= m <= 199:
                    raise _Err(
                        label,
                        "user M codes M100-M199 are not supported (allowed: the "
                        "codes of the G-code reference)",
                    )
                raise _Err(label, "unknown M code (allowed: the codes of the G-code reference)")
            g = _M_GROUP[m]
            if g in mgroups:
                raise _Err(
                    label,
                    f"M{mgroups[g]} and {label} on one line are of the same modal "
                    "group (allowed: one per group)",
                )
            mgroups[g] = m
        for letter in b.words:
            if letter in AXES:
                if letter not in self.setup.axes:
                    have = ", ".join(
                        f"{c}={self.setup.names[i]}" for c, i in self.setup.axes.items()
                    )
                    raise _Err(
                        b.word_text[letter],
                        f"the machine has no {letter} axis (allowed: its axes {have})",
                    )
            elif letter in "@^":
                if "X" not in self.setup.axes or "Y" not in self.setup.axes:
                    raise _Err(b.word_text[letter], "polar coordinates need X and Y axes")
                for c in "XY":
                    if c in b.words:
                        raise _Err(
                            b.word_text[letter],
                            f"{letter} (polar coordinates) with a {c} word (allowed: @ ^ in "
                            "place of X Y)",
                        )
            elif letter not in "FSTHDIJKRPQL":
                if letter == "E":
                    _exponent_error(b)
                raise _Err(
                    b.word_text[letter], "unknown word (allowed: the words of the G-code reference)"
                )
        if "D" in b.words:
            raise _Err(
                b.word_text["D"],
                "D word without G41/G42 (cutter compensation is not supported; allowed: G40)",
            )
        return groups, mgroups

    def _run_block(self, b: _Block) -> None:
        if b.o_keyword:
            self._o_word(b)
            return
        for c in b.comments:
            self._comment(c, b.line)
        if not (b.words or b.gs or b.ms or b.assigns):
            return
        g, m = self._check_block(b)
        for key, val in b.assigns:
            self._set_param(key, val)
        w = b.words
        used: set[str] = set()
        motion_code = g.get(1)
        g0 = g.get(0)
        # feed mode, F, S, T
        if 5 in g:
            self.feed_mode = g[5] // 10
        if "F" in w:
            if w["F"] < 0.0:
                raise _Err(b.word_text["F"], "negative feed rate (allowed: F >= 0)")
            self.feed_value = w["F"]
            used.add("F")
        if "S" in w:
            if w["S"] < 0.0:
                raise _Err(b.word_text["S"], "negative spindle speed (allowed: S >= 0)")
            changed = w["S"] != self.rpm
            self.rpm = w["S"]
            used.add("S")
            if not self.setup.spindle:
                self._note(
                    "S",
                    f"{b.word_text['S']}: the machine has no spindle (S noted, ignored)",
                    b.line,
                )
            if changed and self.spindle_dir and 7 not in m:
                self._event("spindle", self.spindle_dir * self.rpm)
        if "T" in w:
            t = w["T"]
            if t != int(t) or t < 0:
                raise _Err(b.word_text["T"], "tool number must be an integer >= 0")
            self.selected = int(t)
            used.add("T")
        if 6 in m:
            self.tool = self.selected
            self._event("tool_change", index=self.tool)
            if self.tool and self.tool not in self.tools:
                self._note(
                    f"T{self.tool}",
                    f"M6: tool {self.tool} is not in the tool table (its offsets are 0)",
                    b.line,
                )
        if 7 in m:
            code = m[7]
            self.spindle_dir = {3: 1, 4: -1, 5: 0}[code]
            if not self.setup.spindle:
                self._note(
                    f"M{code}", f"M{code}: the machine has no spindle (noted, ignored)", b.line
                )
            self._event("spindle", self.spindle_dir * self.rpm)
        if 8 in m:
            code = m[8]
            for name, on in (("mist", code == 7), ("flood", code == 8)):
                if code == 9 or on:
                    if name not in self.setup.coolant:
                        self._note(
                            f"cool{name}",
                            f"M{code}: the machine has no {name} coolant output (noted, ignored)",
                            b.line,
                        )
                    setattr(self, name, on)
                    self._event("coolant", 1.0 if on else 0.0, name=name)
        if 9 in m:
            self._note(
                f"M{m[9]}", f"M{m[9]}: the machine has no override inputs (noted, ignored)", b.line
            )
        if 5 in m:
            code = m[5]
            p = self._need(b, "P", f"M{code}", "the output number P")
            used.add("P")
            if p != int(p) or p < 0:
                raise _Err(b.word_text["P"], "output number must be an integer >= 0")
            idx = int(p)
            if idx >= len(self.setup.outputs):
                self._note(
                    f"out{idx}",
                    f"M{code} P{idx}: the machine has no digital output "
                    f"{idx} (it has {len(self.setup.outputs)}; noted, ignored)",
                    b.line,
                )
            on = code in (62, 64)
            if code in (62, 63):
                self._pending_outputs.append((idx, on))
            else:
                name = self.setup.outputs[idx] if idx < len(self.setup.outputs) else ""
                self._event("output", 1.0 if on else 0.0, name=name, index=idx, sync=False)
        if g0 == 40:  # dwell
            p = self._need(b, "P", "G4", "the dwell time P [s]")
            used.add("P")
            if p < 0.0:
                raise _Err(b.word_text["P"], "negative dwell time (allowed: P >= 0 seconds)")
            self._event("dwell", p)
        if 2 in g:
            plane = _PLANE_OF[g[2]]
            self.plane = plane
        if 6 in g:
            new = INCH if g[6] == 200 else MM
            if new != self.unit:
                self.feed_value *= self.unit / new
                self.unit = new
        # G40: nothing to cancel (G41/G42 are refused)
        if 8 in g:
            self._tool_length(b, g[8], used)
        if 12 in g:
            self.cs = _SYSTEM_OF[g[12]]
        if 13 in g:
            self._path_control(b, g[13], used)
        if 3 in g:
            self.incremental = g[3] == 910
        if 4 in g:
            self.ijk_absolute = g[4] == 901
        if 10 in g:
            self.retract_r = g[10] == 990
        axis_words = [c for c in AXES if c in w] + [c for c in "@^" if c in w]
        if ("@" in w or "^" in w) and (self.plane != "XY" or g0 in (100, 280, 300, 530, 920)):
            c = "@" if "@" in w else "^"
            raise _Err(
                b.word_text[c],
                f"{c} (polar coordinates) "
                + ("outside the G17 plane" if self.plane != "XY" else f"with {_g_label(g0)}")
                + " (allowed: in G17, with G0, G1 or a canned cycle)",
            )
        if g0 in (100, 280, 281, 300, 301, 920, 921, 922, 923):
            if (
                motion_code is not None
                and motion_code != 800
                and axis_words
                and g0 in (100, 280, 300, 920)
            ):
                raise _Err(
                    _g_label(g0),
                    f"{_g_label(g0)} and {_g_label(motion_code)} both use "
                    "the axis words (allowed: one of them on the line)",
                )
            self._non_modal(b, g0, used)
            axis_words = [] if g0 in (100, 280, 300, 920) else axis_words
        if motion_code is not None:
            if motion_code == 800:
                if axis_words:
                    raise _Err(
                        b.word_text[axis_words[0]],
                        "axis word with G80 (allowed: G80 alone; axis words need a motion mode)",
                    )
                self.motion = None
                self.cycle_il = None
            else:
                if motion_code not in _CYCLES:
                    self.cycle_il = None
                elif self.motion != motion_code:
                    self.cycle_il = None
        if axis_words or (motion_code in (20, 30) and any(c in w for c in "IJKR")):
            code = motion_code if motion_code not in (None, 800) else self.motion
            if code is None:
                raise _Err(
                    b.word_text[axis_words[0]] if axis_words else "G2",
                    "axis word without a motion mode (allowed: after G0, G1, G2, G3 or a "
                    "canned cycle)",
                )
            rot = [c for c in axis_words if c in "ABC"]
            if code in _CYCLES and rot and g0 not in (100, 280, 300, 920):
                # LinuxCNC (interp_check.cc check_other_codes): "Cannot put an A in canned cycle"
                raise _Err(
                    b.word_text[rot[0]],
                    f"{rot[0]} word in canned cycle {_g_label(code)} (allowed: the cycle's X Y Z "
                    "R words; move the rotary axis before the cycle, or after G80)",
                )
            if g0 == 530 and code not in (0, 10):
                raise _Err("G53", "G53 needs G0 or G1 (allowed: G53 G0 / G53 G1)")
            if g0 == 530 and self.incremental:
                raise _Err("G53", "G53 in incremental mode G91 (allowed: G53 in G90)")
            self._motion(b, code, used, g0 == 530, first=self.motion != code)
            self.motion = code
        elif motion_code is not None and motion_code != 800:
            if g0 == 530:
                raise _Err("G53", "G53 without axis words")
            self.motion = motion_code
        elif g0 == 530:
            raise _Err("G53", "G53 without axis words (allowed: G53 G0 X..)")
        for letter in "IJKRPQLH":
            if letter in w and letter not in used:
                raise _Err(
                    b.word_text[letter],
                    f"{letter} word with nothing on the line that uses "
                    "it (allowed: see the G-code reference)",
                )
        if 4 in m:
            code = m[4]
            if code == 1 and not self.setup.optional_stop:
                self._note("M1", "M1: the optional-stop switch is off (M1 ignored)", b.line)
            elif code in (0, 1, 60):
                self._event("pause", float(code))
            else:
                self._event("end", float(code), text=f"M{code}")
                self.ended = True

    def _need(self, b: _Block, letter: str, code: str, what: str) -> float:
        if letter not in b.words:
            raise _Err(code, f"{code} needs {what} (allowed: {code} {letter}...)")
        return b.words[letter]

    def _event(self, kind: str, value: float = 0.0, **kw: Any) -> None:
        self._out.append(GcodeEvent(self._line_no, kind, float(value), **kw))

    def _comment(self, c: str, line: int) -> None:
        s = c.strip()
        head = s[:6].upper()
        if head.startswith("MSG,"):
            self._event("message", text=escape(s[4:].strip(), 400))
        elif head.startswith("DEBUG,") or head.startswith("PRINT,"):
            body = s[6:].strip()
            if not self._dry:
                body = re.sub(r"#<([^>]*)>|#(\d+)", self._subst, body)
            self._event("message", text=escape(body, 400))

    def _subst(self, mm: re.Match[str]) -> str:
        try:
            key: Any = mm.group(1).lower() if mm.group(1) is not None else int(mm.group(2))
            return f"{self._get_param(key):.6g}"
        except _Err:
            return "######"

    def _tool_length(self, b: _Block, code: int, used: set[str]) -> None:
        w = b.words
        if code == 490:
            self.tlo = [0.0] * 9
            return
        if code == 431:
            self.tlo = [0.0] * 9
            for k, c in enumerate(AXES):
                if c in w:
                    self.tlo[k] = w[c] * self._conv(k)
                    used.add(c)
            b.words = {k: v for k, v in w.items() if k not in AXES}
            return
        h = w.get("H", float(self.tool) if code == 430 else None)
        if h is None:
            raise _Err("G43.2", "G43.2 needs H (allowed: G43.2 H<tool>)")
        used.add("H")
        if h != int(h) or h < 0:
            raise _Err(b.word_text.get("H", "H"), "H must be an integer >= 0")
        hn = int(h)
        offs = [0.0] * 9
        if hn:
            tool = self.tools.get(hn)
            if tool is None:
                raise _Err(
                    b.word_text.get("H", f"H{hn}"),
                    f"tool {hn} is not in the tool table "
                    f"(allowed: {sorted(self.tools)[:20] or 'no tools: gcode.tool_table'})",
                )
            for c, v in tool.offsets.items():
                offs[AXES.index(c)] = v
        if code == 430:
            self.tlo = offs
        else:
            self.tlo = [a + o for a, o in zip(self.tlo, offs, strict=True)]

    def _path_control(self, b: _Block, code: int, used: set[str]) -> None:
        w = b.words
        if code == 610:
            self.path_mode = "exact_path"
        elif code == 611:
            self.path_mode = "exact_stop"
        else:
            self.path_mode = "blend"
            self.p_tol = None
            self.q_tol = None
            if "P" in w:
                used.add("P")
                if w["P"] < 0.0:
                    raise _Err(
                        b.word_text["P"],
                        "negative G64 tolerance (allowed: P >= 0; P0 or none: as fast as possible)",
                    )
                self.p_tol = w["P"] * self.unit if w["P"] > 0.0 else None
            if "Q" in w:
                used.add("Q")
                if w["Q"] < 0.0:
                    raise _Err(b.word_text["Q"], "negative G64 Q tolerance (allowed: Q >= 0)")
                self.q_tol = w["Q"] * self.unit if w["Q"] > 0.0 else None

    def _non_modal(self, b: _Block, code: int, used: set[str]) -> None:
        w = b.words
        axis = [(k, c) for k, c in enumerate(AXES) if c in w]
        if code == 100:
            self._g10(b, axis, used)
        elif code in (280, 300):
            store = self.g28 if code == 280 else self.g30
            if axis:  # through the intermediate point, then only those axes
                inter = list(self.pos)
                for k, c in axis:
                    inter[k] = self._machine(k, w[c], False)
                self._line("rapid", inter, b, _g_label(code))
                home = list(self.pos)
                for k, _ in axis:
                    home[k] = store[k]
            else:
                home = list(self.pos)
                for k in self._member_idx:
                    home[k] = store[k]
            self._line("rapid", home, b, _g_label(code))
        elif code in (281, 301):
            store = self.g28 if code == 281 else self.g30
            store[:] = self.pos
        elif code == 920:
            if not axis:
                raise _Err("G92", "G92 needs axis words (allowed: G92 X0 Y0 ...)")
            for k, c in axis:
                v = w[c] * self._conv(k)
                self.g92[k] = self.pos[k] - self.g5x[self.cs][k] - self.tlo[k] - v
            self.g92_saved = list(self.g92)
        elif code == 921:
            self.g92 = [0.0] * 9
            self.g92_saved = [0.0] * 9
        elif code == 922:
            self.g92 = [0.0] * 9
        elif code == 923:
            self.g92 = list(self.g92_saved)

    def _g10(self, b: _Block, axis: list[tuple[int, str]], used: set[str]) -> None:
        w = b.words
        form = self._need(b, "L", "G10", "the form L (L1, L2, L10, L11, L20)")
        pv = self._need(b, "P", "G10", "P (the coordinate system or the tool)")
        used.update("LP")
        if pv != int(pv) or pv < 0:
            raise _Err(b.word_text["P"], "G10 P must be an integer >= 0")
        p = int(pv)
        if form in (2, 20):
            if p > 9:
                raise _Err(
                    b.word_text["P"],
                    "coordinate system out of range (allowed: P0 current, P1-P9 G54-G59.3)",
                )
            sys_no = self.cs if p == 0 else p
            if "R" in w:
                used.add("R")
                if w["R"] != 0.0:
                    raise _Err(
                        b.word_text["R"],
                        "coordinate system rotation is not supported (allowed: R0)",
                    )
            for k, c in axis:
                v = w[c] * self._conv(k)
                if form == 2:
                    self.g5x[sys_no][k] = (self.g5x[sys_no][k] + v) if self.incremental else v
                else:
                    self.g5x[sys_no][k] = self.pos[k] - self.g92[k] - self.tlo[k] - v
        elif form in (1, 10, 11):
            if p < 1:
                raise _Err(
                    b.word_text["P"], "G10 L1/L10/L11 P is the tool number (allowed: P1 and up)"
                )
            old = self.tools.get(p, Tool(p))
            offs = dict(old.offsets)
            dia = old.diameter
            if "R" in w:
                used.add("R")
                dia = 2.0 * w["R"] * self.unit
            for k, c in axis:
                v = w[c] * self._conv(k)
                if form == 1:
                    offs[c] = v
                else:
                    base = self.g5x[9 if form == 11 else self.cs][k] + self.g92[k]
                    offs[c] = self.pos[k] - base - v
            self.tools[p] = Tool(p, offs, dia, old.comment)
            if p == self.tool and any(self.tlo):  # LinuxCNC re-applies a loaded tool's offset
                for c, v in offs.items():
                    self.tlo[AXES.index(c)] = v
        else:
            raise _Err(b.word_text["L"], "unsupported G10 form (allowed: L1, L2, L10, L11, L20)")
        for _, c in axis:
            used.add(c)

    def _machine(self, k: int, value: float, g53: bool) -> float:
        v = value * self._conv(k)
        if g53:
            return v
        if self.incremental:
            return self.pos[k] + v
        return v + self._offset(k)

    # -- motion ----------------------------------------------------------------------------
    def _motion(self, b: _Block, code: int, used: set[str], g53: bool, first: bool) -> None:
        w = b.words
        if code in _CYCLES:
            self._cycle(b, code, used, first)
            return
        target = list(self.pos)
        for k, c in enumerate(AXES):
            if c in w:
                target[k] = self._machine(k, w[c], g53)
        if "@" in w or "^" in w:
            if code not in (0, 10):
                c = "@" if "@" in w else "^"
                raise _Err(
                    b.word_text[c],
                    f"{c} (polar coordinates) with an arc is not supported (allowed: with G0, "
                    "G1 or a canned cycle)",
                )
            kx, ky = self.setup.axes["X"], self.setup.axes["Y"]
            px, py = self._polar(b, self._prog(kx) / self.unit, self._prog(ky) / self.unit)
            target[kx] = px * self.unit + self._offset(kx)
            target[ky] = py * self.unit + self._offset(ky)
        if code == 0:
            self._line("rapid", target, b, "G0")
        elif code == 10:
            self._line("linear", target, b, "G1")
        else:
            self._arc(b, code, target, used)

    def _polar(self, b: _Block, x: float, y: float) -> tuple[float, float]:
        """The X Y end [program units] of a line with polar words from the program position
        ``x, y``, as LinuxCNC's find_ends: G90 @ radius ^ angle from the origin (the missing
        one kept from the current position); G91 @ added to the radius, ^ to the angle."""
        w = b.words
        word = b.word_text["@" if "@" in w else "^"]
        at_origin = x == 0.0 and y == 0.0
        if not self.incremental:
            if "@" in w and "^" in w:
                r, th = w["@"], math.radians(w["^"])
            elif "@" in w:
                if at_origin:
                    raise _Err(word, "@ without ^ at the origin (allowed: an angle ^ there)")
                r, th = w["@"], math.atan2(y, x)
            else:
                r, th = math.hypot(x, y), math.radians(w["^"])
            return r * math.cos(th), r * math.sin(th)
        if at_origin:
            raise _Err(word, "G91 polar motion at the origin is indeterminate (allowed: G90 there)")
        r = math.hypot(x, y) + w.get("@", 0.0)
        th = math.atan2(y, x) + math.radians(w.get("^", 0.0))
        return r * math.cos(th), r * math.sin(th)

    def _feed(self, b: _Block, word: str) -> tuple[float, float | None]:
        """(linear speed [m/s] or 0 for G93, the G93 duration [s] or None)."""
        if self.feed_mode == 93:
            if "F" not in b.words or self.feed_value <= 0.0:
                raise _Err(
                    word,
                    "inverse time feed G93 needs F > 0 on every feed move "
                    "(allowed: F = 1/minutes of the move)",
                )
            return 0.0, 60.0 / self.feed_value
        if self.feed_value <= 0.0:
            raise _Err(
                word, "F word missing or zero (allowed: a feed rate F > 0 before or on this line)"
            )
        if self.feed_mode == 95:
            if self.spindle_dir == 0 or self.rpm <= 0.0:
                raise _Err(
                    word,
                    "G95 feed per revolution with the spindle stopped (allowed: M3/M4 "
                    "with S > 0 first)",
                )
            return self.feed_value * self.unit * self.rpm / 60.0, None
        return self.feed_value * self.unit / 60.0, None

    def _timing(
        self, b: _Block, word: str, d_xyz: float, d_uvw: float, d_abc: float, length: float
    ) -> tuple[float | None, float | None, float | None]:
        """(feed [m/s or rad/s], group path velocity, duration) of a feed move."""
        speed, dur = self._feed(b, word)
        if dur is None:
            if d_xyz > 0.0:
                feed_len = d_xyz
            elif d_uvw > 0.0:
                feed_len = d_uvw
            else:
                feed_len = d_abc
                speed = speed / self.unit * DEG if self.feed_mode == 94 else speed / self.unit * DEG
            dur = feed_len / speed
            feed = speed
        else:
            feed = None
        if not dur > 0.0:
            return feed, None, None
        return feed, length / dur, dur

    def _out_point(self, p: Sequence[float]) -> tuple[float, ...]:
        return tuple(p[k] for k in self._member_idx)

    def _mode_fields(self) -> dict[str, Any]:
        pm = self.path_mode
        return {
            "exact_stop": pm == "exact_stop",
            "exact_path": pm == "exact_path",
            "tolerance": self.p_tol if pm == "blend" else None,
            "naive_tolerance": self.q_tol if pm == "blend" else None,
        }

    def _line(self, kind: str, target: list[float], b: _Block, word: str) -> None:
        pos = self.pos
        idx = self._member_idx
        start = tuple([pos[k] for k in idx])
        end = tuple([target[k] for k in idx])
        gap = 0.0
        scale = 1.0
        for a, c in zip(start, end, strict=True):
            d = abs(c - a)
            if d > gap:
                gap = d
            m = abs(a) if abs(a) > abs(c) else abs(c)
            if m > scale:
                scale = m
        if gap <= _SAME_POINT_RTOL * scale:
            self.pos = target
            self.n_skipped += 1
            if len(self.skipped) < MAX_ERRORS:
                self.skipped.append(
                    f"{self.path}:{b.line}: {escape(b.text, 80)}: zero-length move skipped (no-op)"
                )
            return
        if kind == "rapid":
            feed = vel = dur = None
        else:
            d = [c - a for a, c in zip(pos, target, strict=True)]
            d_xyz = math.sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2])
            d_abc = d_uvw = 0.0
            if d_xyz == 0.0:
                d_abc = math.sqrt(d[3] ** 2 + d[4] ** 2 + d[5] ** 2)
                d_uvw = math.sqrt(d[6] ** 2 + d[7] ** 2 + d[8] ** 2)
            length = math.dist(start, end)
            feed, vel, dur = self._timing(b, word, d_xyz, d_uvw, d_abc, length)
        if self.setup.limits is not None:
            self._check_limits(word, end, end)
        pm = self.path_mode
        blend = pm == "blend"
        mv = GcodeMove(
            b.line,
            b.number,
            b.text,
            kind,
            start,
            end,
            None,
            self.plane,
            0,
            feed,
            pm == "exact_stop",
            self.p_tol if blend else None,
            vel,
            dur,
            pm == "exact_path",
            self.q_tol if blend else None,
            (),
            word,
        )
        if self._pending_outputs:
            self._push_move(mv)
        else:
            self.n_moves += 1
            self._out.append(mv)
        self.pos = target

    def _push_move(self, mv: GcodeMove) -> None:
        if self._pending_outputs:
            mv = mv._replace(outputs=tuple(self._pending_outputs))
            self._pending_outputs = []
        self.n_moves += 1
        self._out.append(mv)

    def _check_limits(self, word: str, lo: Sequence[float], hi: Sequence[float]) -> None:
        lims = self.setup.limits
        if lims is None:
            return
        for i, ((mn, mx), a, z) in enumerate(zip(lims, lo, hi, strict=True)):
            tol_hi = 1e-12 * (1.0 + abs(z))
            tol_lo = 1e-12 * (1.0 + abs(a))
            if (mx is not None and z > mx + tol_hi) or (mn is not None and a < mn - tol_lo):
                reach = z if mx is not None and z > mx + tol_hi else a
                raise _Err(
                    word,
                    f"the move reaches {_fmt(reach)} on axis "
                    f"{self.setup.names[i]!r}, outside its software limits [{mn}, {mx}] "
                    "(machine coordinates, m or rad; allowed: inside the limits)",
                )

    def _arc(self, b: _Block, code: int, target: list[float], used: set[str]) -> None:
        w = b.words
        word = "G2" if code == 20 else "G3"
        ia, ib, inn = _PLANES[self.plane]
        la, lb = AXES[ia], AXES[ib]
        for c in (la, lb):
            if c not in self.setup.axes:
                raise _Err(
                    word,
                    f"an arc in the {self.plane} plane needs a {c} axis (allowed: "
                    "arcs in a plane of the machine's axes)",
                )
        oa, ob = _OFFSET_LETTER[ia], _OFFSET_LETTER[ib]
        for c in "IJK":
            if c in w and c not in (oa, ob):
                raise _Err(
                    b.word_text[c],
                    f"{c} is not a centre offset in the {self.plane} plane "
                    f"({_PLANE_CODE[self.plane]}; allowed: {oa}, {ob})",
                )
        u = self.unit
        inch = u == INCH
        spiral_abs = CENTER_ARC_RADIUS_TOLERANCE_INCH if inch else CENTER_ARC_RADIUS_TOLERANCE_MM
        spiral_abs *= u
        radius_tol = (RADIUS_TOLERANCE_INCH if inch else RADIUS_TOLERANCE_MM) * u
        sa, sb = self.pos[ia], self.pos[ib]
        ea, eb = target[ia], target[ib]
        turns = 1
        if "P" in w:
            used.add("P")
            p = w["P"]
            if p != int(p) or not 1 <= p <= MAX_TURNS:
                raise _Err(
                    b.word_text["P"],
                    f"arc turns must be an integer 1..{MAX_TURNS} (allowed: P1, P2, ...)",
                )
            turns = int(p)
        cw = code == 20
        spiral_line = False
        if "R" in w:
            used.add("R")
            if oa in w or ob in w:
                raise _Err(b.word_text["R"], f"arc with both {oa}/{ob} and R (allowed: one form)")
            r = w["R"] * u
            if ea == sa and eb == sb:
                raise _Err(
                    b.word_text["R"],
                    f"an R arc cannot end where it starts (allowed: a full circle with {oa}/{ob})",
                )
            if r == 0.0:
                raise _Err(b.word_text["R"], "arc radius must be non-zero")
            ra = abs(r)
            ma, mb = (sa + ea) / 2.0, (sb + eb) / 2.0
            half = math.hypot(ea - ma, eb - mb)
            if half - ra > radius_tol:
                raise _Err(
                    b.word_text["R"],
                    f"radius {_fmt(ra / u)} too small to reach the end "
                    f"point (allowed: |R| >= half the chord, {_fmt(half / u)})",
                )
            if half / ra > 1.0 - _TINY:
                half = ra
            if (cw and r > 0) or (not cw and r < 0):
                theta = math.atan2(eb - sb, ea - sa) - math.pi / 2.0
            else:
                theta = math.atan2(eb - sb, ea - sa) + math.pi / 2.0
            off = ra * math.cos(math.asin(half / ra))
            ca, cb = ma + off * math.cos(theta), mb + off * math.sin(theta)
        else:
            if oa not in w and ob not in w:
                raise _Err(
                    word,
                    f"arc with neither {oa}/{ob} nor R (allowed: {oa}/{ob} centre offsets or R)",
                )
            used.update(c for c in (oa, ob) if c in w)
            i_v = w.get(oa, 0.0) * u
            j_v = w.get(ob, 0.0) * u
            if self.ijk_absolute:
                ca = i_v + self._offset(ia) if oa in w else sa
                cb = j_v + self._offset(ib) if ob in w else sb
            else:
                ca, cb = sa + i_v, sb + j_v
            r0 = math.hypot(sa - ca, sb - cb)
            r1 = math.hypot(ea - ca, eb - cb)
            if r0 < radius_tol or r1 < radius_tol:
                raise _Err(
                    word,
                    f"zero-radius arc (radius to the start {_fmt(r0 / u)}, to the end "
                    f"{_fmt(r1 / u)}; allowed: a radius >= {_fmt(radius_tol / u)})",
                )
            abs_err = abs(r1 - r0)
            rel_err = abs_err / max(r0, r1)
            if abs_err > spiral_abs * 100.0 or (
                rel_err > SPIRAL_RELATIVE_TOLERANCE and abs_err > spiral_abs
            ):
                raise _Err(
                    word,
                    f"radius to the end {_fmt(r1 / u)} differs from the radius to the "
                    f"start {_fmt(r0 / u)} (allowed: a difference up to "
                    f"{_fmt(spiral_abs / u)} or {SPIRAL_RELATIVE_TOLERANCE:g} relative, "
                    "LinuxCNC's tolerance)",
                )
            chord = math.hypot(ea - sa, eb - sb)
            if abs_err > 0.0 and chord > _SAME_POINT_RTOL * max(1.0, r0):
                ux, uy = (ea - sa) / chord, (eb - sb) / chord
                shift = (ca - (sa + ea) / 2.0) * ux + (cb - (sb + eb) / 2.0) * uy
                if abs(shift) <= max(abs_err, 1e-9 * r0):
                    ca -= shift * ux
                    cb -= shift * uy
                else:
                    spiral_line = True
        # the swept angle
        r = math.hypot(sa - ca, sb - cb)
        a0 = math.atan2(sb - cb, sa - ca)
        a1 = math.atan2(eb - cb, ea - ca)
        scale = max(1.0, abs(sa), abs(sb), abs(ea), abs(eb), r)
        full = math.hypot(ea - sa, eb - sb) <= _SAME_POINT_RTOL * scale
        if full:
            phi = 2.0 * math.pi
            target[ia], target[ib] = sa, sb
        else:
            phi = (a0 - a1) if cw else (a1 - a0)
            phi %= 2.0 * math.pi
            if phi <= 0.0:
                phi = 2.0 * math.pi
        phi += 2.0 * math.pi * (turns - 1)
        arc_end = list(target)
        if spiral_line:
            arc_end[ia] = ca + r * math.cos(a1)
            arc_end[ib] = cb + r * math.sin(a1)
        # off-plane motion (helix): every other axis linear in the angle
        d = [c - a for a, c in zip(self.pos, arc_end, strict=True)]
        d[ia] = d[ib] = 0.0
        d_norm = d[inn]
        plane_len = r * phi
        d_xyz = math.hypot(plane_len, d_norm)
        d_abc = math.sqrt(d[3] ** 2 + d[4] ** 2 + d[5] ** 2)
        rise = math.sqrt(sum(d[k] ** 2 for k in self._member_idx))
        length = math.hypot(plane_len, rise)
        feed, vel, dur = self._timing(b, word, d_xyz, 0.0, d_abc, length)
        start = self._out_point(self.pos)
        end = self._out_point(arc_end)
        center = list(self.pos)
        center[ia], center[ib] = ca, cb
        lo, hi = self._arc_extent(start, end, ca, cb, r, a0, phi, cw, ia, ib)
        self._check_limits(word, lo, hi)
        self._push_move(
            GcodeMove(
                line=b.line,
                number=b.number,
                text=b.text,
                kind="arc_cw" if cw else "arc_ccw",
                start=start,
                end=end,
                center=self._out_point(center),
                plane=self.plane,
                turns=turns - 1 if not full else turns - 1,
                feed=feed,
                velocity=vel,
                duration=dur,
                word=word,
                **self._mode_fields(),
            )
        )
        self.pos = arc_end
        if spiral_line:
            self._line("linear", target, b, word)

    def _arc_extent(
        self,
        start: Sequence[float],
        end: Sequence[float],
        ca: float,
        cb: float,
        r: float,
        a0: float,
        phi: float,
        cw: bool,
        ia: int,
        ib: int,
    ) -> tuple[list[float], list[float]]:
        lo = [min(a, z) for a, z in zip(start, end, strict=True)]
        hi = [max(a, z) for a, z in zip(start, end, strict=True)]
        for axis_k, c, ang0 in ((ia, ca, 0.0), (ib, cb, math.pi / 2.0)):
            if axis_k not in self._member_idx:
                continue
            i = self._member_idx.index(axis_k)
            # extremes at angle ang0 (max) and ang0 + pi (min), passed if within the sweep
            for target_ang, is_max in ((ang0, True), (ang0 + math.pi, False)):
                delta = ((a0 - target_ang) if cw else (target_ang - a0)) % (2.0 * math.pi)
                if delta <= phi:
                    if is_max:
                        hi[i] = max(hi[i], c + r)
                    else:
                        lo[i] = min(lo[i], c - r)
        return lo, hi

    # -- canned cycles ---------------------------------------------------------------------
    def _cycle(self, b: _Block, code: int, used: set[str], first: bool) -> None:
        w = b.words
        word = _g_label(code)
        ka, kb, kc = _PLANES[self.plane]  # plane axes and the drilling axis
        la, lb, lc = AXES[ka], AXES[kb], AXES[kc]
        for c in (la, lb, lc):
            if c not in self.setup.axes:
                raise _Err(word, f"a {word} cycle in the {self.plane} plane needs a {c} axis")
        cyc = self.cycle
        if first or self.motion != code:
            if lc not in w:
                raise _Err(
                    word, f"{lc} missing with {word} (allowed: {word} ... {lc}<bottom> R<retract>)"
                )
        if "R" in w:
            cyc["R"] = w["R"]
        if "R" not in cyc:
            raise _Err(word, f"R missing with {word} (allowed: R the retract level)")
        used.add("R")
        zraw = w.get(lc, cyc.get("Z"))
        assert zraw is not None
        used.add(lc)
        used.update(c for c in (la, lb) if c in w)
        for letter in "PQ":
            if letter in w:
                cyc[letter] = w[letter]
        repeats = 1
        if "L" in w:
            used.add("L")
            if w["L"] != int(w["L"]) or not 0 <= w["L"] <= 100_000:
                raise _Err(b.word_text["L"], "L repeats must be an integer 0..100000")
            repeats = int(w["L"])
        u = self.unit
        conv = [self._conv(k) for k in (ka, kb, kc)]

        def prog(k: int) -> float:
            return self._prog(k)

        current_cc = prog(kc) / conv[2]
        if self.cycle_il is None:
            self.cycle_il = current_cc
        old_cc = self.cycle_il
        r_inc = th_inc = 0.0  # polar increments (G17 only: checked in _run_block)
        if not self.incremental:
            aa_inc = bb_inc = 0.0
            rr = cyc["R"]
            cc = zraw
            aa = w[la] if la in w else prog(ka) / conv[0]
            bb = w[lb] if lb in w else prog(kb) / conv[1]
            if "@" in w or "^" in w:  # LinuxCNC convert_cycle_xy
                x0, y0 = prog(ka) / conv[0], prog(kb) / conv[1]
                rad = w["@"] if "@" in w else math.hypot(x0, y0)
                th = math.radians(w["^"]) if "^" in w else math.atan2(y0, x0)
                aa, bb = rad * math.cos(th), rad * math.sin(th)
        else:
            aa_inc = w.get(la, 0.0)
            bb_inc = w.get(lb, 0.0)
            r_inc = w.get("@", 0.0)
            th_inc = math.radians(w.get("^", 0.0))
            rr = cyc["R"] + old_cc
            cc = rr + zraw
            aa = prog(ka) / conv[0]
            bb = prog(kb) / conv[1]
        if rr < cc:
            raise _Err(
                word,
                f"R {_fmt(rr)} below the bottom {lc}{_fmt(cc)} (allowed: R >= the bottom level)",
            )
        save = self.path_mode
        self.path_mode = "exact_path"
        try:

            def go(kind: str, a: float, bq: float, c: float) -> None:
                t = list(self.pos)
                t[ka] = a * conv[0] + self._offset(ka)
                t[kb] = bq * conv[1] + self._offset(kb)
                t[kc] = c * conv[2] + self._offset(kc)
                self._line(kind, t, b, word)

            if old_cc < rr:
                go("rapid", prog(ka) / conv[0], prog(kb) / conv[1], rr)
                old_cc = rr
                current_cc = rr
            clear = rr if self.retract_r else old_cc
            peck_clear = 0.05 if u == INCH else 1.0
            for rep in range(repeats, 0, -1):
                aa += aa_inc
                bb += bb_inc
                if r_inc or th_inc:  # LinuxCNC CYCLE_MACRO: about the program origin
                    if aa == 0.0 and bb == 0.0:
                        raise _Err(
                            word, "G91 polar motion at the origin is indeterminate (allowed: G90)"
                        )
                    rad = math.hypot(aa, bb) + r_inc
                    th = math.atan2(bb, aa) + th_inc
                    aa, bb = rad * math.cos(th), rad * math.sin(th)
                if rep == repeats and current_cc > rr:
                    go("rapid", aa, bb, current_cc)
                    go("rapid", aa, bb, rr)
                else:
                    go("rapid", aa, bb, clear)
                    if clear > rr:
                        go("rapid", aa, bb, rr)
                self._cycle_body(b, code, word, go, aa, bb, rr, clear, cc, peck_clear, used)
        finally:
            self.path_mode = save
        cyc["Z"] = zraw

    def _cycle_body(
        self,
        b: _Block,
        code: int,
        word: str,
        go: Any,
        x: float,
        y: float,
        r: float,
        clear: float,
        bottom: float,
        peck_clear: float,
        used: set[str],
    ) -> None:
        cyc = self.cycle

        def dwell(key_needed: bool) -> float:
            if "P" not in cyc:
                if key_needed:
                    raise _Err(word, f"{word} needs the dwell time P (allowed: P seconds)")
                return 0.0
            used.add("P")
            if cyc["P"] < 0.0:
                raise _Err(word, "negative dwell time P")
            return cyc["P"]

        def spindle_needed() -> int:
            if self.spindle_dir == 0:
                raise _Err(word, f"spindle not turning in {word} (allowed: M3/M4 before)")
            return self.spindle_dir

        if code == 810:
            go("linear", x, y, bottom)
            go("rapid", x, y, clear)
        elif code == 820:
            p = dwell(True)
            go("linear", x, y, bottom)
            self._event("dwell", p)
            go("rapid", x, y, clear)
        elif code in (730, 830):
            if "Q" not in cyc:
                raise _Err(word, f"{word} needs the peck depth Q (allowed: Q > 0)")
            used.add("Q")
            q = cyc["Q"]
            if q <= 0.0:
                raise _Err(word, "negative or zero Q peck depth (allowed: Q > 0)")
            n = math.ceil((r - bottom) / q)
            if n > 1_000_000:
                raise _Err(word, f"{n} pecks (allowed: up to 1000000; a larger Q)")
            depth = r - q
            while depth > bottom:
                go("linear", x, y, depth)
                if code == 830:
                    go("rapid", x, y, r)
                go("rapid", x, y, depth + peck_clear)
                depth -= q
            go("linear", x, y, bottom)
            go("rapid", x, y, clear)
        elif code == 840:
            d = spindle_needed()
            if d < 0:
                raise _Err(word, "spindle turning counter-clockwise in G84 (allowed: M3)")
            p = dwell(False)
            go("linear", x, y, bottom)
            self._event("spindle", 0.0)
            self._event("spindle", -self.rpm)
            if p:
                self._event("dwell", p)
            go("linear", x, y, clear)
            self._event("spindle", 0.0)
            self._event("spindle", self.rpm)
        elif code == 850:
            go("linear", x, y, bottom)
            go("linear", x, y, r)
            if clear > r:
                go("rapid", x, y, clear)
        elif code == 860:
            d = spindle_needed()
            p = dwell(True)
            go("linear", x, y, bottom)
            self._event("dwell", p)
            self._event("spindle", 0.0)
            go("rapid", x, y, clear)
            self._event("spindle", d * self.rpm)
        elif code == 870:
            d = spindle_needed()
            w = b.words
            ka, kb, kc = _PLANES[self.plane]
            oa, ob, oc = _OFFSET_LETTER[ka], _OFFSET_LETTER[kb], _OFFSET_LETTER[kc]
            for c in (oa, ob, oc):
                if c in w:
                    cyc[c] = w[c]
                    used.add(c)
                elif c not in cyc:
                    raise _Err(word, f"{c} missing with G87 (allowed: G87 ... {oa} {ob} {oc})")
            off_x, off_y = x + cyc[oa], y + cyc[ob]
            middle = bottom + cyc[oc] if self.incremental else cyc[oc]
            go("rapid", off_x, off_y, r)
            self._event("spindle", 0.0)
            go("rapid", off_x, off_y, bottom)
            go("rapid", x, y, bottom)
            self._event("spindle", d * self.rpm)
            go("linear", x, y, middle)
            go("linear", x, y, bottom)
            self._event("spindle", 0.0)
            go("rapid", off_x, off_y, bottom)
            go("rapid", off_x, off_y, clear)
            go("rapid", x, y, clear)
            self._event("spindle", d * self.rpm)
        elif code == 880:
            d = spindle_needed()
            p = dwell(True)
            go("linear", x, y, bottom)
            self._event("dwell", p)
            self._event("spindle", 0.0)
            self._event("pause", 88.0, text="G88: retract by hand")
            self._note(
                "G88",
                "G88: the manual retract after the pause is a rapid to the clear "
                "level (no operator)",
                b.line,
            )
            go("rapid", x, y, clear)
            self._event("spindle", d * self.rpm)
        elif code == 890:
            p = dwell(True)
            go("linear", x, y, bottom)
            self._event("dwell", p)
            go("linear", x, y, clear)


# ------------------------------------------------------------------------------- programs
@dataclass(frozen=True, slots=True)
class GcodeProgram:
    """A program checked by a complete :class:`Interpreter` run (syntax of every line and
    every executed block), kept as its source (``text`` or the file ``path``): :meth:`moves`
    and :meth:`items` run it again, streaming."""

    path: str
    setup: MachineSetup
    text: str | None = field(default=None, repr=False)
    n_moves: int = 0
    notes: tuple[str, ...] = ()

    @property
    def axes(self) -> tuple[str, ...]:
        return self.setup.names

    def __len__(self) -> int:
        """Number of moves (from the machine origin)."""
        return self.n_moves

    def interpreter(
        self, start: Sequence[float] | None = None, *, collect: bool = False
    ) -> Interpreter:
        return Interpreter(
            self.path, self.setup, start, path=self.path, text=self.text, collect=collect
        )

    def items(self, start: Sequence[float] | None = None) -> Iterator[GcodeMove | GcodeEvent]:
        """Moves and events from the group position ``start``, lazily."""
        return self.interpreter(start).run()

    def moves(
        self, start: Sequence[float] | None = None, *, skipped: list[str] | None = None
    ) -> Iterator[GcodeMove]:
        """The moves from ``start``, lazily; zero-length moves are appended to ``skipped``."""
        interp = self.interpreter(start)
        for item in interp.run():
            if isinstance(item, GcodeMove):
                yield item
        if skipped is not None:
            skipped.extend(interp.skipped)


def validate(
    program: GcodeProgram, start: Sequence[float] | None = None
) -> tuple[int, int, Interpreter]:
    """Run ``program`` completely, collecting every error: (moves, events, the interpreter).
    Raises :class:`GcodeError` with all of them (``FILE:LINE: WORD: ...``, at most 100)."""
    interp = program.interpreter(start, collect=True)
    n_moves = n_events = 0
    for item in interp.run():
        if isinstance(item, GcodeMove):
            n_moves += 1
        else:
            n_events += 1
    return n_moves, n_events, interp


def parse_gcode(
    text: str,
    path: str = "<string>",
    axes: Sequence[str] = ("x", "y", "z"),
    setup: MachineSetup | None = None,
) -> GcodeProgram:
    """Check a program given as text (see :func:`load_gcode`)."""
    return _checked(path, setup or _setup_for(axes, path), text)


def load_gcode(
    path: str | FilePath,
    axes: Sequence[str] = ("x", "y", "z"),
    setup: MachineSetup | None = None,
) -> GcodeProgram:
    """Check a G-code file for a machine: the whole program is run once (from the machine
    origin), every error collected; raises :class:`GcodeError` listing them."""
    p = FilePath(path)
    if not p.is_file():
        raise GcodeError(f"{p}: cannot read: no such file")
    return _checked(str(p), setup or _setup_for(axes, str(p)), None)


def _setup_for(axes: Sequence[str], path: str) -> MachineSetup:
    try:
        names = tuple(axes)
    except TypeError:
        raise GcodeError(f"{path}: axes: must be a sequence of axis names") from None
    if not 1 <= len(names) <= 3 or not all(isinstance(a, str) and a for a in names):
        raise GcodeError(
            f"{path}: axes: must be 1 to 3 axis names (mapped to X, Y, Z), got {names!r}"
        )
    if len(set(names)) != len(names):
        raise GcodeError(f"{path}: axes: names must be distinct, got {names!r}")
    return MachineSetup.for_axes(names)


def _checked(path: str, setup: MachineSetup, text: str | None) -> GcodeProgram:
    prog = GcodeProgram(path, setup, text)
    n_moves, _, interp = validate(prog)
    return GcodeProgram(path, setup, text, n_moves, tuple(interp.notes))


# ------------------------------------------------------------------------------- paths
class _HelixN(Helix):
    """A helix in R^n: a circle in a plane plus a linear motion ``rise`` (any vector
    orthogonal to the plane) over the swept ``angle`` (the closed form of the planning's
    Arc/Helix, which is dimension-free)."""

    __slots__ = ()

    def __init__(  # noqa: PLR0913 - the frame
        self,
        base: np.ndarray,
        x: np.ndarray,
        y: np.ndarray,
        r: float,
        angle: float,
        rise: np.ndarray,
    ) -> None:
        h = float(np.linalg.norm(rise))
        n = rise / h
        self._set(base, x, y, n, r, h / angle, angle)


def move_path(move: GcodeMove) -> Path:
    """The geometric path of a move: a :class:`Line`, an :class:`Arc` (a plane arc, all its
    turns) or a helix (an arc with any other axis moving linearly with the angle), in the
    group's coordinates. Starts at ``move.start`` and ends at ``move.end`` (to rounding)."""
    p0 = np.asarray(move.start, dtype=float)
    p1 = np.asarray(move.end, dtype=float)
    if move.kind in ("rapid", "linear"):
        return Line(p0, p1)
    if move.kind not in ("arc_cw", "arc_ccw"):
        raise PlanningError(
            f"move.kind: must be 'rapid', 'linear', 'arc_cw' or 'arc_ccw', got {move.kind!r}"
        )
    if move.center is None:
        raise PlanningError("move.center: an arc needs its centre")
    if move.plane not in _PLANES:
        raise PlanningError(f"move.plane: must be 'XY', 'ZX' or 'YZ', got {move.plane!r}")
    if isinstance(move.turns, bool) or not isinstance(move.turns, int) or move.turns < 0:
        raise PlanningError(f"move.turns: must be an integer >= 0, got {move.turns!r}")
    return _arc_path(
        p0,
        p1,
        np.asarray(move.center, dtype=float),
        move.plane,
        move.kind == "arc_cw",
        move.turns,
        _plane_index(move),
    )


def _plane_index(move: GcodeMove) -> tuple[int, int]:
    """Group indices of the plane's two axes: the first two members for XY (X, Y), else
    the members' positions X=0, Y=1, Z=2 (the default mapping)."""
    ia, ib, _ = _PLANES[move.plane]
    dim = len(move.start)
    if max(ia, ib) >= dim:
        raise PlanningError(f"move.plane: the {move.plane} plane needs 3 axes, got {dim}")
    return ia, ib


def arc_path(move: GcodeMove, ia: int, ib: int) -> Path:
    """:func:`move_path` with the group indices ``ia``, ``ib`` of the plane's axes."""
    assert move.center is not None
    return _arc_path(
        np.asarray(move.start, dtype=float),
        np.asarray(move.end, dtype=float),
        np.asarray(move.center, dtype=float),
        move.plane,
        move.kind == "arc_cw",
        move.turns,
        (ia, ib),
    )


def _arc_path(
    p0: np.ndarray,
    p1: np.ndarray,
    c: np.ndarray,
    plane: str,
    cw: bool,
    turns: int,
    idx: tuple[int, int],
) -> Path:
    ia, ib = idx
    dim = p0.size
    ea = np.zeros(dim)
    eb = np.zeros(dim)
    ea[ia] = 1.0
    eb[ib] = 1.0
    sa, sb = p0[ia] - c[ia], p0[ib] - c[ib]
    r = math.hypot(sa, sb)
    if not r > 0.0:
        raise PlanningError("move.center: the start lies on the arc's axis (zero radius)")
    x = (sa * ea + sb * eb) / r
    yv = (-sb * ea + sa * eb) / r  # +90 deg in the plane (counter-clockwise)
    if cw:
        yv = -yv
    da, db = p1[ia] - c[ia], p1[ib] - c[ib]
    scale = max(1.0, r, float(np.max(np.abs(np.concatenate([p0, p1])))))
    if math.hypot(p1[ia] - p0[ia], p1[ib] - p0[ib]) <= _SAME_POINT_RTOL * scale:
        phi = 2.0 * math.pi
    else:
        e = da * ea + db * eb
        phi = math.atan2(float(e @ yv), float(e @ x)) % (2.0 * math.pi)
        if phi <= 0.0:
            phi = 2.0 * math.pi
    phi += 2.0 * math.pi * turns
    rise = p1 - p0
    rise[ia] = rise[ib] = 0.0
    base = p0.copy()
    base[ia], base[ib] = c[ia], c[ib]
    if float(np.max(np.abs(rise))) <= _SAME_POINT_RTOL * scale:
        return Arc(base, r, x, yv, phi)
    return _HelixN(base, x, yv, r, phi, rise)


def reference_markdown() -> str:
    """The G-code reference page (``docs/reference/gcode.md``), from :data:`WORDS`."""
    out = [
        "# G-code reference (generated from `motionplc.gcode.WORDS`)",
        "",
        "RS274/NGC with LinuxCNC's meanings. Exactly these codes and words are accepted;",
        "anything else is a located error `FILE:LINE: WORD: ...`. Words understood but without",
        "effect on the machine (no spindle, no coolant output, override switches) are notes.",
        "Moves are in the group's machine coordinates; linear axes in the program's units,",
        "A B C in degrees. Bounds: lines up to "
        f"{MAX_LINE} characters, files up to {MAX_LINES} lines, expressions nested up to "
        f"{MAX_NESTING}, subroutine calls up to {MAX_CALL_DEPTH} deep, arcs up to "
        f"{MAX_TURNS} turns (one move).",
        "",
        "| code | modal group | meaning |",
        "|---|---|---|",
    ]
    for w in WORDS:
        out.append(f"| `{w.code}` | {w.group or 'value word'} | {w.meaning} |")
    out += [
        "",
        "## Refused with a reason",
        "",
        "| code | why |",
        "|---|---|",
    ]
    for code, why in {**_REFUSED_G, **_REFUSED_M}.items():
        out.append(f"| `{code}` | {why} |")
    out += [
        "",
        "## Expressions and parameters",
        "",
        "`#1`-`#5602` numbered (`#1`-`#30` local to a call; the system parameters of work "
        "offsets, G28/G30, G92, tool and position as LinuxCNC), `#<name>` local and "
        "`#<_name>` global named parameters, `[...]` expressions with "
        + " ".join(f"`{op}`" for op, _ in _BINOPS)
        + " and the functions "
        + " ".join(f"`{fn}`" for fn in _FUNCS)
        + " (`ATAN[y]/[x]`, angles in degrees). Comments `(...)`, `;...`, `(MSG,...)`, "
        "`(DEBUG,...)`, `(PRINT,...)`; block delete `/`; `%` lines.",
        "",
    ]
    return "\n".join(out)
