"""A Python program's module constants as campaign values (``program.NAME``), a machine
without a program (``seconds``), and G-code programs refused as value targets."""

from __future__ import annotations

from pathlib import Path

import pytest

from motionplc.campaign import load_campaign, run_campaign
from motionplc.errors import ConfigError
from tests.campaign.conftest import DEMO, ROOT

PROGRAM = """\
from motionplc.blocks import MC_MoveAbsolute, MC_Power

TIMEOUT = 1.0
TARGET = 0.01

power = MC_Power()
move = MC_MoveAbsolute()


def program(ctx):
    x = ctx.axes["x"]
    power(axis=x, enable=True)
    if not power.status:
        return
    move(axis=x, execute=True, position=TARGET, velocity=0.2)
    if move.error:
        ctx.fail(f"move to {TARGET} refused: {move.error_id.name}")
    elif move.done:
        ctx.done()
"""


def _campaign(tmp: Path, body: str) -> Path:
    (tmp / "prog.py").write_text(PROGRAM, encoding="utf-8")
    p = tmp / "c.yaml"
    p.write_text(f"config: {DEMO}\nprogram: prog.py\n" + body, encoding="utf-8")
    return p


def test_module_constants_are_varied(tmp_path: Path) -> None:
    c = load_campaign(_campaign(tmp_path, "grid:\n  program.TARGET: [0.01, 0.03, 2.0]\n"))
    res = run_campaign(c, workers=0, output=tmp_path / "o", quiet=True)
    rows = res.table
    assert [r["verdict"] for r in rows] == ["pass", "pass", "fail"]
    assert rows[0]["end_time"] < rows[1]["end_time"]  # the longer move ends later
    assert "move to 2.0 refused" in rows[2]["failures"]


def test_unknown_or_mistyped_constants_are_refused(tmp_path: Path) -> None:
    with pytest.raises(ConfigError) as ei:
        load_campaign(
            _campaign(tmp_path, "grid:\n  program.SPEED: [1.0]\n  program.TARGET: [fast]\n")
        )
    text = str(ei.value)
    assert "grid.program.SPEED[0]: 1.0 is refused: prog.py: no module constant 'SPEED'" in text
    assert "grid.program.TARGET[0]: 'fast' is refused: str for the constant TARGET" in text


def test_gcode_programs_have_no_program_values(tmp_path: Path) -> None:
    (tmp_path / "job.ngc").write_text("G21 G90\nG1 X10 Y10 F600\nM2\n", encoding="utf-8")
    p = tmp_path / "g.yaml"
    p.write_text(
        f"config: {ROOT / 'configs' / 'gcode' / 'mill3.yaml'}\nprogram: job.ngc\n"
        "grid:\n  program.F: [100]\n",
        encoding="utf-8",
    )
    with pytest.raises(ConfigError) as ei:
        load_campaign(p)
    assert "a G-code program has no values to vary" in str(ei.value)


def test_without_a_program_the_machine_idles_for_seconds(tmp_path: Path) -> None:
    p = tmp_path / "idle.yaml"
    p.write_text(f"config: {DEMO}\nseconds: 0.05\ngrid:\n  plant.x.kp: [50, 200]\n")
    res = run_campaign(load_campaign(p), workers=0, output=tmp_path / "o", quiet=True)
    assert [r["verdict"] for r in res.table] == ["pass", "pass"]
    assert [r["cycles"] for r in res.table] == [50, 50]
