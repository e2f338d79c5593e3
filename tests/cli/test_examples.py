"""``motionplc examples DIR``: the shipped examples, from a checkout and from a built package."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from motionplc.cli import main
from motionplc.examples import example_files, examples_root

ROOT = Path(__file__).resolve().parents[2]
CONFIGS = ROOT / "configs"


def _shipped() -> list[Path]:
    return sorted(
        p.relative_to(CONFIGS)
        for p in CONFIGS.rglob("*")
        if p.is_file() and "__pycache__" not in p.parts
    )


def test_every_file_of_configs_is_an_example() -> None:
    assert examples_root() == CONFIGS  # an editable install reads the checkout's configs/
    assert example_files() == _shipped()


def test_copy_then_validate_from_elsewhere(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    dest = tmp_path / "x"
    assert main(["examples", str(dest)]) == 0
    out = capsys.readouterr().out
    assert f"wrote {len(_shipped())} example files to {dest}" in out
    for rel in _shipped():
        assert (dest / rel).read_bytes() == (CONFIGS / rel).read_bytes()
    # the copies refer to their cam files and programs relative to themselves
    monkeypatch.chdir(tmp_path)
    for config, script in (
        ("demo.yaml", "demo_sequence.yaml"),
        ("cams/rotary_cam.yaml", "cams/rotary_cam_program.py"),
    ):
        assert main(["validate", str(dest / config), str(dest / script)]) == 0, config
    capsys.readouterr()


def test_refuses_to_replace_unless_forced(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    dest = tmp_path / "x"
    assert main(["examples", str(dest)]) == 0
    (dest / "demo.yaml").write_text("edited\n")
    capsys.readouterr()
    assert main(["examples", str(dest)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "exists" in err[0] and "--force" in err[0], err
    assert (dest / "demo.yaml").read_text() == "edited\n"
    assert main(["examples", str(dest), "--force"]) == 0
    assert (dest / "demo.yaml").read_bytes() == (CONFIGS / "demo.yaml").read_bytes()
    (tmp_path / "file").write_text("")
    assert main(["examples", str(tmp_path / "file")]) == 2
    assert "not a folder" in capsys.readouterr().err


def test_a_built_package_carries_the_examples(tmp_path: Path) -> None:
    """setup.py's build_py copies configs/ into the package (the wheel's contents), and the
    built package hands them out without a checkout beside it."""
    # built from a copy of the sources: setup.py run in the checkout itself would void the
    # editable install's compiled build (a pure-Python build removes its manifest)
    src = tmp_path / "src"
    ignore = shutil.ignore_patterns("__pycache__", "*.so", "_compiled.json", "*.egg-info")
    shutil.copytree(ROOT / "motionplc", src / "motionplc", ignore=ignore)
    shutil.copytree(ROOT / "configs", src / "configs", ignore=ignore)
    for name in ("setup.py", "pyproject.toml", "README.md", "LICENSE"):
        shutil.copyfile(ROOT / name, src / name)
    build = tmp_path / "build"
    env = {**os.environ, "MOTIONPLC_NO_MYPYC": "1"}
    subprocess.run(
        [sys.executable, "setup.py", "-q", "build_py", "-d", str(build)],
        cwd=src,
        env=env,
        check=True,
        capture_output=True,
    )
    packaged = build / "motionplc" / "_examples"
    assert example_files(packaged) == _shipped()
    dest = tmp_path / "copy"
    code = (
        "import sys; from motionplc.examples import examples_root; "
        "from motionplc.cli import main; print(examples_root()); "
        f"sys.exit(main(['examples', {str(dest)!r}]))"
    )
    res = subprocess.run(
        [sys.executable, "-c", code],
        cwd=tmp_path,
        env={**env, "PYTHONPATH": str(build)},
        capture_output=True,
        text=True,
    )
    assert res.returncode == 0, res.stderr
    assert res.stdout.splitlines()[0] == str(packaged)
    assert sorted(p.relative_to(dest) for p in dest.rglob("*") if p.is_file()) == _shipped()
