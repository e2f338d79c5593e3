"""MC_GearIn / MC_GearOut: jerk-limited engagement from any state, exact position lock once
InGear, ratio change on the fly, disengagement keeping the velocity, buffering, limits, master
checks and the step order (invariants checked every cycle by the rig's runtime)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from motionplc.blocks import (
    AxisState,
    BufferMode,
    ErrorID,
    MC_MoveAbsolute,
    MC_MoveVelocity,
    MC_Stop,
    Source,
)
from motionplc.blocks.sync import MC_GearIn, MC_GearOut
from tests.blocks.sync_rig import Rig, jumps

S = AxisState


def _blended_master(rig: Rig) -> list[MC_MoveAbsolute]:
    """A blended sequence on the master (queued at once)."""
    m = rig.m
    seq = [
        MC_MoveAbsolute(axis=m, position=1.0, velocity=1.5),
        MC_MoveAbsolute(axis=m, position=2.5, velocity=1.0, buffer_mode=BufferMode.BLENDING_LOW),
        MC_MoveAbsolute(axis=m, position=0.5, velocity=1.8, buffer_mode=BufferMode.BUFFERED),
        MC_MoveAbsolute(axis=m, position=-1.0, velocity=2.0, buffer_mode=BufferMode.BLENDING_HIGH),
        MC_MoveAbsolute(axis=m, position=3.0, velocity=1.2, buffer_mode=BufferMode.BLENDING_NEXT),
    ]
    rig.add(*seq)
    for fb in seq:
        fb.execute = True
    return seq


def _lock_error(rig: Rig, ratio: float, in_gear: np.ndarray) -> tuple[float, int]:
    """Max |slave - (c + ratio * master)| over the cycles in gear (c from the first one)."""
    tr = rig.trace()
    idx = np.flatnonzero(in_gear)
    if idx.size == 0:
        return math.nan, 0
    c = tr[idx[0], 3] - ratio * tr[idx[0], 0]
    err = np.abs(tr[idx, 3] - (c + ratio * tr[idx, 0]))
    return float(err.max()), int(idx.size)


def test_geared_3_2_to_a_blended_sequence() -> None:
    rig = Rig().powered()
    _blended_master(rig)
    g = rig.add(MC_GearIn(master=rig.m, slave=rig.s, ratio_numerator=3, ratio_denominator=2))
    go = rig.add(MC_GearOut(slave=rig.s))
    rig.watch = {"in_gear": (g, "in_gear")}
    rig.run(150)  # the master accelerates towards 1.0
    assert abs(rig.m.a) > 0.1
    g.execute = True
    rig.run(1)
    assert rig.s.state is S.SYNCHRONIZED_MOTION and g.busy and not g.in_gear
    rig.run(2500)
    assert g.in_gear
    go.execute = True
    rig.run(2)
    assert go.done and g.command_aborted and rig.s.state is S.CONTINUOUS_MOTION
    rig.run(300)
    locked = rig.locked()
    err, n = _lock_error(rig, 1.5, locked)
    assert n > 2000
    assert err <= 1e-12 * (1.0 + np.max(np.abs(rig.trace()[:, 3])))
    # InGear is the kernel's lock, shown one scan later
    in_gear = rig.flag("in_gear")
    assert np.array_equal(in_gear[1:], locked[:-1])
    dv, da = jumps(rig)
    assert dv <= 1.0 + 1e-6 and da <= 1.0 + 1e-6


def test_gear_out_keeps_the_velocity() -> None:
    rig = Rig().powered()
    mv = rig.add(MC_MoveVelocity(axis=rig.m, velocity=1.0, execute=True))
    g = rig.add(MC_GearIn(master=rig.m, slave=rig.s, ratio_numerator=2, execute=True))
    go = rig.add(MC_GearOut(slave=rig.s))
    rig.run(1500)
    assert g.in_gear and mv.in_velocity
    assert rig.s.v == pytest.approx(2.0, abs=1e-12)
    # the master now brakes; the slave decouples while the master decelerates
    rig.add(MC_MoveVelocity(axis=rig.m, velocity=0.2, execute=True))
    rig.run(30)
    v_at, a_at = rig.s.v, rig.s.a
    assert a_at < -0.5
    go.execute = True
    rig.run(400)
    assert go.done and rig.s.state is S.CONTINUOUS_MOTION
    # the acceleration went to 0 at the slave's jerk limit: v_end = v + a|a| / (2 j)
    j = rig.s.cfg.j_max
    assert rig.s.a == 0.0
    assert abs(rig.s.v - (v_at + a_at * abs(a_at) / (2 * j))) < 0.5  # a few cycles later
    v1 = rig.s.v
    rig.run(100)
    assert rig.s.v == v1
    assert max(jumps(rig)) <= 1.0 + 1e-6


def test_ratio_change_without_gear_out() -> None:
    rig = Rig().powered()
    rig.add(MC_MoveVelocity(axis=rig.m, velocity=0.8, execute=True))
    g1 = rig.add(MC_GearIn(master=rig.m, slave=rig.s, ratio_numerator=1, execute=True))
    rig.run(1000)
    assert g1.in_gear
    g2 = rig.add(MC_GearIn(master=rig.m, slave=rig.s, ratio_numerator=-5, ratio_denominator=2))
    rig.watch = {"g2": (g2, "in_gear")}
    g2.execute = True
    rig.run(1500)
    assert g1.command_aborted and g2.in_gear
    assert rig.s.v == pytest.approx(-2.0, abs=1e-12)
    err, n = _lock_error(rig, -2.5, rig.flag("g2"))
    assert n > 100 and err <= 1e-12 * (1 + abs(rig.s.p))
    assert max(jumps(rig)) <= 1.0 + 1e-6


def test_buffered_move_starts_at_in_gear() -> None:
    rig = Rig().powered()
    rig.add(MC_MoveVelocity(axis=rig.m, velocity=0.5, execute=True))
    rig.run(200)
    g = rig.add(MC_GearIn(master=rig.m, slave=rig.s, ratio_numerator=1, execute=True))
    ma = rig.add(
        MC_MoveAbsolute(
            axis=rig.s, position=0.0, velocity=1.0, buffer_mode=BufferMode.BUFFERED, execute=True
        )
    )
    rig.watch = {"in_gear": (g, "in_gear"), "ma_active": (ma, "active")}
    rig.run(3000)
    assert g.command_aborted and ma.done and rig.s.state is S.STANDSTILL
    first_active = int(np.argmax(rig.flag("ma_active")))
    assert first_active > 0 and not rig.flag("in_gear")[first_active]
    last_in_gear = int(np.flatnonzero(rig.flag("in_gear"))[-1])
    assert 0 < first_active - last_in_gear <= 2  # handed over right after InGear
    assert max(jumps(rig)) <= 1.0 + 1e-6


def test_buffered_gear_in_starts_when_the_move_is_done() -> None:
    rig = Rig().powered()
    rig.add(MC_MoveVelocity(axis=rig.m, velocity=0.5, execute=True))
    ma = rig.add(MC_MoveAbsolute(axis=rig.s, position=0.3, velocity=1.0, execute=True))
    g = rig.add(MC_GearIn(master=rig.m, slave=rig.s, buffer_mode=BufferMode.BUFFERED))
    rig.run(2)
    g.execute = True
    rig.run(2)
    assert g.busy and not g.active and rig.s.state is S.DISCRETE_MOTION
    rig.run(3000)
    assert ma.done and g.in_gear and rig.s.v == pytest.approx(0.5, abs=1e-12)


def test_stop_aborts_the_coupling() -> None:
    rig = Rig().powered()
    rig.add(MC_MoveVelocity(axis=rig.m, velocity=1.0, execute=True))
    g = rig.add(MC_GearIn(master=rig.m, slave=rig.s, execute=True))
    rig.run(1000)
    stop = rig.add(MC_Stop(axis=rig.s, execute=True))
    rig.run(1000)
    assert g.command_aborted and stop.done and rig.s.state is S.STOPPING and rig.s.v == 0.0
    assert rig.m.state is S.CONTINUOUS_MOTION  # the master is never affected


def test_limits_refused_at_engagement() -> None:
    rig = Rig(slave={"v_max": 1.0}).powered()
    rig.add(MC_MoveVelocity(axis=rig.m, velocity=1.0, execute=True))
    rig.run(1000)
    g = rig.add(MC_GearIn(master=rig.m, slave=rig.s, ratio_numerator=3, execute=True))
    rig.run(1)
    assert g.error and g.error_id is ErrorID.SLAVE_LIMITS_EXCEEDED
    assert "exceeds the slave's limits" in g.error_text
    assert rig.s.state is S.STANDSTILL and rig.s.v == 0.0


def test_limits_supervised_while_coupled() -> None:
    rig = Rig(slave={"v_max": 1.6}).powered()
    mv = rig.add(MC_MoveVelocity(axis=rig.m, velocity=0.5, execute=True))
    g = rig.add(MC_GearIn(master=rig.m, slave=rig.s, ratio_numerator=3, execute=True))
    rig.run(1000)
    assert g.in_gear
    mv2 = rig.add(MC_MoveVelocity(axis=rig.m, velocity=1.0, acceleration=0.5, execute=True))
    rig.run(3000)
    assert mv2.in_velocity and not mv.busy
    assert g.error and g.error_id is ErrorID.SLAVE_LIMITS_EXCEEDED
    assert rig.s.state is S.STANDSTILL and rig.s.v == 0.0  # a controlled stop
    assert np.max(np.abs(rig.trace()[:, 4])) <= 1.6 * (1 + 1e-9)


def test_master_checks() -> None:
    rig = Rig(extra={"t": {"v_max": 1.0, "a_max": 1.0}}).powered()
    t = rig.rt.axes["t"]
    bad_self = rig.add(MC_GearIn(master=rig.s, slave=rig.s, execute=True))
    bad_none = rig.add(MC_GearIn(master=None, slave=rig.s, execute=True))
    rig.run(1)
    assert (
        bad_self.error_id is ErrorID.INVALID_MASTER and bad_none.error_id is ErrorID.INVALID_MASTER
    )
    a = rig.add(MC_GearIn(master=rig.m, slave=rig.s, execute=True))
    b = rig.add(MC_GearIn(master=rig.s, slave=t, execute=True))
    rig.run(2)
    assert a.busy and b.busy
    cyc = rig.add(MC_GearIn(master=t, slave=rig.m, execute=True))  # m -> s -> t -> m
    rig.run(1)
    assert cyc.error and cyc.error_id is ErrorID.INVALID_MASTER
    assert rig.m.state is S.STANDSTILL


@pytest.mark.parametrize(
    ("num", "den"), [(0.5, 1), (True, 1), (40000, 1), (1, 0), (1, -2), (1, 70000), (1, 2.0)]
)
def test_invalid_ratio(num: object, den: object) -> None:
    rig = Rig().powered()
    g = rig.add(MC_GearIn(master=rig.m, slave=rig.s, ratio_numerator=num, ratio_denominator=den))
    g.execute = True
    rig.run(1)
    assert g.error and g.error_id is ErrorID.INVALID_RATIO
    assert "ratio_" in g.error_text and "integer in" in g.error_text
    assert g.input_problems(rig.s).keys() & {"ratio_numerator", "ratio_denominator"}


def test_master_steps_before_its_slave() -> None:
    """The slave declared first: the coupling re-sorts the task, SET_VALUE is of this cycle."""
    rig = Rig(slave_first=True).powered()
    task = rig.rt.tasks[0]
    assert [a.name for a in task.axes] == ["s", "m"]
    rig.add(MC_MoveVelocity(axis=rig.m, velocity=1.0, execute=True))
    g = rig.add(MC_GearIn(master=rig.m, slave=rig.s, ratio_numerator=3, ratio_denominator=2))
    rig.watch = {"in_gear": (g, "in_gear")}
    rig.run(50)
    g.execute = True
    rig.run(1)
    assert [a.name for a in task.axes] == ["m", "s"]
    rig.run(1500)
    err, n = _lock_error(rig, 1.5, rig.flag("in_gear"))
    assert n > 500 and err <= 1e-12 * (1 + abs(rig.s.p))
    assert rig.s.v == 1.5 * rig.m.v


def test_actual_value_source() -> None:
    rig = Rig().powered()
    rig.add(MC_MoveVelocity(axis=rig.m, velocity=1.0, execute=True))
    rig.run(500)
    g = rig.add(
        MC_GearIn(master=rig.m, slave=rig.s, master_value_source=Source.ACTUAL_VALUE, execute=True)
    )
    rig.run(800)
    assert g.in_gear
    # the ideal drive's actual position is the set position sent in the last cycle
    assert rig.s.v == pytest.approx(rig.m.act_v, abs=1e-12)


ENGAGE_MASTER = st.sampled_from(["rest", "cruise", "accelerate", "decelerate"])


@settings(
    max_examples=20, deadline=None, suppress_health_check=[HealthCheck.too_slow], derandomize=True
)
@given(
    num=st.integers(-4, 4),
    den=st.integers(1, 3),
    master=ENGAGE_MASTER,
    v_slave=st.sampled_from([0.0, 0.7, -1.3]),
    a_slave=st.sampled_from([0.0, 3.0]),
    jerk=st.sampled_from([0.0, 120.0]),
)
def test_engagement_from_any_state(
    num: int, den: int, master: str, v_slave: float, a_slave: float, jerk: float
) -> None:
    rig = Rig().powered()
    if v_slave != 0.0:
        acc = 24.0 if a_slave == 0.0 else 3.0
        rig.add(MC_MoveVelocity(axis=rig.s, velocity=v_slave, acceleration=acc, execute=True))
    if master != "rest":
        v = 1.5 if master != "decelerate" else 0.1
        rig.add(MC_MoveVelocity(axis=rig.m, velocity=1.0, acceleration=4.0, execute=True))
        if master == "decelerate":
            rig.run(700)
            rig.add(MC_MoveVelocity(axis=rig.m, velocity=v, acceleration=2.0, execute=True))
    rig.run(60 if master in ("accelerate", "decelerate") else 600)
    g = rig.add(
        MC_GearIn(master=rig.m, slave=rig.s, ratio_numerator=num, ratio_denominator=den, jerk=jerk)
    )
    rig.watch = {"in_gear": (g, "in_gear")}
    k0 = len(rig.rows)
    g.execute = True
    rig.run(1400)
    assert g.in_gear, g.error_text
    r = num / den
    err, n = _lock_error(rig, r, rig.flag("in_gear"))
    assert n > 0 and err <= 1e-12 * (1 + float(np.max(np.abs(rig.trace()[:, 3]))))
    assert rig.s.v == pytest.approx(r * rig.m.v, abs=1e-12)
    dv, da = jumps(rig, k0 - 1)
    assert dv <= 1.0 + 1e-6 and da <= 1.0 + 1e-6


def test_modulo_master_and_its_set_position() -> None:
    """A modulo master wraps, the slave does not; MC_SetPosition on the master (a coordinate
    shift) does not move the slave."""
    from motionplc.blocks import MC_SetPosition

    rig = Rig(master={"modulo": 1.0}).powered()
    rig.add(MC_MoveVelocity(axis=rig.m, velocity=1.5, execute=True))
    g = rig.add(MC_GearIn(master=rig.m, slave=rig.s, ratio_numerator=2, execute=True))
    rig.run(3000)
    assert g.in_gear and rig.s.p > 4.0 and 0.0 <= rig.m.position < 1.0
    sp = rig.add(MC_SetPosition(axis=rig.m, position=0.25, execute=True))
    rig.run(200)
    assert sp.done and g.in_gear and rig.s.v == pytest.approx(3.0, abs=1e-12)
    assert max(jumps(rig)) <= 1.0 + 1e-6


def test_master_in_another_task() -> None:
    """The master steps in another task (here after the slave's): the slave follows its latest
    set values, those of the tick before (a constant lag of one cycle)."""
    from motionplc.blocks import MC_Power
    from motionplc.runtime import Runtime

    rt = Runtime(cycle=0.001, check_invariants=True)
    m = rt.add_axis("m", task="slow", v_max=2.0, a_max=4.0, j_max=40.0)
    s = rt.add_axis("s", task="fast", v_max=6.0, a_max=24.0, j_max=300.0)
    pm, ps = MC_Power(axis=m, enable=True), MC_Power(axis=s, enable=True)
    mv = MC_MoveVelocity(axis=m, velocity=1.0, execute=True)
    g = MC_GearIn(master=m, slave=s, ratio_numerator=1)
    rt.add_task("fast", lambda ctx: (ps(), g()), priority=0)
    rt.add_task("slow", lambda ctx: (pm(), mv()), priority=1)
    rt.run(cycles=100)
    g.execute = True
    rt.run(cycles=2000)
    assert g.in_gear and s.v == pytest.approx(m.v, abs=1e-12)
    c = s.p - m.p
    rt.run(cycles=100)
    assert s.p - m.p == pytest.approx(c, abs=1e-12)


def test_buffered_gear_in_behind_gear_in_and_aborting_move() -> None:
    rig = Rig().powered()
    rig.add(MC_MoveVelocity(axis=rig.m, velocity=0.5, execute=True))
    g1 = rig.add(MC_GearIn(master=rig.m, slave=rig.s, ratio_numerator=1, execute=True))
    g2 = rig.add(
        MC_GearIn(
            master=rig.m,
            slave=rig.s,
            ratio_numerator=2,
            buffer_mode=BufferMode.BUFFERED,
            execute=True,
        )
    )
    rig.run(3000)
    assert g1.command_aborted and g2.in_gear and rig.s.v == pytest.approx(1.0, abs=1e-12)
    ma = rig.add(MC_MoveAbsolute(axis=rig.s, position=0.0, velocity=1.0, execute=True))
    rig.run(2)
    assert g2.command_aborted and ma.busy and rig.s.state is S.DISCRETE_MOTION
    rig.run(5000)
    assert ma.done and rig.s.p == 0.0
    assert max(jumps(rig)) <= 1.0 + 1e-6


def test_invariant_checker_holds_a_locked_coupling_to_its_law() -> None:
    from motionplc.blocks.sync_job import check_coupling

    rig = Rig().powered()
    rig.add(MC_MoveVelocity(axis=rig.m, velocity=1.0, execute=True))
    g = rig.add(MC_GearIn(master=rig.m, slave=rig.s, ratio_numerator=3, ratio_denominator=2))
    g.execute = True
    assert check_coupling(rig.s) is None  # not coupled yet: nothing to check
    rig.run(1500)
    assert g.in_gear and check_coupling(rig.s) is None
    rig.s.p += 1e-6  # off the law
    why = check_coupling(rig.s)
    assert why is not None and "gear locked" in why


def test_buffered_successor_that_cannot_start_leaves_the_slave_moving() -> None:
    """The coupling hands over at InGear, but its buffered successor is refused when it starts
    (its target beyond a software limit): the slave keeps its velocity (ContinuousMotion)."""
    rig = Rig(slave={"sw_limit_pos": 50.0, "sw_limit_neg": -50.0}).powered()
    rig.add(MC_MoveVelocity(axis=rig.m, velocity=0.5, execute=True))
    rig.run(1000)
    g = rig.add(MC_GearIn(master=rig.m, slave=rig.s, execute=True))
    ma = rig.add(
        MC_MoveAbsolute(
            axis=rig.s, position=80.0, velocity=1.0, buffer_mode=BufferMode.BUFFERED, execute=True
        )
    )
    rig.run(2000)
    assert g.command_aborted
    assert ma.error and ma.error_id is ErrorID.TARGET_OUTSIDE_SW_LIMITS
    assert rig.s.state is S.CONTINUOUS_MOTION and rig.s.v == pytest.approx(0.5, abs=1e-12)
    assert max(jumps(rig)) <= 1.0 + 1e-6
