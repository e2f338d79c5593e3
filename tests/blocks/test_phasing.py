"""MC_PhasingAbsolute / MC_PhasingRelative and MC_GearInPos (invariants checked every cycle)."""

from __future__ import annotations

import numpy as np
import pytest

from motionplc.blocks import AxisState, ErrorID, MC_MoveVelocity, MC_Stop, SyncMode
from motionplc.blocks.sync import (
    MC_GearIn,
    MC_GearInPos,
    MC_PhasingAbsolute,
    MC_PhasingRelative,
)
from tests.blocks.sync_rig import Rig, jumps

S = AxisState


def _geared(ratio: int = 1) -> tuple[Rig, MC_GearIn]:
    rig = Rig().powered()
    rig.add(MC_MoveVelocity(axis=rig.m, velocity=1.0, execute=True))
    g = rig.add(MC_GearIn(master=rig.m, slave=rig.s, ratio_numerator=ratio, execute=True))
    rig.run(1500)
    assert g.in_gear
    return rig, g


def test_phasing_absolute_shifts_the_master_the_slave_sees() -> None:
    rig, g = _geared(2)
    c = rig.s.p - 2.0 * rig.m.p
    ph = rig.add(
        MC_PhasingAbsolute(master=rig.m, slave=rig.s, phase_shift=0.2, velocity=0.5, execute=True)
    )
    rig.run(3)
    assert ph.busy and ph.active and rig.s.state is S.SYNCHRONIZED_MOTION
    assert 0.0 < ph.absolute_phase_shift < 0.2
    rig.run(2000)
    assert ph.done and ph.absolute_phase_shift == 0.2 and g.in_gear
    assert rig.s.p == pytest.approx(c + 2.0 * (rig.m.p + 0.2), abs=1e-9)
    # the shift ran at most at its Velocity: the slave at most 2 x (1 + 0.5)
    assert np.max(np.abs(rig.trace()[:, 4])) <= 2.0 * 1.5 * (1 + 1e-9)
    assert max(jumps(rig)) <= 1.0 + 1e-6


def test_phasing_relative_accumulates() -> None:
    rig, g = _geared()
    c = rig.s.p - rig.m.p
    p1 = rig.add(MC_PhasingRelative(master=rig.m, slave=rig.s, phase_shift=0.1, execute=True))
    rig.run(500)
    assert p1.done and p1.covered_phase_shift == pytest.approx(0.1)
    p2 = rig.add(MC_PhasingRelative(master=rig.m, slave=rig.s, phase_shift=-0.3, execute=True))
    rig.run(1000)
    assert p2.done and p2.absolute_phase_shift == pytest.approx(-0.2)
    assert p2.covered_phase_shift == pytest.approx(-0.3)
    assert rig.s.p == pytest.approx(c + rig.m.p - 0.2, abs=1e-9)


def test_phasing_needs_a_coupling() -> None:
    rig = Rig().powered()
    ph = rig.add(MC_PhasingAbsolute(master=rig.m, slave=rig.s, phase_shift=0.1, execute=True))
    rig.run(1)
    assert ph.error and ph.error_id is ErrorID.NOT_SYNCHRONIZED
    assert rig.s.state is S.STANDSTILL


def test_phasing_aborted_with_its_coupling() -> None:
    rig, g = _geared()
    ph = rig.add(
        MC_PhasingAbsolute(master=rig.m, slave=rig.s, phase_shift=1.0, velocity=0.1, execute=True)
    )
    rig.run(100)
    assert ph.busy
    rig.add(MC_Stop(axis=rig.s, execute=True))
    rig.run(2)
    assert g.command_aborted and ph.command_aborted


def test_gear_in_pos_waits_for_the_start_point_then_locks() -> None:
    rig = Rig().powered()
    rig.add(MC_MoveVelocity(axis=rig.m, velocity=1.0, execute=True))
    gp = rig.add(
        MC_GearInPos(
            master=rig.m,
            slave=rig.s,
            ratio_numerator=3,
            ratio_denominator=2,
            master_sync_position=2.0,
            slave_sync_position=1.0,
            master_start_distance=0.5,
            execute=True,
        )
    )
    rig.watch = {"start": (gp, "start_sync"), "in_sync": (gp, "in_sync")}
    rig.run(3000)
    assert gp.in_sync and not gp.start_sync
    tr = rig.trace()
    start = int(np.argmax(rig.flag("start")))
    assert tr[start - 1, 0] >= 1.5 - 1e-3 and tr[start - 3, 0] < 1.5  # the start point
    assert np.all(tr[: start - 2, 3] == 0.0)  # the slave stood still until then
    sync = rig.flag("in_sync")
    law = 1.0 + 1.5 * (tr[sync, 0] - 2.0)
    assert float(np.max(np.abs(tr[sync, 3] - law))) <= 1e-12 * (1 + np.max(np.abs(law)))
    assert max(jumps(rig)) <= 1.0 + 1e-6


