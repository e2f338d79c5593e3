"""``motionplc run / validate`` with axes groups: sequences with group blocks and G-code
programs (``--group``), the groups sidecar next to the trace, located errors and exit codes
without tracebacks. Ideal drives (fast); the gantry run of rounded_rectangle.ngc is in
tests/gcode/test_gcode_runner.py."""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest

from motionplc.cli import main

CONFIGS = Path(__file__).resolve().parents[2] / "configs"

TWO_GROUPS = """\
runtime:
  tick: 0.001
  tasks:
    motion: {period: 0.001}
axes:
  x: {limits: {v_max: 1.0, a_max: 4.0, j_max: 40.0}}
  y: {limits: {v_max: 1.0, a_max: 4.0, j_max: 40.0}}
  u: {limits: {v_max: 1.0, a_max: 4.0, j_max: 40.0}}
  v: {limits: {v_max: 1.0, a_max: 4.0, j_max: 40.0}}
groups:
  xy: [x, y]
  uv: {axes: [u, v], tolerance: 1.0e-5}
"""

SEQUENCE = """\
steps:
  - call:
      - {block: px, type: MC_Power, axis: x, enable: true}
      - {block: py, type: MC_Power, axis: y, enable: true}
  - call: [{block: en, type: MC_GroupEnable, group: xy}]
  - call:
      - {block: a, type: MC_MoveLinearAbsolute, group: xy, position: {x: 0.1, y: 0.0},
         velocity: 0.5}
      - {block: b, type: MC_MoveLinearAbsolute, group: xy, position: [0.1, 0.1], velocity: 0.5,
         buffer_mode: BLENDING_LOW, transition_mode: TM_MAX_CORNER_DEVIATION}
    until: {done: b, state: {xy: GROUP_STANDBY}}
    expect: {x.position: 0.1, y.position: 0.1, xy.state: GROUP_STANDBY, within: 1.0e-12}
  - call: [{block: st, type: MC_GroupStop, group: xy}]
    expect: {xy.state: GROUP_STOPPING}
  - call: [{block: st, execute: false}]
  - wait: 0.01
    expect: {xy.state: GROUP_STANDBY}
"""


def _write(tmp_path: Path, name: str, text: str) -> Path:
    p = tmp_path / name
    p.write_text(text)
    return p


def test_sequence_with_group_blocks_runs_and_writes_the_sidecar(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    cfg = _write(tmp_path, "m.yaml", TWO_GROUPS)
    seq = _write(tmp_path, "s.yaml", SEQUENCE)
    trace = tmp_path / "out" / "t.csv"
    assert main(["run", str(cfg), str(seq), "--trace", str(trace)]) == 0
    out = capsys.readouterr().out
    sidecar = tmp_path / "out" / "t.groups.json"
    assert json.loads(sidecar.read_text()) == {"groups": {"xy": ["x", "y"], "uv": ["u", "v"]}}
    units = tmp_path / "out" / "t.units.json"
    assert json.loads(units.read_text())["units"]["x.position"] == "m"
    assert f"{tmp_path / 'out' / 't.events.csv'}, {units} and {sidecar}" in out
    # the summary has a line per group: members, moves done, final state
    assert re.search(r"^xy\s+x,y\s+4\s+GROUP_STANDBY\s*$", out, re.M), out
    assert re.search(r"^uv\s+u,v\s+0\s+GROUP_DISABLED\s*$", out, re.M), out
    assert "all expectations met" in out


def test_gcode_needs_a_group_choice_when_there_are_several(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    cfg = _write(tmp_path, "m.yaml", TWO_GROUPS)
    prog = _write(tmp_path, "p.ngc", "G21 G64 F3000\nG1 X20\nG1 Y10\n")
    assert main(["run", str(cfg), str(prog)]) == 2
    err = capsys.readouterr().err
    assert f"{prog}: {cfg} has 2 groups; choose one with --group (allowed: xy, uv)" in err
    assert main(["run", str(cfg), str(prog), "--group", "zz"]) == 2
    err = capsys.readouterr().err
    assert f"{prog}: --group: unknown group 'zz' (allowed: xy, uv)" in err
    assert "Traceback" not in err


def test_gcode_runs_on_the_chosen_group(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    cfg = _write(tmp_path, "m.yaml", TWO_GROUPS)
    prog = _write(tmp_path, "p.ngc", "G21 G64 F3000\nG1 X20\nG1 Y10\n")
    trace = tmp_path / "t.csv"
    assert main(["run", str(cfg), str(prog), "--group", "uv", "--trace", str(trace), "-q"]) == 0
    out = capsys.readouterr().out
    assert re.search(rf"ok: {re.escape(str(prog))}: 2 of 2 moves run on group 'uv'", out), out
    head = trace.read_text().splitlines()
    cols = head[0].split(",")
    last = dict(zip(cols, head[-1].split(","), strict=True))
    assert float(last["u.position"]) == pytest.approx(0.02, abs=1e-12)
    assert float(last["v.position"]) == pytest.approx(0.01, abs=1e-12)
    assert float(last["x.position"]) == 0.0 and last["xy.state"] == "GROUP_DISABLED"
    # the run ended in GroupStandby; its controlled stop switched the group and axes off
    assert last["uv.state"] == "GROUP_DISABLED" and last["u.state"] == "DISABLED"
    assert re.search(r"^uv\s+u,v\s+2\s+GROUP_STANDBY\s*$", out, re.M) is None  # -q


def test_validate_a_gcode_program(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert (
        main(
            ["validate", str(CONFIGS / "gantry.yaml"), str(CONFIGS / "gcode/rounded_rectangle.ngc")]
        )
        == 0
    )
    out = capsys.readouterr().out
    assert "rounded_rectangle.ngc: ok - 18 moves from the origin on " in out
    assert "group 'xyz' (x, y, z)" in out


@pytest.mark.parametrize(
    ("text", "located"),
    [
        ("G21 F600\nG1 X10 M66\n", "p.ngc:2: M66: M66 (wait on input) is not supported"),
        ("G21 F600\nG1 X10\nG2 X30 I5 Z-1\n", "p.ngc:3: G2: radius to the end 15 differs"),
        ("G21 F600\nG1 X2000\n", "p.ngc:2: G1: the move reaches 2 on axis 'x', outside its"),
    ],
    ids=["unsupported word", "arc radii", "software limit"],
)
def test_bad_program_exits_2_located_before_running(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], text: str, located: str
) -> None:
    prog = _write(tmp_path, "p.ngc", text)
    trace = tmp_path / "t.csv"
    assert main(["run", str(CONFIGS / "gantry.yaml"), str(prog), "--trace", str(trace)]) == 2
    out, err = capsys.readouterr()
    assert "Traceback" not in out + err
    assert f"motionplc: error: {tmp_path / located}" in err
    assert not trace.exists()  # nothing ran


def test_group_option_is_for_gcode_only(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    cfg = _write(tmp_path, "m.yaml", TWO_GROUPS)
    seq = _write(tmp_path, "s.yaml", SEQUENCE)
    assert main(["run", str(cfg), str(seq), "--group", "xy"]) == 2
    assert "--group: only for G-code programs" in capsys.readouterr().err
    assert main(["run", str(cfg), "--group", "xy"]) == 2
    assert "--group needs a G-code program" in capsys.readouterr().err
