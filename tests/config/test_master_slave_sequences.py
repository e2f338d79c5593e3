"""Master/slave FBs in sequences: the ``slave:`` key, ``master:`` / ``cam_table:`` /
``cam_table_id:`` naming an axis, a cam of ``cams:`` and an MC_CamTableSelect block (checked
when the file loads, with the allowed names), INT inputs, and a run of the shipped cam
machine whose slave follows the table exactly while synchronized."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from motionplc.config import ConfigError, build, load_config
from motionplc.sequence import InputRef, SequenceRunner, load_sequence

ROOT = Path(__file__).resolve().parents[2]
CONFIG = ROOT / "configs" / "cams" / "rotary_cam.yaml"

POWER = """\
steps:
  - name: power
    call:
      - {block: pd, type: MC_Power, axis: drum, enable: true}
      - {block: pp, type: MC_Power, axis: pusher, enable: true}
      - {block: pk, type: MC_Power, axis: knife, enable: true}
    until: {done: [pd, pp, pk]}
"""


def _load(tmp_path: Path, text: str):
    f = tmp_path / "seq.yaml"
    f.write_text(text)
    return load_sequence(f, load_config(CONFIG))


def _error(tmp_path: Path, text: str) -> str:
    with pytest.raises(ConfigError) as ei:
        _load(tmp_path, text)
    return str(ei.value)


def test_references_resolve_to_refs(tmp_path: Path) -> None:
    seq = _load(
        tmp_path,
        POWER
        + "  - call:\n"
        + "      - {block: sel, type: MC_CamTableSelect, slave: pusher, master: drum,"
        + " cam_table: pusher}\n"
        + "  - call:\n"
        + "      - {block: cam, type: MC_CamIn, slave: pusher, master: drum, cam_table_id: sel}\n"
        + "      - {block: g, type: MC_GearIn, slave: knife, master: drum, ratio_numerator: -3,"
        + " ratio_denominator: 2}\n",
    )
    calls = {c.block: dict(c.inputs) for st in seq.steps for c in st.calls}
    assert calls["sel"]["master"] == InputRef("axis", "drum")
    assert calls["sel"]["cam_table"] == InputRef("cam", "pusher")
    assert calls["cam"]["cam_table_id"] == InputRef("block", "sel")
    assert calls["g"]["ratio_numerator"] == -3 and type(calls["g"]["ratio_numerator"]) is int
    decl = {b.name: b for b in seq.blocks}
    assert decl["g"].axis == "knife" and decl["cam"].axis == "pusher"


@pytest.mark.parametrize(
    ("call", "message"),
    [
        (
            "{block: g, type: MC_GearIn, slave: knife, master: knife}",
            "steps[1].call[0].master: got string 'knife' (allowed: drum, pusher)",
        ),
        (
            "{block: g, type: MC_GearIn, slave: knife, master: spindle}",
            "steps[1].call[0].master: got string 'spindle' (allowed: drum, pusher)",
        ),
        (
            "{block: g, type: MC_GearIn, axis: knife, master: drum}",
            "steps[1].call[0].slave: missing (allowed: drum, pusher, knife)",
        ),
        (
            "{block: g, type: MC_GearIn, slave: knife, master: drum, ratio_numerator: 1.5}",
            "steps[1].call[0].ratio_numerator: got number 1.5 (allowed: an integer)",
        ),
        (
            "{block: s, type: MC_CamTableSelect, slave: pusher, master: drum, cam_table: cam9}",
            "steps[1].call[0].cam_table: got string 'cam9' (allowed: pusher, knife)",
        ),
        (
            "{block: c, type: MC_CamIn, slave: pusher, master: drum, cam_table_id: pd}",
            "steps[1].call[0].cam_table_id: got string 'pd' (allowed: an MC_CamTableSelect "
            "block used before (there is none so far))",
        ),
        (
            "{block: p, type: MC_TouchProbe, axis: pusher, trigger_input: 1, first_position: .nan}",
            "steps[1].call[0].first_position",
        ),
    ],
)
def test_reference_errors_are_located(tmp_path: Path, call: str, message: str) -> None:
    text = POWER + f"  - call:\n      - {call}\n"
    err = _error(tmp_path, text)
    assert f"seq.yaml:9: {message}" in err, err


def test_slave_key_suggests_master_slave_types(tmp_path: Path) -> None:
    err = _error(tmp_path, POWER + "  - call:\n      - {block: g, type: MC_Gear, slave: knife}\n")
    allowed = err.partition("(allowed: ")[2]
    assert "MC_GearIn" in allowed and "MC_CamIn" in allowed
    assert "MC_MoveAbsolute" not in allowed  # an axis FB, not a slave's


def test_cam_run_follows_the_table(tmp_path: Path) -> None:
    """The shipped cam machine run from YAML: while SYNCHRONIZED_MOTION the pusher is the cam
    of the drum's position (modulo one turn) to rounding, the knife 1/20 of the drum's travel
    since it geared in; both leave with CamOut / GearOut."""
    seq_text = (
        POWER
        + """\
  - call:
      - {block: sel, type: MC_CamTableSelect, slave: pusher, master: drum, cam_table: pusher}
    until: {done: [sel]}
  - call:
      - {block: cam, type: MC_CamIn, slave: pusher, master: drum, cam_table_id: sel}
      - {block: g, type: MC_GearIn, slave: knife, master: drum, ratio_numerator: 1,
         ratio_denominator: 20}
    until: {done: [cam, g]}
  - call: [{block: vd, type: MC_MoveVelocity, axis: drum, velocity: 3.0}]
    until: {done: [vd]}
  - wait: 1.5
  - call:
      - {block: go, type: MC_GearOut, slave: knife}
      - {block: co, type: MC_CamOut, slave: pusher}
    until: {done: [go, co]}
