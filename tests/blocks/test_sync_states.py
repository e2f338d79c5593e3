"""The master/slave FBs in every axis state (spec notes 1.3: accepted with the transition, or
Error with the state's ErrorID and the axis unaffected), and a stateful hypothesis test mixing
gear / cam / phasing FBs with moves, stops and power on the master and the slave (every cycle
checked by the runtime's invariant checker, including the coupling law once locked)."""

from __future__ import annotations

import math
from typing import Any

import pytest
from hypothesis import HealthCheck, settings
from hypothesis import strategies as st
from hypothesis.stateful import RuleBasedStateMachine, invariant, rule

from motionplc.blocks import (
    AxisState,
    ErrorID,
    MC_Home,
    MC_MoveAbsolute,
    MC_MoveVelocity,
    MC_Reset,
    MC_Stop,
)
from motionplc.blocks.cam_select import CamTableID
from motionplc.blocks.sync import (
    MC_CamIn,
    MC_CamOut,
    MC_GearIn,
    MC_GearInPos,
    MC_GearOut,
    MC_PhasingAbsolute,
    MC_PhasingRelative,
)
from motionplc.planning.cam import CamTable
from tests.blocks.sync_rig import Rig

S = AxisState
TABLE = CamTable.from_points(
    [(0.0, 0.0), (1.0, 0.2), (2.0, 0.0)], laws=["poly5", "modified_sine"], periodic=True
)
STATES = list(S)
SLAVE = {"v_max": 6.0, "a_max": 24.0, "j_max": 300.0, "home_switch": 1e6, "home_velocity": 1.0}


def _enter(rig: Rig, state: AxisState) -> None:
    s = rig.s
    if state is S.DISABLED:
        rig.powers[1].enable = False
    elif state is S.HOMING:
        rig.add(MC_Home(axis=s, execute=True))
    elif state is S.DISCRETE_MOTION:
        rig.add(MC_MoveAbsolute(axis=s, position=100.0, velocity=1.0, execute=True))
    elif state is S.CONTINUOUS_MOTION:
        rig.add(MC_MoveVelocity(axis=s, velocity=1.0, execute=True))
    elif state is S.SYNCHRONIZED_MOTION:
        rig.add(MC_GearIn(master=rig.m, slave=s, execute=True))
    elif state is S.STOPPING:
        rig.add(MC_Stop(axis=s, deceleration=1.0, execute=True))
    elif state is S.ERROR_STOP:
        s.drive.inject_fault()
    rig.run(5)
    assert s.state is state


def _couplings(rig: Rig) -> dict[str, Any]:
    return {
        "MC_GearIn": MC_GearIn(master=rig.m, slave=rig.s, ratio_numerator=2),
        "MC_GearInPos": MC_GearInPos(master=rig.m, slave=rig.s, master_sync_position=1.0),
        "MC_CamIn": MC_CamIn(master=rig.m, slave=rig.s, cam_table_id=CamTableID(TABLE)),
    }


COUPLING_OK = {S.STANDSTILL, S.DISCRETE_MOTION, S.CONTINUOUS_MOTION, S.SYNCHRONIZED_MOTION}


@pytest.mark.parametrize("fbname", ["MC_GearIn", "MC_GearInPos", "MC_CamIn"])
@pytest.mark.parametrize("state", STATES, ids=lambda s: s.name)
def test_coupling_in_every_state(state: AxisState, fbname: str) -> None:
    rig = Rig(slave=SLAVE).powered()
    rig.add(MC_MoveVelocity(axis=rig.m, velocity=0.5, execute=True))  # the master moves
    _enter(rig, state)
    m_state = rig.m.state
    fb = rig.add(_couplings(rig)[fbname])
    fb.execute = True
    rig.run(1)
    if state in COUPLING_OK:
        assert not fb.error, fb.error_text
        assert rig.s.state is S.SYNCHRONIZED_MOTION
    else:
        assert fb.error and fb.error_id is ErrorID.for_state(state)
        assert rig.s.state is state
    assert rig.m.state is m_state  # being a master changes nothing


