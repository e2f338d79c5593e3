"""The ``cams:`` section of a machine configuration: inline points and CSV files become
CamTables (``Config.cams``, ``Machine.cams``), every problem is reported located
(``FILE:LINE: cams.<name>.points[i].<field>: ...``), the schema declares the section (the JSON
Schema accepts the shipped example, jsonschema as the peer validator) and its literals equal
motionplc.planning.cam's."""

from __future__ import annotations

import math
from pathlib import Path

import jsonschema
import numpy as np
import pytest

from motionplc.config import build, load_config
from motionplc.errors import ConfigError
from motionplc.planning import CamPoint, CamTable
from motionplc.planning import cam as cam_mod
from motionplc.schema import config as S  # noqa: N812
from motionplc.schema import json_schema

ROOT = Path(__file__).resolve().parents[2]
EXAMPLE = ROOT / "configs" / "cams" / "rotary_cam.yaml"
HEAD = """\
runtime:
  tick: 0.001
  tasks:
    motion: {period: 0.001}
axes:
  x:
    limits: {v_max: 1.0, a_max: 10.0, j_max: 100.0}
"""


def _load(tmp_path: Path, cams: str, files: dict[str, str] | None = None):
    for name, text in (files or {}).items():
        (tmp_path / name).write_text(text, encoding="utf-8")
    f = tmp_path / "m.yaml"
    f.write_text(HEAD + cams, encoding="utf-8")
    return f, load_config(f)


def _errors(tmp_path: Path, cams: str, files: dict[str, str] | None = None) -> list[str]:
    with pytest.raises(ConfigError) as ei:
        _load(tmp_path, cams, files)
    return list(ei.value.errors)


def test_shipped_example_loads_and_builds() -> None:
    cfg = load_config(EXAMPLE)
    assert [c.name for c in cfg.cams] == ["pusher", "knife"]
    pusher = cfg.cam("pusher")
    assert pusher.segment_laws == ("poly5", "poly5", "linear", "modified_sine")
    assert pusher.periodic and pusher.c2 and pusher.lift == 0.0
    assert pusher.master_end == pytest.approx(2 * math.pi)
    knife = cfg.cam("knife")
    assert knife.segment_laws == ("poly5", "linear", "poly5")
    assert knife.boundary[1][0] == pytest.approx(0.1)  # the linear cut's slope taken over
    with build(cfg) as machine:
        assert machine.cams == {"pusher": pusher, "knife": knife}
    # the JSON Schema (docs/schema/config.schema.json's source) accepts the example
    import yaml

    data = yaml.safe_load(EXAMPLE.read_text())
    jsonschema.Draft202012Validator(json_schema("config")).validate(data)


def test_shipped_program_runs_the_cams() -> None:
    """configs/cams/rotary_cam_program.py: MC_CamTableSelect + MC_CamIn on both cams of the
    example, slaves on their tables to 1e-9 for two drum turns."""
    from motionplc.sequence import runner_for

    with build(load_config(EXAMPLE)) as machine:
        runner, task = runner_for(EXAMPLE.parent / "rotary_cam_program.py", machine)
        machine.attach(runner, task)
        machine.runtime.run_until(lambda: runner.over, max_seconds=10.0)
        assert runner.failures == []
        assert runner.finished


def test_inline_points_in_every_form(tmp_path: Path) -> None:
    _, cfg = _load(
        tmp_path,
        """\
cams:
  c1:
    law: cycloid
    points:
      - [0, 0]
      - [1, 1, 0]
      - [2, 1, 0.0, 0.0]
      - {master: 3, slave: 0.5, curvature: 0.0, law: poly7}
      - {master: 4, slave: 0.0}
""",
    )
    want = CamTable(
        (
            CamPoint(0, 0),
            CamPoint(1, 1, 0),
            CamPoint(2, 1, 0.0, 0.0),
            CamPoint(3, 0.5, None, 0.0, "poly7"),
            CamPoint(4, 0.0),
        ),
        ("cycloid",),
        name="c1",
    )
    got = cfg.cam("c1")
    assert got == want
    assert got.segment_laws == ("cycloid", "cycloid", "cycloid", "poly7")
    xs = np.linspace(0, 4, 101)
    assert np.array_equal(got.sample(xs).y, want.sample(xs).y)


def test_smooth_and_periodic_keys(tmp_path: Path) -> None:
    _, cfg = _load(
        tmp_path,
        "cams:\n  s:\n    smooth: true\n    periodic: true\n"
        "    points: [[0, 0], [1, 1], [2, 0.5], [3, 1.5]]\n",
    )
    t = cfg.cam("s")
    assert t == CamTable.from_points(
        [(0, 0), (1, 1), (2, 0.5), (3, 1.5)], smooth=True, periodic=True, name="s"
    )
    assert t.boundary[1][0] != 0.0 and t.lift == 1.5
    errs = _errors(tmp_path, "cams:\n  s:\n    smooth: yes please\n    points: [[0, 0], [1, 1]]\n")
    assert errs[0].endswith("cams.s.smooth: got string 'yes please' (allowed: true, false)")


def test_csv_file(tmp_path: Path) -> None:
    csv = "# comment\nmaster,slave,slope,curvature,law\n0,0\n\n1,0.5,,,linear\n2,1.0 # end\n"
    _, cfg = _load(tmp_path, "cams:\n  k:\n    file: k.csv\n    law: poly7\n", {"k.csv": csv})
    t = cfg.cam("k")
    assert [(p.master, p.slave, p.law) for p in t.points] == [
        (0.0, 0.0, None),
        (1.0, 0.5, "linear"),
        (2.0, 1.0, None),
    ]
    assert t.segment_laws == ("poly7", "linear")
    assert t.boundary[1] == (0.5, 0.0)


