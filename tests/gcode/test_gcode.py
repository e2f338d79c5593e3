"""The G-code subset: located errors, units, modes, arcs in every plane, round trips, peers."""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from motionplc.errors import ConfigError, MotionPlcError, PlanningError
from motionplc.gcode import (
    INCH,
    GcodeError,
    GcodeMove,
    GcodeProgram,
    load_gcode,
    move_path,
    parse_gcode,
    split_words,
)
from motionplc.planning.paths import Arc, Helix, Line

CONFIGS = Path(__file__).resolve().parents[2] / "configs" / "gcode"
XYZ = ("x", "y", "z")
NORMALS = {"XY": (0.0, 0.0, 1.0), "ZX": (0.0, 1.0, 0.0), "YZ": (1.0, 0.0, 0.0)}
PLANE_AXES = {"XY": (0, 1), "ZX": (2, 0), "YZ": (1, 2)}
PLANE_CODE = {"XY": "G17", "ZX": "G18", "YZ": "G19"}


def resolve(text: str, start=(0.0, 0.0, 0.0), axes=XYZ, skipped=None) -> list[GcodeMove]:
    return list(parse_gcode(text, "t.ngc", axes).moves(start, skipped=skipped))


def error_lines(text: str, axes=XYZ, start=(0.0, 0.0, 0.0)) -> list[str]:
    with pytest.raises(GcodeError) as info:
        list(parse_gcode(text, "t.ngc", axes).moves(start))
    assert str(info.value) == "\n".join(info.value.errors)
    return list(info.value.errors)


# ------------------------------------------------------------------------ located errors

