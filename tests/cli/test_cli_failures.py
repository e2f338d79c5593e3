"""Every failure a user can reach through the CLI is one line with a documented exit code
(issue 14, point 3): a port in use (run and drives), a kernel without CAN, output paths that
cannot be written, missing or wrong input files, Ctrl-C, and the last-resort handler for a
defect (exit 3, ``--debug`` for the traceback)."""

from __future__ import annotations

import errno
import re
import socket
from collections.abc import Iterator
from pathlib import Path

import pytest

from motionplc import cli
from motionplc.cli import main

CONFIGS = Path(__file__).resolve().parents[2] / "configs"

IDEAL = """\
runtime:
  tasks:
    motion: {period: 0.001}
axes:
  x:
    limits: {v_max: 1.0, a_max: 4.0, j_max: 40.0}
"""

MODBUS = """\
runtime:
  tasks:
    motion: {period: 0.001}
buses:
  mb0: {type: modbus, host: 127.0.0.1, port: PORT, drives: simulated}
axes:
  z:
    limits: {v_max: 0.3, a_max: 2.0, j_max: 20.0}
    drive: {bus: mb0, unit_id: 1, counts_per_unit: 1.0e6}
"""

DONE_PROGRAM = "def program(ctx):\n    if ctx.t >= 0.01:\n        ctx.done()\n"


def _write(tmp_path: Path, name: str, text: str) -> str:
    p = tmp_path / name
    p.write_text(text)
    return str(p)


def _one_line(err: str) -> str:
    """The single line of ``err`` (asserting that there is exactly one, no traceback)."""
    assert "Traceback" not in err, err
    assert err.count("\n") == 1 and err.endswith("\n"), err
    return err[:-1]


@pytest.fixture
def busy_port() -> Iterator[int]:
    """A 127.0.0.1 port with a listening socket on it (another process' server)."""
    s = socket.socket()
    s.bind(("127.0.0.1", 0))
    s.listen()
    try:
        yield s.getsockname()[1]
    finally:
        s.close()


def test_run_on_a_modbus_port_in_use_is_one_located_line(
    tmp_path: Path, busy_port: int, capsys: pytest.CaptureFixture[str]
) -> None:
    cfg = _write(tmp_path, "m.yaml", MODBUS.replace("PORT", str(busy_port)))
    prog = _write(tmp_path, "p.py", DONE_PROGRAM)
    assert main(["run", cfg, prog]) == 2
    out, err = capsys.readouterr()
    assert out == ""
    assert _one_line(err) == (
        f"motionplc: error: {cfg}:5: buses.mb0.port: 127.0.0.1:{busy_port} is in use (address "
        "already in use: another process listens there; stop it or choose another port, 0 "
        "picks a free one)"
    )


def test_drives_on_a_port_in_use_is_one_located_line(
    tmp_path: Path, busy_port: int, capsys: pytest.CaptureFixture[str]
) -> None:
    cfg = _write(tmp_path, "m.yaml", MODBUS.replace("PORT", str(busy_port)))
    assert main(["drives", cfg, "--duration", "0.2"]) == 2
    out, err = capsys.readouterr()
    assert out == ""
    assert _one_line(err) == (
        f"motionplc: error: {cfg}:5: buses.mb0.port: 127.0.0.1:{busy_port} is in use (address "
        "already in use: another process listens there; stop it or choose another port, 0 "
        "picks a free one)"
    )


def test_port_problem_agrees_with_the_operating_system(busy_port: int) -> None:
    from motionplc.fieldbus.drives_main import port_problem

    assert port_problem("127.0.0.1", busy_port) == "address already in use"
    assert port_problem("127.0.0.1", 0) is None
    free = socket.socket()
    free.bind(("127.0.0.1", 0))
    port = free.getsockname()[1]
    free.close()
    assert port_problem("127.0.0.1", port) is None
    # the OS' own refusal for the busy port, as a peer of the probe
    probe = socket.socket()
    probe.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
    with pytest.raises(OSError) as exc:
        probe.bind(("127.0.0.1", busy_port))
    probe.close()
    assert exc.value.errno == errno.EADDRINUSE


def _af_can() -> bool:
    try:
        socket.socket(socket.PF_CAN, socket.SOCK_RAW, socket.CAN_RAW).close()
    except (OSError, AttributeError):
        return False
    return True


@pytest.mark.skipif(_af_can(), reason="this kernel has SocketCAN: vcan0 may exist")
def test_vcan0_on_a_kernel_without_can_is_one_line(capsys: pytest.CaptureFixture[str]) -> None:
    cfg = str(CONFIGS / "vcan0.yaml")
    assert main(["run", cfg, str(CONFIGS / "single_axis_sequence.yaml")]) == 2
    line = _one_line(capsys.readouterr().err)
    bus_line = next(
        i for i, t in enumerate(Path(cfg).read_text().splitlines(), 1) if t.startswith("  can0:")
    )
    assert line.startswith(
        f"motionplc: error: {cfg}:{bus_line}: buses.can0: cannot open CAN interface 'socketcan' "
        "channel "
        "'vcan0': [Errno 97] "
    )
    assert line.endswith(
        "this kernel has no SocketCAN (AF_CAN): load the can, can_raw and vcan "
        "modules, or use interface: virtual"
    )


