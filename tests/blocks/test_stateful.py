"""Random FB sequences on a random axis; the runtime checks invariants A, B, C, H every cycle.

120 examples x up to 100 rule steps: about 11,500 steps (each runs 1-15 cycles).
"""

from __future__ import annotations

import math

from hypothesis import HealthCheck, settings
from hypothesis import strategies as st
from hypothesis.stateful import RuleBasedStateMachine, initialize, invariant, precondition, rule

from motionplc.blocks import (
    AxisState,
    BufferMode,
    Direction,
    ErrorID,
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
from tests.runtime.helpers import Bench

MOVES = ("abs", "rel", "add", "vel", "halt")
frac = st.floats(0.05, 1.0)


class AxisMachine(RuleBasedStateMachine):
    bench: Bench

    @initialize(
        v_max=st.sampled_from([1.0, 50.0, 400.0]),
        a_max=st.sampled_from([2.0, 500.0, 5000.0]),
        j_max=st.sampled_from([math.inf, 1e3, 1e5]),
        modulo=st.sampled_from([None, None, 360.0]),
    )
    def setup(self, v_max: float, a_max: float, j_max: float, modulo: float | None) -> None:
        b = Bench(
            v_max=v_max, a_max=a_max, j_max=j_max, modulo=modulo, queue_depth=3, home_switch=5.0
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
        b.run(2)

    @rule(
        which=st.sampled_from(["abs", "rel", "add", "vel", "halt", "abs2"]),
        pos=st.floats(-1.0, 1.0),
        v=frac,
        acc=frac,
        dec=frac,
        mode=st.sampled_from(list(BufferMode)),
        direction=st.sampled_from(list(Direction)),
        hold=st.booleans(),
    )
    def issue_move(self, which, pos, v, acc, dec, mode, direction, hold) -> None:
        fb = self.moves[which]
        span = 0.5 * self.modulo if self.modulo else 20.0 * self.vm
        if which in ("abs", "abs2"):
            fb.position = (abs(pos) * self.modulo * 0.999) if self.modulo else pos * span
            fb.direction = direction
        elif which in ("rel", "add"):
            fb.distance = pos * span
        if which == "vel":
            fb.velocity = pos * self.vm
            fb.direction = (
                Direction.NEGATIVE if direction is Direction.NEGATIVE else Direction.POSITIVE
            )
        elif which != "halt":
            fb.velocity = v * self.vm
        if which != "halt":
            fb.acceleration = acc * self.am
        fb.deceleration = dec * self.am
        fb.buffer_mode = mode
        self._edge(fb, hold)

    def _edge(self, fb, hold: bool) -> None:
        if fb.execute:
            fb.execute = False
            self.bench.run(1)
        fb.execute = True
        self.bench.run(1)
        if not hold:
            fb.execute = False

    @rule(hold=st.booleans(), dec=frac)
    def issue_stop(self, hold: bool, dec: float) -> None:
        self.stop.deceleration = dec * self.am
        self._edge(self.stop, hold)

    @rule()
    def release_stop(self) -> None:
        self.stop.execute = False

    @rule(pos=st.floats(0.0, 300.0))
    def issue_home(self, pos: float) -> None:
        self.home.position = pos
        self._edge(self.home, False)

    @rule()
    def issue_reset(self) -> None:
        self._edge(self.reset, False)

    @rule(pos=st.floats(-100.0, 100.0), relative=st.booleans())
    def issue_set_position(self, pos: float, relative: bool) -> None:
        self.setpos.position = pos
        self.setpos.relative = relative
        self._edge(self.setpos, False)

    @rule(on=st.booleans())
    def power(self, on: bool) -> None:
        self.bench.power.enable = on

    @rule(f=st.sampled_from([0.0, 0.3, 1.0, 1.5]), enable=st.booleans())
    def set_override(self, f: float, enable: bool) -> None:
        self.override.vel_factor = f
        self.override.enable = enable

    @precondition(lambda self: self.bench.x.state is not AxisState.ERROR_STOP)
    @rule()
    def drive_fault(self) -> None:
        self.bench.x.drive.inject_fault()

    @rule(n=st.integers(1, 15))
    def run(self, n: int) -> None:
        self.bench.run(n)

    @invariant()
    def sane(self) -> None:
        x = self.bench.x
        assert math.isfinite(x.p) and math.isfinite(x.v) and math.isfinite(x.a)
        for fb in self.bench.fbs:
            assert isinstance(fb.error_id, ErrorID)
        assert len(x.queue) <= 3


AxisMachine.TestCase.settings = settings(
    max_examples=120,
    stateful_step_count=100,
    deadline=None,
    derandomize=True,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large],
)
TestAxisMachine = AxisMachine.TestCase
