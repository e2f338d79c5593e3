"""The result store of a campaign: Parquet files under ``<output>/results/``, one per finished
task, each written to a temporary name and renamed (a kill never leaves half a file).

A row is kept only while its ``key`` is one of the campaign's scenario keys (a changed
campaign reruns what changed); :meth:`ResultStore.done` tells which scenarios need not run
again; :meth:`ResultStore.table` is the result table, one row per scenario in order.
"""

from __future__ import annotations

import json
import os
import uuid
from pathlib import Path
from typing import Any

__all__ = ["NONDETERMINISTIC", "ResultStore", "table_digest"]

NONDETERMINISTIC = ("wall_s", "worker")
"""Columns that depend on the machine and the run (left out of :func:`table_digest`)."""


def _pa() -> tuple[Any, Any]:
    try:
        import pyarrow as pa
        import pyarrow.parquet as pq
    except ImportError:  # pragma: no cover - the campaign extra installs it
        from motionplc.errors import MotionPlcError

        raise MotionPlcError(
            "campaigns keep their results in Parquet: pip install 'motionplc[campaign]'"
        ) from None
    return pa, pq


class ResultStore:
    def __init__(self, output: str | Path) -> None:
        self.root = Path(output)
        self.results = self.root / "results"

    def write(self, rows: list[dict[str, Any]]) -> Path | None:
        """Persist ``rows`` (one finished task) atomically."""
        if not rows:
            return None
        pa, pq = _pa()
        self.results.mkdir(parents=True, exist_ok=True)
        first = min(r["scenario"] for r in rows)
        name = f"part-{first:07d}-{uuid.uuid4().hex[:8]}.parquet"
        tmp = self.results / f".{name}.tmp"
        pq.write_table(pa.Table.from_pylist(rows), tmp)
        final = self.results / name
        os.replace(tmp, final)
        return final

    def rows(self, keys: dict[int, str] | None = None) -> dict[int, dict[str, Any]]:
        """Stored rows by scenario number (the last written wins); with ``keys`` (scenario ->
        key) only the rows of those scenarios with those keys."""
        _, pq = _pa()
        out: dict[int, dict[str, Any]] = {}
        if not self.results.is_dir():
            return out
        for p in sorted(self.results.glob("part-*.parquet"), key=lambda q: q.stat().st_mtime_ns):
            try:
                part = pq.read_table(p).to_pylist()
            except Exception:  # noqa: BLE001 - an unreadable part is rerun, not fatal
                continue
            for r in part:
                i = r.get("scenario")
                if i is None:
                    continue
                if keys is not None and keys.get(i) != r.get("key"):
                    continue
                out[int(i)] = r
        return out

    def done(self, keys: dict[int, str]) -> set[int]:
        return set(self.rows(keys))

    def table(self, keys: dict[int, str]) -> list[dict[str, Any]]:
        """The result table: one row per stored scenario, by scenario number, every column
        present in every row (None where a row has none)."""
        rows = self.rows(keys)
        cols: list[str] = []
        seen: set[str] = set()
        for i in sorted(rows):
            for c in rows[i]:
                if c not in seen:
                    seen.add(c)
                    cols.append(c)
        return [{c: rows[i].get(c) for c in cols} for i in sorted(rows)]

    def write_table(self, table: list[dict[str, Any]], name: str = "results.parquet") -> Path:
        pa, pq = _pa()
        self.root.mkdir(parents=True, exist_ok=True)
        path = self.root / name
        tmp = self.root / f".{name}.tmp"
        pq.write_table(pa.Table.from_pylist(table), tmp)
        os.replace(tmp, path)
        return path


def table_digest(table: list[dict[str, Any]]) -> str:
    """SHA-256 of the result table without the machine-dependent columns (wall time, worker):
    equal digests, equal results bit for bit (floats by their exact repr)."""
    import hashlib

    h = hashlib.sha256()
    for row in table:
        kept = {k: v for k, v in row.items() if k not in NONDETERMINISTIC}
        h.update(json.dumps(kept, sort_keys=True, default=repr).encode())
        h.update(b"\n")
    return h.hexdigest()
