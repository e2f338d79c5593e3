"""MC_MoveSuperimposed / MC_HaltSuperimposed (issue 16): a relative move added to whatever the
axis does, with the SUM of underlying and superimposed motion within the axis' limits.

Every Bench checks the conformance invariants each cycle (v and a within the axis limits, p / v
/ a continuous, FB output rules, state changes along the diagram); the tests here add the jerk of
the sum (the difference of consecutive accelerations), the exact end positions and the state
machine of plcopen.md 1.3.
"""

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
    MC_Halt,
    MC_Home,
    MC_MoveAbsolute,
    MC_MoveRelative,
    MC_MoveVelocity,
    MC_Stop,
)
from motionplc.blocks.motion import StaticAxis
from motionplc.blocks.superimposed import MC_HaltSuperimposed, MC_MoveSuperimposed
from tests.runtime.helpers import Bench

S = AxisState
LIM = {"v_max": 2.0, "a_max": 4.0, "j_max": 40.0}
# the underlying moves use part of the axis' limits (the usual set-up for corrections)
UNDER = {"velocity": 1.0, "acceleration": 2.0, "deceleration": 2.0, "jerk": 20.0}


def _bench(**kw: float) -> Bench:
    return Bench(**{**LIM, **kw}).powered()


def _ratios(b: Bench) -> tuple[float, float, float]:
    """max |v| / v_max, max |a| / a_max, max |j| / j_max of the set values over the trace (the
    jerk as the difference of consecutive accelerations / dt)."""
    v = b.col("x.velocity")
    a = b.col("x.acceleration")
    j = np.abs(np.diff(a)) / b.rt.cycle
    return (
        float(np.max(np.abs(v))) / LIM["v_max"],
        float(np.max(np.abs(a))) / LIM["a_max"],
        float(np.max(j)) / LIM["j_max"],
    )


def _held(b: Bench) -> None:
    rv, ra, rj = _ratios(b)
    assert rv <= 1 + 1e-9 and ra <= 1 + 1e-9 and rj <= 1 + 1e-6, (rv, ra, rj)


# -- the correction during a move ----
def test_correction_during_absolute_move_ends_at_the_summed_target() -> None:
    b = _bench()
    ma = b.add(MC_MoveAbsolute(position=3.0, **UNDER))
    ms = b.add(MC_MoveSuperimposed(distance=0.5, velocity_diff=0.5))
    ma.execute = True
    b.run(500)  # cruising
    ms.execute = True
    b.run(1)
    assert ms.busy and not ms.active and b.x.state is S.DISCRETE_MOTION
    b.run_until_idle()
    assert ma.done and ms.done
    assert b.x.p == 3.0 + 0.5  # exactly: the distance folds into the job's end
    assert ms.covered_distance == 0.5
    assert b.x.state is S.STANDSTILL and b.x.sup is None  # the fast path is back
    _held(b)
    # the underlying FB finished in its own time: Done at the same cycle as without correction
    ref = _bench()
    mr = ref.add(MC_MoveAbsolute(position=3.0, **UNDER))
    mr.execute = True
    ref.run_until_idle()
    assert [c for c, v in b.edges(ma, "done") if v] == [c for c, v in ref.edges(mr, "done") if v]


def test_correction_on_a_velocity_move_is_a_pure_offset() -> None:
    """On top of MC_MoveVelocity the state stays ContinuousMotion, InVelocity stays TRUE (its
    own contribution, C8), and afterwards the axis runs exactly ``distance`` ahead of the same
    run without correction."""
    runs = []
    for d in (0.0, -0.7):
        b = _bench()
        mv = b.add(MC_MoveVelocity(velocity=1.2, acceleration=2.0, jerk=20.0))
        ms = b.add(MC_MoveSuperimposed(distance=d))
        mv.execute = True
        b.run(800)
        assert mv.in_velocity
        if d:
            ms.execute = True
        iv = []
        for _ in range(3000):
            b.run(1)
            iv.append(mv.in_velocity)
            if d:
                assert b.x.state is S.CONTINUOUS_MOTION
        assert all(iv)
        if d:
            assert ms.done and b.x.sup is None  # folded into the velocity job
        _held(b)
        runs.append(b.col("x.position"))
    diff = runs[1][-500:] - runs[0][-500:]
    assert np.max(np.abs(diff - (-0.7))) < 1e-9


def test_from_standstill_acts_like_move_relative() -> None:
    b = _bench()
    ms = b.add(MC_MoveSuperimposed(distance=-1.25))
    k = b.pulse(ms)
    assert b.x.state is S.DISCRETE_MOTION
    b.run_until_idle()
    assert [c for c, v in b.edges(ms, "done") if v]
    assert b.x.p == -1.25 and b.x.state is S.STANDSTILL
    states = b.col("x.state")[k:]
    assert set(states) == {float(S.STANDSTILL), float(S.DISCRETE_MOTION)}
    _held(b)
    # with the axis' full limits: the same time as MC_MoveRelative
    ref = _bench()
    mr = ref.add(MC_MoveRelative(distance=-1.25, velocity=LIM["v_max"]))
    ref.pulse(mr)
    ref.run_until_idle()
    assert np.allclose(b.col("x.position")[-50:], ref.col("x.position")[-50:], atol=1e-12)


