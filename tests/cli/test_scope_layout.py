"""The scope's layout from 1 to 16 axes (issue 30): a grid of cards, at most four grid columns
wide (an axis card one column, a group card two), further axes in further rows of the same
size. Checked on the figure itself -- no two plots overlap, the colour bar has its own room,
the card titles sit above their card, the path views are large, the first row's state and FB
lanes lie above the fold of a 1600 x 1000 window, a group that was never enabled gets no card --
and in headless Chromium for 2, 6 and 12 axes (screenshots kept in ``out/test-artefacts/``).

The machines are real runs (``tests/cli/scope_rig.py``: ``motionplc run --trace``).
"""

from __future__ import annotations

import re
import shutil
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from motionplc.cli import main
from motionplc.scope import (
    MAX_GRID_COLUMNS,
    PNG_COLUMN_WIDTH,
    PNG_DPI,
    PNG_ROW_HEIGHT,
    read_trace,
    write_plot,
)
from tests.cli.scope_rig import axis_names, groups_of, write_machine
from tests.cli.test_scope import plotly_figure, png_size
from tests.cli.test_scope_html import CHROMIUM, artefacts, screenshot_tool

NOMINAL_WIDTH = 1330.0  # the plot width of a 1600 px window (less margins and legend)
FOLD = 1000.0


@pytest.fixture(scope="module")
def runs(tmp_path_factory: pytest.TempPathFactory) -> dict[int, Path]:
    out = {}
    for n in (1, 2, 6, 12, 16):
        d = tmp_path_factory.mktemp(f"axes{n}")
        cfg, seq = write_machine(d, n)
        assert main(["run", str(cfg), str(seq), "--trace", str(d / "t.csv"), "-q"]) == 0
        write_plot(d / "scope.html", read_trace(d / "t.csv"), f"{n} axes")
        out[n] = d
    return out


def figure(runs: dict[int, Path], n: int) -> tuple[list[dict[str, Any]], dict[str, Any]]:
    data, layout, _ = plotly_figure((runs[n] / "scope.html").read_text(encoding="utf-8"))
    return data, layout


Rect = tuple[float, float, float, float]  # x0, x1, y0, y1 in px (y from the plot area's top)


def plots(layout: dict[str, Any]) -> dict[str, Rect]:
    """Every subplot's rectangle: a y axis and the x axis it is anchored to."""
    plot_px = layout["height"] - layout["margin"]["t"] - layout["margin"]["b"]
    out = {}
    for key, ax in layout.items():
        if not (key.startswith("yaxis") and isinstance(ax, dict) and "domain" in ax):
            continue
        xa = layout[ax["anchor"].replace("x", "xaxis")]
        (x0, x1), (y0, y1) = xa["domain"], ax["domain"]
        out[key] = (x0 * NOMINAL_WIDTH, x1 * NOMINAL_WIDTH, (1 - y1) * plot_px, (1 - y0) * plot_px)
    return out


def overlap(a: Rect, b: Rect, tol: float = 0.5) -> bool:
    return a[0] < b[1] - tol and b[0] < a[1] - tol and a[2] < b[3] - tol and b[2] < a[3] - tol


@pytest.mark.parametrize("n", [1, 2, 6, 12, 16])
def test_no_two_plots_overlap_and_the_colour_bar_has_its_room(
    runs: dict[int, Path], n: int
) -> None:
    data, layout = figure(runs, n)
    rects = plots(layout)
    keys = sorted(rects)
    for i, a in enumerate(keys):
        for b in keys[i + 1 :]:
            assert not overlap(rects[a], rects[b]), (a, rects[a], b, rects[b])
    plot_px = layout["height"] - layout["margin"]["t"] - layout["margin"]["b"]
    bars = [d["marker"]["colorbar"] for d in data if d.get("marker", {}).get("showscale")]
    assert len(bars) == (1 if n >= 2 else 0)  # one speed scale per drawn group
    for cb in bars:
        x0 = cb["x"] * NOMINAL_WIDTH
        ym = (1 - cb["y"]) * plot_px
        bar = (x0, x0 + 60.0, ym - cb["len"] * plot_px / 2, ym + cb["len"] * plot_px / 2)
        for key, r in rects.items():
            assert not overlap(bar, r), (key, r, bar)


