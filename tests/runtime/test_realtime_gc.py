"""Real time: no garbage-collector pause inside the loop (issue 13, finding 4).

A full collection of a loaded process takes ~10 ms; the CLI used to run in 1 s slices, each
starting with one: SYNC and setpoints stopped for 12.5 ms every second. The runtime now
collects fully once before its first real-time run only, keeps the collector off in the loop
and collects the youngest generation in the idle slack of a cycle.
"""

from __future__ import annotations

import gc
from typing import Any

import pytest

from motionplc.runtime import RealtimeClock, Runtime


@pytest.fixture
def collections(monkeypatch: pytest.MonkeyPatch) -> list[int]:
    calls: list[int] = []
    real = gc.collect

    def counting(generation: int = 2) -> int:
        calls.append(generation)
        return real(generation)

    monkeypatch.setattr(gc, "collect", counting)
    return calls


def test_full_collection_once_not_per_slice(collections: list[int]) -> None:
    rt = Runtime(cycle=0.001, clock=RealtimeClock())
    rt.add_task("main", lambda ctx: None)
    enabled_inside: list[bool] = []
    rt.add_cycle_hook(lambda rt, k: enabled_inside.append(gc.isenabled()))
    was = gc.isenabled()
    for _ in range(4):
        rt.run(cycles=5)
    assert collections.count(2) == 1  # before the first real-time run only
    assert enabled_inside and not any(enabled_inside)  # the collector is off in the loop
    assert gc.isenabled() == was  # and restored after each run
    assert gc.get_freeze_count() == 0


def test_young_garbage_collected_in_idle_slack(collections: list[int]) -> None:
    rt = Runtime(cycle=0.002, clock=RealtimeClock())
    garbage: list[Any] = []

    def program(ctx: Any) -> None:
        a: list[Any] = []
        a.append(a)  # a reference cycle: refcounting alone never frees it
        garbage.append(None)

    rt.add_task("main", program)
    rt._gc_every = 10  # every 10 ticks instead of once per second (test speed)
    rt.run(cycles=60)
    young = [g for g in collections if g == 0]
    # at most once per 10 ticks, only with half a tick of slack left (a loaded host may
    # leave less in some of them)
    assert 1 <= len(young) <= 6
    assert rt.gc_stats["collections"] == len(young)
    assert rt.gc_stats["freed"] >= 10  # the cycles' reference cycles were freed
    assert rt.gc_stats["max_ns"] > 0


def test_simulated_clock_leaves_the_collector_alone(collections: list[int]) -> None:
    rt = Runtime(cycle=0.001)
    rt.add_task("main", lambda ctx: None)
    inside: list[bool] = []
    rt.add_cycle_hook(lambda rt, k: inside.append(gc.isenabled()))
    was = gc.isenabled()
    rt.run(cycles=10)
    assert collections == []
    assert inside == [was] * 10
