"""The interactive HTML scope of the demo: its embedded plotly figure, its rendering in headless
Chromium (screenshot and DOM, when /usr/bin/chromium exists), series plots, display
decimation of long traces and the messages for missing optional packages.

The screenshot and the PNG scope are kept in ``out/test-artefacts/`` (or
``$MOTIONPLC_ARTEFACTS``) for a human to look at.
"""

from __future__ import annotations

import importlib.util
import os
import re
import shutil
import sys
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from motionplc.cli import main
from motionplc.config import load_config
from motionplc.runtime.trace import axis_units
from motionplc.scope import (
    PlotDependencyError,
    ScopeTrace,
    minmax_indices,
    read_trace,
    write_plot,
    write_series_plot,
)
from tests.cli.test_scope import plotly_figure, png_size

ROOT = Path(__file__).resolve().parents[2]
DEMO = ROOT / "configs" / "demo.yaml"
DEMO_SEQ = ROOT / "configs" / "demo_sequence.yaml"
CHROMIUM = Path("/usr/bin/chromium")
CHANNELS = (
    "position",
    "actual_position",
    "velocity",
    "actual_velocity",
    "acceleration",
    "jerk",
    "following_error",
)
QUANTITIES = ("position", "velocity", "acceleration", "jerk", "following error")


def artefacts() -> Path:
    """Where the screenshots are kept: $MOTIONPLC_ARTEFACTS or out/test-artefacts/."""
    path = Path(os.environ.get("MOTIONPLC_ARTEFACTS") or ROOT / "out" / "test-artefacts")
    path.mkdir(parents=True, exist_ok=True)
    return path


def screenshot_tool() -> Any:
    spec = importlib.util.spec_from_file_location(
        "scope_screenshot", ROOT / "tools" / "scope_screenshot.py"
    )
    assert spec is not None and spec.loader is not None
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def yaxis(layout: dict[str, Any], trace: dict[str, Any]) -> dict[str, Any]:
    return layout[trace["yaxis"].replace("y", "yaxis")]


@pytest.fixture(scope="module")
def demo(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Any]:
    """The demo run through the CLI with --trace, and its HTML and PNG scopes."""
    out = tmp_path_factory.mktemp("demo")
    trace = out / "demo.csv"
    assert main(["run", str(DEMO), str(DEMO_SEQ), "--trace", str(trace), "-q"]) == 0
    data = read_trace(trace)
    write_plot(out / "scope.html", data, "demo")
    write_plot(out / "scope.png", data, "demo")
    axes = {a.name: a.units for a in load_config(DEMO).axes}
    return {
        "dir": out,
        "trace": data,
        "html": out / "scope.html",
        "png": out / "scope.png",
        "axes": axes,
    }


def expected_unit(demo: dict[str, Any], axis: str) -> str:
    """The demo trace's position unit: the config's once the trace records units, else the
    scope's honest 'm or rad' (a trace without units)."""
    if demo["trace"].units:
        assert demo["trace"].units[f"{axis}.position"] == demo["axes"][axis]
        return demo["axes"][axis]
    return "m or rad"