# (name, program, axes, [expected "t.ngc:LINE: WORD: ..." message prefixes])
ERROR_CASES = [
    ("dwell", "G4 P1", XYZ, ["t.ngc:1: G4: G4 (dwell) is not supported (allowed: G0 G1"]),
    ("tool length", "G0 X1\nG43 H1", XYZ, ["t.ngc:2: G43: G43 (tool length offset) is not"]),
    ("spindle", "M3 S1000", XYZ, ["t.ngc:1: M3: M3 (spindle on) is not supported"]),
    ("speed", "S1000", XYZ, ["t.ngc:1: S1000: spindle speed is not supported (allowed:"]),
    ("tool", "T1 M6", XYZ, ["t.ngc:1: T1: tool selection is not supported"]),
    ("o-word", "o100 sub", XYZ, ["t.ngc:1: O100: O-words (subroutines and control flow)"]),
    ("expression", "G1 F1 X[1+2]", XYZ, ["t.ngc:1: X[1+2]: expressions [...] are not"]),
    ("bare expression", "G1 F1 [1]", XYZ, ["t.ngc:1: [1]: expressions [...] are not"]),
    ("parameter", "G1 F1 X#1", XYZ, ["t.ngc:1: X#1: parameters #... are not supported"]),
    ("assignment", "#1=5", XYZ, ["t.ngc:1: #1=5: parameters #... are not supported"]),
    ("letter alone", "G1 F100 X", XYZ, ["t.ngc:1: X: letter without a number (allowed:"]),
    ("number alone", "G1 F100 X1 2.5", XYZ, ["t.ngc:1: 2.5: number without a letter"]),
    ("space in number", "G1 F100 X1 .5", XYZ, ["t.ngc:1: .5: number without a letter"]),
    ("two motions", "G0 G1 X1", XYZ, ["t.ngc:1: G1: second motion code on the line (G0"]),
    ("two planes", "G17 G18", XYZ, ["t.ngc:1: G18: second plane code on the line (G17"]),
    ("two units", "G20 G21", XYZ, ["t.ngc:1: G21: second unit code on the line (G20"]),
    ("two modes", "G90 G91", XYZ, ["t.ngc:1: G91: second distance-mode code on the line"]),
    ("two path modes", "G61 G64", XYZ, ["t.ngc:1: G64: second path-control code on the"]),
    ("two ends", "M2 M30", XYZ, ["t.ngc:1: M30: second program-end code on the line"]),
    ("two X", "G1 F1 X1 X2", XYZ, ["t.ngc:1: X2: second X word on the line (X1 already"]),
    ("two F", "F1 F2", XYZ, ["t.ngc:1: F2: second F word on the line"]),
    (
        "no Z axis",
        "G0 X1 Z1",
        ("x", "y"),
        ["t.ngc:1: Z1: the group has no Z axis (allowed: its axes X=x, Y=y)"],
    ),
    (
        "no Y axis",
        "G0 Y1",
        ("s",),
        ["t.ngc:1: Y1: the group has no Y axis (allowed: its axes X=s)"],
    ),
    (
        "arc, 1 axis",
        "F1 G2 X1 I1",
        ("s",),
        ["t.ngc:1: G2: an arc in the XY plane needs a Y axis, the group has s"],
    ),
    ("ZX plane, 2 axes", "G18", ("x", "y"), ["t.ngc:1: G18: the ZX plane needs a Z axis"]),
    ("A axis", "G0 A1", XYZ, ["t.ngc:1: A1: A axis word is not supported"]),
    ("arc neither", "F1 G2 X1 Y1", XYZ, ["t.ngc:1: G2: arc with neither centre offsets nor"]),
    ("arc both", "F1 G3 X1 Y1 I1 R1", XYZ, ["t.ngc:1: R1: arc with both I/J/K and R"]),
    (
        "arc off-plane offset",
        "F1 G2 X1 K1",
        XYZ,
        ["t.ngc:1: K1: K is not a centre offset in the XY plane (G17; allowed: I, J)"],
    ),
    ("arc G18 J", "F1 G18 G2 X1 J1", XYZ, ["t.ngc:1: J1: J is not a centre offset in the ZX"]),
    ("arc G19 I", "F1 G19 G2 Y1 I1", XYZ, ["t.ngc:1: I1: I is not a centre offset in the YZ"]),
    ("R zero", "F1 G2 X1 R0", XYZ, ["t.ngc:1: R0: arc radius must be non-zero"]),
    ("R without end", "F1 G2 Z1 R1", XYZ, ["t.ngc:1: R1: an R arc needs an end point in the"]),
    ("I without arc", "G1 F1 X1 I1", XYZ, ["t.ngc:1: I1: I word without an arc (allowed:"]),
    ("R without arc", "G0 X1 R1", XYZ, ["t.ngc:1: R1: R word without an arc"]),
    ("P stray", "G1 F1 X1 P2", XYZ, ["t.ngc:1: P2: P word without G64 or an arc"]),
    ("P turns", "F1 G2 X1 I1 P1.5", XYZ, ["t.ngc:1: P1.5: arc turns must be an integer >= 1"]),
    ("P ambiguous", "F1 G2 G64 X2 I1 P1", XYZ, ["t.ngc:1: P1: P with both G64 and an arc"]),
    ("G64 P0", "G64 P0", XYZ, ["t.ngc:1: P0: G64 tolerance must be > 0"]),
    ("F missing", "G0 X1\nG1 X2", XYZ, ["t.ngc:2: G1: F word missing (allowed: a feed rate"]),
    ("F missing arc", "G2 X1 I1", XYZ, ["t.ngc:1: G2: F word missing"]),
    ("F zero", "F0", XYZ, ["t.ngc:1: F0: feed rate must be > 0"]),
    ("F with unit change", "G20 F10", XYZ, ["t.ngc:1: F10: F on the line that changes the"]),
    ("axis without mode", "X1", XYZ, ["t.ngc:1: X1: axis word without a motion mode"]),
    ("N not first", "G0 N10 X1", XYZ, ["t.ngc:1: N10: line number not first on the line"]),
    ("N fraction", "N1.5 G0 X1", XYZ, ["t.ngc:1: N1.5: line number must be an integer"]),
    ("unclosed comment", "G0 X1 (oops", XYZ, ["t.ngc:1: (: unclosed comment"]),
    ("nested comment", "G0 X1 (a (b) c)", XYZ, ["t.ngc:1: (: nested comment"]),
    ("block delete", "/G0 X1", XYZ, ["t.ngc:1: /: block delete is not supported"]),
    ("stray char", "G0 X1 *12", XYZ, ["t.ngc:1: *: unexpected character '*'"]),
    ("percent text", "% G0 X1", XYZ, ["t.ngc:1: %: text after % (allowed: % alone"]),
    ("G fraction", "G1.5", XYZ, ["t.ngc:1: G1.5: G1.5 (unknown G code) is not supported"]),
    ("exact path", "G61.1", XYZ, ["t.ngc:1: G61.1: G61.1 (exact path mode) is not"]),
    ("M fraction", "M2.5", XYZ, ["t.ngc:1: M2.5: not an M code"]),
    ("exponent", "G0 X1e3", XYZ, ["t.ngc:1: E3: E word is not supported"]),
    ("huge", "G0 X" + "9" * 400, XYZ, ["t.ngc:1: X999999999999999999999"]),
    (
        "too large",
        "G0 X1000000000000000",
        XYZ,
        ["t.ngc:1: X1000000000000000: number out of range (allowed: |value| < 1e+15)"],
    ),
    (
        "every line reported",
        "G0 X1\nM3\nG0 Y1\nT2\nG1 X3\nG1 X4",
        XYZ,
        ["t.ngc:2: M3:", "t.ngc:4: T2:", "t.ngc:5: G1: F word missing"],
    ),
]


@pytest.mark.parametrize(("name", "text", "axes", "expected"), ERROR_CASES)
def test_located_error(name: str, text: str, axes: tuple[str, ...], expected: list[str]) -> None:
    errors = error_lines(text, axes)
    assert len(errors) == len(expected), errors
    for got, want in zip(errors, expected, strict=True):
        assert got.startswith(want), (got, want)
        assert "allowed: " in got and got.endswith(")"), got


