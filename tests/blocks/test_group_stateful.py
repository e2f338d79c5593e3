"""Random sequences of group FBs on the gantry group (hypothesis RuleBasedStateMachine,
derandomized by the suite's conftest).

Rules issue moves (MC_MoveLinearAbsolute x 3, MC_MoveCircularAbsolute, MC_MoveDirectAbsolute,
MC_MovePassingPoints) with random targets in and around the workspace (the members have
software limits just outside it), random BufferMode x TransitionMode x TransitionParameter
(valid and invalid), Velocity / Acceleration / Jerk, Execute pulses or held, re-triggers; halts,
stops (held, released), interrupts and continues, MC_GroupReset / Enable / Disable, override,
MC_RemoveAxisFromGroup / MC_AddAxisToGroup (GroupDisabled; refused while the disable brake
runs), member drive faults, member resets and power, and runs of a few cycles.

Checked every cycle: the runtime's invariants (FB output rules of group and axis FBs; member
state changes along the diagram, continuity of set positions, velocities and accelerations,
v and a within limits) and ``group_state_rig.check_group_consistency`` (group state vs member
states, |v|, |a|, |j| of every member within its limits); when the group comes to rest with
nothing queued or interrupted, the set position is exactly the target of the last accepted
move if that move is Done. After every step: nothing failed inside the kernel or an FB
(INTERNAL_ERROR, a group error other than a member's), members fault only when a fault was
injected, and no move FB stays Busy while nothing is running, queued or interrupted.

No known defect is kept out (those found are fixed; their tests in test_group_state.py).

80 examples x up to 50 steps, about 8 s.
"""

from __future__ import annotations

import math
from typing import Any

from hypothesis import HealthCheck, settings
from hypothesis import strategies as st
from hypothesis.stateful import RuleBasedStateMachine, initialize, invariant, precondition, rule

from motionplc.blocks.enums import (
    AxisState,
    BufferMode,
    CircMode,
    ErrorID,
    GroupState,
    PathChoice,
)
from motionplc.blocks.group_blocks import (
    MC_AddAxisToGroup,
    MC_GroupContinue,
    MC_GroupDisable,
    MC_GroupEnable,
    MC_GroupHalt,
    MC_GroupInterrupt,
    MC_GroupReadStatus,
    MC_GroupReset,
    MC_GroupSetOverride,
    MC_GroupStop,
    MC_MoveCircularAbsolute,
    MC_MoveDirectAbsolute,
    MC_MoveLinearAbsolute,
    MC_MovePassingPoints,
    MC_RemoveAxisFromGroup,
)
from motionplc.blocks.motion_queue import Status
from tests.blocks.group_rig import GANTRY
from tests.blocks.group_state_rig import StateBench

# workspace [0, 0.3] x [0, 0.2] x [-0.02, 0.02]; software limits 1 cm outside it, targets
# drawn up to 2 cm outside (some refused with TARGET_OUTSIDE_SW_LIMITS)
SW = {"x": (-0.01, 0.31), "y": (-0.01, 0.21), "z": (-0.03, 0.03)}
AXES = {n: {**GANTRY[n], "sw_limit_neg": lo, "sw_limit_pos": hi} for n, (lo, hi) in SW.items()}
# on a 1 mm grid: a move is either of zero length exactly or at least 1 mm long (a move
# shorter than the kernel's 1e-12 relative zero length is Done where the group stands)
MM = 0.001
point = st.tuples(
    st.integers(-20, 320).map(lambda k: k * MM),
    st.integers(-20, 220).map(lambda k: k * MM),
    st.sampled_from([0.0, 0.0, -0.02, 0.015]),
)
MOVE_FBS = ("lin0", "lin1", "lin2", "circ", "direct", "pass")
INVALID_TM = 9
B = BufferMode
# (BufferMode, TransitionMode, TransitionParameter): mostly valid combinations, and any
# combination (valid or not: TM other than TM_NONE with ABORTING / BUFFERED, parameter 0 where
# it must be > 0, a negative parameter, TransitionMode 9)
VALID_TRANSITIONS = [
    (B.ABORTING, 0, 0.0),
    (B.BUFFERED, 0, 0.0),
    (B.BLENDING_LOW, 0, 0.0),
    (B.BLENDING_LOW, 4, 0.005),
    (B.BLENDING_PREVIOUS, 4, 0.0),
    (B.BLENDING_NEXT, 3, 0.02),
    (B.BLENDING_HIGH, 2, 0.2),
    (B.BLENDING_LOW, 1, 0.1),
]
Point = tuple[float, float, float]
Trans = tuple[BufferMode, int, float]
Dynamics = tuple[float, float, float]  # Velocity, Acceleration (= Deceleration), Jerk
dynamics = st.tuples(
    st.sampled_from([0.05, 0.2, 0.5, 0.5, 1.0, 3.0, 0.0]),
    st.sampled_from([0.0, 0.0, 0.5, 2.0]),
    st.sampled_from([0.0, 0.0, 5.0]),
)
transition = st.one_of(
    st.sampled_from(VALID_TRANSITIONS),
    st.sampled_from(VALID_TRANSITIONS),
    st.tuples(
        st.sampled_from(list(B)),
        st.sampled_from([0, 1, 2, 3, 4, INVALID_TM]),
        st.sampled_from([0.0, 0.001, 0.005, 0.02, 0.1, 0.5, -0.1]),
    ),
)