# ---------------------------------------------------------------------------- the figure
def test_demo_figure_has_every_channel_with_units_and_linked_time_axes(
    demo: dict[str, Any],
) -> None:
    page = demo["html"].read_text(encoding="utf-8")
    assert not re.search(r"<script[^>]*\bsrc=", page)  # plotly.js inlined: opens offline
    assert "cdn.plot.ly" not in page.split("Plotly.newPlot(")[1]
    data, layout, config = plotly_figure(page)
    assert config["scrollZoom"] is True
    assert layout["hovermode"] == "x unified" and layout["hoversubplots"] == "axis"
    tr = demo["trace"]
    for ax in demo["axes"]:
        unit = expected_unit(demo, ax)
        derived = {"m or rad": ("m/s or rad/s", "m/s² or rad/s²", "m/s³ or rad/s³")}.get(
            unit, (f"{unit}/s", f"{unit}/s²", f"{unit}/s³")
        )
        titles = {}
        for ch in CHANNELS:
            (trace,) = [d for d in data if d["name"] == f"{ax}.{ch}"]
            assert trace["legendgroup"] == ax  # legend groups per axis
            full = tr.data[:, tr.columns.index(f"{ax}.{ch}")]
            assert np.max(trace["y"]) == np.max(full) and np.min(trace["y"]) == np.min(full)
            titles[ch] = yaxis(layout, trace)["title"]["text"]
        assert titles["position"] == titles["actual_position"] == f"position [{unit}]"
        assert titles["velocity"] == titles["actual_velocity"] == f"velocity [{derived[0]}]"
        assert titles["acceleration"] == f"acceleration [{derived[1]}]"
        assert titles["jerk"] == f"jerk [{derived[2]}]"
        assert titles["following_error"] == f"following error [{unit}]"
        # commanded and actual in one lane, the actual one dashed
        (cmd,) = [d for d in data if d["name"] == f"{ax}.position"]
        (act,) = [d for d in data if d["name"] == f"{ax}.actual_position"]
        assert cmd["yaxis"] == act["yaxis"] and cmd["xaxis"] == act["xaxis"]
        assert act["line"]["dash"] == "dash" and cmd["line"]["dash"] == "solid"
    # every time axis is the first one or matches it; the path view's axes are not time axes
    time_axes = [v for k, v in layout.items() if k.startswith("xaxis") and "matches" in v]
    # the demo's group xy is never enabled (its sync move is single-axis blocks): no card
    assert len(time_axes) == 1 and layout["xaxis"]["title"]["text"] == "time [s]"
    assert "never enabled, not drawn: group xy (x, y)" in layout["title"]["text"]
    assert all(a["title"]["text"] == "time [s]" for a in time_axes)
    # FB rows per instance, states named (a bar trace per state, the name as its text)
    lanes = [v["ticktext"] for v in layout.values() if isinstance(v, dict) and "ticktext" in v]
    assert ["state", "pwr_x", "mx1", "mx2", "mx3", "xy.x"] in lanes
    states = {d["name"]: d for d in data if d.get("legendgroup") == "states"}
    assert {"STANDSTILL", "DISCRETE_MOTION"} <= set(states)
    assert set(states["DISCRETE_MOTION"]["text"]) == {"DISCRETE_MOTION"}
    assert layout["uniformtext"]["mode"] == "hide"  # a name that does not fit is not drawn
    assert "display decimated" in layout["title"]["text"]  # 9212 rows > 2 x 2000


def test_units_of_a_rotary_axis(tmp_path: Path) -> None:
    """With recorded units the labels say them: an axis in rad gets rad, rad/s, ..."""
    from motionplc.blocks import MC_MoveAbsolute, MC_Power
    from motionplc.runtime import Runtime
    from motionplc.scope import trace_from_runtime

    rt = Runtime(cycle=0.001)
    rt.add_axis("r", 3.0, 10.0, 100.0)
    rt.trace.set_units(axis_units("r", "rad"))
    pwr, mv = MC_Power(axis=rt.axes["r"], enable=True), MC_MoveAbsolute()

    def program(ctx: object) -> None:
        pwr()
        mv(axis=rt.axes["r"], execute=pwr.status, position=1.0, velocity=2.0)

    rt.add_task("main", program)
    assert rt.run_until(lambda: mv.done, max_seconds=5)
    write_plot(tmp_path / "r.html", trace_from_runtime(rt), "r")
    data, layout, _ = plotly_figure((tmp_path / "r.html").read_text(encoding="utf-8"))
    titles = {
        d["name"]: yaxis(layout, d)["title"]["text"]
        for d in data
        if d["name"] in {f"r.{c}" for c in CHANNELS}
    }
    assert titles["r.position"] == "position [rad]"
    assert titles["r.velocity"] == "velocity [rad/s]"
    assert titles["r.acceleration"] == "acceleration [rad/s²]"
    assert titles["r.jerk"] == "jerk [rad/s³]"
    assert titles["r.following_error"] == "following error [rad]"
    assert "all drawn" in layout["title"]["text"]  # short trace: nothing decimated


