"""Hostile and broken trace files given to ``motionplc plot``: one located line, exit code 2,
bounded memory (issue 31). The large ones are generated here, never committed."""

from __future__ import annotations

import json
import re
from collections.abc import Callable
from pathlib import Path

import pytest

from motionplc.cli import main
from tests.config.test_hostile_files import _peak_meter

HEAD = "cycle,t,x.position,x.velocity,x.acceleration,x.jerk,x.state\n"


def _rows(n: int) -> str:
    return "".join(f"{i},{i * 0.001},0.0,0.0,0.0,0.0,STANDSTILL\n" for i in range(n))


def _w(name: str, text: str | bytes) -> Callable[[Path], Path]:
    def make(d: Path) -> Path:
        p = d / name
        p.write_bytes(text.encode() if isinstance(text, str) else text)
        return p

    return make


def _with_sidecar(suffix: str, content: str) -> Callable[[Path], Path]:
    def make(d: Path) -> Path:
        p = d / "t.csv"
        p.write_text(HEAD + _rows(10))
        p.with_suffix(suffix).write_text(content)
        return p

    return make


CASES: list[tuple[str, Callable[[Path], Path], str, str]] = [
    ("one_3MB_line", _w("t.csv", "cycle,t," + "x" * 3_000_000), "1", "a line of more than"),
    ("second_line_2MB", _w("t.csv", HEAD + "1," * 1_000_000 + "\n"), "2", "a line of more than"),
    (
        "columns_20000",
        _w("t.csv", "cycle,t," + ",".join(f"c{i}" for i in range(20_000)) + "\n"),
        "1",
        "20002 columns (allowed: at most 10000)",
    ),
    (
        "bad_number_late",
        _w("t.csv", HEAD + _rows(100_000) + "1,0.1,nan?,0,0,0,STANDSTILL\n"),
        "100002",
        "x.position: not a number: 'nan?'",
    ),
    ("short_row", _w("t.csv", HEAD + _rows(4) + "1,2\n"), "6", "2 values for 7 columns"),
    (
        "latin1",
        _w("t.csv", HEAD.encode() + b"0,0,caf\xe9,0,0,0,STANDSTILL\n"),
        r"\d+",
        "cannot read",
    ),
    ("binary", _w("t.csv", bytes(range(256)) * 100), "1", ""),
    ("empty", _w("t.csv", ""), "1", "not a motionplc trace"),
    ("escape_state", _w("t.csv", HEAD + "0,0,0,0,0,0,\x1b[2J\n"), "2", "not a number: '\\x1b[2J'"),
    (
        "units_nested",
        _with_sidecar(".units.json", "[" * 100_000 + "]" * 100_000),
        "1",
        "nested too deeply",
    ),
    (
        "groups_5MB",
        _with_sidecar(".groups.json", json.dumps({"g": ["x"] * 1_000_000})),
        "",
        "more than 4 MB",
    ),
    (
        "events_bad_row",
        _with_sidecar(".events.csv", "cycle,fb,output,value\n1,a,done,True\nx,y\n"),
        "3",
        "not an FB edge",
    ),
]


@pytest.mark.parametrize(("name", "make", "line", "text"), CASES, ids=[c[0] for c in CASES])
def test_hostile_trace_is_one_located_line(
    name: str,
    make: Callable[[Path], Path],
    line: str,
    text: str,
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
) -> None:
    path = make(tmp_path)
    capsys.readouterr()
    start, peak_since = _peak_meter()
    start()
    rc = main(["plot", str(path), "-o", str(tmp_path / "out.png")])
    peak = peak_since()
    err = capsys.readouterr().err
    lines = err.splitlines()
    assert rc == 2, err[:2000]
    assert len(lines) == 1, err[:2000]
    assert re.match(rf"motionplc: error: {re.escape(str(tmp_path))}/t\.\S+:{line}", lines[0])
    assert text in lines[0], lines[0]
    assert lines[0].isprintable() and len(lines[0]) < 600
    assert peak < 200 * 1024 * 1024, f"{peak / 1e6:.0f} MB"
