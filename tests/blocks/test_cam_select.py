"""MC_CamTableSelect: the CamTableID it outputs, every refusal (axes, table, flags, execution
mode, a periodic slope step) and the slave-limit check at the master's motion (velocity,
acceleration, jerk; asymmetric limits; exactly at the limit; scalings of the helper), then a
360-degree periodic cam of poly5 and modified-sine segments run through MC_CamIn."""

from __future__ import annotations

import dataclasses
import math
from typing import Any

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from motionplc.blocks import MC_MoveVelocity, MC_Power
from motionplc.blocks.axis_config import AxisConfig
from motionplc.blocks.cam_select import CamTableID, MC_CamTableSelect, cam_limit_violation
from motionplc.blocks.enums import ErrorID, ExecutionMode
from motionplc.blocks.motion import StaticAxis
from motionplc.planning import CamTable
from motionplc.runtime import Runtime

TWO_PI = 2.0 * math.pi
# a 360-degree cam: dwell, poly5 rise, modified-sine return
CAM = CamTable.from_points(
    [(0.0, 0.0), (math.pi / 2, 0.0), (math.pi, 0.2), (3 * math.pi / 2, 0.2), (TWO_PI, 0.0)],
    laws=["linear", "poly5", "linear", "modified_sine"],
)


class Rig:
    def __init__(self, slave: dict[str, Any] | None = None, modulo: bool = False) -> None:
        self.rt = Runtime(cycle=0.001, check_invariants=True)
        self.m = self.rt.add_axis(
            "m", v_max=20.0, a_max=100.0, j_max=2000.0, **({"modulo": TWO_PI} if modulo else {})
        )
        self.s = self.rt.add_axis(
            "s", **{"v_max": 6.0, "a_max": 60.0, "j_max": 2000.0, **(slave or {})}
        )
        self.fbs: list[Any] = [MC_Power(axis=a, enable=True) for a in (self.m, self.s)]
        self.rt.add_task("main", lambda ctx: [fb() for fb in self.fbs])
        self.rt.run(cycles=3)

    def add(self, fb: Any) -> Any:
        self.fbs.append(fb)
        return fb

    def master_at(self, v: float) -> None:
        """Run the master at constant velocity v (after its ramp)."""
        self.add(MC_MoveVelocity(axis=self.m, execute=True, velocity=abs(v), acceleration=100.0))
        self.rt.run(cycles=400)
        assert self.m.v == pytest.approx(abs(v)) and self.m.a == 0.0


def test_select_done_in_the_same_scan_with_the_id() -> None:
    r = Rig()
    sel = r.add(MC_CamTableSelect(master=r.m, slave=r.s, cam_table=CAM))
    assert sel.slave is r.s and sel.axis is r.s
    sel(execute=True)
    assert sel.done and not sel.busy and not sel.error
    cid = sel.cam_table_id
    assert cid == CamTableID(CAM, periodic=True, master_absolute=True, slave_absolute=True)
    assert hash(cid) == hash(CamTableID(CAM))
    with pytest.raises(dataclasses.FrozenInstanceError):
        cid.periodic = False  # type: ignore[misc]
    r.rt.run(cycles=5)
    assert sel.done and sel.cam_table_id is cid  # held while Execute stays TRUE
    sel(execute=False)
    assert not sel.done and sel.cam_table_id is cid  # the ID stays valid for MC_CamIn
    sel(execute=True, periodic=False, master_absolute=False, slave_absolute=False)
    assert sel.cam_table_id == CamTableID(CAM, False, False, False)
    assert r.s.state.name == "STANDSTILL" and r.m.state.name == "STANDSTILL"


