"""A G-code subset for axis groups: parser, resolver and the path of each move.

The subset follows LinuxCNC/RS274NGC where it applies:

* Motion (modal group 1): ``G0`` rapid, ``G1`` linear, ``G2``/``G3`` arc clockwise /
  counter-clockwise with ``I``/``J``/``K`` (centre offsets from the start point, in the active
  plane's two axes; always incremental, as LinuxCNC's default G91.1) or ``R`` (radius;
  ``R < 0`` takes the arc longer than 180 degrees). An I/J/K arc whose end equals its start is a
  full circle; a word of the axis normal to the plane makes a helix; ``P`` (a positive integer)
  is the number of turns as in LinuxCNC (``P1`` the plain arc, each more adds a full turn).
* ``G17``/``G18``/``G19``: the XY / ZX / YZ plane. The sense of an arc is seen from the plane
  normal's positive side (+Z, +Y, +X; right-handed in the plane's own order, so in G18 a G3 arc
  turns from +Z towards +X, as in LinuxCNC).
* ``G90``/``G91`` absolute / incremental axis words, ``G20``/``G21`` inch / mm, ``F`` feed rate in
  units per minute (modal; the physical speed is kept across a unit change, as LinuxCNC).
* ``G61`` exact stop, ``G64`` blending (``G64 P<tol>``: tolerance in program units; ``G64``
  alone: the group's default tolerance, represented as ``tolerance=None``).
* ``M2``/``M30`` end the program (anything after is ignored, as is anything after a second
  ``%`` line). ``N`` line numbers (first word of the line), comments ``( ... )`` and ``; ...``,
  blank lines, upper or lower case, spaces between words and between a letter and its number.

Start state: G17 G21 G90 G61, no motion mode and no feed rate. Order on one line (RS274NGC):
F, plane, units, path control, distance mode, then the motion, then M2/M30; ``F`` on a line that
changes the units is refused as ambiguous (LinuxCNC would read it in the old units).

Everything else is a located :class:`GcodeError` ``FILE:LINE: WORD: what is wrong (what is
allowed)``: unsupported G/M codes and letters (G4, G43, M3, S, T, O-words, ...), expressions
``[...]``, parameters ``#1``, a letter without a number, a number without a letter, two words
of one modal group or two equal letters on a line, axis words the group does not have, an arc
with neither I/J/K nor R or with both, ... . All syntax and modal errors of a file are reported at
once by :func:`parse_gcode`; geometric errors that need the start position (a radius too small
for the chord, an I/J/K centre whose start and end radii differ by more than 1e-6 relative) are
raised by :meth:`GcodeProgram.moves` at the move's line. A zero-length move is not an error: it
is skipped and reported (``skipped`` list of :meth:`GcodeProgram.moves`, and the module logger).

Internally everything is SI: positions in metres, feed in m/s.
"""

from __future__ import annotations

import logging
import math
import re
from collections.abc import Iterator, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path as FilePath

import numpy as np

from motionplc.errors import ConfigError, PlanningError
from motionplc.planning.paths import Arc, Helix, Line, Path

__all__ = [
    "GcodeError",
    "GcodeMove",
    "GcodeProgram",
    "GcodeWord",
    "load_gcode",
    "move_path",
    "parse_gcode",
    "split_words",
]

_log = logging.getLogger(__name__)

MM = 0.001  # metres per millimetre
INCH = 0.0254  # metres per inch
# Relative (to the larger radius) and absolute [m] tolerance of an I/J/K arc's start and end radii.
ARC_RADIUS_RTOL = 1e-6
ARC_RADIUS_ATOL = 1e-9
# An end point this close to the start (relative to max(1 m, radius, |coordinates|)) is the same
# point: a zero-length line (skipped) or a full circle (I/J/K arcs).
_SAME_POINT_RTOL = 1e-12
# LinuxCNC's TINY: half the chord may exceed |R| by this relative amount (then a semicircle).
_R_TINY = 1e-12
_MAX_ERRORS = 100
# Largest number in a word: 1e15 mm = 1e12 m, the planner's position range.
_MAX_VALUE = 1e15

_PLANES: dict[str, tuple[int, int, int]] = {
    # plane: (first in-plane axis, second in-plane axis, normal axis) as X=0, Y=1, Z=2
    "XY": (0, 1, 2),
    "ZX": (2, 0, 1),
    "YZ": (1, 2, 0),
}
_PLANE_CODE = {"XY": "G17", "ZX": "G18", "YZ": "G19"}
_OFFSET_LETTERS = {"XY": "IJ", "ZX": "IK", "YZ": "JK"}
_AXIS_LETTERS = "XYZ"
_OFFSET_AXIS = {"I": 0, "J": 1, "K": 2}
_KINDS = {"G0": "rapid", "G1": "linear", "G2": "arc_cw", "G3": "arc_ccw"}

