"""Real third-party G-code programs (tests/gcode/thirdparty, PROVENANCE.md there): LinuxCNC's
example programs and test suites (its trajectory planner's test programs include CAM output:
3D_Chips, LHchips4, wheels, trochoidal, ...), cncjs' examples (CAM output for a router) and bCNC's
sample, copied unchanged with their licences.

* every program validates on the mills of configs/gcode, or is refused with the located message
  recorded in ``expected.tsv`` (features outside the interpreter: cutter compensation, G33,
  probing, lathe cycles, polar words, coordinate rotation; programs bad by LinuxCNC's own test
  suite; moves beyond the mill's travel);
* the end of every motion line agrees with pygcode (an independent interpreter) up to the
  first line pygcode does not interpret like LinuxCNC;
* the moves agree with LinuxCNC's own interpreter where its test suite has the reference's
  canonical output (``expected`` beside the program): canned cycles in three planes, O-word
  recursion, EXISTS;
* a few of them run in the runtime on the mills, checked on the trace (limits by differencing,
  the path within the blend tolerance, exact corners, the end point: tests/gcode/corpus_check.py).
"""

from __future__ import annotations

import hashlib
import math
import re
from pathlib import Path

import pytest

from motionplc.config import load_config
from motionplc.gcode import GcodeMove, Interpreter, MachineSetup, Tool
from motionplc.gcode_runner import GCODE_SUFFIXES, load_gcode_job
from tests.gcode.corpus_check import MILL3, MILL4, PATH_ATOL, run_checked

HERE = Path(__file__).resolve().parent / "thirdparty"
PROGRAMS = sorted(p for p in HERE.rglob("*") if p.suffix.lower() in GCODE_SUFFIXES)
EXPECTED = {
    row[0]: row[1:]
    for row in (ln.split("\t") for ln in (HERE / "expected.tsv").read_text().splitlines())
}
LICENCES = {"linuxcnc": "COPYING", "cncjs": "LICENSE", "bcnc": "LICENSE.md"}


def _rel(p: Path) -> str:
    return p.relative_to(HERE).as_posix()


def _outcome(path: Path, cfg) -> str:  # noqa: ANN001
    try:
        job = load_gcode_job(path, cfg)
    except Exception as exc:  # noqa: BLE001 - the message is the outcome
        first = str(exc).splitlines()[0]
        assert first.startswith(f"{path}:"), first  # located: FILE:LINE: WORD: message
        return "refused " + first[len(str(path)) + 1 :]
    return f"ok {len(job.program)}"


def test_the_corpus_is_third_party_unchanged_with_licences() -> None:
    prov = (HERE / "PROVENANCE.md").read_text()
    for src, lic in LICENCES.items():
        assert (HERE / src / lic).stat().st_size > 1000, src
    for p in PROGRAMS + sorted(HERE.rglob("expected")):
        data = p.read_bytes()
        blob = hashlib.sha1(b"blob %d\0" % len(data) + data).hexdigest()  # noqa: S324 - git's id
        row = re.search(rf"^\| `{re.escape(_rel(p))}` \| `([^`]+)` \| `([0-9a-f]+)` \|", prov, re.M)
        assert row is not None, f"{_rel(p)} is not in PROVENANCE.md"
        assert blob.startswith(row.group(2)), f"{_rel(p)} differs from its source"
    assert set(EXPECTED) == {_rel(p) for p in PROGRAMS}
    run = [k for k, (m3, m4) in EXPECTED.items() if m3.startswith("ok") or m4.startswith("ok")]
    real_cam = [k for k in run if re.search(r"performance/|cncjs/|bcnc/|3dtest|tort|arcspiral", k)]
    assert len(run) >= 150 and len(EXPECTED) - len(run) >= 45 and len(real_cam) >= 30


_MILL4_ALL = 40_000  # [bytes] on mill4 every program up to this size, and those with A words


