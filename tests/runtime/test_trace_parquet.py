"""Parquet traces and trace units: ``Trace.to_parquet``, ``Trace.set_units``, the CSV units
sidecar, and ``scope.read_trace`` for both formats (the same arrays bit for bit)."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np
import pyarrow.parquet as pq
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from motionplc.blocks import MC_MoveAbsolute, MC_Power
from motionplc.blocks.enums import AxisState
from motionplc.errors import MotionPlcError
from motionplc.runtime import Runtime
from motionplc.runtime.trace import Trace, axis_units, units_sidecar_path
from motionplc.scope import PlotDependencyError, column_unit, read_trace


def bits(a: np.ndarray) -> np.ndarray:
    return np.ascontiguousarray(a, dtype=np.float64).view(np.uint64)


def small_run(capacity: int = 500_000) -> Runtime:
    """Two axes (x in m, r in rad) moving, one of them to a new target twice; ~1.6 s."""
    rt = Runtime(cycle=0.001, trace_capacity=capacity)
    rt.add_axis("x", 1.0, 4.0, 40.0)
    rt.add_axis("r", 3.0, 10.0, 100.0)
    rt.trace.set_units({**axis_units("x", "m"), **axis_units("r", "rad")})
    fbs = {n: (MC_Power(axis=rt.axes[n], enable=True), MC_MoveAbsolute()) for n in ("x", "r")}

    def program(ctx: object) -> None:
        for n, (pwr, mv) in fbs.items():
            pwr()
            if pwr.status:
                mv(axis=rt.axes[n], execute=True, position=0.3 if n == "x" else 1.5, velocity=0.8)

    rt.add_task("main", program)
    rt.run_until(lambda: all(mv.done for _, mv in fbs.values()), max_seconds=5)
    rt.run(cycles=200)
    return rt


def test_csv_and_parquet_read_back_the_same_arrays(tmp_path: Path) -> None:
    rt = small_run()
    tr = rt.trace
    csv_path, pq_path = tmp_path / "run.csv", tmp_path / "run.parquet"
    tr.to_csv(csv_path, events_path=csv_path.with_suffix(".events.csv"))
    tr.to_parquet(pq_path, events_path=pq_path.with_suffix(".events.parquet"))
    a, b = read_trace(csv_path), read_trace(pq_path)
    assert a.columns == b.columns == list(tr.columns)
    assert np.array_equal(bits(a.data), bits(b.data))  # bit for bit
    assert np.array_equal(bits(b.data), bits(tr.array()))
    assert a.events == b.events == [tuple(e) for e in tr.events] and len(a.events) > 6
    assert a.units == b.units == tr.units
    assert AxisState.DISCRETE_MOTION in b.data[:, b.columns.index("x.state")]
    # units: recorded in the CSV sidecar and the Parquet schema, used for the axis labels
    side = json.loads(units_sidecar_path(csv_path).read_text(encoding="utf-8"))
    assert side == {"units": tr.units}
    assert column_unit(b, "r.acceleration") == "rad/s²" and column_unit(b, "x.jerk") == "m/s³"


def test_parquet_columns_types_and_metadata_read_by_pyarrow(tmp_path: Path) -> None:
    """pyarrow as the reader: CSV column names, exact types, states by name, units."""
    rt = small_run()
    path = tmp_path / "run.parquet"
    rt.trace.to_parquet(path, events_path=tmp_path / "run.events.parquet", block_rows=500)
    table = pq.read_table(path)
    assert table.column_names == list(rt.trace.columns)
    assert pq.ParquetFile(path).metadata.num_row_groups == -(-len(rt.trace) // 500)
    schema = table.schema
    assert str(schema.field("cycle").type) == "int64" and str(schema.field("t").type) == "double"
    assert schema.field("r.velocity").metadata == {b"unit": b"rad/s"}
    names = table.column("x.state").to_pylist()
    assert names[0] == "DISABLED" and "DISCRETE_MOTION" in names and names[-1] == "STANDSTILL"
    meta = json.loads(schema.metadata[b"motionplc"])
    assert meta["units"]["x.following_error"] == "m"
    assert meta["enums"]["x.state"]["STANDSTILL"] == AxisState.STANDSTILL
    for c in ("t", "x.position", "r.actual_velocity"):
        assert np.array_equal(bits(table.column(c).to_numpy()), bits(rt.trace.column(c)))
    assert np.array_equal(table.column("cycle").to_numpy(), rt.trace.column("cycle"))
    ev = pq.read_table(tmp_path / "run.events.parquet").to_pylist()
    assert [tuple(e.values()) for e in ev] == [tuple(e) for e in rt.trace.events]


def test_a_wrapped_ring_writes_the_retained_rows(tmp_path: Path) -> None:
    rt = small_run(capacity=700)
    tr = rt.trace
    assert tr.dropped_rows > 0
    tr.to_parquet(tmp_path / "w.parquet")
    back = read_trace(tmp_path / "w.parquet")
    assert np.array_equal(bits(back.data), bits(tr.array())) and len(back.data) == len(tr)
    assert back.events == []  # no events file asked for


@settings(max_examples=25, deadline=None)
@given(
    values=st.lists(
        st.lists(st.floats(allow_nan=False, width=64), min_size=3, max_size=3),
        min_size=1,
        max_size=40,
    ),
    small=st.lists(st.integers(-128, 127), min_size=40, max_size=40),
)
def test_any_float_round_trips_exactly_through_csv_and_parquet(
    tmp_path_factory: pytest.TempPathFactory, values: list[list[float]], small: list[int]
) -> None:
    d = tmp_path_factory.mktemp("rt")
    tr = Trace()
    tr.add_columns(["a", "b", "c", "k"], [np.float64, np.float64, np.float64, np.int8])
    for i, row in enumerate(values):
        tr.record([i, i * 0.001, *row, small[i]])
    tr.to_csv(d / "t.csv")
    tr.to_parquet(d / "t.parquet")
    a, b = read_trace(d / "t.csv"), read_trace(d / "t.parquet")
    assert np.array_equal(bits(a.data), bits(tr.array()))
    assert np.array_equal(bits(b.data), bits(tr.array()))
    assert not units_sidecar_path(d / "t.csv").exists()  # no units, no sidecar


def test_units_are_checked() -> None:
    tr = Trace()
    tr.add_columns(["x.position"])
    with pytest.raises(ValueError, match=r"set_units: no trace column 'x\.velocity'"):
        tr.set_units({"x.velocity": "m/s"})
    with pytest.raises(ValueError, match=r"set_units: x\.position: not a unit: ''"):
        tr.set_units({"x.position": ""})
    assert tr.units == {}
    with pytest.raises(ValueError, match=r"axis 'x': units: 'mm' \(allowed: m, rad\)"):
        axis_units("x", "mm")
    tr.set_units({"x.position": "rad"})
    assert tr.units == {"x.position": "rad"}


def test_an_old_csv_without_units_reads_and_says_m_or_rad(tmp_path: Path) -> None:
    rt = small_run()
    rt.trace.to_csv(tmp_path / "old.csv")
    units_sidecar_path(tmp_path / "old.csv").unlink()
    old = read_trace(tmp_path / "old.csv")
    assert old.units == {}
    assert column_unit(old, "x.position") == "m or rad"
    assert column_unit(old, "r.velocity") == "m/s or rad/s"
    assert column_unit(old, "t") == "s" and column_unit(old, "x.state") == ""


def test_broken_parquet_and_units_sidecar_are_located_errors(tmp_path: Path) -> None:
    bad = tmp_path / "bad.parquet"
    bad.write_bytes(b"PAR1 this is not parquet")
    with pytest.raises(MotionPlcError, match=r"bad\.parquet: cannot read as Parquet"):
        read_trace(bad)
    import pyarrow as pa

    pq.write_table(pa.table({"a": [1.0], "b": [2.0]}), tmp_path / "other.parquet")
    with pytest.raises(MotionPlcError, match=r"other\.parquet: not a motionplc trace"):
        read_trace(tmp_path / "other.parquet")
    pq.write_table(
        pa.table({"cycle": [0], "t": [0.0], "x.state": ["FLYING"]}), tmp_path / "s.parquet"
    )
    with pytest.raises(MotionPlcError, match=r"s\.parquet: x\.state: not a state name: 'FLYING'"):
        read_trace(tmp_path / "s.parquet")
    rt = small_run()
    rt.trace.to_csv(tmp_path / "u.csv")
    units_sidecar_path(tmp_path / "u.csv").write_text('{"units": {"x.position": 3}}')
    with pytest.raises(MotionPlcError, match=r"u\.units\.json: units\.x\.position: not a unit"):
        read_trace(tmp_path / "u.csv")
    units_sidecar_path(tmp_path / "u.csv").write_text('{"units": ')
    with pytest.raises(MotionPlcError, match=r"u\.units\.json:1:\d+: not valid JSON"):
        read_trace(tmp_path / "u.csv")


def test_without_pyarrow_one_line_names_the_extra(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    rt = small_run()
    rt.trace.to_parquet(tmp_path / "t.parquet")
    for mod in ("pyarrow", "pyarrow.parquet"):
        monkeypatch.setitem(sys.modules, mod, None)  # import raises ImportError
    for call in (
        lambda: rt.trace.to_parquet(tmp_path / "u.parquet"),
        lambda: read_trace(tmp_path / "t.parquet"),
    ):
        with pytest.raises(PlotDependencyError) as info:
            call()
        msg = str(info.value)
        assert "\n" not in msg and "pip install 'motionplc[parquet]'" in msg
        assert msg.startswith("Parquet traces need pyarrow")
