"""The PLC scope: plots of a trace (per-axis p/v/a/j, state and FB lanes) as PNG or HTML.

:func:`read_trace` reads a trace CSV written by ``motionplc run --trace`` (FB edges from the
``*.events.csv`` next to it), :func:`trace_from_runtime` takes the same data from a live runtime,
and :func:`write_plot` writes a ``.png`` (needs matplotlib, imported only when drawing) or a
self-contained ``.html`` (no dependencies).
"""

from __future__ import annotations

import csv
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from motionplc.errors import MotionPlcError


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


def trace_from_runtime(rt: Any) -> ScopeTrace:
    """The scope data of a runtime's trace ring (the cycles it still holds)."""
    import numpy as np

    columns = list(rt.trace.columns)
    data = np.asarray(rt.trace.array(), dtype=float)
    events = [(int(e.cycle), e.fb, e.output, bool(e.value)) for e in rt.trace.events]
    return ScopeTrace(columns, data, events)


def read_trace(path: Path) -> ScopeTrace:
    """Read a trace CSV (``motionplc run --trace``) and its ``*.events.csv`` if present.

    Raises :class:`MotionPlcError` located at ``file:line`` for anything that is not a trace.
    """
    import numpy as np

    from motionplc.blocks import AxisState

    try:
        with path.open(newline="") as fh:
            rows = list(csv.reader(fh))
    except OSError as exc:
        raise MotionPlcError(f"{path}: cannot read: {exc.strerror or exc}") from None
    if not rows or rows[0][:2] != ["cycle", "t"]:
        raise MotionPlcError(f"{path}:1: not a motionplc trace (expected columns cycle, t, ...)")
    columns = rows[0]
    states = {s.name: float(s.value) for s in AxisState}
    data = np.empty((len(rows) - 1, len(columns)))
    for i, row in enumerate(rows[1:]):
        if len(row) != len(columns):
            raise MotionPlcError(f"{path}:{i + 2}: {len(row)} values for {len(columns)} columns")
        for j, x in enumerate(row):
            try:
                data[i, j] = states[x] if x in states else float(x)
            except ValueError:
                raise MotionPlcError(f"{path}:{i + 2}: {columns[j]}: not a number: {x!r}") from None
    events: list[Event] = []
    ev_path = path.with_suffix(".events.csv")
    if ev_path.is_file():
        with ev_path.open(newline="") as fh:
            for row in list(csv.reader(fh))[1:]:
                if len(row) == 4:
                    events.append((int(row[0]), row[1], row[2], row[3] == "True"))
    return ScopeTrace(columns, data, events)


def _lanes(columns: list[str], data: Any, events: list[Event]) -> dict[str, Any]:
    """Per axis: p/v/a/j arrays, state segments and FB intervals (busy/active, done/error)."""
    t = data[:, 1] if len(data) else data
    cycles = data[:, 0] if len(data) else data
    axes = [c[: -len(".position")] for c in columns if c.endswith(".position")]
    axes = [a for a in axes if "." not in a]
    t0 = float(t[0]) if len(t) else 0.0
    dt = float(t[1] - t[0]) if len(t) > 1 else 0.001
    c0 = int(cycles[0]) if len(cycles) else 0
    out: dict[str, Any] = {}
    for ax in axes:
        col = {
            f: data[:, columns.index(f"{ax}.{f}")]
            for f in ("position", "velocity", "acceleration", "jerk", "state")
        }
        fbs: dict[str, list[tuple[str, float, float]]] = {}
        open_: dict[tuple[str, str], float] = {}
        for cyc, fb, output, value in events:
            if not fb.startswith(ax + "."):
                continue
            label = fb[len(ax) + 1 :]
            tt = t0 + (cyc - c0) * dt
            lst = fbs.setdefault(label, [])
            if output in ("busy", "active", "valid", "status", "in_velocity"):
                if value:
                    open_[(label, output)] = tt
                elif (label, output) in open_:
                    lst.append((output, open_.pop((label, output)), tt))
            elif output in ("done", "error", "command_aborted") and value:
                lst.append((output, tt, tt))
        t_end = float(t[-1]) if len(t) else 0.0
        for (label, output), ts in open_.items():
            fbs.setdefault(label, []).append((output, ts, t_end))
        out[ax] = {"t": t, **col, "fbs": fbs}
    return out


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


