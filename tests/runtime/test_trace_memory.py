"""The trace's memory bound and its exactness (issue 11, finding 8).

* a row takes 16 B plus 57 B per axis; the storage bound ``nbytes`` never exceeds the budget;
* the trace is a ring of the most recent rows: ``array``, ``column``, ``last`` and the CSV equal
  the tail of an independent list of every row recorded, for any layout, row capacity and
  byte budget (hypothesis), with ``dropped_rows + len == recorded``;
* recording many times the budget keeps the memory numpy allocates within it (tracemalloc);
* a runtime with a small budget keeps exactly the values of its axes (captured independently
  by a cycle hook);
* a small-integer column refuses a value it cannot hold; FB edges live in a ring of their own.
"""

from __future__ import annotations

import csv
import math
import tracemalloc
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from motionplc.blocks import BufferMode, MC_MoveAbsolute, MC_Power
from motionplc.runtime import Runtime, Trace
from motionplc.runtime import trace as trace_module
from motionplc.runtime.trace import (
    AXIS_DTYPES,
    AXIS_FIELDS,
    AXIS_ROW_BYTES,
    CYCLE_ROW_BYTES,
    EVENT_BYTES,
    TRACE_BYTES,
)


def _axis_trace(n_axes: int, **kw: int) -> Trace:
    tr = Trace(**kw)
    for i in range(n_axes):
        tr.add_columns([f"a{i}.{f}" for f in AXIS_FIELDS], AXIS_DTYPES)
    return tr


def test_documented_bytes_per_axis_and_cycle() -> None:
    assert AXIS_ROW_BYTES == 57 and CYCLE_ROW_BYTES == 16
    rt = Runtime(cycle=0.001)
    for i in range(8):
        rt.add_axis(f"a{i}", v_max=1.0, a_max=1.0)
    tr = rt.trace
    assert tr.row_bytes == 16 + 8 * 57 == 472
    assert tr.max_bytes == TRACE_BYTES == 32 * 2**20
    assert tr.nbytes <= TRACE_BYTES
    # the ring holds what the budget leaves after the edge ring and the staging block
    edges = tr.event_capacity * EVENT_BYTES
    staging = 256 * 8 * len(tr.columns)
    assert tr.rows_capacity == (TRACE_BYTES - edges - staging) // 472 // 256 * 256 == 64_256


@pytest.mark.parametrize("n_axes", [0, 1, 3, 8, 32, 200])
@pytest.mark.parametrize("budget", [64 * 2**10, 300_000, 4 * 2**20, TRACE_BYTES])
def test_storage_bound_holds_for_every_layout(n_axes: int, budget: int) -> None:
    tr = _axis_trace(n_axes, max_bytes=budget)
    assert tr.nbytes <= budget or tr.rows_capacity <= 256  # at least one staging block
    assert tr.rows_capacity >= 1


@settings(max_examples=40, deadline=None)
@given(
    n_float=st.integers(0, 5),
    n_small=st.integers(0, 3),
    capacity=st.integers(1, 3000),
    budget=st.integers(64 * 2**10, 200_000),
    n_rows=st.integers(0, 4000),
    seed=st.integers(0, 2**32 - 1),
)
def test_ring_keeps_the_exact_tail(
    n_float: int, n_small: int, capacity: int, budget: int, n_rows: int, seed: int
) -> None:
    rng = np.random.default_rng(seed)
    tr = Trace(capacity=capacity, max_bytes=budget)
    names = [f"f{i}" for i in range(n_float)] + [f"s{i}" for i in range(n_small)]
    tr.add_columns(names, [np.float64] * n_float + [np.int8] * n_small)
    rows: list[list[float]] = []
    for k in range(n_rows):
        row = [float(k), k * 0.001]
        row += rng.standard_normal(n_float).tolist()
        row += rng.integers(-128, 128, n_small).astype(float).tolist()
        tr.record(row)
        rows.append(row)
    n = len(tr)
    assert tr.dropped_rows + n == n_rows
    assert min(n_rows, tr.rows_capacity) <= n <= min(n_rows, tr.rows_capacity + 256)
    # the row capacity is honoured unless the byte budget cannot hold one more staging block
    # of rows (the ring is a whole number of them; the staging block is float64 per column)
    room = budget - tr.event_capacity * EVENT_BYTES
    stage = tr._plan()[0]
    staging_bytes = stage * 8 * (2 + len(names))
    assert (
        tr.rows_capacity >= capacity
        or (tr.rows_capacity + stage) * tr.row_bytes + staging_bytes > room
    )
    assert tr.nbytes <= budget
    expected = np.array(rows[n_rows - n :], dtype=np.float64).reshape(n, 2 + len(names))
    got = tr.array()
    assert got.dtype == np.float64 and got.tobytes() == expected.tobytes()
    for j, name in enumerate(tr.columns):
        assert tr.column(name).tobytes() == expected[:, j].tobytes()
        if n:
            assert tr.last(name) == expected[-1, j]


def test_csv_of_a_truncated_trace_starts_at_the_first_kept_cycle(tmp_path: Path) -> None:
    tr = _axis_trace(1, capacity=600)
    rows = []
    for k in range(2000):
        row = [k, k * 0.002, math.sin(k), math.cos(k), 0.5, -k * 1e-3, 1.0 / (k + 1), 0.0, 1e-9]
        row.append(float(k % 8))
        tr.record(row)
        rows.append(row)
    path = tmp_path / "t.csv"
    tr.to_csv(path, block_rows=97)  # several blocks, one across the ring's wrap
    with path.open() as fh:
        table = list(csv.reader(fh))
    assert table[0] == list(tr.columns)
    assert len(table) == len(tr) + 1 and int(table[1][0]) == tr.dropped_rows
    for line, row in zip(table[1:], rows[tr.dropped_rows :], strict=True):
        assert [float(x) for x in line] == row  # repr round-trips exactly


