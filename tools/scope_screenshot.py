"""The HTML scope of the demo, rendered in headless Chromium: a screenshot and the rendered DOM.

Runs the demo (``configs/demo.yaml`` + ``configs/demo_sequence.yaml``) through
``motionplc.cli.main`` with ``--trace``, writes the interactive HTML scope and the PNG scope of
the trace, opens the HTML page in headless Chromium (no network, fresh profile) and writes

* ``OUT/scope.html`` (the page), ``OUT/scope.png`` (the matplotlib scope),
* ``OUT/scope_screenshot.png`` (Chromium's rendering at 1600 x 1200),
* ``OUT/scope_dom.html`` (the DOM after plotly drew, from ``--dump-dom``).

Usage: ``.venv/bin/python tools/scope_screenshot.py [--out DIR] [--trace TRACE]`` (default
``out/scope``; ``--trace`` plots an existing trace instead of running the demo). Exit code 2
when Chromium is missing. :func:`render` is the Chromium step, also used by
``tests/cli/test_scope_html.py``.
"""

from __future__ import annotations

import argparse
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
CHROMIUM = "/usr/bin/chromium"
WINDOW = (1600, 1200)


def chromium_command(
    page: Path, user_data: Path, action: list[str], window: tuple[int, int] = WINDOW
) -> list[str]:
    """The headless Chromium command line for ``page`` (no network, GPU, sync or updates)."""
    return [
        CHROMIUM,
        "--headless",
        "--no-sandbox",
        "--disable-gpu",
        "--disable-quic",
        "--no-first-run",
        "--disable-background-networking",
        "--disable-component-update",
        "--disable-sync",
        "--disable-extensions",
        "--hide-scrollbars",
        f"--user-data-dir={user_data}",
        f"--window-size={window[0]},{window[1]}",
        "--virtual-time-budget=10000",
        *action,
        page.resolve().as_uri(),
    ]


def render(
    page: Path, screenshot: Path, window: tuple[int, int] = WINDOW, timeout: float = 120.0
) -> str:
    """Open ``page`` in headless Chromium: write its screenshot to ``screenshot`` and return
    the rendered DOM (``--dump-dom``). Each run uses a fresh, deleted profile directory.

    Raises ``FileNotFoundError`` when Chromium is missing and ``RuntimeError`` (with
    Chromium's last error lines) when it fails or writes no screenshot.
    """
    if not Path(CHROMIUM).exists():
        raise FileNotFoundError(f"{CHROMIUM} not found (Debian package 'chromium')")
    screenshot.parent.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(prefix="motionplc-chromium-") as tmp:
        action = [f"--screenshot={screenshot.resolve()}", "--dump-dom"]
        run = subprocess.run(
            chromium_command(page, Path(tmp) / "profile", action, window),
            capture_output=True,
            text=True,
            timeout=timeout,
            check=False,
        )
    if run.returncode != 0 or not screenshot.is_file() or "<html" not in run.stdout:
        tail = "\n".join(run.stderr.strip().splitlines()[-5:])
        raise RuntimeError(f"chromium failed (exit code {run.returncode}): {tail}")
    return run.stdout


def run_demo(out: Path) -> Path:
    """Run the demo through the CLI with ``--trace OUT/demo.csv``; returns the trace path."""
    from motionplc.cli import main

    trace = out / "demo.csv"
    code = main(
        [
            "run",
            str(ROOT / "configs" / "demo.yaml"),
            str(ROOT / "configs" / "demo_sequence.yaml"),
            "--trace",
            str(trace),
            "-q",
        ]
    )
    if code != 0:
        raise SystemExit(f"the demo failed (exit code {code})")
    return trace


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", default=str(ROOT / "out" / "scope"), help="output directory")
    ap.add_argument("--trace", help="plot this trace (.csv or .parquet) instead of the demo's")
    args = ap.parse_args(argv)
    from motionplc.scope import read_trace, write_plot

    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    trace = Path(args.trace) if args.trace else run_demo(out)
    data = read_trace(trace)
    title = str(trace.name)
    write_plot(out / "scope.html", data, title)
    write_plot(out / "scope.png", data, title)
    if not shutil.which(CHROMIUM):
        print(f"{CHROMIUM} not found: wrote {out / 'scope.html'} only", file=sys.stderr)
        return 2
    dom = render(out / "scope.html", out / "scope_screenshot.png")
    (out / "scope_dom.html").write_text(dom, encoding="utf-8")
    for name in ("scope.html", "scope.png", "scope_screenshot.png", "scope_dom.html"):
        print(f"wrote {out / name}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
