"""The RS274/NGC interpreter against hand-computed LinuxCNC results (motionplc.gcode)."""

from __future__ import annotations

import math

import pytest

from motionplc.gcode import (
    GcodeError,
    GcodeEvent,
    GcodeMove,
    Interpreter,
    MachineSetup,
    Tool,
    escape,
    move_path,
    parse_gcode,
)

XYZ = MachineSetup.for_axes(("x", "y", "z"))
XYZA = MachineSetup(
    axes={"X": 0, "Y": 1, "Z": 2, "A": 3}, names=("x", "y", "z", "a"), rotary=frozenset("A")
)


def run(text: str, setup: MachineSetup = XYZ, start=None) -> list[GcodeMove | GcodeEvent]:
    return list(Interpreter("t.ngc", setup, start, text=text).run())


def moves(text: str, setup: MachineSetup = XYZ, start=None) -> list[GcodeMove]:
    return [m for m in run(text, setup, start) if isinstance(m, GcodeMove)]


def ends_mm(text: str, setup: MachineSetup = XYZ) -> list[list[float]]:
    return [[round(v * 1000.0, 6) for v in m.end] for m in moves(text, setup)]


def error_of(text: str, setup: MachineSetup = XYZ) -> str:
    with pytest.raises(GcodeError) as exc:
        run(text, setup)
    return str(exc.value)


def test_modal_group_conflicts_and_unknown_words_are_located() -> None:
    assert "t.ngc:2: G1: G0 and G1 on one line are of the same modal group" in error_of(
        "G21\nG0 G1 X1\n"
    )
    assert "t.ngc:1: M5: M3 and M5" in error_of("M3 M5\n")
    assert "t.ngc:1: A1: the machine has no A axis" in error_of("G0 A1\n")
    assert "G41 (cutter radius compensation" in error_of("G41 D1\n")
    assert "t.ngc:1: G92: G92 and G1 both use the axis words" in error_of("G92 G1 X1 F1\n")
    assert "X1: axis word with G80" in error_of("G80 X1\n")
    assert "Q word with nothing on the line" in error_of("G1 X1 F1 Q2\n")


def test_work_offsets_g10_g92_g53_give_machine_coordinates() -> None:
    got = ends_mm(
        "G21 G90\n"
        "G10 L2 P1 X100 Y50 Z-10\n"  # G54 offsets
        "G0 X0 Y0 Z0\n"  # machine (100, 50, -10)
        "G10 L20 P2 X5 Y5 Z5\n"  # G55: the current point is (5, 5, 5) in G55
        "G55 G0 X0 Y0 Z0\n"  # machine (95, 45, -15)
        "G54 G92 X10 Y10\n"  # the current point, (-5, -5) in G54, becomes (10, 10)
        "G0 X20 Y20\n"  # machine 20 + 100 - 15 = 105, 55
        "G92.1\n"
        "G0 X1 Y1\n"  # machine (101, 51)
        "G53 G0 X3 Y4 Z-1\n"  # machine coordinates
        "G91 G0 X1\n"  # incremental
    )
    assert got == [
        [100.0, 50.0, -10.0],
        [95.0, 45.0, -15.0],
        [105.0, 55.0, -15.0],
        [101.0, 51.0, -15.0],
        [3.0, 4.0, -1.0],
        [4.0, 4.0, -1.0],
    ]


def test_tool_length_offsets_from_the_table_and_dynamic() -> None:
    setup = MachineSetup.for_axes(("x", "y", "z"), tools={1: Tool(1, {"Z": 0.025})})
    got = ends_mm(
        "G21 T1 M6\nG43 H1\nG0 Z0\nG43.1 Z-5\nG0 Z0\nG49\nG0 Z0\n",
        setup,
    )
    assert got == [[0.0, 0.0, 25.0], [0.0, 0.0, -5.0], [0.0, 0.0, 0.0]]
    assert "tool 7 is not in the tool table" in error_of("G43 H7\n", setup)


