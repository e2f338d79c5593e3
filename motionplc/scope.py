"""The PLC scope: plots of a trace as PNG or HTML.

Per axis: position, velocity, acceleration and jerk over time, the PLCopen state lane and one lane
per function block (busy/active bars, done/error/aborted marks). Per axes group (when the trace
has groups): the group's path in space coloured by its path speed (XY for two axes, XY and XZ for
three or more; equal aspect, start and end marked, a colour scale), the path speed over time and
the group state lane, drawn left of the per-axis columns, which the member axes keep.

:func:`read_trace` reads a trace CSV written by ``motionplc run --trace`` (FB edges from the
``*.events.csv`` next to it, the group membership from the ``*.groups.json`` sidecar that
:func:`write_groups_sidecar` writes), :func:`trace_from_runtime` takes the same data from a live
runtime, and :func:`write_plot` writes a ``.png`` (needs matplotlib, imported only when drawing)
or a self-contained ``.html`` (no dependencies, no scripts). Long paths are thinned for drawing
by :func:`decimate_path`, which keeps corners and the speed extremes.

Trace columns of a group ``g``: ``g.path_velocity`` (path speed [m/s], >= 0) and ``g.state``
(a :class:`~motionplc.blocks.enums.GroupState`; in the CSV by member name, e.g.
``GROUP_MOVING``). Without ``g.path_velocity`` the scope uses the Euclidean norm of the member
axes' commanded velocities (the path speed of the identity Cartesian mapping) and says so;
without ``g.state`` the group gets no state lane.
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
"""Default bound on the line segments drawn per path view (see :func:`decimate_path`)."""

GROUPS_SUFFIX = ".groups.json"
"""Suffix of the group sidecar of a trace CSV (``out/demo.csv`` -> ``out/demo.groups.json``)."""


class PlotDependencyError(MotionPlcError):
    """A PNG was asked for but matplotlib is not installed (the message says how to get it)."""


Event = tuple[int, str, str, bool]
"""One FB output edge: (cycle, FB label ``axis.fb``, output name, new value)."""


@dataclass(frozen=True, slots=True)
class ScopeTrace:
    """What the scope draws: the trace columns, one row per cycle, the FB edges and the groups.

    ``data`` is a float array (rows x columns; states as their enum values); ``groups`` maps a
    group name to its member axes in order (empty when the trace has no groups).
    """

    columns: list[str]
    data: Any
    events: list[Event]
    groups: dict[str, list[str]] = field(default_factory=dict)


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
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise MotionPlcError(
            f"{path}: cannot read: {getattr(exc, 'strerror', None) or exc}"
        ) from None
    try:
        obj = json.loads(text)
    except json.JSONDecodeError as exc:
        raise MotionPlcError(
            f"{path}:{exc.lineno}:{exc.colno}: not valid JSON: {exc.msg}"
        ) from None
    return _checked_groups(obj, str(path))


# ---------------------------------------------------------------------------- reading
def trace_from_runtime(rt: Any) -> ScopeTrace:
    """The scope data of a runtime's trace ring (the cycles it still holds).

    The groups come from ``rt.groups`` (``{name: group}`` with ``group.axis_names``) when the
    runtime has them; groups without member names are left out.
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
    return ScopeTrace(columns, data, events, groups)


