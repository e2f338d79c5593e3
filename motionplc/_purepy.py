"""Which planning core is used: the mypyc-compiled extensions or the pure-Python sources.

The build (``setup.py``) compiles the modules in :data:`COMPILED_MODULES` with mypyc where a C
compiler exists; the extensions sit next to their ``.py`` sources, which stay installed. Python's
import system prefers an extension to a source, so without intervention the compiled core is
used. :func:`install` (called once by ``motionplc/__init__.py``, before any planning module is
imported) puts a finder in front of the import system that loads the ``.py`` sources instead
when

* ``MOTIONPLC_PURE_PYTHON`` is set (to anything but ``""`` or ``"0"``) at import time;
* an extension, the shared library or the build manifest is missing (a build without a C
  compiler, or with ``MOTIONPLC_NO_MYPYC=1``), or ``librt``, the run-time library the
  extensions import, is not installed;
* a source differs from the one the extensions were built from (an edited checkout with an
  editable install: the edit is what runs, never a stale extension; rebuild with
  ``pip install -e .`` to compile it again).

The choice is all or nothing: the compiled modules call each other directly in C, so mixing
compiled and source modules of the core could run stale code. :func:`status` tells which core
is in use and why; it does not change after the first import of the planning core.
"""

from __future__ import annotations

import hashlib
import importlib.machinery
import importlib.util
import json
import os
import sys
from collections.abc import Sequence
from importlib.machinery import ModuleSpec
from types import ModuleType
from typing import NamedTuple

ENV_PURE = "MOTIONPLC_PURE_PYTHON"
# Keep in step with setup.py (tests/planning/test_compiled.py checks both lists are equal).
COMPILED_MODULES = (
    "motionplc.planning.roots",
    "motionplc.planning._lower",
    "motionplc.planning._velocity",
    "motionplc.planning._brake",
    "motionplc.planning._third",
    "motionplc.planning.profile",
    "motionplc.planning.trajectory",
    "motionplc.planning.plan",
    "motionplc.planning._fixed",
    "motionplc.planning.sync",
    "motionplc.planning._batchrow",
    "motionplc.blocks._axis_core",  # the axis kernel's per-cycle common case (Axis' base)
    "motionplc.fieldbus._ideal_core",  # the ideal drive's per-cycle fields (IdealDrive's base)
    "motionplc.fieldbus._plant_core",  # the virtual drives' frictionless servo loop
)
SHARED_LIB = "_core__mypyc"  # mypyc's group library, inside the motionplc package
MANIFEST = "_compiled.json"  # written by the build: the sources' SHA-256 digests

_PKG_DIR = os.path.dirname(os.path.abspath(__file__))


class CoreStatus(NamedTuple):
    """Which planning core the import system was set up for, and why."""

    compiled: bool
    reason: str


def _pure_requested() -> bool:
    return os.environ.get(ENV_PURE, "") not in ("", "0")


def _source(module: str) -> str:
    parts = module.split(".")[1:]
    return os.path.join(_PKG_DIR, *parts) + ".py"


def _extension(directory: str, name: str) -> str | None:
    for suffix in importlib.machinery.EXTENSION_SUFFIXES:
        path = os.path.join(directory, name + suffix)
        if os.path.isfile(path):
            return path
    return None


def _librt_available() -> bool:
    """Whether ``librt.strings`` (mypyc's run-time library, which the compiled core imports)
    can be imported."""
    try:
        import librt.strings  # noqa: F401
    except ImportError:
        return False
    return True


def _compiled_available() -> tuple[bool, str]:
    """Whether every extension of the core exists and was built from the present sources
    (and the run-time library it needs is installed)."""
    if _extension(_PKG_DIR, SHARED_LIB) is None:
        return False, "pure Python: no compiled core installed"
    if not _librt_available():
        return False, "pure Python: librt.strings (mypyc's run-time library) is not installed"
    for module in COMPILED_MODULES:
        src = _source(module)
        if _extension(os.path.dirname(src), module.rpartition(".")[2]) is None:
            return False, f"pure Python: {module} has no compiled extension"
    try:
        with open(os.path.join(_PKG_DIR, MANIFEST), encoding="utf-8") as f:
            built = json.load(f)["modules"]
    except (OSError, ValueError, KeyError, TypeError):
        return False, f"pure Python: no valid build manifest motionplc/{MANIFEST}"
    for module in COMPILED_MODULES:
        try:
            with open(_source(module), "rb") as f:
                digest = hashlib.sha256(f.read()).hexdigest()
        except OSError:
            return False, f"pure Python: the source of {module} is missing"
        if built.get(module) != digest:
            return (
                False,
                f"pure Python: {module} changed since the compiled core was built "
                "(reinstall to compile it)",
            )
    return True, "compiled (mypyc)"


class _SourceFinder:
    """Meta-path finder that loads the core's modules from their ``.py`` sources."""

    def __init__(self, reason: str) -> None:
        self.reason = reason

    def find_spec(
        self, fullname: str, path: Sequence[str] | None, target: ModuleType | None = None
    ) -> ModuleSpec | None:
        """A source-file spec for a module of the core, else None (the normal import)."""
        if fullname not in COMPILED_MODULES:
            return None
        src = _source(fullname)
        if not os.path.isfile(src):
            return None
        loader = importlib.machinery.SourceFileLoader(fullname, src)
        return importlib.util.spec_from_file_location(fullname, src, loader=loader)


def _installed() -> _SourceFinder | None:
    for finder in sys.meta_path:
        if isinstance(finder, _SourceFinder):
            return finder
    return None


def install() -> CoreStatus:
    """Set the import system up for the compiled or the pure core (idempotent).

    Must run before any module of :data:`COMPILED_MODULES` is imported (``motionplc``'s
    ``__init__`` calls it); later calls return the status decided by the first one.
    """
    finder = _installed()
    if finder is not None:
        return CoreStatus(False, finder.reason)
    if any(m in sys.modules for m in COMPILED_MODULES):
        return status()
    if _pure_requested():
        ok, reason = False, f"pure Python: {ENV_PURE} is set"
    else:
        ok, reason = _compiled_available()
    if not ok:
        sys.meta_path.insert(0, _SourceFinder(reason))  # type: ignore[arg-type]
    return CoreStatus(ok, reason)


def _is_extension(module: ModuleType | None) -> bool:
    file = getattr(module, "__file__", None) or ""
    return any(file.endswith(s) for s in importlib.machinery.EXTENSION_SUFFIXES)


def status() -> CoreStatus:
    """Which core is in use: compiled only if every module of the core that is imported is
    an extension (and the import system was not set up for the sources)."""
    finder = _installed()
    if finder is not None:
        return CoreStatus(False, finder.reason)
    loaded = [sys.modules.get(m) for m in COMPILED_MODULES if m in sys.modules]
    if loaded and all(_is_extension(m) for m in loaded):
        return CoreStatus(True, "compiled (mypyc)")
    if loaded:
        return CoreStatus(False, "pure Python: the core was imported from its sources")
    ok, reason = _compiled_available()
    return CoreStatus(ok, reason)
