"""``motionplc drives CONFIG`` serves a configuration's Modbus bus the way ``motionplc run``
reaches it: one server on the bus's port, the axes told apart by their unit ids (each with its
own word order). End to end, two processes: the drives, then a run against them."""

from __future__ import annotations

import json
import os
import signal
import socket
import subprocess
import sys
from pathlib import Path

import pytest

from motionplc.fieldbus.drives_main import DrivesSpec

ROOT = Path(__file__).resolve().parents[2]

CONFIG = """\
runtime: {tick: 0.002, clock: simulated, tasks: {motion: {period: 0.002}}}
buses:
  mb0: {type: modbus, host: 127.0.0.1, port: PORT, timeout: 1.0, drives: external}
axes:
  x:
    limits: {v_max: 0.5, a_max: 2.0, j_max: 20.0}
    drive: {bus: mb0, unit_id: 1, counts_per_unit: 1.0e6, word_order: big}
  y:
    limits: {v_max: 0.5, a_max: 2.0, j_max: 20.0}
    drive: {bus: mb0, unit_id: 2, counts_per_unit: 1.0e6, word_order: little}
"""

SEQUENCE = """\
timeout: 10
steps:
  - name: power on
    call:
      - {block: px, type: MC_Power, axis: x, enable: true}
      - {block: py, type: MC_Power, axis: y, enable: true}
    until: {done: [px, py]}
    timeout: 1.0
  - name: move both
    call:
      - {block: mx, type: MC_MoveAbsolute, axis: x, position: 0.1, velocity: 0.2}
      - {block: my, type: MC_MoveAbsolute, axis: y, position: -0.05, velocity: 0.2}
    expect: {x.position: 0.1, y.position: -0.05, within: 1.0e-9}
  - name: settle
    wait: 0.1
    expect: {x.actual_position: 0.1, y.actual_position: -0.05, within: 2.0e-6}
"""


def test_spec_lays_the_servers_out() -> None:
    shared = DrivesSpec(
        modbus=(1, 2), modbus_port=1502, modbus_shared=True, modbus_word_orders=("big", "little")
    )
    assert shared.modbus_servers() == [(1502, [(1, "big"), (2, "little")])]
    apart = DrivesSpec(modbus=(1, 2), modbus_port=1502, word_order="little")
    assert apart.modbus_servers() == [(1502, [(1, "little")]), (1503, [(2, "little")])]
    assert DrivesSpec(modbus=(3, 4)).modbus_servers() == [(0, [(3, "big")]), (0, [(4, "big")])]
    with pytest.raises(ValueError, match=r"modbus_word_orders: 1 word orders for 2 Modbus"):
        DrivesSpec(modbus=(1, 2), modbus_word_orders=("big",))
    with pytest.raises(ValueError, match=r"modbus: device ids must be distinct, got \[1, 1\]"):
        DrivesSpec(modbus=(1, 1))


def test_run_against_the_drives_of_its_own_config(tmp_path: Path) -> None:
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    free = socket.socket()
    free.bind(("127.0.0.1", 0))
    port = free.getsockname()[1]
    free.close()
    cfg = tmp_path / "machine.yaml"
    cfg.write_text(CONFIG.replace("PORT", str(port)))
    drives = subprocess.Popen(
        [sys.executable, "-m", "motionplc", "drives", str(cfg), "--duration", "60", "--json"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env=env,
    )
    try:
        assert drives.stdout is not None
        info = json.loads(drives.stdout.readline())
        ports = info["modbus"]
        assert ports == {"1": port, "2": port}, info
        seq = tmp_path / "seq.yaml"
        seq.write_text(SEQUENCE)
        run = subprocess.run(
            [sys.executable, "-m", "motionplc", "run", str(cfg), str(seq)],
            capture_output=True,
            text=True,
            env=env,
            timeout=120,
        )
        assert run.returncode == 0, (run.stdout[-2000:], run.stderr[-2000:])
        assert "all expectations met" in run.stdout
    finally:
        drives.send_signal(signal.SIGTERM)
        try:
            drives.wait(timeout=10)
        except subprocess.TimeoutExpired:
            drives.kill()
            drives.wait()