@pytest.mark.parametrize("fbcls", [MC_GearOut, MC_CamOut])
@pytest.mark.parametrize("state", STATES, ids=lambda s: s.name)
def test_gear_out_in_every_state(state: AxisState, fbcls: type) -> None:
    rig = Rig(slave=SLAVE).powered()
    rig.add(MC_MoveVelocity(axis=rig.m, velocity=0.5, execute=True))
    _enter(rig, state)
    fb = rig.add(fbcls(slave=rig.s, execute=True))
    rig.run(1)
    if state is S.SYNCHRONIZED_MOTION:
        assert not fb.error and rig.s.state is S.CONTINUOUS_MOTION
        rig.run(1)
        assert fb.done
    else:
        assert fb.error and fb.error_id is ErrorID.for_state(state)
        assert rig.s.state is state


@pytest.mark.parametrize("fbcls", [MC_PhasingAbsolute, MC_PhasingRelative])
@pytest.mark.parametrize("state", STATES, ids=lambda s: s.name)
def test_phasing_in_every_state(state: AxisState, fbcls: type) -> None:
    rig = Rig(slave=SLAVE).powered()
    rig.add(MC_MoveVelocity(axis=rig.m, velocity=0.5, execute=True))
    _enter(rig, state)
    fb = rig.add(fbcls(master=rig.m, slave=rig.s, phase_shift=0.05, execute=True))
    rig.run(2)
    if state is S.SYNCHRONIZED_MOTION:  # a coupling runs: the state never changes
        assert fb.busy and not fb.error
    else:
        assert fb.error and fb.error_id is ErrorID.NOT_SYNCHRONIZED
    assert rig.s.state is state


def test_gear_out_in_a_group_member_sync_state_needs_a_coupling() -> None:
    """SynchronizedMotion without a coupling (the GearInPos not started yet is one) -> the
    coupling FB is aborted; a GearOut without any coupling -> NOT_SYNCHRONIZED."""
    rig = Rig(slave=SLAVE).powered()
    out = rig.add(MC_GearOut(slave=rig.s))
    rig.s.state = S.SYNCHRONIZED_MOTION  # as a moving group member would be
    out.execute = True
    rig.rt._hooks.clear()  # (the forced state is not a diagram transition)
    rig.run(1)
    assert out.error and out.error_id is ErrorID.NOT_SYNCHRONIZED


