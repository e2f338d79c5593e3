# ruff: noqa: E501 - the expected error lines are kept whole, as a user sees them
"""Axes groups in YAML: the list and mapping forms, runtime groups built with their options,
every bad case a located error (exact text); group blocks in sequences (points by member name
or list, enums by name) with their located errors."""

from __future__ import annotations

from pathlib import Path

import pytest

from motionplc.blocks.enums import BufferMode, CircMode, GroupState, TransitionMode
from motionplc.cli import main
from motionplc.config import GroupSpec, build, load_config
from motionplc.errors import ConfigError
from motionplc.sequence import load_sequence

AXES = """\
runtime:
  tick: 0.001
  tasks:
    fast: {period: 0.001}
    slow: {period: 0.002}
axes:
  x:
    limits: {v_max: 1.0, a_max: 2.0}
  y:
    limits: {v_max: 1.0, a_max: 2.0}
  z:
    limits: {v_max: 1.0, a_max: 2.0}
  c:
    limits: {v_max: 1.0, a_max: 2.0}
    modulo: 6.283185307179586
  w:
    limits: {v_max: 1.0, a_max: 2.0}
    task: slow
"""
# the groups: section starts at line 19 (its first entry at line 20)

CASES: list[tuple[str, str, list[str]]] = [
    (
        "unknown axis (list form)",
        "groups:\n  g: [x, q]\n",
        ["{f}:20: groups.g[1]: unknown axis 'q' (allowed: x, y, z, c, w)"],
    ),
    (
        "unknown axis (mapping form)",
        "groups:\n  g:\n    axes: [x, q]\n",
        ["{f}:21: groups.g.axes[1]: unknown axis 'q' (allowed: x, y, z, c, w)"],
    ),
    (
        "axis listed twice",
        "groups:\n  g: [x, y, x]\n",
        ["{f}:20: groups.g[2]: axis 'x' is listed twice"],
    ),
    (
        "axis in two groups",
        "groups:\n  a: [x, y]\n  b:\n    axes: [z, y]\n",
        [
            "{f}:22: groups.b.axes[1]: axis 'y' is already in group 'a' (allowed: each axis in at most one group)"
        ],
    ),
    (
        "modulo axis",
        "groups:\n  g: [x, c]\n",
        [
            "{f}:20: groups.g[1]: axis 'c' is a modulo axis (modulo: 6.28319) (allowed: linear axes (paths need them))"
        ],
    ),
    (
        "axes in different tasks",
        "groups:\n  g: [x, w]\n",
        [
            "{f}:20: groups.g[1]: axis 'w' runs in task 'slow', axis 'x' in 'fast' (a group steps in one task) (allowed: member axes of one task)"
        ],
    ),
    (
        "group named like an axis",
        "groups:\n  x: [y, z]\n",
        ["{f}:20: groups.x: a group cannot have the name of an axis"],
    ),
    (
        "not a list",
        "groups:\n  g: x\n",
        [
            "{f}:20: groups.g: got string 'x' (allowed: a list of axis names, or a mapping {axes: [...], queue_depth, tolerance, v_share, blend_share})"
        ],
    ),
    (
        "empty list",
        "groups:\n  g: []\n",
        [
            "{f}:20: groups.g: got an empty list (allowed: a list of axis names, or a mapping {axes: [...], queue_depth, tolerance, v_share, blend_share})"
        ],
    ),
    (
        "axes missing",
        "groups:\n  g: {queue_depth: 8}\n",
        ["{f}:20: groups.g.axes: missing (allowed: required key)"],
    ),
    (
        "unknown option",
        "groups:\n  g: {axes: [x, y], depth: 8}\n",
        [
            "{f}:20: groups.g.depth: unknown key (allowed: axes, queue_depth, tolerance, v_share, blend_share)"
        ],
    ),
    (
        "bad option values with their ranges",
        "groups:\n  g:\n    axes: [x, y]\n    queue_depth: 0\n    tolerance: 0.0\n    v_share: 1.0\n    blend_share: -0.5\n",
        [
            "{f}:22: groups.g.queue_depth: got 0 (allowed: an integer in 1..10000)",
            "{f}:23: groups.g.tolerance: got 0 (allowed: a number > 0 and <= 1)",
            "{f}:24: groups.g.v_share: got 1 (allowed: a number >= 0.01 and <= 0.99)",
            "{f}:25: groups.g.blend_share: got -0.5 (allowed: a number >= 0.01 and <= 0.99)",
        ],
    ),
    (
        "option types",
        "groups:\n  g: {axes: [x], queue_depth: 2.5, tolerance: big}\n",
        [
            "{f}:20: groups.g.queue_depth: got number 2.5 (allowed: an integer in 1..10000)",
            "{f}:20: groups.g.tolerance: got string 'big' (allowed: a number > 0 and <= 1)",
        ],
    ),
    (
        "every problem at once",
        "groups:\n  a: [x, q]\n  b: [c]\n  c2: [y, y]\n",
        [
            "{f}:20: groups.a[1]: unknown axis 'q' (allowed: x, y, z, c, w)",
            "{f}:21: groups.b[0]: axis 'c' is a modulo axis (modulo: 6.28319) (allowed: linear axes (paths need them))",
            "{f}:22: groups.c2[1]: axis 'y' is listed twice",
        ],
    ),
]