@pytest.mark.parametrize("n", [1, 2, 6, 12, 16])
def test_titles_above_their_card_and_lanes_above_the_fold(runs: dict[int, Path], n: int) -> None:
    data, layout = figure(runs, n)
    rects = plots(layout)
    plot_px = layout["height"] - layout["margin"]["t"] - layout["margin"]["b"]
    drawn = [g for g in groups_of(n) if g != "g2"] + axis_names(n)  # g2 is never enabled
    titles = [a for a in layout["annotations"] if a["text"].startswith("<b>")]
    assert len(titles) == len(drawn)
    for a, name in zip(titles, drawn, strict=True):
        assert re.match(rf"<b>(group|axis) {name}\b", a["text"]), (a["text"], name)
        # a title (13 px bold, ~7.5 px per character) fits its card and covers no plot
        text = re.sub(r"<[^>]+>", "", a["text"])
        half = 7.5 * len(text) / 2
        cx, y = a["x"] * NOMINAL_WIDTH, (1 - a["y"]) * plot_px
        box = (cx - half, cx + half, y - 18.0, y)
        for key, r in rects.items():
            assert not overlap(box, r), (a["text"], key, r, box)
    # the first row of cards, lanes and time axis included, fits a 1000 px window
    lanes = [
        r
        for key, r in rects.items()
        if "ticktext" in layout[key] and r[2] < 750.0  # the state/FB lanes of row one
    ]
    assert lanes
    assert layout["margin"]["t"] + max(r[3] for r in lanes) + 40.0 <= FOLD
    # a grid at most four columns wide: a card keeps its width whatever the number of axes
    time_axes = [
        v for k, v in layout.items() if k.startswith("xaxis") and v["title"]["text"] == "time [s]"
    ]
    x1s = {round(v["domain"][1], 6) for v in time_axes}
    assert len(x1s) <= MAX_GRID_COLUMNS + 1


def test_path_views_are_large_and_a_never_enabled_group_gets_no_card(
    runs: dict[int, Path],
) -> None:
    for n in (2, 6, 12):
        data, layout = figure(runs, n)
        plot_px = layout["height"] - layout["margin"]["t"] - layout["margin"]["b"]
        views = [d for d in data if " path (" in d.get("name", "")]
        assert [v["name"].split()[0] for v in views] == ["g1"] * (1 if n == 2 else 2)
        for v in views:
            ya = layout[v["yaxis"].replace("y", "yaxis")]
            xa = layout[v["xaxis"].replace("x", "xaxis")]
            assert (ya["domain"][1] - ya["domain"][0]) * plot_px >= 300.0
            assert (xa["domain"][1] - xa["domain"][0]) * NOMINAL_WIDTH >= 230.0
        note = layout["title"]["text"]
        if n >= 6:
            assert "never enabled, not drawn: group g2 (a, b, c)" in note
            assert not [d for d in data if d.get("name", "").startswith("g2")]
        else:
            assert "never enabled" not in note


def test_png_of_six_axes_on_the_grid(runs: dict[int, Path]) -> None:
    d = runs[6]
    write_plot(d / "scope.png", read_trace(d / "t.csv"), "6 axes")
    shutil.copyfile(d / "scope.png", artefacts() / "scope_6_axes.png")
    w, h = png_size(d / "scope.png")
    # g1 (two columns), x, y | z, a, b, c: four columns, two rows (was 4680 x 1170, 8 columns)
    assert w == round(4 * PNG_COLUMN_WIDTH * PNG_DPI)
    assert 2 * PNG_ROW_HEIGHT * PNG_DPI < h < (2 * PNG_ROW_HEIGHT + 2) * PNG_DPI


@pytest.mark.parametrize("n", [2, 6, 12])
def test_scope_of_many_axes_in_headless_chromium(runs: dict[int, Path], n: int) -> None:
    if not CHROMIUM.exists():
        pytest.skip(f"{CHROMIUM} not installed (Debian package 'chromium')")
    tool = screenshot_tool()
    shot = runs[n] / "shot.png"
    dom = tool.render(runs[n] / "scope.html", shot, (1600, 1000), timeout=900.0)
    shutil.copyfile(shot, artefacts() / f"scope_{n}_axes_chromium.png")
    assert png_size(shot) == (1600, 1000)
    # every card's title and every axis' position lane were drawn
    texts = set(re.findall(r'<text[^>]*class="annotation-text"[^>]*>(.*?)</text>', dom))
    for name in axis_names(n):
        assert any(re.match(rf"axis {name}\b", re.sub(r"<[^>]+>", "", t)) for t in texts), name
    ytitles = re.findall(r'<text class="y\d*title"[^>]*>([^<]+)</text>', dom)
    assert ytitles.count("position [m]") == n
    import matplotlib.image as mpimg

    img = mpimg.imread(shot)[..., :3].mean(axis=2)
    assert img.std() > 0.05 and 0.03 < float(np.mean(img < 0.95)) < 0.9