def test_split_words_reports_its_location() -> None:
    words = split_words("n7 g01x-.5 (c) Y 2. ; z9")
    assert [(w.letter, w.value, w.text) for w in words] == [
        ("N", 7.0, "N7"),
        ("G", 1.0, "G01"),
        ("X", -0.5, "X-.5"),
        ("Y", 2.0, "Y2."),
    ]
    with pytest.raises(GcodeError, match=r"^p\.ngc:4: X: letter without a number"):
        split_words("G1 X", "p.ngc", 4)


def test_error_is_a_located_motionplc_error(tmp_path: Path) -> None:
    f = tmp_path / "prog.ngc"
    f.write_text("G21\n(ok)\nG1 F100 X1 M3\n")
    with pytest.raises(GcodeError) as info:
        load_gcode(f)
    assert isinstance(info.value, MotionPlcError) and isinstance(info.value, ConfigError)
    assert info.value.errors == (
        f"{f}:3: M3: M3 (spindle on) is not supported (allowed: M2, M30 program end)",
    )


def test_unreadable_file_is_a_gcode_error(tmp_path: Path) -> None:
    with pytest.raises(GcodeError, match=r"missing\.ngc: cannot read"):
        load_gcode(tmp_path / "missing.ngc")
    f = tmp_path / "bin.ngc"
    f.write_bytes(b"G0 X1\n\xff\xfe\n")
    with pytest.raises(GcodeError, match=r"bin\.ngc: not a UTF-8 text file"):
        load_gcode(f)


def test_bad_axes_and_start() -> None:
    with pytest.raises(GcodeError, match="axes: must be 1 to 3 axis names"):
        parse_gcode("G0 X1", axes=("a", "b", "c", "d"))
    with pytest.raises(GcodeError, match="axes: names must be distinct"):
        parse_gcode("G0 X1", axes=("a", "a"))
    prog = parse_gcode("G0 X1", "p.ngc")
    with pytest.raises(GcodeError, match=r"p\.ngc: start: must be 3 finite numbers"):
        prog.moves((0.0, 0.0))  # raised at the call, not at the first next()
    with pytest.raises(GcodeError, match="start: must be 3 finite numbers"):
        prog.moves((0.0, math.nan, 0.0))


def test_many_errors_are_capped() -> None:
    errors = error_lines("M3\n" * 150)
    assert len(errors) == 101
    assert errors[-1] == "t.ngc: too many errors, stopped at line 100"


# ------------------------------------------------------------- geometric errors (moves())


def test_radius_too_small_is_located_at_the_move() -> None:
    prog = parse_gcode("G21 F100\nG0 X0 Y0\n\nN7 G2 X30 Y0 R10\n", "r.ngc")
    with pytest.raises(GcodeError) as info:
        list(prog.moves((0.0, 0.0, 0.0)))
    assert info.value.errors == (
        "r.ngc:4: R10: radius 10 mm too small for the chord (allowed: |R| >= half the distance "
        "from start to end, 15 mm)",
    )


def test_inconsistent_centre_reports_both_radii() -> None:
    (err,) = error_lines("G20\nF10 G2 X2 Y0 I1.5 J0")
    assert err == (
        "t.ngc:2: G2: radius to the end 0.5 in differs from radius to the start 1.5 in "
        "(allowed: a difference up to 1e-06 relative)"
    )


def test_centre_within_tolerance_is_made_exact() -> None:
    # radius to the end differs by 5e-7 relative: accepted, centre moved onto the bisector
    (m,) = resolve("G21 F100 G3 X20 Y0 I10.000005 J0")
    c = np.array(m.center)
    assert abs(np.linalg.norm(c - m.start) - np.linalg.norm(c - m.end)) < 1e-15
    assert np.linalg.norm(c - np.array([0.010000005, 0, 0])) <= 1e-6 * 0.01
    path = move_path(m)
    assert np.allclose(path.end, m.end, atol=1e-12)


def test_r_full_circle_is_an_error() -> None:
    (err,) = error_lines("F100 G2 X0 Y0 R5")
    assert err.startswith("t.ngc:1: R5: an R arc cannot end where it starts (allowed: a full ")


def test_zero_radius_is_an_error() -> None:
    (err,) = error_lines("F100 G2 X1 I0 J0")
    assert err.startswith("t.ngc:1: G2: zero radius: the centre is the start point")


def test_zero_length_moves_are_skipped_and_reported(caplog: pytest.LogCaptureFixture) -> None:
    skipped: list[str] = []
    text = "F600\nG1 X1\nN5 G1 X1\nG91 G0 X0 Y0\nG1 Y2\n"
    with caplog.at_level("INFO", logger="motionplc.gcode"):
        moves = resolve(text, skipped=skipped)
    assert [m.line for m in moves] == [2, 5]
    assert skipped == [
        "t.ngc:3: N5 G1 X1: zero-length move skipped (no-op)",
        "t.ngc:4: G91 G0 X0 Y0: zero-length move skipped (no-op)",
    ]
    assert [r.getMessage() for r in caplog.records] == skipped
    assert moves[1].start == moves[0].end