def test_gear_in_pos_previous_motion_goes_on() -> None:
    rig = Rig().powered()
    rig.add(MC_MoveVelocity(axis=rig.m, velocity=1.0, execute=True))
    sv = rig.add(MC_MoveVelocity(axis=rig.s, velocity=0.4, execute=True))
    rig.run(500)
    gp = rig.add(
        MC_GearInPos(
            master=rig.m,
            slave=rig.s,
            master_sync_position=3.0,
            slave_sync_position=2.0,
            master_start_distance=1.0,
            execute=True,
        )
    )
    rig.run(2)
    assert sv.command_aborted and gp.busy and not gp.start_sync
    assert rig.s.state is S.SYNCHRONIZED_MOTION
    rig.run(1000)
    assert rig.s.v == pytest.approx(0.4) and not gp.start_sync  # still the old velocity
    rig.run(3000)
    assert gp.in_sync and rig.s.p == pytest.approx(2.0 + (rig.m.p - 3.0), abs=1e-12)


def test_gear_in_pos_sync_mode_that_cannot_reach() -> None:
    rig = Rig().powered()
    rig.add(MC_MoveVelocity(axis=rig.m, velocity=1.0, execute=True))
    rig.run(200)
    # the slave stands far ahead of the law: catching up (never slower) cannot reach it
    gp = rig.add(
        MC_GearInPos(
            master=rig.m,
            slave=rig.s,
            master_sync_position=0.0,
            slave_sync_position=-5.0,
            sync_mode=SyncMode.CATCH_UP,
            execute=True,
        )
    )
    rig.run(1000)
    assert gp.error and gp.error_id is ErrorID.INVALID_SYNC_MODE
    assert rig.s.state is S.STANDSTILL


@pytest.mark.parametrize("mode", [SyncMode.SHORTEST, SyncMode.CATCH_UP, SyncMode.SLOW_DOWN])
def test_gear_in_pos_sync_modes(mode: SyncMode) -> None:
    rig = Rig().powered()
    rig.add(MC_MoveVelocity(axis=rig.m, velocity=1.0, execute=True))
    rig.run(200)
    # slave behind the law for CATCH_UP, ahead for SLOW_DOWN
    slave_sync = {SyncMode.SHORTEST: 0.3, SyncMode.CATCH_UP: 0.5, SyncMode.SLOW_DOWN: -0.5}[mode]
    gp = rig.add(
        MC_GearInPos(
            master=rig.m,
            slave=rig.s,
            master_sync_position=0.0,
            slave_sync_position=slave_sync,
            sync_mode=mode,
            execute=True,
        )
    )
    k0 = len(rig.rows)
    rig.run(3000)
    assert gp.in_sync, gp.error_text
    tr = rig.trace()[k0:]
    rel_v = tr[:, 4] - tr[:, 1]  # slave velocity minus the law's (ratio 1)
    # from the slave at rest: once its start velocity is braked, one-signed
    if mode is SyncMode.CATCH_UP:
        first = int(np.argmax(rel_v >= 0.0))
        assert first < 200 and np.min(rel_v[first:]) >= -1e-9
    elif mode is SyncMode.SLOW_DOWN:
        first = int(np.argmax(rel_v <= 0.0))
        assert np.max(rel_v[first:]) <= 1e-9
    assert rig.s.p == pytest.approx(slave_sync + rig.m.p, abs=1e-12)


def test_gear_in_pos_start_point_is_sign_aware() -> None:
    """A master moving negatively starts the catch-up at master_sync + start distance."""
    rig = Rig().powered()
    rig.add(MC_MoveVelocity(axis=rig.m, velocity=-1.0, execute=True))
    gp = rig.add(
        MC_GearInPos(
            master=rig.m,
            slave=rig.s,
            ratio_numerator=-1,
            master_sync_position=-2.0,
            slave_sync_position=0.5,
            master_start_distance=0.5,
            execute=True,
        )
    )
    rig.watch = {"start": (gp, "start_sync")}
    rig.run(4000)
    assert gp.in_sync and rig.s.p == pytest.approx(0.5 - (rig.m.p + 2.0), abs=1e-12)
    tr = rig.trace()
    start = int(np.argmax(rig.flag("start")))
    assert -1.5 - 3e-3 <= tr[start - 1, 0] <= -1.5 + 1e-9


def test_phasing_dynamics_are_the_masters() -> None:
    """The shift's Velocity is a velocity of the master (its units, its range): with a slave
    slower than the master (ratio 1/4), a shift velocity above the slave's v_max but within the
    master's is accepted; one above the master's v_max is refused with INVALID_VELOCITY."""
    rig = Rig(slave={"v_max": 1.0, "a_max": 24.0, "j_max": 300.0}).powered()
    rig.add(MC_MoveVelocity(axis=rig.m, velocity=1.0, execute=True))
    g = rig.add(
        MC_GearIn(master=rig.m, slave=rig.s, ratio_numerator=1, ratio_denominator=4, execute=True)
    )
    rig.run(1500)
    assert g.in_gear
    ok = rig.add(
        MC_PhasingRelative(master=rig.m, slave=rig.s, phase_shift=0.5, velocity=1.5, execute=True)
    )
    rig.run(2000)
    assert ok.done and not ok.error and g.in_gear
    bad = rig.add(
        MC_PhasingRelative(master=rig.m, slave=rig.s, phase_shift=0.5, velocity=2.5, execute=True)
    )
    rig.run(1)
    assert bad.error and bad.error_id is ErrorID.INVALID_VELOCITY
    assert "(0, 2]" in bad.error_text  # the master's range
