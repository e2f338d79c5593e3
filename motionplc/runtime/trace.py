"""Per-cycle trace recorder with a byte budget, columnar numpy storage and CSV export.

Memory bound (documented, checked by ``tests/runtime/test_trace_memory.py``):

* a row holds ``cycle`` (int64, 8 B) and ``t`` (float64, 8 B), and per axis seven float64
  columns (set position, velocity, acceleration, jerk, actual position, actual velocity,
  following error: 56 B) and the PLCopen state (int8, 1 B): **57 B per axis per cycle plus
  16 B per cycle** (8 axes: 472 B per cycle, against 528 B as float64 rows);
* the trace never holds more than ``max_bytes`` (default :data:`TRACE_BYTES` = 32 MiB) of
  samples: a ring buffer keeps the most recent cycles — ``min(capacity, rows that fit)`` of
  them (8 axes: 64,256 cycles = 64 s at 1 ms; 1 axis: 418,048; the row ``capacity``, 500,000
  by default, binds first only for a trace without axes) — and drops the oldest (``dropped_rows``
  counts them; ``rows_capacity`` and ``nbytes`` tell the figures for a layout). The budget
  includes a float64 staging block (the hot path writes one row into it; a full block of 256
  rows is converted column by column into the ring) and the FB-edge ring (15 B per edge,
  ``event_capacity`` edges, 200,000 = 3 MB by default). The ring is allocated in chunks of
  about 2 MiB as rows arrive, so a short run costs only what it records and a long one holds
  the bound without copying (``tools/bench_runtime.py --rss-cycles 1000000``: 8 axes stay
  near 70 MB resident).

Values are stored exactly: the float columns stay float64, and a small-integer column is
checked to convert without loss (anything else raises ``ValueError`` naming the column), so
``array()``, ``column()``, ``digest()`` and ``to_csv()`` give the same numbers (and bytes) as a
trace of plain float64 rows.

Units: :meth:`Trace.set_units` records the SI unit of columns (:func:`axis_units` gives those of
an axis in m or rad). ``to_csv`` writes them to a sidecar ``<stem>.units.json`` next to the CSV
(the CSV itself stays plain: old readers are not affected), ``to_parquet`` into the Parquet
schema (per field ``unit`` and the schema key ``motionplc``). A trace without units writes no
sidecar; readers then label axes with "m or rad".
"""

from __future__ import annotations

import csv
import hashlib
import json
from collections.abc import Callable, Iterator, Mapping, Sequence
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np

AXIS_FIELDS = (
    "position",  # commanded (set) position
    "velocity",
    "acceleration",
    "jerk",
    "actual_position",
    "actual_velocity",
    "following_error",
    "state",  # AxisState value
)
# storage type of each axis field (the state is an AxisState value 0..7)
AXIS_DTYPES: tuple[type[np.generic], ...] = (np.float64,) * 7 + (np.int8,)

# an axes group records its GroupState and its path speed
GROUP_DTYPES: tuple[type[np.generic], ...] = (np.int8, np.float64)

TRACE_BYTES = 32 * 2**20
"""Default byte budget of a trace (rows, staging block and FB edges)."""

MIN_TRACE_BYTES = 64 * 2**10

CYCLE_ROW_BYTES = 16
"""Bytes per recorded cycle besides the axes: ``cycle`` (int64) and ``t`` (float64)."""

AXIS_ROW_BYTES = sum(np.dtype(d).itemsize for d in AXIS_DTYPES)
"""Bytes per axis per recorded cycle (57: seven float64 columns and the int8 state)."""

EVENT_BYTES = 15
"""Bytes per FB output edge: cycle (int64), FB id (int32), output id (int16), value (bool)."""

EVENT_CAPACITY = 200_000
"""Default number of FB edges kept (fewer if they would take more than 1/8 of the budget)."""

UNITS_SUFFIX = ".units.json"
"""Suffix of the units sidecar of a trace CSV (``out/demo.csv`` -> ``out/demo.units.json``)."""

