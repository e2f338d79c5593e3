"""What the CLI says when a run fails (issue 11, finding 6), and what it keeps quiet.

* the FAILED line of an FB that failed because its axis stopped names the axis, its error,
  code and reason (the drive's or kernel's text), not only ``AXIS_ERROR_STOP (0x4000)``;
* a Modbus drive process that stops answering mid-move: the reason reaches the FAILED line and
  no pymodbus log line reaches stderr;
* the fieldbus libraries' log records (pymodbus, canopen, python-can) are silent by default and
  shown with ``-v``; the logger levels are restored after the command;
* a run longer than the trace bound writes the kept cycles and says how many were dropped; the
  truncated trace still plots.
"""

from __future__ import annotations

import json
import logging
import os
import re
import selectors
import subprocess
import sys
from pathlib import Path

import pytest

from motionplc.cli import LIBRARY_LOGGERS, main

ROOT = Path(__file__).resolve().parents[2]

CAN_TIGHT = """\
runtime:
  tasks:
    motion: {period: 0.001}
buses:
  can0: {type: can, interface: virtual, channel: CHANNEL, drives: simulated}
axes:
  x:
    limits: {v_max: 0.5, a_max: 2.0, j_max: 20.0}
    following_error: 1.0e-6
    drive: {bus: can0, node_id: 1, counts_per_unit: 1.0e6}
"""

MOVE_X = """\
steps:
  - name: power
    call: [{block: p, type: MC_Power, axis: x, enable: true}]
    timeout: 1.0
  - name: move_x
    call: [{block: m, type: MC_MoveAbsolute, axis: x, position: 0.5, velocity: 0.5}]
"""

# the drive reports its (lagging) position: a 1 um limit trips early in the move
FAILED_FE = re.compile(
    r"^FAILED: \S+: block 'm' \(MC_MoveAbsolute on axis 'x', line 6\) failed with "
    r"AXIS_ERROR_STOP \(0x4000\) at t = [0-9.]+ s in step 'move_x' \(line 5\): "
    r"axis 'x': FOLLOWING_ERROR \(0x4002\): following error ([0-9.e+-]+) exceeds 1e-06$",
    re.M,
)


def _write(tmp_path: Path, name: str, text: str) -> str:
    p = tmp_path / name
    p.write_text(text)
    return str(p)


