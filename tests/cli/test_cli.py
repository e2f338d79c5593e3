"""The command line in-process: run / validate / plot / drives and their exit codes."""

from __future__ import annotations

import csv
import json
import re
from pathlib import Path

import pytest

from motionplc.cli import main

CONFIGS = Path(__file__).resolve().parents[2] / "configs"
DEMO = str(CONFIGS / "demo.yaml")
DEMO_SEQ = str(CONFIGS / "demo_sequence.yaml")

IDEAL = """\
runtime:
  tasks:
    motion: {period: 0.001}
axes:
  x:
    limits: {v_max: 1.0, a_max: 4.0, j_max: 40.0}
"""


def _write(tmp_path: Path, name: str, text: str) -> str:
    p = tmp_path / name
    p.write_text(text)
    return str(p)


def test_demo_run_writes_trace_and_plots(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    trace = tmp_path / "demo.csv"
    png = tmp_path / "demo.png"
    code = main(["run", DEMO, DEMO_SEQ, "--trace", str(trace), "--plot", str(png)])
    out, err = capsys.readouterr()
    assert code == 0, err
    assert "all expectations met" in out
    assert "moves done" in out and "STANDSTILL" in out  # summary table
    with trace.open() as fh:
        header = next(csv.reader(fh))
    assert header[:2] == ["cycle", "t"] and "x.position" in header and "y.state" in header
    assert (tmp_path / "demo.events.csv").is_file()
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    # plot the written trace again, as PNG and as HTML
    assert main(["plot", str(trace), "-o", str(tmp_path / "again.png")]) == 0
    assert main(["plot", str(trace), "-o", str(tmp_path / "scope.html")]) == 0
    page = (tmp_path / "scope.html").read_text()
    from tests.cli.test_scope import plotly_figure

    data, layout, _ = plotly_figure(page)  # the figure itself, not plotly.js' own source
    names = {d.get("name") for d in data}
    assert {"x.position", "x.actual_position", "y.position", "x.following_error"} <= names
    assert "axis x" in repr(layout) and "mx1" in repr([data, layout])


def test_validate_ok(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["validate", DEMO, DEMO_SEQ]) == 0
    out = capsys.readouterr().out
    assert "ok - 2 axes" in out and "steps" in out
    assert (
        main(["validate", str(CONFIGS / "telescope.yaml"), str(CONFIGS / "telescope_program.py")])
        == 0
    )


def test_failed_expectation_exits_1(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    cfg = _write(tmp_path, "m.yaml", IDEAL)
    seq = _write(
        tmp_path,
        "s.yaml",
        "steps:\n"
        "  - call: [{block: p, type: MC_Power, axis: x, enable: true}]\n"
        "  - call: [{block: m, type: MC_MoveAbsolute, axis: x, position: 0.5, velocity: 1.0}]\n"
        "    expect: {x.position: 0.6, within: 1.0e-6}\n",
    )
    assert main(["run", cfg, seq, "-q"]) == 1
    err = capsys.readouterr().err
    assert f"FAILED: {seq}: line 4: expectation failed in step 'step 2'" in err
    assert "x.position = 0.5 (error -0.1), expected 0.6 within 1e-06" in err


def test_fb_error_exits_1(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    cfg = _write(tmp_path, "m.yaml", IDEAL)
    seq = _write(
        tmp_path,
        "s.yaml",
        "steps:\n"
        "  - call: [{block: m, type: MC_MoveAbsolute, axis: x, position: 0.5, velocity: 1.0}]\n",
    )
    assert main(["run", cfg, seq, "-q"]) == 1
    err = capsys.readouterr().err
    assert "block 'm' (MC_MoveAbsolute on axis 'x', line 2) failed with STATE_DISABLED" in err


def test_step_timeout_and_parallel(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    cfg = _write(tmp_path, "m.yaml", IDEAL)
    seq = _write(
        tmp_path,
        "s.yaml",
        "steps:\n"
        "  - call: [{block: p, type: MC_Power, axis: x, enable: true}]\n"
        "  - name: slow\n"
        "    call: [{block: m, type: MC_MoveAbsolute, axis: x, position: 2.0, velocity: 0.5}]\n"
        "    timeout: 1.0\n",
    )
    assert main(["run", cfg, seq, "-q"]) == 1
    err = capsys.readouterr().err
    assert "step 'slow' (line 3) timed out after 1 s (condition not met: not done: m)" in err


def test_program_exception_exits_1(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    cfg = _write(tmp_path, "m.yaml", IDEAL)
    prog = _write(
        tmp_path,
        "p.py",
        "def program(ctx):\n    if ctx.t > 0.01:\n        raise RuntimeError('boom')\n",
    )
    assert main(["run", cfg, prog, "-q"]) == 1
    err = capsys.readouterr().err
    assert f"{prog}:3: program raised RuntimeError: boom" in err


def test_program_done_and_seconds(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    cfg = _write(tmp_path, "m.yaml", IDEAL)
    prog = _write(
        tmp_path,
        "p.py",
        "from motionplc.blocks import MC_MoveRelative, MC_Power\n"
        "power = MC_Power()\nmove = MC_MoveRelative()\n"
        "def program(ctx):\n"
        "    x = ctx.axes['x']\n"
        "    power(axis=x, enable=True)\n"
        "    move(axis=x, execute=power.status, distance=0.25, velocity=0.5)\n"
        "    if move.done:\n"
        "        ctx.expect('x.position', x.position, 0.25, within=1e-9)\n"
        "        ctx.done()\n",
    )
    assert main(["run", cfg, prog]) == 0
    assert "all expectations met" in capsys.readouterr().out
    assert main(["run", cfg, "--seconds", "0.5", "-q"]) == 0
    assert main(["run", cfg, "--seconds", "-1"]) == 2


def test_plot_rejects_a_non_trace(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    bad = _write(tmp_path, "x.csv", "a,b\n1,2\n")
    assert main(["plot", bad]) == 2
    assert "not a motionplc trace" in capsys.readouterr().err


def test_drives_serves_modbus_of_the_gantry(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["drives", str(CONFIGS / "gantry.yaml"), "--duration", "0.2", "--json"]) == 0
    out, err = capsys.readouterr()
    info = json.loads(out.strip().splitlines()[-1])
    assert list(info["modbus"]) == ["1"] and info["modbus"]["1"] > 0
    assert "virtual bus does not reach other processes" in err


def test_drives_says_what_it_serves_in_words(capsys: pytest.CaptureFixture[str]) -> None:
    """issue 30: a readable line per bus by default (the JSON record with --json)."""
    assert main(["drives", str(CONFIGS / "gantry.yaml"), "--duration", "0.2"]) == 0
    out = capsys.readouterr().out.strip().splitlines()
    assert len(out) == 1, out
    assert re.fullmatch(
        r"bus 'mb0': Modbus TCP on 127\.0\.0\.1:\d+: unit 1 \(z\); serving for 0\.2 s", out[0]
    ), out[0]


def test_plan_still_works(tmp_path: Path) -> None:
    assert main(["plan", "--pf", "1", "--csv", str(tmp_path / "p.csv")]) == 0
