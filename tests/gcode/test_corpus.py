"""The corpus of our own programs (tests/gcode/corpus, LICENSE.md there): every program runs
as written on the 3-axis and 4-axis mills of configs/gcode (the rotary ones on the 4-axis one
only), positions of every move agree with pygcode (an independent interpreter) where it
covers the program, and the word table is exactly what the interpreter accepts."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from motionplc.config import load_config
from motionplc.gcode import (
    _G_GROUP,
    _M_GROUP,
    AXES,
    WORDS,
    GcodeMove,
    Interpreter,
    MachineSetup,
    Tool,
    _g_label,
    reference_markdown,
    validate,
)
from motionplc.gcode_runner import load_gcode_job, setup_from_config

ROOT = Path(__file__).resolve().parents[2]
CORPUS = sorted((ROOT / "tests" / "gcode" / "corpus").glob("*.ngc"))
MILL3 = ROOT / "configs" / "gcode" / "mill3.yaml"
MILL4 = ROOT / "configs" / "gcode" / "mill4.yaml"


def test_the_corpus_is_ours_and_large_enough() -> None:
    assert len(CORPUS) >= 50
    assert "written for motionplc" in (CORPUS[0].parent / "LICENSE.md").read_text()


@pytest.mark.parametrize("config", [MILL3, MILL4], ids=["mill3", "mill4"])
def test_every_program_validates_on_the_mills(config: Path) -> None:
    cfg = load_config(config)
    ran = refused = 0
    for path in CORPUS:
        if "rotary" in path.name and config == MILL3:
            with pytest.raises(Exception, match="the machine has no A axis"):
                load_gcode_job(path, cfg)
            refused += 1
            continue
        job = load_gcode_job(path, cfg)
        assert len(job.program) > 0, path.name
        ran += 1
    assert ran >= 48


# -- the peer: pygcode 0.2.1 (program coordinates of the end of every motion line) ----------
# lines pygcode does not interpret like LinuxCNC (or at all): the comparison stops there
_STOP = re.compile(r"[#\[\]<>]|^\s*o|G8[1-9]|G7[0-9]|G28|G30|G53|G92|G10", re.I)


def _pygcode_ends(text: str) -> dict[int, tuple[float, float, float]]:
    pygcode = pytest.importorskip("pygcode")
    m = pygcode.Machine()
    out = {}
    for no, raw in enumerate(text.splitlines(), start=1):
        line = raw.strip()
        if not line or line.startswith("%") or line.lstrip("/").strip().upper().startswith("M"):
            continue
        block = pygcode.Line(line).block
        if not block.gcodes and not block.words:
            continue
        m.process_block(block)
        if any(
            type(g).__name__.startswith("GCodeRapidMove")
            or type(g).__name__ in ("GCodeLinearMove", "GCodeArcMoveCW", "GCodeArcMoveCCW")
            for g in m.mode.gcodes
        ) and any(w.letter in "XYZ" for w in block.words):
            pos = m.pos.values
            out[no] = (pos["X"], pos["Y"], pos["Z"])
    return out


def test_move_positions_agree_with_pygcode() -> None:
    tools = {n: Tool(n) for n in range(1, 10)}
    compared = programs = 0
    for path in CORPUS:
        text = path.read_text()
        if "rotary" in path.name:
            continue
        lines = text.splitlines()
        stop = next((i for i, ln in enumerate(lines) if _STOP.search(ln.split("(")[0])), len(lines))
        text = "\n".join(ln for ln in lines[:stop] if not ln.startswith("%")) + "\n"
        if stop < 5:
            continue
        setup = MachineSetup.for_axes(("x", "y", "z"), tools=tools)
        unit = 25.4 if re.search(r"\bG20\b", text) else 1.0
        ours: dict[int, tuple[float, ...]] = {}
        for mv in Interpreter(path.name, setup, text=text).run():
            if isinstance(mv, GcodeMove):
                ours[mv.line] = tuple(v * 1000.0 / unit for v in mv.end)
        peer = _pygcode_ends(text)
        for line, p in peer.items():
            if line in ours:
                assert ours[line] == pytest.approx(p, abs=1e-9), f"{path.name}:{line}"
                compared += 1
        programs += 1
    assert programs >= 15 and compared >= 300


def test_the_reference_page_lists_exactly_the_accepted_codes() -> None:
    g_table = {w.code for w in WORDS if w.code.startswith("G")}
    m_table = {w.code for w in WORDS if w.code.startswith("M")}
    assert g_table == {_g_label(t) for t in _G_GROUP}
    assert m_table == {f"M{m}" for m in _M_GROUP}
    page = (ROOT / "docs" / "reference" / "gcode.md").read_text()
    assert page == reference_markdown()
    listed = set(re.findall(r"^\| `([^`]+)` \| [^|]*\| [^|]*\|$", page, re.M))
    assert {c for c in listed if c[0] in "GM"} == g_table | m_table
    # every listed G/M code is accepted by the interpreter on a line of its own
    setup = MachineSetup.for_axes(("x", "y", "z"), tools={1: Tool(1)}, spindle=True)
    needs = {
        "G4": " P0",
        "G10": " L2 P1",
        "G43.2": " H1",
        "G92": " X0",
        "G53": " G0 X0",
        "M62": " P0",
        "M63": " P0",
        "M64": " P0",
        "M65": " P0",
    }
    for code in sorted(g_table | m_table):
        text = f"G21 F100 S100 M3\n{code}{needs.get(code, '')}\nM2\n"
        n_moves, _, interp = validate(_program(text, setup))
        assert not interp.errors, code
    axis_words = {c for w in WORDS if w.code in ("X Y Z", "A B C", "U V W") for c in w.code.split()}
    assert axis_words == set(AXES)


def _program(text: str, setup: MachineSetup):  # noqa: ANN202
    from motionplc.gcode import GcodeProgram

    return GcodeProgram("t.ngc", setup, text)


def test_setup_from_the_config_block() -> None:
    s = setup_from_config(load_config(MILL4), "xyza")
    assert s.axes == {"X": 0, "Y": 1, "Z": 2, "A": 3} and s.rotary == frozenset("A")
    assert s.work_offsets[1] == {"X": 0.3, "Y": 0.2, "Z": -0.05}
    assert s.tools[2].offsets == {"Z": pytest.approx(0.0625)} and s.spindle
