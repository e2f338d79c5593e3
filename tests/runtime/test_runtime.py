from __future__ import annotations

import math

import pytest

from motionplc.blocks import AxisState, ErrorID, MC_MoveAbsolute, MC_Power, MC_ReadAxisError
from motionplc.runtime import RealtimeClock, Runtime
from motionplc.runtime.invariants import InvariantError


def test_task_order_by_priority_then_declaration() -> None:
    rt = Runtime(cycle=0.001, check_invariants=True)
    calls: list[tuple[int, str]] = []
    rt.add_task("slow", lambda ctx: calls.append((ctx.cycle, "slow")), period=0.010, priority=5)
    rt.add_task("fast", lambda ctx: calls.append((ctx.cycle, "fast")), period=0.001, priority=0)
    rt.add_task("fast2", lambda ctx: calls.append((ctx.cycle, "fast2")), period=0.002, priority=0)
    rt.run(cycles=30)
    at = {k: [n for c, n in calls if c == k] for k in range(30)}
    for k in range(30):
        expect = ["fast"] + (["fast2"] if k % 2 == 0 else []) + (["slow"] if k % 10 == 0 else [])
        assert at[k] == expect
    assert rt.stats()["slow"].cycle_count == 3
    assert rt.stats()["fast"].cycle_count == 30


def test_task_context_time_and_dt() -> None:
    rt = Runtime(cycle=0.0005)
    seen: list[tuple[int, float, float]] = []
    rt.add_task("t", lambda ctx: seen.append((ctx.cycle, ctx.t, ctx.dt)), period=0.002)
    rt.run(seconds=0.01)
    assert [c for c, _, _ in seen] == [0, 4, 8, 12, 16]
    assert all(t == c * 0.0005 and dt == 0.002 for c, t, dt in seen)
    assert rt.time == pytest.approx(0.01)


@pytest.mark.parametrize("period", [0.0015, 0.0, -1.0, math.nan])
def test_period_must_be_a_multiple_of_the_tick(period: float) -> None:
    rt = Runtime(cycle=0.001)
    with pytest.raises(ValueError, match="period"):
        rt.add_task("t", lambda ctx: None, period=period)


def test_bad_runtime_arguments() -> None:
    with pytest.raises(ValueError, match="cycle"):
        Runtime(cycle=0.0)
    with pytest.raises(ValueError, match="overrun_policy"):
        Runtime(overrun_policy="ignore")
    rt = Runtime()
    with pytest.raises(ValueError, match="priority"):
        rt.add_task("t", lambda ctx: None, priority=40)
    rt.add_task("t", lambda ctx: None)
    with pytest.raises(ValueError, match="duplicate"):
        rt.add_task("t", lambda ctx: None)
    with pytest.raises(TypeError):
        rt.run()
    with pytest.raises(ValueError, match="v_max"):
        rt.add_axis("x", v_max=-1.0, a_max=1.0)


def test_input_image_is_frozen_during_the_scan() -> None:
    """H3: an input toggled mid-scan by another task is seen in the next input phase only."""
    rt = Runtime(cycle=0.001, check_invariants=True)
    seen_before: list[object] = []
    seen_after: list[object] = []

    def writer(ctx):  # runs first (priority 0) and toggles a physical input each cycle
        seen_before.append(ctx.inputs.get("sensor"))
        ctx.image.set_input("sensor", ctx.cycle)

    def reader(ctx):
        seen_after.append(ctx.inputs.get("sensor"))

    rt.add_task("writer", writer, priority=0)
    rt.add_task("reader", reader, priority=1)
    rt.run(cycles=4)
    # the reader's input phase runs after the writer's scan: it sees the value of this cycle,
    # while the writer saw the value of the previous cycle during its own scan
    assert seen_before == [None, 0, 1, 2]
    assert seen_after == [0, 1, 2, 3]


def test_outputs_are_published_after_the_scan() -> None:
    rt = Runtime(cycle=0.001)
    phys: list[object] = []

    def prog(ctx):
        phys.append(ctx.image.physical_outputs.get("lamp"))
        ctx.outputs["lamp"] = ctx.cycle

    rt.add_task("t", prog)
    rt.run(cycles=3)
    assert phys == [None, 0, 1]


@pytest.mark.parametrize("policy", ["skip", "catch_up"])
def test_overrun_injection(policy: str) -> None:
    """H4: a scan taking 2.5 periods in virtual time."""
    rt = Runtime(cycle=0.001, overrun_policy=policy)
    starts: list[int] = []

    def prog(ctx):
        starts.append(ctx.cycle)
        if ctx.cycle == 2:
            ctx.spend(0.0025)

    rt.add_task("t", prog)
    rt.run(cycles=8)
    st = rt.stats()["t"]
    if policy == "skip":
        assert st.overruns == 1
        assert starts == [0, 1, 2, 5, 6, 7]
        assert st.omitted_cycles == 2
        assert st.lateness_max == 0.0  # realigned to the grid
    else:
        assert starts == [0, 1, 2, 3, 4, 5, 6, 7]
        # cycle 3 starts 1.5 ms late (at 4.5 ms) and ends after its release at 4 ms: overrun too
        assert st.overruns == 2
        assert st.omitted_cycles == 0
        assert st.lateness_max == pytest.approx(0.0015)
    assert not st.cycle_time_exceeded  # the last cycle was on time