"""
    )
    seq = _load(tmp_path, seq_text)
    with build(load_config(CONFIG), check_invariants=True) as machine:
        runner = SequenceRunner(seq, machine)
        machine.attach(runner, seq.task)
        _run_and_check(machine, runner)


def _run_and_check(machine, runner) -> None:
    drum, pusher, knife = (machine.axes[n] for n in ("drum", "pusher", "knife"))
    cam = machine.cams["pusher"]
    rt = machine.runtime
    synced = 0
    worst = 0.0
    gear_base = None
    while not runner.over and rt.time < 10.0:
        rt.run(cycles=1)
        if pusher.state.name == "SYNCHRONIZED_MOTION":
            synced += 1
            worst = max(worst, abs(pusher.p - cam.at(drum.p % (2.0 * math.pi))[0]))
        if knife.state.name == "SYNCHRONIZED_MOTION":
            if gear_base is None:
                gear_base = (knife.p, drum.p)
            assert knife.p - gear_base[0] == pytest.approx(
                (drum.p - gear_base[1]) / 20.0, abs=1e-12
            )
    assert runner.finished and not runner.failed, runner.failures
    assert synced > 1000
    assert worst <= 1e-12
    assert pusher.state.name == "CONTINUOUS_MOTION"


JOG = """\
steps:
  - call: [{block: pw, type: MC_Power, axis: pusher, enable: true}]
    until: {done: [pw]}
  - name: hold the button
    call: [{block: j, type: MC_Jog, axis: pusher, jog_forward: true, mode: CONTINUOUS,
            velocity: 0.1}]
    until: {time: 0.5}
  - name: release
    call: [{block: j, jog_forward: false}]
    until: {done: [j]}
  - call: [{block: wp, type: MC_WriteParameter, axis: pusher, parameter_number: 9,
            value: 0.05}]
    until: {done: [wp]}
  - call: [{block: m, type: MC_MoveRelative, axis: pusher, distance: 0.1, velocity: VEL}]
    until: {done: [m]}
"""


def test_jog_buttons_and_parameter_writes_in_sequences(tmp_path: Path) -> None:
    """MC_Jog takes its buttons as they are (no Execute edge): held for 0.5 s, released, Done
    at rest; a literal MC_WriteParameter (9 MaxVelocityAppl) is applied to the checks of the
    later calls before the run, as the FB applies it at run time."""
    err = _error(tmp_path, JOG.replace("VEL", "0.1"))
    assert "seq.yaml:14: steps[4].call[0].velocity: got 0.1, above the axis' v_max 0.05" in err
    seq = _load(tmp_path, JOG.replace("VEL", "0.05"))
    with build(load_config(CONFIG), check_invariants=True) as machine:
        runner = SequenceRunner(seq, machine)
        machine.attach(runner, seq.task)
        pusher = machine.axes["pusher"]
        vmax = 0.0
        while not runner.over and machine.runtime.time < 10.0:
            machine.runtime.run(cycles=1)
            vmax = max(vmax, abs(pusher.v))
        assert runner.finished and not runner.failed, runner.failures
        jogged = 0.1 * 0.5  # the button held 0.5 s at 0.1 m/s (the ramps cancel: symmetric)
        assert pusher.p == pytest.approx(jogged + 0.1, abs=2e-3)
        assert vmax == pytest.approx(0.1)
        assert pusher.cfg.v_max == 0.05  # the written MaxVelocityAppl