def test_waits_for_headroom_while_the_underlying_uses_the_axis_jerk() -> None:
    """The underlying move uses the axis' own jerk while it accelerates: no jerk reserve, so
    the superimposed move waits (Busy, no motion) and starts at the end of that phase."""
    b = _bench()
    ma = b.add(MC_MoveAbsolute(position=4.0, velocity=1.0, acceleration=2.0))  # jerk: axis'
    ms = b.add(MC_MoveSuperimposed(distance=0.3))
    ma.execute = ms.execute = True
    b.run(2)
    assert ms.busy
    b.run_until_idle()
    assert b.x.p == 4.3 and ma.done and ms.done
    _held(b)


@pytest.mark.parametrize("late", [False, True])
def test_halt_superimposed_brakes_only_the_correction(late: bool) -> None:
    b = _bench()
    mv = b.add(MC_MoveVelocity(velocity=1.0, acceleration=2.0, jerk=20.0))
    ms = b.add(MC_MoveSuperimposed(distance=2.0, velocity_diff=0.6))
    hs = b.add(MC_HaltSuperimposed(deceleration=1.0))
    mv.execute = True
    b.run(1000)
    ms.execute = True
    b.run(900 if late else 300)
    covered = ms.covered_distance
    assert 0.0 < covered < 2.0
    hs.execute = True
    b.run(2)
    assert ms.command_aborted and hs.busy and mv.in_velocity
    b.run(2000)
    assert hs.done and not mv.command_aborted and b.x.state is S.CONTINUOUS_MOTION
    assert b.x.v == pytest.approx(1.0, abs=1e-12)  # only the underlying velocity is left
    _held(b)


def test_halt_superimposed_without_superimposed_motion_is_done_at_once() -> None:
    b = _bench()
    hs = b.add(MC_HaltSuperimposed())
    hs.execute = True
    b.run(1)
    assert hs.done and b.x.state is S.STANDSTILL


# -- abort rules ----
def _running_correction(b: Bench) -> tuple[MC_MoveAbsolute, MC_MoveSuperimposed]:
    ma = b.add(MC_MoveAbsolute(position=5.0, **UNDER))
    ms = b.add(MC_MoveSuperimposed(distance=1.0, velocity_diff=0.5))
    ma.execute = True
    b.run(600)
    ms.execute = True
    b.run(400)
    assert ms.busy and b.x.sup is not None and b.x.sup.sv != 0.0
    return ma, ms


def test_second_superimposed_aborts_only_the_first() -> None:
    b = _bench()
    ma, ms = _running_correction(b)
    at = ms.covered_distance
    ms2 = b.add(MC_MoveSuperimposed(distance=0.25, velocity_diff=0.5))
    ms2.execute = True
    b.run(2)
    assert ms.command_aborted and ms2.busy and ma.busy
    b.run_until_idle()
    assert ma.done and ms2.done
    # the second counts from the superimposed position reached: ~ at + 0.25 (one cycle more)
    assert b.x.p - 5.0 == pytest.approx(at + 0.25, abs=0.6 * 0.002)
    _held(b)


@pytest.mark.parametrize("kind", ["absolute", "halt", "stop", "velocity"])
def test_aborting_command_aborts_both_without_a_jump(kind: str) -> None:
    b = _bench()
    ma, ms = _running_correction(b)
    if kind == "absolute":
        new = b.add(MC_MoveAbsolute(position=-1.0, **UNDER))
    elif kind == "halt":
        new = b.add(MC_Halt())
    elif kind == "stop":
        new = b.add(MC_Stop())
    else:
        new = b.add(MC_MoveVelocity(velocity=0.2))
    new.execute = True
    b.run(2)
    assert ma.command_aborted and ms.command_aborted and b.x.sup is None
    b.run(4000)  # the invariants check p / v / a continuity at the hand-over
    if kind == "absolute":
        assert new.done and b.x.p == -1.0


def test_buffered_command_leaves_it_alone() -> None:
    b = _bench()
    ma, ms = _running_correction(b)
    nxt = b.add(MC_MoveRelative(distance=1.0, buffer_mode=BufferMode.BUFFERED, **UNDER))
    nxt.execute = True
    b.run_until_idle()
    assert ma.done and ms.done and nxt.done
    # the buffered move counts from the first target; the correction folded in at its end
    assert b.x.p == pytest.approx(7.0, abs=1e-12)
    _held(b)