def _watchdog_rt(spend: dict[int, float]) -> tuple[Runtime, object]:
    rt = Runtime(cycle=0.001, check_invariants=True)
    x = rt.add_axis("x", v_max=100.0, a_max=1000.0, j_max=1e5)
    pw = MC_Power()
    mv = MC_MoveAbsolute()
    calls = [0]

    def prog(ctx):  # spend is keyed by the number of the scan (ticks are skipped on overrun)
        pw(axis=x, enable=True)
        mv(axis=x, execute=ctx.cycle >= 3, position=50.0, velocity=50.0)
        ctx.spend(spend.get(calls[0], 0.0))
        calls[0] += 1

    rt.add_task("main", prog, watchdog_time=0.005, watchdog_sensitivity=3)
    return rt, x


def test_watchdog_two_consecutive_overruns_are_tolerated() -> None:
    rt, x = _watchdog_rt({100: 0.006, 101: 0.006})
    rt.run(cycles=300)
    assert not rt.stats()["main"].watchdog_tripped
    assert x.state is AxisState.DISCRETE_MOTION


def test_watchdog_three_consecutive_overruns_stop_the_axes() -> None:
    rt, x = _watchdog_rt({100: 0.006, 101: 0.006, 102: 0.006})
    rt.run(cycles=130)
    st = rt.stats()["main"]
    assert st.watchdog_tripped
    assert x.state is AxisState.ERROR_STOP
    assert x.axis_error is ErrorID.WATCHDOG
    assert "3 consecutive" in x.axis_error_reason and "main" in rt.error_reason


def test_watchdog_single_long_cycle() -> None:
    rt, x = _watchdog_rt({100: 0.016})
    rt.run(cycles=102)
    assert rt.stats()["main"].watchdog_tripped
    assert x.state is AxisState.ERROR_STOP
    rt.run(cycles=1)  # the axis image read by the FBs is refreshed in the input phase
    rd = MC_ReadAxisError(axis=x, enable=True)
    rd()
    assert rd.axis_error_id is ErrorID.WATCHDOG and "16.000 ms" in rd.axis_error_reason


def test_virtual_time_statistics_are_zero() -> None:
    rt = Runtime(cycle=0.001, check_invariants=True)
    rt.add_task("t", lambda ctx: None)
    rt.run(cycles=50)
    st = rt.stats()["t"]
    assert st.cycle_count == 50
    assert st.lateness_max == st.lateness_p99 == st.exec_max == 0.0
    assert st.overruns == 0


def test_realtime_clock_runs_and_reports_statistics() -> None:
    rt = Runtime(cycle=0.001, clock=RealtimeClock())
    rt.add_task("t", lambda ctx: None)
    rt.run(cycles=40)
    st = rt.stats()["t"]
    # executed cycles never exceed the requested ticks; with omitted ones (a late cycle under
    # load) they cover them (the last late cycle may omit a tick beyond the run)
    assert st.cycle_count <= 40 <= st.cycle_count + st.omitted_cycles
    assert 0.0 <= st.lateness_min <= st.lateness_p50 <= st.lateness_max
    assert st.exec_max >= st.exec_mean >= st.exec_min >= 0.0
    assert set(st.as_dict()) >= {"lateness_p99", "overruns", "exec_mean"}


def test_run_until_and_run_seconds() -> None:
    rt = Runtime(cycle=0.002)
    count = [0]
    rt.add_task("t", lambda ctx: count.__setitem__(0, count[0] + 1))
    assert rt.run_until(lambda: count[0] >= 7)
    assert count[0] == 7 and rt.tick == 7
    assert rt.run_until(lambda r: r.tick >= 10)
    assert not rt.run_until(lambda: False, max_seconds=0.01)
    assert rt.tick == 15
    rt.run(seconds=0.1)
    assert rt.tick == 65


def test_trace_columns_csv_and_bounded_memory(tmp_path) -> None:
    rt = Runtime(cycle=0.001, trace_capacity=3000)
    x = rt.add_axis("x", v_max=10.0, a_max=10.0)
    pw = MC_Power()
    rt.add_task("main", lambda ctx: pw(axis=x, enable=True))
    rt.run(cycles=10_000)
    tr = rt.trace
    assert 3000 <= len(tr) <= 3000 + 2 * 3000
    assert tr.dropped_rows + len(tr) == 10_000
    cyc = tr.column("cycle")
    assert cyc[-1] == 9999 and (cyc[1:] - cyc[:-1] == 1).all()
    assert set(tr.columns) >= {"x.position", "x.velocity", "x.state", "x.following_error"}
    with pytest.raises(KeyError, match="no trace column"):
        tr.column("y.velocity")
    path = tmp_path / "trace.csv"
    ev = tmp_path / "events.csv"
    tr.to_csv(path, ev)
    lines = path.read_text().splitlines()
    assert lines[0].startswith("cycle,t,x.position")
    assert len(lines) == len(tr) + 1
    assert lines[-1].split(",")[tr.columns.index("x.state")] == "STANDSTILL"
    assert "x.MC_Power1,status,True" in ev.read_text()


def test_invariant_checker_catches_a_violation() -> None:
    rt = Runtime(cycle=0.001, check_invariants=True)
    x = rt.add_axis("x", v_max=10.0, a_max=10.0)
    pw = MC_Power()

    def prog(ctx):
        pw(axis=x, enable=True)
        if ctx.cycle == 5:
            x.p += 1.0  # corrupt the set position in Standstill

    rt.add_task("main", prog)
    with pytest.raises(InvariantError, match="position jump"):
        rt.run(cycles=10)
