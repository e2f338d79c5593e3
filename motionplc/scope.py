"""The PLC scope: a trace drawn as an interactive HTML page (plotly) or a PNG (matplotlib).

The scope is a grid of cards, at most :data:`MAX_GRID_COLUMNS` grid columns wide (an axis card
one column, a group card two, groups first); more axes wrap into further rows of the same size,
so a card reads the same from 1 to 16 axes, and the first row (lanes included) fits a 1600 x
1000 window. A group that was never enabled (GROUP_DISABLED throughout, no FB of it) gets no
card; the title names it. Per axis, one card of lanes over a common time axis: position
(commanded and actual overlaid), velocity (commanded and actual), acceleration, jerk, following
error, and a lane of rows for the PLCopen axis state (coloured spans, each named once where it
fits; the colours in the legend) and one row per function block instance (Busy/Active/Valid
spans, Done/Error/CommandAborted marks from the FB edge events). Every y-axis names its
quantity and unit ("position [m]"; [rad] for a rotary axis), taken from the trace's units
(``*.units.json`` next to a CSV, the schema of a Parquet file, ``Trace.units`` of a live
runtime); a trace without units says "m or rad". Per axes group (when the trace has groups): the
group's path in space coloured by its path speed (XY for two axes, XY and XZ side by side for
three or more; equal aspect, start and end marked, a colour scale in its own room right of
them), the path speed over time and the group state and FB lanes.

The HTML page is self-contained (plotly.js inlined, it opens offline): every time axis is linked
(zoom or pan one, all follow; scroll zooms; double-click resets), a unified hover cursor reads
every channel of a column at one time, a legend click hides or shows a channel (legend groups
per axis). Traces longer than ``2 * max_points`` rows are decimated for display by
:func:`minmax_indices` (per channel the first, lowest and highest sample of each of
``max_points`` buckets, so peaks survive); the title says so. Group paths are thinned by
:func:`decimate_path`, which keeps corners and the speed extremes.

:func:`read_trace` reads a trace ``.csv`` (``motionplc run --trace``; FB edges from the
``*.events.csv``, units from ``*.units.json``, group membership from ``*.groups.json``, see
:func:`write_groups_sidecar`) or ``.parquet`` (``Trace.to_parquet``; edges from
``*.events.parquet``); :func:`trace_from_runtime` takes the same data from a live runtime;
:func:`write_plot` draws a trace, :func:`write_series_plot` any time series (``motionplc plan``).
plotly, matplotlib and pyarrow are imported only when needed; a missing one raises
:class:`PlotDependencyError` with a one-line message naming the pip extra.

Trace columns of a group ``g``: ``g.path_velocity`` (path speed, >= 0) and ``g.state`` (a
:class:`~motionplc.blocks.enums.GroupState`; in the CSV by member name, e.g. ``GROUP_MOVING``).
Without ``g.path_velocity`` the scope uses the Euclidean norm of the member axes' commanded
velocities (the path speed of the identity Cartesian mapping) and says so; without ``g.state``
the group gets no state row.
"""

from __future__ import annotations

import csv
import json
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from motionplc.errors import MotionPlcError

MAX_PATH_SEGMENTS = 20_000
# Bounds of what `plot` reads (a hostile or broken trace gets one located line, fast, in
# bounded memory): the columns of a trace, the size of a JSON sidecar and of an edge file.
MAX_TRACE_COLUMNS = 10_000
MAX_SIDECAR_BYTES = 4 * 1024 * 1024
MAX_EVENT_ROWS = 5_000_000
MAX_TRACE_LINE = 1 << 20  # bytes in one CSV line (10_000 columns of numbers fit)
"""Default bound on the line segments drawn per path view (see :func:`decimate_path`)."""

MAX_POINTS = 2_000
"""Default display buckets per channel (about one per pixel column of a wide lane)."""

GROUPS_SUFFIX = ".groups.json"
"""Suffix of the group sidecar of a trace CSV (``out/demo.csv`` -> ``out/demo.groups.json``)."""

UNKNOWN_LENGTH = "m or rad"
"""The position unit shown for a trace that does not record its units (older CSVs)."""

HTML_DIV_ID = "motionplc-scope"
"""The id of the plot's ``<div>`` in the HTML page (fixed: the same trace gives the same page)."""


class PlotDependencyError(MotionPlcError):
    """An optional package (matplotlib, plotly or pyarrow) is missing; the message is one line
    naming the pip extra that installs it."""


Event = tuple[int, str, str, bool]
"""One FB output edge: (cycle, FB label ``axis.fb``, output name, new value)."""


@dataclass(frozen=True, slots=True)
class ScopeTrace:
    """What the scope draws: the trace columns, one row per cycle, the FB edges, the groups and
    the units.

    ``data`` is a float array (rows x columns; states as their enum values); ``groups`` maps a
    group name to its member axes in order (empty when the trace has no groups); ``units`` maps
    a column to its unit (``{"x.position": "m", ...}``; empty when the trace has none).
    """

    columns: list[str]
    data: Any
    events: list[Event]
    groups: dict[str, list[str]] = field(default_factory=dict)
    units: dict[str, str] = field(default_factory=dict)


def _plotly() -> tuple[Any, Any]:
    """``(plotly.graph_objects, plotly.io)`` or a one-line :class:`PlotDependencyError`."""
    try:
        import plotly.graph_objects as go
        import plotly.io as pio
    except ImportError:
        raise PlotDependencyError(
            "the interactive HTML scope needs plotly: pip install 'motionplc[plot]'"
        ) from None
    return go, pio


def _pyplot() -> Any:
    """``matplotlib.pyplot`` on the Agg backend or a one-line :class:`PlotDependencyError`."""
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        raise PlotDependencyError(
            "plotting a PNG needs matplotlib: pip install 'motionplc[plot]' "
            "(or write an .html plot)"
        ) from None
    return plt


def _pyarrow() -> tuple[Any, Any]:
    """``(pyarrow, pyarrow.parquet)`` or a one-line :class:`PlotDependencyError`."""
    try:
        import pyarrow as pa
        import pyarrow.parquet as pq
    except ImportError:
        raise PlotDependencyError(
            "Parquet traces need pyarrow: pip install 'motionplc[parquet]' (or use a .csv trace)"
        ) from None
    return pa, pq


def _reason(exc: Exception) -> str:
    return str(getattr(exc, "strerror", None) or exc)


# ---------------------------------------------------------------------------- groups sidecar
def groups_sidecar_path(csv_path: str | Path) -> Path:
    """The group sidecar of a trace CSV: ``<trace stem>.groups.json`` in the same directory."""
    return Path(csv_path).with_suffix(GROUPS_SUFFIX)


def _checked_groups(obj: Any, where: str) -> dict[str, list[str]]:
    """``{"groups": {name: [axis, ...]}}`` checked; errors name ``where`` and the key path."""
    if not isinstance(obj, dict):
        raise MotionPlcError(f'{where}: expected an object {{"groups": {{...}}}}')
    unknown = sorted(set(obj) - {"groups"})
    if unknown:
        raise MotionPlcError(f"{where}: {unknown[0]}: unknown key (allowed: groups)")
    groups = obj.get("groups", {})
    if not isinstance(groups, dict):
        raise MotionPlcError(f"{where}: groups: expected an object {{name: [axis, ...]}}")
    out: dict[str, list[str]] = {}
    for name, members in groups.items():
        if not isinstance(name, str) or not name or "." in name:
            raise MotionPlcError(f"{where}: groups.{name}: not a group name (no '.', not empty)")
        if isinstance(members, str) or not isinstance(members, list | tuple) or not members:
            raise MotionPlcError(
                f"{where}: groups.{name}: expected a non-empty list of axis names, got {members!r}"
            )
        for k, m in enumerate(members):
            if not isinstance(m, str) or not m or "." in m:
                raise MotionPlcError(f"{where}: groups.{name}[{k}]: not an axis name: {m!r}")
        if len(set(members)) != len(members):
            raise MotionPlcError(f"{where}: groups.{name}: an axis is listed twice: {members}")
        out[name] = list(members)
    return out


def write_groups_sidecar(csv_path: str | Path, groups: Mapping[str, Sequence[str]]) -> Path:
    """Write ``{"groups": {name: [axis, ...]}}`` next to the trace CSV; returns its path.

    Call it after ``Trace.to_csv(csv_path)``; :func:`read_trace` picks it up. Group and axis
    names are non-empty and contain no ``.``, a group lists each axis once; otherwise
    :class:`MotionPlcError` names the group. An empty mapping writes an empty ``groups``.
    """
    path = groups_sidecar_path(csv_path)
    plain = {"groups": {name: list(members) for name, members in groups.items()}}
    checked = _checked_groups(plain, str(path))
    path.write_text(json.dumps({"groups": checked}, indent=2) + "\n", encoding="utf-8")
    return path


def read_groups_sidecar(csv_path: str | Path) -> dict[str, list[str]]:
    """The groups of a trace CSV from its sidecar; ``{}`` when there is no sidecar.

    A sidecar that cannot be read, is not JSON or has the wrong shape raises
    :class:`MotionPlcError` located at the sidecar (``file:line:column`` for JSON syntax).
    """
    path = groups_sidecar_path(csv_path)
    if not path.exists():
        return {}
    return _checked_groups(_read_json(path), str(path))


def _read_json(path: Path) -> Any:
    """A JSON sidecar, at most ``MAX_SIDECAR_BYTES``; every failure one located line."""
    try:
        with path.open("rb") as fh:
            raw = fh.read(MAX_SIDECAR_BYTES + 1)
        if len(raw) > MAX_SIDECAR_BYTES:
            raise MotionPlcError(
                f"{path}: more than {MAX_SIDECAR_BYTES // 1048576} MB (allowed: at most that)"
            )
        text = raw.decode("utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise MotionPlcError(
            f"{path}: cannot read: {getattr(exc, 'strerror', None) or exc}"
        ) from None
    try:
        return json.loads(text)
    except json.JSONDecodeError as exc:
        raise MotionPlcError(
            f"{path}:{exc.lineno}:{exc.colno}: not valid JSON: {exc.msg}"
        ) from None
    except RecursionError:
        raise MotionPlcError(f"{path}:1: not valid JSON: nested too deeply") from None


