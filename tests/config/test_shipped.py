"""Every shipped configuration validates, and runs its sequence or program to the end
(simulated clock) with all expectations met."""

from __future__ import annotations

from pathlib import Path

import pytest

from motionplc.cli import main
from motionplc.config import build, load_config
from motionplc.sequence import runner_for

CONFIGS = Path(__file__).resolve().parents[2] / "configs"

# every machine configuration shipped in configs/ with the sequences and programs that belong
# to it (paths relative to configs/)
SHIPPED = [
    ("demo.yaml", "demo_sequence.yaml"),
    ("single_axis_can.yaml", "single_axis_sequence.yaml"),
    ("gantry.yaml", "gantry_sequence.yaml"),
    ("gantry.yaml", "gantry_groups_sequence.yaml"),
    ("gantry.yaml", "gcode/rounded_rectangle.ngc"),
    ("gantry.yaml", "gcode/planes_helix.ngc"),
    ("telescope.yaml", "telescope_program.py"),
    ("packaging.yaml", "packaging_sequence.yaml"),
    ("cams/rotary_cam.yaml", "cams/rotary_cam_program.py"),
]
# configurations without a program of their own in configs/: vcan0.yaml runs the single-axis
# sequence on real CAN (test_vcan0_config); the mills run the G-code corpus of tests/gcode
CONFIG_ONLY = {"vcan0.yaml", "gcode/mill3.yaml", "gcode/mill4.yaml"}
# data files read by a configuration (not configurations, sequences or programs)
DATA = {"cams/knife.csv", "gcode/tools.tbl"}


def _shipped_files() -> set[str]:
    return {str(p.relative_to(CONFIGS)) for p in CONFIGS.rglob("*") if p.is_file()}


def test_every_config_is_covered() -> None:
    """Every file of configs/ is a configuration with its programs, or a data file named here."""
    covered = {c for c, _ in SHIPPED} | {s for _, s in SHIPPED} | CONFIG_ONLY | DATA
    assert _shipped_files() == covered


@pytest.mark.parametrize(
    "name", sorted({c for c, _ in SHIPPED} | CONFIG_ONLY), ids=lambda n: n.replace("/", ":")
)
def test_validates(name: str) -> None:
    cfg = load_config(CONFIGS / name)
    assert cfg.axes and cfg.warnings == ()


@pytest.mark.parametrize(("config", "script"), SHIPPED)
def test_cli_validates_the_pair(
    config: str, script: str, capsys: pytest.CaptureFixture[str]
) -> None:
    """``motionplc validate CONFIG PROGRAM`` says ok for both (the G-code, sequence or Python
    program checked against its machine: axes, limits, software limits, arcs)."""
    assert main(["validate", str(CONFIGS / config), str(CONFIGS / script)]) == 0
    out = capsys.readouterr().out
    assert f"{script.rsplit('/', 1)[-1]}: ok" in out, out


# the G-code programs run on the gantry's CAN and Modbus drives for ~10 s of machine time each:
# validated above; rounded_rectangle.ngc runs in tests/gcode/test_gcode_runner.py
@pytest.mark.parametrize(("config", "script"), [p for p in SHIPPED if not p[1].endswith(".ngc")])
def test_runs_and_meets_expectations(config: str, script: str) -> None:
    cfg = load_config(CONFIGS / config)
    with build(cfg) as machine:
        runner, task = runner_for(CONFIGS / script, machine)
        machine.attach(runner, task)
        machine.runtime.run_until(lambda: runner.over, max_seconds=60.0)
        assert runner.failures == []
        assert runner.finished
        for ax in machine.axes.values():
            assert ax.state.name != "ERROR_STOP", (ax.name, ax.axis_error_reason)


def test_gantry_sync_move_arrives_together() -> None:
    cfg = load_config(CONFIGS / "gantry.yaml")
    with build(cfg) as machine:
        runner, task = runner_for(CONFIGS / "gantry_sequence.yaml", machine)
        machine.attach(runner, task)
        machine.runtime.run_until(lambda: runner.over, max_seconds=20.0)
        assert runner.finished
        trace = machine.runtime.trace
        ends = {}
        for ev in trace.events:
            if ev.fb.startswith(tuple(f"{a}.go." for a in "xyz")) and ev.output == "done":
                if ev.value and ev.fb not in ends:
                    ends[ev.fb] = ev.cycle
        assert len(ends) == 3
        assert max(ends.values()) - min(ends.values()) <= 2  # same cycle (+ task period)


@pytest.mark.vcan
def test_vcan0_config() -> None:
    """The shipped vcan0 configuration with its drive in this process (drives: simulated, the
    simulated clock: the drive on its own socket of the kernel's vcan0)."""
    assert (
        main(["run", str(CONFIGS / "vcan0.yaml"), str(CONFIGS / "single_axis_sequence.yaml"), "-q"])
        == 0
    )


def test_blend_replan_budget_reaches_the_runtime(tmp_path: Path) -> None:
    text = (CONFIGS / "demo.yaml").read_text()
    assert "blend_replans_per_cycle" not in text
    with build(load_config(CONFIGS / "demo.yaml")) as machine:
        assert machine.runtime._budget is not None and machine.runtime._budget.per_cycle == 2
    cfg = tmp_path / "budget.yaml"
    cfg.write_text(text.replace("runtime:\n", "runtime:\n  blend_replans_per_cycle: 5\n", 1))
    with build(load_config(cfg)) as machine:
        assert machine.runtime._budget is not None and machine.runtime._budget.per_cycle == 5


def test_trace_byte_budget_reaches_the_runtime(tmp_path: Path) -> None:
    text = (CONFIGS / "demo.yaml").read_text()
    with build(load_config(CONFIGS / "demo.yaml")) as machine:
        assert machine.runtime.trace.nbytes <= 32 * 1024 * 1024
        default_rows = machine.runtime.trace.rows_capacity
    cfg = tmp_path / "trace.yaml"
    cfg.write_text(text.replace("runtime:\n", "runtime:\n  trace_bytes: 1048576\n", 1))
    with build(load_config(cfg)) as machine:
        assert machine.runtime.trace.rows_capacity < default_rows / 16


def test_can_frame_budget_reaches_the_master(tmp_path: Path) -> None:
    text = (CONFIGS / "demo.yaml").read_text()
    assert "max_frames_per_cycle" not in text
    with build(load_config(CONFIGS / "demo.yaml")) as machine:
        masters = {id(ax.drive.master): ax.drive.master for ax in machine.axes.values()}
        assert [m.rx.max_frames for m in masters.values()] == [256]
    cfg = tmp_path / "frames.yaml"
    cfg.write_text(
        text.replace("    type: can\n", "    type: can\n    max_frames_per_cycle: 64\n", 1)
    )
    assert "max_frames_per_cycle: 64" in cfg.read_text()
    with build(load_config(cfg)) as machine:
        masters = {id(ax.drive.master): ax.drive.master for ax in machine.axes.values()}
        assert [m.rx.max_frames for m in masters.values()] == [64]
