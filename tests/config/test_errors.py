"""The table of malformed configurations and sequences: exact error text, no traceback."""

from __future__ import annotations

from pathlib import Path

import pytest

from motionplc.cli import main
from motionplc.config import load_config
from motionplc.errors import ConfigError
from motionplc.sequence import load_sequence
from tests.config.cases import BASE, CONFIG_CASES, SEQUENCE_CASES


def test_table_is_large_enough() -> None:
    assert len(CONFIG_CASES) + len(SEQUENCE_CASES) >= 25


@pytest.mark.parametrize(
    ("name", "text", "expected"), CONFIG_CASES, ids=[c[0] for c in CONFIG_CASES]
)
def test_config_error(tmp_path: Path, name: str, text: str, expected: list[str]) -> None:
    f = tmp_path / "machine.yaml"
    f.write_text(text)
    with pytest.raises(ConfigError) as info:
        load_config(f)
    want = [e.replace("{f}", str(f)) for e in expected]
    assert list(info.value.errors) == want
    assert str(info.value) == "\n".join(want)


@pytest.mark.parametrize(
    ("name", "text", "expected"), SEQUENCE_CASES, ids=[c[0] for c in SEQUENCE_CASES]
)
def test_sequence_error(tmp_path: Path, name: str, text: str, expected: list[str]) -> None:
    cfg = tmp_path / "machine.yaml"
    cfg.write_text(BASE)
    f = tmp_path / "seq.yaml"
    f.write_text(text)
    with pytest.raises(ConfigError) as info:
        load_sequence(f, load_config(cfg))
    assert list(info.value.errors) == [e.replace("{f}", str(f)) for e in expected]


@pytest.mark.parametrize(("name", "text", "expected"), CONFIG_CASES[:8] + CONFIG_CASES[-3:])
def test_cli_validate_reports_without_traceback(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], name: str, text: str, expected: list[str]
) -> None:
    f = tmp_path / "machine.yaml"
    f.write_text(text)
    assert main(["validate", str(f)]) == 2
    out, err = capsys.readouterr()
    assert "Traceback" not in out + err
    for e in expected:
        assert e.replace("{f}", str(f)) in err


def test_sequence_errors_through_run_start_nothing(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    cfg = tmp_path / "machine.yaml"
    cfg.write_text(BASE)
    seq = tmp_path / "seq.yaml"
    seq.write_text(SEQUENCE_CASES[0][1])
    assert main(["run", str(cfg), str(seq)]) == 2
    out, err = capsys.readouterr()
    assert "running" not in out  # validated before anything was built
    assert SEQUENCE_CASES[0][2][0].replace("{f}", str(seq)) in err


def test_float_exponent_without_dot_is_a_number(tmp_path: Path) -> None:
    f = tmp_path / "m.yaml"
    f.write_text(
        BASE.replace("a_max: 2.0}\n    drive: {bus: mb0", "a_max: 2e0}\n    drive: {bus: mb0")
    )
    assert load_config(f).axis("y").limits.a_max == 2.0


def test_missing_file_and_program_errors(tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match="cannot read"):
        load_config(tmp_path / "nope.yaml")
    from motionplc.program import load_program

    bad = tmp_path / "p.py"
    bad.write_text("x = 1\n\ndef program(ctx):\n    return (\n")
    with pytest.raises(ConfigError, match=r"p\.py:4: syntax error"):
        load_program(bad)
    bad.write_text("def program():\n    pass\n")
    with pytest.raises(ConfigError, match=r"p\.py:1: program: takes 0 parameters"):
        load_program(bad)