class SyncMachine(RuleBasedStateMachine):
    """Random gear / cam / phasing / moves / stops / power on a master and a slave."""

    def __init__(self) -> None:
        super().__init__()
        self.rig = Rig(slave=SLAVE).powered()
        self.fbs: list[Any] = []

    def _pulse(self, fb: Any) -> None:
        self.rig.add(fb)
        fb.execute = True
        self.fbs.append(fb)
        self.rig.run(1)
        fb.execute = False

    @rule(v=st.sampled_from([-1.0, 0.0, 0.6, 1.5]))
    def master_velocity(self, v: float) -> None:
        self._pulse(MC_MoveVelocity(axis=self.rig.m, velocity=v, acceleration=2.0))

    @rule(p=st.sampled_from([-1.0, 0.5, 2.0]))
    def master_move(self, p: float) -> None:
        self._pulse(MC_MoveAbsolute(axis=self.rig.m, position=p, velocity=1.0))

    @rule(num=st.integers(-3, 3), den=st.integers(1, 2), jerk=st.sampled_from([0.0, 80.0]))
    def gear_in(self, num: int, den: int, jerk: float) -> None:
        g = MC_GearIn(
            master=self.rig.m, slave=self.rig.s, ratio_numerator=num, ratio_denominator=den
        )
        g.jerk = jerk
        self._pulse(g)

    @rule(ms=st.sampled_from([0.5, 1.0]), rel=st.booleans())
    def cam_in(self, ms: float, rel: bool) -> None:
        cid = CamTableID(TABLE, master_absolute=not rel, slave_absolute=not rel)
        self._pulse(
            MC_CamIn(master=self.rig.m, slave=self.rig.s, cam_table_id=cid, master_scaling=ms)
        )

    @rule(sync=st.sampled_from([-1.0, 0.0, 2.0]), dist=st.sampled_from([0.0, 0.5]))
    def gear_in_pos(self, sync: float, dist: float) -> None:
        self._pulse(
            MC_GearInPos(
                master=self.rig.m,
                slave=self.rig.s,
                master_sync_position=sync,
                slave_sync_position=0.3,
                master_start_distance=dist,
            )
        )

    @rule()
    def gear_out(self) -> None:
        self._pulse(MC_GearOut(slave=self.rig.s))

    @rule()
    def cam_out(self) -> None:
        self._pulse(MC_CamOut(slave=self.rig.s))

    @rule(shift=st.sampled_from([-0.2, 0.1]), rel=st.booleans())
    def phasing(self, shift: float, rel: bool) -> None:
        cls = MC_PhasingRelative if rel else MC_PhasingAbsolute
        self._pulse(cls(master=self.rig.m, slave=self.rig.s, phase_shift=shift))

    @rule(p=st.sampled_from([-0.5, 1.0]))
    def slave_move(self, p: float) -> None:
        self._pulse(MC_MoveAbsolute(axis=self.rig.s, position=p, velocity=1.0))

    @rule(who=st.sampled_from(["m", "s"]))
    def stop(self, who: str) -> None:
        self._pulse(MC_Stop(axis=self.rig.rt.axes[who]))

    @rule(who=st.sampled_from([0, 1]))
    def power_cycle(self, who: int) -> None:
        p = self.rig.powers[who]
        p.enable = False
        self.rig.run(2)
        p.enable = True
        self.rig.run(2)

    @rule()
    def reset(self) -> None:
        for ax in self.rig.rt.axes.values():
            if ax.state is S.ERROR_STOP:
                self._pulse(MC_Reset(axis=ax))

    @rule(n=st.sampled_from([10, 100, 400]))
    def run(self, n: int) -> None:
        self.rig.run(n)

    @invariant()
    def coupled_iff_synchronized(self) -> None:
        s = self.rig.s
        act = s.active
        if act is not None and act.sync and not act.handle.terminal:
            assert s.state is S.SYNCHRONIZED_MOTION
        for fb in self.fbs:
            if getattr(fb, "in_gear", False) or getattr(fb, "in_sync", False):
                assert fb.busy and fb.active and not fb.error  # (the state: one scan later)
            if fb.error and fb.error_id is ErrorID.INTERNAL_ERROR:
                raise AssertionError(fb.error_text)
        assert s.axis_error not in (ErrorID.INTERNAL_ERROR, ErrorID.PLANNING_FAILED), (
            s.axis_error_reason
        )
        assert math.isfinite(s.p) and math.isfinite(self.rig.m.p)


SyncMachine.TestCase.settings = settings(
    max_examples=40,
    stateful_step_count=40,
    deadline=None,
    suppress_health_check=[HealthCheck.too_slow],
    derandomize=True,
)
test_sync_stateful = SyncMachine.TestCase