def read_trace(path: Path) -> ScopeTrace:
    """Read a trace CSV (``motionplc run --trace``), its ``*.events.csv`` and groups sidecar.

    Axis states (``STANDSTILL``) and group states (``GROUP_MOVING``) are read by name. Raises
    :class:`MotionPlcError` located at ``file:line`` for anything that is not a trace, and at the
    sidecar for a broken one or a group whose member axis has no columns in the trace.
    """
    from motionplc.blocks import AxisState
    from motionplc.blocks.enums import GroupState

    states = {s.name: float(s.value) for s in AxisState}
    states.update({s.name: float(s.value) for s in GroupState})
    try:
        with path.open(newline="") as fh:
            reader = csv.reader(fh)
            columns = next(reader, [])
            first = next(reader, None)
    except (OSError, UnicodeDecodeError, csv.Error) as exc:
        raise MotionPlcError(f"{path}: cannot read: {_reason(exc)}") from None
    if columns[:2] != ["cycle", "t"]:
        raise MotionPlcError(f"{path}:1: not a motionplc trace (expected columns cycle, t, ...)")
    data = None
    if first is not None and len(first) == len(columns):
        data = _load_numbers(path, columns, first, states)
    if data is None:  # slow and exact: every value checked, the first bad one located
        data = _parse_rows(path, columns, states)
    events: list[Event] = []
    ev_path = path.with_suffix(".events.csv")
    if ev_path.is_file():
        with ev_path.open(newline="") as fh:
            for row in list(csv.reader(fh))[1:]:
                if len(row) == 4:
                    events.append((int(row[0]), row[1], row[2], row[3] == "True"))
    groups = read_groups_sidecar(path)
    axes = [c[: -len(".position")] for c in columns if c.endswith(".position")]
    for name, members in groups.items():
        for m in members:
            if m not in axes:
                raise MotionPlcError(
                    f"{groups_sidecar_path(path)}: groups.{name}: axis {m!r} has no columns in "
                    f"{path.name} (its axes: {', '.join(axes) or 'none'})"
                )
    return ScopeTrace(columns, data, events, groups)


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
    import numpy as np

    try:
        with path.open(newline="") as fh:
            body = list(csv.reader(fh))[1:]
    except (OSError, UnicodeDecodeError, csv.Error) as exc:
        raise MotionPlcError(f"{path}: cannot read: {_reason(exc)}") from None
    data = np.empty((len(body), len(columns)))
    for i, row in enumerate(body):
        if len(row) != len(columns):
            raise MotionPlcError(f"{path}:{i + 2}: {len(row)} values for {len(columns)} columns")
        for j, x in enumerate(row):
            try:
                data[i, j] = states[x] if x in states else float(x)
            except ValueError:
                raise MotionPlcError(f"{path}:{i + 2}: {columns[j]}: not a number: {x!r}") from None
    return data


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


# ---------------------------------------------------------------------------- lanes
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


def _lanes(columns: list[str], data: Any, events: list[Event]) -> dict[str, Any]:
    """Per axis: p/v/a/j arrays, state segments and FB intervals (busy/active, done/error)."""
    t, t0, c0, dt, t_end = _time_base(data)
    axes = [c[: -len(".position")] for c in columns if c.endswith(".position")]
    axes = [a for a in axes if "." not in a]
    out: dict[str, Any] = {}
    for ax in axes:
        col = {
            f: data[:, columns.index(f"{ax}.{f}")]
            for f in ("position", "velocity", "acceleration", "jerk", "state")
        }
        fbs = _fb_intervals(ax, events, t0, c0, dt, t_end)
        out[ax] = {"t": t, **col, "fbs": fbs}
    return out


@dataclass(frozen=True, slots=True)
class _GroupView:
    """One group's drawing data: member positions (n, d), path speed, state (or None), FBs."""

    name: str
    members: tuple[str, ...]
    t: Any
    positions: Any
    speed: Any
    speed_derived: bool
    state: Any
    fbs: dict[str, list[tuple[str, float, float]]]

    def projections(self) -> list[tuple[int, int]]:
        """Member index pairs drawn: XY for two axes, XY and XZ for three or more, none for one."""
        d = len(self.members)
        return [] if d < 2 else [(0, 1)] if d == 2 else [(0, 1), (0, 2)]