@pytest.mark.parametrize(("name", "text", "expected"), CASES, ids=[c[0] for c in CASES])
def test_bad_groups_are_located_errors(
    tmp_path: Path, name: str, text: str, expected: list[str]
) -> None:
    f = tmp_path / "machine.yaml"
    f.write_text(AXES + text)
    with pytest.raises(ConfigError) as info:
        load_config(f)
    assert list(info.value.errors) == [e.replace("{f}", str(f)) for e in expected]


def test_cli_validate_reports_group_errors_without_traceback(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    f = tmp_path / "machine.yaml"
    f.write_text(AXES + "groups:\n  a: [x, y]\n  b: [y, z]\n")
    assert main(["validate", str(f)]) == 2
    out, err = capsys.readouterr()
    assert "Traceback" not in out + err
    assert f"{f}:21: groups.b[0]: axis 'y' is already in group 'a'" in err


def test_list_and_mapping_forms_build_runtime_groups_with_their_options(tmp_path: Path) -> None:
    f = tmp_path / "machine.yaml"
    f.write_text(
        AXES
        + "groups:\n  xy: [x, y]\n  zz:\n    axes: [z]\n    queue_depth: 5\n"
        + "    tolerance: 2.5e-5\n    v_share: 0.5\n    blend_share: 0.9\n"
    )
    cfg = load_config(f)
    assert cfg.groups == (
        GroupSpec("xy", ("x", "y")),
        GroupSpec("zz", ("z",), queue_depth=5, tolerance=2.5e-5, v_share=0.5, blend_share=0.9),
    )
    assert cfg.group_map == {"xy": ("x", "y"), "zz": ("z",)}
    with build(cfg) as machine:
        rt = machine.runtime
        assert list(rt.groups) == ["xy", "zz"] and machine.axes_groups == rt.groups
        xy, zz = rt.groups["xy"], rt.groups["zz"]
        assert xy.axis_names == ("x", "y") and zz.axis_names == ("z",)
        assert xy.state is GroupState.GROUP_DISABLED
        defaults = GroupSpec("d", ("x",))
        assert (xy.cfg.queue_depth, xy.cfg.tolerance) == (
            defaults.queue_depth,
            defaults.tolerance,
        )
        assert (zz.cfg.queue_depth, zz.cfg.tolerance, zz.cfg.v_share, zz.cfg.blend_share) == (
            5,
            2.5e-5,
            0.5,
            0.9,
        )
        assert machine.axes["x"].group is xy  # membership is the kernel's
        assert "xy.state" in rt.trace.columns and "zz.path_velocity" in rt.trace.columns


# ------------------------------------------------------------------------------ sequences
SEQ_CFG = """\
runtime:
  tick: 0.001
  tasks:
    motion: {period: 0.001}
axes:
  x:
    limits: {v_max: 1.0, a_max: 4.0, j_max: 40.0}
  y:
    limits: {v_max: 1.0, a_max: 4.0, j_max: 40.0}
  z:
    limits: {v_max: 1.0, a_max: 4.0, j_max: 40.0}
groups:
  xy: [x, y]
"""

SEQ_CASES: list[tuple[str, str, list[str]]] = [
    (
        "group FB without a group",
        "steps:\n  - call: [{block: m, type: MC_MoveLinearAbsolute, axis: x}]\n",
        ["{f}:2: steps[0].call[0].group: missing (allowed: xy)"],
    ),
    (
        "unknown group",
        "steps:\n  - call: [{block: m, type: MC_GroupEnable, group: xyz}]\n",
        ["{f}:2: steps[0].call[0].group: unknown group 'xyz' (allowed: xy)"],
    ),
    (
        "unknown type on a group lists the group types",
        "steps:\n  - call: [{block: m, type: MC_MoveLinear, group: xy}]\n",
        [
            "{f}:2: steps[0].call[0].type: got string 'MC_MoveLinear' (allowed: MC_GroupContinue, "
            "MC_GroupDisable, MC_GroupEnable, MC_GroupHalt, MC_GroupInterrupt, "
            "MC_GroupReadActualPosition, MC_GroupReadActualVelocity, MC_GroupReadError, "
            "MC_GroupReadStatus, MC_GroupReset, MC_GroupSetOverride, MC_GroupStop, MC_MoveBSpline, "
            "MC_MoveCircularAbsolute, MC_MoveCircularRelative, MC_MoveDirectAbsolute, "
            "MC_MoveDirectRelative, MC_MoveLinearAbsolute, MC_MoveLinearRelative, "
            "MC_MovePassingPoints, SyncMoveAbsolute)"
        ],
    ),
    (
        "membership FBs are not offered",
        "steps:\n  - call: [{block: m, type: MC_AddAxisToGroup, group: xy}]\n",
        [
            "{f}:2: steps[0].call[0].type: got string 'MC_AddAxisToGroup' (allowed: MC_GroupContinue, MC_GroupDisable, MC_GroupEnable, MC_GroupHalt, MC_GroupInterrupt, MC_GroupReadActualPosition, MC_GroupReadActualVelocity, MC_GroupReadError, MC_GroupReadStatus, MC_GroupReset, MC_GroupSetOverride, MC_GroupStop, MC_MoveBSpline, MC_MoveCircularAbsolute, MC_MoveCircularRelative, MC_MoveDirectAbsolute, MC_MoveDirectRelative, MC_MoveLinearAbsolute, MC_MoveLinearRelative, MC_MovePassingPoints, SyncMoveAbsolute)"
        ],
    ),
    (
        "a member missing from the position",
        "steps:\n  - call: [{block: m, type: MC_MoveLinearAbsolute, group: xy, position: {x: 0.1}}]\n",
        ["{f}:2: steps[0].call[0].position.y: missing (allowed: required key)"],
    ),
    (
        "a non-member in the position",
        "steps:\n  - call: [{block: m, type: MC_MoveLinearAbsolute, group: xy,\n             position: {x: 0.1, y: 0.2, z: 0.0}}]\n",
        ["{f}:3: steps[0].call[0].position.z: unknown key (allowed: x, y)"],
    ),
    (
        "a member twice in the position",
        "steps:\n  - call: [{block: m, type: MC_MoveLinearAbsolute, group: xy,\n             position: {x: 0.1, y: 0.2, x: 0.3}}]\n",
        ["{f}:3: steps[0].call[0].position.x: duplicate key"],
    ),
    (
        "a list of the wrong length",
        "steps:\n  - call: [{block: m, type: MC_MoveLinearAbsolute, group: xy, position: [0.1, 0.2, 0.3]}]\n",
        [
            "{f}:2: steps[0].call[0].position: got a list of 3 values (allowed: {x: ..., y: ...} (every member once) or a list of 2 numbers in member order)"
        ],
    ),
    (
        "a value that is not a number",
        "steps:\n  - call: [{block: m, type: MC_MoveLinearAbsolute, group: xy, position: [0.1, up]}]\n",
        [
            "{f}:2: steps[0].call[0].position[1]: got string 'up' (allowed: a number >= -1e+12 and <= 1e+12)"
        ],
    ),
    (
        "enum by a wrong name",
        "steps:\n  - call: [{block: m, type: MC_MoveLinearAbsolute, group: xy, position: [0, 0],\n             transition_mode: TM_CORNER}]\n",
        [
            "{f}:3: steps[0].call[0].transition_mode: got string 'TM_CORNER' (allowed: TM_NONE, TM_START_VELOCITY, TM_CONSTANT_VELOCITY, TM_CORNER_DISTANCE, TM_MAX_CORNER_DEVIATION)"
        ],
    ),
    (
        "points not a list",
        "steps:\n  - call: [{block: m, type: MC_MoveBSpline, group: xy, points: {x: 1, y: 2}}]\n",
        ["{f}:2: steps[0].call[0].points: got a mapping (allowed: a non-empty list of points)"],
    ),
    (
        "a bad passing point",
        "steps:\n  - call: [{block: m, type: MC_MovePassingPoints, group: xy,\n             points: [[0.1, 0.1], {x: 0.2}]}]\n",
        ["{f}:3: steps[0].call[0].points[1].y: missing (allowed: required key)"],
    ),
    (
        "an axis input on a group FB",
        "steps:\n  - call: [{block: m, type: MC_GroupEnable, group: xy, axis: x}]\n",
        ["{f}:2: steps[0].call[0].axis: unknown key (allowed: block, type, group)"],
    ),
    (
        "execute: true is not a call",
        "steps:\n  - call: [{block: m, type: MC_GroupStop, group: xy, execute: true}]\n",
        [
            "{f}:2: steps[0].call[0].execute: got boolean true (allowed: false (lets Execute fall; a call without it issues the command))"
        ],
    ),
    (
        "group state names",
        "steps:\n  - wait: 0.1\n    until: {state: {xy: MOVING}}\n    expect: {xy.state: STANDSTILL, xy.speed: 0}\n",
        [
            "{f}:3: steps[0].until.state.xy: got string 'MOVING' (allowed: GROUP_DISABLED, GROUP_STANDBY, GROUP_HOMING, GROUP_MOVING, GROUP_STOPPING, GROUP_ERROR_STOP)",
            "{f}:4: steps[0].expect.xy.state: got string 'STANDSTILL' (allowed: GROUP_DISABLED, GROUP_STANDBY, GROUP_HOMING, GROUP_MOVING, GROUP_STOPPING, GROUP_ERROR_STOP)",
            "{f}:4: steps[0].expect.xy.speed: unknown group field 'speed' (allowed: state, path_velocity)",
        ],
    ),
]


@pytest.mark.parametrize(("name", "text", "expected"), SEQ_CASES, ids=[c[0] for c in SEQ_CASES])
def test_bad_group_calls_are_located_errors(
    tmp_path: Path, name: str, text: str, expected: list[str]
) -> None:
    cfg = tmp_path / "machine.yaml"
    cfg.write_text(SEQ_CFG)
    f = tmp_path / "seq.yaml"
    f.write_text(text)
    with pytest.raises(ConfigError) as info:
        load_sequence(f, load_config(cfg))
    assert list(info.value.errors) == [e.replace("{f}", str(f)) for e in expected]


def test_group_calls_are_parsed_into_fb_inputs(tmp_path: Path) -> None:
    cfg = tmp_path / "machine.yaml"
    cfg.write_text(SEQ_CFG)
    f = tmp_path / "seq.yaml"
    f.write_text(
        "steps:\n"
        "  - call:\n"
        "      - {block: m1, type: MC_MoveLinearAbsolute, group: xy, position: {y: 0.2, x: 0.1},\n"
        "         velocity: 0.5, buffer_mode: BLENDING_LOW,\n"
        "         transition_mode: TM_MAX_CORNER_DEVIATION, transition_parameter: 0.001}\n"
        "      - {block: c, type: MC_MoveCircularAbsolute, group: xy, circ_mode: RADIUS,\n"
        "         aux_point: -0.05, end_point: [0.2, 0.2], path_choice: CLOCKWISE,\n"
        "         velocity: 0.3}\n"
        "      - {block: p, type: MC_MovePassingPoints, group: xy,\n"
        "         points: [[0.3, 0.2], {x: 0.4, y: 0.1}]}\n"
        "  - call: [{block: st, type: MC_GroupStop, group: xy}]\n"
        "  - call: [{block: st, execute: false}]\n"
    )
    seq = load_sequence(f, load_config(cfg))
    calls = [c for st in seq.steps for c in st.calls]
    assert dict(calls[0].inputs) == {
        "position": (0.1, 0.2),  # member order, whatever the mapping's order
        "velocity": 0.5,
        "buffer_mode": BufferMode.BLENDING_LOW,
        "transition_mode": TransitionMode.TM_MAX_CORNER_DEVIATION,
        "transition_parameter": 0.001,
    }
    assert dict(calls[1].inputs) == {
        "circ_mode": CircMode.RADIUS,
        "aux_point": (-0.05,),
        "end_point": (0.2, 0.2),
        "path_choice": dict(calls[1].inputs)["path_choice"],
        "velocity": 0.3,
    }
    assert dict(calls[1].inputs)["path_choice"].name == "CLOCKWISE"
    assert dict(calls[2].inputs) == {"points": ((0.3, 0.2), (0.4, 0.1))}
    assert dict(calls[4].inputs) == {"execute": False}
    assert {b.name: (b.type, b.axis, b.group) for b in seq.blocks}["st"] == (
        "MC_GroupStop",
        "xy",
        True,
    )
