"""Appendix A blended sequence (runtime issue) on fieldbus axes: CAN and Modbus vs ideal.

The sequence of ``tests/blocks/test_appendix_a.py`` (examples 4-7: FB1 to 1000 at 100, FB2
to 2000 at 50 started at t = 2 s, FB3 to 3000 at 100 started at t = 14 s, all blending) runs
on

* a CAN axis: our CANopen master <-> our virtual CiA 402 drive on a python-can ``virtual``
  channel of its own, lock-stepped (1 ms cycle, one SYNC per cycle);
* a Modbus axis: our Modbus master <-> our virtual Modbus drive on 127.0.0.1, lock-stepped
  (4 ms cycle, one FC23 per cycle);
* an ideal drive with the same cycle (the reference).

Power-up takes a few more cycles on a real bus (the CiA 402 state machine walks 0x06, 0x07,
0x0F with one cycle of transport delay each), so the sequence starts at the same fixed cycle
on every rig, after every axis is in Standstill. From there the commanded trace (set position,
velocity, acceleration of every cycle) must be identical, and the actual position must follow
within the plant's expected following error, computed from the plant parameters.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import pytest

from motionplc.blocks import AxisState, BufferMode, MC_MoveAbsolute
from tests.hil.rigs import COUNTS_PER_UNIT, PLANT, HilRig

START = 40  # cycle at which the sequence starts (every rig is in Standstill by then)
FB1 = dict(position=1000.0, velocity=100.0, acceleration=100.0, deceleration=100.0)
FB2 = dict(position=2000.0, velocity=50.0, acceleration=50.0, deceleration=50.0)
FB3 = dict(position=3000.0, velocity=100.0, acceleration=100.0, deceleration=100.0)
V_MAX_SEQ = 100.0  # the largest Velocity input of the sequence [u/s]
A_MAX_SEQ = 100.0  # the largest Acceleration/Deceleration input [u/s²]


def run_sequence(rig: HilRig, mode: BufferMode) -> tuple[MC_MoveAbsolute, ...]:
    cycle = rig.rt.cycle
    fbs = rig.add(
        MC_MoveAbsolute(**FB1),
        MC_MoveAbsolute(**FB2, buffer_mode=mode),
        MC_MoveAbsolute(**FB3, buffer_mode=mode),
    )
    rig.run(START)
    assert rig.axes[0].state is AxisState.STANDSTILL
    rig.pulse(fbs[0])
    rig.run(round(2.0 / cycle) - 1)
    rig.pulse(fbs[1])
    rig.run(round(12.0 / cycle) - 1)
    rig.pulse(fbs[2])
    ok = rig.rt.run_until(lambda: not fbs[2].busy, max_seconds=40.0)
    assert ok, "sequence did not finish"
    rig.run(round(0.1 / cycle))  # settle
    return fbs


def expected_following_error(cycle: float) -> float:
    """Bound of |set position (sent last cycle) - actual position| from the plant model.

    The error dynamics of the plant (P-loop kp, velocity feed-forward kff, first-order velocity
    loop tau_v) are ``tau_v·e'' + e' + kp·e = (1 - kff)·v_d + tau_v·a_d``; with these gains they
    are overdamped (tau_v·4·kp < 1), so the impulse response is positive and
    ``|e| <= max|(1 - kff)·v_d + tau_v·a_d| / kp`` (the DC gain). CSP interpolation inside the
    drive adds at most one servo sub-tick of lag, ``v·cycle/substeps``, and the position
    quantisation one count.
    """
    p = PLANT
    assert p.tau_v * 4.0 * p.kp < 1.0, "plant must be overdamped for this bound"
    steady = ((1.0 - p.kff) * V_MAX_SEQ + p.tau_v * A_MAX_SEQ) / p.kp
    return steady + V_MAX_SEQ * cycle / p.substeps + 1.0 / COUNTS_PER_UNIT


@pytest.mark.parametrize(("kind", "cycle"), [("can", 0.001), ("modbus", 0.004)])
def test_blended_sequence_same_commanded_trace_as_ideal(
    rig_factory: Callable[..., HilRig], kind: str, cycle: float
) -> None:
    mode = BufferMode.BLENDING_LOW
    ideal = rig_factory("ideal", cycle=cycle, check_invariants=False)
    bus = rig_factory(kind, cycle=cycle, check_invariants=False)
    f_ideal = run_sequence(ideal, mode)
    f_bus = run_sequence(bus, mode)
    n = ideal.rt.tick
    assert bus.rt.tick == n
    # identical commanded trace, every cycle from the start of the sequence
    for col in ("x.position", "x.velocity", "x.acceleration", "x.jerk"):
        a, b = ideal.col(col)[START:], bus.col(col)[START:]
        assert a.shape == b.shape == (n - START,)
        assert np.array_equal(a, b), f"{col} differs from the ideal drive ({kind})"
    assert (bus.col("cycle") == np.arange(n)).all()
    # the same outputs in the same cycles
    for a, b in zip(f_ideal, f_bus, strict=True):
        for out in ("busy", "active", "done", "command_aborted", "error"):
            assert ideal.rt.trace.edges(a.name, out) == bus.rt.trace.edges(b.name, out)
    assert [fb.end_velocity for fb in f_bus] == [fb.end_velocity for fb in f_ideal]
    # the actual position follows within the plant's expected following error
    fe = bus.col("x.following_error")[START:]
    bound = expected_following_error(cycle)
    assert np.abs(fe).max() <= bound, (np.abs(fe).max(), bound)
    assert np.abs(fe).max() > 0.5 * bound  # the plant really lags (not an ideal follower)
    assert bus.axes[0].act_p == pytest.approx(3000.0, abs=2.0 / COUNTS_PER_UNIT)
    assert bus.axes[0].state is AxisState.STANDSTILL
    state = bus.col("x.state")[START:]
    assert not (state == float(AxisState.ERROR_STOP)).any()
