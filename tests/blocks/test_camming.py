"""MC_CamIn / MC_CamOut with CamTable (VDI 2143 laws): the slave's trace against the table at
every cycle (checked independently through the master's wrapped modulo position), periodic and
non-periodic tables, EndOfProfile, scaling and offsets, ramp-in, limits at engagement and while
coupled, CamOut (invariants checked every cycle by the rig's runtime)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from motionplc.blocks import AxisState, BufferMode, ErrorID, MC_MoveAbsolute, MC_MoveVelocity
from motionplc.blocks.cam_select import CamTableID
from motionplc.blocks.sync import MC_CamIn, MC_CamOut
from motionplc.planning.cam import CamTable
from tests.blocks.sync_rig import Rig, jumps

S = AxisState
TWO_PI = 2.0 * math.pi
MASTER = {"v_max": 8.0, "a_max": 20.0, "j_max": 200.0, "modulo": TWO_PI}
SLAVE = {"v_max": 1.0, "a_max": 20.0, "j_max": 1000.0}


def table_360() -> CamTable:
    """One master revolution: rise (poly5), dwell, partial return (modified sine), return
    (poly5); periodic."""
    q = math.pi / 2
    return CamTable.from_points(
        [(0.0, 0.0), (q, 0.05), (2 * q, 0.05), (3 * q, 0.02), (4 * q, 0.0)],
        laws=["poly5", "linear", "modified_sine", "poly5"],
        periodic=True,
        name="360",
    )


def expected(tab: CamTable, m_wrapped: np.ndarray, ms: float, mo: float, ss: float, so: float):
    xs = (ms * m_wrapped + mo - tab.master_start) % (tab.master_end - tab.master_start)
    return so + ss * tab.sample(xs + tab.master_start).y


def _rig(**slave: float) -> Rig:
    return Rig(master=MASTER, slave={**SLAVE, **slave}).powered()


def test_periodic_cam_follows_the_table_at_every_cycle() -> None:
    tab = table_360()
    assert tab.c2 and set(tab.segment_laws) >= {"poly5", "modified_sine"}
    rig = _rig()
    cam = rig.add(MC_CamIn(master=rig.m, slave=rig.s, cam_table_id=CamTableID(tab), execute=True))
    rig.watch = {"in_sync": (cam, "in_sync"), "eop": (cam, "end_of_profile")}
    rig.run(2)
    assert cam.in_sync and rig.s.state is S.SYNCHRONIZED_MOTION  # on the table at rest
    mv = rig.add(MC_MoveVelocity(axis=rig.m, velocity=TWO_PI, acceleration=4.0, execute=True))
    rows_m = []
    rig.rt.add_cycle_hook(lambda rt, k: rows_m.append(rig.m.position))
    rig.run(5000)
    assert mv.in_velocity and cam.in_sync
    tr = rig.trace()[-len(rows_m) :]
    ref = expected(tab, np.array(rows_m), 1.0, 0.0, 1.0, 0.0)
    err = float(np.max(np.abs(tr[:, 3] - ref)))
    assert err < 1e-9, err
    revs = (rig.m.p - 0.0) / TWO_PI
    assert rig.flag("eop").sum() == math.floor(revs)  # one pulse per revolution
    assert max(jumps(rig)) <= 1.0 + 1e-6


def test_scaled_and_offset_cam() -> None:
    tab = table_360()
    rig = _rig()
    rig.add(MC_MoveVelocity(axis=rig.m, velocity=2.0, execute=True))
    rig.run(1000)
    cam = rig.add(
        MC_CamIn(
            master=rig.m,
            slave=rig.s,
            cam_table_id=CamTableID(tab),
            master_scaling=2.0,
            master_offset=0.3,
            slave_scaling=-1.5,
            slave_offset=0.25,
            execute=True,
        )
    )
    rig.watch = {"in_sync": (cam, "in_sync")}
    rows_m = []
    rig.rt.add_cycle_hook(lambda rt, k: rows_m.append(rig.m.position))
    rig.run(3000)
    assert cam.in_sync, cam.error_text  # ramped onto the absolute table, then exact
    sync = rig.flag("in_sync")[-len(rows_m) :]
    tr = rig.trace()[-len(rows_m) :]
    ref = expected(tab, np.array(rows_m), 2.0, 0.3, -1.5, 0.25)
    assert float(np.max(np.abs(tr[sync, 3] - ref[sync]))) < 1e-9
    assert max(jumps(rig)) <= 1.0 + 1e-6


def test_relative_slave_and_master() -> None:
    tab = table_360()
    rig = _rig()
    rig.add(MC_MoveAbsolute(axis=rig.s, position=0.4, velocity=1.0, execute=True))
    rig.add(MC_MoveVelocity(axis=rig.m, velocity=1.0, execute=True))
    rig.run(2000)
    m0 = rig.m.p
    cam = rig.add(
        MC_CamIn(
            master=rig.m,
            slave=rig.s,
            cam_table_id=CamTableID(tab, master_absolute=False, slave_absolute=False),
            execute=True,
        )
    )
    rig.run(1)
    rig.run(1000)
    assert cam.in_sync
    # the table starts at the master's position when the coupling started, at the slave's
    m_rel = (rig.m.p - m0) - 0.001  # one cycle: the coupling started in the step after Execute
    y = tab.at(m_rel % TWO_PI)[0]
    assert rig.s.p == pytest.approx(0.4 + y, abs=2e-3)


def test_non_periodic_cam_holds_its_end() -> None:
    tab = CamTable.from_points([(0.0, 0.0), (1.0, 0.3)], law="poly5")
    rig = _rig()
    cam = rig.add(
        MC_CamIn(
            master=rig.m,
            slave=rig.s,
            cam_table_id=CamTableID(tab, periodic=False),
            execute=True,
        )
    )
    rig.watch = {"eop": (cam, "end_of_profile")}
    rig.add(MC_MoveVelocity(axis=rig.m, velocity=1.0, execute=True))
    rig.run(3000)
    assert cam.in_sync and rig.s.p == pytest.approx(0.3, abs=1e-12) and rig.s.v == 0.0
    assert rig.flag("eop").sum() == 1


def test_buffered_successor_takes_over_at_end_of_profile() -> None:
    tab = CamTable.from_points([(0.0, 0.0), (1.0, 0.3)], law="poly5")
    rig = _rig()
    cam = rig.add(MC_CamIn(master=rig.m, slave=rig.s, cam_table_id=CamTableID(tab, periodic=False)))
    ma = rig.add(
        MC_MoveAbsolute(axis=rig.s, position=0.0, velocity=0.5, buffer_mode=BufferMode.BUFFERED)
    )
    cam.execute = True
    rig.run(1)
    ma.execute = True
    rig.add(MC_MoveVelocity(axis=rig.m, velocity=1.0, execute=True))
    rig.run(4000)
    assert cam.command_aborted and ma.done and rig.s.p == 0.0
    assert rig.s.state is S.STANDSTILL


def test_cam_refused_when_it_violates_the_slave_limits() -> None:
    tab = table_360()
    rig = _rig(v_max=0.1)
    rig.add(MC_MoveVelocity(axis=rig.m, velocity=TWO_PI, execute=True))
    rig.run(1500)
    cam = rig.add(MC_CamIn(master=rig.m, slave=rig.s, cam_table_id=CamTableID(tab), execute=True))
    rig.run(1)
    assert cam.error and cam.error_id is ErrorID.SLAVE_LIMITS_EXCEEDED
    assert "velocity" in cam.error_text
    rig.run(10)
    assert rig.s.state is S.STANDSTILL and rig.s.p == 0.0 and rig.s.v == 0.0


def test_cam_supervised_when_the_master_speeds_up() -> None:
    tab = table_360()
    rig = _rig(v_max=0.25)
    rig.add(MC_MoveVelocity(axis=rig.m, velocity=2.0, execute=True))
    cam = rig.add(MC_CamIn(master=rig.m, slave=rig.s, cam_table_id=CamTableID(tab), execute=True))
    rig.run(1500)
    assert cam.in_sync
    rig.add(MC_MoveVelocity(axis=rig.m, velocity=6.0, acceleration=2.0, execute=True))
    rig.run(4000)
    assert cam.error and cam.error_id is ErrorID.SLAVE_LIMITS_EXCEEDED
    assert rig.s.state is S.STANDSTILL and rig.s.v == 0.0


def test_cam_out_keeps_the_velocity() -> None:
    tab = CamTable.from_points([(0.0, 0.0), (TWO_PI, 0.5)], law="linear", periodic=True)
    rig = _rig()
    rig.add(MC_MoveVelocity(axis=rig.m, velocity=1.0, execute=True))
    cam = rig.add(MC_CamIn(master=rig.m, slave=rig.s, cam_table_id=CamTableID(tab), execute=True))
    out = rig.add(MC_CamOut(slave=rig.s))
    rig.run(3000)
    assert cam.in_sync
    out.execute = True
    rig.run(100)
    assert out.done and cam.command_aborted and rig.s.state is S.CONTINUOUS_MOTION
    assert rig.s.v == pytest.approx(0.5 / TWO_PI, rel=1e-12)


@pytest.mark.parametrize(
    ("pin", "value", "eid"),
    [
        ("master_scaling", 0.0, ErrorID.INVALID_SCALING),
        ("slave_scaling", math.nan, ErrorID.INVALID_SCALING),
        ("slave_scaling", math.inf, ErrorID.INVALID_SCALING),
        ("cam_table_id", "table", ErrorID.INVALID_CAM_TABLE),
        ("cam_table_id", None, ErrorID.INVALID_CAM_TABLE),
        ("start_mode", "absolute", ErrorID.INVALID_SYNC_MODE),
    ],
)
def test_invalid_inputs(pin: str, value: object, eid: ErrorID) -> None:
    rig = _rig()
    cam = rig.add(MC_CamIn(master=rig.m, slave=rig.s, cam_table_id=CamTableID(table_360())))
    setattr(cam, pin, value)
    cam.execute = True
    rig.run(1)
    assert cam.error and cam.error_id is eid and pin in cam.error_text
    assert pin in cam.input_problems(rig.s)


def test_cam_in_waits_for_the_master_start_distance() -> None:
    tab = CamTable.from_points([(0.0, 0.0), (1.0, 0.3)], law="poly5")
    rig = _rig()
    rig.add(MC_MoveVelocity(axis=rig.m, velocity=1.0, execute=True))
    cam = rig.add(
        MC_CamIn(
            master=rig.m,
            slave=rig.s,
            cam_table_id=CamTableID(tab, periodic=False, master_absolute=False),
            master_sync_position=2.0,
            master_start_distance=0.5,
            execute=True,
        )
    )
    rig.watch = {"in_sync": (cam, "in_sync")}
    rig.run(1000)
    assert cam.busy and not cam.in_sync and rig.s.p == 0.0  # the master is not at 1.5 yet
    rig.run(3000)
    assert cam.in_sync and rig.s.p == pytest.approx(0.3, abs=1e-12)  # past the table's end
    tr = rig.trace()
    moving = np.flatnonzero(tr[:, 4] != 0.0)
    assert tr[moving[0], 0] >= 1.5 - 2e-3  # the slave started with the master at the start point


def test_cam_supervision_envelope_is_sound_for_either_sign_of_the_master_acceleration() -> None:
    """The per-cycle cam supervision caches an envelope of master |v|, |a|, |j| only where
    the table's monotone bound fits; a motion the exact signed extremes allow for one sign of
    the master's acceleration (braking) does not let the other sign (speeding up) through.
    Table from points (0, 0), (0.2, 0.15), (1, 1), poly5 through cubic-spline slopes: at a
    master velocity of 2, the slave's peak acceleration is ~43.3 with am = -5 and ~48.0 with
    am = +5; the slave allows 45."""
    from types import SimpleNamespace

    from motionplc.blocks.axis_config import AxisConfig
    from motionplc.blocks.sync_job import SyncJob

    table = CamTable.from_points([(0, 0), (0.2, 0.15), (1, 1)], law="poly5", smooth=True)
    cfg = AxisConfig(name="s", v_max=100.0, a_max=45.0, j_max=1e9)
    braking = table.slave_bounds(2.0, -5.0, 0.0, False)
    speeding = table.slave_bounds(2.0, 5.0, 0.0, False)
    assert max(braking.a_max, -braking.a_min) < 45.0 < max(speeding.a_max, -speeding.a_min)
    failures: list[str] = []
    job = SimpleNamespace(
        table=table,
        msc=1.0,
        ssc=1.0,
        periodic=False,
        slave=SimpleNamespace(cfg=cfg, name="s"),
        master=SimpleNamespace(name="m"),
        chk=(0.0, 0.0, 0.0),
        peaks=(0.0, 0.0, 0.0),
        _fail=lambda eid, why: failures.append(f"{eid.name}: {why}"),
    )
    assert SyncJob._cam_supervised(job, (0.0, 2.0, -5.0, 0.0))  # braking: fits
    assert not failures
    assert not SyncJob._cam_supervised(job, (0.0, 2.0, 5.0, 0.0))  # speeding up: refused
    assert failures and failures[0].startswith("SLAVE_LIMITS_EXCEEDED")