def test_axis_error_and_power_off_end_it() -> None:
    b = _bench()
    _, ms = _running_correction(b)
    b.x.drive.inject_fault()
    b.run(2)
    assert ms.error and ms.error_id is ErrorID.AXIS_ERROR_STOP and b.x.sup is None
    b2 = _bench()
    _, ms2 = _running_correction(b2)
    b2.power.enable = False
    b2.run(2)
    assert ms2.command_aborted and b2.x.sup is None and b2.x.state is S.DISABLED


def test_end_beyond_a_software_limit_is_refused() -> None:
    b = _bench(sw_limit_pos=3.2, sw_limit_neg=-1.0)
    ma = b.add(MC_MoveAbsolute(position=3.0, **UNDER))
    ms = b.add(MC_MoveSuperimposed(distance=0.5))
    ma.execute = True
    b.run(200)
    ms.execute = True
    b.run(1)
    assert ms.error and ms.error_id is ErrorID.TARGET_OUTSIDE_SW_LIMITS
    assert "3.5" in ms.error_text
    b.run_until_idle()
    assert b.x.p == 3.0


def test_continuous_update_changes_the_distance_from_the_start() -> None:
    b = _bench()
    ma = b.add(MC_MoveAbsolute(position=5.0, **UNDER))
    ms = b.add(MC_MoveSuperimposed(distance=1.0, velocity_diff=0.5, continuous_update=True))
    ma.execute = ms.execute = True
    b.run(1500)
    ms.distance = 0.4  # still relative to where the correction started
    b.run_until_idle()
    assert ms.done and b.x.p == pytest.approx(5.4, abs=1e-12)
    _held(b)


# -- state machine (plcopen.md 1.3) ----
def _enter(b: Bench, state: AxisState) -> None:
    if state is S.DISABLED:
        b.power.enable = False
        b.run(2)
    elif state is S.HOMING:
        b.pulse(b.add(MC_Home(position=0.0)))
    elif state is S.DISCRETE_MOTION:
        b.pulse(b.add(MC_MoveAbsolute(position=100.0, velocity=0.5)))
    elif state is S.CONTINUOUS_MOTION:
        b.pulse(b.add(MC_MoveVelocity(velocity=0.5)))
    elif state is S.STOPPING:
        st_ = b.add(MC_Stop(deceleration=1.0))
        st_.execute = True
    elif state is S.ERROR_STOP:
        b.x.drive.inject_fault()
    b.run(300)
    assert b.x.state is state


STATES = [
    S.DISABLED,
    S.STANDSTILL,
    S.HOMING,
    S.DISCRETE_MOTION,
    S.CONTINUOUS_MOTION,
    S.STOPPING,
    S.ERROR_STOP,
]
# SynchronizedMotion: covered by engineer SY's gearing tests once MC_GearIn lands
MOVE_OK = {S.STANDSTILL: S.DISCRETE_MOTION, S.DISCRETE_MOTION: None, S.CONTINUOUS_MOTION: None}
HALT_ERR = {S.DISABLED, S.ERROR_STOP}


@pytest.mark.parametrize("state", STATES, ids=lambda s: s.name)
def test_move_superimposed_in_every_state(state: AxisState) -> None:
    b = Bench(home_switch=1e6, home_velocity=0.2, **LIM).powered()
    _enter(b, state)
    ms = b.add(MC_MoveSuperimposed(distance=0.1))
    ms.execute = True
    b.run(1)
    if state in MOVE_OK:
        assert ms.busy and not ms.error
        after = MOVE_OK[state] or state
        assert b.x.state is after
        b.run(1500)
        assert ms.done, ms.error_text
        assert b.x.state is (S.STANDSTILL if state is S.STANDSTILL else state)
    else:
        assert ms.error and ms.error_id is ErrorID.for_state(state)
        assert b.x.state is state and b.x.sup is None


@pytest.mark.parametrize("state", STATES, ids=lambda s: s.name)
def test_halt_superimposed_in_every_state(state: AxisState) -> None:
    b = Bench(home_switch=1e6, home_velocity=0.2, **LIM).powered()
    _enter(b, state)
    hs = b.add(MC_HaltSuperimposed())
    hs.execute = True
    b.run(1)
    assert b.x.state is state  # never changes the state
    if state in HALT_ERR:
        assert hs.error and hs.error_id is ErrorID.for_state(state)
    else:
        assert hs.done