@pytest.mark.skipif(_af_can(), reason="this kernel has SocketCAN")
def test_drives_on_socketcan_without_can_is_one_located_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    text = (
        (CONFIGS / "gantry.yaml").read_text().replace("interface: virtual", "interface: socketcan")
    )
    cfg = _write(tmp_path, "g.yaml", text)
    line = next(i for i, t in enumerate(text.splitlines(), 1) if t.startswith("  can0:"))
    assert main(["drives", cfg, "--duration", "0.2"]) == 2
    err = _one_line(capsys.readouterr().err)
    assert err.startswith(
        f"motionplc: error: {cfg}:{line}: buses.can0: cannot open CAN interface 'socketcan' "
        "channel 'gantry': [Errno 97] "
    )
    assert err.endswith("load the can, can_raw and vcan modules (tools/setup_vcan.sh)")


@pytest.mark.parametrize(
    ("option", "name", "message"),
    [
        ("--trace", "t.txt", "unsupported file type '.txt' (allowed: .csv, .parquet)"),
        ("--trace", "adir", "is a directory (allowed: a file name)"),
        ("--plot", "p.pdf", "unsupported file type '.pdf' (allowed: .png, .html, .htm)"),
        ("--plot", "afile/p.png", "cannot create {dir}/afile: file exists"),
    ],
)
def test_bad_output_paths_are_refused_before_the_run(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], option: str, name: str, message: str
) -> None:
    (tmp_path / "adir").mkdir()
    (tmp_path / "afile").write_text("")
    cfg = _write(tmp_path, "m.yaml", IDEAL)
    target = str(tmp_path / name)
    assert main(["run", cfg, "--seconds", "0.01", option, target]) == 2
    out, err = capsys.readouterr()
    assert out == ""  # nothing ran
    assert _one_line(err) == (
        f"motionplc: error: {option}: {target}: {message.format(dir=tmp_path)}"
    )