# ---------------------------------------------------------------------------- units sidecar
def read_units_sidecar(csv_path: str | Path) -> dict[str, str]:
    """The units of a trace CSV from ``<stem>.units.json``; ``{}`` when there is none.

    A sidecar that cannot be read, is not JSON or is not ``{"units": {column: unit}}`` raises
    :class:`MotionPlcError` located at the sidecar.
    """
    from motionplc.runtime.trace import units_sidecar_path

    path = units_sidecar_path(csv_path)
    if not path.exists():
        return {}
    return _checked_units(_read_json(path), str(path))


def _checked_units(obj: Any, where: str) -> dict[str, str]:
    if not isinstance(obj, dict) or set(obj) - {"units"}:
        raise MotionPlcError(f'{where}: expected an object {{"units": {{column: unit}}}}')
    units = obj.get("units", {})
    if not isinstance(units, dict):
        raise MotionPlcError(f"{where}: units: expected an object {{column: unit}}")
    for k, v in units.items():
        if not isinstance(v, str) or not v:
            raise MotionPlcError(f"{where}: units.{k}: not a unit: {v!r}")
    return dict(units)


def _length_unit(units: Mapping[str, str], axis: str) -> str | None:
    """The position unit of ``axis`` as recorded (``None`` when the trace does not say)."""
    return units.get(f"{axis}.position") or units.get(f"{axis}.actual_position")


def _derived_unit(length: str | None, order: int) -> str:
    """The unit of the ``order``-th time derivative of a position in ``length`` (or unknown)."""
    suffix = ("", "/s", "/s²", "/s³")[order]
    if length is None:
        return " or ".join(u + suffix for u in ("m", "rad")) if order else UNKNOWN_LENGTH
    return length + suffix


_FIELD_ORDER = {
    "position": 0,
    "actual_position": 0,
    "following_error": 0,
    "velocity": 1,
    "actual_velocity": 1,
    "acceleration": 2,
    "jerk": 3,
    "path_velocity": 1,
}


def column_unit(trace: ScopeTrace, column: str) -> str:
    """The unit of a trace column: as recorded in the trace, else derived from the position
    unit of its axis (velocity: position unit per second, ...), else "m or rad" forms; ``s``
    for ``t`` and ``""`` for columns without a unit (cycle, states)."""
    if column in trace.units:
        return trace.units[column]
    if column == "t":
        return "s"
    owner, _, fld = column.rpartition(".")
    if fld not in _FIELD_ORDER:
        return ""
    if owner in trace.groups:
        lengths = {_length_unit(trace.units, m) for m in trace.groups[owner]}
        length = lengths.pop() if len(lengths) == 1 else None
    else:
        length = _length_unit(trace.units, owner)
    return _derived_unit(length, _FIELD_ORDER[fld])


# ---------------------------------------------------------------------------- reading
def trace_from_runtime(rt: Any) -> ScopeTrace:
    """The scope data of a runtime's trace ring (the cycles it still holds).

    The groups come from ``rt.groups`` (``{name: group}`` with ``group.axis_names``) when the
    runtime has them; groups without member names are left out. Units from ``rt.trace.units``.
    """
    import numpy as np

    columns = list(rt.trace.columns)
    data = np.asarray(rt.trace.array(), dtype=float)
    events = [(int(e.cycle), e.fb, e.output, bool(e.value)) for e in rt.trace.events]
    groups: dict[str, list[str]] = {}
    for name, group in (getattr(rt, "groups", None) or {}).items():
        members = [str(m) for m in (getattr(group, "axis_names", None) or ())]
        if members:
            groups[str(name)] = members
    units = dict(getattr(rt.trace, "units", None) or {})
    return ScopeTrace(columns, data, events, groups, units)


def _state_names() -> dict[str, float]:
    from motionplc.blocks import AxisState
    from motionplc.blocks.enums import GroupState

    states = {s.name: float(s.value) for s in AxisState}
    states.update({s.name: float(s.value) for s in GroupState})
    return states


def read_trace(path: Path) -> ScopeTrace:
    """Read a trace ``.csv`` or ``.parquet`` and what lies next to it (edges, groups, units).

    CSV (``motionplc run --trace``): FB edges from ``*.events.csv``, units from
    ``*.units.json`` (absent in older traces: then none). Parquet (``Trace.to_parquet``): edges
    from ``*.events.parquet``, units from the schema. Both: groups from ``*.groups.json``. Axis
    states (``STANDSTILL``) and group states (``GROUP_MOVING``) are read by name; the values of
    both formats are the same float64 numbers bit for bit. Raises :class:`MotionPlcError`
    located at ``file:line`` (CSV) or ``file: column`` for anything that is not a trace, at the
    sidecar for a broken one or a group whose member axis has no columns in the trace, and
    :class:`PlotDependencyError` for a Parquet file without pyarrow.
    """
    path = Path(path)
    if path.suffix.lower() == ".parquet":
        columns, data, events, units = _read_parquet(path)
    else:
        columns, data, events = _read_csv(path)
        units = read_units_sidecar(path)
    groups = read_groups_sidecar(path)
    axes = [c[: -len(".position")] for c in columns if c.endswith(".position")]
    for name, members in groups.items():
        for m in members:
            if m not in axes:
                raise MotionPlcError(
                    f"{groups_sidecar_path(path)}: groups.{name}: axis {m!r} has no columns in "
                    f"{path.name} (its axes: {', '.join(axes) or 'none'})"
                )
    return ScopeTrace(columns, data, events, groups, units)


def _check_lines(path: Path) -> None:
    """No line of ``path`` is longer than ``MAX_TRACE_LINE`` bytes (a scan in blocks, at C
    speed, before any parser builds a line), else one located error."""
    line, since = 1, 0
    try:
        with path.open("rb") as fh:
            while block := fh.read(1 << 23):
                start = 0
                while (nl := block.find(b"\n", start)) >= 0:
                    if since + nl - start > MAX_TRACE_LINE:
                        break
                    line, since, start = line + 1, 0, nl + 1
                since += len(block) - start
                if since > MAX_TRACE_LINE or nl >= 0:
                    raise MotionPlcError(
                        f"{path}:{line}: a line of more than {MAX_TRACE_LINE} bytes (allowed: "
                        f"at most that; not a trace?)"
                    )
    except OSError as exc:
        raise MotionPlcError(f"{path}: cannot read: {_reason(exc)}") from None


def _read_csv(path: Path) -> tuple[list[str], Any, list[Event]]:
    states = _state_names()
    _check_lines(path)
    try:
        with path.open(newline="", encoding="utf-8") as fh:
            reader = csv.reader(fh)
            columns = next(reader, [])
            first = next(reader, None)
    except (OSError, UnicodeDecodeError, csv.Error) as exc:
        raise MotionPlcError(f"{path}:1: cannot read: {_reason(exc)}") from None
    if columns[:2] != ["cycle", "t"]:
        raise MotionPlcError(f"{path}:1: not a motionplc trace (expected columns cycle, t, ...)")
    if len(columns) > MAX_TRACE_COLUMNS:
        raise MotionPlcError(
            f"{path}:1: {len(columns)} columns (allowed: at most {MAX_TRACE_COLUMNS})"
        )
    data = None
    if first is not None and len(first) == len(columns):
        data = _load_numbers(path, columns, first, states)
    if data is None:  # slow and exact: every value checked, the first bad one located
        data = _parse_rows(path, columns, states)
    return columns, data, _read_events(path.with_suffix(".events.csv"))


def _read_events(ev_path: Path) -> list[Event]:
    """The FB edges of ``*.events.csv`` (cycle, fb, output, value), row by row; a row that is
    not one is located."""
    events: list[Event] = []
    if not ev_path.is_file():
        return events
    _check_lines(ev_path)
    try:
        with ev_path.open(newline="", encoding="utf-8") as fh:
            reader = csv.reader(fh)
            next(reader, None)
            for line, row in enumerate(reader, 2):
                if len(row) != 4 or not row[0].isdigit() or len(row[0]) > 18:
                    raise MotionPlcError(
                        f"{ev_path}:{line}: not an FB edge (allowed: cycle, fb, output, "
                        f"True|False; got {len(row)} values)"
                    )
                if len(events) >= MAX_EVENT_ROWS:
                    raise MotionPlcError(
                        f"{ev_path}:{line}: more than {MAX_EVENT_ROWS} FB edges (allowed: at "
                        "most that many)"
                    )
                events.append((int(row[0]), row[1], row[2], row[3] == "True"))
    except (OSError, UnicodeDecodeError, csv.Error) as exc:
        raise MotionPlcError(f"{ev_path}: cannot read: {_reason(exc)}") from None
    return events


