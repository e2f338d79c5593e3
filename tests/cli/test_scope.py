"""The scope with axes groups: path views coloured by speed, the groups sidecar, decimation.

Traces are synthesized here: a rectangle with rounded corners on x/y (counter-clockwise from
the middle of the bottom edge), a smooth path speed 0 -> max -> 0, written as a trace CSV like
``motionplc run --trace`` writes, plus the ``*.groups.json`` sidecar.
"""

from __future__ import annotations

import base64
import csv
import json
import re
import struct
from pathlib import Path
from types import SimpleNamespace
from typing import Any

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from motionplc.cli import main
from motionplc.errors import MotionPlcError
from motionplc.scope import (
    HTML_DIV_ID,
    PNG_COLUMN_WIDTH,
    PNG_DPI,
    PNG_ROW_HEIGHT,
    ScopeTrace,
    decimate_path,
    groups_sidecar_path,
    read_trace,
    trace_from_runtime,
    write_groups_sidecar,
)

WIDTH, HEIGHT, RADIUS = 0.6, 0.3, 0.05


def rounded_rectangle(s: np.ndarray) -> tuple[np.ndarray, float]:
    """Points at arc lengths ``s`` along the rounded rectangle, and its perimeter."""
    ex, ey, q = WIDTH - 2 * RADIUS, HEIGHT - 2 * RADIUS, np.pi * RADIUS / 2
    pieces = []  # (length, start point, direction or None, corner centre, start angle)
    x, y = RADIUS, 0.0
    for k, (e, d) in enumerate(((ex, (1, 0)), (ey, (0, 1)), (ex, (-1, 0)), (ey, (0, -1)))):
        pieces.append((e, (x, y), d, None, 0.0))
        x, y = x + e * d[0], y + e * d[1]
        a0 = -np.pi / 2 + k * np.pi / 2
        centre = (x - RADIUS * np.cos(a0), y - RADIUS * np.sin(a0))
        pieces.append((q, (x, y), None, centre, a0))
        x, y = (
            centre[0] + RADIUS * np.cos(a0 + np.pi / 2),
            centre[1] + RADIUS * np.sin(a0 + np.pi / 2),
        )
    per = sum(p[0] for p in pieces)
    out = np.empty((len(s), 2))
    base = 0.0
    for length, start, d, centre, a0 in pieces:
        m = (s >= base) & (s <= base + length)
        u = s[m] - base
        if d is not None:
            out[m] = np.array(start) + np.outer(u, d)
        else:
            a = a0 + u / RADIUS
            out[m] = np.array(centre) + RADIUS * np.column_stack([np.cos(a), np.sin(a)])
        base += length
    return out, per


