"""Bad inputs on the Python API side (issue 31): the documented error, never a TypeError from
inside, and a bad FB input is the FB's Error (the task goes on)."""

from __future__ import annotations

from pathlib import Path

import pytest

from motionplc.blocks import ErrorID, MC_MoveAbsolute, MC_Power
from motionplc.cli import main
from motionplc.errors import PlanningError
from motionplc.planning import Limits
from motionplc.planning.cam import CamTable, CamTableError
from motionplc.planning.otg import OnlineGenerator
from motionplc.runtime import Runtime

ROOT = Path(__file__).resolve().parents[2]


@pytest.mark.parametrize("limits", [None, 5, "ab", [], [1.0]])
def test_online_generator_bad_limits_is_a_planning_error(limits: object) -> None:
    with pytest.raises(PlanningError, match=r"^limits must be a Limits or a non-empty sequence"):
        OnlineGenerator(limits, 0.001)  # type: ignore[arg-type]
    OnlineGenerator(Limits(v_max=1.0, a_max=2.0, j_max=10.0), 0.001)  # the good case


@pytest.mark.parametrize("points", [None, 5, "ab", {"master": 0}])
def test_cam_table_bad_points_is_a_cam_table_error(points: object) -> None:
    with pytest.raises(CamTableError, match=r"^points: must be a list of at least 2 points"):
        CamTable.from_points(points)  # type: ignore[arg-type]


def test_cam_table_error_message_is_short_for_a_huge_point() -> None:
    bomb: list[object] = ["lol"]
    for _ in range(20):  # 10^20 leaves if printed
        bomb = [bomb] * 10
    with pytest.raises(CamTableError) as info:
        CamTable.from_points([bomb, [1.0, 1.0]])
    assert len(str(info.value)) < 300
    assert str(info.value).endswith("got a list of 10 items")


def test_fb_with_a_bad_axis_is_the_fbs_error_and_the_task_goes_on() -> None:
    rt = Runtime(cycle=0.001)
    x = rt.add_axis("x", v_max=1.0, a_max=10.0)
    power = MC_Power(axis=x, enable=True)
    bad = MC_MoveAbsolute()
    good = MC_MoveAbsolute(axis=x, position=0.01, velocity=0.5)

    def task(ctx: object) -> None:
        power()
        bad(axis="x", execute=True, position=0.1, velocity=0.1)
        good(execute=power.status)

    rt.add_task("main", task)
    rt.run(cycles=500)
    assert bad.error and bad.error_id is ErrorID.INVALID_AXIS
    assert bad.error_text == ("MC_MoveAbsolute: axis must be an Axis (ctx.axes['name']), got 'x'")
    assert good.done and abs(x.p - 0.01) < 1e-12


def test_python_program_with_a_bad_axis_runs_on(tmp_path: Path) -> None:
    prog = tmp_path / "prog.py"
    prog.write_text(
        "from motionplc.blocks import MC_MoveAbsolute\n"
        "TASK = 'motion'\nTIMEOUT = 0.5\nmv = MC_MoveAbsolute()\n"
        "def program(ctx):\n"
        "    mv(axis='x', execute=True, position=0.1, velocity=0.1)\n"
        "    if ctx.t > 0.1:\n"
        "        ctx.expect('mv error', float(mv.error), 1.0, within=0.0)\n"
        "        ctx.expect('mv error id', float(mv.error_id), float(0x1000), within=0.0)\n"
        "        ctx.done()\n"
    )
    assert main(["run", str(ROOT / "configs" / "demo.yaml"), str(prog), "-q"]) == 0


def test_ipv6_loopback_host_validates_and_runs(tmp_path: Path) -> None:
    """``host: '::1'`` passed validate and then failed in run with no file:line (the master's
    link was IPv4 only); now it runs, or validate refuses it where there is no IPv6."""
    from motionplc.config import _ipv6_unusable

    cfg = tmp_path / "v6.yaml"
    cfg.write_text(
        "runtime: {tick: 0.001, clock: simulated, tasks: {motion: {period: 0.001}}}\n"
        "buses:\n  mb0: {type: modbus, host: '::1', port: 0, drives: simulated}\n"
        "axes:\n  z:\n    limits: {v_max: 0.5, a_max: 2.0, j_max: 20.0}\n"
        "    drive: {bus: mb0, unit_id: 1, counts_per_unit: 1.0e6}\n"
    )
    if _ipv6_unusable("::1"):
        assert main(["validate", str(cfg)]) == 2
        return
    assert main(["validate", str(cfg)]) == 0
    assert main(["run", str(cfg), "--seconds", "0.05", "-q"]) == 0