PARQUET_META_KEY = b"motionplc"
"""Parquet schema metadata key: JSON ``{"format": 1, "units": {...}, "enums": {...}}``."""

_DERIVATIVE_SUFFIXES = ("", "/s", "/s²", "/s³")


def axis_units(axis: str, length_unit: str = "m") -> dict[str, str]:
    """The units of the trace columns of ``axis`` when its positions are in ``length_unit``.

    ``length_unit`` is ``"m"`` or ``"rad"`` (the YAML ``units`` of the axis); otherwise
    ``ValueError`` names it. Positions and the following error get ``length_unit``, velocities
    ``length_unit/s``, acceleration ``/s²``, jerk ``/s³``; the state has no unit.
    """
    if length_unit not in ("m", "rad"):
        raise ValueError(f"axis {axis!r}: units: {length_unit!r} (allowed: m, rad)")
    u = length_unit
    d = [u + s for s in _DERIVATIVE_SUFFIXES]
    return {
        f"{axis}.position": d[0],
        f"{axis}.velocity": d[1],
        f"{axis}.acceleration": d[2],
        f"{axis}.jerk": d[3],
        f"{axis}.actual_position": d[0],
        f"{axis}.actual_velocity": d[1],
        f"{axis}.following_error": d[0],
    }


def units_sidecar_path(csv_path: str | Path) -> Path:
    """The units sidecar of a trace CSV: ``<trace stem>.units.json`` in the same directory."""
    return Path(csv_path).with_suffix(UNITS_SUFFIX)


_STAGING_ROWS = 256
_CHUNK_BYTES = 2 * 2**20  # ring chunks stay below numpy's huge-page threshold (4 MiB)

_ALLOWED_DTYPES = {
    np.dtype(np.float64),
    np.dtype(np.int64),
    np.dtype(np.int32),
    np.dtype(np.int16),
    np.dtype(np.int8),
    np.dtype(np.uint8),
    np.dtype(np.bool_),
}


class TraceEvent(NamedTuple):
    """An FB output edge: in ``cycle`` the output ``output`` of ``fb`` became ``value``."""

    cycle: int
    fb: str
    output: str
    value: bool