# ---------------------------------------------------------------------------- Chromium
def test_demo_scope_in_headless_chromium(demo: dict[str, Any]) -> None:
    if not CHROMIUM.exists():
        pytest.skip(f"{CHROMIUM} not installed (Debian package 'chromium')")
    tool = screenshot_tool()
    shot = demo["dir"] / "scope_screenshot.png"
    dom = tool.render(demo["html"], shot)
    keep = artefacts()
    shutil.copyfile(shot, keep / "scope_demo_chromium.png")
    shutil.copyfile(demo["png"], keep / "scope_demo.png")
    # plotly drew: the main SVG with a real size, one legend entry per channel
    assert 'id="motionplc-scope"' in dom and "js-plotly-plot" in dom
    sizes = re.findall(r'<svg class="main-svg"[^>]*width="(\d+)" height="(\d+)"', dom)
    assert sizes and int(sizes[0][0]) >= 1200 and int(sizes[0][1]) >= 750, sizes
    legend = set(re.findall(r'<text class="legendtext"[^>]*>([^<]+)</text>', dom))
    for ax in demo["axes"]:
        assert {f"{ax}.{ch}" for ch in CHANNELS} <= legend, legend
    assert {"STANDSTILL", "DISCRETE_MOTION", "busy", "active", "done"} <= legend
    ytitles = re.findall(r'<text class="y\d*title"[^>]*>([^<]+)</text>', dom)
    unit = expected_unit(demo, "x")
    assert ytitles.count(f"position [{unit}]") == 2, ytitles
    assert sum(t.startswith("following error [") for t in ytitles) == 2
    xticks = re.findall(r'<g class="x\d*tick"><text[^>]*>([^<]+)</text>', dom)
    assert {"0", "2", "4", "6", "8"} <= set(xticks), xticks  # a real time axis with ticks
    assert len(re.findall(r'class="scatterlayer', dom)) >= 3 and "DISCRETE_MOTION</text>" in dom
    # the screenshot is a picture, not a blank page
    import matplotlib.image as mpimg

    w, h = png_size(shot)
    assert (w, h) == tool.WINDOW
    img = mpimg.imread(shot)[..., :3].mean(axis=2)
    assert img.std() > 0.05 and 0.05 < float(np.mean(img < 0.95)) < 0.9


# ---------------------------------------------------------------------------- decimation
def test_a_million_rows_make_a_sane_page(tmp_path: Path) -> None:
    n = 1_000_000
    t = np.arange(n) * 0.001
    rng = np.random.default_rng(7)
    p = np.cumsum(rng.normal(size=n)) * 1e-4
    p[123_457] = 5.0  # a one-sample spike the display must keep
    cols = ["cycle", "t", "x.position", "x.velocity", "x.state"]
    data = np.column_stack([np.arange(n, dtype=float), t, p, np.gradient(p, 0.001), np.ones(n)])
    events = [(k, "x.mv", "busy", k % 2000 == 0) for k in range(0, n, 1000)]
    write_plot(tmp_path / "big.html", ScopeTrace(cols, data, events), "big")
    size = (tmp_path / "big.html").stat().st_size
    assert size < 30e6, size
    traces, layout, _ = plotly_figure((tmp_path / "big.html").read_text(encoding="utf-8"))
    (pos,) = [d for d in traces if d["name"] == "x.position"]
    assert len(pos["y"]) <= 3 * 2000 + 1 and np.max(pos["y"]) == 5.0
    assert np.min(pos["y"]) == np.min(p) and pos["x"][np.argmax(pos["y"])] == t[123_457]
    assert "display decimated" in layout["title"]["text"]
    assert "1000000 samples per channel" in layout["title"]["text"]


