"""``motionplc run``: statistics, the overrun verdict, ``--seconds`` as a limit, real-time
settings from the CLI, progress output (issue 14, points 2, 6 and 9)."""

from __future__ import annotations

import argparse
import fcntl
import os
import pty
import re
import select
import struct
import subprocess
import sys
import termios
import types
from pathlib import Path

import pytest

from motionplc.cli import _apply_realtime_options, _realtime_report, _TickTimer, main
from motionplc.config import build, load_config

ROOT = Path(__file__).resolve().parents[2]
CONFIGS = ROOT / "configs"

IDEAL = """\
runtime:
  tasks:
    motion: {period: 0.001}
axes:
  x:
    limits: {v_max: 1.0, a_max: 4.0, j_max: 40.0}
"""

# declares 1.5 ms of execution in five 1 ms cycles: an overrun each (on the simulated clock)
SPENDING = """\
def program(ctx):
    if 10 <= ctx.cycle < 15:
        ctx.cycle_ctx.spend(0.0015)
    if ctx.t >= 0.05:
        ctx.done()
"""

MOVE = """\
from motionplc.blocks import MC_MoveRelative, MC_Power
power = MC_Power()
move = MC_MoveRelative()
def program(ctx):
    x = ctx.axes['x']
    power(axis=x, enable=True)
    move(axis=x, execute=power.status, distance=0.25, velocity=0.5)
    if move.done:
        ctx.done()
"""


def _write(tmp_path: Path, name: str, text: str) -> str:
    p = tmp_path / name
    p.write_text(text)
    return str(p)