@pytest.mark.parametrize(
    ("inputs", "error_id", "match"),
    [
        ({"slave": None}, ErrorID.INVALID_AXIS, "axis input is not connected"),
        ({"master": None}, ErrorID.INVALID_MASTER, "master must be an Axis other"),
        ({"master": "s"}, ErrorID.INVALID_MASTER, "master must be an Axis other"),
        ({"cam_table": None}, ErrorID.INVALID_CAM_TABLE, "cam_table must be a CamTable"),
        ({"cam_table": [(0, 0), (1, 1)]}, ErrorID.INVALID_CAM_TABLE, "got \\[\\(0, 0\\)"),
        ({"periodic": "yes"}, ErrorID.INVALID_CAM_TABLE, "periodic must be a BOOL"),
        ({"master_absolute": 2}, ErrorID.INVALID_CAM_TABLE, "master_absolute must be a BOOL"),
        ({"slave_absolute": None}, ErrorID.INVALID_CAM_TABLE, "slave_absolute must be a BOOL"),
        ({"execution_mode": "queued"}, ErrorID.INVALID_EXECUTION_MODE, "ExecutionMode"),
    ],
)
def test_refused_inputs(inputs: dict[str, Any], error_id: ErrorID, match: str) -> None:
    r = Rig()
    kw: dict[str, Any] = {"master": r.m, "slave": r.s, "cam_table": CAM, **inputs}
    if kw["master"] == "s":
        kw["master"] = r.s
    sel = r.add(MC_CamTableSelect(**kw))
    sel(execute=True)
    assert sel.error and sel.error_id is error_id and not sel.done
    assert sel.cam_table_id is None
    assert re_search(match, sel.error_text)
    sel(execute=False)
    assert not sel.error  # held only while Execute is TRUE


def re_search(pattern: str, text: str) -> bool:
    import re

    return re.search(pattern, text) is not None


def test_periodic_slope_step_refused_non_periodic_accepted() -> None:
    lift = CamTable.from_points([(0, 0), (1, 0.5), (2, 1.5)], laws=["poly5", "linear"])
    r = Rig()
    sel = r.add(MC_CamTableSelect(master=r.m, slave=r.s, cam_table=lift))
    sel(execute=True)
    assert sel.error_id is ErrorID.INVALID_CAM_TABLE
    assert "slope is 1 at its end but 0 at its start" in sel.error_text
    sel(execute=False)
    sel(execute=True, periodic=False)
    assert sel.done and sel.cam_table_id == CamTableID(lift, periodic=False)
    # the same lift built periodic (slope carried over the seam) is fine periodically
    per = CamTable.from_points(
        [(0, 0), (1, 0.5), (2, 1.5)], laws=["poly5", "linear"], periodic=True
    )
    sel(execute=False)
    sel(execute=True, periodic=True, cam_table=per)
    assert sel.done


def _rise(h: float, law: str = "poly5") -> CamTable:
    return CamTable.from_points([(0.0, 0.0), (1.0, h), (2.0, 0.0)], laws=[law, law])


@pytest.mark.parametrize("quantity", ["velocity", "acceleration", "jerk"])
def test_slave_limits_at_the_master_velocity(quantity: str) -> None:
    """Each limit on its own: the cam scaled to 1 % below it passes, 1 % above it is refused
    with the figures; the master at rest passes anything."""
    vm = 2.0
    unit = _rise(1.0)
    need = {
        "velocity": unit.peak_slope * vm,
        "acceleration": unit.peak_curvature * vm**2,
        "jerk": unit.peak_jerk * vm**3,
    }[quantity]
    big = {"v_max": 1e6, "a_max": 1e6, "j_max": 1e9}
    limit = 10.0
    slave = {
        **big,
        {"velocity": "v_max", "acceleration": "a_max", "jerk": "j_max"}[quantity]: limit,
    }
    r = Rig(slave=slave)
    ok = r.add(MC_CamTableSelect(master=r.m, slave=r.s, cam_table=_rise(0.99 * limit / need)))
    bad = r.add(MC_CamTableSelect(master=r.m, slave=r.s, cam_table=_rise(1.01 * limit / need)))
    ok(execute=True)
    bad(execute=True)
    assert ok.done and bad.done  # master at rest
    ok(execute=False)
    bad(execute=False)
    r.master_at(vm)
    ok(execute=True)
    bad(execute=True)
    assert ok.done, ok.error_text
    assert bad.error and bad.error_id is ErrorID.SLAVE_LIMITS_EXCEEDED
    assert f"needs a slave {quantity} in [" in bad.error_text
    assert "master velocity 2," in bad.error_text and "allows [-10, 10]" in bad.error_text
    assert bad.cam_table_id is None


