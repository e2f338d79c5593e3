"""What the CLI says (issue 14, point 7): help with defaults and units for every option, exit
codes in ``--help``, ``--version``, singular/plural, no ``-0``, enums printed by name, the
``drives`` announcement of a configuration without CAN drives, ``plot --out``, ``schema``."""

from __future__ import annotations

import argparse
import json
import re
from importlib import metadata
from pathlib import Path

import jsonschema
import pytest

from motionplc import schema
from motionplc.blocks.enums import AxisState, BufferMode, ErrorID, GroupState, TransitionMode
from motionplc.cli import EXIT_CODES_HELP, _num, _plural, build_parser, main

CONFIGS = Path(__file__).resolve().parents[2] / "configs"

IDEAL = """\
runtime:
  tasks:
    motion: {period: 0.001}
axes:
  x:
    limits: {v_max: 1.0, a_max: 4.0, j_max: 40.0}
"""


def _subparsers(parser: argparse.ArgumentParser) -> dict[str, argparse.ArgumentParser]:
    action = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    return dict(action.choices)


def test_every_option_of_every_command_has_help_with_its_default() -> None:
    parser = build_parser()
    commands = _subparsers(parser)
    assert set(commands) == {
        "run",
        "validate",
        "plot",
        "drives",
        "plan",
        "schema",
        "examples",
        "campaign",
    }
    for name, sub in commands.items():
        for action in sub._actions:
            if isinstance(action, argparse._HelpAction):
                continue
            where = f"{name} {'/'.join(action.option_strings) or action.dest}"
            assert action.help, where
            if action.option_strings:
                assert "default" in action.help, where
    # plan: a unit with every number
    for action in commands["plan"]._actions:
        if action.option_strings and action.dest not in ("help", "debug", "csv", "plot"):
            assert re.search(r"\[(m|m/s|m/s\^2|m/s\^3|m or rad|s)\]", action.help or ""), action


def test_help_shows_the_exit_codes(capsys: pytest.CaptureFixture[str]) -> None:
    for argv in (["--help"], ["run", "--help"], ["drives", "--help"]):
        assert main(argv) == 0
        out = capsys.readouterr().out
        assert EXIT_CODES_HELP in out, argv
    import motionplc.cli

    for code in ("0", "1", "2", "3", "130"):
        assert re.search(rf"^  {code} +\S", EXIT_CODES_HELP, re.M)
        assert f"* {code} " in (motionplc.cli.__doc__ or ""), code


def test_plan_help_lists_defaults_and_units(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["plan", "--help"]) == 0
    out = " ".join(capsys.readouterr().out.split())
    assert "--pf X target position [m or rad] (default: 6)" in out
    assert "--j-max X jerk limit (inf: trapezoidal profile) [m/s^3] (default: 1)" in out
    assert "--dt S sample period of --csv and --plot [s] (default: 0.001)" in out


def test_version(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["--version"]) == 0
    import motionplc

    core = motionplc.compiled_core().reason
    assert capsys.readouterr().out == (
        f"motionplc {metadata.version('motionplc')} (planning core: {core})\n"
    )