def _single_axis_commands(rig: Rig) -> dict[str, tuple[Any, AxisState | None]]:
    """The single-axis FBs issued on a coupled slave and the state they lead to (None: the
    state's ErrorID, plcopen.md 1.3)."""
    from motionplc.blocks import (
        MC_Halt,
        MC_Jog,
        MC_MoveAdditive,
        MC_MoveRelative,
        MC_MoveSuperimposed,
    )

    s = rig.s
    return {
        "MC_MoveAbsolute": (MC_MoveAbsolute(axis=s, position=5.0, velocity=1.0), S.DISCRETE_MOTION),
        "MC_MoveRelative": (MC_MoveRelative(axis=s, distance=1.0, velocity=1.0), S.DISCRETE_MOTION),
        "MC_MoveAdditive": (MC_MoveAdditive(axis=s, distance=1.0, velocity=1.0), S.DISCRETE_MOTION),
        "MC_MoveVelocity": (MC_MoveVelocity(axis=s, velocity=0.2), S.CONTINUOUS_MOTION),
        "MC_Halt": (MC_Halt(axis=s), S.DISCRETE_MOTION),
        "MC_Stop": (MC_Stop(axis=s), S.STOPPING),
        "MC_Home": (MC_Home(axis=s), None),
        # a correction on top of the coupling: no state change (plcopen.md 1.3, C8)
        "MC_MoveSuperimposed": (MC_MoveSuperimposed(axis=s, distance=0.01), S.SYNCHRONIZED_MOTION),
        "MC_Jog": (MC_Jog(axis=s, velocity=0.2), S.CONTINUOUS_MOTION),
    }


@pytest.mark.parametrize(
    "fbname",
    [
        "MC_MoveAbsolute",
        "MC_MoveRelative",
        "MC_MoveAdditive",
        "MC_MoveVelocity",
        "MC_Halt",
        "MC_Stop",
        "MC_Home",
        "MC_MoveSuperimposed",
        "MC_Jog",
    ],
)
def test_single_axis_commands_on_a_coupled_slave(fbname: str) -> None:
    """From SynchronizedMotion (T14/T16/T18, plcopen.md 1.3): a move, a velocity, a halt or a
    stop takes the slave out of the coupling (its FB CommandAborted, the master untouched),
    MC_Home is refused with STATE_SYNCHRONIZED_MOTION, a superimposed move rides on the
    coupling (which stays InGear)."""
    rig = Rig(slave=SLAVE).powered()
    rig.add(MC_MoveVelocity(axis=rig.m, velocity=0.5, execute=True))
    g = rig.add(MC_GearIn(master=rig.m, slave=rig.s, execute=True))
    rig.run(1500)
    assert g.in_gear and rig.s.state is S.SYNCHRONIZED_MOTION
    m_state = rig.m.state
    fb, target = _single_axis_commands(rig)[fbname]
    rig.add(fb)
    if fbname == "MC_Jog":
        fb.jog_forward = True
    else:
        fb.execute = True
    rig.run(2)
    if target is None:
        assert fb.error and fb.error_id is ErrorID.STATE_SYNCHRONIZED_MOTION
        assert rig.s.state is S.SYNCHRONIZED_MOTION and g.in_gear
    else:
        assert not fb.error, fb.error_text
        assert rig.s.state is target
        if target is S.SYNCHRONIZED_MOTION:
            assert g.in_gear and not g.command_aborted
        else:
            assert g.command_aborted and not g.in_gear
    assert rig.m.state is m_state


def test_cam_ramp_replanned_when_the_master_speeds_up() -> None:
    """Found by a soak of the stateful test (400 random examples): a CamIn catching up while
    its master changes velocity. The ramp's headroom is reserved for the master's motion at
    engagement; the law's acceleration and jerk grow with the master's speed, so the ramp is
    planned again (for 1.25x the master's motion) when the master leaves that envelope -- before,
    ramp + law stepped the slave's acceleration 0.01 % beyond j_max dt (the invariant checker's
    "acceleration jump", raised by every cycle of this rig)."""
    st = SyncMachine()
    st.master_velocity(v=-1.0)
    st.run(n=10)
    st.cam_in(ms=0.5, rel=False)
    st.run(n=100)
    st.stop(who="m")
    st.master_velocity(v=-1.0)
    st.cam_in(ms=1.0, rel=False)
    st.run(n=400)
    st.cam_out()
    st.cam_in(ms=0.5, rel=False)
    st.master_velocity(v=0.6)
    st.run(n=600)
    assert st.rig.s.state is S.SYNCHRONIZED_MOTION
    st.teardown()
