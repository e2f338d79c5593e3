"""``validate CONFIG SEQUENCE`` checks the sequence against the machine (issue 14, point 5).

Every literal block input outside what the axis or group and the block accept is one located
line ``FILE:LINE: steps[i].call[j].pin: got ..., why (allowed: ...)``, all of a file at once,
exit code 2 through ``motionplc.cli.main``. A test per kind; the static verdicts are held equal
to the FBs' own at run time (the same ``_in_<pin>`` checks, and the axis' and group's
software-limit rules against :mod:`motionplc.blocks.sw_limits`).
"""

from __future__ import annotations

import math
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from motionplc.blocks import MC_MoveAbsolute, MC_MoveRelative, MC_MoveVelocity, MC_Power
from motionplc.blocks.axis_config import AxisConfig
from motionplc.blocks.enums import Direction, ErrorID
from motionplc.blocks.motion import StaticAxis
from motionplc.blocks.sw_limits import point_refused, target_refused
from motionplc.cli import main
from motionplc.config import Checker, load_config
from motionplc.errors import ConfigError
from motionplc.runtime import Runtime, SimClock
from motionplc.sequence import load_sequence
from motionplc.sequence_check import check_sequence

CONFIGS = Path(__file__).resolve().parents[2] / "configs"

# x: symmetric, software limits; y: asymmetric (v_min, a_min); r: modulo 1; group xy
MACHINE = """\
runtime:
  tasks:
    motion: {period: 0.001}
axes:
  x:
    limits: {v_max: 0.5, a_max: 2.0, j_max: 20.0}
    software_limits: {min: -0.05, max: 1.05}
  y:
    limits: {v_max: 0.25, a_max: 1.0, j_max: 10.0, v_min: -0.2, a_min: -1.5}
    software_limits: {min: 0.0, max: 0.6}
  r:
    units: rad
    limits: {v_max: 1.0, a_max: 4.0}
    modulo: 1.0
groups:
  xy: [x, y]
"""

POWER = """\
steps:
  - name: power
    call:
      - {block: px, type: MC_Power, axis: x, enable: true}
      - {block: py, type: MC_Power, axis: y, enable: true}
      - {block: pr, type: MC_Power, axis: r, enable: true}
"""


@pytest.fixture
def machine(tmp_path: Path) -> Path:
    p = tmp_path / "m.yaml"
    p.write_text(MACHINE)
    return p


def _seq(tmp_path: Path, steps: str) -> Path:
    p = tmp_path / "s.yaml"
    p.write_text(POWER + steps)
    return p


def _errors(machine: Path, seq: Path) -> list[str]:
    with pytest.raises(ConfigError) as exc:
        load_sequence(seq, load_config(machine))
    return [e.removeprefix(f"{seq}:") for e in exc.value.errors]


def _validate(machine: Path, seq: Path, capsys: pytest.CaptureFixture[str]) -> list[str]:
    """``motionplc validate``: exit code 2, the problems on stderr, one per line."""
    assert main(["validate", str(machine), str(seq)]) == 2
    err = capsys.readouterr().err
    return [
        ln.removeprefix("motionplc: error: ").removeprefix(f"{seq}:") for ln in err.splitlines()
    ]


# ------------------------------------------------------------------------------ shipped
@pytest.mark.parametrize(
    ("config", "sequence"),
    [
        ("demo", "demo"),
        ("gantry", "gantry"),
        ("gantry", "gantry_groups"),
        ("single_axis_can", "single_axis"),
        ("vcan0", "single_axis"),
    ],
)
def test_every_shipped_sequence_validates(
    config: str, sequence: str, capsys: pytest.CaptureFixture[str]
) -> None:
    cfg, seq = CONFIGS / f"{config}.yaml", CONFIGS / f"{sequence}_sequence.yaml"
    assert main(["validate", str(cfg), str(seq)]) == 0
    report = check_sequence(load_sequence(seq, load_config(cfg)), load_config(cfg), Checker(seq))
    assert report.problems == 0 and report.checks > 10