def test_parameters_expressions_functions_and_control_flow() -> None:
    got = ends_mm(
        "G21 F600\n"
        "#1 = 3 #<len> = [2 ** 3]\n"
        "#<_g> = [ATAN[1]/[1] + SQRT[16] + ABS[-1] + FIX[2.7] + FUP[2.1] + 7 MOD 4]\n"
        "o<sq> sub\n"
        "  G1 X#1 Y[#1 * 2]\n"
        "  o<sq> return [#1 + 1]\n"
        "o<sq> endsub\n"
        "o<sq> call [#<len>]\n"  # X8 Y16
        "G1 X#<_value>\n"  # X9
        "#2 = 0\n"
        "o10 while [#2 LT 2]\n"
        "  #2 = [#2 + 1]\n"
        "  o11 if [#2 EQ 1]\n"
        "    G1 Z-1\n"
        "  o11 else\n"
        "    G1 Z-2\n"
        "  o11 endif\n"
        "o10 endwhile\n"
        "o12 repeat [2]\n"
        "  G91 G1 Y1\n"
        "o12 endrepeat\n"
        "G90 G1 X[#<_g>]\n"  # 45 + 4 + 1 + 2 + 3 + 3 = 58
        "o13 do\n"
        "  #2 = [#2 - 1]\n"
        "o13 while [#2 GT 0]\n"
        "G1 Y#2\n"
    )
    assert got == [
        [8.0, 16.0, 0.0],
        [9.0, 16.0, 0.0],
        [9.0, 16.0, -1.0],
        [9.0, 16.0, -2.0],
        [9.0, 17.0, -2.0],
        [9.0, 18.0, -2.0],
        [58.0, 18.0, -2.0],
        [58.0, 0.0, -2.0],
    ]


def test_parameter_assignments_take_effect_after_the_line() -> None:
    got = ends_mm("G21 G0 X1\n#1 = 5 G0 X#1\nG0 X#1\n")
    assert got == [[1.0, 0.0, 0.0], [0.0, 0.0, 0.0], [5.0, 0.0, 0.0]]


def test_units_from_the_machine_and_arcs_with_linuxcnc_tolerance() -> None:
    inch = MachineSetup.for_axes(("x", "y", "z"), units="inch")
    assert ends_mm("G0 X1\n", inch) == [[25.4, 0.0, 0.0]]
    assert ends_mm("G0 X1\n") == [[1.0, 0.0, 0.0]]
    # end radius 10.01 against 10: 0.01 mm < 0.028 mm, LinuxCNC accepts it
    mv = moves("G21 G0 X0 Y0\nG2 X20.01 Y0 I10 J0 F100\n")[-1]
    assert mv.kind == "arc_cw"
    # 0.1 mm and 1 %: refused with the figures
    msg = error_of("G21 G0 X0 Y0\nG2 X20.1 Y0 I10 J0 F100\n")
    assert "t.ngc:2: G2: radius to the end 10.1 differs from the radius to the start 10" in msg


def test_helix_with_turns_is_one_move_and_the_path_ends_at_the_end() -> None:
    (m,) = moves("G21 G17 G0 X10 Y0 Z0\nG3 I-10 J0 Z-6 P3 F600\n")[1:]
    assert m.turns == 2 and m.kind == "arc_ccw"
    path = move_path(m)
    assert path.length == pytest.approx(math.hypot(3 * 2 * math.pi * 0.01, 0.006))
    assert list(path.evaluate(path.u_end)) == pytest.approx([0.01, 0.0, -0.006], abs=1e-12)
    # the feed applies to the XYZ length: duration = length / F
    assert m.duration == pytest.approx(path.length / 0.01)
    # a huge P is one arc (its turns a parameter, never expanded)
    (big,) = moves("G21 G0 X10 Y0\nG2 I-10 P100000000 F600\n")[1:]
    assert big.turns == 99_999_999


def test_rotary_axis_in_degrees_and_feed_on_the_linear_axes() -> None:
    ms = moves("G21 G1 X10 A90 F600\nG1 A180\n", XYZA)
    assert ms[0].end == pytest.approx((0.01, 0.0, 0.0, math.pi / 2))
    assert ms[0].duration == pytest.approx(1.0)  # 10 mm at 10 mm/s, A follows
    assert ms[1].duration == pytest.approx(9.0)  # 90 deg at 600 deg/min = 10 deg/s


def test_canned_cycles_expand_like_linuxcnc() -> None:
    got = ends_mm("G21 G0 X0 Y0 Z10\nG98 G81 X5 Y5 Z-3 R2 F100\nG99 X10\nG80\n")
    assert got == [
        [0.0, 0.0, 10.0],
        [5.0, 5.0, 10.0],
        [5.0, 5.0, 2.0],
        [5.0, 5.0, -3.0],
        [5.0, 5.0, 10.0],  # G98: back to the initial level
        [10.0, 5.0, 10.0],
        [10.0, 5.0, 2.0],
        [10.0, 5.0, -3.0],
        [10.0, 5.0, 2.0],  # G99: to R
    ]
    peck = ends_mm("G21 G0 X0 Y0 Z5\nG83 Z-5 R1 Q2.5 F100\n")
    assert [p[2] for p in peck[1:]] == [1.0, -1.5, 1.0, -0.5, -4.0, 1.0, -3.0, -5.0, 5.0]