def _group_views(trace: ScopeTrace) -> list[_GroupView]:
    import numpy as np

    cols = {c: i for i, c in enumerate(trace.columns)}
    data = trace.data
    t, t0, c0, dt, t_end = _time_base(data)
    views = []
    for name, members in trace.groups.items():
        pos = np.column_stack([data[:, cols[f"{m}.position"]] for m in members])
        derived = f"{name}.path_velocity" not in cols
        if derived:
            vel = np.column_stack([data[:, cols[f"{m}.velocity"]] for m in members])
            speed = np.sqrt(np.sum(vel * vel, axis=1))
        else:
            speed = data[:, cols[f"{name}.path_velocity"]]
        state = data[:, cols[f"{name}.state"]] if f"{name}.state" in cols else None
        fbs = _fb_intervals(name, trace.events, t0, c0, dt, t_end)
        views.append(_GroupView(name, tuple(members), t, pos, speed, derived, state, fbs))
    return views


def _runs(state: Any) -> list[tuple[int, int]]:
    """(first, next) index pairs of the runs of equal values (``next`` is len for the last)."""
    import numpy as np

    n = len(state)
    if n == 0:
        return []
    cuts = (np.flatnonzero(np.asarray(state)[1:] != np.asarray(state)[:-1]) + 1).tolist()
    return list(zip([0, *cuts], [*cuts, n], strict=True))


def _speed_scale(values: Any) -> float:
    """Top of the colour scale: the fastest drawn segment (1 m/s when nothing moves)."""
    import numpy as np

    top = float(np.max(values)) if len(values) else 0.0
    return top if top > 0 and np.isfinite(top) else 1.0


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

_GROUP_STATE_COLORS = {  # GroupState value -> colour, matching the axis state lane's colours
    0: "#d9d9d9",  # GROUP_DISABLED (axis DISABLED)
    1: "#a1d99b",  # GROUP_STANDBY (axis STANDSTILL)
    2: "#fdd0a2",  # GROUP_HOMING (axis HOMING)
    3: "#9ecae1",  # GROUP_MOVING (axis DISCRETE_MOTION)
    4: "#fdae6b",  # GROUP_STOPPING (axis STOPPING)
    5: "#d62728",  # GROUP_ERROR_STOP (axis ERROR_STOP)
}

_VIRIDIS = (  # matplotlib's viridis at 0, 1/8, ..., 1 (the PNG uses the real map)
    "#440154",
    "#482878",
    "#3e4989",
    "#31688e",
    "#26828e",
    "#1f9e89",
    "#35b779",
    "#6ece58",
    "#fde725",
)

SPEED_LEVELS = 64
"""Colour levels of the HTML path view: level k of 0..63 is viridis at k / 63 of the scale top."""


def speed_color(fraction: float) -> str:
    """Viridis (linear between its ninths) at ``fraction`` of the scale, clipped to [0, 1]."""
    f = min(max(float(fraction), 0.0), 1.0) * (len(_VIRIDIS) - 1)
    i = min(int(f), len(_VIRIDIS) - 2)
    r = f - i
    a, b = _VIRIDIS[i], _VIRIDIS[i + 1]
    rgb = [round(int(a[k : k + 2], 16) * (1 - r) + int(b[k : k + 2], 16) * r) for k in (1, 3, 5)]
    return "#" + "".join(f"{c:02x}" for c in rgb)