class GroupMachine(RuleBasedStateMachine):
    bench: StateBench

    @initialize(depth=st.sampled_from([2, 8]))
    def setup(self, depth: int) -> None:
        b = StateBench(axes=AXES, queue_depth=depth)
        self.bench = b
        self.g = b.g
        self.moves: dict[str, Any] = {
            "lin0": b.add(MC_MoveLinearAbsolute()),
            "lin1": b.add(MC_MoveLinearAbsolute()),
            "lin2": b.add(MC_MoveLinearAbsolute()),
            "circ": b.add(MC_MoveCircularAbsolute()),
            "direct": b.add(MC_MoveDirectAbsolute()),
            "pass": b.add(MC_MovePassingPoints()),
        }
        self.halt = b.add(MC_GroupHalt())
        self.interrupt = b.add(MC_GroupInterrupt())
        self.cont = b.add(MC_GroupContinue())
        self.stop = b.add(MC_GroupStop())
        self.enable = b.add(MC_GroupEnable())
        self.disable = b.add(MC_GroupDisable())
        self.reset = b.add(MC_GroupReset())
        self.override = b.add(MC_GroupSetOverride())
        self.remove = b.add(MC_RemoveAxisFromGroup(axis=b.rt.axes["z"]))
        self.add_axis = b.add(MC_AddAxisToGroup(axis=b.rt.axes["z"]))
        self.status = b.add(MC_GroupReadStatus(enable=True))
        # the last accepted move (its command's handle and absolute end point); None after
        # anything that ends motion elsewhere (halt, stop, faults, power, disable)
        self.last: tuple[Any, tuple[float, ...]] | None = None
        self.faults: set[str] = set()
        self.rest_checks = 0
        b.rt.add_cycle_hook(self._at_rest)
        b.enabled()

    # -- helpers ----------------------------------------------------------------------------
    def _edge(self, fb: Any, hold: bool) -> bool:
        """A rising edge of Execute (after one scan with Execute FALSE); True if the command
        was accepted (busy or done in its first scan)."""
        b = self.bench
        fb.execute = False  # a scan with Execute FALSE (a pulse's falling edge may be unseen)
        b.run(1)
        fb.execute = True
        b.run(1)
        accepted = not fb.error
        if not hold:
            fb.execute = False
        return accepted

    def _at_rest(self, rt: Any, cycle: int) -> None:
        """Cycle hook: at rest with nothing queued or interrupted, the last accepted move, if
        Done, ended exactly at its target."""
        g = self.g
        if self.last is None or g.moving or not g.mq.idle() or g._interrupted:
            return
        handle, target = self.last
        if handle.status is Status.DONE:
            self.rest_checks += 1
            assert g.position() == target, (cycle, g.position(), target)

    def _ends_elsewhere(self) -> None:
        self.last = None

    # -- moves ------------------------------------------------------------------------------
    def _move(
        self, fb: Any, end: tuple[float, ...], dyn: Dynamics, trans: Trans, hold: bool
    ) -> None:
        fb.velocity, fb.acceleration, fb.jerk = dyn
        fb.deceleration = dyn[1]
        fb.buffer_mode, fb.transition_mode, fb.transition_parameter = trans
        if self._edge(fb, hold):
            self.last = (fb._handle, tuple(float(x) for x in end))

    @rule(
        which=st.sampled_from(["lin0", "lin1", "lin2", "direct"]),
        end=point,
        dyn=dynamics,
        trans=transition,
        hold=st.booleans(),
    )
    def move_to(self, which: str, end: Point, dyn: Dynamics, trans: Trans, hold: bool) -> None:
        fb = self.moves[which]
        fb.position = end
        self._move(fb, end, dyn, trans, hold)

    @rule(ends=st.lists(point, min_size=2, max_size=3), dyn=dynamics, trans=transition)
    def queue_lines(self, ends: list[Point], dyn: Dynamics, trans: Trans) -> None:
        """Lines issued in consecutive scans with one BufferMode x TransitionMode (a corner
        chain); the first one Aborting."""
        for k, end in enumerate(ends):
            fb = self.moves[f"lin{k}"]
            fb.position = end
            self._move(fb, end, dyn, trans if k else (B.ABORTING, 0, 0.0), False)

    @rule(
        end=point,
        aux=point,
        circ=st.sampled_from([CircMode.BORDER, CircMode.BORDER, CircMode.CENTER, CircMode.RADIUS]),
        radius=st.integers(-300, 300).map(lambda k: k * MM),
        cw=st.booleans(),
        dyn=dynamics,
        trans=transition,
        hold=st.booleans(),
    )
    def move_circle(
        self,
        end: Point,
        aux: Point,
        circ: CircMode,
        radius: float,
        cw: bool,
        dyn: Dynamics,
        trans: Trans,
        hold: bool,
    ) -> None:
        fb = self.moves["circ"]
        fb.circ_mode = circ
        fb.aux_point = (radius,) if circ is CircMode.RADIUS else aux
        fb.end_point = end
        fb.path_choice = PathChoice.CLOCKWISE if cw else PathChoice.COUNTER_CLOCKWISE
        self._move(fb, end, dyn, trans, hold)

    @rule(
        points=st.lists(point, min_size=1, max_size=3),
        dyn=dynamics,
        trans=transition,
        hold=st.booleans(),
    )
    def move_passing(self, points: list[Point], dyn: Dynamics, trans: Trans, hold: bool) -> None:
        fb = self.moves["pass"]
        fb.points = points
        self._move(fb, points[-1], dyn, trans, hold)

    # -- stops ------------------------------------------------------------------------------
    @rule(dec=st.sampled_from([0.0, 0.5, 5.0]), hold=st.booleans())
    def issue_halt(self, dec: float, hold: bool) -> None:
        self.halt.deceleration = dec
        if self._edge(self.halt, hold):
            self._ends_elsewhere()

    @rule(dec=st.sampled_from([0.0, 0.5, 5.0]), hold=st.booleans())
    def issue_interrupt(self, dec: float, hold: bool) -> None:
        self.interrupt.deceleration = dec
        self._edge(self.interrupt, hold)

    @rule(anyway=st.integers(0, 3))
    def issue_continue(self, anyway: int) -> None:
        if self.g._interrupted or not anyway:  # mostly when there is something to resume
            self._edge(self.cont, False)

    @rule(dec=st.sampled_from([0.0, 0.5, 5.0]), hold=st.booleans())
    def issue_stop(self, dec: float, hold: bool) -> None:
        self.stop.deceleration = dec
        if self._edge(self.stop, hold):
            self._ends_elsewhere()

    @rule()
    def release_stop(self) -> None:
        self.stop.execute = False

    # -- administration ---------------------------------------------------------------------
    @rule()
    def group_enable(self) -> None:
        self._edge(self.enable, False)

    @rule(go=st.integers(0, 2))
    def group_disable(self, go: int) -> None:
        if not go and self._edge(self.disable, False):
            self._ends_elsewhere()

    @rule()
    def group_reset(self) -> None:
        self._edge(self.reset, False)

    @rule(f=st.sampled_from([1.0, 0.5, 0.2, 0.0, 2.0]), on=st.booleans())
    def set_override(self, f: float, on: bool) -> None:
        self.override.vel_factor = f
        self.override.enable = on

    @precondition(lambda self: self.g.state is GroupState.GROUP_DISABLED)
    @rule()
    def regroup(self) -> None:
        """MC_RemoveAxisFromGroup z, then MC_AddAxisToGroup z at its place (GroupDisabled;
        refused while the group still brakes after MC_GroupDisable)."""
        z = self.bench.rt.axes["z"]
        if self.g.moving:
            if self.g.path_velocity > 0.01:  # the brake surely lasts beyond the next 2 scans
                assert not self._edge(self.remove, False) and z.group is self.g
            return
        assert self._edge(self.remove, False) and z.group is None
        assert self.g.axis_names == ("x", "y")
        self.add_axis.index = 2
        assert self._edge(self.add_axis, False) and z.group is self.g
        assert self.g.axis_names == ("x", "y", "z")

    # -- members ----------------------------------------------------------------------------
    @rule(name=st.sampled_from(["x", "y", "z"]), go=st.integers(0, 2))
    def member_fault(self, name: str, go: int) -> None:
        ax = self.bench.rt.axes[name]
        if not go and ax.state is not AxisState.ERROR_STOP:
            ax.raise_axis_error("DRIVE_FAULT", f"test: injected fault of {name}")
            self.faults.add(name)
            self._ends_elsewhere()

    @rule(name=st.sampled_from(["x", "y", "z"]))
    def member_reset(self, name: str) -> None:
        if self._edge(self.bench.resets[name], False):
            self.bench.run(2)
            if self.bench.rt.axes[name].state is not AxisState.ERROR_STOP:
                self.faults.discard(name)

    @rule(name=st.sampled_from(["x", "y", "z"]), off=st.integers(0, 2))
    def member_power(self, name: str, off: int) -> None:
        on = bool(off)
        self.bench.powers[name].enable = on
        if not on:
            self._ends_elsewhere()

    @precondition(lambda self: not self.g.moving)
    @rule()
    def recover(self) -> None:
        """What an operator does: power on, reset the faulted members, MC_GroupReset,
        release the stop, MC_GroupEnable."""
        b = self.bench
        for p in b.powers.values():
            p.enable = True
        b.run(2)
        for name in sorted(self.faults):
            b.reset_axis(name)
            self.faults.discard(name)
        self.stop.execute = False
        self._edge(self.reset, False)
        self._edge(self.enable, False)

    # -- time -------------------------------------------------------------------------------
    @rule(n=st.integers(1, 30))
    def run(self, n: int) -> None:
        self.bench.run(n)

    @rule()
    def run_to_rest(self) -> None:
        g = self.g
        self.bench.rt.run_until(lambda: not g.moving, max_seconds=2.0)
        self.bench.run(2)

    # -- invariants after every step ---------------------------------------------------------
    @invariant()
    def nothing_failed_inside(self) -> None:
        b = self.bench
        g = self.g
        assert g.error_id in (ErrorID.OK, ErrorID.AXIS_ERROR_STOP), (g.error_id, g.error_reason)
        for fb in g.fbs:
            assert isinstance(fb.error_id, ErrorID)
            assert fb.error_id is not ErrorID.INTERNAL_ERROR, (fb.name, fb.error_text)
        for ax in g.axes:
            assert math.isfinite(ax.p) and math.isfinite(ax.v) and math.isfinite(ax.a)
            if ax.state is AxisState.ERROR_STOP:  # only the faults the test injected
                assert ax.name in self.faults and ax.axis_error is ErrorID.DRIVE_FAULT, (
                    ax.name,
                    ax.axis_error,
                    ax.axis_error_reason,
                )
        for ax in b.rt.axes.values():
            for lo_hi, x in ((SW.get(ax.name), ax.p),):
                if lo_hi is not None:
                    assert lo_hi[0] - 1e-9 <= x <= lo_hi[1] + 1e-9, (ax.name, x)

    @invariant()
    def no_orphan_busy_move(self) -> None:
        """Nothing running, queued or interrupted: no move FB waits for its command."""
        g = self.g
        if g.moving or not g.mq.idle() or g._interrupted:
            return
        for fb in (*self.moves.values(), self.halt, self.interrupt):
            h = fb._handle
            assert h is None or h.terminal, (fb.name, h.status, self.g.state)


GroupMachine.TestCase.settings = settings(
    max_examples=80,
    stateful_step_count=50,
    deadline=None,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large],
)
TestGroupMachine = GroupMachine.TestCase