@pytest.mark.parametrize(
    ("cams", "line", "path", "problem"),
    [
        (
            "cams:\n  c1:\n    points:\n      - [0, 0]\n      - [1, 1]\n      - [0.5, 2]\n",
            13,
            "cams.c1.points[2].master",
            "must be at least 1e-09 beyond points[1].master",
        ),
        (
            "cams:\n  c1:\n    points:\n      - [0, 0]\n      - {master: 1,\n"
            "         slave: .nan}\n",
            13,
            "cams.c1.points[1].slave",
            "finite number in [-1e+12, 1e+12]",
        ),
        (
            "cams:\n  c1:\n    points:\n      - [0, 0]\n      - {master: 1, slave: 1, "
            "law: spline}\n      - [2, 0]\n",
            12,
            "cams.c1.points[1].law",
            "unknown motion law 'spline'",
        ),
        (
            "cams:\n  c1:\n    points:\n      - [0, 0]\n",
            11,
            "cams.c1.points",
            "at least 2 points",
        ),
        (
            "cams:\n  c1:\n    law: linear\n    points:\n      - [0, 0]\n      - [1, 1]\n"
            "      - [2, 3]\n",
            13,
            "cams.c1.points[1].slope",
            "segment 0 (law 'linear') ends with slope 1.0 but segment 1",
        ),
        (
            "cams:\n  c1:\n    points:\n      - [0, 0]\n      - [1, 1, 2, 3, 4]\n",
            12,
            "cams.c1.points[1]",
            "must be [master, slave]",
        ),
        ("cams:\n  c1:\n    law: poly9\n    points: [[0, 0], [1, 1]]\n", 10, "cams.c1.law", ""),
        (
            "cams:\n  c1:\n    periodic: 1\n    points: [[0, 0], [1, 1]]\n",
            10,
            "cams.c1.periodic",
            "",
        ),
        (
            "cams:\n  c1:\n    point: 1\n    points: [[0, 0], [1, 1]]\n",
            10,
            "cams.c1.point",
            "unknown key",
        ),
        (
            "cams:\n  c1:\n    law: poly5\n",
            10,
            "cams.c1.points",
            "missing (allowed: points or file)",
        ),
        (
            "cams:\n  c1:\n    file: a.csv\n    points: [[0, 0], [1, 1]]\n",
            10,
            "cams.c1.file",
            "given with `points` (allowed: one of them)",
        ),
        ("cams:\n  c1:\n    points: 3\n", 10, "cams.c1.points", "got number 3 (allowed: a list)"),
        ("cams:\n  1c: {points: [[0, 0], [1, 1]]}\n", 9, "cams.1c", "invalid name"),
        ("cams:\n  c1: [[0, 0], [1, 1]]\n", 9, "cams.c1", "got a list"),
    ],
)
def test_located_errors(tmp_path: Path, cams: str, line: int, path: str, problem: str) -> None:
    errs = _errors(tmp_path, cams)
    f = tmp_path / "m.yaml"
    assert len(errs) == 1, errs
    assert errs[0].startswith(f"{f}:{line}: {path}: "), errs[0]
    assert problem in errs[0]


def test_csv_errors_point_at_the_csv_line(tmp_path: Path) -> None:
    csv = "master,slave\n0,0\n1,abc\n2,2,3,4,poly5,9\n"
    errs = _errors(tmp_path, "cams:\n  k:\n    file: k.csv\n", {"k.csv": csv})
    k = tmp_path / "k.csv"
    assert errs == [
        f"{k}:3: cams.k.points[1].slave: got 'abc' (allowed: a number)",
        f"{k}:4: cams.k.points[2]: 6 fields (allowed: master, slave[, slope[, curvature[, law]]])",
    ]
    # table errors too: the line of the offending point
    errs = _errors(
        tmp_path, "cams:\n  k:\n    file: k2.csv\n", {"k2.csv": "0,0\n\n1,1,,,bad\n2,0\n"}
    )
    assert errs[0].startswith(f"{tmp_path / 'k2.csv'}:3: cams.k.points[1].law: unknown motion law")
    errs = _errors(tmp_path, "cams:\n  k:\n    file: missing.csv\n")
    assert errs[0].startswith(f"{tmp_path / 'm.yaml'}:10: cams.k.file: cannot read")


def test_every_cam_error_of_a_file_is_reported(tmp_path: Path) -> None:
    errs = _errors(
        tmp_path,
        "cams:\n  a: {points: [[0, 0]]}\n  b: {points: [[0, 0], [1, 1]]}\n  c: {law: x}\n",
    )
    assert [e.split(": ")[1] for e in errs] == ["cams.a.points", "cams.c.law", "cams.c.points"]


def test_schema_literals_match_the_planner() -> None:
    assert S.CAM_LAWS == cam_mod.LAWS
    assert S.CAM_COORD_MAX == cam_mod.COORD_MAX
    assert S.CAM_SLOPE_MAX == cam_mod.SLOPE_MAX
    assert S.CAM_CURVATURE_MAX == cam_mod.CURVATURE_MAX
    assert "cams" in S.TOP
    js = json_schema("config")
    assert "cams" in js["properties"]