def test_simulated_statistics_show_wall_clock_time_per_tick_not_zeros(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    cfg = _write(tmp_path, "m.yaml", IDEAL)
    assert main(["run", cfg, "--seconds", "0.2"]) == 0
    out = capsys.readouterr().out
    assert "0.0us" not in out and "late p99" not in out
    lines = out.splitlines()
    i = lines.index(f"{'task':<10} {'cycles':>10} {'overruns':>9} {'omitted':>8}")
    assert lines[i + 1].split() == ["motion", "200", "0", "0"]
    m = re.fullmatch(
        r"wall-clock time per tick: mean ([0-9.]+) (ns|us|ms), p99 ([0-9.]+) (ns|us|ms|s), max "
        r"([0-9.]+) (ns|us|ms|s) \(200 ticks of 1 ms in ([0-9.e-]+) s, ([0-9.e+]+)x real time\)",
        lines[i + 2],
    )
    assert m, lines[i + 2]
    scale = {"ns": 1e-9, "us": 1e-6, "ms": 1e-3, "s": 1.0}
    mean, p99, peak = (float(m.group(k)) * scale[m.group(k + 1)] for k in (1, 3, 5))
    assert 0 < mean <= peak and p99 <= peak * 1.001 + 1e-6
    assert float(m.group(7)) == pytest.approx(200 * mean, rel=0.01)
    assert lines[i + 3].startswith("(simulated time: no lateness by construction")


def test_the_measurement_leaves_simulated_runs_bit_reproducible(tmp_path: Path) -> None:
    cfg = _write(tmp_path, "m.yaml", IDEAL)
    prog = _write(tmp_path, "p.py", MOVE)
    for name in ("a.csv", "b.csv"):
        assert main(["run", cfg, prog, "-q", "--trace", str(tmp_path / name)]) == 0
    assert (tmp_path / "a.csv").read_bytes() == (tmp_path / "b.csv").read_bytes()


def test_tick_timer_percentile() -> None:
    timer = _TickTimer()
    # 99 ticks of 5 us and one of 3 ms, put into the histogram directly
    timer._hist[4] = 99
    timer._hist[2999] = 1
    timer.count, timer.max_ns = 100, 3_000_000
    assert timer.percentile(0.5) == pytest.approx(5e-6)
    assert timer.percentile(0.99) == pytest.approx(5e-6)
    assert timer.percentile(1.0) == pytest.approx(3e-3)


def test_more_overruns_than_allowed_fail_the_run(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    cfg = _write(tmp_path, "m.yaml", IDEAL)
    prog = _write(tmp_path, "p.py", SPENDING)
    assert main(["run", cfg, prog, "-q"]) == 0  # no policy: overruns are only counted
    capsys.readouterr()
    assert main(["run", cfg, prog, "-q", "--max-overruns", "3"]) == 0
    capsys.readouterr()
    assert main(["run", cfg, prog, "-q", "--max-overruns", "2"]) == 1
    out, err = capsys.readouterr()
    assert err.splitlines()[-1] == (
        "FAILED: task 'motion': 3 overruns in 48 cycles, more than the 2 allowed (--max-overruns)"
    )
    assert re.search(r"^motion\s+48\s+3\s+3$", out, re.M), out  # the summary is shown
    # the YAML policy, and the CLI overriding it
    cfg2 = _write(tmp_path, "m2.yaml", IDEAL.replace("runtime:\n", "runtime:\n  max_overruns: 0\n"))
    assert main(["run", cfg2, prog, "-q"]) == 1
    assert capsys.readouterr().err.splitlines()[-1] == (
        "FAILED: task 'motion': 3 overruns in 48 cycles, more than the 0 allowed "
        "(runtime.max_overruns)"
    )
    assert main(["run", cfg2, prog, "-q", "--max-overruns", "10"]) == 0


def test_seconds_is_a_limit_the_run_ends_with_the_program(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    cfg = _write(tmp_path, "m.yaml", IDEAL)
    prog = _write(tmp_path, "p.py", MOVE)
    trace = tmp_path / "t.csv"
    assert main(["run", cfg, prog, "-q", "--seconds", "100", "--trace", str(trace)]) == 0
    out = capsys.readouterr().out
    m = re.search(r"ok: \S+ finished at t = ([0-9.]+) s", out)
    assert m and 0.5 < float(m.group(1)) < 1.0, out
    rows = trace.read_text().splitlines()
    # the run ended with the program; the cycles of its controlled stop (the drives
    # switched off: at rest already) follow in the trace
    times = [float(r.split(",")[1]) for r in rows[1:]]
    assert any(t == pytest.approx(float(m.group(1)), abs=1e-9) for t in times)
    assert 0 < times[-1] - float(m.group(1)) < 0.01
    # a limit shorter than the program: it did not finish
    assert main(["run", cfg, prog, "-q", "--seconds", "0.1"]) == 1
    assert capsys.readouterr().err == f"FAILED: {prog}: did not finish within 0.1 s (--seconds)\n"


def test_the_telescope_example_passes_its_own_check_with_a_long_limit(
    capsys: pytest.CaptureFixture[str],
) -> None:
    """issue 14: ``--seconds 120`` ran past ctx.done() and failed the program's own check."""
    cfg, prog = str(CONFIGS / "telescope.yaml"), str(CONFIGS / "telescope_program.py")
    assert main(["run", cfg, prog, "--seconds", "120", "-q"]) == 0
    assert capsys.readouterr().out == (
        f"ok: {prog} finished at t = 20.000 s, all expectations met\n"
    )


def _args(**kw: object) -> argparse.Namespace:
    base = {
        "rt_priority": None,
        "cpus": None,
        "lock_memory": False,
        "max_overruns": None,
        "realtime": False,
    }
    base.update(kw)
    return argparse.Namespace(**base)


def test_realtime_options_override_the_yaml_and_reach_the_clock(tmp_path: Path) -> None:
    cfg = load_config(
        _write(
            tmp_path,
            "m.yaml",
            IDEAL.replace(
                "runtime:\n",
                "runtime:\n  realtime: {priority: 10, cpus: [1], lock_memory: false}\n",
            ),
        )
    )
    assert _apply_realtime_options(cfg, _args()) is cfg
    new = _apply_realtime_options(
        cfg, _args(realtime=True, rt_priority=80, cpus=(0,), lock_memory=True, max_overruns=4)
    )
    assert new.runtime.rt_priority == 80 and new.runtime.rt_cpus == (0,)
    assert new.runtime.rt_lock_memory and new.runtime.max_overruns == 4
    assert cfg.runtime.rt_priority == 10  # the loaded configuration is unchanged
    with build(new, realtime=True) as machine:  # built, not started: nothing applied yet
        clock = machine.runtime.clock
        assert clock.fifo_priority == 80 and clock.lock_memory
        assert tuple(clock.cpus) == (0,)
        assert not (clock.fifo_active or clock.affinity_active or clock.mlock_active)


def test_realtime_options_need_a_realtime_run(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    cfg = _write(tmp_path, "m.yaml", IDEAL)
    assert main(["run", cfg, "--rt-priority", "50", "--lock-memory"]) == 2
    assert capsys.readouterr().err == (
        "motionplc: error: --rt-priority, --lock-memory: only for a real-time run (add "
        "--realtime, or runtime.clock: realtime in the configuration)\n"
    )


def test_realtime_report_says_what_was_applied_or_refused() -> None:
    def clock(**kw: object) -> types.SimpleNamespace:
        base = {
            "realtime": True,
            "fifo_priority": None,
            "cpus": None,
            "lock_memory": False,
            "fifo_active": False,
            "affinity_active": False,
            "mlock_active": False,
        }
        base.update(kw)
        return types.SimpleNamespace(**base)

    assert _realtime_report(types.SimpleNamespace(realtime=False)) is None
    assert _realtime_report(clock()) == (
        "real time: default scheduling (no priority, CPU affinity or memory lock asked)"
    )
    assert _realtime_report(
        clock(fifo_priority=80, cpus=(0, 1), lock_memory=True, affinity_active=True)
    ) == (
        "real time: SCHED_FIFO 80: refused (needs CAP_SYS_NICE or an RLIMIT_RTPRIO >= 80); "
        "CPUs 0,1: applied; memory lock: refused (needs CAP_IPC_LOCK or a large enough "
        "RLIMIT_MEMLOCK)"
    )
    assert _realtime_report(
        clock(fifo_priority=5, fifo_active=True, lock_memory=True, mlock_active=True)
    ) == ("real time: SCHED_FIFO 5: applied; memory lock: applied")


def _cli(*argv: str, **kw: object) -> subprocess.CompletedProcess[str]:
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    return subprocess.run(
        [sys.executable, "-m", "motionplc", *argv],
        capture_output=True,
        text=True,
        timeout=120,
        env=env,
        **kw,  # type: ignore[arg-type]
    )


def test_a_realtime_run_reports_the_settings_of_the_operating_system(tmp_path: Path) -> None:
    """In its own process: SCHED_FIFO and mlockall stay for the rest of a process."""
    cfg = _write(tmp_path, "m.yaml", IDEAL)
    cpu = min(os.sched_getaffinity(0))
    res = _cli(
        "run",
        cfg,
        "--realtime",
        "--seconds",
        "0.05",
        "--rt-priority",
        "5",
        "--cpus",
        str(cpu),
        "--lock-memory",
    )
    assert res.returncode == 0, res.stderr
    lines = res.stdout.splitlines()
    report = next(line for line in lines if line.startswith("real time: "))
    assert re.fullmatch(
        r"real time: SCHED_FIFO 5: (applied|refused \(needs CAP_SYS_NICE or an RLIMIT_RTPRIO "
        rf">= 5\)); CPUs {cpu}: applied; memory lock: (applied|refused \(needs CAP_IPC_LOCK or "
        r"a large enough RLIMIT_MEMLOCK\))",
        report,
    ), report
    assert any(line.split()[:2] == ["task", "cycles"] and "late p99" in line for line in lines)


def test_progress_lines_without_a_terminal_and_nothing_with_q(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    cfg = _write(
        tmp_path,
        "m.yaml",
        IDEAL.replace("0.001}", "0.01}").replace("runtime:\n", "runtime:\n  tick: 0.01\n"),
    )
    assert main(["run", cfg, "--seconds", "12"]) == 0
    err = capsys.readouterr().err
    assert err == "  t =     5.0 s\n  t =    10.0 s\n"
    assert main(["run", cfg, "--seconds", "12", "-q"]) == 0
    out, err = capsys.readouterr()
    assert err == "" and out == "ok: ran 12 s\n"


def test_progress_bar_on_a_terminal(tmp_path: Path) -> None:
    cfg = _write(
        tmp_path,
        "m.yaml",
        IDEAL.replace("0.001}", "0.01}").replace("runtime:\n", "runtime:\n  tick: 0.01\n"),
    )
    master, slave = pty.openpty()
    # a new pty is 0 x 0 characters: give it a size, as a terminal window has
    fcntl.ioctl(slave, termios.TIOCSWINSZ, struct.pack("HHHH", 24, 100, 0, 0))
    try:
        env = dict(os.environ, PYTHONPATH=str(ROOT))
        proc = subprocess.Popen(
            [sys.executable, "-m", "motionplc", "run", cfg, "--seconds", "30"],
            stdout=subprocess.PIPE,
            stderr=slave,
            env=env,
        )
        os.close(slave)
        slave = -1
        chunks = []
        while True:
            ready, _, _ = select.select([master], [], [], 60)
            if not ready:
                break
            try:
                data = os.read(master, 4096)
            except OSError:  # EIO: the child closed the terminal
                break
            if not data:
                break
            chunks.append(data)
        assert proc.wait(timeout=60) == 0
        assert proc.stdout is not None
        out = proc.stdout.read().decode()
        proc.stdout.close()
    finally:
        os.close(master)
        if slave >= 0:
            os.close(slave)
    screen = b"".join(chunks).decode(errors="replace")
    assert "t =     5.0 s" not in screen  # the bar, not the lines
    assert re.search(r"run +\d+%\|.*\| t = [0-9.]+ of 30 s \[", screen), screen
    assert "ok: ran 30 s" in out