def test_singular_and_plural(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert [_plural(n, "bus", "buses") for n in (0, 1, 2)] == ["0 buses", "1 bus", "2 buses"]
    cfg = tmp_path / "m.yaml"
    cfg.write_text(IDEAL)
    assert main(["validate", str(cfg)]) == 0
    assert capsys.readouterr().out == f"{cfg}: ok - 1 axis (x), 0 buses, task: motion 1 ms\n"
    assert main(["validate", str(CONFIGS / "gantry.yaml")]) == 0
    assert "ok - 3 axes (x, y, z), 2 buses, task: motion 2 ms" in capsys.readouterr().out


def test_no_negative_zero_in_printed_numbers(capsys: pytest.CaptureFixture[str]) -> None:
    assert _num(-0.0) == "0" and _num(-1e-20, ".5f") == "0.00000" and _num(-0.5) == "-0.5"
    # planning a move in the negative direction gives -0.0 jerks and accelerations
    assert main(["plan", "--pf", "-6"]) == 0
    out = capsys.readouterr().out
    rows = [line.split() for line in out.splitlines() if line.split()[:1] in (["1"], ["2"])]
    assert rows and rows[1][3] == "0"  # the constant-acceleration phase: jerk 0
    assert not re.search(r"(?<![\w.])-0(\.0*)?(?![\w.])", out), out


def test_enums_print_by_name() -> None:
    assert str(AxisState.STANDSTILL) == "AxisState.STANDSTILL"
    assert f"{ErrorID.INVALID_VELOCITY}" == "ErrorID.INVALID_VELOCITY"
    assert f"{GroupState.GROUP_MOVING:<25}|" == "GroupState.GROUP_MOVING  |"
    assert "%s" % BufferMode.BUFFERED == "BufferMode.BUFFERED"  # noqa: UP031
    assert str(TransitionMode.TM_NONE) == "TransitionMode.TM_NONE"
    # still the PLCopen numbers underneath
    assert f"{ErrorID.INVALID_VELOCITY:#06x}" == "0x1003" and f"{AxisState.HOMING:d}" == "2"
    assert int(ErrorID.INVALID_VELOCITY) == 4099 and AxisState.STANDSTILL == 1
    assert repr(AxisState.STANDSTILL) == "<AxisState.STANDSTILL: 1>"


def test_a_program_printing_axis_state_and_error_id(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    cfg = tmp_path / "m.yaml"
    cfg.write_text(IDEAL)
    prog = tmp_path / "p.py"
    prog.write_text(
        "from motionplc.blocks import MC_MoveVelocity, MC_Power\n"
        "power, jog = MC_Power(), MC_MoveVelocity()\n"
        "def program(ctx):\n"
        "    x = ctx.axes['x']\n"
        "    power(axis=x, enable=True)\n"
        "    jog(axis=x, execute=power.status, velocity=-5.0)\n"
        "    if jog.error:\n"
        "        print(x.state, jog.error_id)\n"
        "        ctx.done()\n"
    )
    assert main(["run", str(cfg), str(prog), "-q"]) == 0
    out = capsys.readouterr().out
    assert out.splitlines()[0] == "AxisState.STANDSTILL ErrorID.INVALID_VELOCITY"


def test_drives_of_a_config_without_can_drives_announce_no_can(
    capsys: pytest.CaptureFixture[str],
) -> None:
    """issue 14: ``drives configs/gantry.yaml`` reported socketcan/vcan0 for a virtual bus."""
    assert main(["drives", str(CONFIGS / "gantry.yaml"), "--duration", "0.2", "--json"]) == 0
    out, err = capsys.readouterr()
    info = json.loads(out.strip().splitlines()[-1])
    assert set(info) == {"modbus"} and list(info["modbus"]) == ["1"]
    assert "socketcan" not in out and "vcan0" not in out
    assert err.startswith("motionplc: bus 'can0': the python-can virtual bus does not reach")


def test_plot_accepts_out_as_in_the_readme(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    cfg = tmp_path / "m.yaml"
    cfg.write_text(IDEAL)
    trace = tmp_path / "t.csv"
    assert main(["run", str(cfg), "--seconds", "0.05", "-q", "--trace", str(trace)]) == 0
    capsys.readouterr()
    for option in ("--out", "-o", "--output"):
        assert build_parser().parse_args(["plot", "t.csv", option, "s.png"]).output == "s.png"
    out = tmp_path / "scope.png"
    assert main(["plot", str(trace), "--out", str(out)]) == 0
    assert capsys.readouterr().out == f"wrote {out}\n"
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_trace_as_parquet_and_plotted(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    pq = pytest.importorskip("pyarrow.parquet")
    cfg = tmp_path / "m.yaml"
    cfg.write_text(IDEAL)
    trace = tmp_path / "t.parquet"
    assert main(["run", str(cfg), "--seconds", "0.05", "-q", "--trace", str(trace)]) == 0
    assert capsys.readouterr().out.startswith(
        f"wrote {trace} (50 rows) and {tmp_path / 't.events.parquet'}\n"
    )
    table = pq.read_table(trace)
    assert table.num_rows == 50 and table.column_names[:2] == ["cycle", "t"]
    assert (tmp_path / "t.events.parquet").is_file()
    assert main(["plot", str(trace), "-o", str(tmp_path / "p.html")]) == 0


@pytest.mark.parametrize("kind", ["config", "sequence", "register_map"])
def test_schema_command(kind: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["schema", kind]) == 0
    printed = json.loads(capsys.readouterr().out)
    assert printed == schema.json_schema(kind)
    jsonschema.Draft202012Validator.check_schema(printed)
    out = tmp_path / f"{kind}.md"
    assert main(["schema", kind, "--format", "markdown", "-o", str(out)]) == 0
    assert capsys.readouterr().out == f"wrote {out} ({kind}, markdown)\n"
    assert out.read_text().rstrip("\n") == schema.reference_markdown(kind).rstrip("\n")


def test_schema_defaults_and_errors(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["schema"]) == 0
    assert json.loads(capsys.readouterr().out) == schema.json_schema("config")
    assert main(["schema", "gcode"]) == 2
    assert "invalid choice: 'gcode'" in capsys.readouterr().err
    assert main(["schema", "-o", str(tmp_path / "x.md")]) == 2
    assert capsys.readouterr().err == (
        f"motionplc: error: --output: {tmp_path / 'x.md'}: unsupported file type '.md' "
        "(allowed: .json)\n"
    )