def test_machine_events_in_order() -> None:
    items = run("G21 S1000 M3\nM8\nG4 P0.5\nM62 P0\nG0 X1\nM5 M9\nM2\n")
    kinds = [(i.kind, i.value) for i in items if isinstance(i, GcodeEvent)]
    assert kinds == [
        ("spindle", 1000.0),
        ("coolant", 1.0),
        ("dwell", 0.5),
        ("spindle", 0.0),
        ("coolant", 0.0),
        ("coolant", 0.0),
        ("end", 2.0),
    ]
    mv = next(i for i in items if isinstance(i, GcodeMove))
    assert mv.outputs == ((0, True),)


def test_path_control_modes() -> None:
    ms = moves("G21 G61 G0 X1\nG61.1 G0 X2\nG64 G0 X3\nG64 P0.5 Q0.1 G0 X4\nG64 P0 G0 X5\n")
    assert [(m.exact_path, m.exact_stop, m.tolerance, m.naive_tolerance) for m in ms] == [
        (True, False, None, None),
        (False, True, None, None),
        (False, False, None, None),
        (False, False, pytest.approx(0.0005), pytest.approx(0.0001)),
        (False, False, None, None),
    ]


def test_validate_collects_every_error_with_file_and_line() -> None:
    with pytest.raises(GcodeError) as exc:
        parse_gcode("G21\nG1 X1\nG0 Q1 X1\nG2 X5 R1 F1\nM2\n", "p.ngc")
    errs = exc.value.errors
    assert errs[0].startswith("p.ngc:2: G1: F word missing")
    assert errs[1].startswith("p.ngc:3: Q1:")
    assert errs[2].startswith("p.ngc:4: R1: radius 1 too small")


def test_hostile_input_is_bounded_and_escaped() -> None:
    msg = error_of("G1 X1\x1b[31m\n")
    assert "\x1b" not in msg and "\\x1b" in msg
    assert escape("a\x07b") == "a\\x07b"
    assert "longer than 1024" in error_of("G0 X1 " + "(c)" * 400 + "\n")
    loop = "#1=0\no1 while [#1 GE 0]\n#1=[#1+1]\no1 endwhile\n"
    assert "blocks executed" in error_of(loop, MachineSetup.for_axes("xyz", max_blocks=10_000))
    assert "nested deeper" in error_of("G0 X" + "[" * 100 + "1" + "]" * 100 + "\n")
    rec = "o1 sub\no1 call\no1 endsub\no1 call\n"
    assert "nested deeper than 64" in error_of(rec)


@pytest.mark.parametrize(
    ("text", "line", "reads"),
    [
        ("#1=0\no1 while [1]\n#1=[#1+1]\no1 endwhile\n", 2, "reads no parameter"),
        ("#1=1\n#2=0\no7 while [#1 GT 0]\n#2=[#2+1]\no7 endwhile\n", 3, "reads #1, which"),
        ("#<a>=1\no<x> do\nG0 X1\nG0 X0\no<x> while [#<a>]\n", 5, "reads #<a>, which"),
        # nested: the inner loop never ends, found on the outer loop's first pass
        (
            "#1=0\no1 while [#1 LT 3]\n#1=[#1+1]\no2 while [#1]\nG0 X1\no2 endwhile\no1 endwhile\n",
            4,
            "reads #1, which",
        ),
    ],
)
def test_a_loop_that_cannot_end_is_found_at_its_line(text: str, line: int, reads: str) -> None:
    setup = MachineSetup.for_axes("xyz", max_blocks=10**9)  # found at once, not by the limit
    msg = error_of(text, setup)
    assert msg.startswith(f"t.ngc:{line}: O") and "this loop never ends" in msg
    assert reads in msg
    assert "\n" not in msg  # one error: the run ends at the loop