def test_input_checks_name_the_input() -> None:
    ax = StaticAxis(Bench(**LIM).x.cfg)
    fb = MC_MoveSuperimposed(distance=math.nan, velocity_diff=-1.0, acceleration=1e9, jerk=-2)
    probs = fb.input_problems(ax)
    assert set(probs) == {"distance", "velocity_diff", "acceleration", "jerk"}
    assert probs["distance"].error_id is ErrorID.INVALID_DISTANCE
    assert probs["velocity_diff"].error_id is ErrorID.INVALID_VELOCITY
    assert "velocity_diff" in str(probs["velocity_diff"])
    assert MC_MoveSuperimposed(distance=1.0).input_problems(ax) == {}
    hs = MC_HaltSuperimposed(deceleration=math.inf)
    assert set(hs.input_problems(ax)) == {"deceleration"}
    b = _bench()
    bad = b.add(MC_MoveSuperimposed(distance=math.inf))
    bad.execute = True
    b.run(1)
    assert bad.error and bad.error_id is ErrorID.INVALID_DISTANCE and b.x.state is S.STANDSTILL


# -- property: start time, distance, underlying move, optional HaltSuperimposed ----
@settings(
    max_examples=25,
    deadline=None,
    suppress_health_check=[HealthCheck.too_slow],
)
@given(
    under=st.sampled_from(["absolute", "velocity", "none"]),
    start=st.integers(0, 1500),
    distance=st.floats(-1.5, 1.5).filter(lambda d: abs(d) > 1e-3),
    vdiff=st.sampled_from([0.0, 0.3, 0.8]),
    halt_after=st.one_of(st.none(), st.integers(1, 800)),
    target=st.floats(-3.0, 3.0).filter(lambda p: abs(p) > 0.05),
)
def test_sum_within_limits_and_exact_end(
    under: str,
    start: int,
    distance: float,
    vdiff: float,
    halt_after: int | None,
    target: float,
) -> None:
    b = _bench()
    main = None
    if under == "absolute":
        main = b.add(MC_MoveAbsolute(position=target, **UNDER))
    elif under == "velocity":
        main = b.add(MC_MoveVelocity(velocity=abs(target) / 3.0, acceleration=2.0, jerk=20.0))
    ms = b.add(MC_MoveSuperimposed(distance=distance, velocity_diff=vdiff))
    hs = b.add(MC_HaltSuperimposed())
    if main is not None:
        main.execute = True
    b.run(start)
    ms.execute = True
    if halt_after is not None:
        b.run(halt_after)
        hs.execute = True
    b.rt.run_until(
        lambda: (
            not ms.busy and not hs.busy and (main is None or not main.busy or under == "velocity")
        ),
        max_seconds=8.0,
    )
    b.run(2)
    assert not ms.busy and not hs.busy and not ms.error, ms.error_text
    _held(b)
    if halt_after is None:
        assert ms.done
        if under == "absolute":
            assert b.x.p == target + distance
        elif under == "none":
            assert b.x.p == distance
    if under != "velocity":
        assert b.x.state is S.STANDSTILL and b.x.sup is None


def test_on_a_geared_slave() -> None:
    """SynchronizedMotion (plcopen.md 1.3: accepted, no state change): a registration
    correction on a slave geared 1:1 to a master at constant velocity; the coupling stays
    locked (the invariant checker's coupling check: law + the superimposed offset) and the
    slave ends ``distance`` ahead of its law."""
    from motionplc.blocks.sync import MC_GearIn

    b = Bench(axes={"x": dict(LIM), "m": dict(LIM)}).powered()
    m = b.axes["m"]
    mv = b.add(MC_MoveVelocity(axis=m, velocity=0.5))
    g = b.add(MC_GearIn(master=m, slave=b.x, ratio_numerator=1, ratio_denominator=1))
    mv.execute = True
    b.run(300)
    g.execute = True
    b.run(1500)
    assert g.in_gear and b.x.state is S.SYNCHRONIZED_MOTION
    lag = b.x.p - m.p
    ms = b.add(MC_MoveSuperimposed(distance=0.1))
    ms.execute = True
    b.run(1)
    assert ms.busy and b.x.state is S.SYNCHRONIZED_MOTION
    b.run(1500)
    assert ms.done and g.in_gear and b.x.state is S.SYNCHRONIZED_MOTION
    assert b.x.p - m.p == pytest.approx(lag + 0.1, abs=1e-9)
    _held(b)


def test_no_headroom_is_an_error_that_says_why() -> None:
    b = _bench()
    mv = b.add(MC_MoveVelocity(velocity=LIM["v_max"]))  # at the axis' speed limit
    ms = b.add(MC_MoveSuperimposed(distance=0.2))
    mv.execute = True
    b.run(1500)
    ms.execute = True
    b.run(2)
    assert ms.error and ms.error_id is ErrorID.PLANNING_FAILED
    assert "no headroom" in ms.error_text
    assert mv.in_velocity and b.x.state is S.CONTINUOUS_MOTION and b.x.sup is None
    ms.execute = False
    b.run(1)
    ms.distance = -0.2  # backwards there is headroom
    ms.execute = True
    b.run(3000)
    assert ms.done and mv.in_velocity
    _held(b)