# Supported G codes (value * 10) -> (modal group, canonical name).
_G_SUPPORTED: dict[int, tuple[str, str]] = {
    0: ("motion", "G0"),
    10: ("motion", "G1"),
    20: ("motion", "G2"),
    30: ("motion", "G3"),
    170: ("plane", "G17"),
    180: ("plane", "G18"),
    190: ("plane", "G19"),
    200: ("units", "G20"),
    210: ("units", "G21"),
    610: ("path", "G61"),
    640: ("path", "G64"),
    900: ("distance", "G90"),
    910: ("distance", "G91"),
}
_GROUP_NAMES = {
    "motion": "motion code",
    "plane": "plane code",
    "units": "unit code",
    "path": "path-control code",
    "distance": "distance-mode code",
    "stop": "program-end code",
}
# Names of well-known unsupported G codes (value * 10), for the messages.
_G_NAMES: dict[int, str] = {
    40: "dwell",
    50: "spline",
    51: "quadratic spline",
    52: "NURBS",
    70: "lathe diameter mode",
    80: "lathe radius mode",
    100: "data setting",
    280: "go to predefined position",
    281: "set predefined position",
    300: "go to predefined position",
    301: "set predefined position",
    330: "spindle-synchronised motion",
    331: "rigid tapping",
    382: "probing",
    383: "probing",
    384: "probing",
    385: "probing",
    400: "cutter compensation off",
    410: "cutter compensation",
    411: "dynamic cutter compensation",
    420: "cutter compensation",
    421: "dynamic cutter compensation",
    430: "tool length offset",
    431: "dynamic tool length offset",
    432: "additional tool length offset",
    490: "tool length offset cancel",
    520: "local coordinate offset",
    530: "machine coordinates",
    540: "coordinate system",
    550: "coordinate system",
    560: "coordinate system",
    570: "coordinate system",
    580: "coordinate system",
    590: "coordinate system",
    591: "coordinate system",
    592: "coordinate system",
    593: "coordinate system",
    611: "exact path mode",
    730: "canned cycle",
    760: "threading cycle",
    800: "canned cycle cancel",
    810: "canned cycle",
    820: "canned cycle",
    830: "canned cycle",
    840: "canned cycle",
    850: "canned cycle",
    860: "canned cycle",
    870: "canned cycle",
    880: "canned cycle",
    890: "canned cycle",
    901: "absolute arc centre mode",
    911: "incremental arc centre mode (already the default; not supported as a word)",
    920: "coordinate offset",
    921: "coordinate offset",
    922: "coordinate offset",
    923: "coordinate offset",
    930: "inverse-time feed",
    940: "units-per-minute feed mode (already the default; not supported as a word)",
    950: "units-per-revolution feed",
    960: "constant surface speed",
    970: "spindle RPM mode",
    980: "canned cycle return level",
    990: "canned cycle return level",
}
_M_NAMES: dict[int, str] = {
    0: "program pause",
    1: "optional pause",
    3: "spindle on",
    4: "spindle on",
    5: "spindle stop",
    6: "tool change",
    7: "coolant",
    8: "coolant",
    9: "coolant off",
    48: "override enable",
    49: "override disable",
    60: "pallet change pause",
    62: "digital output",
    63: "digital output",
    64: "digital output",
    65: "digital output",
    66: "wait on input",
    67: "analog output",
    68: "analog output",
}
_LETTER_NAMES = {
    "A": "A axis word",
    "B": "B axis word",
    "C": "C axis word",
    "U": "U axis word",
    "V": "V axis word",
    "W": "W axis word",
    "D": "cutter compensation number",
    "E": "E word",
    "H": "tool length offset number",
    "L": "L word",
    "O": "O-word (subroutines and control flow)",
    "Q": "Q word",
    "S": "spindle speed",
    "T": "tool selection",
}
_SUPPORTED = (
    "G0 G1 G2 G3 G17 G18 G19 G20 G21 G61 G64 G90 G91, M2 M30, N, F, "
    "the group's axis letters, I J K R P"
)

_NUMBER = re.compile(r"[+-]?(?:\d+(?:\.\d*)?|\.\d+)")
_SPACES = " \t"


class GcodeError(ConfigError):
    """An invalid or unsupported G-code program.

    ``errors`` holds one line per problem, ``FILE:LINE: WORD: what is wrong (what is
    allowed)``; the message lists all of them. A subclass of
    :class:`~motionplc.errors.ConfigError` (a program file is configuration input), hence of
    :class:`~motionplc.errors.MotionPlcError` and ``ValueError``.
    """

    MAX_SHOWN = None  # this module caps and escapes its own messages
    MAX_LINE = None


