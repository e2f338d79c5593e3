"""Our Modbus master against a drive we did not write (tests/interop/modbus_servo.py, the
"Kestrel KD-40": input-register status, low word first, float32 velocity, FC 03/04/06/16
only), configured from YAML with the register map a user writes from its manual: a blended
sequence with the trace matching the drive, and drive fault, stalled answers, watchdog and a
reboot behaving as specified."""

from __future__ import annotations

import shutil
import textwrap
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from motionplc.blocks import AxisState, ErrorID, MC_MoveAbsolute, MC_Power, MC_Reset
from motionplc.config import Machine, build, load_config
from motionplc.sequence import runner_for
from tests.interop.modbus_servo import ModbusServo

MAP = Path(__file__).parent / "data" / "modbus_servo_map.yaml"
CPU = 1.0e6  # encoder counts per m
UNIT = 7

SEQUENCE = """\
timeout: 10
steps:
  - name: power on
    call: [{block: pwr, type: MC_Power, axis: z, enable: true}]
    until: {done: pwr}
    timeout: 0.5
  - name: two blended moves
    call:
      - {block: a, type: MC_MoveAbsolute, axis: z, position: 0.04, velocity: 0.1,
         acceleration: 1.0, deceleration: 1.0, jerk: 20.0}
      - {block: b, type: MC_MoveAbsolute, axis: z, position: -0.02, velocity: 0.15,
         acceleration: 1.0, deceleration: 1.0, jerk: 20.0, buffer_mode: BLENDING_LOW}
    until: {done: b}
  - name: settle
    wait: 0.1
    expect: {z.actual_position: -0.02, within: 5.0e-6}
"""


@pytest.fixture
def rig(tmp_path: Path) -> Iterator[tuple[ModbusServo, Machine, Path]]:
    servo = ModbusServo(unit_id=UNIT).start()
    shutil.copy(MAP, tmp_path / "kd40.yaml")
    (tmp_path / "machine.yaml").write_text(
        textwrap.dedent(
            f"""\
            runtime: {{tick: 0.004, tasks: {{motion: {{period: 0.004}}}}}}
            buses:
              mb: {{type: modbus, host: 127.0.0.1, port: {servo.port}, drives: external,
                   timeout: 0.5}}
            axes:
              z:
                limits: {{v_max: 0.2, a_max: 2.0, j_max: 40.0}}
                following_error: 0.005
                drive:
                  bus: mb
                  unit_id: {UNIT}
                  counts_per_unit: {CPU}
                  register_map: kd40.yaml
                  following_error_window: 0.004
                  following_error_timeout: 0.02
                  watchdog: 0.05
            """
        )
    )
    (tmp_path / "sequence.yaml").write_text(SEQUENCE)
    machine = build(load_config(tmp_path / "machine.yaml"))
    try:
        yield servo, machine, tmp_path
    finally:
        machine.close()
        servo.stop()


def test_blended_sequence_from_yaml_and_trace_matches_the_drive(rig: Any) -> None:
    servo, machine, d = rig
    positions: list[float] = []  # the drive's own position after each cycle's exchange
    machine.runtime.add_cycle_hook(lambda rt, k: positions.append(servo.position))
    runner, task = runner_for(d / "sequence.yaml", machine)
    machine.attach(runner, task)
    machine.runtime.run_until(lambda: runner.over, max_seconds=10.0)
    assert runner.failures == []
    assert runner.finished
    assert machine.axes["z"].state is AxisState.STANDSTILL
    # set up from the map: parameters in the drive's units, CSP only, nothing but 03/04/06/16
    params = servo.parameters
    assert params["following_error_window"] == round(0.004 * CPU)
    assert params["following_error_timeout_ms"] == 20
    assert params["watchdog_ms"] == 50
    assert params["cycle_time_us"] == 4000
    assert set(servo.requests_by_function) <= {3, 4, 6, 16}
    assert servo.requests_by_function[4] >= len(positions)  # status read every cycle
    # the trace's actual position in cycle k+1 is what the drive had after cycle k's exchange
    trace = machine.runtime.trace
    actual = trace.column("z.actual_position")
    n = len(positions)
    assert n > 300
    for k in range(n - 300, n - 1):
        assert actual[k + 1] * CPU == pytest.approx(round(positions[k]), abs=0.5), k
    assert abs(positions[-1] + 0.02 * CPU) < 5.0


def test_fault_stall_watchdog_and_reboot(rig: Any) -> None:
    servo, machine, _ = rig
    rt = machine.runtime
    ax = machine.axes["z"]
    power = MC_Power(axis=ax, enable=True)
    reset = MC_Reset(axis=ax)
    state: dict[str, Any] = {"reset": False, "move": None}

    def program(ctx: Any) -> None:
        power()
        reset(execute=state["reset"])
        if state["move"] is not None:
            state["move"](execute=power.status)

    machine.attach(program, "motion")
    rt.run_until(lambda: power.status, max_seconds=0.5)
    assert power.status

    def recover() -> None:
        state["move"] = None
        rt.run(cycles=1)
        state["reset"] = True
        rt.run_until(lambda: reset.done or reset.error, max_seconds=2.0)
        assert reset.done, (reset.error_id, ax.axis_error_reason)
        state["reset"] = False
        rt.run(cycles=1)
        rt.run_until(lambda: power.status, max_seconds=0.5)
        assert ax.state is AxisState.STANDSTILL, ax.axis_error_reason

    def move(position: float) -> MC_MoveAbsolute:
        mv = MC_MoveAbsolute(
            axis=ax, position=position, velocity=0.1, acceleration=1.0, deceleration=1.0
        )
        state["move"] = mv
        return mv

    # 1. drive fault mid-move
    move(0.05)
    rt.run(cycles=40)
    servo.inject_fault(0x2310)
    rt.run(cycles=5)
    assert ax.state is AxisState.ERROR_STOP and ax.axis_error is ErrorID.DRIVE_FAULT
    assert ax.axis_error_reason.count("0x2310") == 1, ax.axis_error_reason
    recover()

    # 2. the drive stops answering: COMM_TIMEOUT after the bus timeout, reset resynchronises
    servo.stall(3)
    rt.run(cycles=10)
    assert ax.state is AxisState.ERROR_STOP and ax.axis_error is ErrorID.COMM_TIMEOUT
    recover()

    # 3. the master is silent longer than the watchdog: the drive faults (its own clock)
    servo.advance(0.2)
    rt.run(cycles=5)
    assert ax.state is AxisState.ERROR_STOP and ax.axis_error is ErrorID.MASTER_LOST, (
        ax.axis_error,
        ax.axis_error_reason,
    )
    recover()

    # 4. reboot mid-move: factory parameters, connection dropped; after MC_Reset the
    #    parameters are the configured ones again before the axis moves
    move(0.03)
    rt.run(cycles=30)
    servo.reboot()
    rt.run(cycles=10)
    assert ax.state is AxisState.ERROR_STOP
    recover()
    assert ax.drive.reconfigurations == 1  # the reset after the reconnection set it up again
    params = servo.parameters
    assert params["following_error_window"] == round(0.004 * CPU)
    assert params["watchdog_ms"] == 50
    mv = move(0.0)
    rt.run_until(lambda: mv.done, max_seconds=3.0)
    rt.run(cycles=40)
    assert abs(ax.actual_position) < 5e-6