def test_missing_and_directory_inputs(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    cfg = _write(tmp_path, "m.yaml", IDEAL)
    for argv, line in (
        (["validate", "nothere.yaml"], "nothere.yaml: cannot read: No such file or directory"),
        (["validate", str(tmp_path)], f"{tmp_path}: cannot read: Is a directory"),
        (["run", cfg, str(tmp_path / "p.py")], f"{tmp_path / 'p.py'}: cannot read: no such file"),
        (
            ["plot", str(tmp_path / "t.csv")],
            f"{tmp_path / 't.csv'}: cannot read: No such file or directory",
        ),
        (
            ["plot", str(tmp_path / "t.txt")],
            f"{tmp_path / 't.txt'}: unsupported trace type '.txt' (allowed: .csv, .parquet, as "
            "written by run --trace)",
        ),
    ):
        assert main(argv) == 2, argv
        assert _one_line(capsys.readouterr().err) == f"motionplc: error: {line}", argv


def test_option_values_are_named_in_the_error(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["plan", "--pf", "abc"]) == 2
    err = capsys.readouterr().err
    assert err.splitlines()[-1] == "motionplc plan: error: argument --pf: invalid number: 'abc'"
    assert "_float" not in err and "Traceback" not in err
    assert main(["run", "x.yaml", "--seconds", "-1"]) == 2
    assert capsys.readouterr().err.splitlines()[-1] == (
        "motionplc run: error: argument --seconds: invalid duration: '-1' (allowed: a number of "
        "seconds > 0)"
    )
    assert main(["run", "x.yaml", "--cpus", "1-0"]) == 2
    assert "invalid CPU list: '1-0'" in capsys.readouterr().err
    assert main(["run", "x.yaml", "--rt-priority", "100"]) == 2
    assert "invalid priority: '100' (allowed: 1..99)" in capsys.readouterr().err


def test_plan_errors_are_one_line(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["plan", "--v-max", "-1"]) == 2
    line = _one_line(capsys.readouterr().err)
    assert line.startswith("motionplc: error: --v-max: must be in ")  # the option, not Limits.v_max
    assert main(["plan", "--dt", "0"]) == 2
    assert _one_line(capsys.readouterr().err) == (
        "motionplc: error: --dt: got 0 (allowed: a number of seconds > 0)"
    )


def test_plan_plot_html(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    from motionplc import scope

    if not hasattr(scope, "write_series_plot"):
        pytest.skip("scope.write_series_plot (SP) not there yet")
    out = tmp_path / "p.html"
    assert main(["plan", "--pf", "1", "--plot", str(out)]) == 0
    assert capsys.readouterr().out.splitlines()[-1] == f"wrote {out}"
    page = out.read_text()
    assert "<html" in page.lower() and "velocity" in page


def test_ctrl_c_during_a_run_writes_the_trace_and_exits_130(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    cfg = _write(tmp_path, "m.yaml", IDEAL)
    prog = _write(
        tmp_path,
        "p.py",
        "def program(ctx):\n    if ctx.cycle == 20:\n        raise KeyboardInterrupt\n",
    )
    trace = tmp_path / "t.csv"
    assert main(["run", cfg, prog, "-q", "--trace", str(trace)]) == 130
    out, err = capsys.readouterr()
    assert err == "FAILED: interrupted at t = 0.020 s\n"
    assert len(trace.read_text().splitlines()) == 1 + 20  # header and cycles 0..19 (20 ended early)


def test_an_internal_error_is_one_line_and_debug_shows_the_traceback(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    def broken(args: object) -> int:
        raise KeyError("no such thing")

    monkeypatch.setattr(cli, "_cmd_validate", broken)
    cfg = _write(tmp_path, "m.yaml", IDEAL)
    assert main(["validate", cfg]) == 3
    assert _one_line(capsys.readouterr().err) == (
        "motionplc: internal error: KeyError: 'no such thing' (run with --debug for the traceback)"
    )
    for argv in (["--debug", "validate", cfg], ["validate", cfg, "--debug"]):
        assert main(argv) == 3
        err = capsys.readouterr().err
        assert err.startswith("Traceback (most recent call last):")
        assert err.splitlines()[-1] == "motionplc: internal error: KeyError: 'no such thing'"


def test_relative_program_path_reports_its_own_lines(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """issue 14 point 4: ``bad_prog.py:8:``, not ``:1:``, whatever fails where."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / "m.yaml").write_text(IDEAL)
    body = (
        "from motionplc.blocks import MC_Power\n"  # 1
        "\n"
        "power = MC_Power()\n"  # 3
        "\n"
        "\n"
        "def program(ctx):\n"  # 6
        "    x = ctx.axes['x']\n"
        "    power(axis=x, enable=True, {arg})\n"  # 8
        "    if ctx.t > 0.01:\n"
        "        ctx.expect('x.position', x.position, 1.0)\n"  # 10
        "        ctx.done()\n"
        "TIMEOUT = {timeout}\n"  # 12
    )
    cases = (
        ("foo=1", "5.0", 1, "bad_prog.py:8: program raised TypeError: MC_Power() got an unknown"),
        ("enable_positive=True", "5.0", 1, "bad_prog.py:10: expectation failed at t = 0.011 s"),
        ("enable_positive=True", "-1", 2, "motionplc: error: bad_prog.py:12: TIMEOUT: got -1"),
        (
            "enable_positive=True",
            "1 / 0",
            2,
            "motionplc: error: bad_prog.py:12: import failed: ZeroDivisionError",
        ),
    )
    for arg, timeout, code, expected in cases:
        Path("bad_prog.py").write_text(body.format(arg=arg, timeout=timeout))
        assert main(["run", "m.yaml", "bad_prog.py", "-q"]) == code
        err = capsys.readouterr().err
        assert expected in err, err


def test_an_external_modbus_drive_that_is_not_there_is_located_at_its_drive(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    free = socket.socket()
    free.bind(("127.0.0.1", 0))
    port = free.getsockname()[1]
    free.close()  # nobody listens there
    text = MODBUS.replace("PORT", str(port)).replace("simulated", "external, timeout: 0.1")
    cfg = _write(tmp_path, "m.yaml", text)
    prog = _write(tmp_path, "p.py", DONE_PROGRAM)
    assert main(["run", cfg, prog, "-q"]) == 2
    line = _one_line(capsys.readouterr().err)
    assert line.startswith(
        f"motionplc: error: {cfg}:9: axes.z.drive (bus mb0): cannot connect to 127.0.0.1:{port}: "
    )


def test_a_real_sigint_ends_the_run_with_its_summary_and_130(tmp_path: Path) -> None:
    import os
    import signal
    import subprocess
    import sys

    root = Path(__file__).resolve().parents[2]
    cfg = _write(tmp_path, "m.yaml", IDEAL)
    trace = tmp_path / "t.csv"
    proc = subprocess.Popen(
        [sys.executable, "-m", "motionplc", "run", cfg, "--seconds", "3000", "--trace", str(trace)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env=dict(os.environ, PYTHONPATH=str(root)),
        # a shell's background job inherits SIGINT ignored: give Python its handler back
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),
    )
    try:
        assert proc.stdout is not None
        assert proc.stdout.readline().startswith(f"running {cfg} (simulated time")
        proc.send_signal(signal.SIGINT)
        out, err = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    assert proc.returncode == 130, (proc.returncode, out[-2000:], err[-2000:])
    assert "Traceback" not in err
    assert re.fullmatch(r"FAILED: interrupted at t = [0-9.]+ s\n", err), err
    assert out.startswith(f"wrote {trace} (") and "task " in out