def write_plot(out: Path, trace: ScopeTrace, title: str) -> None:
    """Write the scope of ``trace`` to ``out``: ``.html``/``.htm`` as inline SVG, else a PNG.

    Raises :class:`MotionPlcError` for a trace without axis columns and
    :class:`PlotDependencyError` for a PNG without matplotlib; creates the parent directory.
    """
    lanes = _lanes(trace.columns, trace.data, trace.events)
    if not lanes:
        raise MotionPlcError(f"{title}: the trace has no axis columns")
    out.parent.mkdir(parents=True, exist_ok=True)
    if out.suffix.lower() in (".html", ".htm"):
        out.write_text(_html_plot(lanes, title), encoding="utf-8")
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
    from motionplc.blocks import AxisState

    names = list(lanes)
    fig, grid = plt.subplots(
        5,
        len(names),
        sharex=True,
        figsize=(6.5 * len(names), 11),
        squeeze=False,
        gridspec_kw={"height_ratios": [1, 1, 1, 1, 1.4]},
    )
    for j, ax_name in enumerate(names):
        ln = lanes[ax_name]
        t = ln["t"]
        for i, (key, label) in enumerate(
            (
                ("position", "position"),
                ("velocity", "velocity"),
                ("acceleration", "acceleration"),
                ("jerk", "jerk"),
            )
        ):
            a = grid[i][j]
            a.plot(t, ln[key], lw=1.2, drawstyle="steps-post" if key == "jerk" else "default")
            a.set_ylabel(label)
            a.grid(True, alpha=0.3)
        grid[0][j].set_title(f"axis {ax_name}")
        a = grid[4][j]
        fbs = ln["fbs"]
        labels = ["state", *fbs]
        state = ln["state"]
        if len(t):
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
            start = 0
            for k in range(1, len(t) + 1):
                if k == len(t) or state[k] != state[start]:
                    s = int(state[start])
                    a.broken_barh(
                        [(t[start], t[min(k, len(t) - 1)] - t[start])],
                        (-0.4, 0.8),
                        color=colors.get(AxisState(s), "grey"),
                    )
                    dur = t[min(k, len(t) - 1)] - t[start]
                    if dur > 0.06 * (t[-1] - t[0] + 1e-12):
                        a.text(
                            t[start] + dur / 2,
                            0,
                            AxisState(s).name.lower(),
                            ha="center",
                            va="center",
                            fontsize=6,
                        )
                    start = k
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
        a.set_yticks(range(len(labels)))
        a.set_yticklabels(labels, fontsize=7)
        a.set_ylim(-0.7, len(labels) - 0.3)
        a.invert_yaxis()
        a.set_xlabel("time [s]")
        a.grid(True, axis="x", alpha=0.3)
    fig.suptitle(
        f"{title} - FB lanes: busy (light), active (dark), valid/status (green), "
        "done |, error x, aborted v",
        fontsize=9,
    )
    fig.tight_layout()
    fig.savefig(out, dpi=90)
    plt.close(fig)


def _html_plot(lanes: dict[str, Any], title: str) -> str:
    """A self-contained HTML scope (inline SVG, hover shows values; no scripts from the web)."""
    import html

    import numpy as np

    w, h, pad = 900, 120, 40
    parts = [
        "<!doctype html><meta charset='utf-8'>",
        f"<title>{html.escape(title)}</title>",
        "<style>body{font-family:sans-serif;font-size:12px} svg{background:#fafafa;"
        "margin:2px 0} polyline{fill:none;stroke:#1f77b4;stroke-width:1.2}</style>",
        f"<h3>{html.escape(title)}</h3>",
    ]
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
    return "\n".join(parts) + "\n"