def _read_parquet(path: Path) -> tuple[list[str], Any, list[Event], dict[str, str]]:
    import numpy as np

    from motionplc.runtime.trace import PARQUET_META_KEY

    pa, pq = _pyarrow()
    try:
        table = pq.read_table(str(path))
    except (OSError, pa.ArrowException) as exc:
        raise MotionPlcError(f"{path}: cannot read as Parquet: {_reason(exc)}") from None
    columns = list(table.column_names)
    if columns[:2] != ["cycle", "t"]:
        raise MotionPlcError(f"{path}: not a motionplc trace (expected columns cycle, t, ...)")
    try:
        meta = json.loads((table.schema.metadata or {}).get(PARQUET_META_KEY, b"{}"))
    except (json.JSONDecodeError, UnicodeDecodeError) as exc:
        raise MotionPlcError(f"{path}: schema metadata 'motionplc' is not JSON: {exc}") from None
    units = {
        f.name: f.metadata[b"unit"].decode()
        for f in table.schema
        if f.metadata and b"unit" in f.metadata
    }
    units.update(_checked_units({"units": meta.get("units", {})}, f"{path}: metadata"))
    states = _state_names()
    out = np.empty((table.num_rows, len(columns)))
    for j, (name, col) in enumerate(zip(columns, table.columns, strict=True)):
        if col.null_count:
            raise MotionPlcError(f"{path}: {name}: {col.null_count} missing values")
        typ = col.type
        if pa.types.is_dictionary(typ) or pa.types.is_string(typ):
            table_ = {
                **states,
                **{k: float(v) for k, v in meta.get("enums", {}).get(name, {}).items()},
            }
            parts = []
            for chunk in col.chunks:
                if pa.types.is_dictionary(typ):  # decode the dictionary, not every row
                    names, codes = chunk.dictionary.to_pylist(), chunk.indices.to_numpy()
                else:
                    uniq, codes = np.unique(
                        chunk.to_numpy(zero_copy_only=False).astype(str), return_inverse=True
                    )
                    names = uniq.tolist()
                bad = [str(u) for u in names if u not in table_]
                if bad:
                    raise MotionPlcError(f"{path}: {name}: not a state name: {bad[0]!r}")
                lut = np.array([table_[u] for u in names], dtype=float)
                parts.append(lut[codes] if len(lut) else np.empty(0))
            out[:, j] = np.concatenate(parts) if parts else np.empty(0)
        elif pa.types.is_integer(typ) or pa.types.is_floating(typ) or pa.types.is_boolean(typ):
            out[:, j] = col.to_numpy().astype(float)
        else:
            raise MotionPlcError(f"{path}: {name}: unsupported column type {typ}")
    events: list[Event] = []
    ev_path = path.with_suffix(".events.parquet")
    if ev_path.is_file():
        try:
            ev = pq.read_table(str(ev_path)).to_pydict()
            events = [
                (int(c), str(f), str(o), bool(v))
                for c, f, o, v in zip(ev["cycle"], ev["fb"], ev["output"], ev["value"], strict=True)
            ]
        except (OSError, KeyError, pa.ArrowException) as exc:
            raise MotionPlcError(f"{ev_path}: not an FB edge table: {_reason(exc)}") from None
    return columns, out, events, units


def _load_numbers(
    path: Path, columns: list[str], first: list[str], states: dict[str, float]
) -> Any:
    """The values of a well-formed trace at numpy speed; ``None`` on anything unusual."""
    import warnings

    import numpy as np

    def state_or_number(x: str) -> float:
        return states[x] if x in states else float(x)

    conv = {j: state_or_number for j, x in enumerate(first) if x in states}
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            data = np.loadtxt(
                path, delimiter=",", skiprows=1, comments=None, converters=conv, ndmin=2
            )
    except (ValueError, UserWarning, OSError):
        return None
    return data if data.shape[1] == len(columns) else None


def _parse_rows(path: Path, columns: list[str], states: dict[str, float]) -> Any:
    """Every row checked as it is read (a bad row is located without reading further; memory:
    the good rows' values, in blocks of floats)."""
    import numpy as np

    n = len(columns)
    blocks: list[Any] = []
    block = np.empty((4096, n))
    k = 0
    try:
        with path.open(newline="", encoding="utf-8") as fh:
            reader = csv.reader(fh)
            next(reader, None)
            for line, row in enumerate(reader, 2):
                if len(row) != n:
                    raise MotionPlcError(f"{path}:{line}: {len(row)} values for {n} columns")
                for j, x in enumerate(row):
                    try:
                        block[k, j] = states[x] if x in states else float(x)
                    except ValueError:
                        raise MotionPlcError(
                            f"{path}:{line}: {columns[j]}: not a number: {x[:40]!r}"
                        ) from None
                k += 1
                if k == len(block):
                    blocks.append(block)
                    block, k = np.empty((4096, n)), 0
    except (OSError, UnicodeDecodeError, csv.Error) as exc:
        raise MotionPlcError(f"{path}: cannot read: {_reason(exc)}") from None
    blocks.append(block[:k])
    return np.concatenate(blocks) if len(blocks) > 1 else blocks[0]


# ---------------------------------------------------------------------------- decimation
def decimate_path(points: Any, speed: Any, max_segments: int = MAX_PATH_SEGMENTS) -> Any:
    """Indices of the samples to draw a path with at most ``max_segments`` line segments.

    ``points`` is (n, d) (or (n,)), ``speed`` has n values. Guarantees:

    * the result is strictly increasing, starts at 0 and ends at n - 1, and has at most
      ``max_segments`` + 1 entries; when n - 1 <= ``max_segments`` it is every sample;
    * otherwise the samples are cut into ``max_segments // 4`` buckets of consecutive samples
      (sizes differing by at most one); every bucket boundary is kept, and in each bucket the
      sample farthest from the chord between its boundaries (in all d dimensions, so in every
      projection) and the samples of lowest and highest speed;
    * hence a corner whose direction change happens at one sample (an exact-stop corner or a
      polyline vertex) is drawn exactly where it is the only one in its bucket (corners more
      than one bucket, about 4 (n - 1) / ``max_segments`` samples, apart), and the overall
      fastest and slowest samples are vertices of the drawing (the colour scale of a drawing
      coloured by the speed at each segment's first vertex reaches the true maximum unless it
      occurs only at the last sample).

    Curved stretches are drawn as chords between kept samples; nothing bounds that deviation
    beyond the bucket size. Raises ``ValueError`` for mismatched lengths or ``max_segments < 4``.
    """
    import numpy as np

    p = np.asarray(points, dtype=float)
    if p.ndim == 1:
        p = p[:, None]
    v = np.asarray(speed, dtype=float).reshape(-1)
    if p.ndim != 2 or len(v) != len(p):
        raise ValueError(
            f"decimate_path: speed: one value per point needed ({len(v)} speeds for "
            f"{len(p)} points of shape {p.shape})"
        )
    if int(max_segments) < 4:
        raise ValueError(f"decimate_path: max_segments: {max_segments} (allowed: >= 4)")
    n = len(p)
    if n - 1 <= max_segments:
        return np.arange(n)
    nb = int(max_segments) // 4
    bounds = np.round(np.linspace(0, n - 1, nb + 1)).astype(np.int64)  # spacing >= 4
    starts, ends = bounds[:-1] + 1, bounds[1:]  # interior samples [start, end)
    width = int(np.max(ends - starts))
    idx = starts[:, None] + np.arange(width)[None, :]
    valid = idx < ends[:, None]
    idx_c = np.minimum(idx, n - 1)
    rows = np.arange(nb)
    a = p[bounds[:-1]][:, None, :]
    u = (p[bounds[1:]] - p[bounds[:-1]])[:, None, :]
    uu = np.sum(u * u, axis=-1)
    w = p[idx_c] - a
    s = np.clip(np.sum(w * u, axis=-1) / np.where(uu > 0, uu, 1.0), 0.0, 1.0)
    dist2 = np.sum((w - s[..., None] * u) ** 2, axis=-1)
    far = idx[rows, np.argmax(np.where(valid, dist2, -1.0), axis=1)]
    vv = v[idx_c]
    fast = idx[rows, np.argmax(np.where(valid, vv, -np.inf), axis=1)]
    slow = idx[rows, np.argmin(np.where(valid, vv, np.inf), axis=1)]
    return np.unique(np.concatenate([bounds, far, fast, slow]))


