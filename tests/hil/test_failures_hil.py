"""Every fieldbus failure mode injected during motion, through the runtime and the PLCopen FBs.

For each mode (CAN: dropped RPDOs, dropped TPDOs, late RPDOs, late TPDOs, drive fault,
heartbeat loss, master heartbeat loss seen by the drive, bus-off, following error exceeded;
Modbus: timeout, exception responses, drive fault, following error exceeded) the axis moves at
constant velocity, the fault is switched on, and:

* the axis goes to ErrorStop within a bounded number of cycles with the mode's own AxisErrorID
  (MC_ReadAxisError), the moving FB reports Error (AXIS_ERROR_STOP);
* the commanded stop is controlled: the set speed falls monotonically to 0 with |a| <= a_max;
* the trace has every cycle, before, during and after the fault;
* while a persistent fault is present MC_Reset fails; once it is gone MC_Reset succeeds, the
  axis is in Standstill and a new move completes;
* nothing raises and every wait is bounded (cycle counts; Modbus requests time out).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
import pytest
from pymodbus.constants import ExcCodes

from motionplc.blocks import (
    AxisState,
    MC_MoveAbsolute,
    MC_MoveRelative,
    MC_ReadAxisError,
    MC_Reset,
)
from motionplc.blocks.enums import ErrorID
from tests.hil.rigs import HilRig

A_MAX = 400.0
V_MOVE = 100.0
CAN_HB = 0x700  # + node


@dataclass(frozen=True)
class Mode:
    name: str
    kind: str  # "can" or "modbus"
    inject: Callable[[HilRig], None]
    clear: Callable[[HilRig], None]
    error: ErrorID
    within: int  # cycles from injection to ErrorStop
    persistent: bool = True  # MC_Reset must fail while the fault is present
    drive_options: dict[str, Any] | None = None
    axis_options: dict[str, Any] | None = None


def _can_master(rig: HilRig) -> Any:
    assert rig.master_bus is not None
    return rig.master_bus


def _can_rack(rig: HilRig) -> Any:
    assert rig.rack is not None
    return rig.rack


def _set(attr: str, value: Any) -> Callable[[HilRig], None]:
    def f(rig: HilRig) -> None:
        setattr(rig.vdrives[0], attr, value)

    return f


def _stall(on: bool) -> Callable[[HilRig], None]:
    def f(rig: HilRig) -> None:
        rig.vdrives[0].device.stalled = on

    return f


MODES = [
    # --- CAN --------------------------------------------------------------------------------
    Mode(  # RPDOs lost on the way to the drive: it holds 2 cycles, then faults 0x8250
        "can-dropped-rpdo",
        "can",
        lambda r: _can_master(r).drop_tx_ids.add(0x201),
        lambda r: _can_master(r).drop_tx_ids.discard(0x201),
        ErrorID.SETPOINT_LOST,
        within=6,
    ),
    Mode(  # TPDOs lost on the way to the master: no feedback for > 3 cycles
        "can-dropped-tpdo",
        "can",
        lambda r: _can_rack(r).faults.drop_tx_ids.update({0x181, 0x281}),
        lambda r: _can_rack(r).faults.drop_tx_ids.difference_update({0x181, 0x281}),
        ErrorID.FEEDBACK_LOST,
        within=6,
    ),
    Mode(  # RPDOs delivered 4 cycles late (after their SYNC): the drive misses them, 0x8250
        "can-late-rpdo",
        "can",
        lambda r: _can_master(r).delay_tx.update({0x201: 4}),
        lambda r: _can_master(r).delay_tx.clear(),
        ErrorID.SETPOINT_LOST,
        within=6,
        persistent=False,  # a steady delay afterwards is just more transport delay
    ),
    Mode(  # TPDOs delivered 5 cycles late: stale feedback for more than the allowed 3 cycles
        "can-late-tpdo",
        "can",
        lambda r: _can_master(r).delay_rx.update({0x181: 5, 0x281: 5}),
        lambda r: _can_master(r).delay_rx.clear(),
        ErrorID.FEEDBACK_LOST,
        within=6,
        persistent=False,  # a steady delay afterwards is just more transport delay
    ),
    Mode(  # a drive fault (over-current): FAULT REACTION -> FAULT, EMCY 0x2310
        "can-drive-fault",
        "can",
        lambda r: r.vdrives[0].inject_fault(0x2310, persistent=True),
        lambda r: r.vdrives[0].clear_fault(),
        ErrorID.DRIVE_FAULT,
        within=3,
    ),
    Mode(  # the drive's heartbeat stops: node offline after 1.5 x 50 ms
        "can-heartbeat-lost",
        "can",
        lambda r: _can_rack(r).stop_heartbeat(1),
        lambda r: _can_rack(r).stop_heartbeat(1, stopped=False),
        ErrorID.HEARTBEAT_LOST,
        within=80,
    ),
    Mode(  # the master's heartbeat stops reaching the drive (consumer 0x1016, 20 ms): 0x8130
        "can-master-heartbeat-lost",
        "can",
        lambda r: _can_master(r).drop_tx_ids.add(CAN_HB + 0x7F),
        lambda r: _can_master(r).drop_tx_ids.discard(CAN_HB + 0x7F),
        ErrorID.MASTER_LOST,
        within=35,
        persistent=False,  # the drive re-arms its consumer at the next heartbeat
        drive_options={"master_heartbeat_timeout": 0.02},
    ),
    Mode(  # the master's controller goes bus-off: sends fail, nothing is received
        "can-bus-off",
        "can",
        lambda r: setattr(_can_master(r), "bus_off", True),
        lambda r: setattr(_can_master(r), "bus_off", False),
        ErrorID.BUS_OFF,
        within=2,
    ),
    Mode(  # jammed mechanics: following error > 0x6065 for 0x6066 -> drive fault 0x8611
        "can-following-error",
        "can",
        _stall(True),
        _stall(False),
        ErrorID.FOLLOWING_ERROR,
        within=150,
        persistent=False,
    ),
    Mode(  # the same seen by the axis' own following-error supervision (limit 0.5 u)
        "can-following-error-axis",
        "can",
        _stall(True),
        _stall(False),
        ErrorID.FOLLOWING_ERROR,
        within=10,
        persistent=False,
        axis_options={"following_error_limit": 0.5},
    ),
    # --- Modbus -----------------------------------------------------------------------------
    Mode(  # answers 200 ms late on the drive's (simulated) clock: no answer for the 15 cycles
        "modbus-timeout",  # of the 60 ms timeout (4 ms task) -> COMM_TIMEOUT, reconnect
        "modbus",
        _set("response_delay", 0.2),
        _set("response_delay", 0.0),
        ErrorID.COMM_TIMEOUT,
        within=15 + 2,
        drive_options={"timeout": 0.06},
    ),
    Mode(  # exception responses (0x04 device failure)
        "modbus-exception",
        "modbus",
        lambda r: r.vdrives[0].inject_exception(ExcCodes.DEVICE_FAILURE),
        lambda r: r.vdrives[0].clear_exception(),
        ErrorID.COMM_EXCEPTION,
        within=2,
    ),
    Mode(
        "modbus-drive-fault",
        "modbus",
        lambda r: r.vdrives[0].inject_fault(0x4210, persistent=True),
        lambda r: r.vdrives[0].clear_fault(),
        ErrorID.DRIVE_FAULT,
        within=2,
    ),
    Mode(
        "modbus-following-error",
        "modbus",
        _stall(True),
        _stall(False),
        ErrorID.FOLLOWING_ERROR,
        within=40,
        persistent=False,
    ),
]


def _run_until(rig: HilRig, pred: Callable[[], bool], cycles: int) -> bool:
    return rig.rt.run_until(pred, max_seconds=cycles * rig.rt.cycle)


@pytest.mark.parametrize("mode", MODES, ids=lambda m: m.name)
def test_failure_during_motion(rig_factory: Callable[..., HilRig], mode: Mode) -> None:
    cycle = 0.001 if mode.kind == "can" else 0.004
    rig = rig_factory(
        mode.kind,
        cycle=cycle,
        a_max=A_MAX,
        drive_options=mode.drive_options,
        axis_options=mode.axis_options,
    )
    ax = rig.axes[0]
    move = MC_MoveAbsolute(position=500.0, velocity=V_MOVE, acceleration=A_MAX, deceleration=A_MAX)
    read_error = MC_ReadAxisError(enable=True)
    reset = MC_Reset()
    rig.add(move, read_error, reset)
    assert _run_until(rig, lambda: ax.state is AxisState.STANDSTILL, 50)
    move.execute = True
    assert _run_until(rig, lambda: ax.v >= V_MOVE, round(0.5 / cycle))
    rig.run(5)

    # --- the fault, during motion at constant velocity ---
    k_fault = rig.rt.tick
    mode.inject(rig)
    assert _run_until(rig, lambda: ax.state is AxisState.ERROR_STOP, mode.within), (
        f"no ErrorStop within {mode.within} cycles: {ax!r}"
    )
    k_err = rig.rt.tick - 1
    rig.run(1)
    assert ax.axis_error is mode.error, (ax.axis_error, ax.axis_error_reason)
    assert read_error.axis_error_id is mode.error
    assert ax.axis_error_reason
    assert move.error and move.error_id is ErrorID.AXIS_ERROR_STOP
    assert not move.busy and not move.done

    # --- controlled stop of the set values (jerk-limited ramp with a_max) ---
    assert _run_until(rig, lambda: ax.active is None and ax.v == 0.0, round(1.0 / cycle))
    rig.run(3)
    v = rig.col("x.velocity")[k_err:]
    acc = rig.col("x.acceleration")[k_err:]
    assert (np.diff(np.abs(v)) <= 1e-9).all()
    assert np.abs(acc).max() <= A_MAX * (1 + 1e-9)
    assert v[-1] == 0.0
    assert ax.state is AxisState.ERROR_STOP

    # --- MC_Reset fails while the fault is still there ---
    if mode.persistent:
        reset.execute = True
        assert _run_until(rig, lambda: reset.done or reset.error, 100)
        assert reset.error and not reset.done
        reset.execute = False
        rig.run(1)
        assert ax.state is AxisState.ERROR_STOP

    # --- the fault goes away: MC_Reset recovers, a new move completes ---
    mode.clear(rig)
    rig.run(3)
    reset.execute = True
    assert _run_until(rig, lambda: reset.done or reset.error, 200)
    assert reset.done, (reset.error_id, ax.axis_error_reason)
    reset.execute = False
    assert _run_until(rig, lambda: ax.state is AxisState.STANDSTILL, 100)
    assert ax.axis_error is ErrorID.OK and read_error.axis_error_id is ErrorID.OK
    again = MC_MoveRelative(distance=2.0, velocity=20.0, acceleration=A_MAX, deceleration=A_MAX)
    rig.add(again)
    again.execute = True
    assert _run_until(rig, lambda: again.done or again.error, round(1.0 / cycle))
    assert again.done, (again.error_id, ax.state, ax.axis_error, ax.axis_error_reason)
    rig.run(round(0.2 / cycle))  # the drive settles on the end position
    assert math.isclose(ax.act_p, ax.p, abs_tol=0.01)

    # --- the trace has every cycle, before and after the fault ---
    n = rig.rt.tick
    assert (rig.col("cycle") == np.arange(n)).all()
    state = rig.col("x.state")
    assert (state[k_fault - 5 : k_fault] == float(AxisState.DISCRETE_MOTION)).all()
    assert (state[k_err : k_err + 10] == float(AxisState.ERROR_STOP)).all()


def test_one_late_tpdo_is_tolerated(rig_factory: Callable[..., HilRig]) -> None:
    """A TPDO one cycle late (or one lost) is flagged stale, without an axis error."""
    rig = rig_factory("can", a_max=A_MAX)
    ax = rig.axes[0]
    move = MC_MoveAbsolute(position=100.0, velocity=V_MOVE, acceleration=A_MAX, deceleration=A_MAX)
    rig.add(move)
    assert _run_until(rig, lambda: ax.state is AxisState.STANDSTILL, 50)
    move.execute = True
    rig.run(300)
    bus = _can_master(rig)
    bus.delay_rx.update({0x181: 1, 0x281: 1})
    rig.run(20)
    bus.delay_rx.clear()
    assert _run_until(rig, lambda: move.done, 2000)
    assert ax.axis_error is ErrorID.OK