# ---------------------------------------------------------------------------- writing
def write_plot(
    out: Path, trace: ScopeTrace, title: str, max_segments: int = MAX_PATH_SEGMENTS
) -> None:
    """Write the scope of ``trace`` to ``out``: ``.html``/``.htm`` as inline SVG, else a PNG.

    Groups get a path view each (at most ``max_segments`` segments per view, see
    :func:`decimate_path`); a trace without groups is drawn exactly as before groups existed.
    Raises :class:`MotionPlcError` for a trace without axis columns and
    :class:`PlotDependencyError` for a PNG without matplotlib; creates the parent directory.
    """
    lanes = _lanes(trace.columns, trace.data, trace.events)
    if not lanes:
        raise MotionPlcError(f"{title}: the trace has no axis columns")
    views = _group_views(trace)
    out.parent.mkdir(parents=True, exist_ok=True)
    if out.suffix.lower() in (".html", ".htm"):
        out.write_text(_html_plot(lanes, title, views, max_segments), encoding="utf-8")
        return
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        raise PlotDependencyError(
            "plotting a PNG needs matplotlib: pip install 'motionplc[plot]' "
            "(or write an .html plot, which needs nothing)"
        ) from None
    names = list(lanes)
    suptitle = (
        f"{title} - FB lanes: busy (light), active (dark), valid/status (green), "
        "done |, error x, aborted v"
    )
    if not views:
        fig, grid = plt.subplots(
            5,
            len(names),
            sharex=True,
            figsize=(6.5 * len(names), 11),
            squeeze=False,
            gridspec_kw={"height_ratios": [1, 1, 1, 1, 1.4]},
        )
        _axis_columns(grid, lanes, {})
        fig.suptitle(suptitle, fontsize=9)
        fig.tight_layout()
    else:
        fig = plt.figure(figsize=(6.5 * (len(names) + len(views)), 11), layout="constrained")
        left, right = fig.subfigures(1, 2, width_ratios=[len(views), len(names)], wspace=0.02)
        grid = right.subplots(
            5,
            len(names),
            sharex=True,
            squeeze=False,
            gridspec_kw={"height_ratios": [1, 1, 1, 1, 1.4]},
        )
        member_of = {m: v.name for v in views for m in v.members}
        _axis_columns(grid, lanes, member_of)
        subs = left.subfigures(1, len(views), squeeze=False)[0] if len(views) > 1 else [left]
        for sub, view in zip(subs, views, strict=True):
            _group_column(sub, view, grid[0][0], max_segments)
        fig.suptitle(suptitle, fontsize=9)
    fig.savefig(out, dpi=90)
    plt.close(fig)


def _state_lane(a: Any, t: Any, state: Any, colors: dict[int, str], names: Any) -> None:
    """Coloured bars of the runs of equal state on row 0, named when wide enough."""
    n = len(t)
    for start, k in _runs(state):
        s = int(state[start])
        a.broken_barh(
            [(t[start], t[min(k, n - 1)] - t[start])], (-0.4, 0.8), color=colors.get(s, "grey")
        )
        dur = t[min(k, n - 1)] - t[start]
        if dur > 0.06 * (t[-1] - t[0] + 1e-12):
            a.text(t[start] + dur / 2, 0, names(s).lower(), ha="center", va="center", fontsize=6)


def _fb_rows(a: Any, fbs: dict[str, list[tuple[str, float, float]]]) -> None:
    """One row per FB (rows 1, 2, ...): busy/active/valid bars, done/error/aborted marks."""
    for row, fb in enumerate(fbs, start=1):
        bars: dict[str, list[tuple[float, float]]] = {}
        marks: dict[str, list[float]] = {}
        for output, t_a, t_b in fbs[fb]:
            if t_b > t_a:
                bars.setdefault(output, []).append((t_a, t_b - t_a))
            else:
                marks.setdefault(output, []).append(t_a)
        for output, spans in bars.items():  # one collection per lane: fast for many edges
            h = 0.8 if output in ("busy", "valid") else 0.4
            a.broken_barh(spans, (row - h / 2, h), color=_LANE_COLORS.get(output, "grey"))
        for output, ts in marks.items():
            marker = {"done": "|", "error": "x", "command_aborted": "v"}.get(output, ".")
            a.plot(
                ts,
                [row] * len(ts),
                marker=marker,
                color=_LANE_COLORS.get(output, "grey"),
                ms=9,
                mew=2,
                ls="none",
            )


def _finish_lane(a: Any, labels: list[str]) -> None:
    a.set_yticks(range(len(labels)))
    a.set_yticklabels(labels, fontsize=7)
    a.set_ylim(-0.7, len(labels) - 0.3)
    a.invert_yaxis()
    a.set_xlabel("time [s]")
    a.grid(True, axis="x", alpha=0.3)