def _numpy_bytes(fn) -> tuple[int, int]:
    """(bytes still allocated by the trace module after ``fn()``, peak during it), numpy
    buffers included. What is held is counted from allocations made in ``trace.py`` only, so
    threads left running by other tests cannot disturb it; the peak is process-wide."""
    tracemalloc.start()
    try:
        before = tracemalloc.get_traced_memory()[0]
        tracemalloc.reset_peak()
        keep = fn()
        _, peak = tracemalloc.get_traced_memory()
        snap = tracemalloc.take_snapshot().filter_traces(
            [tracemalloc.Filter(True, trace_module.__file__)]
        )
        held = sum(stat.size for stat in snap.statistics("filename"))
        del keep
    finally:
        tracemalloc.stop()
    return held, peak - before


def test_memory_stays_within_the_budget_far_beyond_it() -> None:
    budget = 2**20
    row = [0.0, 0.0] + [0.25, -1.5, 3.0, 0.0, 0.125, 2.0, 1e-6, 4.0] * 8

    def record(n_rows: int, budget: int = budget):
        def fn() -> Trace:
            tr = _axis_trace(8, max_bytes=budget)
            for k in range(n_rows):
                row[0] = k
                tr.record(row)
            return tr

        return fn

    held, peak = _numpy_bytes(record(40_000))  # 40,000 x 472 B = 18 MB unbounded
    assert held <= budget + 64 * 2**10  # the trace object and its small lists
    # plus one staging block converted (and whatever other threads allocate meanwhile)
    assert peak <= budget + 1024 * 2**10
    # the ring is allocated in ~2 MiB chunks as rows arrive: a short run holds one of them
    # (and the edge ring, 3 MB allocated up front; its pages are touched as edges arrive)
    held_short, _ = _numpy_bytes(record(300, budget=TRACE_BYTES))
    assert held_short < 200_000 * EVENT_BYTES + 2.5 * 2**20 < TRACE_BYTES / 5


def test_runtime_with_a_small_budget_keeps_the_axes_values_exactly() -> None:
    rt = Runtime(cycle=0.001, trace_bytes=96 * 2**10)
    axes = [rt.add_axis(n, v_max=2.0, a_max=8.0, j_max=80.0) for n in ("x", "y")]
    powers = [MC_Power() for _ in axes]
    moves = [MC_MoveAbsolute(buffer_mode=BufferMode.ABORTING) for _ in axes]

    def program(ctx) -> None:
        for ax, pw, mv in zip(axes, powers, moves, strict=True):
            pw(axis=ax, enable=True)
            leg = (ctx.cycle // 700) % 2
            mv(axis=ax, execute=pw.status and ctx.cycle % 700 > 5, position=leg * 0.4, velocity=1)

    seen: list[list[float]] = []
    rt.add_task("main", program)
    rt.add_cycle_hook(
        lambda r, k: seen.append([k, k * r.cycle] + [v for a in axes for v in a.trace_values()])
    )
    rt.run(cycles=6000)
    tr = rt.trace
    assert tr.dropped_rows > 0 and tr.nbytes <= 96 * 2**10
    expected = np.array(seen[len(seen) - len(tr) :])
    assert tr.array().tobytes() == expected.tobytes()
    assert {v for v in tr.column("x.state")} >= {3.0}  # discrete motion recorded
    assert tr.column("cycle")[-1] == 5999


def test_small_integer_column_refuses_what_it_cannot_hold() -> None:
    tr = Trace(max_bytes=64 * 2**10)
    tr.add_columns(["x.position", "x.state"], [np.float64, np.int8])
    with pytest.raises(ValueError, match="x.state"):
        for k in range(2000):
            tr.record([k, 0.0, 1.0, 2.5])
    with pytest.raises(ValueError, match="x.bad.*not supported"):
        Trace().add_columns(["x.bad"], [np.float16])


def test_budget_and_capacity_are_validated() -> None:
    with pytest.raises(ValueError, match="max_bytes must be an integer >= 65536"):
        Trace(max_bytes=1000)
    with pytest.raises(ValueError, match="capacity must be an integer >= 1"):
        Trace(capacity=0)
    with pytest.raises(ValueError, match="event_capacity"):
        Trace(max_bytes=64 * 2**10, event_capacity=10_000)
    with pytest.raises(ValueError, match="max_bytes"):
        Runtime(trace_bytes=10)


def test_fb_edges_are_a_ring_of_their_own() -> None:
    tr = Trace(event_capacity=5)
    for k in range(12):
        tr.event(k, f"x.MC_Move{k % 2}", "busy" if k % 3 else "done", k % 2 == 0)
    evs = tr.events
    assert [e.cycle for e in evs] == [7, 8, 9, 10, 11]
    assert tr.dropped_events == 7
    assert evs[1] == (8, "x.MC_Move0", "busy", True)
    assert type(evs[1].cycle) is int and type(evs[1].value) is bool
    assert tr.edges("x.MC_Move1", "done") == [(9, False)]
    d = tr.digest()
    tr.event(12, "x.MC_Move0", "done", True)
    assert tr.digest() != d and tr.events[-1].cycle == 12