# ---------------------------------------------------------------------------- display decimation
def minmax_indices(values: Any, buckets: int = MAX_POINTS) -> Any:
    """Indices of the samples that draw ``values`` on ``buckets`` pixel columns, peaks kept.

    Guarantees: the result is strictly increasing, starts at 0 and ends at n - 1; when
    n <= 2 * ``buckets`` it is every sample; otherwise the samples are cut into at most
    ``buckets`` runs of equal length (the last may be shorter) and from each the first, the
    lowest and the highest sample are kept (at most 3 * ``buckets`` + 1 indices), so the drawn
    line reaches every extreme of the full signal in every bucket. NaN samples count neither
    as lowest nor as highest. Raises ``ValueError`` for ``buckets < 1`` or a non-1-D input.
    """
    import numpy as np

    y = np.asarray(values, dtype=float)
    if y.ndim != 1:
        raise ValueError(f"minmax_indices: values: one-dimensional array needed, got {y.shape}")
    if isinstance(buckets, bool) or int(buckets) < 1:
        raise ValueError(f"minmax_indices: buckets: {buckets} (allowed: >= 1)")
    n = len(y)
    if n <= 2 * int(buckets):
        return np.arange(n)
    size = -(-n // int(buckets))
    nb = -(-n // size)
    padded = np.concatenate([y, np.full(nb * size - n, np.nan)]).reshape(nb, size)
    nan = np.isnan(padded)
    base = np.arange(nb) * size
    lo = base + np.argmin(np.where(nan, np.inf, padded), axis=1)
    hi = base + np.argmax(np.where(nan, -np.inf, padded), axis=1)
    idx = np.unique(np.concatenate([base, lo, hi, [n - 1]]))
    return idx[idx < n]


# ---------------------------------------------------------------------------- lanes
_SIGNAL_COLORS = {
    "position": "#1f77b4",
    "velocity": "#1f77b4",
    "acceleration": "#2ca02c",
    "jerk": "#9467bd",
    "actual_position": "#ff7f0e",
    "actual_velocity": "#ff7f0e",
    "following_error": "#d62728",
    "path_velocity": "#1f77b4",
}

_AXIS_ROWS: tuple[tuple[str, tuple[str, ...], float], ...] = (
    ("position", ("position", "actual_position"), 1.1),
    ("velocity", ("velocity", "actual_velocity"), 1.0),
    ("acceleration", ("acceleration",), 0.8),
    ("jerk", ("jerk",), 0.6),
    ("following error", ("following_error",), 0.7),
)
"""Value lanes of an axis column: (quantity, trace fields drawn in it, relative height)."""

_LANE_ROW_WEIGHT = 0.13
"""Relative height of one state/FB row."""

_LANE_COLORS = {
    "busy": "#c6dbef",
    "active": "#2171b5",
    "valid": "#74c476",
    "status": "#238b45",
    "in_velocity": "#6a51a3",
    "done": "#000000",
    "error": "#d62728",
    "command_aborted": "#ff7f0e",
}
_BAR_OUTPUTS = ("busy", "valid", "status", "active", "in_velocity")  # drawn in this order
_BAR_HEIGHT = {"busy": 0.8, "valid": 0.8, "status": 0.5, "active": 0.45, "in_velocity": 0.25}
_MARKS = {"done": "|", "error": "x", "command_aborted": "v"}
_MARK_SYMBOLS = {"done": "line-ns", "error": "x-thin", "command_aborted": "triangle-down"}

_AXIS_STATE_COLORS = (  # AxisState value order: DISABLED .. ERROR_STOP
    "#d9d9d9",
    "#a1d99b",
    "#fdd0a2",
    "#9ecae1",
    "#bcbddc",
    "#c7e9c0",
    "#fdae6b",
    "#d62728",
)

_GROUP_STATE_COLORS = {  # GroupState value -> colour, matching the axis state lane's colours
    0: "#d9d9d9",  # GROUP_DISABLED (axis DISABLED)
    1: "#a1d99b",  # GROUP_STANDBY (axis STANDSTILL)
    2: "#fdd0a2",  # GROUP_HOMING (axis HOMING)
    3: "#9ecae1",  # GROUP_MOVING (axis DISCRETE_MOTION)
    4: "#fdae6b",  # GROUP_STOPPING (axis STOPPING)
    5: "#d62728",  # GROUP_ERROR_STOP (axis ERROR_STOP)
}


def _state_table(kind: str) -> dict[int, tuple[str, str]]:
    """State value -> (name, colour) of the axis (``"axis"``) or group state enum."""
    from motionplc.blocks import AxisState
    from motionplc.blocks.enums import GroupState

    if kind == "axis":
        return {
            int(s.value): (s.name, _AXIS_STATE_COLORS[i % len(_AXIS_STATE_COLORS)])
            for i, s in enumerate(AxisState)
        }
    return {
        int(s.value): (s.name, _GROUP_STATE_COLORS.get(int(s.value), "grey")) for s in GroupState
    }


Span = tuple[str, float, float]
"""An FB output span (output, t_from, t_to); t_from == t_to for a Done/Error/Aborted mark."""


@dataclass(frozen=True, slots=True)
class _Column:
    """One column of lanes: an axis (value lanes) or a group (path view and path speed)."""

    name: str
    kind: str  # "axis" or "group"
    title: str
    signals: dict[str, Any]  # field -> values over the trace's time (present ones only)
    units: dict[str, str]  # field -> unit
    state: Any  # state values or None
    fbs: dict[str, list[Span]]
    members: tuple[str, ...] = ()
    positions: Any = None  # group: (n, d) member positions
    speed_derived: bool = False
    member_units: tuple[str, ...] = ()  # group: the position unit of each member
    colour_speed: Any = None  # group: the speed that colours the path view (velocity norm)

    def lane_labels(self) -> list[str]:
        return [("state" if self.state is not None else "(no state)"), *self.fbs]

    def projections(self) -> list[tuple[int, int]]:
        """Member index pairs drawn: XY for two axes, XY and XZ for three or more, none for one."""
        d = len(self.members)
        return [] if d < 2 else [(0, 1)] if d == 2 else [(0, 1), (0, 2)]


def _colour_speed(col: _Column) -> Any:
    """The speed that colours a group's path view: the members' velocity norm if known."""
    return col.colour_speed if col.colour_speed is not None else col.signals["path_velocity"]


def _columns(trace: ScopeTrace) -> tuple[Any, list[_Column]]:
    """The time vector and the columns of the scope: the groups first, then the axes."""
    import numpy as np

    data = np.asarray(trace.data, dtype=float)
    if data.ndim != 2 or data.shape[1] != len(trace.columns):
        raise MotionPlcError(
            f"trace data: {data.shape} does not match {len(trace.columns)} columns"
        )
    cols = {c: i for i, c in enumerate(trace.columns)}
    t, t0, c0, dt, t_end = _time_base(data)
    t_end += dt if len(t) else 0.0
    axes = [c[: -len(".position")] for c in trace.columns if c.endswith(".position")]
    axes = [a for a in axes if "." not in a]
    member_of = {m: g for g, ms in trace.groups.items() for m in ms}
    out: list[_Column] = []
    for name, members in trace.groups.items():
        pos = np.column_stack([data[:, cols[f"{m}.position"]] for m in members])
        derived = f"{name}.path_velocity" not in cols
        vcols = [cols[f"{m}.velocity"] for m in members if f"{m}.velocity" in cols]
        norm = np.sqrt(np.sum(data[:, vcols] ** 2, axis=1)) if vcols else None
        if derived:
            speed = norm if norm is not None else np.zeros(len(t))
        else:
            speed = data[:, cols[f"{name}.path_velocity"]]
        # the path view is coloured by the speed of the members' motion (their velocity norm):
        # it is the group's path speed while the group moves, and it also shows the members
        # moving on their own (single-axis or synchronised moves, the group standing by)
        colour = norm if norm is not None else speed
        state = data[:, cols[f"{name}.state"]] if f"{name}.state" in cols else None
        out.append(
            _Column(
                name=name,
                kind="group",
                title=f"group {name}: {', '.join(members)}",
                signals={"path_velocity": speed},
                units={"path_velocity": column_unit(trace, f"{name}.path_velocity")},
                state=state,
                fbs=_fb_intervals(name, trace.events, t0, c0, dt, t_end),
                members=tuple(members),
                positions=pos,
                speed_derived=derived,
                colour_speed=colour,
                member_units=tuple(column_unit(trace, f"{m}.position") for m in members),
            )
        )
    for ax in axes:
        fields = [f for _, fs, _ in _AXIS_ROWS for f in fs]
        signals = {f: data[:, cols[f"{ax}.{f}"]] for f in fields if f"{ax}.{f}" in cols}
        group = f" (group {member_of[ax]})" if ax in member_of else ""
        out.append(
            _Column(
                name=ax,
                kind="axis",
                title=f"axis {ax}{group}",
                signals=signals,
                units={f: column_unit(trace, f"{ax}.{f}") for f in fields},
                state=data[:, cols[f"{ax}.state"]] if f"{ax}.state" in cols else None,
                fbs=_fb_intervals(ax, trace.events, t0, c0, dt, t_end),
                members=(ax,),
            )
        )
    return t, out


def _fb_intervals(
    prefix: str, events: list[Event], t0: float, c0: int, dt: float, t_end: float
) -> dict[str, list[tuple[str, float, float]]]:
    """FB lanes of the FBs labelled ``prefix.<fb>``: (output, t_from, t_to) per FB."""
    fbs: dict[str, list[tuple[str, float, float]]] = {}
    open_: dict[tuple[str, str], float] = {}
    for cyc, fb, output, value in events:
        if not fb.startswith(prefix + "."):
            continue
        label = fb[len(prefix) + 1 :]
        tt = t0 + (cyc - c0) * dt
        lst = fbs.setdefault(label, [])
        if output in ("busy", "active", "valid", "status", "in_velocity"):
            if value:
                open_[(label, output)] = tt
            elif (label, output) in open_:
                lst.append((output, open_.pop((label, output)), tt))
        elif output in ("done", "error", "command_aborted") and value:
            lst.append((output, tt, tt))
    for (label, output), ts in open_.items():
        fbs.setdefault(label, []).append((output, ts, t_end))
    return fbs


def _time_base(data: Any) -> tuple[Any, float, int, float, float]:
    t = data[:, 1] if len(data) else data
    cycles = data[:, 0] if len(data) else data
    t0 = float(t[0]) if len(t) else 0.0
    dt = float(t[1] - t[0]) if len(t) > 1 else 0.001
    c0 = int(cycles[0]) if len(cycles) else 0
    t_end = float(t[-1]) if len(t) else 0.0
    return t, t0, c0, dt, t_end


def _runs(state: Any) -> list[tuple[int, int]]:
    """(first, next) index pairs of the runs of equal values (``next`` is len for the last)."""
    import numpy as np

    n = len(state)
    if n == 0:
        return []
    cuts = (np.flatnonzero(np.asarray(state)[1:] != np.asarray(state)[:-1]) + 1).tolist()
    return list(zip([0, *cuts], [*cuts, n], strict=True))


def _state_spans(t: Any, state: Any, max_spans: int) -> list[tuple[int, float, float]]:
    """(state value, t_from, t_to) of the runs of equal state (the last one ends one cycle after
    the last sample); when there are more than ``max_spans`` runs, those of the state sampled
    at ``max_spans`` evenly spaced rows (short blips may then be missing)."""
    import numpy as np

    n = len(t)
    if n == 0 or state is None:
        return []
    dt = float(t[1] - t[0]) if n > 1 else 0.001
    runs = _runs(state)
    if len(runs) > max_spans:
        rows = np.unique(np.linspace(0, n - 1, max_spans).round().astype(int))
        sub = _runs(np.asarray(state)[rows])
        runs = [(int(rows[a]), int(rows[b]) if b < len(rows) else n) for a, b in sub]
    return [
        (int(state[a]), float(t[a]), float(t[b]) if b < n else float(t[-1]) + dt) for a, b in runs
    ]


def _merged(spans: list[tuple[float, float]], gap: float) -> list[tuple[float, float]]:
    """Spans sorted and joined where they are less than ``gap`` apart (display decimation)."""
    out: list[tuple[float, float]] = []
    for a, b in sorted(spans):
        if out and a - out[-1][1] <= gap:
            out[-1] = (out[-1][0], max(out[-1][1], b))
        else:
            out.append((a, b))
    return out


def _fb_display(
    fbs: Mapping[str, list[Span]], gap: float
) -> tuple[dict[str, list[tuple[int, float, float]]], dict[str, list[tuple[int, float]]]]:
    """Bars per output (row, t_from, t_to) and marks per output (row, t), rows from 1, with
    bars closer than ``gap`` joined and at most one mark per output, row and ``gap``."""
    bars: dict[str, list[tuple[int, float, float]]] = {}
    marks: dict[str, list[tuple[int, float]]] = {}
    for row, (_fb, spans) in enumerate(fbs.items(), start=1):
        by_out: dict[str, list[tuple[float, float]]] = {}
        for output, ta, tb in spans:
            by_out.setdefault(output, []).append((ta, tb))
        for output, items in by_out.items():
            if output in _MARKS:
                seen: set[int] = set()
                for ta, _tb in sorted(items):
                    k = int(ta // gap) if gap > 0 else 0
                    if k not in seen:
                        seen.add(k)
                        marks.setdefault(output, []).append((row, ta))
            else:
                bars.setdefault(output, []).extend((row, a, b) for a, b in _merged(items, gap))
    return bars, marks


def _fb_status_text(spans: list[Span], grid: Any) -> list[str]:
    """The FB outputs that are true at each grid time (marks within the grid step after it)."""
    import numpy as np

    g = np.asarray(grid, dtype=float)
    parts: list[list[str]] = [[] for _ in range(len(g))]
    by_out: dict[str, list[tuple[float, float]]] = {}
    for output, ta, tb in spans:
        by_out.setdefault(output, []).append((ta, tb))
    for output in [*_BAR_OUTPUTS, *(o for o in by_out if o not in _BAR_OUTPUTS)]:
        items = by_out.get(output)
        if not items or len(g) == 0:
            continue
        arr = np.array(sorted(items))
        if output in _MARKS:
            k = np.searchsorted(g, arr[:, 0], side="right") - 1
            hit = np.zeros(len(g), bool)
            hit[np.clip(k, 0, len(g) - 1)] = True
        else:
            k = np.searchsorted(arr[:, 0], g, side="right") - 1
            ends = np.maximum.accumulate(arr[:, 1])
            hit = (k >= 0) & (g < ends[np.clip(k, 0, None)])
        for i in np.flatnonzero(hit):
            parts[i].append(output)
    return [", ".join(p) if p else "-" for p in parts]


# ---------------------------------------------------------------------------- writing
def write_plot(
    out: Path,
    trace: ScopeTrace,
    title: str,
    max_segments: int = MAX_PATH_SEGMENTS,
    max_points: int = MAX_POINTS,
) -> None:
    """Write the scope of ``trace`` to ``out``: ``.html``/``.htm`` (interactive, plotly), else PNG.

    The HTML page is self-contained (plotly.js inlined) and the same trace gives the same
    bytes. Channels longer than ``2 * max_points`` rows are decimated for display by
    :func:`minmax_indices` (the title says so); group paths have at most ``max_segments``
    segments per view (:func:`decimate_path`; at most ``4 * max_points`` in the HTML). Raises
    :class:`MotionPlcError` for a trace without axis columns and :class:`PlotDependencyError`
    when plotly (HTML) or matplotlib (PNG) is missing; creates the parent directory.
    """
    t, cols = _columns(trace)
    if not any(c.kind == "axis" for c in cols):
        raise MotionPlcError(f"{title}: the trace has no axis columns")
    if isinstance(max_points, bool) or int(max_points) < 1:
        raise ValueError(f"write_plot: max_points: {max_points} (allowed: >= 1)")
    html = out.suffix.lower() in (".html", ".htm")
    if html:
        go, pio = _plotly()
        fig = _html_figure(go, t, cols, title, int(max_points), max_segments)
        page = pio.to_html(
            fig, include_plotlyjs=True, full_html=True, div_id=HTML_DIV_ID, config=_HTML_CONFIG
        )
        out.parent.mkdir(parents=True, exist_ok=True)
        out.write_text(page, encoding="utf-8")
        return
    plt = _pyplot()
    out.parent.mkdir(parents=True, exist_ok=True)
    _png(plt, out, t, cols, title, int(max_points), max_segments)


_HTML_CONFIG = {
    "scrollZoom": True,
    "displaylogo": False,
    "responsive": True,
    "toImageButtonOptions": {"format": "png", "scale": 2},
}


def _decimation_note(n: int, max_points: int) -> str:
    if n <= 2 * max_points:
        return f"{n} samples per channel, all drawn"
    return (
        f"{n} samples per channel, display decimated: first, min and max of each of "
        f"{max_points} buckets"
    )


def _axis_key(letter: str, k: int) -> tuple[str, str]:
    """(layout key, trace reference) of the k-th x or y axis (1-based): xaxis/x, xaxis2/x2."""
    return (f"{letter}axis", letter) if k == 1 else (f"{letter}axis{k}", f"{letter}{k}")


def _row_domains(weights: Sequence[float], gap: float) -> list[tuple[float, float]]:
    """Vertical domains (bottom, top) of rows of relative heights, top row first."""
    total = sum(weights) + gap * (len(weights) - 1)
    out, top = [], 1.0
    for w in weights:
        bottom = top - w / total
        out.append((max(bottom, 0.0), top))
        top = bottom - gap / total
    return out


# ---------------------------------------------------------------------------- the grid
MAX_GRID_COLUMNS = 4
"""Grid columns per row of the scope (an axis card is one column wide, a group card two): more
axes wrap into further rows of the same size, so a card keeps its size from 1 to 16 axes."""


@dataclass(frozen=True, slots=True)
class _Cell:
    """Where a card (a :class:`_Column`) sits: its grid row, first grid column and width."""

    col: _Column
    row: int
    start: int
    span: int


def _grid(cols: Sequence[_Column]) -> tuple[int, int, list[_Cell]]:
    """(grid columns, grid rows, cells): the cards in order (groups first), row by row; a
    group card spans two grid columns. Rows are balanced: 6 units give 2 rows of 3, not 4 + 2."""
    spans = [2 if c.kind == "group" else 1 for c in cols]
    units = sum(spans)
    limit = MAX_GRID_COLUMNS + 1 if units == MAX_GRID_COLUMNS + 1 else MAX_GRID_COLUMNS
    nrows = -(-units // limit)
    ncols = max(-(-units // nrows), max(spans))
    while True:  # greedy packing; widen by one column if a group card would not fit a row
        cells: list[_Cell] = []
        row = used = 0
        for col, span in zip(cols, spans, strict=True):
            if used + span > ncols:
                row, used = row + 1, 0
            cells.append(_Cell(col, row, used, span))
            used += span
        if row + 1 <= nrows or ncols >= limit:
            return ncols, row + 1, cells
        ncols += 1


def _drawn_columns(cols: list[_Column]) -> tuple[list[_Column], list[_Column]]:
    """(drawn, left out): a group that was never enabled (its state GROUP_DISABLED throughout
    and no FB of it ever switched) has nothing to show and gets no card."""
    import numpy as np

    drawn, idle = [], []
    for col in cols:
        never = (
            col.kind == "group"
            and col.state is not None
            and not col.fbs
            and bool(np.all(np.asarray(col.state) == 0))
        )
        (idle if never else drawn).append(col)
    return drawn, idle


def _idle_note(idle: Sequence[_Column]) -> str:
    if not idle:
        return ""
    names = "; ".join(f"{c.name} ({', '.join(c.members)})" for c in idle)
    return (
        f"; never enabled, not drawn: group {names}"
        if len(idle) == 1
        else (f"; never enabled, not drawn: groups {names}")
    )


# HTML geometry in pixels (the page is responsive in width; NOMINAL_WIDTH is the plot width the
# horizontal gaps are sized for, a 1600 px window less margins and the legend)
_NOMINAL_WIDTH = 1330.0
_GAP_X_PX = 78.0  # between cards: the next card's y tick labels and title
_HEADER_PX = 92.0  # page title and its note (the top margin)
_BOTTOM_PX = 20.0
_TITLE_PX = 30.0  # a card row's titles
_VALUE_PX = 500.0  # the five value lanes of an axis card (with their gaps)
_VALUE_GAP_PX = 14.0
_LANES_GAP_PX = 16.0
_LANE_PX = 19.0  # one state/FB row
_LANES_MIN_PX = 58.0
_TIME_AXIS_PX = 44.0  # the time axis' tick labels and title below the lanes
_ROW_GAP_PX = 26.0
_VIEW_AXIS_PX = 48.0  # a path view's x tick labels and title, above the path speed lane
_COLOURBAR_PX = 74.0  # right of a group's path views: the speed colour bar and its labels
_VIEW_GAP_PX = 70.0  # between two path views: the second one's y tick labels and title


def _row_px(n_lanes: int) -> float:
    lanes = max(_LANES_MIN_PX, _LANE_PX * n_lanes)
    return _TITLE_PX + _VALUE_PX + _LANES_GAP_PX + lanes + _TIME_AXIS_PX + _ROW_GAP_PX


def _html_figure(
    go: Any, t: Any, cols: list[_Column], title: str, max_points: int, max_segments: int
) -> Any:
    """The plotly figure: a card per group and axis on a grid, every time axis linked."""
    import numpy as np

    n = len(t)
    t = np.asarray(t, dtype=float)
    cols, idle = _drawn_columns(cols)
    ncol, nrow, cells = _grid(cols)
    lanes_of_row = [max(len(c.col.lane_labels()) for c in cells if c.row == r) for r in range(nrow)]
    row_top = [float(sum(_row_px(k) for k in lanes_of_row[:r])) for r in range(nrow)]
    plot_px = sum(_row_px(k) for k in lanes_of_row)
    height = _HEADER_PX + plot_px + _BOTTOM_PX

    def py(px: float) -> float:  # pixels from the top of the plot area -> paper y
        return min(1.0, max(0.0, 1.0 - px / plot_px))

    gap_x = _GAP_X_PX / _NOMINAL_WIDTH if ncol > 1 else 0.0
    unit_w = (1.0 - gap_x * (ncol - 1)) / ncol
    weights = [w for _, _, w in _AXIS_ROWS]
    value_px = _VALUE_PX - _VALUE_GAP_PX * (len(weights) - 1)
    grid = np.unique(np.linspace(0, n - 1, min(n, max_points)).round().astype(int)) if n else []
    grid_t = t[grid] if n else np.zeros(0)
    bucket = (float(t[-1] - t[0]) / max_points) if n > 1 else 0.0
    data: list[dict[str, Any]] = []
    layout: dict[str, Any] = {}
    annotations: list[dict[str, Any]] = []
    shown: set[str] = set()  # legend entries shown once (states, FB outputs)
    ny = 0
    nx = len(cols)  # x axes 1..len(cols) are the cards' time axes

    def new_y(domain: tuple[float, float], anchor: str, **kw: Any) -> str:
        nonlocal ny
        ny += 1
        key, ref = _axis_key("y", ny)
        layout[key] = {"domain": list(domain), "anchor": anchor, "automargin": True, **kw}
        return ref

    def ytitle(text: str) -> dict[str, Any]:
        return {"text": text, "font": {"size": 11}, "standoff": 4}

    def signal(col: _Column, fld: str, tx: str, ty: str, unit: str) -> None:
        y = np.asarray(col.signals[fld], dtype=float)
        idx = minmax_indices(y, max_points)
        name = f"{col.name}.{fld}"
        data.append(
            {
                "type": "scatter",
                "mode": "lines",
                "x": t[idx],
                "y": y[idx],
                "xaxis": tx,
                "yaxis": ty,
                "name": name,
                "legendgroup": col.name,
                "legendgrouptitle": {"text": col.title},
                "line": {
                    "color": _SIGNAL_COLORS.get(fld, "#333"),
                    "width": 1.4,
                    "dash": "dash" if fld.startswith("actual_") else "solid",
                    "shape": "hv" if fld == "jerk" else "linear",
                },
                "hovertemplate": f"{name}: %{{y:.6g}} {unit}<extra></extra>",
            }
        )

    for c, cell in enumerate(cells):
        col = cell.col
        x0 = cell.start * (unit_w + gap_x)
        x1 = x0 + cell.span * unit_w + (cell.span - 1) * gap_x
        dom_x = [x0, x1]
        top_px = row_top[cell.row] + _TITLE_PX
        value_rows, at = [], top_px  # (bottom, top) paper y of the five value lanes
        for w in weights:
            h = value_px * w / sum(weights)
            value_rows.append((py(at + h), py(at)))
            at += h + _VALUE_GAP_PX
        value_bottom_px = top_px + _VALUE_PX
        lanes_top_px = value_bottom_px + _LANES_GAP_PX
        # each card's lanes as high as its own rows need (the same bar height in every card)
        own = max(_LANES_MIN_PX, _LANE_PX * len(col.lane_labels()))
        lanes_dom = (py(lanes_top_px + own), py(lanes_top_px))
        tkey, tx = _axis_key("x", c + 1)
        annotations.append(
            {
                "text": f"<b>{col.title}</b>",
                "x": (x0 + x1) / 2,
                "y": py(top_px - 6),
                "xref": "paper",
                "yref": "paper",
                "yanchor": "bottom",
                "showarrow": False,
                "font": {"size": 13},
            }
        )
        if col.kind == "axis":
            for r, (qty, fields, _w) in enumerate(_AXIS_ROWS):
                unit = col.units[fields[0]]
                present = [f for f in fields if f in col.signals]
                ty = new_y(value_rows[r], tx, title=ytitle(f"{qty} [{unit}]"))
                for f in present:
                    signal(col, f, tx, ty, unit)
                if not present:
                    layout[_axis_key("y", ny)[0]]["title"] = ytitle(f"{qty} (not in trace)")
        else:
            proj = col.projections()
            pos = np.asarray(col.positions, dtype=float)
            speed = np.asarray(_colour_speed(col), dtype=float)
            segs = min(max_segments, 4 * max_points)
            keep = decimate_path(pos, speed, segs) if len(pos) else np.arange(0)
            v_top = _speed_scale(speed[keep]) if len(keep) else 1.0
            unit = col.units["path_velocity"]
            # the path views side by side over the position..acceleration lanes, the colour
            # bar right of them in its own space; the path speed over the jerk and FE lanes
            views_top = value_rows[0][1]
            views_bottom_px = top_px + _VALUE_PX * 0.68
            dom_y = [py(views_bottom_px), views_top]
            bar_w = _COLOURBAR_PX / _NOMINAL_WIDTH
            vgap = _VIEW_GAP_PX / _NOMINAL_WIDTH
            k_views = max(len(proj), 1)
            view_w = (x1 - x0 - bar_w - vgap * (k_views - 1)) / k_views
            for k, (i, j) in enumerate(proj):
                vx0 = x0 + k * (view_w + vgap)
                nx += 1
                pkey, px = _axis_key("x", nx)
                ny += 1
                qkey, pyr = _axis_key("y", ny)
                mu = [col.member_units[i], col.member_units[j]]
                layout[pkey] = {
                    "domain": [vx0, vx0 + view_w],
                    "anchor": pyr,
                    "title": ytitle(f"{col.members[i]} position [{mu[0]}]"),
                    "automargin": True,
                }
                layout[qkey] = {
                    "domain": dom_y,
                    "anchor": px,
                    "scaleanchor": px,
                    "scaleratio": 1,
                    "constrain": "domain",
                    "title": ytitle(f"{col.members[j]} position [{mu[1]}]"),
                    "automargin": True,
                }
                xs, ys = pos[keep, i], pos[keep, j]
                data.append(
                    {
                        "type": "scatter",
                        "mode": "lines+markers",
                        "x": xs,
                        "y": ys,
                        "xaxis": px,
                        "yaxis": pyr,
                        "name": f"{col.name} path ({col.members[i]}, {col.members[j]})",
                        "legendgroup": col.name,
                        "legendgrouptitle": {"text": col.title},
                        "line": {"color": "#bbbbbb", "width": 1},
                        "marker": {
                            "size": 4,
                            "color": speed[keep],
                            "colorscale": "Viridis",
                            "cmin": 0.0,
                            "cmax": v_top,
                            "showscale": k == 0,
                            "colorbar": {
                                "title": {"text": f"speed<br>[{unit}]", "side": "top"},
                                "x": x1 - bar_w + 8.0 / _NOMINAL_WIDTH,
                                "xanchor": "left",
                                "y": (dom_y[0] + dom_y[1]) / 2,
                                "len": (dom_y[1] - dom_y[0]),
                                "thickness": 10,
                                "tickfont": {"size": 10},
                            },
                        },
                        "hovertemplate": (
                            f"{col.members[i]} %{{x:.6g}}, {col.members[j]} %{{y:.6g}}, "
                            f"speed %{{marker.color:.4g}} {unit}<extra></extra>"
                        ),
                    }
                )
                if len(xs):
                    for label, at_, sym, colour in (
                        ("start", 0, "circle-open", "#2ca02c"),
                        ("end", -1, "square", "#d62728"),
                    ):
                        data.append(
                            {
                                "type": "scatter",
                                "mode": "markers",
                                "x": [xs[at_]],
                                "y": [ys[at_]],
                                "xaxis": px,
                                "yaxis": pyr,
                                "name": f"{col.name} {label}",
                                "legendgroup": col.name,
                                "showlegend": False,
                                "marker": {
                                    "symbol": sym,
                                    "size": 12,
                                    "color": colour,
                                    "line": {"width": 2, "color": colour},
                                },
                                "hovertemplate": f"{label}<extra></extra>",
                            }
                        )
            if len(keep) < len(pos):
                annotations[-1]["text"] += f" ({len(keep) - 1} of {len(pos) - 1} segments drawn)"
            note = " (norm of member velocities)" if col.speed_derived else ""
            speed_dom = (value_rows[4][0], py(views_bottom_px + _VIEW_AXIS_PX + 14.0))
            ty = new_y(speed_dom, tx, title=ytitle(f"path speed [{unit}]{note}"))
            signal(col, "path_velocity", tx, ty, unit)
        # the state and FB lane rows (the time axis is anchored here, at the bottom)
        labels = col.lane_labels()
        ty = new_y(
            lanes_dom,
            tx,
            range=[len(labels) - 0.5, -0.5],
            tickmode="array",
            tickvals=list(range(len(labels))),
            ticktext=labels,
            tickfont={"size": 10},
            fixedrange=True,
            showgrid=False,
            zeroline=False,
        )
        layout[tkey] = {
            "domain": dom_x,
            "anchor": ty,
            "title": {"text": "time [s]", "font": {"size": 11}, "standoff": 4},
            "showspikes": True,
            "spikemode": "across",
            "spikesnap": "cursor",
            "spikethickness": 1,
            "spikecolor": "#666",
            "spikedash": "solid",
            "hoverformat": ".4f",
            "automargin": True,
            **({"matches": "x"} if c else {}),
        }
        _html_lanes(data, shown, col, t, tx, ty, grid_t, bucket, max_points)
    ncycles = f"{n} cycles, t = {t[0]:.4g} .. {t[-1]:.4g} s" if n else "no cycles"
    layout.update(
        {
            "title": {
                "text": f"{title}<br><sup>{ncycles}; {_decimation_note(n, max_points)}"
                f"{_idle_note(idle)}. Drag: zoom (all time axes follow), double-click: reset, "
                "scroll: zoom, legend click: show/hide a channel</sup>",
                "x": 0.01,
                "font": {"size": 15},
            },
            "height": int(round(height)),
            "margin": {"l": 60, "r": 20, "t": int(_HEADER_PX), "b": int(_BOTTOM_PX)},
            "hovermode": "x unified",
            "hoversubplots": "axis",
            "hoverlabel": {"font": {"size": 11}},
            "barmode": "overlay",
            "uniformtext": {"mode": "hide", "minsize": 9},
            "legend": {
                "groupclick": "toggleitem",
                "font": {"size": 10},
                "tracegroupgap": 10,
                "itemsizing": "constant",
            },
            "template": "plotly_white",
            "annotations": annotations,
            "dragmode": "zoom",
        }
    )
    return go.Figure(data=data, layout=layout)


def _html_lanes(
    data: list[dict[str, Any]],
    shown: set[str],
    col: _Column,
    t: Any,
    tx: str,
    ty: str,
    grid_t: Any,
    bucket: float,
    max_points: int,
) -> None:
    """The state row (coloured spans named inside where the name fits) and the FB rows."""
    import numpy as np

    table = _state_table(col.kind)
    spans = _state_spans(t, col.state, 4 * max_points)
    by_state: dict[int, list[tuple[float, float]]] = {}
    for s, ta, tb in spans:
        by_state.setdefault(s, []).append((ta, tb))
    for s, items in sorted(by_state.items()):
        name, colour = table.get(s, (str(s), "grey"))
        key = f"state {name}"
        arr = np.array(items)
        data.append(
            {
                "type": "bar",
                "orientation": "h",
                "base": arr[:, 0],
                "x": arr[:, 1] - arr[:, 0],
                "y": np.zeros(len(arr)),
                "width": 0.8,
                "xaxis": tx,
                "yaxis": ty,
                "name": name,
                "legendgroup": "states",
                "legendgrouptitle": {"text": "states"},
                "showlegend": key not in shown,
                "marker": {"color": colour, "line": {"width": 0.5, "color": "#ffffff"}},
                "text": [name] * len(arr),
                "textposition": "inside",
                "insidetextanchor": "middle",
                "textangle": 0,
                "constraintext": "both",
                "textfont": {"size": 10, "color": "#111111"},
                "hoverinfo": "skip",
            }
        )
        shown.add(key)
    bars, marks = _fb_display(col.fbs, bucket)
    for output in [*_BAR_OUTPUTS, *(o for o in bars if o not in _BAR_OUTPUTS)]:
        items3 = bars.get(output)
        if not items3:
            continue
        arr = np.array(items3)
        key = f"fb {output}"
        data.append(
            {
                "type": "bar",
                "orientation": "h",
                "base": arr[:, 1],
                "x": np.maximum(arr[:, 2] - arr[:, 1], 0.0),
                "y": arr[:, 0],
                "width": _BAR_HEIGHT.get(output, 0.6),
                "xaxis": tx,
                "yaxis": ty,
                "name": output,
                "legendgroup": "fb",
                "legendgrouptitle": {"text": "FB outputs"},
                "showlegend": key not in shown,
                "marker": {"color": _LANE_COLORS.get(output, "grey")},
                "hoverinfo": "skip",
            }
        )
        shown.add(key)
    for output, items2 in marks.items():
        colour = _LANE_COLORS.get(output, "grey")
        key = f"fb {output}"
        data.append(
            {
                "type": "scatter",
                "mode": "markers",
                "x": [b for _, b in items2],
                "y": [a for a, _ in items2],
                "xaxis": tx,
                "yaxis": ty,
                "name": output,
                "legendgroup": "fb",
                "legendgrouptitle": {"text": "FB outputs"},
                "showlegend": key not in shown,
                "marker": {
                    "symbol": _MARK_SYMBOLS.get(output, "circle"),
                    "size": 12,
                    "color": colour,
                    "line": {"width": 2.5, "color": colour},
                },
                "hoverinfo": "skip",
            }
        )
        shown.add(key)
    # invisible cursor readouts: the state and each FB's true outputs at the hover time
    if len(grid_t) and col.state is not None:
        idx = np.searchsorted(t, grid_t, side="right") - 1
        names = [table.get(int(s), (str(int(s)), ""))[0] for s in np.asarray(col.state)[idx]]
        data.append(_readout(f"{col.name}.state", grid_t, 0, names, tx, ty, col.name))
    for row, (fb, spans_) in enumerate(col.fbs.items(), start=1):
        if len(grid_t):
            text = _fb_status_text(spans_, grid_t)
            data.append(_readout(f"{col.name}.{fb}", grid_t, row, text, tx, ty, col.name))


def _readout(
    name: str, x: Any, row: int, text: list[str], tx: str, ty: str, group: str
) -> dict[str, Any]:
    import numpy as np

    return {
        "type": "scatter",
        "mode": "markers",
        "x": x,
        "y": np.full(len(x), float(row)),
        "xaxis": tx,
        "yaxis": ty,
        "name": name,
        "legendgroup": group,
        "showlegend": False,
        "text": text,
        "marker": {"opacity": 0, "size": 2},
        "hovertemplate": f"{name}: %{{text}}<extra></extra>",
    }


def _speed_scale(values: Any) -> float:
    """Top of the colour scale: the fastest drawn sample (1 when nothing moves)."""
    import numpy as np

    top = float(np.max(values)) if len(values) else 0.0
    return top if top > 0 and np.isfinite(top) else 1.0


# ---------------------------------------------------------------------------- PNG
PNG_DPI = 90
PNG_COLUMN_WIDTH = 4.6  # inches per grid column (an axis card; a group card spans two)
PNG_ROW_HEIGHT = 9.0  # inches per grid row of cards
PNG_HEADER = 0.5  # inches: the title
PNG_FOOTER = 0.5  # inches per line of the legend below the cards
_PNG_LEGEND_COLUMNS = 6


def _png(
    plt: Any,
    out: Path,
    t: Any,
    cols: list[_Column],
    title: str,
    max_points: int,
    max_segments: int,
) -> None:
    """The PNG scope: the same grid of cards and lanes as the HTML page, state names that fit."""
    import numpy as np

    cols, idle = _drawn_columns(cols)
    ncol, nrow, cells = _grid(cols)
    n_legend = len({*_state_legend_names(cols), *_fb_legend_names(cols)})
    legend_rows = -(-max(n_legend, 1) // _PNG_LEGEND_COLUMNS)
    fig = plt.figure(
        figsize=(
            PNG_COLUMN_WIDTH * ncol,
            PNG_HEADER + PNG_ROW_HEIGHT * nrow + PNG_FOOTER * (0.6 + 0.4 * legend_rows),
        ),
        layout="constrained",
        dpi=PNG_DPI,
    )
    outer = fig.add_gridspec(nrow, ncol)
    t = np.asarray(t, dtype=float)
    labels: list[tuple[Any, Any, float, float]] = []  # (text, axes, t_from, t_to)
    share = None
    legend: dict[str, Any] = {}
    for cell in cells:
        col = cell.col
        n_lanes = len(col.lane_labels())
        ratios = [w for _, _, w in _AXIS_ROWS] + [max(0.45, _LANE_ROW_WEIGHT * 1.4 * n_lanes)]
        gs = outer[cell.row, cell.start : cell.start + cell.span].subgridspec(
            len(ratios), 1, height_ratios=ratios
        )
        lane = fig.add_subplot(gs[-1, 0], sharex=share)
        share = share or lane
        if col.kind == "axis":
            for r, (qty, fields, _w) in enumerate(_AXIS_ROWS):
                a = fig.add_subplot(gs[r, 0], sharex=share)
                unit = col.units[fields[0]]
                for f in fields:
                    if f not in col.signals:
                        continue
                    y = np.asarray(col.signals[f], dtype=float)
                    idx = minmax_indices(y, max_points)
                    a.plot(
                        t[idx],
                        y[idx],
                        lw=1.2,
                        color=_SIGNAL_COLORS.get(f, "#333"),
                        ls="--" if f.startswith("actual_") else "-",
                        drawstyle="steps-post" if f == "jerk" else "default",
                        label=f"{col.name}.{f}",
                    )
                present = [f for f in fields if f in col.signals]
                a.set_ylabel(f"{qty} [{unit}]" if present else f"{qty} (not in trace)", fontsize=8)
                if len(present) > 1:
                    a.legend(fontsize=6, loc="best")
                a.grid(True, alpha=0.3)
                a.tick_params(labelbottom=False, labelsize=7)
                if r == 0:
                    a.set_title(col.title, fontsize=10)
        else:
            _png_group(fig, gs, col, t, share, max_points, max_segments)
        _png_lanes(lane, col, t, labels, legend, max_points)
    note = _decimation_note(len(t), max_points) + _idle_note(idle)
    fig.suptitle(f"{title}  ({note})", fontsize=10)
    fig.legend(
        list(legend.values()),
        list(legend),
        loc="outside lower center",
        ncol=min(len(legend), _PNG_LEGEND_COLUMNS),
        fontsize=8,
        frameon=False,
    )
    fig.canvas.draw()  # lay out, then hide the state names that do not fit their span
    renderer = fig.canvas.get_renderer()
    for text, a, ta, tb in labels:
        x0, x1 = a.transData.transform([(ta, 0.0), (tb, 0.0)])[:, 0]
        for candidate in _short_names(text.get_text()):  # the longest name that fits
            text.set_text(candidate)
            if text.get_window_extent(renderer).width <= 0.95 * abs(x1 - x0):
                break
        else:
            text.set_visible(False)
    fig.savefig(out, dpi=PNG_DPI)
    plt.close(fig)


def _state_legend_names(cols: Sequence[_Column]) -> set[str]:
    import numpy as np

    names = set()
    for col in cols:
        if col.state is not None:
            table = _state_table(col.kind)
            names |= {table.get(int(s), (str(int(s)), ""))[0] for s in np.unique(col.state)}
    return names


def _fb_legend_names(cols: Sequence[_Column]) -> set[str]:
    return {f"FB {o}" for col in cols for spans in col.fbs.values() for o, _a, _b in spans}


def _short_names(name: str) -> list[str]:
    """A state name and its shorter forms: ``discrete_motion``, ``discrete``, ``DM``."""
    words = [w for w in name.split("_") if w]
    out = [name]
    if len(words) > 1:
        out.append(words[0] if words[0] != "group" else "_".join(words[1:]))
        out.append("".join(w[0] for w in words if w != "group").upper())
    return list(dict.fromkeys(out))


def _png_lanes(
    a: Any,
    col: _Column,
    t: Any,
    labels: list[tuple[Any, Any, float, float]],
    legend: dict[str, Any],
    max_points: int,
) -> None:
    """State spans (row 0) and FB rows (1, 2, ...): bars and Done/Error/Aborted marks."""
    from matplotlib.patches import Patch

    table = _state_table(col.kind)
    by_state: dict[int, list[tuple[float, float]]] = {}
    for s, ta, tb in _state_spans(t, col.state, 4 * max_points):
        by_state.setdefault(s, []).append((ta, tb - ta))
        name = table.get(s, (str(s), "grey"))[0]
        txt = a.text(
            (ta + tb) / 2, 0, name.lower(), ha="center", va="center", fontsize=7, clip_on=True
        )
        labels.append((txt, a, ta, tb))
    for s, spans in by_state.items():
        name, colour = table.get(s, (str(s), "grey"))
        a.broken_barh(spans, (-0.4, 0.8), color=colour)
        legend.setdefault(name, Patch(color=colour))
    bucket = (float(t[-1] - t[0]) / max_points) if len(t) > 1 else 0.0
    bars, marks = _fb_display(col.fbs, bucket)
    for output in [*_BAR_OUTPUTS, *(o for o in bars if o not in _BAR_OUTPUTS)]:
        items = bars.get(output)
        if not items:
            continue
        h = _BAR_HEIGHT.get(output, 0.6)
        colour = _LANE_COLORS.get(output, "grey")
        by_row: dict[int, list[tuple[float, float]]] = {}
        for row, ta, tb in items:
            by_row.setdefault(row, []).append((ta, max(tb - ta, 0.0)))
        for row, spans in by_row.items():
            a.broken_barh(spans, (row - h / 2, h), color=colour)
        legend.setdefault(f"FB {output}", Patch(color=colour))
    for output, pts in marks.items():
        colour = _LANE_COLORS.get(output, "grey")
        (line,) = a.plot(
            [b for _, b in pts],
            [r for r, _ in pts],
            marker=_MARKS.get(output, "."),
            color=colour,
            ms=9,
            mew=2,
            ls="none",
        )
        legend.setdefault(f"FB {output}", line)
    lane_labels = col.lane_labels()
    a.set_yticks(range(len(lane_labels)))
    a.set_yticklabels(lane_labels, fontsize=7)
    a.set_ylim(len(lane_labels) - 0.4, -0.6)
    a.set_xlabel("time [s]", fontsize=9)
    a.tick_params(labelsize=8)
    a.grid(True, axis="x", alpha=0.3)


def _png_group(
    fig: Any,
    gs: Any,
    col: _Column,
    t: Any,
    share: Any,
    max_points: int,
    max_segments: int,
) -> None:
    """A group's card: its path views side by side (rows 0-2 of ``gs``), the path speed (rows
    3-4); one speed colour bar right of the views."""
    import numpy as np
    from matplotlib.collections import LineCollection
    from matplotlib.colors import Normalize

    proj = col.projections()
    pos = np.asarray(col.positions, dtype=float)
    speed = np.asarray(_colour_speed(col), dtype=float)
    keep = decimate_path(pos, speed, max_segments) if len(pos) else np.arange(0)
    values = speed[keep[:-1]]
    norm = Normalize(0.0, _speed_scale(values))
    unit = col.units["path_velocity"]
    sub = gs[0:3, 0].subgridspec(1, max(len(proj), 1), wspace=0.08)
    views = []
    lc = None
    for k, (i, j) in enumerate(proj):
        a = fig.add_subplot(sub[0, k])
        views.append(a)
        ends = pos[keep][:, [i, j]]
        segs = np.stack([ends[:-1], ends[1:]], axis=1)
        lc = LineCollection(segs, cmap="viridis", norm=norm, linewidths=2.0)
        lc.set_array(values)
        a.add_collection(lc)
        if len(ends):
            a.plot(
                *ends[0], "o", color="#2ca02c", ms=11, mfc="none", mew=2, label="start", zorder=3
            )
            a.plot(*ends[-1], "s", color="#d62728", ms=7, label="end", zorder=3)
            a.legend(fontsize=7, loc="best")
        a.autoscale_view()
        a.set_aspect("equal", adjustable="datalim")
        a.set_xlabel(f"{col.members[i]} position [{col.member_units[i]}]", fontsize=8)
        a.set_ylabel(f"{col.members[j]} position [{col.member_units[j]}]", fontsize=8)
        a.tick_params(labelsize=7)
        a.grid(True, alpha=0.3)
    if views and lc is not None:
        fig.colorbar(lc, ax=views, label=f"speed [{unit}]", shrink=0.9, pad=0.02)
        title = col.title
        if len(keep) < len(pos):
            title += f" ({len(keep) - 1} of {len(pos) - 1} segments drawn)"
        fig.add_subplot(sub[0, :], frameon=False).set_axis_off()  # room for the title
        views[0].figure.axes[-1].set_title(title, fontsize=10)
    a = fig.add_subplot(gs[3:5, 0], sharex=share)
    path_speed = np.asarray(col.signals["path_velocity"], dtype=float)  # the group's channel
    idx = minmax_indices(path_speed, max_points)
    a.plot(t[idx], path_speed[idx], lw=1.2, color=_SIGNAL_COLORS["path_velocity"])
    note = " (norm of member velocities)" if col.speed_derived else ""
    a.set_ylabel(f"path speed [{unit}]{note}", fontsize=8 if not note else 7)
    a.tick_params(labelbottom=False, labelsize=7)
    a.grid(True, alpha=0.3)
    if not views:
        a.set_title(col.title, fontsize=10)


# ---------------------------------------------------------------------------- series
def write_series_plot(
    out: Path,
    t: Any,
    series: Mapping[str, tuple[Any, str]],
    title: str,
    max_points: int = MAX_POINTS,
) -> None:
    """Plot time series, one lane each, on a common time axis: ``.html``/``.htm`` (interactive,
    plotly, self-contained) or PNG (matplotlib), e.g. a planned profile (``motionplc plan``).

    ``series`` maps a name to ``(values, unit)``; every lane's y-axis reads ``name [unit]``
    (``name`` alone for an empty unit). ``t`` is in seconds. Values longer than
    ``2 * max_points`` are decimated for display by :func:`minmax_indices`. Raises
    ``ValueError`` naming the series whose values are not one per time (or when there is no
    series, or ``t`` is not one-dimensional) and :class:`PlotDependencyError` for a missing
    plotly or matplotlib; creates the parent directory.
    """
    import numpy as np

    tt = np.asarray(t, dtype=float)
    if tt.ndim != 1:
        raise ValueError(f"write_series_plot: t: one-dimensional array needed, got {tt.shape}")
    if not series:
        raise ValueError("write_series_plot: series: at least one series needed")
    lanes: list[tuple[str, Any, str]] = []
    for name, item in series.items():
        if not isinstance(item, tuple) or len(item) != 2 or not isinstance(item[1], str):
            raise ValueError(f"write_series_plot: series[{name!r}]: expected (values, unit)")
        y = np.asarray(item[0], dtype=float)
        if y.shape != tt.shape:
            raise ValueError(
                f"write_series_plot: series[{name!r}]: {y.shape[0] if y.ndim else 0} values "
                f"for {len(tt)} times (one value per time needed)"
            )
        lanes.append((str(name), y, item[1]))
    label = [f"{n} [{u}]" if u else n for n, _, u in lanes]
    note = _decimation_note(len(tt), int(max_points))
    if out.suffix.lower() in (".html", ".htm"):
        go, pio = _plotly()
        rows = _row_domains([1.0] * len(lanes), 0.25)
        layout: dict[str, Any] = {}
        data = []
        for k, ((name, y, unit), dom, text) in enumerate(zip(lanes, rows, label, strict=True)):
            ykey, yref = _axis_key("y", k + 1)
            layout[ykey] = {
                "domain": list(dom),
                "anchor": "x",
                "title": {"text": text},
                "automargin": True,
            }
            idx = minmax_indices(y, int(max_points))
            data.append(
                {
                    "type": "scatter",
                    "mode": "lines",
                    "x": tt[idx],
                    "y": y[idx],
                    "xaxis": "x",
                    "yaxis": yref,
                    "name": name,
                    "line": {"width": 1.5},
                    "hovertemplate": f"{name}: %{{y:.6g}} {unit}<extra></extra>",
                }
            )
        layout["xaxis"] = {
            "anchor": _axis_key("y", len(lanes))[1],
            "title": {"text": "time [s]"},
            "showspikes": True,
            "spikemode": "across",
            "spikesnap": "cursor",
            "hoverformat": ".4f",
        }
        layout.update(
            {
                "title": {"text": f"{title}<br><sup>{note}</sup>", "x": 0.01},
                "height": 180 + 190 * len(lanes),
                "hovermode": "x unified",
                "hoversubplots": "axis",
                "template": "plotly_white",
                "margin": {"l": 70, "r": 20, "t": 80, "b": 50},
            }
        )
        page = pio.to_html(
            go.Figure(data=data, layout=layout),
            include_plotlyjs=True,
            full_html=True,
            div_id=HTML_DIV_ID,
            config=_HTML_CONFIG,
        )
        out.parent.mkdir(parents=True, exist_ok=True)
        out.write_text(page, encoding="utf-8")
        return
    plt = _pyplot()
    out.parent.mkdir(parents=True, exist_ok=True)
    fig, axes = plt.subplots(
        len(lanes),
        1,
        sharex=True,
        figsize=(9, 1.2 + 2.0 * len(lanes)),
        squeeze=False,
        layout="constrained",
    )
    for a, (name, y, _unit), text in zip(axes[:, 0], lanes, label, strict=True):
        idx = minmax_indices(y, int(max_points))
        a.plot(tt[idx], y[idx], lw=1.3, drawstyle="steps-post" if name == "jerk" else "default")
        a.set_ylabel(text, fontsize=9)
        a.grid(True, alpha=0.3)
    axes[-1, 0].set_xlabel("time [s]")
    fig.suptitle(f"{title}  ({note})", fontsize=10)
    fig.savefig(out, dpi=100)
    plt.close(fig)
