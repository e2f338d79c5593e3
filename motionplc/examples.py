"""The example machines and programs shipped with motionplc (``motionplc examples DIR``).

The repository keeps them in ``configs/``; a wheel carries the same files as package data in
``motionplc/_examples/`` (``setup.py`` copies them at build time), so an installed motionplc can
hand them out without a checkout::

    motionplc examples /tmp/x
    motionplc run /tmp/x/demo.yaml /tmp/x/demo_sequence.yaml

A configuration refers to its cam files and programs by paths relative to itself, so the copy
runs from anywhere.
"""

from __future__ import annotations

import shutil
from pathlib import Path

from motionplc.errors import ConfigError

__all__ = ["examples_root", "example_files", "copy_examples"]

_PACKAGED = Path(__file__).resolve().parent / "_examples"
_CHECKOUT = Path(__file__).resolve().parent.parent / "configs"


def examples_root() -> Path:
    """The folder holding the examples: the wheel's package data, else the checkout's
    ``configs/`` (an editable install)."""
    for root in (_PACKAGED, _CHECKOUT):
        if (root / "demo.yaml").is_file():
            return root
    raise ConfigError(
        "examples: not found in this installation (looked in "
        f"{_PACKAGED} and {_CHECKOUT}); reinstall motionplc"
    )


def example_files(root: Path | None = None) -> list[Path]:
    """Every example file, relative to :func:`examples_root`, sorted."""
    base = examples_root() if root is None else root
    return sorted(
        p.relative_to(base) for p in base.rglob("*") if p.is_file() and "__pycache__" not in p.parts
    )


def copy_examples(dest: str | Path, overwrite: bool = False) -> list[Path]:
    """Copy every example into ``dest`` (created if missing), keeping the sub-folders.

    Refuses, naming the first one, when a file would be replaced and ``overwrite`` is false.
    Returns the files written (paths under ``dest``)."""
    root = examples_root()
    files = example_files(root)
    target = Path(dest)
    if target.exists() and not target.is_dir():
        raise ConfigError(f"examples: {target} exists and is not a folder")
    if not overwrite:
        clash = [f for f in files if (target / f).exists()]
        if clash:
            raise ConfigError(
                f"examples: {target / clash[0]} exists ({len(clash)} file(s) would be "
                "replaced); choose an empty folder or pass --force"
            )
    written = []
    for rel in files:
        out = target / rel
        out.parent.mkdir(parents=True, exist_ok=True)
        shutil.copyfile(root / rel, out)
        written.append(out)
    return written
