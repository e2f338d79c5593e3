"""The random FB sequences of ``test_stateful`` with MC_MoveSuperimposed, MC_HaltSuperimposed
and MC_Jog mixed in; the runtime checks the invariants A, B, C every cycle (the set values --
the SUM of underlying and superimposed motion -- within the axis' v / a limits and continuous,
the FB output rules, the state diagram)."""

from __future__ import annotations

import math

from hypothesis import HealthCheck, settings
from hypothesis import strategies as st
from hypothesis.stateful import initialize, invariant, rule

from motionplc.blocks import (
    MC_Halt,
    MC_Home,
    MC_MoveAbsolute,
    MC_MoveAdditive,
    MC_MoveRelative,
    MC_MoveVelocity,
    MC_ReadStatus,
    MC_Reset,
    MC_SetOverride,
    MC_SetPosition,
    MC_Stop,
)
from motionplc.blocks.enums import JogMode
from motionplc.blocks.jog import MC_Jog
from motionplc.blocks.superimposed import MC_HaltSuperimposed, MC_MoveSuperimposed
from tests.blocks.test_stateful import AxisMachine
from tests.runtime.helpers import Bench

frac = st.floats(0.05, 1.0)


class SuperimposedMachine(AxisMachine):
    @initialize(
        v_max=st.sampled_from([1.0, 50.0]),
        a_max=st.sampled_from([2.0, 500.0]),
        j_max=st.sampled_from([math.inf, 1e3]),
        modulo=st.sampled_from([None, None, 360.0]),
        limits=st.booleans(),
    )
    def setup(  # type: ignore[override]
        self, v_max: float, a_max: float, j_max: float, modulo: float | None, limits: bool
    ) -> None:
        sw = (
            {}
            if modulo or not limits
            else {"sw_limit_pos": 30 * v_max, "sw_limit_neg": -30 * v_max}
        )
        b = Bench(
            v_max=v_max,
            a_max=a_max,
            j_max=j_max,
            modulo=modulo,
            queue_depth=3,
            home_switch=5.0,
            **sw,
        )
        self.bench = b
        self.vm, self.am = v_max, a_max
        self.modulo = modulo
        self.moves = {
            "abs": b.add(MC_MoveAbsolute()),
            "rel": b.add(MC_MoveRelative()),
            "add": b.add(MC_MoveAdditive()),
            "vel": b.add(MC_MoveVelocity()),
            "halt": b.add(MC_Halt()),
            "abs2": b.add(MC_MoveAbsolute()),
        }
        self.stop = b.add(MC_Stop())
        self.home = b.add(MC_Home())
        self.reset = b.add(MC_Reset())
        self.setpos = b.add(MC_SetPosition())
        self.override = b.add(MC_SetOverride())
        self.status = b.add(MC_ReadStatus(enable=True))
        self.sups = [b.add(MC_MoveSuperimposed()), b.add(MC_MoveSuperimposed())]
        self.hsup = b.add(MC_HaltSuperimposed())
        self.jog = b.add(MC_Jog())
        b.run(2)

    @rule(
        which=st.sampled_from([0, 1]),
        d=st.floats(-1.0, 1.0),
        vd=st.sampled_from([0.0, 0.2, 1.0]),
        acc=st.sampled_from([0.0, 0.3]),
        cu=st.booleans(),
        hold=st.booleans(),
    )
    def issue_superimposed(
        self, which: int, d: float, vd: float, acc: float, cu: bool, hold: bool
    ) -> None:
        fb = self.sups[which]
        fb.distance = d * 5.0 * self.vm
        fb.velocity_diff = vd * self.vm
        fb.acceleration = acc * self.am
        fb.continuous_update = cu
        self._edge(fb, hold)

    @rule(which=st.sampled_from([0, 1]), d=st.floats(-1.0, 1.0))
    def update_superimposed(self, which: int, d: float) -> None:
        self.sups[which].distance = d * 5.0 * self.vm

    @rule(dec=st.sampled_from([0.0, 0.5]), hold=st.booleans())
    def halt_superimposed(self, dec: float, hold: bool) -> None:
        self.hsup.deceleration = dec * self.am
        self._edge(self.hsup, hold)

    @rule(
        fwd=st.booleans(),
        bwd=st.booleans(),
        mode=st.sampled_from(list(JogMode)),
        step=frac,
        v=frac,
    )
    def jog_buttons(self, fwd: bool, bwd: bool, mode: JogMode, step: float, v: float) -> None:
        j = self.jog
        if not (j.jog_forward or j.jog_backward):
            j.mode = mode
            j.position = step * (0.25 * self.modulo if self.modulo else self.vm)
            j.velocity = v * self.vm
        j.jog_forward, j.jog_backward = fwd, bwd
        self.bench.run(1)

    @invariant()
    def layer_consistent(self) -> None:
        x = self.bench.x
        sup = x.sup
        if sup is not None:
            assert not sup.lifted  # between cycles the set values are the sum
            assert math.isfinite(sup.sp) and math.isfinite(sup.sv)


SuperimposedMachine.TestCase.settings = settings(
    max_examples=40,
    stateful_step_count=60,
    deadline=None,
    derandomize=True,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large],
)
TestSuperimposedMachine = SuperimposedMachine.TestCase