def _axis_columns(grid: Any, lanes: dict[str, Any], member_of: dict[str, str]) -> None:
    """The per-axis scope: p/v/a/j rows and the state + FB lane row, one column per axis."""
    from motionplc.blocks import AxisState

    colors = {
        AxisState.DISABLED: "#d9d9d9",
        AxisState.STANDSTILL: "#a1d99b",
        AxisState.HOMING: "#fdd0a2",
        AxisState.DISCRETE_MOTION: "#9ecae1",
        AxisState.CONTINUOUS_MOTION: "#bcbddc",
        AxisState.SYNCHRONIZED_MOTION: "#c7e9c0",
        AxisState.STOPPING: "#fdae6b",
        AxisState.ERROR_STOP: "#d62728",
    }
    for j, ax_name in enumerate(lanes):
        ln = lanes[ax_name]
        t = ln["t"]
        for i, key in enumerate(("position", "velocity", "acceleration", "jerk")):
            a = grid[i][j]
            a.plot(t, ln[key], lw=1.2, drawstyle="steps-post" if key == "jerk" else "default")
            a.set_ylabel(key)
            a.grid(True, alpha=0.3)
        group = f" (group {member_of[ax_name]})" if ax_name in member_of else ""
        grid[0][j].set_title(f"axis {ax_name}{group}")
        a = grid[4][j]
        fbs = ln["fbs"]
        if len(t):
            _state_lane(a, t, ln["state"], colors, lambda s: AxisState(s).name)
        _fb_rows(a, fbs)
        _finish_lane(a, ["state", *fbs])


def _group_column(sub: Any, view: _GroupView, share: Any, max_segments: int) -> None:
    """A group's column: its path views, the path speed over time and the group state lane."""
    import numpy as np
    from matplotlib.collections import LineCollection
    from matplotlib.colors import Normalize

    from motionplc.blocks.enums import GroupState

    proj = view.projections()
    ratios = [3.0] * len(proj) + [1.0, 1.0]
    axs = sub.subplots(len(proj) + 2, 1, squeeze=False, gridspec_kw={"height_ratios": ratios})
    axs = axs[:, 0]
    pos, speed, t = view.positions, view.speed, view.t
    keep = decimate_path(pos, speed, max_segments) if len(pos) else np.arange(0)
    values = speed[keep[:-1]]
    norm = Normalize(0.0, _speed_scale(values))
    source = " (norm of the member velocities)" if view.speed_derived else ""
    for a, (i, j) in zip(axs, proj, strict=False):
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
        a.set_xlabel(f"{view.members[i]} position")
        a.set_ylabel(f"{view.members[j]} position")
        a.grid(True, alpha=0.3)
        sub.colorbar(lc, ax=a, label="path speed [m/s]")
    title = f"group {view.name}: {', '.join(view.members)}"
    if len(keep) < len(pos):
        title += f" ({len(keep) - 1} of {len(pos) - 1} segments drawn)"
    axs[0].set_title(title, fontsize=10)
    a = axs[-2]
    a.plot(t, speed, lw=1.2, color="#1f77b4")
    a.set_ylabel(f"path speed [m/s]{source}", fontsize=8 if source else None)
    a.grid(True, alpha=0.3)
    lane = axs[-1]
    if share is not None:  # the time range of the axis columns (sharex across subfigures
        a.set_xlim(share.get_xlim())  # would redraw the figure on every limit change)
        lane.set_xlim(share.get_xlim())
    if view.state is not None and len(t):
        _state_lane(lane, t, view.state, _GROUP_STATE_COLORS, lambda s: GroupState(s).name)
    _fb_rows(lane, view.fbs)
    _finish_lane(lane, ["state" if view.state is not None else "(no state)", *view.fbs])