@dataclass(frozen=True, slots=True)
class GcodeWord:
    """One word of a line: ``letter`` (upper case), its ``value`` and its ``text`` as written
    (upper case, without spaces, e.g. ``"G01"``, ``"X-.5"``)."""

    letter: str
    value: float
    text: str


@dataclass(frozen=True, slots=True)
class GcodeMove:
    """One resolved move of a program, SI units, absolute coordinates of the group axes.

    ``kind`` is ``"rapid"`` | ``"linear"`` | ``"arc_cw"`` | ``"arc_ccw"``; ``center`` is the
    absolute arc centre (its coordinate along the plane normal is the start's; None for lines);
    ``plane`` the active plane (``"XY"`` | ``"ZX"`` | ``"YZ"``); ``turns`` the extra full turns
    of an arc (``P`` - 1); ``feed`` the path speed [m/s] (None for rapids); ``exact_stop`` G61
    active; ``tolerance`` the G64 P tolerance [m] (None for G64 without P, and under G61).
    An arc whose ``end`` equals its ``start`` in the plane is a full circle.
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


@dataclass(frozen=True, slots=True)
class _Block:
    """A parsed motion line: modal state resolved, positions not (they need the start)."""

    line: int
    number: int | None
    text: str
    code: str  # "G0" .. "G3" (canonical)
    targets: tuple[float | None, ...]  # per group axis [m]; None: word not given
    incremental: bool
    plane: str
    offsets: tuple[float, float] | None  # in-plane I/J/K centre offsets [m]
    radius: float | None  # signed R [m]
    radius_text: str
    turns: int
    feed: float | None
    exact_stop: bool
    tolerance: float | None
    unit: float  # metres per program unit (for messages)


class _WordError(Exception):
    def __init__(self, word: str, message: str) -> None:
        super().__init__(message)
        self.word = word
        self.message = message


class _FeedMissingError(_WordError):
    """The first motion line without a feed rate (reported once per program)."""


def _fmt(x: float) -> str:
    return f"{x:.9g}"


def _unit_name(unit: float) -> str:
    return "in" if unit == INCH else "mm"


# ------------------------------------------------------------------------------- lexing


def _split(line: str) -> list[GcodeWord]:
    """Words of one line (comments dropped); raises _WordError for malformed text."""
    words: list[GcodeWord] = []
    i, n = 0, len(line)
    while i < n:
        ch = line[i]
        if ch in _SPACES:
            i += 1
        elif ch == "(":
            j = line.find(")", i + 1)
            if j < 0:
                raise _WordError("(", "unclosed comment (allowed: ( ... ) closed on its line)")
            if "(" in line[i + 1 : j]:
                raise _WordError("(", "nested comment (allowed: ( ... ) without a second '(')")
            i = j + 1
        elif ch == ";":
            break
        elif ch.isascii() and ch.isalpha():
            letter = ch.upper()
            if letter == "O":  # "O100 sub", "o<name> if [...]": the whole line is control flow
                raise _WordError(
                    _token(line, i).upper(),
                    "O-words (subroutines and control flow) are not supported "
                    f"(allowed: {_SUPPORTED})",
                )
            k = i + 1
            while k < n and line[k] in _SPACES:
                k += 1
            m = _NUMBER.match(line, k)
            if m is None:
                rest = line[k : k + 1]
                if rest == "[":
                    raise _WordError(
                        letter + _bracket(line, k),
                        "expressions [...] are not supported (allowed: a plain number)",
                    )
                if rest == "#":
                    raise _WordError(
                        letter + _token(line, k),
                        "parameters #... are not supported (allowed: a plain number)",
                    )
                raise _WordError(letter, "letter without a number (allowed: e.g. X1.5, G1)")
            value = float(m.group())
            if not abs(value) < _MAX_VALUE:
                raise _WordError(
                    letter + m.group(), f"number out of range (allowed: |value| < {_MAX_VALUE:g})"
                )
            words.append(GcodeWord(letter, value, letter + m.group()))
            i = m.end()
        elif ch.isdigit() or ch in "+-.":
            m = _NUMBER.match(line, i)
            tok = m.group() if m is not None else ch
            raise _WordError(tok, "number without a letter (allowed: a letter before each number)")
        elif ch == "#":
            raise _WordError(
                _token(line, i), "parameters #... are not supported (allowed: plain numbers)"
            )
        elif ch == "[":
            raise _WordError(
                _bracket(line, i), "expressions [...] are not supported (allowed: plain numbers)"
            )
        elif ch == "/":
            raise _WordError("/", "block delete is not supported (allowed: lines without /)")
        else:
            raise _WordError(ch, f"unexpected character {ch!r} (allowed: words, comments)")
    return words


def _bracket(line: str, i: int) -> str:
    j = line.find("]", i)
    return line[i : j + 1] if j >= 0 else line[i:].rstrip()


def _token(line: str, i: int) -> str:
    j = i + 1
    while j < len(line) and line[j] not in _SPACES + "(;":
        j += 1
    return line[i:j]


def split_words(line: str, path: str = "<string>", line_no: int = 1) -> tuple[GcodeWord, ...]:
    """The words of one line of G-code, comments ``( ... )`` and ``; ...`` removed.

    Only the lexical form is checked (every number has a letter and vice versa, comments
    closed, no ``#``/``[``/``/`` or other characters); which words are supported is checked by
    :func:`parse_gcode`. Raises :class:`GcodeError` ``PATH:LINE_NO: WORD: ...``.
    """
    try:
        return tuple(_split(line))
    except _WordError as exc:
        raise GcodeError(f"{path}:{line_no}: {exc.word}: {exc.message}") from None


# ------------------------------------------------------------------------------- parsing


@dataclass(slots=True)
class _Modal:
    motion: str | None = None
    plane: str = "XY"
    incremental: bool = False
    unit: float = MM
    feed: float | None = None  # m/s
    exact_stop: bool = True
    tolerance: float | None = None
    feed_missing_reported: bool = False


@dataclass(slots=True)
class _LineResult:
    block: _Block | None = None
    end_program: bool = False
    modal: _Modal = field(default_factory=_Modal)


def _g_code(word: GcodeWord) -> int:
    tenths = round(word.value * 10.0)
    if abs(word.value * 10.0 - tenths) > 1e-6 or tenths < 0:
        raise _WordError(word.text, f"not a G code (allowed: {_SUPPORTED})")
    return tenths


def _g_label(tenths: int) -> str:
    return f"G{tenths // 10}" + (f".{tenths % 10}" if tenths % 10 else "")


def _parse_line(
    words: Sequence[GcodeWord],
    modal: _Modal,
    axes: tuple[str, ...],
    line_no: int,
    text: str,
) -> _LineResult:
    """Interpret one line's words against ``modal`` (not changed); raises _WordError."""
    naxes = len(axes)
    number: int | None = None
    groups: dict[str, tuple[str, str]] = {}  # group -> (canonical code, text)
    letters: dict[str, GcodeWord] = {}
    for idx, w in enumerate(words):
        if w.letter == "N":
            if idx != 0:
                raise _WordError(w.text, "line number not first on the line (allowed: N first)")
            if w.value != int(w.value) or w.value < 0 or "." in w.text or "-" in w.text:
                raise _WordError(w.text, "line number must be an integer (allowed: N0, N1, ...)")
            number = int(w.value)
            continue
        if w.letter == "G":
            tenths = _g_code(w)
            if tenths not in _G_SUPPORTED:
                name = _G_NAMES.get(tenths, "unknown G code")
                raise _WordError(
                    w.text, f"{_g_label(tenths)} ({name}) is not supported (allowed: {_SUPPORTED})"
                )
            group, code = _G_SUPPORTED[tenths]
            _add_group(groups, group, code, w.text)
            continue
        if w.letter == "M":
            if w.value != int(w.value) or w.value < 0:
                raise _WordError(w.text, f"not an M code (allowed: {_SUPPORTED})")
            mcode = int(w.value)
            if mcode not in (2, 30):
                name = _M_NAMES.get(mcode, "unknown M code")
                raise _WordError(
                    w.text, f"M{mcode} ({name}) is not supported (allowed: M2, M30 program end)"
                )
            _add_group(groups, "stop", f"M{mcode}", w.text)
            continue
        if w.letter in _LETTER_NAMES:
            raise _WordError(
                w.text, f"{_LETTER_NAMES[w.letter]} is not supported (allowed: {_SUPPORTED})"
            )
        if w.letter in _AXIS_LETTERS and _AXIS_LETTERS.index(w.letter) >= naxes:
            have = ", ".join(f"{_AXIS_LETTERS[i]}={a}" for i, a in enumerate(axes))
            raise _WordError(w.text, f"the group has no {w.letter} axis (allowed: its axes {have})")
        if w.letter not in "FXYZIJKRP":
            raise _WordError(w.text, f"unknown word (allowed: {_SUPPORTED})")
        if w.letter in letters:
            raise _WordError(
                w.text,
                f"second {w.letter} word on the line ({letters[w.letter].text} already; "
                "allowed: one per line)",
            )
        letters[w.letter] = w

    new = replace(modal)
    # F (before the units, as RS274NGC; refused when the units change on the same line)
    unit_code = groups.get("units")
    new_unit = modal.unit if unit_code is None else (INCH if unit_code[0] == "G20" else MM)
    if "F" in letters:
        f = letters["F"]
        if unit_code is not None and new_unit != modal.unit:
            raise _WordError(
                f.text,
                f"F on the line that changes the units ({unit_code[1]}) is ambiguous "
                "(allowed: F on a line of its own or after the unit change)",
            )
        if not f.value > 0.0:
            raise _WordError(f.text, "feed rate must be > 0 (allowed: F > 0 in units/min)")
        new.feed = f.value * modal.unit / 60.0
    # plane
    if "plane" in groups:
        code, wtext = groups["plane"]
        plane = {"G17": "XY", "G18": "ZX", "G19": "YZ"}[code]
        missing = [_AXIS_LETTERS[i] for i in _PLANES[plane][:2] if i >= naxes]
        if missing:
            raise _WordError(
                wtext,
                f"the {plane} plane needs a {missing[0]} axis, the group has "
                f"{', '.join(axes)} (allowed: G17 for a 2-axis group)",
            )
        new.plane = plane
    new.unit = new_unit
    # path control (G64 P is handled below, with the other P use)
    if "path" in groups:
        new.exact_stop = groups["path"][0] == "G61"
        new.tolerance = None
    if "distance" in groups:
        new.incremental = groups["distance"][0] == "G91"
    # motion
    motion_word = groups.get("motion")
    if motion_word is not None:
        new.motion = motion_word[0]
    code = new.motion
    code_text = motion_word[1] if motion_word is not None else (code or "")
    axis_words = [letters[c] for c in _AXIS_LETTERS if c in letters]
    offset_words = [letters[c] for c in "IJK" if c in letters]
    r_word = letters.get("R")
    is_arc = code in ("G2", "G3")
    if axis_words and code is None:
        raise _WordError(
            axis_words[0].text, "axis word without a motion mode (allowed: after G0, G1, G2, G3)"
        )
    if not is_arc and (offset_words or r_word is not None):
        w = offset_words[0] if offset_words else r_word
        assert w is not None
        raise _WordError(w.text, f"{w.letter} word without an arc (allowed: with G2 or G3)")
    moves = bool(axis_words) or (is_arc and (bool(offset_words) or r_word is not None))
    # P: G64 tolerance or arc turns
    turns = 0
    p_word = letters.get("P")
    path_code = groups.get("path")
    if p_word is not None:
        if path_code is not None and path_code[0] == "G64":
            if moves and is_arc:
                raise _WordError(
                    p_word.text,
                    f"P with both G64 and an arc ({code}) on one line is ambiguous "
                    "(allowed: G64 P on a line without an arc)",
                )
            if not p_word.value > 0.0:
                raise _WordError(
                    p_word.text,
                    "G64 tolerance must be > 0 (allowed: P > 0 in program units; "
                    "G64 alone for the group's default, G61 for exact stop)",
                )
            new.tolerance = p_word.value * new.unit
        elif moves and is_arc:
            if p_word.value != int(p_word.value) or p_word.value < 1:
                raise _WordError(
                    p_word.text, "arc turns must be an integer >= 1 (allowed: P1, P2, ...)"
                )
            turns = int(p_word.value) - 1
        else:
            raise _WordError(
                p_word.text, "P word without G64 or an arc (allowed: G64 P<tol>, G2/G3 P<turns>)"
            )
    end_program = "stop" in groups
    if not moves:  # modal settings only (also "G2" alone: sets the motion mode)
        return _LineResult(None, end_program, new)
    assert code is not None
    offsets: tuple[float, float] | None = None
    radius: float | None = None
    if is_arc:
        ia, ib, _ = _PLANES[new.plane]
        missing = [_AXIS_LETTERS[i] for i in (ia, ib) if i >= naxes]
        if missing:
            raise _WordError(
                code_text,
                f"an arc in the {new.plane} plane needs a {missing[0]} axis, the group has "
                f"{', '.join(axes)} (allowed: arcs in a plane of the group's axes)",
            )
        allowed = _OFFSET_LETTERS[new.plane]
        for w in offset_words:
            if w.letter not in allowed:
                raise _WordError(
                    w.text,
                    f"{w.letter} is not a centre offset in the {new.plane} plane "
                    f"({_PLANE_CODE[new.plane]}; allowed: {allowed[0]}, {allowed[1]})",
                )
        if offset_words and r_word is not None:
            raise _WordError(
                r_word.text,
                f"arc with both I/J/K and R (allowed: centre offsets {allowed[0]}/{allowed[1]} "
                "or a radius R)",
            )
        if not offset_words and r_word is None:
            raise _WordError(
                code_text,
                f"arc with neither centre offsets nor radius (allowed: {allowed[0]}/{allowed[1]} "
                "or R)",
            )
        if r_word is not None:
            if r_word.value == 0.0:
                raise _WordError(r_word.text, "arc radius must be non-zero (allowed: R > 0, R < 0)")
            if not any(_AXIS_LETTERS.index(w.letter) in (ia, ib) for w in axis_words):
                raise _WordError(
                    r_word.text,
                    f"an R arc needs an end point in the plane (allowed: with "
                    f"{_AXIS_LETTERS[ia]} and/or {_AXIS_LETTERS[ib]}; a full circle needs "
                    f"{allowed[0]}/{allowed[1]})",
                )
            radius = r_word.value * new.unit
        else:
            # the offset along axis X/Y/Z is the I/J/K word (G18: first axis Z, so K first)
            oa = letters.get("IJK"[ia])
            ob = letters.get("IJK"[ib])
            offsets = (
                oa.value * new.unit if oa is not None else 0.0,
                ob.value * new.unit if ob is not None else 0.0,
            )
    feed: float | None = None
    if code != "G0":
        if new.feed is None and not modal.feed_missing_reported:
            raise _FeedMissingError(
                code_text, "F word missing (allowed: a feed rate F > 0 before or on this line)"
            )
        feed = new.feed  # None only after the error was reported: the program is refused
    targets: list[float | None] = [None] * naxes
    for w in axis_words:
        targets[_AXIS_LETTERS.index(w.letter)] = w.value * new.unit
    block = _Block(
        line=line_no,
        number=number,
        text=text,
        code=code,
        targets=tuple(targets),
        incremental=new.incremental,
        plane=new.plane,
        offsets=offsets,
        radius=radius,
        radius_text=r_word.text if r_word is not None else "",
        turns=turns,
        feed=feed,
        exact_stop=new.exact_stop,
        tolerance=None if new.exact_stop else new.tolerance,
        unit=new.unit,
    )
    return _LineResult(block, end_program, new)


def _add_group(groups: dict[str, tuple[str, str]], group: str, code: str, text: str) -> None:
    if group in groups:
        raise _WordError(
            text,
            f"second {_GROUP_NAMES[group]} on the line ({groups[group][1]} already; "
            "allowed: one per modal group)",
        )
    groups[group] = (code, text)


def _check_axes(axes: Sequence[str], path: str) -> tuple[str, ...]:
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
    return names


def parse_gcode(
    text: str, path: str = "<string>", axes: Sequence[str] = ("x", "y", "z")
) -> GcodeProgram:
    """Parse and validate a G-code program for a group with ``axes`` (X, Y, Z in this order).

    Every syntax and modal error of the text is collected; if there is any, one
    :class:`GcodeError` lists them all (at most 100), each ``PATH:LINE: WORD: problem
    (allowed: ...)``. The returned program is immutable; resolve it with
    :meth:`GcodeProgram.moves`.
    """
    names = _check_axes(axes, path)
    modal = _Modal()
    blocks: list[_Block] = []
    errors: list[str] = []
    percent_seen = False
    lines = text.replace("\r\n", "\n").replace("\r", "\n").split("\n")
    for idx, raw in enumerate(lines, start=1):
        stripped = raw.strip()
        try:
            if stripped.startswith("%"):
                if _split(stripped[1:]):
                    raise _WordError("%", "text after % (allowed: % alone on its line)")
                if percent_seen:
                    break
                percent_seen = True
                continue
            words = _split(raw)
            if not words:
                continue
            res = _parse_line(words, modal, names, idx, stripped)
        except _WordError as exc:
            errors.append(f"{path}:{idx}: {exc.word}: {exc.message}")
            if len(errors) >= _MAX_ERRORS:
                errors.append(f"{path}: too many errors, stopped at line {idx}")
                break
            if isinstance(exc, _FeedMissingError):
                modal.feed_missing_reported = True
            continue
        modal = res.modal
        if res.block is not None:
            blocks.append(res.block)
        if res.end_program:
            break
    if errors:
        raise GcodeError(errors)
    return GcodeProgram(path, names, tuple(blocks))


def load_gcode(path: str | FilePath, axes: Sequence[str] = ("x", "y", "z")) -> GcodeProgram:
    """Read and parse a G-code file (UTF-8); an unreadable file is a :class:`GcodeError`."""
    p = FilePath(path)
    try:
        text = p.read_text(encoding="utf-8")
    except OSError as exc:
        raise GcodeError(f"{p}: cannot read: {exc.strerror or exc}") from None
    except UnicodeDecodeError:
        raise GcodeError(f"{p}: not a UTF-8 text file") from None
    return parse_gcode(text, str(p), axes)


# ------------------------------------------------------------------------------- resolving


@dataclass(frozen=True, slots=True)
class GcodeProgram:
    """A parsed, validated G-code program (immutable): ``path`` (for messages), ``axes`` (the
    group axes X, Y, Z map to) and the motion lines. :meth:`moves` resolves them."""

    path: str
    axes: tuple[str, ...]
    _blocks: tuple[_Block, ...] = field(repr=False)

    def __len__(self) -> int:
        """Number of motion lines (moves before zero-length ones are skipped)."""
        return len(self._blocks)

    def moves(
        self, start: Sequence[float], *, skipped: list[str] | None = None
    ) -> Iterator[GcodeMove]:
        """The moves from the group position ``start`` [m] (one value per axis), lazily.

        Guarantees: each move starts where the previous one ended (exactly); absolute (G90)
        targets are the programmed values, incremental (G91) ones the sum of the previous end
        and the word; arcs have a centre equidistant from start and end (an I/J/K centre whose
        start/end radii differ by at most 1e-6 relative is moved onto the chord's perpendicular
        bisector, by at most that much). A zero-length move is skipped (not yielded) and
        reported: appended to ``skipped`` as ``PATH:LINE: TEXT: zero-length move skipped`` and
        logged at INFO level. Geometric errors raise :class:`GcodeError` at the move's line
        when the generator reaches it.
        """
        pos = self._check_start(start)
        return self._resolve(pos, skipped)

    def _check_start(self, start: Sequence[float]) -> list[float]:
        n = len(self.axes)
        try:
            pos = [float(v) for v in start]
        except (TypeError, ValueError):
            raise GcodeError(
                f"{self.path}: start: must be {n} numbers (one per axis {', '.join(self.axes)})"
            ) from None
        if len(pos) != n or not all(math.isfinite(v) for v in pos):
            raise GcodeError(
                f"{self.path}: start: must be {n} finite numbers (one per axis "
                f"{', '.join(self.axes)}), got {list(start)!r}"
            )
        return pos

    def _resolve(self, pos: list[float], skipped: list[str] | None) -> Iterator[GcodeMove]:
        cur = tuple(pos)
        for b in self._blocks:
            end = tuple(
                c if t is None else (c + t if b.incremental else t)
                for c, t in zip(cur, b.targets, strict=True)
            )
            center: tuple[float, ...] | None = None
            if b.code in ("G2", "G3"):
                end, center = self._arc(b, cur, end)
            elif _same_point(cur, end):
                msg = f"{self.path}:{b.line}: {b.text}: zero-length move skipped (no-op)"
                _log.info("%s", msg)
                if skipped is not None:
                    skipped.append(msg)
                continue
            yield GcodeMove(
                line=b.line,
                number=b.number,
                text=b.text,
                kind=_KINDS[b.code],
                start=cur,
                end=end,
                center=center,
                plane=b.plane,
                turns=b.turns,
                feed=b.feed,
                exact_stop=b.exact_stop,
                tolerance=b.tolerance,
            )
            cur = end

    def _error(self, b: _Block, word: str, message: str) -> GcodeError:
        return GcodeError(f"{self.path}:{b.line}: {word}: {message}")

    def _arc(
        self, b: _Block, start: tuple[float, ...], end: tuple[float, ...]
    ) -> tuple[tuple[float, ...], tuple[float, ...]]:
        """The arc's (possibly snapped) end point and its centre; raises GcodeError."""
        ia, ib, _ = _PLANES[b.plane]
        u = b.unit
        un = _unit_name(u)
        sa, sb, ea, eb = start[ia], start[ib], end[ia], end[ib]
        chord = math.hypot(ea - sa, eb - sb)
        scale = max(1.0, abs(sa), abs(sb), abs(ea), abs(eb))
        if b.radius is not None:
            r_abs = abs(b.radius)
            if chord <= _SAME_POINT_RTOL * max(scale, r_abs):
                raise self._error(
                    b,
                    b.radius_text,
                    "an R arc cannot end where it starts (allowed: a full circle with "
                    f"{_OFFSET_LETTERS[b.plane][0]}/{_OFFSET_LETTERS[b.plane][1]})",
                )
            half = chord / 2.0
            if half > r_abs * (1.0 + _R_TINY):
                raise self._error(
                    b,
                    b.radius_text,
                    f"radius {_fmt(r_abs / u)} {un} too small for the chord (allowed: |R| >= "
                    f"half the distance from start to end, {_fmt(half / u)} {un})",
                )
            h = math.sqrt(max(r_abs * r_abs - half * half, 0.0))
            ux, uy = (ea - sa) / chord, (eb - sb) / chord
            ccw = b.code == "G3"
            # centre left of the chord (rotated +90 deg about the normal) for a short ccw or a
            # long cw arc
            side = 1.0 if ccw == (b.radius > 0.0) else -1.0
            ca = (sa + ea) / 2.0 - side * h * uy
            cb = (sb + eb) / 2.0 + side * h * ux
        else:
            assert b.offsets is not None
            ca, cb = sa + b.offsets[0], sb + b.offsets[1]
            r0 = math.hypot(sa - ca, sb - cb)
            r1 = math.hypot(ea - ca, eb - cb)
            word = "G2" if b.code == "G2" else "G3"
            if not r0 > _SAME_POINT_RTOL * scale:
                raise self._error(
                    b, word, "zero radius: the centre is the start point (allowed: I/J/K != 0)"
                )
            if not r1 > _SAME_POINT_RTOL * scale:
                raise self._error(
                    b, word, "zero radius: the centre is the end point (allowed: I/J/K != 0)"
                )
            tol = max(ARC_RADIUS_RTOL * max(r0, r1), ARC_RADIUS_ATOL)
            if abs(r1 - r0) > tol:
                raise self._error(
                    b,
                    word,
                    f"radius to the end {_fmt(r1 / u)} {un} differs from radius to the start "
                    f"{_fmt(r0 / u)} {un} (allowed: a difference up to {ARC_RADIUS_RTOL:g} "
                    "relative)",
                )
            if chord <= _SAME_POINT_RTOL * max(scale, r0):
                # full circle: the end is the start in the plane
                snapped = list(end)
                snapped[ia], snapped[ib] = sa, sb
                end = tuple(snapped)
            else:
                # move the centre onto the perpendicular bisector of the chord
                ux, uy = (ea - sa) / chord, (eb - sb) / chord
                shift = (ca - (sa + ea) / 2.0) * ux + (cb - (sb + eb) / 2.0) * uy
                if abs(shift) > tol:
                    raise self._error(
                        b,
                        word,
                        f"radius to the end {_fmt(r1 / u)} {un} and to the start {_fmt(r0 / u)} "
                        f"{un}: start and end are too close for that difference (the centre "
                        f"would move by {_fmt(abs(shift) / u)} {un}; allowed: "
                        f"{_fmt(tol / u)} {un})",
                    )
                ca -= shift * ux
                cb -= shift * uy
        c = list(start)
        c[ia], c[ib] = ca, cb
        return end, tuple(c)


def _same_point(a: Sequence[float], b: Sequence[float]) -> bool:
    scale = max(1.0, *(abs(v) for v in a), *(abs(v) for v in b))
    return math.dist(a, b) <= _SAME_POINT_RTOL * scale


# ------------------------------------------------------------------------------- paths


def move_path(move: GcodeMove) -> Path:
    """The geometric path of a move: a :class:`Line`, an :class:`Arc` or a :class:`Helix`.

    Guarantees: the path starts at ``move.start`` and ends at ``move.end`` (to rounding), in
    the group's coordinates [m]. An arc turns about ``move.center`` in ``move.plane``,
    clockwise (``arc_cw``) or counter-clockwise (``arc_ccw``) seen from the positive side of
    the plane normal (+Z for XY, +Y for ZX, +X for YZ), through ``turns`` extra full turns; an
    arc whose end equals its start in the plane is a full circle; one that also moves along the
    plane normal is a :class:`Helix` (3-axis groups). A move whose fields are inconsistent
    (say a hand-made arc without centre) raises :class:`~motionplc.errors.PlanningError`.
    """
    p0 = np.asarray(move.start, dtype=float)
    p1 = np.asarray(move.end, dtype=float)
    dim = p0.size
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
    ia, ib, inn = _PLANES[move.plane]
    if max(ia, ib) >= dim:
        raise PlanningError(f"move.plane: the {move.plane} plane needs 3 axes, got {dim}")
    c = np.asarray(move.center, dtype=float)
    # work in 3-D (X, Y, Z), the group's coordinates first
    s3, e3, c3 = (np.pad(v, (0, 3 - dim)) for v in (p0, p1, c))
    normal = np.zeros(3)
    normal[inn] = 1.0
    radial0 = (s3 - c3) - ((s3 - c3) @ normal) * normal
    radial1 = (e3 - c3) - ((e3 - c3) @ normal) * normal
    r = float(np.linalg.norm(radial0))
    if not r > 0.0:
        raise PlanningError("move.center: the start lies on the arc's axis (zero radius)")
    x = radial0 / r
    y = np.cross(normal, x)
    cw = move.kind == "arc_cw"
    if cw:
        y = -y
    chord = float(np.linalg.norm(radial1 - radial0))
    scale = max(1.0, r, float(np.max(np.abs(np.concatenate([s3, e3])))))
    if chord <= _SAME_POINT_RTOL * scale:
        phi = 2.0 * math.pi
    else:
        phi = math.atan2(float(radial1 @ y), float(radial1 @ x)) % (2.0 * math.pi)
    phi += 2.0 * math.pi * move.turns
    rise = float((e3 - s3) @ normal)
    if abs(rise) <= _SAME_POINT_RTOL * scale:
        base = c3 - ((c3 - s3) @ normal) * normal  # the centre at the start's height
        return Arc(base[:dim], r, x[:dim], y[:dim], phi)
    if dim != 3:  # pragma: no cover - the normal axis of a plane of a 2-axis group is not one
        raise PlanningError("move.end: a helix needs 3 axes")
    return Helix(s3, c3, normal, phi, rise * 2.0 * math.pi / phi, clockwise=cw)
