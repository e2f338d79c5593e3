"""MC_MoveCircularAbsolute / Relative with CircMode RADIUS (issue 25 point 10), end to end: the FB
on 2-D and 3-D groups (positive radius: the arc shorter than half a circle, negative: the longer
one, both senses), a YAML sequence run, ``validate`` and the JSON Schema agreeing on the
radius' range, and a radius too small for the chord refused as INVALID_CIRCLE naming the
radius (the geometry's verdict, never a coding error turned into an ErrorID)."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from motionplc.blocks.enums import BufferMode, CircMode, ErrorID, PathChoice
from motionplc.blocks.group_blocks import (
    MC_MoveCircularAbsolute,
    MC_MoveCircularRelative,
    MC_MoveLinearAbsolute,
)
from motionplc.cli import main
from motionplc.config import ConfigError, build, load_config
from motionplc.sequence import load_sequence, runner_for
from tests.blocks.group_rig import GroupBench

XY = {
    "x": {"v_max": 1.0, "a_max": 4.0, "j_max": 40.0},
    "y": {"v_max": 0.8, "a_max": 3.0, "j_max": 30.0},
}
START = (0.1, 0.1)
END = (0.16, 0.18)  # chord 0.1
CHORD = math.dist(START, END)


def _centre(start, end, r: float, clockwise: bool) -> np.ndarray:
    """The centre of the RADIUS arc, computed here from the definition (not the library's):
    the short arc (r > 0) turning counter-clockwise has its centre on the left of the chord,
    a clockwise one on the right; the long arc (r < 0) the other side."""
    p0, p1 = np.asarray(start, float), np.asarray(end, float)
    mid = 0.5 * (p0 + p1)
    u = (p1 - p0) / np.linalg.norm(p1 - p0)
    left = np.array([-u[1], u[0]])
    h = math.sqrt(r * r - 0.25 * float(np.dot(p1 - p0, p1 - p0)))
    side = 1.0 if (clockwise == (r < 0.0)) else -1.0  # +1: on the left
    return mid + side * h * left


def _swept(r: float) -> float:
    """Angle of the RADIUS arc: short (< pi) for r > 0, long (> pi) for r < 0."""
    short = 2.0 * math.asin(CHORD / (2.0 * abs(r)))
    return short if r > 0.0 else 2.0 * math.pi - short


@pytest.mark.parametrize("relative", [False, True])
@pytest.mark.parametrize("choice", [PathChoice.COUNTER_CLOCKWISE, PathChoice.CLOCKWISE])
@pytest.mark.parametrize("r", [0.08, -0.08, 0.05000001])
def test_radius_arcs_on_a_2d_group(r: float, choice: PathChoice, relative: bool) -> None:
    b = GroupBench(axes=XY).enabled()
    go = b.add(MC_MoveLinearAbsolute(execute=True, position=START, velocity=0.5))
    b.run_until_idle()
    assert go.done
    n0 = len(b.col("x.position"))
    cls = MC_MoveCircularRelative if relative else MC_MoveCircularAbsolute
    end = tuple(e - s for e, s in zip(END, START, strict=True)) if relative else END
    arc = b.add(
        cls(
            execute=True,
            circ_mode=CircMode.RADIUS,
            aux_point=(r,),
            end_point=end,
            path_choice=choice,
            velocity=0.2,
        )
    )
    b.run_until_idle()
    assert arc.done, (arc.error_id, arc.error_text)
    pos = np.vstack([START, b.positions()[n0:]])  # (the arc's first row has moved already)
    assert tuple(pos[-1]) == pytest.approx(END, abs=1e-12)
    cw = choice is PathChoice.CLOCKWISE
    c = _centre(START, END, r, cw)
    rad = np.linalg.norm(pos - c, axis=1)
    assert np.abs(rad - abs(r)).max() <= 1e-9 * (1.0 + abs(r))
    # the sense and the swept angle: unwrap the polar angle about the centre
    ang = np.unwrap(np.arctan2(pos[:, 1] - c[1], pos[:, 0] - c[0]))
    swept = ang[-1] - ang[0]
    assert math.copysign(1.0, swept) == (-1.0 if cw else 1.0)
    assert abs(swept) == pytest.approx(_swept(r), rel=1e-9)
    assert (abs(swept) > math.pi) == (r < 0.0)
    b.check_limits()


def test_radius_arc_on_a_3d_group_lies_in_xy() -> None:
    b = GroupBench().enabled()
    go = b.add(MC_MoveLinearAbsolute(execute=True, position=(*START, -0.05), velocity=0.5))
    b.run_until_idle()
    n0 = len(b.col("x.position"))
    arc = b.add(
        MC_MoveCircularAbsolute(
            execute=True,
            circ_mode=CircMode.RADIUS,
            aux_point=(-0.07,),
            end_point=(*END, -0.05),
            path_choice=PathChoice.CLOCKWISE,
            velocity=0.2,
            buffer_mode=BufferMode.BUFFERED,
        )
    )
    b.run_until_idle()
    assert go.done and arc.done, (arc.error_id, arc.error_text)
    pos = b.positions()[n0:]
    assert np.abs(pos[:, 2] + 0.05).max() == 0.0
    c = _centre(START, END, -0.07, True)
    assert np.abs(np.linalg.norm(pos[:, :2] - c, axis=1) - 0.07).max() <= 1e-9


@pytest.mark.parametrize(
    ("aux", "error_id", "text"),
    [
        ((0.03,), ErrorID.INVALID_CIRCLE, "radius: must be at least half the chord"),
        ((-0.03,), ErrorID.INVALID_CIRCLE, "radius: must be at least half the chord"),
        ((0.0,), ErrorID.INVALID_CIRCLE, "must not be 0"),
        ((), ErrorID.INVALID_CIRCLE, "aux_point[0] must hold the radius"),
        ((math.nan,), ErrorID.INVALID_CIRCLE, "aux_point[0]"),
    ],
)
def test_bad_radius_is_an_invalid_circle(aux, error_id, text: str) -> None:
    b = GroupBench(axes=XY).enabled()
    b.add(MC_MoveLinearAbsolute(execute=True, position=START, velocity=0.5))
    b.run_until_idle()
    arc = b.add(
        MC_MoveCircularAbsolute(
            execute=True, circ_mode=CircMode.RADIUS, aux_point=aux, end_point=END, velocity=0.2
        )
    )
    b.run(5)
    assert arc.error and arc.error_id is error_id, (arc.error_id, arc.error_text)
    assert text in arc.error_text
    assert "TypeError" not in arc.error_text and "keyword" not in arc.error_text


# -- YAML: a sequence run, validate, the JSON Schema ---------------------------------------------
CFG = """\
runtime:
  tick: 0.001
  tasks:
    motion: {period: 0.001}
axes:
  x:
    limits: {v_max: 1.0, a_max: 4.0, j_max: 40.0}
  y:
    limits: {v_max: 1.0, a_max: 4.0, j_max: 40.0}
groups:
  xy: [x, y]
"""

SEQ = """\
timeout: 10
steps:
  - call:
      - {block: px, type: MC_Power, axis: x, enable: true}
      - {block: py, type: MC_Power, axis: y, enable: true}
  - call: [{block: en, type: MC_GroupEnable, group: xy}]
    expect: {xy.state: GROUP_STANDBY}
  - call:
      - {block: go, type: MC_MoveLinearAbsolute, group: xy, position: [0.1, 0.1], velocity: 0.5}
    until: {done: go}
  - name: the long arc (negative radius), then back on the short one (relative)
    call:
      - {block: c1, type: MC_MoveCircularAbsolute, group: xy, circ_mode: RADIUS,
         aux_point: {RADIUS1}, end_point: {x: 0.16, y: 0.18}, path_choice: CLOCKWISE,
         velocity: 0.2}
      - {block: c2, type: MC_MoveCircularRelative, group: xy, circ_mode: RADIUS,
         aux_point: 0.08, end_point: [-0.06, -0.08], velocity: 0.2, buffer_mode: BUFFERED}
    until: {done: [c1, c2], state: {xy: GROUP_STANDBY}}
    expect: {x.position: 0.1, y.position: 0.1, within: 1.0e-12}
"""


def _files(tmp_path: Path, radius: str) -> tuple[Path, Path]:
    cfg = tmp_path / "xy.yaml"
    cfg.write_text(CFG)
    seq = tmp_path / "seq.yaml"
    seq.write_text(SEQ.replace("{RADIUS1}", radius))
    return cfg, seq


def test_sequence_runs_radius_arcs_end_to_end(tmp_path: Path) -> None:
    cfg_path, seq_path = _files(tmp_path, "-0.08")
    cfg = load_config(cfg_path)
    with build(cfg, check_invariants=True) as machine:
        runner, task = runner_for(seq_path, machine)
        machine.attach(runner, task)
        machine.runtime.run_until(lambda: runner.over, max_seconds=10.0)
        assert runner.failures == [] and runner.finished
        tr = machine.runtime.trace
        pos = np.stack([tr.column("x.position"), tr.column("y.position")], axis=1)
    # the long clockwise arc passes the far side of its centre: beyond the chord's bounding box
    c = _centre(START, END, -0.08, True)
    on = np.abs(np.linalg.norm(pos - c, axis=1) - 0.08) <= 1e-9
    assert on.sum() > 100
    assert pos[on, 0].max() > c[0] + 0.079  # the arc reaches its rightmost point


def test_validate_accepts_a_negative_radius_and_refuses_zero(tmp_path: Path, capsys) -> None:
    cfg, seq = _files(tmp_path, "-0.08")
    assert main(["validate", str(cfg), str(seq)]) == 0
    capsys.readouterr()
    for bad in ("0", "0.0", "-2.0e12", ".nan", ".inf"):
        cfg, seq = _files(tmp_path, bad)
        with pytest.raises(ConfigError) as info:
            load_sequence(seq, load_config(cfg))
        (msg,) = info.value.errors
        assert msg.startswith(f"{seq}:14: steps[3].call[0].aux_point: got "), msg
        assert "a radius > 0 and <= 1e+12 or >= -1e+12 and < 0" in msg, msg
        assert main(["validate", str(cfg), str(seq)]) == 2
        assert "aux_point" in capsys.readouterr().err


def test_json_schema_agrees_with_the_validator_on_the_radius(tmp_path: Path) -> None:
    jsonschema = pytest.importorskip("jsonschema")
    root = Path(__file__).resolve().parents[2]
    schema = json.loads((root / "docs" / "schema" / "sequence.schema.json").read_text())
    import yaml

    for radius, ok in (("-0.08", True), ("0.08", True), ("0", False), ("-2.0e12", False)):
        cfg, seq = _files(tmp_path, radius)
        doc = yaml.safe_load(seq.read_text())
        errors = list(jsonschema.Draft202012Validator(schema).iter_errors(doc))
        try:
            load_sequence(seq, load_config(cfg))
            validator_ok = True
        except ConfigError:
            validator_ok = False
        assert (not errors) == ok == validator_ok, (radius, [e.message for e in errors][:3])