class Trace:
    """Rows of numbers, one per recorded cycle, in a columnar ring buffer of bounded bytes.

    ``capacity``: at most this many rows are kept; ``max_bytes``: the samples and FB edges
    never take more than this many bytes (the ring keeps fewer rows if they do not fit; at
    least one). The most recent rows are always the ones kept. Columns ``cycle`` (int64) and
    ``t`` (float64) come first; more are declared with :meth:`add_columns` (float64 unless a
    dtype is given) before the first row. FB output edges are kept in a ring of
    ``event_capacity`` (the oldest dropped first).
    """

    def __init__(
        self,
        capacity: int = 500_000,
        max_bytes: int = TRACE_BYTES,
        event_capacity: int | None = None,
        formatters: dict[str, Callable[[float], str]] | None = None,
    ) -> None:
        if isinstance(capacity, bool) or not isinstance(capacity, int) or capacity < 1:
            raise ValueError(f"trace capacity must be an integer >= 1 row, got {capacity!r}")
        if (
            isinstance(max_bytes, bool)
            or not isinstance(max_bytes, int)
            or max_bytes < (MIN_TRACE_BYTES)
        ):
            raise ValueError(
                f"trace max_bytes must be an integer >= {MIN_TRACE_BYTES} (64 KiB), "
                f"got {max_bytes!r}"
            )
        if event_capacity is None:
            event_capacity = min(EVENT_CAPACITY, max_bytes // 8 // EVENT_BYTES)
        if (
            isinstance(event_capacity, bool)
            or not isinstance(event_capacity, int)
            or not 1 <= event_capacity <= max_bytes // (2 * EVENT_BYTES)
        ):
            raise ValueError(
                f"trace event_capacity must be an integer in [1, {max_bytes // (2 * EVENT_BYTES)}]"
                f" (half of max_bytes = {max_bytes} at {EVENT_BYTES} B per edge), "
                f"got {event_capacity!r}"
            )
        self.capacity = capacity
        self.max_bytes = max_bytes
        self.event_capacity = event_capacity
        self._columns: list[str] = ["cycle", "t"]
        self._dtypes: list[np.dtype] = [np.dtype(np.int64), np.dtype(np.float64)]
        self._index: dict[str, int] = {"cycle": 0, "t": 1}
        self._formatters = dict(formatters or {})
        self._units: dict[str, str] = {}
        self._frozen = False
        # row storage (allocated by _freeze): float64 staging block + one 2-D ring per dtype
        self._stage = np.empty((0, 0))
        self._stage_bytes = memoryview(bytearray())
        self._stage_rows = 0
        self._fill = 0  # rows in the staging block
        self._ring_rows = 0
        self._chunk_rows = 0
        self._groups: list[tuple[np.dtype, np.ndarray]] = []  # (dtype, its columns)
        self._where: list[tuple[int, int]] = []  # column -> (group, row in the group's arrays)
        # the ring: chunks of _chunk_rows slots, one (group columns x rows) array per group
        self._chunks: list[list[np.ndarray]] = []
        self._pos = 0  # next ring slot
        self._count = 0  # rows in the ring
        self._dropped = 0
        # FB edges: one ring of columns; names interned
        self._ev_cycle = np.empty(event_capacity, np.int64)
        self._ev_fb = np.empty(event_capacity, np.int32)
        self._ev_out = np.empty(event_capacity, np.int16)
        self._ev_val = np.empty(event_capacity, np.bool_)
        self._ev_total = 0  # edges recorded since the start (the ring holds the last ones)
        self._fb_ids: dict[str, int] = {}
        self._fb_names: list[str] = []
        self._out_ids: dict[str, int] = {}
        self._out_names: list[str] = []
        self._ev_cache: tuple[int, tuple[TraceEvent, ...]] = (0, ())

    # -- layout ----------------------------------------------------------------------------
    def add_columns(
        self, names: Sequence[str], dtypes: Sequence[type[np.generic] | np.dtype] | None = None
    ) -> None:
        """Declare more columns (only before the first row), float64 unless ``dtypes`` say.

        ``dtypes``: one per name; float64, int8/16/32/64, uint8 or bool. A value recorded
        in a column that its dtype cannot hold exactly raises ``ValueError``.
        """
        if self._frozen:
            raise RuntimeError("trace columns cannot change after recording started")
        names = list(names)
        kinds = [np.dtype(np.float64)] * len(names) if dtypes is None else list(dtypes)
        if len(kinds) != len(names):
            raise ValueError(f"add_columns: {len(kinds)} dtypes for {len(names)} names")
        for n, d in zip(names, kinds, strict=True):
            dt = np.dtype(d)
            if dt not in _ALLOWED_DTYPES:
                raise ValueError(
                    f"trace column {n!r}: dtype {dt} not supported "
                    f"(allowed: {', '.join(sorted(str(a) for a in _ALLOWED_DTYPES))})"
                )
            if n in self._index:
                raise ValueError(f"duplicate trace column {n!r}")
            self._index[n] = len(self._columns)
            self._columns.append(n)
            self._dtypes.append(dt)

    def set_formatter(self, column: str, fmt: Callable[[float], str]) -> None:
        """How a column is written to CSV (e.g. state code -> state name)."""
        self._formatters[column] = fmt

    def set_units(self, units: Mapping[str, str]) -> None:
        """Record the unit of declared columns (``{"x.position": "m", ...}``; any time).

        A column that is not declared or a unit that is not a non-empty one-line string raises
        ``ValueError`` naming it; nothing is recorded then.
        """
        checked = {}
        for column, unit in units.items():
            if column not in self._index:
                raise ValueError(
                    f"set_units: no trace column {column!r}; columns: {', '.join(self._columns)}"
                )
            if not isinstance(unit, str) or not unit.strip() or "\n" in unit:
                raise ValueError(f"set_units: {column}: not a unit: {unit!r}")
            checked[column] = unit.strip()
        self._units.update(checked)

    @property
    def units(self) -> dict[str, str]:
        """The recorded units, column -> unit (a copy; columns without a unit are absent)."""
        return dict(self._units)

    @property
    def columns(self) -> tuple[str, ...]:
        """Column names in storage order."""
        return tuple(self._columns)

    @property
    def row_bytes(self) -> int:
        """Bytes one recorded row takes in the ring (the sum of its columns' item sizes)."""
        return sum(d.itemsize for d in self._dtypes)

    @property
    def rows_capacity(self) -> int:
        """How many of the most recent rows the ring keeps (fixed by the first row).

        ``len(trace)`` is between this (once recorded) and this plus the staging block.
        """
        return self._ring_rows if self._frozen else self._plan()[1]

    @property
    def nbytes(self) -> int:
        """Bytes of sample storage (staging block, row ring, edge ring): <= ``max_bytes``.

        This is the bound; the ring's chunks are allocated as rows arrive.
        """
        stage, ring, _ = self._plan()
        return stage * 8 * len(self._columns) + ring * self.row_bytes + self._event_bytes()

    def _event_bytes(self) -> int:
        return self.event_capacity * EVENT_BYTES

    def _plan(self) -> tuple[int, int, int]:
        """(staging rows S, ring rows R, chunk rows C) within the budget; R and C multiples of S."""
        ncols = len(self._columns)
        rb = self.row_bytes
        budget = self.max_bytes - self._event_bytes()
        stage = max(1, min(_STAGING_ROWS, budget // 16 // (8 * ncols)))
        fit = (budget - stage * 8 * ncols) // rb
        stage = max(1, min(stage, fit))
        want = -(-self.capacity // stage) * stage  # capacity rounded up to whole blocks
        ring = max(stage, min(want, fit // stage * stage))
        chunk = max(stage, min(ring, _CHUNK_BYTES // rb // stage * stage))
        return stage, ring, chunk

    def _freeze(self) -> None:
        # built aside and marked frozen last: a Ctrl-C in the middle leaves the trace as it
        # was (unfrozen, rebuilt at the next row), never frozen without its column map
        plan = self._plan()
        stage = np.empty((plan[0], len(self._columns)))
        by_type: dict[np.dtype, list[int]] = {}
        for i, d in enumerate(self._dtypes):
            by_type.setdefault(d, []).append(i)
        where = [(0, 0)] * len(self._columns)
        groups = []
        for g, (d, cols) in enumerate(by_type.items()):
            groups.append((d, np.array(cols, dtype=np.intp)))
            for r, c in enumerate(cols):
                where[c] = (g, r)
        self._stage_rows, self._ring_rows, self._chunk_rows = plan
        self._stage = stage
        self._stage_bytes = memoryview(stage).cast("B")  # for struct.pack_into
        self._where = where
        self._groups = groups
        self._frozen = True

    def _chunk_size(self, k: int) -> int:
        return min(self._chunk_rows, self._ring_rows - k * self._chunk_rows)

    # -- recording -------------------------------------------------------------------------
    def record(self, row: Sequence[float]) -> None:
        """Append one row (its length must equal the number of columns)."""
        if self._fill == self._stage_rows:
            if not self._frozen:
                self._freeze()
            else:
                self._flush()
        self._stage[self._fill] = row
        self._fill += 1

    def reserve_row(self) -> tuple[memoryview, int]:
        """Append one row to be written in place: returns the staging block's bytes and the
        byte offset of the row (native float64, one per column in :attr:`columns` order).

        The caller must fill the whole row (e.g. with ``struct.pack_into``) before anything
        else touches the trace; the values are stored exactly as :meth:`record` stores them
        (float64 staging, the same exact conversion into the ring)."""
        if self._fill == self._stage_rows:
            if not self._frozen:
                self._freeze()
            else:
                self._flush()
        i = self._fill
        self._fill = i + 1
        return self._stage_bytes, i * 8 * len(self._columns)

    def unreserve_row(self) -> None:
        """Take back the row of the last :meth:`reserve_row` (its filling was interrupted, e.g.
        by Ctrl-C in the middle of a cycle): the trace never holds a half-written row."""
        self._fill -= 1

    def _flush(self) -> None:
        """Move the full staging block into the ring (column by column, exact conversion)."""
        m = self._fill
        k, off = divmod(self._pos, self._chunk_rows)
        if k == len(self._chunks):  # the ring grows chunk by chunk up to its size
            size = self._chunk_size(k)
            self._chunks.append([np.empty((len(cols), size), d) for d, cols in self._groups])
        chunk = self._chunks[k]
        staged = self._stage.T  # (columns, rows) view
        for (d, cols), dest in zip(self._groups, chunk, strict=True):
            src = staged[cols]
            part = dest[:, off : off + m]
            part[...] = src  # a small-integer group casts here: checked right after
            if d.kind != "f" and (part != src).any():
                bad = int(np.argmax((part != src).any(axis=1)))
                name = self._columns[int(cols[bad])]
                raise ValueError(f"trace column {name!r} ({d}) cannot hold the value recorded")
        n = self._ring_rows
        self._dropped += max(0, self._count + m - n)
        self._count = min(n, self._count + m)
        self._pos = (self._pos + m) % n
        self._fill = 0

    def event(self, cycle: int, fb: str, output: str, value: bool) -> None:
        """Record an FB output edge."""
        f = self._fb_ids.get(fb)
        if f is None:
            f = self._fb_ids[fb] = len(self._fb_names)
            self._fb_names.append(fb)
        o = self._out_ids.get(output)
        if o is None:
            o = self._out_ids[output] = len(self._out_names)
            self._out_names.append(output)
        i = self._ev_total % self.event_capacity
        self._ev_cycle[i] = cycle
        self._ev_fb[i] = f
        self._ev_out[i] = o
        self._ev_val[i] = value
        self._ev_total += 1

    # -- access ----------------------------------------------------------------------------
    def __len__(self) -> int:
        return self._count + self._fill

    @property
    def dropped_rows(self) -> int:
        """Rows discarded because of the capacity or byte bound (the oldest ones)."""
        return self._dropped

    @property
    def dropped_events(self) -> int:
        """FB edges discarded because of ``event_capacity`` (the oldest ones)."""
        return max(0, self._ev_total - self.event_capacity)

    def _segments(self, r0: int, r1: int) -> Iterator[tuple[list[np.ndarray], int, int, int]]:
        """Ring rows ``r0:r1`` (0 = the oldest) as runs (chunk, start, stop, offset in r0:r1)."""
        n = self._ring_rows
        base = self._pos if self._count == n else 0
        i = r0
        while i < r1:
            k, off = divmod((base + i) % n, self._chunk_rows)
            m = min(r1 - i, self._chunk_size(k) - off)
            yield self._chunks[k], off, off + m, i - r0
            i += m

    def _rows(self, start: int, stop: int) -> np.ndarray:
        """Retained rows ``start:stop`` (0 = the oldest) as a float64 2-D array."""
        out = np.empty((max(0, stop - start), len(self._columns)))
        if not self._frozen or stop <= start:
            return out
        r0, r1 = min(start, self._count), min(stop, self._count)
        for chunk, a, b, o in self._segments(r0, r1):
            for (_d, cols), arr in zip(self._groups, chunk, strict=True):
                out[o : o + b - a, cols] = arr[:, a:b].T
        s0, s1 = max(start, self._count), stop
        if s1 > s0:
            out[s0 - start :] = self._stage[s0 - self._count : s1 - self._count]
        return out

    def array(self) -> np.ndarray:
        """All retained rows as one float64 2-D array (a copy)."""
        return self._rows(0, len(self))

    def column(self, name: str) -> np.ndarray:
        """One column over the retained rows (float64), e.g. ``trace.column("x.velocity")``."""
        try:
            i = self._index[name]
        except KeyError:
            raise KeyError(
                f"no trace column {name!r}; columns: {', '.join(self._columns)}"
            ) from None
        if not self._frozen:
            return np.empty(0)
        g, r = self._where[i]
        parts = [chunk[g][r, a:b] for chunk, a, b, _ in self._segments(0, self._count)]
        parts.append(self._stage[: self._fill, i])
        return np.concatenate(parts, dtype=np.float64)

    def last(self, name: str) -> float:
        """Value of a column in the most recent row."""
        if not len(self):
            raise IndexError("the trace is empty")
        i = self._index[name]
        if self._fill:
            return float(self._stage[self._fill - 1, i])
        g, r = self._where[i]
        k, off = divmod((self._pos - 1) % self._ring_rows, self._chunk_rows)
        return float(self._chunks[k][g][r, off])

    @property
    def events(self) -> tuple[TraceEvent, ...]:
        """The retained FB output edges, oldest first (materialised; cached until the next)."""
        total, cached = self._ev_cache
        if total == self._ev_total:
            return cached
        cap = self.event_capacity
        n = min(self._ev_total, cap)
        start = self._ev_total - n
        idx = (np.arange(start, self._ev_total) % cap) if n else np.empty(0, np.intp)
        fbs, outs = self._fb_names, self._out_names
        evs = tuple(
            TraceEvent(c, fbs[f], outs[o], v)
            for c, f, o, v in zip(
                self._ev_cycle[idx].tolist(),
                self._ev_fb[idx].tolist(),
                self._ev_out[idx].tolist(),
                self._ev_val[idx].tolist(),
                strict=True,
            )
        )
        self._ev_cache = (self._ev_total, evs)
        return evs

    def edges(self, fb: str, output: str) -> list[tuple[int, bool]]:
        """``(cycle, value)`` of every recorded edge of one FB output."""
        return [(e.cycle, e.value) for e in self.events if e.fb == fb and e.output == output]

    def digest(self) -> str:
        """SHA-256 of the retained rows and events (bit-exact determinism checks)."""
        h = hashlib.sha256()
        h.update(",".join(self._columns).encode())
        h.update(np.ascontiguousarray(self.array()).tobytes())
        for e in self.events:
            h.update(repr(tuple(e)).encode())
        return h.hexdigest()

    def to_csv(
        self, path: str | Path, events_path: str | Path | None = None, block_rows: int = 8192
    ) -> None:
        """Write the rows (and, optionally, the FB edges) as CSV files.

        Rows are converted ``block_rows`` at a time, so writing needs little memory beyond
        the trace itself. A trace with units (:meth:`set_units`) also writes them to
        ``<stem>.units.json`` next to ``path`` (``{"units": {column: unit}}``).
        """
        fmts = [self._formatters.get(c) for c in self._columns]
        n = len(self)
        with open(path, "w", newline="") as f:
            w = csv.writer(f)
            w.writerow(self._columns)
            for start in range(0, n, block_rows):
                for row in self._rows(start, min(n, start + block_rows)):
                    w.writerow(
                        [
                            str(int(x)) if i == 0 else (fm(x) if fm else repr(float(x)))
                            for i, (x, fm) in enumerate(zip(row, fmts, strict=True))
                        ]
                    )
        if events_path is not None:
            with open(events_path, "w", newline="") as f:
                w = csv.writer(f)
                w.writerow(TraceEvent._fields)
                w.writerows(self.events)
        if self._units:
            units_sidecar_path(path).write_text(
                json.dumps({"units": self._units}, indent=2, ensure_ascii=False) + "\n",
                encoding="utf-8",
            )

    def to_parquet(
        self, path: str | Path, events_path: str | Path | None = None, block_rows: int = 65_536
    ) -> None:
        """Write the rows (and, optionally, the FB edges) as Parquet files (needs pyarrow).

        Column names are those of the CSV. Numbers keep their storage type (float64 exactly,
        ``cycle`` int64, small-integer columns their integer type); a column with a formatter
        (the axis and group states) is stored dictionary-encoded by name, as in the CSV, and
        its name -> value table is kept in the schema metadata. Units go into each field's
        metadata (``unit``) and, with the enums, into the schema metadata key ``motionplc``
        (JSON). Rows are written ``block_rows`` at a time (one row group each). Events: columns
        ``cycle``, ``fb``, ``output``, ``value``. Without pyarrow raises
        :class:`motionplc.scope.PlotDependencyError` naming the pip extra.
        """
        pa, pq = _pyarrow()
        n = len(self)
        names = self._columns
        enums: dict[str, dict[str, int]] = {}
        fields = []
        for i, (c, d) in enumerate(zip(names, self._dtypes, strict=True)):
            meta = {b"unit": self._units[c].encode()} if c in self._units else None
            fm = self._formatters.get(c)
            if fm is not None:
                codes = np.unique(self.column(c)).astype(np.int64) if n else np.empty(0, np.int64)
                enums[c] = {fm(float(k)): int(k) for k in codes}
                typ = pa.dictionary(pa.int32(), pa.string())
            else:
                typ = pa.from_numpy_dtype(np.dtype(np.int64) if i == 0 else d)
            fields.append(pa.field(c, typ, metadata=meta))
        info = {"format": 1, "units": self._units, "enums": enums}
        schema = pa.schema(fields, metadata={PARQUET_META_KEY: json.dumps(info).encode()})
        dictionaries = {c: pa.array(list(e), pa.string()) for c, e in enums.items()}
        lookup = {c: np.array(list(e.values()), np.int64) for c, e in enums.items()}
        with pq.ParquetWriter(str(path), schema) as writer:
            for start in range(0, max(n, 1), block_rows):
                rows = self._rows(start, min(n, start + block_rows))
                arrays = []
                for i, (c, d) in enumerate(zip(names, self._dtypes, strict=True)):
                    col = rows[:, i]
                    if c in lookup:
                        order = np.argsort(lookup[c])
                        pos = order[np.searchsorted(lookup[c], col.astype(np.int64), sorter=order)]
                        arrays.append(
                            pa.DictionaryArray.from_arrays(
                                pa.array(pos.astype(np.int32)), dictionaries[c]
                            )
                        )
                    else:
                        arrays.append(pa.array(col.astype(np.int64 if i == 0 else d)))
                writer.write_table(pa.Table.from_arrays(arrays, schema=schema))
        if events_path is not None:
            evs = self.events
            table = pa.table(
                {
                    "cycle": pa.array([e.cycle for e in evs], pa.int64()),
                    "fb": pa.array([e.fb for e in evs], pa.string()).dictionary_encode(),
                    "output": pa.array([e.output for e in evs], pa.string()).dictionary_encode(),
                    "value": pa.array([e.value for e in evs], pa.bool_()),
                }
            )
            pq.write_table(table, str(events_path))


def _pyarrow() -> tuple[Any, Any]:
    """``(pyarrow, pyarrow.parquet)``; a missing pyarrow is a one-line error naming the extra."""
    try:
        import pyarrow as pa
        import pyarrow.parquet as pq
    except ImportError:
        from motionplc.scope import PlotDependencyError

        raise PlotDependencyError(
            "Parquet traces need pyarrow: pip install 'motionplc[parquet]' (or write a .csv trace)"
        ) from None
    return pa, pq