# ---------------------------------------------------------------------- software limits
def test_absolute_target_beyond_the_software_limits(
    machine: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    seq = _seq(
        tmp_path,
        "  - call:\n"
        "      - {block: m, type: MC_MoveAbsolute, axis: x, position: 1.2, velocity: 0.5}\n"
        "      - {block: n, type: MC_MoveAbsolute, axis: y, velocity: 0.1,\n"
        "         position: -0.01}\n",
    )
    assert _validate(machine, seq, capsys) == [
        "8: steps[1].call[0].position: got 1.2, beyond the software limit max 1.05 of axis 'x' "
        "(allowed: a position in [-0.05, 1.05])",
        "10: steps[1].call[1].position: got -0.01, beyond the software limit min 0 of axis 'y' "
        "(allowed: a position in [0, 0.6])",
    ]


def test_relative_moves_from_known_positions(
    machine: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # x starts at 0 (simulated drive); 0.8 known after the first step; buffered relative moves
    # add up from the previous target; the aborting one counts from the step's start
    seq = _seq(
        tmp_path,
        "  - call: [{block: a, type: MC_MoveAbsolute, axis: x, position: 0.8, velocity: 0.5}]\n"
        "  - call:\n"
        "      - {block: r1, type: MC_MoveRelative, axis: x, distance: 0.2, velocity: 0.5}\n"
        "      - {block: r2, type: MC_MoveRelative, axis: x, distance: 0.1, velocity: 0.5,\n"
        "         buffer_mode: BUFFERED}\n"
        "      - {block: r3, type: MC_MoveAdditive, axis: x, distance: -2.0, velocity: 0.5,\n"
        "         buffer_mode: BLENDING_LOW}\n",
    )
    assert _validate(machine, seq, capsys) == [
        "10: steps[2].call[1].distance: got 0.1: from 1 (where the sequence left axis 'x') the "
        "target 1.1 is beyond the software limit max 1.05 (allowed: a distance in [-1.05, 0.05] "
        "from there)",
    ]
    # r2 refused: r3's base (the last target) is unknown, so it is left to run time


def test_relative_moves_after_unknown_positions_are_left_to_run_time(
    machine: Path, tmp_path: Path
) -> None:
    # after a velocity move and a halt the position is not known: no static verdict
    seq = _seq(
        tmp_path,
        "  - call: [{block: v, type: MC_MoveVelocity, axis: x, velocity: 0.1}]\n"
        "    until: {time: 0.5}\n"
        "  - call: [{block: h, type: MC_Halt, axis: x}]\n"
        "  - call: [{block: r, type: MC_MoveRelative, axis: x, distance: 5.0, velocity: 0.5}]\n",
    )
    load_sequence(seq, load_config(machine))


def test_parallel_branches_keep_their_own_positions(
    machine: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    seq = _seq(
        tmp_path,
        "  - parallel:\n"
        "      bx:\n"
        "        - call: [{block: a, type: MC_MoveAbsolute, axis: x, position: 1.0,\n"
        "                  velocity: 0.5}]\n"
        "        - call: [{block: b, type: MC_MoveRelative, axis: x, distance: 0.1,\n"
        "                  velocity: 0.5}]\n"
        "      by:\n"
        "        - call: [{block: c, type: MC_MoveRelative, axis: y, distance: 0.5,\n"
        "                  velocity: 0.2}]\n",
    )
    assert _validate(machine, seq, capsys) == [
        "11: steps[1].parallel.bx[1].call[0].distance: got 0.1: from 1 (where the sequence left "
        "axis 'x') the target 1.1 is beyond the software limit max 1.05 (allowed: a distance in "
        "[-1.05, 0.05] from there)",
    ]


# ------------------------------------------------------------------- velocities, dynamics
def test_velocity_above_v_max_and_not_positive(
    machine: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    seq = _seq(
        tmp_path,
        "  - call:\n"
        "      - {block: m, type: MC_MoveAbsolute, axis: x, position: 0.5, velocity: 3.0}\n"
        "      - {block: n, type: MC_MoveAbsolute, axis: y, position: 0.5, velocity: -0.1}\n"
        "  - call:\n"
        "      - {block: m, position: 0.1}\n"
        "      - {block: k, type: MC_MoveRelative, axis: y, distance: 0.1}\n",
    )
    assert _validate(machine, seq, capsys) == [
        "8: steps[1].call[0].velocity: got 3.0, above the axis' v_max 0.5 of axis 'x' "
        "(allowed: [5e-07, 0.5])",
        "9: steps[1].call[1].velocity: got -0.1, a move's velocity must be > 0 (the target "
        "gives the direction) (allowed: [2.5e-07, 0.25])",
        # an omitted input keeps its value (m's bad velocity: reported once, at its line),
        # else the block's default
        "12: steps[2].call[1].velocity: not given, the block's default: 0.0, a move's velocity "
        "must be > 0 (the target gives the direction) (allowed: [2.5e-07, 0.25])",
    ]


def test_move_velocity_range_after_direction(
    machine: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # y: [-0.2, 0.25]; Direction NEGATIVE flips the sign; CURRENT fits either direction
    seq = _seq(
        tmp_path,
        "  - call:\n"
        "      - {block: v, type: MC_MoveVelocity, axis: y, velocity: 0.22, direction: NEGATIVE}\n"
        "  - call:\n"
        "      - {block: w, type: MC_MoveVelocity, axis: y, velocity: -0.22}\n"
        "  - call:\n"
        "      - {block: u, type: MC_MoveVelocity, axis: y, velocity: 0.22, direction: CURRENT}\n"
        "  - call:\n"
        "      - {block: s, type: MC_MoveVelocity, axis: x, velocity: 0.1, direction: SHORTEST}\n",
    )
    assert _validate(machine, seq, capsys) == [
        "8: steps[1].call[0].velocity: got 0.22 (NEGATIVE: -0.22), below the axis' v_min -0.2 "
        "of axis 'y' (allowed: [-0.2, 0.25] after the direction)",
        "10: steps[2].call[0].velocity: got -0.22, below the axis' v_min -0.2 of axis 'y' "
        "(allowed: [-0.2, 0.25] after the direction)",
        "14: steps[4].call[0].direction: got SHORTEST, not accepted by MC_MoveVelocity "
        "(allowed: POSITIVE, NEGATIVE, CURRENT)",
    ]


def test_acceleration_deceleration_jerk_and_override_ranges(
    machine: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    seq = _seq(
        tmp_path,
        "  - call:\n"
        "      - {block: m, type: MC_MoveAbsolute, axis: y, position: 0.5, velocity: 0.2,\n"
        "         acceleration: 1.2, deceleration: 1.6, jerk: 11}\n"
        "      - {block: h, type: MC_Halt, axis: x, deceleration: 1.0e-9, jerk: -1}\n"
        "      - {block: o, type: MC_SetOverride, axis: x, enable: true, vel_factor: 0.0001,\n"
        "         acc_factor: 0, jerk_factor: 1.5}\n",
    )
    assert _validate(machine, seq, capsys) == [
        # a_top of y is |a_min| 1.5: 1.2 is fine, 1.6 is not
        "9: steps[1].call[0].deceleration: got 1.6, above the axis' |a_min| 1.5 of axis 'y' "
        "(allowed: 0 (the axis' limit) or [4.5e-05, 1.5])",
        "9: steps[1].call[0].jerk: got 11.0, above the axis' j_max 10 of axis 'y' "
        "(allowed: 0 (the axis' limit) or [0.00015, 10])",
        "10: steps[1].call[1].deceleration: got 1e-09, below the lowest supported 0.0001 (a "
        "change over 1e4 s at most) (allowed: 0 (the axis' limit) or [0.0001, 2])",
        "10: steps[1].call[1].jerk: got -1.0, negative (allowed: 0 (the axis' limit) or "
        "[0.0002, 20])",
        "11: steps[1].call[2].vel_factor: got 0.0001, outside the override range "
        "(allowed: 0 or [0.001, 1])",
        "12: steps[1].call[2].acc_factor: got 0.0, outside the override range "
        "(allowed: [0.001, 1])",
        "12: steps[1].call[2].jerk_factor: got 1.5, outside the override range "
        "(allowed: [0.001, 1])",
    ]


def test_move_too_slow_for_its_distance(
    machine: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    seq = _seq(
        tmp_path,
        "  - call: [{block: m, type: MC_MoveRelative, axis: x, distance: 0.5, velocity: 1.0e-5}]\n",
    )
    assert _validate(machine, seq, capsys) == [
        "7: steps[1].call[0].velocity: got 1e-05: too low for the distance 0.5, the move would "
        "last more than the supported 10000 s (allowed: a velocity >= 5e-05 for this move)",
    ]


# ------------------------------------------------------------------------------ modulo
def test_modulo_axis_positions(
    machine: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    seq = _seq(
        tmp_path,
        "  - call:\n"
        "      - {block: m, type: MC_MoveAbsolute, axis: r, position: 1.0, velocity: 0.5}\n"
        "      - {block: h, type: MC_Home, axis: r, position: -0.1}\n",
    )
    assert _validate(machine, seq, capsys) == [
        "8: steps[1].call[0].position: got 1.0, outside the modulo axis' range (allowed: [0, 1))",
        "9: steps[1].call[1].position: got -0.1, outside the modulo axis' range (allowed: [0, 1))",
    ]


# ------------------------------------------------------------------- enumerations, types
def test_unknown_enum_unknown_input_and_wrong_types(
    machine: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    seq = _seq(
        tmp_path,
        "  - call:\n"
        "      - {block: m, type: MC_MoveAbsolute, axis: x, position: 0.5, velocity: 0.5,\n"
        "         buffer_mode: BLENDING_MEDIUM}\n"
        "      - {block: s, type: MC_Stop, axis: y, buffer_mode: BUFFERED}\n"
        "      - {block: n, type: MC_MoveAbsolute, axis: y, position: fast, velocity: ~}\n",
    )
    assert _validate(machine, seq, capsys) == [
        "9: steps[1].call[0].buffer_mode: got string 'BLENDING_MEDIUM' (allowed: ABORTING, "
        "BUFFERED, BLENDING_LOW, BLENDING_PREVIOUS, BLENDING_NEXT, BLENDING_HIGH)",
        "10: steps[1].call[1].buffer_mode: unknown key (allowed: block, type, axis, "
        "deceleration, jerk)",
        "11: steps[1].call[2].position: got string 'fast' (allowed: a number)",
        "11: steps[1].call[2].velocity: got null (allowed: a number)",
    ]


def test_every_buffer_mode_on_halt_and_move_velocity_loads(machine: Path, tmp_path: Path) -> None:
    # the kernel defines blending into MC_Halt / MC_MoveVelocity (junction speed of the
    # previous move) and into MC_Home (as Buffered): accepted as the FBs accept them
    modes = ("ABORTING", "BUFFERED", "BLENDING_LOW", "BLENDING_PREVIOUS", "BLENDING_NEXT")
    body = "".join(
        f"  - call:\n"
        f"      - {{block: m{i}, type: MC_MoveAbsolute, axis: x, position: 0.5, velocity: 0.5}}\n"
        f"      - {{block: h{i}, type: MC_Halt, axis: x, buffer_mode: {m}}}\n"
        f"      - {{block: v{i}, type: MC_MoveVelocity, axis: y, velocity: 0.1,"
        f" buffer_mode: {m}}}\n"
        f"      - {{block: o{i}, type: MC_Home, axis: r, position: 0.5, buffer_mode: {m}}}\n"
        for i, m in enumerate(modes)
    )
    load_sequence(_seq(tmp_path, body), load_config(machine))


# ------------------------------------------------------------------------------- groups
def test_group_points_path_speed_and_transitions(
    machine: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    seq = _seq(
        tmp_path,
        "  - call: [{block: en, type: MC_GroupEnable, group: xy}]\n"
        "  - call:\n"
        "      - {block: l1, type: MC_MoveLinearAbsolute, group: xy, position: {x: 0.2, y: 0.7},\n"
        "         velocity: 0.6}\n"
        "      - {block: l2, type: MC_MoveLinearAbsolute, group: xy, position: [1.1, 0.1],\n"
        "         velocity: 0.3, buffer_mode: BUFFERED, transition_mode: TM_CORNER_DISTANCE,\n"
        "         transition_parameter: 0.01}\n"
        "      - {block: l3, type: MC_MoveLinearRelative, group: xy, distance: [0.1, 0.1],\n"
        "         velocity: 0.3, buffer_mode: BLENDING_LOW, transition_mode: TM_START_VELOCITY}\n"
        "      - {block: d, type: MC_MoveDirectAbsolute, group: xy, position: [0.1, 0.1],\n"
        "         velocity: 0.55, buffer_mode: BUFFERED}\n"
        "      - {block: b, type: MC_MoveBSpline, group: xy,\n"
        "         points: [[0.1, 0.2], {x: 0.3, y: 0.65}], buffer_mode: BUFFERED}\n",
    )
    assert _validate(machine, seq, capsys) == [
        # sqrt(0.5^2 + 0.25^2) = 0.559 the fastest any path can go
        "9: steps[2].call[0].position.y: got 0.7, beyond the software limit max 0.6 of axis 'y' "
        "(allowed: a position of y in [0, 0.6])",
        "10: steps[2].call[0].velocity: got 0.6, above what the members reach together 0.559017 "
        "(sqrt of the sum of squares) (allowed: (0, 0.559017])",
        "11: steps[2].call[1].position[0]: got 1.1, beyond the software limit max 1.05 of axis "
        "'x' (allowed: a position of x in [-0.05, 1.05])",
        "12: steps[2].call[1].transition_mode: transition_mode TM_CORNER_DISTANCE needs a "
        "blending buffer_mode, got BUFFERED (ABORTING and BUFFERED take TM_NONE)",
        "14: steps[2].call[2].transition_parameter: not given, the block's default: "
        "transition_parameter must be > 0 for TM_START_VELOCITY, got 0.0",
        # MC_MoveDirect: velocity caps every axis, so the fastest member's limit
        "17: steps[2].call[3].velocity: got 0.55, above the fastest member's limit 0.5 "
        "(allowed: (0, 0.5])",
        "19: steps[2].call[4].points[1].y: got 0.65, beyond the software limit max 0.6 of axis "
        "'y' (allowed: a position of y in [0, 0.6])",
    ]


def test_group_relative_move_from_known_positions(
    machine: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    seq = _seq(
        tmp_path,
        "  - call: [{block: en, type: MC_GroupEnable, group: xy}]\n"
        "  - call: [{block: a, type: MC_MoveLinearAbsolute, group: xy, position: [1.0, 0.5],\n"
        "            velocity: 0.3}]\n"
        "  - call: [{block: r, type: MC_MoveLinearRelative, group: xy, distance: [-0.5, 0.2],\n"
        "            velocity: 0.3}]\n",
    )
    assert _validate(machine, seq, capsys) == [
        "10: steps[3].call[0].distance[1]: ends at 0.7 (from where the sequence left the group), "
        "beyond the software limit max 0.6 of axis 'y' (allowed: a position of y in [0, 0.6])",
    ]


def test_sync_move_targets(
    machine: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    seq = _seq(
        tmp_path,
        "  - call:\n"
        "      - {block: s, type: SyncMoveAbsolute, group: xy,\n"
        "         position: {x: 0.5, y: 0.9}}\n",
    )
    assert _validate(machine, seq, capsys) == [
        "9: steps[1].call[0].position.y: got 0.9, beyond the software limit max 0.6 of axis 'y' "
        "(allowed: a position in [0, 0.6])",
    ]


def test_all_problems_of_a_file_at_once_in_line_order(
    machine: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    seq = _seq(
        tmp_path,
        "  - call: [{block: m, type: MC_MoveAbsolute, axis: x, position: 9, velocity: 9}]\n"
        "  - call: [{block: q, type: MC_Bogus, axis: x}]\n"
        "  - call: [{block: m, position: 0.2, velocity: 0.0}]\n",
    )
    lines = _validate(machine, seq, capsys)
    assert [ln.split(":")[0] for ln in lines] == ["7", "7", "8", "9"]
    assert "steps[2].call[0].type: got string 'MC_Bogus'" in lines[2]
    assert lines[3].startswith("9: steps[3].call[0].velocity: got 0.0, a move's velocity")


# ---------------------------------------------------------- the same verdicts as the FBs
def _axis_cfg(v_max: float, v_min: float | None, a_max: float, j_max: float) -> AxisConfig:
    return AxisConfig("x", v_max, a_max, j_max, v_min=v_min, sw_limit_pos=1.0, sw_limit_neg=-1.0)


def _fb_error(fb: object, cfg: AxisConfig) -> ErrorID:
    """The FB's verdict at Execute on a powered axis with these limits (ideal drive)."""
    rt = Runtime(cycle=0.001, clock=SimClock())
    rt.add_task("t", lambda ctx: None, 0.001)
    ax = rt.add_axis(
        "x", cfg.v_max, cfg.a_max, cfg.j_max, v_min=cfg.v_min, sw_limit_pos=1.0, sw_limit_neg=-1.0
    )
    pwr = MC_Power(axis=ax, enable=True)
    for _ in range(3):
        pwr()
        rt.run(cycles=1)
    fb(axis=ax, execute=True)  # type: ignore[operator]
    return fb.error_id  # type: ignore[attr-defined]


_num = st.one_of(
    st.floats(-5.0, 5.0),
    st.sampled_from([0.0, 1e-9, -0.0, 1e300, math.inf, -math.inf, math.nan]),
)


@settings(max_examples=60, deadline=None)
@given(
    v_max=st.floats(0.1, 2.0),
    v_min=st.one_of(st.none(), st.floats(-2.0, -0.1)),
    velocity=_num,
    acceleration=_num,
    jerk=_num,
    position=st.floats(-2.0, 2.0),
    relative=st.booleans(),
)
def test_static_verdicts_equal_the_fb_at_execute(
    v_max: float,
    v_min: float | None,
    velocity: float,
    acceleration: float,
    jerk: float,
    position: float,
    relative: bool,
) -> None:
    """A move the static check passes is accepted by the FB on an axis at 0, and a refused
    one is refused with the ErrorID of the first problem (the FB checks in that order)."""
    cfg = _axis_cfg(v_max, v_min, 2.0, 20.0)
    if relative:
        fb = MC_MoveRelative(
            distance=position, velocity=velocity, acceleration=acceleration, jerk=jerk
        )
    else:
        fb = MC_MoveAbsolute(
            position=position, velocity=velocity, acceleration=acceleration, jerk=jerk
        )
    probs = fb.input_problems(StaticAxis(cfg))
    static: ErrorID = ErrorID.OK
    for pin in fb.INPUTS:  # the FB's order: target, velocity, dynamics
        if pin in probs:
            static = probs[pin].error_id
            break
    if static is ErrorID.OK:
        if target_refused(cfg, position, 0.0) is not None:
            static = ErrorID.TARGET_OUTSIDE_SW_LIMITS
        elif abs(position) > velocity * 1e4:
            static = ErrorID.INVALID_VELOCITY
    assert _fb_error(fb, cfg) is static


@settings(max_examples=40, deadline=None)
@given(
    v_min=st.one_of(st.none(), st.floats(-2.0, -0.1)),
    velocity=_num,
    direction=st.sampled_from(list(Direction)),
)
def test_move_velocity_static_verdict_equals_the_fb(
    v_min: float | None, velocity: float, direction: Direction
) -> None:
    cfg = _axis_cfg(0.5, v_min, 2.0, 20.0)
    fb = MC_MoveVelocity(velocity=velocity, direction=direction)
    probs = fb.input_problems(StaticAxis(cfg))  # at rest: CURRENT is positive
    # the FB's order: the velocity range of both directions, the direction, then the range of
    # the direction (input_problems reports the latter only with a valid direction)
    static = ErrorID.OK
    if "velocity" in probs:
        static = probs["velocity"].error_id
    elif "direction" in probs:
        static = probs["direction"].error_id
    assert _fb_error(fb, cfg) is static


@settings(max_examples=60, deadline=None)
@given(
    x=st.floats(-1.1, 1.1),
    y=st.sampled_from([0.6, 0.6 + 1e-13, 0.6 + 1e-11, -1e-13, -1e-11, 0.3]),
)
def test_group_point_verdict_equals_the_group(x: float, y: float) -> None:
    """point_refused (the static check) against the group's own check of a target."""
    from motionplc.blocks.group import _MoveError

    rt = Runtime(cycle=0.001, clock=SimClock())
    rt.add_task("t", lambda ctx: None, 0.001)
    rt.add_axis("x", 0.5, 2.0, sw_limit_pos=1.05, sw_limit_neg=-0.05)
    rt.add_axis("y", 0.25, 1.0, sw_limit_pos=0.6, sw_limit_neg=0.0)
    group = rt.add_group("xy", ["x", "y"])
    static = any(point_refused(rt.axes[a].cfg, v) is not None for a, v in (("x", x), ("y", y)))
    try:
        group._check_limits((x, y), "position")
        refused = False
    except _MoveError as exc:
        assert exc.error_id is ErrorID.TARGET_OUTSIDE_SW_LIMITS
        refused = True
    assert refused is static


@settings(max_examples=80, deadline=None)
@given(target=st.floats(-1.5, 1.5), base=st.floats(-1.5, 1.5))
def test_target_verdict_equals_the_axis_from_any_base(target: float, base: float) -> None:
    """target_refused against Axis._resolve from a base also beyond a limit."""
    from motionplc.blocks.axis import AxisJob, Command, Handle

    rt = Runtime(cycle=0.001, clock=SimClock())
    rt.add_task("t", lambda ctx: None, 0.001)
    ax = rt.add_axis("x", 0.5, 2.0, sw_limit_pos=1.0, sw_limit_neg=-1.0)
    job = AxisJob(Command(kind="absolute", position=target, velocity=0.5), Handle("absolute"))
    err = ax._resolve(job, base)
    static = target_refused(ax.cfg, target, base)
    assert (err is ErrorID.TARGET_OUTSIDE_SW_LIMITS) is (static is not None)
