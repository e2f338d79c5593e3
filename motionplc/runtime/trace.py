"""Per-cycle trace recorder with bounded memory, numpy access and CSV export."""

from __future__ import annotations

import csv
import hashlib
from collections import deque
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import NamedTuple

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


class TraceEvent(NamedTuple):
    """An FB output edge: in ``cycle`` the output ``output`` of ``fb`` became ``value``."""

    cycle: int
    fb: str
    output: str
    value: bool


class Trace:
    """Rows of floats, one per recorded cycle, stored in fixed-size numpy chunks.

    The most recent ``capacity`` rows are always kept; older chunks are dropped, so memory stays
    below ``capacity`` + 2 chunks (a long run keeps its most recent part). FB output edges are
    kept in a bounded deque of ``event_capacity``.
    """

    def __init__(
        self,
        capacity: int = 500_000,
        chunk_rows: int = 4096,
        event_capacity: int = 200_000,
        formatters: dict[str, Callable[[float], str]] | None = None,
    ) -> None:
        if capacity < 1:
            raise ValueError(f"trace capacity must be >= 1 row, got {capacity}")
        self.capacity = capacity
        self._chunk_rows = max(1, min(chunk_rows, capacity))
        self._columns: list[str] = ["cycle", "t"]
        self._index: dict[str, int] = {"cycle": 0, "t": 1}
        self._chunks: deque[np.ndarray] = deque()
        self._fill = self._chunk_rows  # rows used in the last chunk (full: allocate on record)
        self._dropped = 0
        self.events: deque[TraceEvent] = deque(maxlen=event_capacity)
        self._formatters = dict(formatters or {})
        self._frozen = False

    # -- layout ----------------------------------------------------------------------------
    def add_columns(self, names: Sequence[str]) -> None:
        """Declare more columns (only before the first row)."""
        if self._frozen:
            raise RuntimeError("trace columns cannot change after recording started")
        for n in names:
            if n in self._index:
                raise ValueError(f"duplicate trace column {n!r}")
            self._index[n] = len(self._columns)
            self._columns.append(n)

    def set_formatter(self, column: str, fmt: Callable[[float], str]) -> None:
        """How a column is written to CSV (e.g. state code -> state name)."""
        self._formatters[column] = fmt

    @property
    def columns(self) -> tuple[str, ...]:
        """Column names in storage order."""
        return tuple(self._columns)

    # -- recording -------------------------------------------------------------------------
    def record(self, row: Sequence[float]) -> None:
        """Append one row (its length must equal the number of columns)."""
        if self._fill == self._chunk_rows:
            self._frozen = True
            self._chunks.append(np.empty((self._chunk_rows, len(self._columns))))
            self._fill = 0
            if (len(self._chunks) - 2) * self._chunk_rows >= self.capacity:
                self._chunks.popleft()
                self._dropped += self._chunk_rows
        self._chunks[-1][self._fill] = row
        self._fill += 1

    def event(self, cycle: int, fb: str, output: str, value: bool) -> None:
        """Record an FB output edge."""
        self.events.append(TraceEvent(cycle, fb, output, value))

    # -- access ----------------------------------------------------------------------------
    def __len__(self) -> int:
        if not self._chunks:
            return 0
        return (len(self._chunks) - 1) * self._chunk_rows + self._fill

    @property
    def dropped_rows(self) -> int:
        """Rows discarded because of the capacity bound."""
        return self._dropped

    def array(self) -> np.ndarray:
        """All retained rows as one 2-D array (a copy)."""
        if not self._chunks:
            return np.empty((0, len(self._columns)))
        parts = list(self._chunks)
        parts[-1] = parts[-1][: self._fill]
        return np.concatenate(parts, axis=0)

    def column(self, name: str) -> np.ndarray:
        """One column over the retained rows, e.g. ``trace.column("x.velocity")``."""
        try:
            i = self._index[name]
        except KeyError:
            raise KeyError(
                f"no trace column {name!r}; columns: {', '.join(self._columns)}"
            ) from None
        if not self._chunks:
            return np.empty(0)
        parts = [c[:, i] for c in self._chunks]
        parts[-1] = parts[-1][: self._fill]
        return np.concatenate(parts)

    def last(self, name: str) -> float:
        """Value of a column in the most recent row."""
        if not self._chunks:
            raise IndexError("the trace is empty")
        return float(self._chunks[-1][self._fill - 1, self._index[name]])

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

    def to_csv(self, path: str | Path, events_path: str | Path | None = None) -> None:
        """Write the rows (and, optionally, the FB edges) as CSV files."""
        data = self.array()
        fmts = [self._formatters.get(c) for c in self._columns]
        with open(path, "w", newline="") as f:
            w = csv.writer(f)
            w.writerow(self._columns)
            for row in data:
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