@pytest.mark.parametrize(
    "body",
    [
        "#1=[#1+1]\n",  # sets what the condition reads
        "o9 if [#2 GT 5]\no1 break\no9 endif\n#2=[#2+1]\n",  # a way out
        "o9 if [#2 GT 5]\nM2\no9 endif\n#2=[#2+1]\n",  # the program ends
        "#[1]=[#1+1]\n",  # a computed parameter number: not known statically
        "o<inc> call\n",  # a subroutine may set it
    ],
)
def test_loops_that_can_end_are_not_refused(body: str) -> None:
    text = "o<inc> sub\n#<_n>=[#<_n>+1]\no<inc> endsub\n#<_n>=0\n#1=0\n#2=0\n"
    text += "o1 while [[#1 + #<_n>] LT 8]\n" + body + "G0 X[#1+#<_n>+#2+1]\no1 endwhile\nM2\n"
    xs = [m.end[0] for m in moves(text)]
    assert 1 <= len(xs) <= 9 and len(set(xs)) == len(xs)


def test_a_condition_on_the_machine_state_is_left_to_the_block_limit() -> None:
    # #5420 is the X position, which the loop's moves change: not refused statically
    text = "G21 G0 X0\no1 while [#5420 LT 5]\nG91 G0 X1\no1 endwhile\nM2\n"
    assert [round(m.end[0] * 1000, 9) for m in moves(text)][-1] == 5.0


def test_a_repeat_longer_than_the_block_limit_is_refused_at_once() -> None:
    setup = MachineSetup.for_axes("xyz", max_blocks=1000)
    msg = error_of("o1 repeat [1000000000]\nG0 X1\nG0 X0\no1 endrepeat\n", setup)
    assert msg.startswith("t.ngc:1: O1: repeat of 1000000000 passes: more than the 999 blocks")
    # one with a way out is run (and ends by its break)
    text = "#1=0\no1 repeat [1000000000]\n#1=[#1+1]\no9 if [#1 GE 3]\no1 break\no9 endif\n"
    text += "G0 X[#1]\no1 endrepeat\nM2\n"
    assert len(moves(text, setup)) == 2


def test_compiled_lines_evaluate_afresh_each_pass() -> None:
    # the loop's lines are compiled once; every pass sees the parameters of that pass,
    # including a computed parameter number and functions
    text = "#1=0\n#10=0\no1 while [#1 LT 6]\n#[11+#1]=[SIN[#1*30]*2]\n"
    text += "G0 X[#[11+#1]] Y[ATAN[#1]/[1]] Z-[#1 MOD 4]\n#1=[#1+1]\no1 endwhile\nM2\n"
    got = [[round(v * 1000, 9) for v in m.end] for m in moves(text)]
    want = [
        [
            round(2 * math.sin(math.radians(30 * k)), 9),
            round(math.degrees(math.atan2(k, 1)), 9),
            -float(k % 4),
        ]
        for k in range(1, 6)  # k = 0 is the start point: a zero-length move, skipped
    ]
    assert len(got) == 5
    for g, w in zip(got, want, strict=True):
        assert g == pytest.approx(w, abs=1e-9)


def test_more_distinct_lines_than_the_compiled_cache_holds() -> None:
    text = "".join(f"#1=[{k}+0.5]\nG0 X[#1*2]\n" for k in range(5000))
    assert [round(m.end[0] * 1000, 9) for m in moves(text)] == [2 * k + 1.0 for k in range(5000)]


def test_zero_length_moves_are_skipped_without_memory_per_move() -> None:
    interp = Interpreter("z.ngc", XYZ, text="G21 G1 F100 X0\n" * 5000)
    assert list(interp.run()) == [GcodeEvent(5000, "end", text="end of file")]
    assert interp.n_skipped == 5000 and len(interp.skipped) == 100


@pytest.mark.parametrize(
    ("line", "expected"),
    [
        (
            "G1 F1e3 X1",
            "F1e3: G-code numbers have no exponent: F1 and E3 (allowed: the number "
            "written out, e.g. F1000)",
        ),
        (
            "G1 X1.5E-3",
            "X1.5E-3: G-code numbers have no exponent: X1.5 and E-3 (allowed: the "
            "number written out, e.g. X0.0015)",
        ),
        (
            "G1 X1 F1e15",
            "F1e15: G-code numbers have no exponent: F1 and E15 (allowed: |value| < "
            "1e+15, written out without an exponent)",
        ),
        ("G1 X1 E5", "E5: unknown word (allowed: the words of the G-code reference)"),
    ],
)
def test_a_number_with_an_exponent_is_named_as_such(line: str, expected: str) -> None:
    """issue 30: ``F1e15`` read as 'E15: unknown word'; the message names the exponent."""
    assert expected in error_of(f"G21\n{line}\n")


