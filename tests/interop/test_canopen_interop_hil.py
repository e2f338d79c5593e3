"""Our CANopen master against a drive we did not write (tests/interop/canopen_servo.py), from
YAML: every quirk of issue 13 runs a blended sequence, the trace matches what the drive put on
the bus, and faults, reset, heartbeat loss and a reboot mid-run behave as specified.

The servo runs in its own thread on a python-can virtual channel (``drives: external``); the
master on the simulated clock waits for its TPDOs after each SYNC, so the runs are
reproducible. A third bus object on the channel records the frames ("the bus").
"""

from __future__ import annotations

import struct
import textwrap
import uuid
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import can
import numpy as np
import pytest

from motionplc.blocks import AxisState, ErrorID, MC_MoveAbsolute, MC_Power, MC_Reset
from motionplc.config import Machine, build, load_config
from motionplc.sequence import runner_for
from tests.interop.canopen_servo import CanopenServo, Cia402State, NmtState, ServoQuirks

NODE = 3
CPU = 1.0e6  # position units per m (the servo's factory scaling: 1 increment per unit)

SEQUENCE = """\
timeout: 10
steps:
  - name: power on
    call: [{block: pwr, type: MC_Power, axis: x, enable: true}]
    until: {done: pwr}
    timeout: 0.5
  - name: two blended moves
    call:
      - {block: a, type: MC_MoveAbsolute, axis: x, position: 0.05, velocity: 0.1,
         acceleration: 1.0, deceleration: 1.0, jerk: 20.0}
      - {block: b, type: MC_MoveAbsolute, axis: x, position: 0.12, velocity: 0.15,
         acceleration: 1.0, deceleration: 1.0, jerk: 20.0, buffer_mode: BLENDING_NEXT}
    until: {done: b}
  - name: settle
    wait: 0.05
    expect: {x.actual_position: 0.12, within: 2.0e-6}
"""


@dataclass
class Rig:
    servo: CanopenServo
    machine: Machine
    sniffer: can.BusABC
    dir: Path

    def frames(self) -> list[can.Message]:
        out = []
        while (msg := self.sniffer.recv(timeout=0)) is not None:
            out.append(msg)
        return out


DRIVE_BASE = {
    "bus": "can0",
    "node_id": NODE,
    "counts_per_unit": CPU,
    "eds": "servo.eds",
}


def _yaml(value: Any) -> str:
    if isinstance(value, dict):
        return "{" + ", ".join(f"{k}: {_yaml(v)}" for k, v in value.items()) + "}"
    if isinstance(value, list):
        return "[" + ", ".join(_yaml(v) for v in value) + "]"
    return str(value)


@pytest.fixture
def rig_factory(tmp_path: Path) -> Iterator[Any]:
    made: list[tuple[CanopenServo, Machine, list[can.BusABC]]] = []

    def make(quirks: ServoQuirks | None = None, **drive: Any) -> Rig:
        channel = f"interop-{uuid.uuid4().hex[:10]}"
        servo_bus = can.Bus(interface="virtual", channel=channel)
        sniffer = can.Bus(interface="virtual", channel=channel)
        servo = CanopenServo(servo_bus, NODE, quirks=quirks or ServoQuirks())
        servo.write_eds(tmp_path / "servo.eds")
        servo.start()
        config = tmp_path / "machine.yaml"
        keys = {**DRIVE_BASE, **drive}
        config.write_text(
            textwrap.dedent(
                f"""\
                runtime: {{tick: 0.001, tasks: {{motion: {{period: 0.001}}}}}}
                buses:
                  can0: {{type: can, interface: virtual, channel: {channel}, drives: external}}
                axes:
                  x:
                    limits: {{v_max: 0.2, a_max: 2.0, j_max: 40.0}}
                    following_error: 0.002
                    drive: {_yaml(keys)}
                """
            )
        )
        (tmp_path / "sequence.yaml").write_text(SEQUENCE)
        machine = build(load_config(config))
        made.append((servo, machine, [servo_bus, sniffer]))
        return Rig(servo, machine, sniffer, tmp_path)

    yield make
    for servo, machine, buses in made:
        machine.close()
        servo.stop()
        for bus in buses:
            bus.shutdown()


def _tpdo1_positions(frames: list[can.Message]) -> list[int]:
    """Position actual values of the TPDO1 frames (0x6041 U16 then 0x6064 I32)."""
    return [
        struct.unpack_from("<Hi", bytes(m.data))[1]
        for m in frames
        if m.arbitration_id == 0x180 + NODE and len(m.data) == 6
    ]


def _run_sequence(rig: Rig) -> None:
    machine = rig.machine
    runner, task = runner_for(rig.dir / "sequence.yaml", machine)
    machine.attach(runner, task)
    machine.runtime.run_until(lambda: runner.over, max_seconds=10.0)
    assert runner.failures == []
    assert runner.finished
    ax = machine.axes["x"]
    assert ax.state is AxisState.STANDSTILL, ax.axis_error_reason


QUIRKS = {
    "standard": (ServoQuirks(), {}),
    "mode display lags 0x6060": (ServoQuirks(mode_display_delay=5), {}),
    "no 0x6502, no 0x1006": (ServoQuirks(has_6502=False, has_1006=False), {}),
    "node guarding only": (
        ServoQuirks(heartbeat=False),
        {"node_guarding": {"guard_time": 0.01, "life_time_factor": 3}},
    ),
    "TPDO COB-IDs need bit 30": (ServoQuirks(tpdo_bit30_required=True), {}),
    "0x603F not mappable": (ServoQuirks(map_603f=False), {}),
}