# ------------------------------------------------------------------------ units and modes


def test_units_inch_and_mm() -> None:
    moves = resolve("G20 G90\nF60\nG1 X1 Y-2.5\nG21\nG1 X10\nF1200\nG1 Z3")
    assert moves[0].end == pytest.approx((INCH, -2.5 * INCH, 0.0), abs=1e-15)
    assert INCH == 0.0254
    assert moves[0].feed == pytest.approx(60 * 0.0254 / 60)  # 60 in/min = 0.0254 m/s
    # the physical feed is kept across a unit change (LinuxCNC)
    assert moves[1].feed == pytest.approx(0.0254)
    assert moves[1].end == pytest.approx((0.010, -2.5 * INCH, 0.0), abs=1e-15)
    assert moves[2].feed == pytest.approx(1200 * 0.001 / 60)  # 0.02 m/s
    assert moves[2].end[2] == pytest.approx(0.003)


def test_unit_change_scales_arc_words_and_tolerance() -> None:
    (m,) = resolve("G20\nG64 P0.01\nF10 G91 G3 X2 Y2 I0 J2")
    assert m.tolerance == pytest.approx(0.01 * INCH)
    assert m.center == pytest.approx((0.0, 2 * INCH, 0.0))
    assert move_path(m).length == pytest.approx(math.pi * INCH)


def test_absolute_and_incremental_mix() -> None:
    text = "G21 F600\nG90 G1 X10 Y10\nG91 X5\nY-3 Z1\nG90 X0\nG91 G0 X1 Y1 Z1\nG90 Y7"
    ends = [m.end for m in resolve(text, start=(0.1, 0.2, 0.3))]
    want = [
        (0.010, 0.010, 0.3),
        (0.015, 0.010, 0.3),
        (0.015, 0.007, 0.301),
        (0.0, 0.007, 0.301),
        (0.001, 0.008, 0.302),
        (0.001, 0.007, 0.302),
    ]
    assert len(ends) == len(want)
    for got, exp in zip(ends, want, strict=True):
        assert got == pytest.approx(exp, abs=1e-15)


def test_incremental_arc_end_and_centre() -> None:
    (m,) = resolve("G91 F60 G2 X2 Y0 I1 J0", start=(0.1, 0.2, 0.0))
    assert m.end == pytest.approx((0.102, 0.2, 0.0))
    assert m.center == pytest.approx((0.101, 0.2, 0.0))  # I/J/K always from the start


def test_modal_exact_stop_and_blending() -> None:
    text = "F600\nG1 X1\nG64 P0.05\nG1 X2\nG0 X3\nG64\nG1 X4\nG61\nG1 X5\nG64 P0.2 G1 X6\nX7"
    got = [(m.exact_stop, m.tolerance) for m in resolve(text)]
    assert got == [
        (True, None),  # start state G61
        (False, pytest.approx(5e-5)),
        (False, pytest.approx(5e-5)),  # rapids blend too
        (False, None),  # G64 without P: the group's default
        (True, None),
        (False, pytest.approx(2e-4)),
        (False, pytest.approx(2e-4)),
    ]


def test_comments_numbers_case_percent_and_program_end() -> None:
    text = (
        "\n%\n"
        "( header: G4 M3 #1 [x] are ignored in comments )\n"
        "n10 g21 g90 ; a comment with G4 and (parens\n"
        "N20 f1200 (feed) g1 x 1.5 (spaces between letter and number) y-.5\n"
        "   \t\n"
        "N30G0X1Y2Z3\n"
        "G1 X+2. ; explicit plus sign, trailing point\n"
        "M30 (end)\n"
        "G4 this line is never read\n"
        "%\n"
    )
    moves = resolve(text)
    assert [(m.line, m.number) for m in moves] == [(5, 20), (7, 30), (8, None)]
    assert moves[0].text == "N20 f1200 (feed) g1 x 1.5 (spaces between letter and number) y-.5"
    assert moves[0].end == pytest.approx((0.0015, -0.0005, 0.0))
    assert moves[0].feed == pytest.approx(0.02)
    assert moves[1].kind == "rapid" and moves[1].feed is None
    assert moves[2].end == pytest.approx((0.002, 0.002, 0.003))


def test_second_percent_ends_the_program() -> None:
    assert len(resolve("%\nF1 G1 X1\n%\nM3 garbage")) == 1


def test_modal_settings_alone_make_no_move() -> None:
    assert resolve("G17 G21 G90 G64 P0.1 F100\nG2\nG1\nN5\n(c)\n") == []


