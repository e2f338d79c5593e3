"""Hostile and broken YAML files (tests/config/hostile_corpus.py): each one is refused by
``motionplc validate`` as one located line ``FILE:LINE: ...`` with exit code 2, within bounded
memory (tracemalloc's peak, < 200 MB) and without running anything it names. The time of each
file is bounded loosely here (the machine is shared); ``tools/bench_hostile.py`` measures the
time and peak RSS of every file in its own process."""

from __future__ import annotations

import re
import time
import tracemalloc
from collections.abc import Callable
from pathlib import Path

import pytest

from motionplc.cli import main
from motionplc.errors import ConfigError
from tests.config.hostile_corpus import Case, cases, write_case

CASES = cases()


def _peak_meter() -> tuple[Callable[[], None], Callable[[], int]]:
    """(start, peak bytes since start): the process's peak RSS reset through
    /proc/self/clear_refs where Linux allows it, else tracemalloc's peak."""
    try:
        Path("/proc/self/clear_refs").write_text("5")

        def hwm() -> int:
            for row in Path("/proc/self/status").read_text().splitlines():
                if row.startswith("VmHWM:"):
                    return int(row.split()[1]) * 1024
            raise OSError("no VmHWM")

        hwm()
    except OSError:
        return tracemalloc.start, lambda: tracemalloc.get_traced_memory()[1]
    base = [0]

    def start() -> None:
        Path("/proc/self/clear_refs").write_text("5")
        base[0] = hwm()

    return start, lambda: hwm() - base[0]


def test_the_corpus_is_large_enough() -> None:
    assert len(CASES) >= 50
    assert len({c.name for c in CASES}) == len(CASES)
    assert {c.kind for c in CASES} == {"config", "sequence", "regmap", "gcode"}


@pytest.mark.parametrize("case", CASES, ids=[c.name for c in CASES])
def test_hostile_file_is_one_located_line(
    case: Case, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    args, path = write_case(case, tmp_path)
    capsys.readouterr()
    start, peak_since = _peak_meter()
    start()
    t0 = time.perf_counter()
    try:
        rc = main(["validate", *args])
    finally:
        elapsed = time.perf_counter() - t0
        peak = peak_since()
        tracemalloc.stop()
        path.unlink()  # the 100 MB one is not kept in pytest's tmp folders
    out, err = capsys.readouterr()
    assert rc == 2, (out, err[:2000])
    lines = err.splitlines()
    assert len(lines) == case.lines, err[:3000]
    line = r"\d+" if case.line is None else str(case.line)
    assert re.match(rf"motionplc: error: {re.escape(str(path))}:{line}: ", lines[0]), lines[0]
    assert case.text in lines[0], lines[0]
    capped = case.lines > ConfigError.MAX_SHOWN
    problems = lines[1:-1] if capped else lines[1:]
    for row in problems:  # each further problem located too
        assert re.match(r"/\S+\.(yaml|ngc):\d+: ", row), row
    if capped:
        assert re.fullmatch(r"\.\.\. and \d+ more problems \(not shown\)", lines[-1]), lines[-1]
    assert all(len(x) < 600 for x in lines)
    assert all(x.isprintable() for x in lines)  # nothing from the input drives the terminal
    assert peak < 200 * 1024 * 1024, f"{peak / 1e6:.0f} MB"
    assert elapsed < 20.0  # bounded (the figure of record is tools/bench_hostile.py's)
    assert not Path("/tmp/motionplc-pwned").exists()