@pytest.mark.parametrize("config", [MILL3, MILL4], ids=["mill3", "mill4"])
def test_every_program_validates_or_is_refused_with_the_expected_message(config: Path) -> None:
    cfg = load_config(config)
    col = 0 if config == MILL3 else 1
    checked = 0
    for p in PROGRAMS:
        want = EXPECTED[_rel(p)]
        if col == 1 and p.stat().st_size > _MILL4_ALL and "no A axis" not in want[0]:
            continue  # the same XYZ program as on mill3 (validated there)
        assert _outcome(p, cfg) == want[col], _rel(p)
        checked += 1
    assert checked >= (197 if col == 0 else 150)


# -- the peer: pygcode 0.2.1 (program coordinates of the end of every motion line) ----------
# lines pygcode does not interpret like LinuxCNC (or at all): the comparison stops there
_STOP = re.compile(r"[#\[\]<>@^/]|^\s*o|G8[1-9]|G7[0-9]|G28|G30|G53|G92|G10|G4[1-3]|G5\b", re.I)
_NOT_MOTION = re.compile(r"[MSTNHD]\s*[-+]?[0-9.]+", re.I)  # words pygcode need not see
_MAX_LINES = 2000  # per program (pygcode is slow: the large CAM files are compared this far)


def _pygcode_ends(lines: list[str]) -> tuple[dict[int, tuple[float, float, float]], int]:
    """(the end of every motion line of ``lines`` by pygcode, the line it stopped at)."""
    pygcode = pytest.importorskip("pygcode")
    m = pygcode.Machine()
    out = {}
    motion = ("GCodeRapidMove", "GCodeLinearMove", "GCodeArcMoveCW", "GCodeArcMoveCCW")
    for no, raw in enumerate(lines, start=1):
        line = _NOT_MOTION.sub(" ", re.sub(r"\([^)]*\)", " ", raw.split(";")[0])).strip()
        if not line or line.startswith("%"):
            continue
        try:
            block = pygcode.Line(line).block
            if not block.gcodes and not block.words:
                continue
            m.process_block(block)
        except pygcode.exceptions.GCodeException:
            return out, no  # the peer stops here (a word or code it does not know)
        if any(type(g).__name__ in motion for g in m.mode.gcodes) and any(
            w.letter in "XYZ" for w in block.words
        ):
            pos = m.pos.values
            out[no] = (pos["X"], pos["Y"], pos["Z"])
    return out, len(lines) + 1


def test_move_positions_agree_with_pygcode() -> None:
    tools = {n: Tool(n) for n in range(1, 100)}
    compared = programs = 0
    for p in PROGRAMS:
        if not EXPECTED[_rel(p)][0].startswith("ok"):
            continue
        lines = p.read_text(errors="replace").splitlines()[:_MAX_LINES]
        stop = next((i for i, ln in enumerate(lines) if _STOP.search(ln.split("(")[0])), len(lines))
        lines = lines[:stop]
        text = "\n".join("" if ln.startswith("%") else ln for ln in lines) + "\n"  # same lines
        units = {m.upper() for m in re.findall(r"\bG2[01]\b", text, re.I)}
        if stop < 3 or len(units) > 1:
            continue
        setup = MachineSetup.for_axes(("x", "y", "z"), tools=tools, spindle=True)
        unit = 25.4 if units == {"G20"} else 1.0
        ours: dict[int, tuple[float, ...]] = {}
        for mv in Interpreter(p.name, setup, text=text).run():
            if isinstance(mv, GcodeMove):
                ours[mv.line] = tuple(v * 1000.0 / unit for v in mv.end)
        peer, upto = _pygcode_ends(lines)
        ours = {k: v for k, v in ours.items() if k < upto}
        n = 0
        for line, pos in peer.items():
            if line in ours:
                assert ours[line] == pytest.approx(pos, abs=1e-9), f"{_rel(p)}:{line}"
                n += 1
        assert n >= 0.9 * len(ours) - 1, (_rel(p), n, len(ours))  # zero-length ones skipped
        compared += n
        programs += 1
    print(f"pygcode: {compared} move ends of {programs} programs agree")  # noqa: T201
    assert programs >= 120 and compared >= 25_000, (programs, compared)