def test_program_is_immutable() -> None:
    prog = parse_gcode("F1 G1 X1")
    (m,) = prog.moves((0, 0, 0))
    with pytest.raises(dataclasses.FrozenInstanceError):
        m.end = (1.0,)  # type: ignore[misc]
    with pytest.raises(dataclasses.FrozenInstanceError):
        prog.path = "x"  # type: ignore[misc]
    assert isinstance(prog, GcodeProgram) and len(prog) == 1 and prog.axes == XYZ


# ------------------------------------------------------------------------ arcs


def _rotate(v: np.ndarray, n: np.ndarray, angle: float) -> np.ndarray:
    """Rodrigues: ``v`` rotated by ``angle`` about the unit axis ``n`` (right-hand rule)."""
    return (
        v * math.cos(angle)
        + np.cross(n, v) * math.sin(angle)
        + n * float(n @ v) * (1.0 - math.cos(angle))
    )


def _fmt_mm(v_m: float) -> str:
    """Metres as a G-code number in mm: shortest round-trip digits, never an exponent."""
    return np.format_float_positional(float(v_m) * 1000.0, unique=True, trim="-")


def _check_arc(
    m: GcodeMove, center: np.ndarray, radius: float, sweep: float, ccw: bool, rise: float = 0.0
) -> None:
    """The move and its path: centre, radius, sense (seen from +normal), swept angle, ends."""
    n = np.array(NORMALS[m.plane])
    assert np.allclose(m.center, center, atol=1e-12)
    path = move_path(m)
    assert isinstance(path, Helix if rise else Arc)
    assert np.allclose(path.start, m.start, atol=1e-9)
    assert np.allclose(path.end, m.end, atol=1e-9)
    assert path.length == pytest.approx(math.hypot(radius * sweep, rise), rel=1e-9)
    u = np.linspace(0.0, path.length, 41)
    p, d1 = path.evaluate(u), path.evaluate(u, 1)
    radial = (p - center) - np.outer((p - center) @ n, n)
    assert np.allclose(np.linalg.norm(radial, axis=1), radius, rtol=1e-9)
    turn = np.cross(radial, d1) @ n
    assert np.all(turn > 0.0) if ccw else np.all(turn < 0.0)
    assert np.allclose((p - p[0]) @ n, rise * u / path.length, atol=1e-12)


@pytest.mark.parametrize("plane", ["XY", "ZX", "YZ"])
@pytest.mark.parametrize("code", ["G2", "G3"])
@pytest.mark.parametrize("form", ["IJK", "R+", "R-"])
def test_arc_in_every_plane_both_senses(plane: str, code: str, form: str) -> None:
    rng = np.random.default_rng([ord(c) for c in plane + code + form])
    n = np.array(NORMALS[plane])
    ia, ib = PLANE_AXES[plane]
    ccw = code == "G3"
    for _ in range(10):
        start = rng.uniform(-0.2, 0.2, 3)
        radius, phi = rng.uniform(0.005, 0.05), rng.uniform(0.0, 2 * math.pi)
        center = start.copy()
        center[ia] += radius * math.cos(phi)
        center[ib] += radius * math.sin(phi)
        sweep = {"IJK": rng.uniform(0.05, 6.2), "R+": rng.uniform(0.05, 3.1)}.get(
            form, rng.uniform(3.2, 6.2)
        )
        end = center + _rotate(start - center, n, sweep if ccw else -sweep)
        words = " ".join(f"{'XYZ'[k]}{_fmt_mm(end[k])}" for k in (ia, ib))
        if form == "IJK":
            words += " " + " ".join(f"{'IJK'[k]}{_fmt_mm(center[k] - start[k])}" for k in (ia, ib))
        else:
            words += f" R{_fmt_mm(radius if form == 'R+' else -radius)}"
        text = f"{PLANE_CODE[plane]} F1000 {code} {words}"
        (m,) = resolve(text, start=tuple(start))
        assert m.kind == ("arc_ccw" if ccw else "arc_cw") and m.plane == plane
        assert np.allclose(m.end, end, atol=1e-15)
        _check_arc(m, center, radius, sweep, ccw)
        # the planning package's own constructor (CircMode CENTER) agrees with the path
        ref = Arc.from_center(start, end, center, normal=n, clockwise=not ccw)
        u = np.linspace(0.0, ref.length, 9)
        assert np.allclose(move_path(m).evaluate(u), ref.evaluate(u), atol=1e-12)


def test_g18_sense_follows_the_right_hand_rule() -> None:
    # G18 G3 from +X of the centre turns towards -Z (counter-clockwise about +Y: Z -> X -> -Z)
    (m,) = resolve("G18 F100 G3 X0 Z-10 I-10 K0", start=(0.01, 0.0, 0.0))
    path = move_path(m)
    assert path.length == pytest.approx(0.01 * math.pi / 2)
    mid = path.evaluate(path.length / 2)
    assert mid == pytest.approx([0.01 * math.cos(math.pi / 4), 0.0, -0.01 * math.sin(math.pi / 4)])