def test_asymmetric_limits_and_exactly_at_the_limit() -> None:
    # the slave may run at 6 forwards but only 1 backwards: a fall fails, a rise passes
    r = Rig(slave={"v_min": -1.0})
    vm = 2.0
    rise = CamTable.from_points([(0, 0), (1, 6.0 / (1.875 * vm))], law="poly5")
    fall = CamTable.from_points([(0, 0), (1, -1.01 / (1.875 * vm))], law="poly5")
    s1 = r.add(MC_CamTableSelect(master=r.m, slave=r.s, cam_table=rise, periodic=False))
    s2 = r.add(MC_CamTableSelect(master=r.m, slave=r.s, cam_table=fall, periodic=False))
    r.master_at(vm)
    s1(execute=True)
    s2(execute=True)
    assert s1.done, s1.error_text  # exactly at v_max (1.875 is exact for poly5)
    assert s2.error_id is ErrorID.SLAVE_LIMITS_EXCEEDED
    assert "velocity in [-1.01, 0]" in s2.error_text and "allows [-1, 6]" in s2.error_text


def test_master_acceleration_counts() -> None:
    """During the master's ramp the term y' am adds to the slave's acceleration."""
    lin = CamTable.from_points([(0, 0), (1, 1.0)], law="linear")  # y' = 1, y'' = 0
    r = Rig(slave={"a_max": 50.0})
    sel = r.add(MC_CamTableSelect(master=r.m, slave=r.s, cam_table=lin, periodic=False))
    r.add(MC_MoveVelocity(axis=r.m, execute=True, velocity=10.0, acceleration=80.0))
    r.rt.run(cycles=60)
    assert r.m.img_a == pytest.approx(80.0)
    sel(execute=True)
    assert sel.error_id is ErrorID.SLAVE_LIMITS_EXCEEDED
    assert "acceleration in [80, 80]" in sel.error_text


def test_cam_limit_violation_scalings() -> None:
    cfg = AxisConfig("s", v_max=3.0, a_max=100.0, j_max=math.inf, v_min=-1.0)
    t = CamTable.from_points([(0, 0), (1, 1)], law="poly5")  # y' in [0, 1.875]
    assert cam_limit_violation(t, cfg, 1.6) == ""  # 3.0 >= 1.875 * 1.6
    assert "velocity" in cam_limit_violation(t, cfg, 1.7)
    # master scaling 2 doubles the table speed; slave scaling -0.5 flips and halves
    assert cam_limit_violation(t, cfg, 0.8, master_scaling=2.0) == ""
    assert cam_limit_violation(t, cfg, 0.8, master_scaling=2.0, slave_scaling=-0.5) != ""
    assert cam_limit_violation(t, cfg, 0.5, slave_scaling=-1.0) == ""  # -0.9375 >= -1
    assert cam_limit_violation(t, cfg, 0.6, slave_scaling=-1.0) != ""  # -1.125 < -1
    # no jerk limit: never a jerk violation, even at a curvature step
    h = CamTable.from_points(
        [(0, 0), (1, 0), (2, 1), (3, 1)], laws=["linear", "harmonic", "linear"]
    )
    assert cam_limit_violation(h, cfg, 0.1) == ""
    jcfg = AxisConfig("s", v_max=3.0, a_max=100.0, j_max=1e6)
    assert "(a step at a curvature or slope jump)" in cam_limit_violation(h, jcfg, 0.1)