# -- the reference: LinuxCNC's interpreter (rs274), its test suite's canonical output --------
_CANON = re.compile(r"(STRAIGHT_TRAVERSE|STRAIGHT_FEED)\(([^)]*)\)|USE_LENGTH_UNITS\((\w+)\)")
_REFERENCE = [
    "linuxcnc/tests/interp/flowsnake",  # O-word recursion, if/else, expressions
    "linuxcnc/tests/interp/exists",  # EXISTS of named and numbered parameters (an A word)
    *(
        f"linuxcnc/tests/interp/g81/{pl}/{r}"
        for pl in ("g17", "g18", "g19")
        for r in ("g98", "g99")
    ),
]


def _canon_ends(text: str) -> list[tuple[float, ...]]:
    """The end of every straight move [m; A in degrees], repeated ends dropped."""
    unit, out = 1e-3, []
    for m in _CANON.finditer(text):
        if m.group(3):
            unit = 0.0254 if "INCH" in m.group(3) else 1e-3
            continue
        x, y, z, a = (float(v) for v in m.group(2).split(",")[:4])
        end = (x * unit, y * unit, z * unit, a)
        if not out or max(abs(u - v) for u, v in zip(out[-1], end, strict=True)) > 1e-12:
            out.append(end)
    return out


@pytest.mark.parametrize("case", _REFERENCE, ids=[c.split("interp/")[1] for c in _REFERENCE])
def test_moves_agree_with_linuxcncs_own_interpreter(case: str) -> None:
    d = HERE / case
    prog = next(p for p in d.iterdir() if p.suffix == ".ngc")
    ref = _canon_ends((d / "expected").read_text())
    setup = MachineSetup(
        axes={"X": 0, "Y": 1, "Z": 2, "A": 3}, names=("x", "y", "z", "a"), rotary=frozenset("A")
    )
    ours = [
        (*mv.end[:3], math.degrees(mv.end[3]))
        for mv in Interpreter(prog.name, setup, text=prog.read_text()).run()
        if isinstance(mv, GcodeMove)
    ]
    assert len(ours) == len(ref) >= 2
    for k, (a, b) in enumerate(zip(ours, ref, strict=True)):
        # the reference prints 4 decimals in its current unit
        assert a == pytest.approx(b, abs=0.6e-4 * 0.0254), (prog.name, k, a, b)


# -- a few run in the runtime, checked on the trace ------------------------------------------
_TP = "linuxcnc/tests/trajectory-planner/circular-arcs/nc_files/"
RUNS = [
    (_TP + "quick-tests/tangent_helix.ngc", MILL3),  # inch, a helix tangent to lines, G64
    (_TP + "arc-intersections/arc-arc-sawtooth.ngc", MILL3),  # 48 arcs joined, G64 P
    (_TP + "quick-tests/naive_cam_corner1.ngc", MILL3),  # G64 P Q: naive-CAM merge
    ("bcnc/tests/static/sample.gcode", MILL3),  # CAM output (398 moves, mm)
    ("linuxcnc/nc_files/daisy.ngc", MILL4),  # A axis with X, exact stops
]


@pytest.mark.parametrize(("rel", "config"), RUNS, ids=[Path(r).stem for r, _ in RUNS])
def test_program_runs_within_limits_and_tolerance(rel: str, config: Path) -> None:
    r = run_checked(HERE / rel, config)
    assert r.finished and not r.failures, r.failures
    assert r.dropped_rows == 0
    assert r.limit_violations == 0, r.worst_limit
    assert r.excess <= 0.0, (r.excess, r.excess_at)
    assert r.corner_miss <= r.corner_allowance
    assert r.end_error <= PATH_ATOL
    assert r.ok and r.moves > 0