def test_full_circles_and_turns() -> None:
    moves = resolve("F100\nG2 I10\nG3 J-5 P3", start=(0.0, 0.0, 0.0))
    assert moves[0].end == moves[0].start == (0.0, 0.0, 0.0)
    _check_arc(moves[0], np.array([0.01, 0.0, 0.0]), 0.01, 2 * math.pi, ccw=False)
    assert moves[1].turns == 2
    _check_arc(moves[1], np.array([0.0, -0.005, 0.0]), 0.005, 6 * math.pi, ccw=True)


def test_full_circle_with_rounding_in_the_end_point() -> None:
    # 0.1 + 0.2 != 0.3 in binary; the end is the start to rounding: a full circle, snapped
    (_, _, m) = resolve("F100 G91 G1 X0.1\nX0.2\nG90 G2 X0.3 I5", start=(0.0, 0.0, 0.0))
    assert m.start[0] != 0.0003  # 0.0001 + 0.0002
    assert m.end == m.start
    assert move_path(m).length == pytest.approx(2 * math.pi * 0.005)


@pytest.mark.parametrize("plane", ["XY", "ZX", "YZ"])
@pytest.mark.parametrize("code", ["G2", "G3"])
def test_helix(plane: str, code: str) -> None:
    ia, ib = PLANE_AXES[plane]
    (inn,) = {0, 1, 2} - {ia, ib}
    start = np.array([0.01, 0.02, 0.03])
    center = start.copy()
    center[ia] += 0.004
    center[ib] -= 0.003
    ccw = code == "G3"
    sweep = 2.5
    n = np.array(NORMALS[plane])
    end = center + _rotate(start - center, n, sweep if ccw else -sweep)
    end[inn] += 0.007
    words = " ".join(f"{'XYZ'[k]}{_fmt_mm(end[k])}" for k in range(3))
    offs = " ".join(f"{'IJK'[k]}{_fmt_mm(center[k] - start[k])}" for k in (ia, ib))
    (m,) = resolve(f"{PLANE_CODE[plane]} F100 {code} {words} {offs} P2", start=tuple(start))
    assert m.turns == 1
    _check_arc(m, center, 0.005, sweep + 2 * math.pi, ccw, rise=0.007)


def test_arcs_of_a_two_axis_group() -> None:
    moves = resolve("F100 G3 X10 Y10 R10\nG2 X20 Y0 R-10\nG2 I-5", start=(0, 0), axes=("x", "y"))
    p = [move_path(m) for m in moves]
    assert all(isinstance(q, Arc) and q.dim == 2 for q in p)
    assert [q.length for q in p] == pytest.approx(
        [0.005 * math.pi, 0.015 * math.pi, 0.01 * math.pi]
    )


def test_move_path_of_lines_and_bad_moves() -> None:
    (m,) = resolve("G0 X3 Y4")
    path = move_path(m)
    assert isinstance(path, Line) and path.length == pytest.approx(0.005)
    with pytest.raises(PlanningError, match="move.center"):
        move_path(dataclasses.replace(m, kind="arc_cw"))
    with pytest.raises(PlanningError, match="move.kind"):
        move_path(dataclasses.replace(m, kind="spline"))


# ------------------------------------------------------------------------ properties

_VALUE = st.integers(-99999, 99999).map(lambda k: k / 1000.0)  # |v| < 100 program units


@st.composite
def _linear_program(draw: st.DrawFn) -> list[tuple[str, dict[str, float]]]:
    items: list[tuple[str, dict[str, float]]] = []
    for _ in range(draw(st.integers(1, 25))):
        kind = draw(st.sampled_from(["G0", "G1", "G1", "G90", "G91", "G20", "G21", "modal"]))
        if kind in ("G0", "G1", "modal"):
            letters = draw(st.sets(st.sampled_from("XYZ"), min_size=1))
            items.append((kind, {c: draw(_VALUE) for c in sorted(letters)}))
        else:
            items.append((kind, {}))
    return items


def _format_linear(items: list[tuple[str, dict[str, float]]]) -> str:
    lines = ["F500 G0"]  # a motion mode and a feed, so "modal" lines are moves
    for kind, words in items:
        code = "" if kind == "modal" else kind + " "
        lines.append(
            code + " ".join(f"{c}{v:g}" if v % 1 else f"{c}{v:.0f}" for c, v in words.items())
        )
    return "\n".join(lines)


