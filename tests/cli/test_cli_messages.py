"""Messages a new user meets (issue 30, point 6): the option a value came from, the program
types by suffix."""

from __future__ import annotations

from pathlib import Path

import pytest

from motionplc.cli import _plan_option_message, main

CONFIGS = Path(__file__).resolve().parents[2] / "configs"
PLAN = ["plan", "--pf", "1", "--v-max", "1", "--a-max", "1", "--j-max", "1"]


@pytest.mark.parametrize(
    ("extra", "expected"),
    [
        (["--v-max", "-1"], "--v-max: must be in [1e-15, 1e+15] or inf"),
        (["--a-max", "0"], "--a-max: must be in [1e-15, 1e+15] or inf"),
        (["--j-max", "-2"], "--j-max: must be in"),
        (["--v-min", "3"], "--v-min: must be in [-1e+15, -1e-15] or -inf"),
        (["--a-min", "2"], "--a-min: must be in [-1e+15, -1e-15] or -inf"),
        (["--pf", "1e300"], "--pf: must be a finite number in [-1e+12, 1e+12], got 1e+300"),
        (["--p0=-1e300"], "--p0: must be a finite number"),
    ],
)
def test_plan_names_the_option(
    extra: list[str], expected: str, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(PLAN + extra) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith(f"motionplc: error: {expected}"), err
    assert "Limits." not in err and "start." not in err and "target." not in err


def test_plan_option_message_keeps_other_text() -> None:
    assert _plan_option_message("something else: Limits.v_max") == "something else: --v-max"
    assert _plan_option_message("unrelated text") == "unrelated text"


@pytest.mark.parametrize("name", ["program.txt", "program", "program.json"])
def test_an_unknown_program_type_says_which_types_exist(
    name: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = tmp_path / name
    path.write_text("steps: []\n")
    for cmd in ("validate", "run"):
        assert main([cmd, str(CONFIGS / "demo.yaml"), str(path)]) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert err == [
            f"motionplc: error: {path}: unknown program type "
            f"{repr(path.suffix) if path.suffix else '(none)'} (allowed: .yaml or .yml "
            "sequence, .py Python program, .ngc, .nc, .gcode, .tap G-code)"
        ], err