# -- found by the third-party corpus (tests/gcode/thirdparty) --------------------------------
def test_g80_beside_another_motion_code_is_dropped_like_linuxcnc() -> None:
    # LinuxCNC's read_g: "G80 G0" / "G0 G80" on one line is a G0 (CAM preambles, e.g. the
    # trajectory planner's quick-tests/zero_length_move.ngc: "G90 G17 G40 G80 G00 G20")
    assert ends_mm("G21 G90 G80 G0 X1\nG0 G80 Y2\nM2\n") == [[1, 0, 0], [1, 2, 0]]
    assert ends_mm("G21 F60 G80 G81 X1 Y1 Z-1 R1\nG80\nM2\n")[-1] == [1, 1, 1]
    assert "G0 and G1 on one line are of the same modal group" in error_of("G0 G1 X1 F9\n")


def test_a_rotary_word_in_a_canned_cycle_is_refused_like_linuxcnc() -> None:
    # LinuxCNC tests/interp/bad/a-in-canned-cycle*.ngc: "Cannot put an a in canned cycle"
    for text in ("G81 X0 Y0 Z-1 R0 F12\nA90\n", "G81 X0 Y0 Z-1 R0 A90 F12\n"):
        assert "A90: A word in canned cycle G81" in error_of("G21\n" + text, XYZA)
    last = moves("G21 F12 G81 X0 Y0 Z-1 R0\nG80\nG0 A90\nM2\n", XYZA)[-1]
    assert last.end[3] == pytest.approx(math.pi / 2)


def test_exists_of_numbered_parameters_like_linuxcnc() -> None:
    # LinuxCNC tests/interp/exists: EXISTS[#n] is 1 for 1 <= n < 5602, the number may be
    # #-valued; the reference's canon output is (1, 0, 1) then (1, 0, 0)
    text = (
        "#<a>=999\nG0 X EXISTS[#1] Y EXISTS[#99999] Z EXISTS[#<a>]\n"
        "#1=2\n#2=99999\nG0 X EXISTS[##1] Y EXISTS[##2] Z EXISTS[###1]\nM2\n"
    )
    assert ends_mm("G21\n" + text) == [[1, 0, 1], [1, 0, 0]]
    assert "EXISTS needs [#<name>] or [#number]" in error_of("G0 X EXISTS[1]\n")
    assert "EXISTS needs [#<name>] or [#number]" in error_of("G0 X EXISTS[#1+#2]\n")
    assert "parameter number out of range" in error_of("#2=99999\nG0 X EXISTS[###2]\n")


def test_a_nested_subroutine_definition_is_refused_like_linuxcnc() -> None:
    text = "F100\nO1 sub\nG1 X0\n  O2 sub\n  G1 Y0\n  O2 endsub\nO1 endsub\nO1 call\nM30\n"
    assert "t.ngc:4: O2: subroutine definition inside O1 sub of line 2" in error_of(text)


def test_polar_coordinates_like_linuxcnc() -> None:
    # LinuxCNC's find_ends: G90 @ radius ^ angle about the program origin, the missing one from
    # the current position; G91 @ adds to the radius, ^ to the angle (nc_files/spiral.ngc)
    text = "G21 G17 G0 X10 Y0\nG1 @5 F100\nG1 ^90\nG91 G1 @1\nG1 ^-90\nM2\n"
    got = ends_mm(text)
    assert got == [[10, 0, 0], [5, 0, 0], pytest.approx([0, 5, 0]), pytest.approx([0, 6, 0]),
                   pytest.approx([6, 0, 0])]  # fmt: skip
    # a canned cycle repeated about the origin (nc_files/hole-circle.ngc): six holes 60 deg apart
    holes = [
        m.end[:2]
        for m in moves("G20 G17 G90 G0 X1.5 Y0 Z0\nG91 G81 R.1 Z-.5 ^60 L6 F10\nM2\n")
        if m.kind == "linear"
    ]
    assert len(holes) == 6
    for k, (x, y) in enumerate(holes, start=1):
        assert (x, y) == pytest.approx(
            (
                1.5 * 0.0254 * math.cos(math.radians(60 * k)),
                1.5 * 0.0254 * math.sin(math.radians(60 * k)),
            ),
            abs=1e-12,
        )
    assert "@1: @ (polar coordinates) with a X word" in error_of("G0 X1 @1\n")
    assert "outside the G17 plane" in error_of("G18 G0 @1 ^2\n")
    assert "with an arc is not supported" in error_of("G2 @1 ^1 R1 F1\n")
    assert "@ without ^ at the origin" in error_of("G0 X0 Y0\nG0 @1\n")