@settings(max_examples=150, deadline=None)
@given(_linear_program(), st.tuples(_VALUE, _VALUE, _VALUE))
def test_random_linear_programs_end_at_the_cumulative_sum(items, start_mm) -> None:
    start = tuple(v * 0.001 for v in start_mm)
    skipped: list[str] = []
    moves = resolve(_format_linear(items), start=start, skipped=skipped)
    # independent model: a position per line, in metres
    pos, inc, unit = list(start), False, 0.001
    expected: list[tuple[int, tuple[float, ...]]] = []
    for line, (kind, words) in enumerate(items, start=2):
        if kind in ("G90", "G91"):
            inc = kind == "G91"
        elif kind in ("G20", "G21"):
            unit = 0.0254 if kind == "G20" else 0.001
        else:
            new = list(pos)
            for c, v in words.items():
                k = "XYZ".index(c)
                new[k] = pos[k] + v * unit if inc else v * unit
            if math.dist(new, pos) > 1e-12:
                expected.append((line, tuple(new)))
            pos = new
    assert [m.line for m in moves] == [line for line, _ in expected]
    prev = start
    for m, (_, end) in zip(moves, expected, strict=True):
        assert m.start == prev  # continuity is exact
        assert m.end == pytest.approx(end, abs=1e-12)
        prev = m.end
    assert len(moves) + len(skipped) == sum(1 for k, _ in items if k in ("G0", "G1", "modal"))


@st.composite
def _random_moves(draw: st.DrawFn) -> list[dict]:
    """Specs of moves in metres: lines and XY arcs (centre form or radius form)."""
    pos = np.zeros(3)
    specs = []
    coord = st.floats(-0.3, 0.3, allow_nan=False)
    for _ in range(draw(st.integers(1, 12))):
        kind = draw(st.sampled_from(["rapid", "linear", "arc_cw", "arc_ccw"]))
        spec = {
            "kind": kind,
            "number": draw(st.none() | st.integers(0, 99999)),
            "feed": draw(st.floats(0.001, 2.0)),
            "tolerance": draw(st.none() | st.just(-1.0) | st.floats(1e-6, 1e-3)),
        }
        if kind in ("rapid", "linear"):
            end = np.array([draw(coord), draw(coord), draw(coord)])
            if np.linalg.norm(end - pos) < 1e-6:
                continue
            spec["center"] = None
        else:
            radius = draw(st.floats(0.001, 0.2))
            phi0 = draw(st.floats(0.0, 2 * math.pi))
            sweep = draw(st.floats(0.01, 2 * math.pi - 0.01))
            center = pos - radius * np.array([math.cos(phi0), math.sin(phi0), 0.0])
            sign = 1.0 if kind == "arc_ccw" else -1.0
            end = center + radius * np.array(
                [math.cos(phi0 + sign * sweep), math.sin(phi0 + sign * sweep), 0.0]
            )
            end[2] = pos[2]
            spec["center"] = center
            # R arcs are ill-conditioned near a half circle: centre offsets there
            near_half = abs(sweep - math.pi) < 1e-3
            spec["form"] = "IJ" if near_half else draw(st.sampled_from(["IJ", "R"]))
            spec["r"] = radius if sweep <= math.pi else -radius
        spec["end"] = end
        specs.append(spec)
        pos = end
    return specs


def _format_moves(specs: list[dict]) -> str:
    lines = ["G21 G90 G17"]
    pos = np.zeros(3)
    for s in specs:
        words = []
        if s["number"] is not None:
            words.append(f"N{s['number']}")
        tol = s["tolerance"]
        words.append("G61" if tol is None else ("G64" if tol < 0 else f"G64 P{_fmt_mm(tol)}"))
        lines.append(" ".join(words))  # P goes on a line of its own (P after an arc: turns)
        words = [] if s["number"] is None else [f"N{s['number']}"]
        if s["kind"] != "rapid":
            words.append(f"F{_fmt_mm(s['feed'] * 60.0)}")
        words.append({"rapid": "G0", "linear": "G1", "arc_cw": "G2", "arc_ccw": "G3"}[s["kind"]])
        words += [f"{c}{_fmt_mm(v)}" for c, v in zip("XYZ", s["end"], strict=True)]
        if s["center"] is not None:
            if s["form"] == "IJ":
                words += [
                    f"I{_fmt_mm(s['center'][0] - pos[0])}",
                    f"J{_fmt_mm(s['center'][1] - pos[1])}",
                ]
            else:
                words.append(f"R{_fmt_mm(s['r'])}")
        lines.append(" ".join(words))
        pos = s["end"]
    return "\n".join(lines) + "\nM2\n"


@settings(max_examples=100, deadline=None)
@given(_random_moves())
def test_round_trip_moves_to_text_and_back(specs) -> None:
    text = _format_moves(specs)
    moves = resolve(text)
    assert len(moves) == len(specs)
    for m, s in zip(moves, specs, strict=True):
        assert m.kind == s["kind"]
        assert m.number == s["number"]
        assert m.end == pytest.approx(tuple(s["end"]), abs=1e-12)
        assert m.feed == (None if s["kind"] == "rapid" else pytest.approx(s["feed"], rel=1e-12))
        assert m.exact_stop == (s["tolerance"] is None)
        tol = s["tolerance"]
        assert m.tolerance == (None if tol is None or tol < 0 else pytest.approx(tol, rel=1e-12))
        if s["center"] is None:
            assert m.center is None
        else:
            assert np.allclose(m.center, s["center"], atol=1e-9)
            path = move_path(m)
            assert np.allclose(path.start, m.start, atol=1e-9)
            assert np.allclose(path.end, m.end, atol=1e-9)


