"""The operator desk in simulated time, without a server: requests enter the cycle through
the queue and go through the FBs' checks, the snapshot is one cycle's values, every action is
in the trace and the audit with its user."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from motionplc.blocks.enums import AxisState, ErrorID, GroupState
from motionplc.config import build, load_config
from motionplc.operator.desk import OperatorDesk, Request

CONFIG = """\
runtime:
  tick: 0.001
  tasks:
    motion: {period: 0.001}
    slow: {period: 0.004, priority: 2}
axes:
  x:
    limits: {v_max: 0.5, a_max: 2.0, j_max: 20.0}
    software_limits: {min: -0.05, max: 1.05}
  y:
    limits: {v_max: 0.4, a_max: 1.5, j_max: 15.0}
  s:
    task: slow
    units: rad
    limits: {v_max: 10.0, a_max: 50.0, j_max: 500.0}
groups:
  xy: [x, y]
"""


@pytest.fixture
def rig(tmp_path: Path) -> tuple[object, OperatorDesk]:
    f = tmp_path / "m.yaml"
    f.write_text(CONFIG)
    m = build(load_config(f))
    desk = OperatorDesk(m, publish_every=4)
    desk.install()
    yield m, desk
    m.close()


class _Req(Request):
    """A request that keeps the replies it got (a subclass: has a __dict__)."""


def ask(desk: OperatorDesk, target: str, method: str, *args: object) -> _Req:
    replies: list[tuple[bool, int, str, int]] = []
    req = _Req(target, method, args, "alice", lambda *r: replies.append(r))
    req.replies = replies
    desk.submit(req)
    return req


def test_requests_act_in_the_next_cycle_of_the_axis_task(rig: tuple) -> None:
    m, desk = rig
    rt = m.runtime
    rt.run(cycles=3)
    a = ask(desk, "axis:x", "Power", True)
    b = ask(desk, "axis:s", "Power", True)
    assert a.ok is None  # queued: nothing happens outside the cycle
    rt.run(cycles=1)
    assert a.ok is True and a.cycle == 3 and a.replies == [(True, 0, "", 3)]
    assert b.ok is None  # the slow task runs every 4th tick
    rt.run(cycles=1)
    assert b.ok is True and b.cycle == 4
    rt.run(cycles=20)
    assert m.axes["x"].state is AxisState.STANDSTILL and m.axes["s"].state is AxisState.STANDSTILL
    # the operator's FBs are in the trace (edges) and the audit names the user
    assert rt.trace.edges("op.x.MC_Power", "status")[0][1] is True
    assert [(c, u, t, mt, ok) for c, u, t, mt, _, ok, _ in desk.audit] == [
        (3, "alice", "axis:x", "Power", True),
        (4, "alice", "axis:s", "Power", True),
    ]


def test_jog_is_one_exact_inching_step_and_bad_inputs_are_the_fbs_errors(rig: tuple) -> None:
    m, desk = rig
    rt = m.runtime
    ask(desk, "axis:x", "Power", True)
    rt.run(cycles=20)
    j = ask(desk, "axis:x", "Jog", 1, 0.02, 0.0)
    rt.run(seconds=1.0)
    assert j.ok is True
    assert math.isclose(m.axes["x"].p, 0.02, abs_tol=1e-12)
    assert m.axes["x"].state is AxisState.STANDSTILL
    bad = [
        ask(desk, "axis:x", "SetOverride", 7.0),
        ask(desk, "axis:x", "Jog", 0, 0.02, 0.0),
        ask(desk, "axis:x", "Jog", -1, -0.02, 0.0),
        ask(desk, "axis:x", "Jog", 1, 5.0, 0.0),  # beyond the software limit
        ask(desk, "axis:x", "Power", "yes"),
        ask(desk, "axis:nope", "Power", True),
        ask(desk, "group:xy", "FeedHold"),  # the group is disabled
    ]
    rt.run(cycles=2)
    ov, d0, dneg, far, typ, unknown, hold = bad
    assert ov.ok is False and ov.error_id == ErrorID.INVALID_OVERRIDE
    assert "vel_factor" in ov.text and "7.0" in ov.text
    assert d0.ok is False and "Direction must be +1 or -1" in d0.text
    assert dneg.ok is False and dneg.error_id == ErrorID.INVALID_DISTANCE
    assert far.ok is False and far.error_id == ErrorID.TARGET_OUTSIDE_SW_LIMITS, far.text
    assert typ.ok is False and "Enable must be a Boolean" in typ.text
    assert unknown.ok is False and "no such target" in unknown.text and unknown.cycle == -1
    assert hold.ok is False and hold.error_id == ErrorID.GROUP_STATE_DISABLED, hold.text
    assert m.axes["x"].state is AxisState.STANDSTILL  # nothing refused moved anything


def test_snapshot_is_one_cycle_and_immutable(rig: tuple) -> None:
    m, desk = rig
    rt = m.runtime
    ask(desk, "axis:x", "Power", True)
    rt.run(cycles=10)
    ask(desk, "axis:x", "Jog", 1, 0.05, 0.2)
    rt.run(cycles=101)
    while (rt.tick - 1) % desk.publish_every:  # up to the tick of a publication
        rt.run(cycles=1)
    snap = desk.snapshot
    assert snap is not None and snap.cycle == rt.tick - 1 and snap.t == snap.cycle * rt.cycle
    x = snap.axes[0]
    ax = m.axes["x"]
    assert x.name == "x" and x.state == int(AxisState.DISCRETE_MOTION)
    assert (x.set_position, x.set_velocity, x.actual_position) == (ax.p, ax.v, ax.act_p)
    assert 0.0 < x.set_position < 0.05 and x.set_velocity > 0.0
    with pytest.raises(AttributeError):
        x.set_position = 1.0  # type: ignore[misc]
    rt.run(cycles=desk.publish_every - 1)
    assert desk.snapshot is snap  # the next one after publish_every ticks
    assert ax.p != x.set_position  # the axis moved on, the snapshot did not
    rt.run(cycles=1)
    assert desk.snapshot is not snap and desk.snapshot.seq == snap.seq + 1
    assert snap.tasks[0].name == "motion" and snap.tasks[0].cycle_count >= 100


def test_mdi_feed_hold_continue_and_program_control(rig: tuple, tmp_path: Path) -> None:
    m, desk = rig
    rt = m.runtime
    mdi = ask(desk, "group:xy", "Mdi", "G1 X20 Y10 F3000")
    rt.run(cycles=1)
    assert mdi.ok is True, mdi.text
    busy = ask(desk, "group:xy", "Mdi", "G1 X0")
    rt.run(cycles=200)
    assert busy.ok is False and "still runs" in busy.text
    g = m.axes_groups["xy"]
    assert g.state is GroupState.GROUP_MOVING
    hold = ask(desk, "group:xy", "FeedHold")
    rt.run(seconds=1.0)
    assert hold.ok is True and g.path_velocity == 0.0
    held = g.position()
    assert held[0] < 0.02
    cont = ask(desk, "group:xy", "FeedContinue")
    rt.run(seconds=2.0)
    assert cont.ok is True
    end = g.position()
    assert math.isclose(end[0], 0.02, abs_tol=1e-12) and math.isclose(end[1], 0.01, abs_tol=1e-12)
    assert desk.snapshot.program.kind == "none"  # the MDI line is over
    bad = ask(desk, "group:xy", "Mdi", "G1 X")
    two = ask(desk, "group:xy", "Mdi", "G1 X1\nG1 X2")
    rt.run(cycles=1)
    assert bad.ok is False and "G-code" in bad.text
    assert two.ok is False and "one non-empty G-code line" in two.text
    # a program: loaded, started, stopped under control, not restarted
    from motionplc.gcode_runner import GcodeRunner, load_gcode_job

    prog = tmp_path / "p.ngc"
    prog.write_text("G21 G90\nG1 X40 Y0 F3000\nG1 X0 Y0\nM2\n")
    job = load_gcode_job(prog, m.config, "xy")
    nothing = ask(desk, "program", "Stop")
    load = desk.load(GcodeRunner(job, m))
    rt.run(cycles=1)
    assert nothing.ok is False and load.ok is True
    start = ask(desk, "program", "Start")
    rt.run(seconds=0.5)
    assert start.ok is True and desk.snapshot.program.state == "running"
    pv = desk.snapshot.program
    assert pv.kind == "gcode" and pv.line >= 2 and pv.lines_total == 2 and pv.path == str(prog)
    stop = ask(desk, "program", "Stop")
    again = ask(desk, "program", "Start")
    rt.run(seconds=1.0)
    assert stop.ok is True and again.ok is False and "runs once" in again.text
    assert g.state is GroupState.GROUP_STANDBY and g.path_velocity == 0.0
    assert desk.snapshot.program.state == "stopped"


def test_close_answers_what_is_still_queued(rig: tuple) -> None:
    _, desk = rig
    req = ask(desk, "axis:y", "Reset")
    desk.close("the machine stopped")
    assert req.ok is False and req.text == "the machine stopped" and req.cycle == -1