@pytest.mark.parametrize("name", list(QUIRKS))
def test_blended_sequence_from_yaml_and_trace_matches_the_bus(rig_factory: Any, name: str) -> None:
    quirks, drive = QUIRKS[name]
    rig = rig_factory(quirks, **drive)
    _run_sequence(rig)
    machine, servo = rig.machine, rig.servo
    # the drive is configured as the master says
    assert servo.nmt_state is NmtState.OPERATIONAL
    assert servo.mode_display == 8
    assert [e[:2] for e in servo.mapping("tpdo", 1)] == [(0x6041, 0), (0x6064, 0)]
    assert [e[:2] for e in servo.mapping("rpdo", 1)] == [(0x6040, 0), (0x607A, 0)]
    if quirks.tpdo_bit30_required:
        assert servo.od_value(0x1800, 1) & (1 << 30)
    # the trace's actual positions are the drive's TPDOs as they were on the bus
    on_bus = _tpdo1_positions(rig.frames())
    trace = machine.runtime.trace
    actual = np.rint(trace.column("x.actual_position") * CPU).astype(int).tolist()
    n = 400  # the motion's last 0.4 s: every cycle read the TPDO of the previous SYNC
    assert len(on_bus) > n
    assert actual[-n:] == on_bus[-n - 1 : -1]
    assert on_bus[-1] == round(0.12 * CPU)
    assert abs(servo.position - 0.12 * CPU) < 1e-3  # the servo's own plant, in position units


def test_fault_reset_heartbeat_loss_and_reboot(rig_factory: Any) -> None:
    rig = rig_factory(heartbeat={"producer": 0.01, "consumer": 0.05})
    rt = rig.machine.runtime
    ax = rig.machine.axes["x"]
    power = MC_Power(axis=ax, enable=True)
    reset = MC_Reset(axis=ax)
    moves: list[MC_MoveAbsolute] = []

    def move_to(position: float) -> MC_MoveAbsolute:
        mv = MC_MoveAbsolute(
            axis=ax, position=position, velocity=0.1, acceleration=1.0, deceleration=1.0
        )
        moves.append(mv)
        return mv

    state = {"reset": False, "move": None}

    def program(ctx: Any) -> None:
        power()
        reset(execute=state["reset"])
        mv = state["move"]
        if mv is not None:
            mv(execute=power.status)

    rig.machine.attach(program, "motion")
    rt.run_until(lambda: power.status, max_seconds=0.5)
    assert power.status

    def recover() -> int:
        """MC_Reset: cycles until Done (asserting it is Busy, not Done, meanwhile)."""
        state["reset"] = True
        cycles = 0
        while not reset.done:
            assert not reset.error, reset.error_id
            rt.run(cycles=1)
            cycles += 1
            assert cycles < 3000
        state["reset"] = False
        rt.run(cycles=1)
        rt.run_until(lambda: power.status, max_seconds=0.5)
        assert ax.state is AxisState.STANDSTILL
        return cycles

    # 1. a drive fault mid-move: ErrorStop with the drive's code, MC_Reset clears it
    state["move"] = move_to(0.1)
    rt.run(cycles=200)
    rig.servo.inject_fault(0x5530)
    rt.run(cycles=20)
    assert ax.state is AxisState.ERROR_STOP
    assert ax.axis_error is ErrorID.DRIVE_FAULT
    assert "0x5530" in ax.axis_error_reason and ax.axis_error_reason.count("0x5530") == 1
    state["move"] = None
    rt.run(cycles=1)
    recover()
    assert rig.servo.cia402_state is Cia402State.OPERATION_ENABLED

    # 2. a warning EMCY: shown, nothing stops
    state["move"] = move_to(0.05)
    rt.run(cycles=50)
    rig.servo.warn(0x4210)
    rt.run_until(lambda: moves[-1].done, max_seconds=3.0)
    assert ax.state is AxisState.STANDSTILL
    assert any("0x4210" in text for _, text in ax.warnings_seen), ax.warnings_seen
    assert any(e.fb == "x.drive" and "0x4210" in e.output for e in rt.trace.events)
    rig.servo.clear_warning()
    state["move"] = None
    rt.run(cycles=5)

    # 3. heartbeat loss: HEARTBEAT_LOST; back when it returns and MC_Reset is given
    rig.servo.stop_heartbeat(True)
    rt.run(cycles=100)
    assert ax.state is AxisState.ERROR_STOP
    assert ax.axis_error is ErrorID.HEARTBEAT_LOST, ax.axis_error_reason
    rig.servo.stop_heartbeat(False)
    rt.run(cycles=30)
    recover()

    # 4. reboot mid-move: the drive comes back with factory settings; MC_Reset re-runs the
    #    whole configuration inside the cycle and is Done only once the drive is configured
    state["move"] = move_to(0.1)
    rt.run(cycles=150)
    rig.servo.reboot()
    rt.run(cycles=30)
    assert ax.state is AxisState.ERROR_STOP
    assert "reboot" in ax.axis_error_reason or "boot" in ax.axis_error_reason
    assert [e[:2] for e in rig.servo.mapping("tpdo", 1)] == [(0x6041, 0)]  # factory
    state["move"] = None
    rt.run(cycles=1)
    cycles = recover()
    assert cycles > 10  # the configuration took SDO round trips, one per cycle
    assert [e[:2] for e in rig.servo.mapping("tpdo", 1)] == [(0x6041, 0), (0x6064, 0)]
    assert rig.servo.od_value(0x1017) == 10  # heartbeat producer configured again
    assert rig.servo.cia402_state is Cia402State.OPERATION_ENABLED
    state["move"] = move_to(0.0)
    rt.run_until(lambda: moves[-1].done, max_seconds=3.0)
    rt.run(cycles=50)
    assert ax.state is AxisState.STANDSTILL
    assert abs(ax.actual_position) < 2e-6
