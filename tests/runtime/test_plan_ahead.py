"""Planning ahead (``Axis.plan_ahead``): the queued move's start profile is planned in a quiet
cycle before its hand-over and reused there only for bit-identical planner inputs.

* axes running blended legs in lockstep plan nothing in their hand-over cycles (no planning
  burst: the profiles were planned ahead, one per quiet cycle);
* the trace (rows and FB edges) is bit-identical with planning ahead switched off, for the
  lockstep legs and for random FB sequences (overrides, aborts, stops, resets).
"""

from __future__ import annotations

from typing import Any

import pytest

from motionplc.blocks import BufferMode, MC_MoveAbsolute, MC_Power
from motionplc.blocks import axis as axis_module
from motionplc.blocks.axis import Axis, planner_calls
from motionplc.runtime import Runtime
from tests.runtime.test_fast_paths import _random_program

LEGS = ((400.0, 120.0), (1000.0, 80.0), (600.0, 150.0), (0.0, 100.0))


def _lockstep(rt: Runtime, n_axes: int) -> list[Axis]:
    """Every axis keeps two BlendingLow moves queued (as tools/bench_runtime.py does)."""
    state: list[dict[str, Any]] = []
    for i in range(n_axes):
        x = rt.add_axis(f"a{i}", v_max=200.0, a_max=1000.0, j_max=20_000.0)
        moves = [MC_MoveAbsolute(buffer_mode=BufferMode.BLENDING_LOW) for _ in range(2)]
        state.append({"x": x, "power": MC_Power(), "moves": moves, "leg": 0, "turn": 0})

    def program(ctx: Any) -> None:
        for s in state:
            x = s["x"]
            s["power"](axis=x, enable=True)
            if not s["power"].status:
                continue
            cur, other = s["moves"][s["turn"]], s["moves"][1 - s["turn"]]
            if not cur.busy and not cur.execute:
                pos, vel = LEGS[s["leg"] % len(LEGS)]
                s["leg"] += 1
                cur(axis=x, execute=True, position=pos, velocity=vel, acceleration=800.0)
            else:
                cur(axis=x, execute=False)
            other(axis=x)
            if cur.active:
                s["turn"] = 1 - s["turn"]

    rt.add_task("main", program)
    return [s["x"] for s in state]


@pytest.fixture
def no_plan_ahead(monkeypatch: pytest.MonkeyPatch) -> None:
    def off(self: Axis) -> bool:
        self._ahead = False
        return False

    monkeypatch.setattr(Axis, "plan_ahead", off)
    monkeypatch.setattr(Axis, "_plan_memo", lambda self, s, t, lim: axis_module._plan(s, t, lim))


def test_hand_over_cycles_do_not_plan() -> None:
    rt = Runtime(cycle=0.001, check_invariants=True)
    axes = _lockstep(rt, 4)
    handles = [None] * len(axes)
    calls = [planner_calls()]
    hand_overs: list[int] = []
    per_cycle: dict[int, int] = {}

    def hook(rt: Runtime, k: int) -> None:
        n = planner_calls()
        per_cycle[k] = n - calls[0]
        calls[0] = n
        changed = False
        for i, ax in enumerate(axes):
            h = ax.active.handle if ax.active is not None else None
            if h is not handles[i] and handles[i] is not None and h is not None:
                changed = True
            handles[i] = h
        if changed:
            hand_overs.append(k)

    rt.add_cycle_hook(hook)
    rt.run(cycles=25_000)
    assert len(hand_overs) >= 4
    assert all(per_cycle[k] == 0 for k in hand_overs), [(k, per_cycle[k]) for k in hand_overs]


def _digest_lockstep() -> str:
    rt = Runtime(cycle=0.001, check_invariants=True)
    _lockstep(rt, 3)
    rt.run(cycles=25_000)
    return rt.trace.digest()


def _digest_random(seed: int) -> str:
    rt = Runtime(cycle=0.001, check_invariants=True)
    _random_program(rt, seed)
    rt.run(cycles=4000)
    return rt.trace.digest()


def test_lockstep_trace_is_the_same_without_planning_ahead(
    request: pytest.FixtureRequest,
) -> None:
    with_ahead = _digest_lockstep()
    request.getfixturevalue("no_plan_ahead")
    assert _digest_lockstep() == with_ahead


@pytest.mark.parametrize("seed", [1, 2, 3, 4])
def test_random_trace_is_the_same_without_planning_ahead(
    seed: int, request: pytest.FixtureRequest
) -> None:
    with_ahead = _digest_random(seed)
    request.getfixturevalue("no_plan_ahead")
    assert _digest_random(seed) == with_ahead


def _lockstep_run(budget: int | None) -> tuple[Runtime, list[Axis], dict[int, int]]:
    """Six lockstep axes; per cycle, how many running moves were re-planned to a junction."""
    rt = Runtime(cycle=0.001, check_invariants=True, blend_replans_per_cycle=budget)
    axes = _lockstep(rt, 6)
    per_cycle: dict[int, int] = {}
    orig = Axis._replan_active

    def counting(self: Axis) -> None:
        per_cycle[rt.tick] = per_cycle.get(rt.tick, 0) + 1
        orig(self)

    for ax in axes:
        ax._replan_active = counting.__get__(ax)  # type: ignore[method-assign]
    rt.run(cycles=12_000)
    return rt, axes, per_cycle


def test_blend_replans_are_spread_over_cycles() -> None:
    """With a budget of 2 junction re-plans per cycle, six axes queueing their next leg in the
    same cycle re-plan in three consecutive cycles, in axis order; re-planned from their set
    state a cycle or two later, the moves are the same (re-planning along a profile gives that
    profile again), so the axes still run in lockstep and reach the same junction speeds."""
    rt, axes, per_cycle = _lockstep_run(2)
    free_rt, free_axes, free_per_cycle = _lockstep_run(None)
    assert max(per_cycle.values()) == 2
    assert max(free_per_cycle.values()) == 6
    assert sum(per_cycle.values()) == sum(free_per_cycle.values()) >= 12
    first = min(free_per_cycle)
    assert [per_cycle.get(first + i) for i in range(3)] == [2, 2, 2]
    p0 = free_rt.trace.column("a0.position")
    for i in range(6):
        p = rt.trace.column(f"a{i}.position")
        assert abs(p - p0).max() <= 1e-9 * 1000.0
        assert (
            abs(rt.trace.column(f"a{i}.velocity") - free_rt.trace.column("a0.velocity")).max()
            <= 1e-6
        )


def test_blend_replan_budget_is_validated() -> None:
    for bad in (0, -1, 1.5, "2", True):
        with pytest.raises(ValueError, match="blend_replans_per_cycle must be an integer >= 1"):
            Runtime(blend_replans_per_cycle=bad)  # type: ignore[arg-type]
