"""Plausibility warnings (issue 30): values accepted but beyond any machine for the axis'
units warn -- never refuse -- with the usual unit mistake named, located ``FILE:LINE:``, in
``motionplc validate`` and ``motionplc run``: axis limits (mm typed as m, degrees as rad), jog
and homing velocities, software limits, a sequence's velocity inputs, a G-code feed."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from motionplc.cli import main
from motionplc.config import load_config
from motionplc.plausibility import feed_warning, warning

ROOT = Path(__file__).resolve().parents[2]
DEMO = ROOT / "configs" / "demo.yaml"
DEMO_SEQ = ROOT / "configs" / "demo_sequence.yaml"


def test_bounds_and_the_mistake_named() -> None:
    assert warning(10.0, "m", "velocity") is None and warning(float("inf"), "m", "jerk") is None
    text = warning(800.0, "m", "velocity", "v_max")
    assert text == (
        "v_max 800 m/s is implausible for an axis in m (beyond ±20 m/s): mm typed as m? "
        "(800 mm/s is 0.8 m/s)"
    )
    assert "mm/s² is 2 m/s²" in (warning(2000.0, "m", "acceleration") or "")
    assert warning(-800.0, "m", "velocity", "v_min") is not None  # by magnitude
    rad = warning(3600.0, "rad", "velocity", "v_max") or ""
    assert "degrees typed as rad? (3600 °/s is 62.83 rad/s)" in rad
    assert warning(300.0, "rad", "velocity") is None  # a spindle at ~2900 rpm
    assert feed_warning(0.5) is None
    assert "F is in program units per minute" in (feed_warning(1.7e7) or "")


def test_a_spindle_is_judged_as_a_spindle(tmp_path: Path) -> None:
    """A rotary axis the machine names its spindle (``gcode: spindle:``) may turn at 2000 rad/s
    (~19,000 rpm) without a warning; the same axis not named spindle warns (degrees?), and a
    spindle beyond 1e4 rad/s warns with the rpm mistake named."""
    assert warning(2000.0, "spindle", "velocity") is None
    text = warning(20000.0, "spindle", "velocity", "v_max") or ""
    assert "implausible for a spindle" in text and "(2e+04 rpm is 2094 rad/s)" in text
    body = (ROOT / "configs" / "gcode" / "mill3.yaml").read_text(encoding="utf-8")
    assert "spindle: s" in body
    (tmp_path / "tools.tbl").write_text((ROOT / "configs" / "gcode" / "tools.tbl").read_text())
    named = tmp_path / "named.yaml"
    named.write_text(body)
    assert load_config(named).warnings == ()
    unnamed = tmp_path / "unnamed.yaml"
    unnamed.write_text(body.replace("  spindle: s\n", ""))
    (warned,) = load_config(unnamed).warnings
    assert "axes.s.limits.v_max: warning: v_max 2000 rad/s" in warned and "degrees" in warned


def test_shipped_configurations_warn_about_nothing() -> None:
    for cfg in sorted((ROOT / "configs").rglob("*.yaml")):
        text = cfg.read_text(encoding="utf-8")
        if "axes:" in text and "runtime:" in text:
            assert load_config(cfg).warnings == (), cfg


def mm_typed_as_m(tmp_path: Path) -> Path:
    text = DEMO.read_text(encoding="utf-8")
    old = "limits: {v_max: 0.5, a_max: 2.0, j_max: 20.0}"
    assert old in text
    cfg = tmp_path / "demo_mm.yaml"
    cfg.write_text(text.replace(old, "limits: {v_max: 800, a_max: 2.0, j_max: 20.0}", 1))
    return cfg


def test_validate_and_run_warn_with_file_and_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    cfg = mm_typed_as_m(tmp_path)
    line = next(i for i, t in enumerate(cfg.read_text().splitlines(), 1) if "v_max: 800" in t)
    expected = (
        f"{cfg}:{line}: axes.x.limits.v_max: warning: v_max 800 m/s is implausible for an axis "
        "in m (beyond ±20 m/s): mm typed as m? (800 mm/s is 0.8 m/s)"
    )
    assert main(["validate", str(cfg), str(DEMO_SEQ)]) == 0  # a warning, not an error
    out = capsys.readouterr()
    assert out.err.splitlines() == [expected] and "ok" in out.out
    assert main(["run", str(cfg), str(DEMO_SEQ), "-q"]) == 0
    assert capsys.readouterr().err.splitlines() == [expected]


def test_rotary_axis_jog_and_software_limits(tmp_path: Path) -> None:
    cfg = tmp_path / "r.yaml"
    cfg.write_text(
        "runtime: {tick: 0.001, tasks: {motion: {period: 0.001}}}\n"
        "axes:\n"
        "  r:\n"
        "    units: rad\n"
        "    limits: {v_max: 3600, a_max: 20.0, j_max: 200.0}\n"
        "    jog_velocity_slow: 1.0\n"
        "  x:\n"
        "    limits: {v_max: 1.0, a_max: 2.0}\n"
        "    jog_velocity_fast: 0.5\n"
        "    software_limits: {min: 0.0, max: 1500}\n"
    )
    w = load_config(cfg).warnings
    assert len(w) == 2
    assert re.match(rf"{re.escape(str(cfg))}:5: axes\.r\.limits\.v_max: warning: .*degrees", w[0])
    assert re.match(
        rf"{re.escape(str(cfg))}:10: axes\.x\.software_limits\.max: warning: max 1500 m .*"
        r"mm typed as m\? \(1500 mm is 1\.5 m\)",
        w[1],
    )


def test_a_gcode_feed_beyond_any_machine(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    prog = tmp_path / "big.ngc"
    prog.write_text("G21 G90 G61\nG1 X10 Y10 F1000000000000\nG1 X20\nG1 X30 F600\n")
    assert main(["validate", str(ROOT / "configs" / "gantry.yaml"), str(prog)]) == 0
    err = capsys.readouterr().err.splitlines()
    assert err == [
        f"{prog}:2: F: warning: feed 1.667e+07 m/s is implausible (beyond 20 m/s): F is in "
        "program units per minute (this is F1e+12 in mm; F6000 in mm is 0.1 m/s)"
    ]