@settings(max_examples=60, deadline=None)
@given(
    values=st.lists(st.floats(-1e6, 1e6), min_size=1, max_size=600),
    buckets=st.integers(1, 100),
)
def test_minmax_keeps_every_bucket_extreme(values: list[float], buckets: int) -> None:
    y = np.array(values)
    idx = minmax_indices(y, buckets)
    n = len(y)
    assert idx[0] == 0 and idx[-1] == n - 1 and np.all(np.diff(idx) > 0)
    if n <= 2 * buckets:
        assert np.array_equal(idx, np.arange(n))
        return
    assert len(idx) <= 3 * buckets + 1
    size = -(-n // buckets)
    for start in range(0, n, size):
        chunk = y[start : start + size]
        kept = y[idx[(idx >= start) & (idx < start + size)]]
        assert kept.max() == chunk.max() and kept.min() == chunk.min()


# ---------------------------------------------------------------------------- series plots
def test_series_plot_html_and_png(tmp_path: Path) -> None:
    t = np.linspace(0.0, 2.0, 201)
    series = {"p": (t**2, "m"), "v": (2 * t, "m/s"), "count": (np.round(t), "")}
    write_series_plot(tmp_path / "s.html", t, series, "profile")
    data, layout, _ = plotly_figure((tmp_path / "s.html").read_text(encoding="utf-8"))
    assert [d["name"] for d in data] == ["p", "v", "count"]
    assert [yaxis(layout, d)["title"]["text"] for d in data] == ["p [m]", "v [m/s]", "count"]
    assert {d["xaxis"] for d in data} == {"x"} and layout["xaxis"]["title"]["text"] == "time [s]"
    assert np.array_equal(data[1]["y"], 2 * t) and layout["hovermode"] == "x unified"
    write_series_plot(tmp_path / "s.png", t, series, "profile")
    w, h = png_size(tmp_path / "s.png")
    assert w == 900 and h == round((1.2 + 2.0 * 3) * 100)
    with pytest.raises(ValueError, match=r"series\['v'\]: 200 values for 201 times"):
        write_series_plot(tmp_path / "x.html", t, {"v": (t[1:], "m/s")}, "bad")
    with pytest.raises(ValueError, match=r"series\['v'\]: expected \(values, unit\)"):
        write_series_plot(tmp_path / "x.html", t, {"v": t}, "bad")  # type: ignore[dict-item]
    with pytest.raises(ValueError, match="at least one series"):
        write_series_plot(tmp_path / "x.html", t, {}, "bad")
    assert not (tmp_path / "x.html").exists()


# ---------------------------------------------------------------------------- dependencies
@pytest.mark.parametrize(
    ("modules", "suffix", "message"),
    [
        (("plotly", "plotly.graph_objects", "plotly.io"), ".html", "needs plotly"),
        (("matplotlib", "matplotlib.pyplot"), ".png", "needs matplotlib"),
    ],
)
def test_a_missing_plot_package_is_one_line_naming_the_extra(
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    modules: tuple[str, ...],
    suffix: str,
    message: str,
) -> None:
    t = np.arange(3.0)
    tr = ScopeTrace(["cycle", "t", "x.position", "x.state"], np.column_stack([t, t, t, t * 0]), [])
    for mod in modules:
        monkeypatch.setitem(sys.modules, mod, None)  # the import raises ImportError
    for call in (
        lambda: write_plot(tmp_path / f"a{suffix}", tr, "a"),
        lambda: write_series_plot(tmp_path / f"b{suffix}", t, {"p": (t, "m")}, "b"),
    ):
        with pytest.raises(PlotDependencyError) as info:
            call()
        text = str(info.value)
        assert message in text and "pip install 'motionplc[plot]'" in text and "\n" not in text
    assert not list(tmp_path.iterdir())