def test_fb_failure_names_the_axis_error_code_and_reason(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    cfg = _write(tmp_path, "m.yaml", CAN_TIGHT.replace("CHANNEL", f"cli_fe_{os.getpid()}"))
    seq = _write(tmp_path, "s.yaml", MOVE_X)
    assert main(["run", cfg, seq, "-q"]) == 1
    out, err = capsys.readouterr()
    m = FAILED_FE.search(err)
    assert m, err
    assert float(m.group(1)) > 1e-6
    assert "ERROR_STOP" in out  # the summary table still shows the final state
    assert err.count("FAILED:") == 1  # the axis is named once, by the FB's line


def test_library_logs_are_quiet_by_default_and_shown_with_v(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    cfg = _write(tmp_path, "m.yaml", CAN_TIGHT.replace("CHANNEL", f"cli_log_{os.getpid()}"))
    prog = _write(
        tmp_path,
        "p.py",
        "import logging\n"
        "def program(ctx):\n"
        "    if ctx.cycle == 3:\n"
        "        logging.getLogger('pymodbus.logging').error('Repeating....')\n"
        "        logging.getLogger('canopen.pdo.base').warning('PDO is disabled')\n"
        "        logging.getLogger('can.interfaces.virtual').error('bus is gone')\n"
        "        logging.getLogger('motionplc.fieldbus.can').warning('3 malformed frames')\n"
        "        ctx.done()\n",
    )
    before = {n: logging.getLogger(n).level for n in (*LIBRARY_LOGGERS, "motionplc")}
    assert main(["run", cfg, prog, "-q"]) == 0
    err = capsys.readouterr().err
    assert "pymodbus" not in err and "Repeating" not in err
    assert "canopen" not in err and "bus is gone" not in err
    assert "WARNING motionplc.fieldbus.can: 3 malformed frames" in err  # our own warnings stay
    assert main(["run", cfg, prog, "-q", "-v"]) == 0
    err = capsys.readouterr().err
    assert "ERROR pymodbus.logging: Repeating...." in err
    assert "WARNING canopen.pdo.base: PDO is disabled" in err
    assert "ERROR can.interfaces.virtual: bus is gone" in err
    assert {n: logging.getLogger(n).level for n in before} == before


class _DrivesProcess:
    """``python -m motionplc.fieldbus.drives_main --modbus 1`` that ends after ``duration``."""

    def __init__(self, duration: float) -> None:
        env = dict(os.environ, PYTHONPATH=str(ROOT))
        cmd = [sys.executable, "-m", "motionplc.fieldbus.drives_main", "--modbus", "1"]
        cmd += ["--duration", str(duration)]
        self.proc = subprocess.Popen(
            cmd, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, env=env, text=True
        )
        assert self.proc.stdout is not None
        sel = selectors.DefaultSelector()
        sel.register(self.proc.stdout, selectors.EVENT_READ)
        if not sel.select(timeout=30.0):
            self.stop()
            raise AssertionError("drives process did not announce itself")
        self.port = int(json.loads(self.proc.stdout.readline())["modbus"]["1"])

    def stop(self) -> None:
        if self.proc.poll() is None:
            self.proc.terminate()
            try:
                self.proc.wait(timeout=5.0)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait(timeout=5.0)


def test_modbus_drive_that_stops_answering_is_named_with_its_reason(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    drives = _DrivesProcess(duration=3.0)  # gone long before the 100 s move ends
    try:
        cfg = _write(
            tmp_path,
            "m.yaml",
            "runtime:\n  tasks:\n    motion: {period: 0.001}\n"
            f"buses:\n  mb0: {{type: modbus, host: 127.0.0.1, port: {drives.port}, "
            "timeout: 0.1, drives: external}\n"
            "axes:\n  z:\n    limits: {v_max: 0.3, a_max: 2.0, j_max: 20.0}\n"
            "    drive: {bus: mb0, unit_id: 1, counts_per_unit: 1.0e6}\n",
        )
        seq = _write(
            tmp_path,
            "s.yaml",
            "steps:\n"
            "  - call: [{block: p, type: MC_Power, axis: z, enable: true}]\n"
            "    timeout: 1.0\n"
            "  - name: move_z\n"
            "    call: [{block: m, type: MC_MoveAbsolute, axis: z, position: 1.0, "
            "velocity: 0.01}]\n",
        )
        assert main(["run", cfg, seq, "-q"]) == 1
    finally:
        drives.stop()
    err = capsys.readouterr().err
    failed = [line for line in err.splitlines() if line.startswith("FAILED:")]
    assert len(failed) == 1, err
    # the axis error (a lost connection or a request without answer) and the reason's text
    assert re.search(
        r"axis 'z': (COMMUNICATION_LOST \(0x4004\)|COMM_TIMEOUT \(0x400B\)): \S", failed[0]
    ), failed[0]
    assert "pymodbus" not in err and "Repeating" not in err, err


def test_long_run_writes_the_kept_cycles_and_says_what_was_dropped(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    cfg = _write(
        tmp_path,
        "m.yaml",
        "runtime:\n  trace_capacity: 700\n  tasks:\n    motion: {period: 0.001}\n"
        "axes:\n  x:\n    limits: {v_max: 1.0, a_max: 4.0, j_max: 40.0}\n",
    )
    trace = tmp_path / "t.csv"
    assert main(["run", cfg, "--seconds", "2", "--trace", str(trace), "-q"]) == 0
    out = capsys.readouterr().out
    m = re.search(r"wrote \S+ \((\d+) rows; the last \1 cycles: (\d+) older rows and 0 FB", out)
    assert m, out
    kept, dropped = int(m.group(1)), int(m.group(2))
    assert kept + dropped == 2000 and 700 <= kept < 2000
    lines = trace.read_text().splitlines()
    assert len(lines) == kept + 1 and lines[1].split(",")[0] == str(dropped)
    assert main(["plot", str(trace), "-o", str(tmp_path / "t.html")]) == 0
    from tests.cli.test_scope import plotly_figure

    data, _, _ = plotly_figure((tmp_path / "t.html").read_text())
    (pos,) = [d for d in data if d.get("name") == "x.position"]
    assert pos["x"][0] == pytest.approx(dropped * 0.001)  # the plot starts where the trace does


RAISING_PROGRAM = """\
from motionplc.blocks import MC_MoveVelocity, MC_Power

power = MC_Power()
jog = MC_MoveVelocity()


def program(ctx):
    x = ctx.axes["x"]
    power(axis=x, enable=True)
    jog(axis=x, execute=power.status, velocity=0.4)
    if ctx.t > 0.5:
        ctx.vars["n"] = 1 / 0
"""


def test_a_raising_program_stops_its_axes_and_is_located(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """A program given by a relative path raises while its axis moves: the FAILED line names
    the program's own line, the axis is brought to rest in ErrorStop, the trace is written."""
    monkeypatch.chdir(tmp_path)
    cfg = tmp_path / "m.yaml"
    cfg.write_text(CAN_TIGHT.replace("CHANNEL", f"cli-{os.getpid()}-prog").replace("1.0e-6", "1.0"))
    (tmp_path / "prog.py").write_text(RAISING_PROGRAM)
    assert main(["run", str(cfg), "prog.py", "-q", "--trace", "t.csv"]) == 1
    err = capsys.readouterr().err
    assert "FAILED: prog.py:12: program raised ZeroDivisionError: division by zero" in err
    assert "axis 'x' ends in ERROR_STOP (INTERNAL_ERROR (0x5002)" in err
    rows = (tmp_path / "t.csv").read_text().splitlines()
    header = rows[0].split(",")
    last = dict(zip(header, rows[-1].split(","), strict=True))
    assert float(last["x.velocity"]) == 0.0  # the stop ran to rest before the run ended


def test_a_program_calling_sys_exit_stops_its_axes_and_fails_located(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """sys.exit() inside program(ctx) does not end the process with the axis in motion: the
    run fails at the program's line and the axis is brought to rest."""
    monkeypatch.chdir(tmp_path)
    cfg = tmp_path / "m.yaml"
    cfg.write_text(CAN_TIGHT.replace("CHANNEL", f"cli-{os.getpid()}-exit").replace("1.0e-6", "1.0"))
    text = RAISING_PROGRAM.replace('ctx.vars["n"] = 1 / 0', "import sys; sys.exit(3)")
    (tmp_path / "prog.py").write_text(text)
    assert main(["run", str(cfg), "prog.py", "-q", "--trace", "t.csv"]) == 1
    err = capsys.readouterr().err
    assert "FAILED: prog.py:12: program called sys.exit(3); a program ends with ctx.done()" in err
    assert "axis 'x' ends in ERROR_STOP (INTERNAL_ERROR (0x5002)" in err
    rows = (tmp_path / "t.csv").read_text().splitlines()
    header = rows[0].split(",")
    last = dict(zip(header, rows[-1].split(","), strict=True))
    assert float(last["x.velocity"]) == 0.0


def test_a_program_calling_sys_exit_at_import_is_a_located_error(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    prog = tmp_path / "prog.py"
    prog.write_text("import sys\n\nsys.exit('no')\n")
    cfg = tmp_path / "m.yaml"
    cfg.write_text(CAN_TIGHT.replace("CHANNEL", f"cli-{os.getpid()}-exit2"))
    assert main(["validate", str(cfg), str(prog)]) == 2
    err = capsys.readouterr().err
    assert err == f"motionplc: error: {prog}:3: import failed: SystemExit: no\n"