# ------------------------------------------------------------------------ peer: pygcode

_PEER_WORD = st.one_of(
    st.tuples(st.sampled_from("GMgm"), st.integers(0, 99).map(str)),
    st.tuples(st.sampled_from("NnTt"), st.integers(1, 9999).map(str)),
    st.tuples(
        st.sampled_from("FXYZIJKRPSxyzijkrf"),
        st.one_of(
            st.integers(-9999, 9999).map(str),
            st.decimals(-1000, 1000, places=4, allow_nan=False, allow_infinity=False).map(str),
            st.integers(0, 9999).map(lambda k: f".{k}"),
            st.integers(0, 999).map(lambda k: f"-{k}."),
        ),
    ),
)
_COMMENT_TEXT = st.text(st.sampled_from("abc XYZ G1 12.5,:"), max_size=12)


@st.composite
def _peer_line(draw: st.DrawFn) -> str:
    parens = draw(st.booleans())
    parts = []
    for letter, value in draw(st.lists(_PEER_WORD, max_size=8)):
        parts.append(letter + draw(st.sampled_from(["", " "])) + value)
        if parens and draw(st.integers(0, 4)) == 0:
            parts.append(f"({draw(_COMMENT_TEXT)})")
    line = draw(st.sampled_from([" ", "", "  "])).join(parts)
    if not parens and draw(st.booleans()):
        line += f" ;{draw(_COMMENT_TEXT)}"
    return line


@settings(max_examples=300, deadline=None)
@given(_peer_line())
def test_word_splitting_agrees_with_pygcode(line: str) -> None:
    pytest.importorskip("pygcode")
    from pygcode.comment import split_line
    from pygcode.words import text2words

    ours = [(w.letter, w.value) for w in split_words(line)]
    block, _comment = split_line(line)  # pygcode's lexer without its modal-group checks
    theirs = [(w.letter, float(w.value)) for w in text2words(block)]
    assert ours == theirs


def test_pygcode_machine_agrees_on_absolute_and_incremental_positions() -> None:
    pygcode = pytest.importorskip("pygcode")
    rng = np.random.default_rng(7)
    for _ in range(40):
        lines = ["G21 G90 F100"]
        for _ in range(15):
            mode = rng.choice(["G90", "G91", ""])
            axes = [c for c in "XYZ" if rng.random() < 0.6] or ["X"]
            words = " ".join(f"{c}{rng.integers(-5000, 5000) / 100:g}" for c in axes)
            lines.append(f"{mode} {rng.choice(['G0', 'G1'])} {words}".strip())
        machine = pygcode.Machine()
        for text in lines:
            machine.process_block(pygcode.Line(text).block)
        moves = resolve("\n".join(lines))
        final = moves[-1].end if moves else (0.0, 0.0, 0.0)
        p = machine.pos
        assert final == pytest.approx((p.X * 0.001, p.Y * 0.001, p.Z * 0.001), abs=1e-12)


# ------------------------------------------------------------------------ shipped programs


@pytest.mark.parametrize("name", ["rounded_rectangle.ngc", "planes_helix.ngc"])
def test_shipped_programs_are_continuous(name: str) -> None:
    prog = load_gcode(CONFIGS / name)
    moves = list(prog.moves((0.0, 0.0, 0.0)))
    assert moves
    prev = (0.0, 0.0, 0.0)
    for m in moves:
        path = move_path(m)
        assert m.start == prev
        assert np.allclose(path.start, m.start, atol=1e-9) and np.allclose(
            path.end, m.end, atol=1e-9
        )
        prev = m.end


def test_rounded_rectangle_program() -> None:
    moves = list(load_gcode(CONFIGS / "rounded_rectangle.ngc").moves((0.0, 0.0, 0.0)))
    assert all(not m.exact_stop and m.tolerance == pytest.approx(1e-4) for m in moves)
    assert all(m.feed == pytest.approx(0.1) for m in moves if m.kind != "rapid")
    contour = [m for m in moves if 70 <= (m.number or 0) <= 140]
    assert [m.kind for m in contour] == ["linear", "arc_ccw"] * 4
    length = sum(move_path(m).length for m in contour)
    # 100..400 x 100..300 mm with 20 mm corners: 2 (260 + 160) + 2 pi 20 mm
    assert length == pytest.approx(0.84 + 2 * math.pi * 0.02, rel=1e-12)
    assert contour[-1].end == pytest.approx(contour[0].start)
    circle = [m for m in moves if m.number in (180, 190, 200)]
    assert sum(move_path(m).length for m in circle) == pytest.approx(4 * math.pi * 0.1)