def write_trace(
    path: Path,
    n: int = 3001,
    groups: dict[str, list[str]] | None = None,
    speed_column: bool = True,
    state_column: bool = True,
) -> dict[str, np.ndarray]:
    """A 2-axis (x, y) trace of one lap; with ``groups`` its columns and sidecar."""
    dt = 0.001
    t = np.arange(n) * dt
    _, per = rounded_rectangle(np.zeros(1))
    s = np.clip(per * (1 - np.cos(np.pi * t / t[-1])) / 2, 0.0, per)
    speed = np.abs(per * np.pi / t[-1] * np.sin(np.pi * t / t[-1]) / 2)
    p, _ = rounded_rectangle(s)
    vel = np.gradient(p, dt, axis=0)
    acc = np.gradient(vel, dt, axis=0)
    jerk = np.gradient(acc, dt, axis=0)
    cols = ["cycle", "t"]
    fields = ("position", "velocity", "acceleration", "jerk", "actual_position", "state")
    for ax in "xy":
        cols += [f"{ax}.{f}" for f in fields]
    for g in groups or {}:
        cols += [f"{g}.path_velocity"] if speed_column else []
        cols += [f"{g}.state"] if state_column else []
    with path.open("w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(cols)
        for i in range(n):
            moving = 0 < i < n - 1
            row: list[object] = [i, repr(float(t[i]))]
            for k in range(2):
                state = "SYNCHRONIZED_MOTION" if moving else "STANDSTILL"
                row += [p[i, k], vel[i, k], acc[i, k], jerk[i, k], p[i, k], state]
            for _g in groups or {}:
                row += [speed[i]] if speed_column else []
                row += ["GROUP_MOVING" if moving else "GROUP_STANDBY"] if state_column else []
            w.writerow(row)
    with path.with_suffix(".events.csv").open("w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["cycle", "fb", "output", "value"])
        w.writerows([[1, "x.move", "busy", True], [n - 2, "x.move", "busy", False]])
        w.writerow([n - 2, "x.move", "done", True])
    if groups is not None:
        write_groups_sidecar(path, groups)
    vnorm = np.sqrt(np.sum(vel * vel, axis=1))  # the members' speed: colours the path view
    return {"t": t, "p": p, "speed": speed, "vnorm": vnorm}


def png_size(path: Path) -> tuple[int, int]:
    data = path.read_bytes()
    assert data[:8] == b"\x89PNG\r\n\x1a\n" and data[12:16] == b"IHDR"
    return struct.unpack(">II", data[16:24])


def _arrays(obj: Any) -> Any:
    """plotly's JSON with its base64 typed arrays (``{"dtype", "bdata"}``) as numpy arrays."""
    if isinstance(obj, dict):
        if set(obj) >= {"dtype", "bdata"}:
            a = np.frombuffer(base64.b64decode(obj["bdata"]), dtype=np.dtype(obj["dtype"]))
            return a.reshape(obj["shape"]) if "shape" in obj else a
        return {k: _arrays(v) for k, v in obj.items()}
    if isinstance(obj, list):
        return [_arrays(v) for v in obj]
    return obj


def plotly_figure(page: str) -> tuple[list[dict[str, Any]], dict[str, Any], dict[str, Any]]:
    """(traces, layout, config) of the ``Plotly.newPlot`` call embedded in an HTML page."""
    start = page.index("Plotly.newPlot(") + len("Plotly.newPlot(")
    dec = json.JSONDecoder()
    parts = []
    pos = start
    for _ in range(4):
        while page[pos] in " \n\t,":
            pos += 1
        obj, pos = dec.raw_decode(page, pos)
        parts.append(obj)
    div, data, layout, config = parts
    assert div == HTML_DIV_ID
    return _arrays(data), _arrays(layout), config


def traces_named(data: list[dict[str, Any]], name: str) -> list[dict[str, Any]]:
    return [d for d in data if d.get("name") == name]


def path_traces(data: list[dict[str, Any]]) -> list[dict[str, Any]]:
    return [d for d in data if " path (" in d.get("name", "")]


# ---------------------------------------------------------------------------- PNG
def test_png_group_card_spans_two_grid_columns(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    plain = tmp_path / "plain.csv"
    write_trace(plain)
    grouped = tmp_path / "grouped.csv"
    write_trace(grouped, groups={"g": ["x", "y"]})
    assert main(["plot", str(plain), "-o", str(tmp_path / "plain.png")]) == 0
    assert main(["plot", str(grouped)]) == 0  # default output: TRACE.png
    assert f"wrote {tmp_path / 'grouped.png'}" in capsys.readouterr().out
    w0, h0 = png_size(tmp_path / "plain.png")
    w1, h1 = png_size(tmp_path / "grouped.png")
    col, row = round(PNG_COLUMN_WIDTH * PNG_DPI), round(PNG_ROW_HEIGHT * PNG_DPI)
    assert w0 == 2 * col and row < h0 < row + 2 * PNG_DPI  # two axis cards in one row
    assert w1 == 4 * col and row < h1 < row + 2 * PNG_DPI  # plus a group card, two wide
    assert (tmp_path / "grouped.png").stat().st_size > 30_000  # not an empty canvas


# ---------------------------------------------------------------------------- HTML
def test_html_path_view_colours_points_by_speed(tmp_path: Path) -> None:
    trace = tmp_path / "t.csv"
    ref = write_trace(trace, n=4001, groups={"g": ["x", "y"]})
    out = tmp_path / "t.html"
    from motionplc.scope import write_plot

    write_plot(out, read_trace(trace), "t", max_segments=400)
    data, layout, _ = plotly_figure(out.read_text())
    (path,) = path_traces(data)
    assert path["name"] == "g path (x, y)"
    # coloured by the members' velocity norm (not the group's path_velocity column, which is 0
    # while the members move on their own)
    keep = decimate_path(ref["p"], ref["vnorm"], 400)
    assert 100 < len(keep) - 1 <= 400  # decimated: corners and speed extremes kept
    assert np.array_equal(path["x"], ref["p"][keep, 0])
    assert np.array_equal(path["y"], ref["p"][keep, 1])
    marker = path["marker"]
    assert np.array_equal(marker["color"], ref["vnorm"][keep])
    assert marker["cmin"] == 0 and marker["cmax"] == pytest.approx(ref["vnorm"].max(), rel=1e-5)
    assert marker["showscale"] and marker["colorscale"][0][1] == "#440154"  # viridis
    # equal aspect: the y axis of the view is scaled to its x axis
    xa, ya = path["xaxis"].replace("x", "xaxis"), path["yaxis"].replace("y", "yaxis")
    assert layout[ya]["scaleanchor"] == path["xaxis"] and layout[ya]["scaleratio"] == 1
    assert layout[xa]["title"]["text"] == "x position [m or rad]"
    # start and end marked; the path speed over time on a linked time axis
    assert traces_named(data, "g start")[0]["x"] == [ref["p"][0, 0]]
    assert traces_named(data, "g end")[0]["y"] == [ref["p"][-1, 1]]
    (speed,) = traces_named(data, "g.path_velocity")
    assert speed["xaxis"] == "x" and layout["xaxis2"]["matches"] == "x"
    assert layout[speed["yaxis"].replace("y", "yaxis")]["title"]["text"] == (
        "path speed [m/s or rad/s]"
    )
    # the per-axis columns are still there, right of the group's
    titles = [a["text"] for a in layout["annotations"]]
    assert titles[0].startswith("<b>group g: x, y</b> (") and "segments drawn" in titles[0]
    assert titles[1:] == ["<b>axis x (group g)</b>", "<b>axis y (group g)</b>"]
    states = [d["name"] for d in data if d.get("legendgroup") == "states"]
    assert {"GROUP_MOVING", "SYNCHRONIZED_MOTION", "STANDSTILL"} <= set(states)


def test_html_three_axis_group_has_xy_and_xz(tmp_path: Path) -> None:
    trace = tmp_path / "t.csv"
    write_trace(trace, groups={"g": ["x", "y"]})
    data = read_trace(trace)
    # add a z axis (z = x / 2) and make it the group's third member
    cols = list(data.columns)
    z = {f: data.data[:, cols.index(f"x.{f}")] / 2 for f in ("position", "velocity")}
    extra = np.column_stack(
        [z["position"], z["velocity"], 0 * z["position"], 0 * z["position"], 0 * z["position"] + 5]
    )
    cols += ["z.position", "z.velocity", "z.acceleration", "z.jerk", "z.state"]
    tr = ScopeTrace(cols, np.hstack([data.data, extra]), data.events, {"g": ["x", "y", "z"]})
    from motionplc.scope import write_plot

    write_plot(tmp_path / "t.html", tr, "t")
    traces, layout, _ = plotly_figure((tmp_path / "t.html").read_text())
    views = path_traces(traces)
    assert [v["name"] for v in views] == ["g path (x, y)", "g path (x, z)"]
    assert np.array_equal(views[1]["y"], views[0]["x"] / 2)
    assert [v["marker"]["showscale"] for v in views] == [True, False]  # one colour scale
    write_plot(tmp_path / "t.png", tr, "t")
    w, h = png_size(tmp_path / "t.png")  # one row: the group card (two columns), x, y, z
    assert w == round(5 * PNG_COLUMN_WIDTH * PNG_DPI)
    assert PNG_ROW_HEIGHT * PNG_DPI < h < (PNG_ROW_HEIGHT + 2) * PNG_DPI


def test_speed_from_member_velocities_without_a_speed_column(tmp_path: Path) -> None:
    trace = tmp_path / "t.csv"
    write_trace(trace, groups={"g": ["x", "y"]}, speed_column=False, state_column=False)
    assert main(["plot", str(trace), "-o", str(tmp_path / "t.html")]) == 0
    data, layout, _ = plotly_figure((tmp_path / "t.html").read_text())
    (speed,) = traces_named(data, "g.path_velocity")
    title = layout[speed["yaxis"].replace("y", "yaxis")]["title"]["text"]
    assert title.endswith("(norm of member velocities)")
    read = read_trace(trace)
    vx = read.data[:, read.columns.index("x.velocity")]
    vy = read.data[:, read.columns.index("y.velocity")]
    (path,) = path_traces(data)
    assert path["marker"]["cmax"] == pytest.approx(float(np.max(np.hypot(vx, vy))), rel=1e-9)
    # no group state: its lane says so and it has no state spans
    group_lanes = [ax for ax in layout.values() if isinstance(ax, dict) and "ticktext" in ax]
    assert group_lanes[0]["ticktext"][0] == "(no state)"
    assert not [d for d in data if d.get("name", "").startswith("GROUP_")]


def test_traces_without_groups_plot_as_before(tmp_path: Path) -> None:
    """The axis columns do not depend on the groups: same traces, same data."""
    plain, grouped = tmp_path / "a.csv", tmp_path / "b.csv"
    write_trace(plain)
    write_trace(grouped, groups={"g": ["x", "y"]})
    assert read_trace(plain).groups == {}
    assert read_trace(grouped).groups == {"g": ["x", "y"]}
    assert main(["plot", str(plain), "-o", str(tmp_path / "a.html")]) == 0
    assert main(["plot", str(grouped), "-o", str(tmp_path / "b.html")]) == 0
    a, la, _ = plotly_figure((tmp_path / "a.html").read_text())
    b, lb, _ = plotly_figure((tmp_path / "b.html").read_text())
    assert not path_traces(a) and len(path_traces(b)) == 1
    assert [x["text"] for x in la["annotations"]] == ["<b>axis x</b>", "<b>axis y</b>"]

    def channels(data: list[dict[str, Any]]) -> dict[str, Any]:
        return {d["name"]: d["y"] for d in data if d["name"][:2] in ("x.", "y.")}

    ca, cb = channels(a), channels(b)
    assert sorted(ca) == sorted(cb) and len(ca) >= 10
    for k in ca:
        assert np.array_equal(np.asarray(ca[k], dtype=object), np.asarray(cb[k], dtype=object)), k


# ---------------------------------------------------------------------------- sidecar
@pytest.mark.parametrize(
    ("text", "message"),
    [
        ('{"groups": {"g": ["x", "y"]', r"t\.groups\.json:1:\d+: not valid JSON"),
        ('{"groups": {"g": "xy"}}', r"t\.groups\.json: groups\.g: expected a non-empty list"),
        ('{"groups": {"g": ["x", 3]}}', r"t\.groups\.json: groups\.g\[1\]: not an axis name"),
        ('{"groups": {"g": ["x", "q"]}}', r"t\.groups\.json: groups\.g: axis 'q' has no columns"),
        ('{"group": {}}', r"t\.groups\.json: group: unknown key \(allowed: groups\)"),
        ("[1, 2]", r"t\.groups\.json: expected an object"),
    ],
)
def test_a_broken_sidecar_is_a_located_error(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], text: str, message: str
) -> None:
    trace = tmp_path / "t.csv"
    write_trace(trace, n=50, groups={"g": ["x", "y"]})
    groups_sidecar_path(trace).write_text(text)
    assert main(["plot", str(trace), "-o", str(tmp_path / "t.html")]) == 2
    err = capsys.readouterr().err
    assert re.search(message, err), err
    assert err.startswith("motionplc: error: ") and "Traceback" not in err
    assert not (tmp_path / "t.html").exists()


def test_sidecar_round_trip_and_bad_groups(tmp_path: Path) -> None:
    trace = tmp_path / "run.csv"
    path = write_groups_sidecar(trace, {"g": ("x", "y", "z"), "h": ["a", "b"]})
    assert path == tmp_path / "run.groups.json"
    from motionplc.scope import read_groups_sidecar

    assert read_groups_sidecar(trace) == {"g": ["x", "y", "z"], "h": ["a", "b"]}
    assert read_groups_sidecar(tmp_path / "other.csv") == {}
    with pytest.raises(MotionPlcError, match=r"groups\.g: an axis is listed twice"):
        write_groups_sidecar(trace, {"g": ["x", "x"]})
    with pytest.raises(MotionPlcError, match=r"groups\.g\.h: not a group name"):
        write_groups_sidecar(trace, {"g.h": ["x"]})


def test_groups_from_the_runtime() -> None:
    trace = SimpleNamespace(columns=["cycle", "t"], array=lambda: np.zeros((0, 2)), events=[])
    rt = SimpleNamespace(trace=trace, groups={"g": SimpleNamespace(axis_names=("x", "y"))})
    assert trace_from_runtime(rt).groups == {"g": ["x", "y"]}
    assert trace_from_runtime(SimpleNamespace(trace=trace)).groups == {}


# ---------------------------------------------------------------------------- decimation
def test_decimation_keeps_everything_below_the_bound() -> None:
    p = np.random.default_rng(1).normal(size=(101, 2))
    assert np.array_equal(decimate_path(p, np.ones(101), 100), np.arange(101))
    with pytest.raises(ValueError, match="max_segments"):
        decimate_path(p, np.ones(101), 3)
    with pytest.raises(ValueError, match="speed"):
        decimate_path(p, np.ones(100), 100)


@settings(max_examples=40, deadline=None)
@given(
    n_corners=st.integers(1, 12),
    dims=st.integers(2, 3),
    max_segments=st.integers(8, 400),
    spacing=st.integers(20, 200),
    seed=st.integers(0, 2**31),
)
def test_decimation_keeps_corners_and_speed_extremes(
    n_corners: int, dims: int, max_segments: int, spacing: int, seed: int
) -> None:
    """A polyline with exact-stop corners (a dwell at each vertex), sampled densely: each corner
    alone in its bucket is kept, and so is every corner when the edges span two buckets each;
    the fastest and slowest samples are kept."""
    rng = np.random.default_rng(seed)
    vertices = rng.uniform(-1, 1, size=(n_corners + 2, dims))
    pts, corners = [vertices[:1]], []
    for a, b in zip(vertices[:-1], vertices[1:], strict=True):
        pts.append(a + np.outer(np.linspace(0, 1, spacing + 1)[1:], b - a))
        corners.append(sum(len(x) for x in pts) - 1)
        pts.append(np.repeat(b[None, :], 3, axis=0))  # dwell at the corner
    corners = corners[:-1]  # the last vertex is the end point
    p = np.vstack(pts)
    n = len(p)
    speed = np.concatenate([[0.0], np.linalg.norm(np.diff(p, axis=0), axis=1)])
    speed += rng.uniform(0, 1e-3, size=n)
    keep = decimate_path(p, speed, max_segments)
    assert keep[0] == 0 and keep[-1] == n - 1 and np.all(np.diff(keep) > 0)
    assert len(keep) - 1 <= max_segments
    kept = set(keep.tolist())
    assert int(np.argmax(speed)) in kept and int(np.argmin(speed)) in kept
    drawn = {tuple(x) for x in p[keep]}  # a corner is drawn when its point is a vertex
    if n - 1 <= max_segments:
        assert len(keep) == n
        return
    nb = max_segments // 4
    bounds = np.round(np.linspace(0, n - 1, nb + 1)).astype(int)
    bucket_of = np.searchsorted(bounds, corners, side="left")  # interior of (b[k-1], b[k])
    for c, k in zip(corners, bucket_of, strict=True):
        alone = np.count_nonzero(bucket_of == k) == 1
        if alone or c == bounds[min(k, nb)]:
            assert tuple(p[c]) in drawn, (c, bounds[k - 1 : k + 1])
    if (n - 1) / nb * 2 <= spacing:  # every edge spans two buckets: no bucket has two corners
        assert {tuple(p[c]) for c in corners} <= drawn


# ---------------------------------------------------------------------------- reading
def test_reading_is_exact_and_locates_bad_values(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    from motionplc.blocks import AxisState
    from motionplc.blocks.enums import GroupState
    from motionplc.scope import _parse_rows

    trace = tmp_path / "t.csv"
    write_trace(trace, n=200, groups={"g": ["x", "y"]})
    data = read_trace(trace)
    states = {s.name: float(s.value) for s in (*AxisState, *GroupState)}
    assert np.array_equal(data.data, _parse_rows(trace, data.columns, states))  # row by row
    rows = list(csv.reader(trace.open()))
    assert data.data[1, data.columns.index("g.state")] == GroupState.GROUP_MOVING
    assert data.data[1, data.columns.index("x.position")] == float(rows[2][2])
    j = data.columns.index("x.velocity")
    for line, row, message in (
        (58, [*rows[57][:j], "abc", *rows[57][j + 1 :]], r"t\.csv:58: x\.velocity: not a number"),
        (10, rows[9][:5], rf"t\.csv:10: 5 values for {len(rows[0])} columns"),
    ):
        bad = [*rows[: line - 1], row, *rows[line:]]
        with trace.open("w", newline="") as fh:
            csv.writer(fh).writerows(bad)
        assert main(["plot", str(trace), "-o", str(tmp_path / "t.html")]) == 2
        err = capsys.readouterr().err
        assert re.search(message, err) and "Traceback" not in err, err


# ---------------------------------------------------------------------------- the runtime
def test_a_runtime_group_round_trips_through_csv_and_sidecar(tmp_path: Path) -> None:
    """A real group (x, y) blends a 0.3 x 0.2 rectangle: the plot from the runtime and from
    the CSV + sidecar agree byte for byte, the group state is written by name, the path view
    has the rectangle's extent and its colour scale tops at the fastest path speed."""
    from motionplc.blocks import MC_Power
    from motionplc.blocks.enums import BufferMode, GroupState, TransitionMode
    from motionplc.blocks.group_blocks import MC_GroupEnable, MC_MoveLinearAbsolute
    from motionplc.runtime import Runtime
    from motionplc.scope import write_plot

    rt = Runtime(cycle=0.001)
    for n in "xy":
        rt.add_axis(n, v_max=1.0, a_max=4.0, j_max=40.0)
    g = rt.add_group("g", ["x", "y"])
    powers = [MC_Power(axis=rt.axes[n], enable=True) for n in "xy"]
    enable = MC_GroupEnable(axes_group=g)
    corners = [(0.3, 0.0), (0.3, 0.2), (0.0, 0.2), (0.0, 0.0)]
    moves = [
        MC_MoveLinearAbsolute(
            axes_group=g,
            execute=True,
            position=p,
            velocity=0.5,
            buffer_mode=BufferMode.BLENDING_LOW if i else BufferMode.ABORTING,
            transition_mode=TransitionMode.TM_MAX_CORNER_DEVIATION if i else TransitionMode.TM_NONE,
            transition_parameter=0.01 if i else 0.0,
        )
        for i, p in enumerate(corners)
    ]

    def program(ctx: object) -> None:
        for fb in powers:
            fb()
        enable(execute=all(fb.status for fb in powers))
        if enable.done:
            for m in moves:
                m()

    rt.add_task("main", program)
    assert rt.run_until(lambda: moves[-1].done, max_seconds=10)
    live = trace_from_runtime(rt)
    assert live.groups == {"g": ["x", "y"]}
    trace = tmp_path / "run.csv"
    rt.trace.to_csv(trace, events_path=trace.with_suffix(".events.csv"))
    write_groups_sidecar(trace, {n: list(gr.axis_names) for n, gr in rt.groups.items()})
    read = read_trace(trace)
    assert read.groups == live.groups and read.columns == live.columns
    assert np.array_equal(read.data, live.data)
    assert "GROUP_MOVING" in trace.read_text()
    assert GroupState.GROUP_MOVING in read.data[:, read.columns.index("g.state")]
    for name, tr in (("live", live), ("read", read)):
        write_plot(tmp_path / f"{name}.html", tr, "run")
    page = (tmp_path / "live.html").read_text()
    assert page == (tmp_path / "read.html").read_text()
    data, _, _ = plotly_figure(page)
    (path,) = path_traces(data)
    ext = [np.ptp(path["x"]), np.ptp(path["y"])]
    assert ext == pytest.approx([0.3, 0.2], abs=1e-6)  # the blended rectangle, to scale
    pv = read.data[:, read.columns.index("g.path_velocity")]
    top = path["marker"]["cmax"]
    assert top == pytest.approx(pv.max(), rel=1e-9) and 0.4 < top <= 0.5 + 1e-9
