"""runtime.realtime / runtime.max_overruns from YAML into RuntimeSpec and RealtimeClock."""

from __future__ import annotations

from pathlib import Path

import pytest

from motionplc.config import build, load_config
from motionplc.errors import ConfigError
from motionplc.runtime.clock import RealtimeClock

CFG = """\
runtime:
  clock: realtime
  max_overruns: 3
  realtime: {{priority: 80, cpus: {cpus}, lock_memory: true}}
  tasks:
    motion: {{}}
axes:
  x:
    limits: {{v_max: 1.0, a_max: 2.0}}
"""


def test_realtime_settings_reach_the_clock(tmp_path: Path) -> None:
    f = tmp_path / "m.yaml"
    f.write_text(CFG.format(cpus="[0, 1023, 0]"))
    cfg = load_config(f)
    rs = cfg.runtime
    assert (rs.rt_priority, rs.rt_cpus, rs.rt_lock_memory, rs.max_overruns) == (
        80,
        (0, 1023),
        True,
        3,
    )
    with build(cfg) as machine:
        clock = machine.runtime.clock
        assert isinstance(clock, RealtimeClock)
        assert (clock.fifo_priority, clock.cpus, clock.lock_memory) == (80, {0, 1023}, True)


@pytest.mark.parametrize(
    ("cpus", "error"),
    [
        ("[1024]", "runtime.realtime.cpus[0]: got number 1024 (allowed: an integer in 0..1023)"),
        ("[]", "runtime.realtime.cpus: got a list (allowed: a non-empty list of CPU numbers"),
        ("2", "runtime.realtime.cpus: got number 2"),
    ],
)
def test_bad_cpus_are_located(tmp_path: Path, cpus: str, error: str) -> None:
    f = tmp_path / "m.yaml"
    f.write_text(CFG.format(cpus=cpus))
    with pytest.raises(ConfigError) as info:
        load_config(f)
    assert error in str(info.value)


def test_cpu_keeps_working_and_a_missing_cpu_is_reported_not_raised() -> None:
    assert RealtimeClock(cpu=2).cpus == {2}
    assert RealtimeClock(cpu=2, cpus=[3]).cpus == {2, 3}
    clock = RealtimeClock(cpus=[1023])
    clock.start()  # this machine has no CPU 1023: refused, reported
    assert clock.affinity_active is False