@given(
    st.lists(st.tuples(st.floats(0.2, 2.0), st.floats(-1, 1)), min_size=2, max_size=6),
    st.sampled_from(["poly5", "poly7", "modified_sine", "cycloid", "modified_trapezoid"]),
    st.floats(-3, 3),
    st.floats(-10, 10),
    st.floats(0.5, 5),
    st.floats(0.5, 5),
    st.floats(2, 50),
    st.floats(20, 2000),
)
@settings(max_examples=60, deadline=None, derandomize=True)
def test_limit_verdict_against_sampling(
    rows: list, law: str, vm: float, am: float, vp: float, vn: float, a: float, j: float
) -> None:
    """cam_limit_violation says "fits" exactly when the sampled slave motion (a dense grid)
    stays within the asymmetric limits (cases within 1e-3 of a limit are not judged)."""
    xs = np.cumsum([0.0] + [r[0] for r in rows[1:]])
    t = CamTable.from_points([(x, r[1]) for x, r in zip(xs, rows, strict=True)], law=law)
    cfg = AxisConfig("s", v_max=vp, a_max=a, j_max=j, v_min=-vn)
    edges = np.array(t._starts[1:])  # both sides of every section boundary: jerk peaks
    grid = np.concatenate([np.linspace(xs[0], xs[-1], 40_001), edges, np.nextafter(edges, -1)])
    s = t.sample(grid)
    v = s.dy * vm
    acc = s.d2y * vm * vm + s.dy * am
    jerk = s.d3y * vm**3 + 3 * s.d2y * vm * am
    ratios = [
        max(float(np.max(v)) / vp, float(-np.min(v)) / vn),
        float(np.max(np.abs(acc))) / a,
        float(np.max(np.abs(jerk))) / j,
    ]
    worst = max(ratios)
    assume(abs(worst - 1.0) > 1e-3)
    why = cam_limit_violation(t, cfg, vm, am)
    assert (why == "") == (worst < 1.0), (why, ratios)


def test_input_checks_before_the_run() -> None:
    """motionplc validate checks literal inputs with a StaticAxis."""
    fb = MC_CamTableSelect(cam_table="c1", execution_mode=ExecutionMode.QUEUED)
    probs = fb.input_problems(StaticAxis(AxisConfig("s", v_max=1.0, a_max=1.0)))
    assert set(probs) == {"cam_table"}
    assert probs["cam_table"].error_id is ErrorID.INVALID_CAM_TABLE
    fb.cam_table = CAM
    assert fb.input_problems(StaticAxis(AxisConfig("s", v_max=1.0, a_max=1.0))) == {}


def test_periodic_360_cam_through_cam_in() -> None:
    """A 360-degree periodic cam of poly5 and modified-sine segments on a modulo master: once
    in sync the slave's set position is the table at the master's position in every cycle."""
    from motionplc.blocks.sync import MC_CamIn

    r = Rig(modulo=True)
    sel = r.add(MC_CamTableSelect(master=r.m, slave=r.s, cam_table=CAM))
    r.master_at(TWO_PI)  # one turn per second
    sel(execute=True)
    assert sel.done, sel.error_text
    cam = r.add(MC_CamIn(master=r.m, slave=r.s, cam_table_id=sel.cam_table_id, execute=True))
    rows: list[tuple[float, float, bool]] = []
    r.rt.add_cycle_hook(lambda rt, c: rows.append((r.m.p, r.s.p, cam.in_sync)))
    r.rt.run(cycles=3000)
    assert cam.in_sync and not cam.error, cam.error_text
    tr = np.array(rows)
    synced = tr[tr[:, 2] > 0]
    assert len(synced) > 2000
    want = CAM.sample(np.mod(synced[:, 0], TWO_PI)).y
    assert float(np.max(np.abs(synced[:, 1] - want))) < 1e-9