# ---------------------------------------------------------------------------- HTML
def _html_plot(
    lanes: dict[str, Any],
    title: str,
    views: Sequence[_GroupView] = (),
    max_segments: int = MAX_PATH_SEGMENTS,
) -> str:
    """A self-contained HTML scope (inline SVG, hover shows values; no scripts from the web).

    With groups, a column of path views (``<svg class='path-view'>``, one per group) stands
    left of the per-axis lanes; without groups the page is the per-axis lanes only.
    """
    import html

    import numpy as np

    w, h, pad = 900, 120, 40
    head = [
        "<!doctype html><meta charset='utf-8'>",
        f"<title>{html.escape(title)}</title>",
        "<style>body{font-family:sans-serif;font-size:12px} svg{background:#fafafa;"
        "margin:2px 0} polyline{fill:none;stroke:#1f77b4;stroke-width:1.2}</style>",
        f"<h3>{html.escape(title)}</h3>",
    ]
    parts: list[str] = []
    for ax_name, ln in lanes.items():
        t = np.asarray(ln["t"], dtype=float)
        parts.append(f"<h4>axis {html.escape(ax_name)}</h4>")
        if t.size == 0:
            continue
        t0, t1 = float(t[0]), float(t[-1]) if t[-1] > t[0] else float(t[0]) + 1.0
        step = max(1, t.size // 2000)
        for key in ("position", "velocity", "acceleration", "jerk", "state"):
            y = np.asarray(ln[key], dtype=float)
            lo, hi = float(np.min(y)), float(np.max(y))
            hi = hi if hi > lo else lo + 1.0
            xs = pad + (t[::step] - t0) / (t1 - t0) * (w - 2 * pad)
            ys = h - 10 - (y[::step] - lo) / (hi - lo) * (h - 20)
            pts = " ".join(f"{a:.1f},{b:.1f}" for a, b in zip(xs, ys, strict=True))
            parts.append(
                f"<svg width='{w}' height='{h}'><title>{ax_name}.{key}: min {lo:.6g}, "
                f"max {hi:.6g}</title><text x='2' y='12'>{key} [{lo:.4g} .. {hi:.4g}]"
                f"</text><polyline points='{pts}'/></svg><br>"
            )
        rows = ln["fbs"]
        hh = 18 * (len(rows) + 1)
        svg = [f"<svg width='{w}' height='{hh}'>"]
        for r, (fb, items) in enumerate(rows.items()):
            y = 18 * r + 4
            svg.append(f"<text x='2' y='{y + 11}'>{html.escape(fb)}</text>")
            for output, ta, tb in items:
                x0 = pad + 60 + (ta - t0) / (t1 - t0) * (w - 2 * pad - 60)
                x1 = pad + 60 + (tb - t0) / (t1 - t0) * (w - 2 * pad - 60)
                color = _LANE_COLORS.get(output, "grey")
                svg.append(
                    f"<rect x='{x0:.1f}' y='{y}' width='{max(x1 - x0, 2):.1f}' height='12' "
                    f"fill='{color}'><title>{html.escape(fb)} {output} {ta:.3f}-{tb:.3f} s"
                    "</title></rect>"
                )
        svg.append("</svg>")
        parts.append("".join(svg))
    if not views:
        return "\n".join(head + parts) + "\n"
    head.insert(
        3,
        "<style>svg.path-view polyline{stroke-width:2;stroke-linejoin:round}"
        " .scope-row{display:flex;gap:24px;align-items:flex-start}</style>",
    )
    groups = [_html_group(k, v, max_segments) for k, v in enumerate(views)]
    return (
        "\n".join(
            [
                *head,
                "<div class='scope-row'><div class='groups'>",
                *groups,
                "</div><div class='axes'>",
                *parts,
                "</div></div>",
            ]
        )
        + "\n"
    )


def _html_group(k: int, view: _GroupView, max_segments: int) -> str:
    """One group's HTML: the path view (projections, speed-coloured, legend), speed and state."""
    import html

    import numpy as np

    from motionplc.blocks.enums import GroupState

    esc = html.escape
    pos, speed, t = view.positions, view.speed, np.asarray(view.t, dtype=float)
    keep = decimate_path(pos, speed, max_segments) if len(pos) else np.arange(0)
    values = np.asarray(speed[keep[:-1]], dtype=float)
    top = _speed_scale(values)
    levels = np.clip(np.round(values / top * (SPEED_LEVELS - 1)), 0, SPEED_LEVELS - 1).astype(int)
    palette = [speed_color(i / (SPEED_LEVELS - 1)) for i in range(SPEED_LEVELS)]
    proj = view.projections()
    size, pad, legend = 400.0, 30.0, 90
    kept = pos[keep] if len(keep) else np.zeros((0, len(view.members)))
    lo = kept.min(axis=0) if len(kept) else np.zeros(len(view.members))
    hi = kept.max(axis=0) if len(kept) else np.zeros(len(view.members))
    used = sorted({c for ij in proj for c in ij})
    extent = float(np.max(hi[used] - lo[used])) if used else 0.0
    scale = size / extent if extent > 0 else 1.0  # px per position unit, equal on every axis
    panels: list[str] = []
    y_off = 0.0
    width = 0.0
    for i, j in proj:
        pw = (hi[i] - lo[i]) * scale + 2 * pad
        ph = (hi[j] - lo[j]) * scale + 2 * pad
        xs = pad + (kept[:, i] - lo[i]) * scale
        ys = y_off + ph - pad - (kept[:, j] - lo[j]) * scale
        g = [
            f"<g class='projection' data-axes='{esc(view.members[i])},{esc(view.members[j])}' "
            f"data-segments='{max(len(keep) - 1, 0)}'>",
            f"<rect x='0' y='{y_off:.1f}' width='{pw:.1f}' height='{ph:.1f}' fill='none' "
            "stroke='#ccc'/>",
            f"<text x='{pw / 2:.1f}' y='{y_off + ph - 8:.1f}'>{esc(view.members[i])}</text>",
            f"<text x='4' y='{y_off + ph / 2:.1f}'>{esc(view.members[j])}</text>",
        ]
        for s, e in _runs(levels):  # one polyline per run of segments of one colour level
            pts = " ".join(f"{xs[m]:.1f},{ys[m]:.1f}" for m in range(s, e + 1))
            v_lo, v_hi = float(np.min(values[s:e])), float(np.max(values[s:e]))
            g.append(
                f"<polyline class='speed' points='{pts}' style='stroke:{palette[levels[s]]}'>"
                f"<title>{v_lo:.4g} .. {v_hi:.4g} m/s</title></polyline>"
            )
        if len(kept):
            g.append(
                f"<circle class='start' cx='{xs[0]:.1f}' cy='{ys[0]:.1f}' r='7' fill='none' "
                "stroke='#2ca02c' stroke-width='2'><title>start</title></circle>"
            )
            g.append(
                f"<rect class='end' x='{xs[-1] - 4:.1f}' y='{ys[-1] - 4:.1f}' width='8' "
                "height='8' fill='#d62728'><title>end</title></rect>"
            )
        g.append("</g>")
        panels.append("".join(g))
        y_off += ph + 6
        width = max(width, pw)
    gid = f"speed-scale-{k}"
    stops = "".join(
        f"<stop offset='{i / (len(_VIRIDIS) - 1):.4f}' stop-color='{c}'/>"
        for i, c in enumerate(_VIRIDIS)
    )
    height = max(y_off, 200.0)
    bar_x, bar_h = width + 20, min(height - 40, 300.0)
    legend_svg = (
        f"<defs><linearGradient id='{gid}' x1='0' y1='1' x2='0' y2='0'>{stops}"
        f"</linearGradient></defs><g class='speed-scale' data-top='{top:.6g}'>"
        f"<rect x='{bar_x:.1f}' y='20' width='14' height='{bar_h:.1f}' fill='url(#{gid})'/>"
        f"<text x='{bar_x + 18:.1f}' y='28'>{top:.4g}</text>"
        f"<text x='{bar_x + 18:.1f}' y='{20 + bar_h:.1f}'>0</text>"
        f"<text x='{bar_x:.1f}' y='12'>path speed [m/s]</text></g>"
    )
    note = " (norm of the member velocities)" if view.speed_derived else ""
    drawn = f"{len(keep) - 1} of {len(pos) - 1} segments drawn" if len(keep) < len(pos) else "all"
    out = [
        f"<h4>group {esc(view.name)}: {esc(', '.join(view.members))}</h4>",
        f"<svg class='path-view' data-group='{esc(view.name)}' "
        f"data-axes='{esc(','.join(view.members))}' data-scale='{scale:.6g}' "
        f"width='{width + legend + 30:.0f}' height='{height:.0f}'>"
        f"<title>group {esc(view.name)}: path coloured by path speed 0 .. {top:.4g} m/s{note}"
        f" ({drawn} segments)</title>",
        *panels,
        legend_svg,
        "</svg><br>",
    ]
    if t.size:
        w, h, lpad = 500, 100, 40
        t0, t1 = float(t[0]), float(t[-1]) if t[-1] > t[0] else float(t[0]) + 1.0
        idx = decimate_path(np.column_stack([t, speed]), speed, 2000)
        v_hi = max(float(np.max(speed)), 1e-12)
        xs = lpad + (t[idx] - t0) / (t1 - t0) * (w - 2 * lpad)
        ys = h - 10 - np.asarray(speed[idx], dtype=float) / v_hi * (h - 20)
        pts = " ".join(f"{a:.1f},{b:.1f}" for a, b in zip(xs, ys, strict=True))
        out.append(
            f"<svg class='path-speed' width='{w}' height='{h}'><title>{esc(view.name)} path "
            f"speed: max {v_hi:.6g} m/s</title><text x='2' y='12'>path speed [m/s]{note} "
            f"[0 .. {v_hi:.4g}]</text><polyline points='{pts}'/></svg><br>"
        )
        rows = [("state", None), *((fb, items) for fb, items in view.fbs.items())]
        svg = [f"<svg class='group-lanes' width='{w}' height='{18 * (len(rows) + 1)}'>"]

        label_w = min(7 * max(len(label) for label, _ in rows), 180)  # FB names fit

        def x_of(tt: float) -> float:
            return label_w + 8 + (tt - t0) / (t1 - t0) * (w - label_w - 8 - lpad)

        for r, (label, items) in enumerate(rows):
            y = 18 * r + 4
            svg.append(f"<text x='2' y='{y + 11}'>{esc(label)}</text>")
            if items is None:
                if view.state is None:
                    continue
                for s, e in _runs(view.state):
                    st = int(view.state[s])
                    ta, tb = float(t[s]), float(t[min(e, len(t) - 1)])
                    name = GroupState(st).name if st in GroupState._value2member_map_ else st
                    svg.append(
                        f"<rect class='state' x='{x_of(ta):.1f}' y='{y}' "
                        f"width='{max(x_of(tb) - x_of(ta), 1):.1f}' height='12' "
                        f"fill='{_GROUP_STATE_COLORS.get(st, 'grey')}'><title>{name} "
                        f"{ta:.3f}-{tb:.3f} s</title></rect>"
                    )
                continue
            for output, ta, tb in items:
                svg.append(
                    f"<rect x='{x_of(ta):.1f}' y='{y}' width='{max(x_of(tb) - x_of(ta), 2):.1f}' "
                    f"height='12' fill='{_LANE_COLORS.get(output, 'grey')}'><title>"
                    f"{esc(label)} {output} {ta:.3f}-{tb:.3f} s</title></rect>"
                )
        svg.append("</svg>")
        out.append("".join(svg))
    return "\n".join(out)
