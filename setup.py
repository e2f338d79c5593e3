"""Build of motionplc: the planning core compiled with mypyc where possible, plain Python otherwise.

Everything but the compiled extension is declared in ``pyproject.toml``. The way black and mypy
ship: the hot planning modules (``motionplc/_purepy.py`` lists them) are compiled with mypyc into
C extensions that sit next to their ``.py`` sources; the sources stay installed and are the
fallback. The build never fails for lack of a compiler:

* ``MOTIONPLC_NO_MYPYC=1`` at build time: no extension, plain Python;
* mypyc not importable, or its translation failing: a warning, plain Python;
* no C compiler, or a compile error: a warning, every extension built so far removed (the
  compiled modules call each other directly, so they are installed all together or not at
  all), plain Python.

At run time ``MOTIONPLC_PURE_PYTHON=1`` selects the sources even when the extensions exist, and
an extension whose source has changed since it was built is never used (see ``_purepy.py``).
"""

from __future__ import annotations

import functools
import hashlib
import json
import os
import sys
from pathlib import Path

from setuptools import Extension, setup
from setuptools.command.build_ext import build_ext
from setuptools.command.build_py import build_py

ROOT = Path(__file__).resolve().parent
# The compiled modules, as in motionplc/_purepy.py (COMPILED_MODULES); both lists are checked
# against each other by tests/planning/test_compiled.py.
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
GROUP = "motionplc._core"  # the shared library: motionplc/_core__mypyc.<abi>.so
MANIFEST = "motionplc/_compiled.json"  # source digests of the last successful compile


def _warn(msg: str) -> None:
    print(f"motionplc build: {msg}; installing the pure-Python planning core", file=sys.stderr)  # noqa: T201


def _sources() -> list[str]:
    return [m.replace(".", "/") + ".py" for m in COMPILED_MODULES]


@functools.cache  # taken when mypyc reads the sources: an edit during the build voids it
def _digests() -> dict[str, str]:
    return {
        m: hashlib.sha256((ROOT / src).read_bytes()).hexdigest()
        for m, src in zip(COMPILED_MODULES, _sources(), strict=True)
    }


@functools.cache
def _ext_modules() -> list:
    if os.environ.get("MOTIONPLC_NO_MYPYC", "") not in ("", "0"):
        print("motionplc build: MOTIONPLC_NO_MYPYC set: pure-Python planning core", file=sys.stderr)  # noqa: T201
        return []
    try:
        from mypyc.build import mypycify
    except Exception as exc:  # noqa: BLE001 - any failure means: no compiled core
        _warn(f"mypyc is not available ({type(exc).__name__}: {exc})")
        return []
    _digests()
    cwd = os.getcwd()
    try:
        os.chdir(ROOT)  # mypyc takes the module names from the paths relative to here
        exts = mypycify(
            [
                "--follow-imports=silent",  # type-check the compiled modules only
                # numpy is not in the isolated build environment; profile.py's numpy code
                # (Profile.sample) then stays generic Python calls
                "--ignore-missing-imports",
                f"--cache-dir={os.devnull}",
                *_sources(),
            ],
            opt_level="3",
            group_name=GROUP,
        )
    except BaseException as exc:  # noqa: BLE001 - mypyc exits via SystemExit on type errors
        _warn(f"mypyc could not translate the planning core ({type(exc).__name__}: {exc})")
        return []
    finally:
        os.chdir(cwd)
    for ext in exts:
        ext.optional = True
    return exts


def _metadata_only() -> bool:
    """pip only asks for requirements or metadata (setuptools' egg_info / dist_info pass)."""
    cmds = set(sys.argv[1:])
    build = {"build", "build_ext", "bdist_wheel", "editable_wheel", "install", "develop"}
    return bool(cmds & {"egg_info", "dist_info"}) and not cmds & build


class OptionalBuildExt(build_ext):
    """``build_ext`` that installs either every compiled module or none (never fails).

    mypyc translates the core only when this command runs (not when pip merely asks for the
    metadata); until then a placeholder extension marks the distribution as platform-specific.
    """

    def finalize_options(self) -> None:
        exts = self.distribution.ext_modules or []
        placeholder = [(e.name, e.sources) for e in exts] == [(f"{GROUP}__mypyc", [])]
        if placeholder and not _metadata_only():
            self.distribution.ext_modules = _ext_modules()
        super().finalize_options()

    def run(self) -> None:
        if self.inplace or self.editable_mode:
            # the in-tree manifest of an earlier build is void until this one succeeds: a
            # build that ends in pure Python must not leave the earlier extensions in use
            (ROOT / MANIFEST).unlink(missing_ok=True)
        if not self.extensions:
            return
        try:
            super().run()
        except Exception as exc:  # noqa: BLE001 - no compiler, compile error, ...
            self._drop(f"{type(exc).__name__}: {exc}")
            return
        missing = [e.name for e in self.extensions if not os.path.exists(self._built(e))]
        if missing:
            self._drop(f"not built: {', '.join(missing)}")
            return
        # the digests tell the run time which sources these extensions were built from
        manifest = json.dumps({"modules": _digests()}, indent=1, sort_keys=True) + "\n"
        for base in (
            {self.build_lib, str(ROOT)} if self.inplace or self.editable_mode else {self.build_lib}
        ):
            path = Path(base) / MANIFEST
            path.parent.mkdir(parents=True, exist_ok=True)
            path.write_text(manifest)

    def build_extension(self, ext) -> None:  # noqa: ANN001 - setuptools' signature
        # setuptools skips an ``optional`` extension that fails with a warning only; here
        # one failure drops them all (in run), so re-raise
        ext.optional = False
        super().build_extension(ext)

    def _built(self, ext) -> str:  # noqa: ANN001
        return self.get_ext_fullpath(ext.name)

    def _drop(self, why: str) -> None:
        _warn(f"the C compile failed ({why})")
        for ext in self.extensions:
            for path in {
                self._built(ext),
                os.path.join(self.build_lib, self.get_ext_filename(ext.name)),
            }:
                if os.path.exists(path):
                    os.remove(path)
        self.extensions = []


class BuildPyWithExamples(build_py):
    """``build_py`` that also copies the example machines and programs of ``configs/`` into the
    built package as ``motionplc/_examples/`` (``motionplc examples DIR`` hands them out from an
    installed wheel; an editable install reads ``configs/`` itself)."""

    def run(self) -> None:
        super().run()
        src = ROOT / "configs"
        dest = Path(self.build_lib) / "motionplc" / "_examples"
        for path in sorted(src.rglob("*")):
            if path.is_file() and "__pycache__" not in path.parts:
                out = dest / path.relative_to(src)
                out.parent.mkdir(parents=True, exist_ok=True)
                self.copy_file(str(path), str(out))


def _placeholder() -> list[Extension]:
    if os.environ.get("MOTIONPLC_NO_MYPYC", "") not in ("", "0"):
        (ROOT / MANIFEST).unlink(missing_ok=True)  # extensions of an earlier build: unused
        return []
    return [Extension(f"{GROUP}__mypyc", sources=[])]


setup(
    ext_modules=_placeholder(),
    cmdclass={"build_ext": OptionalBuildExt, "build_py": BuildPyWithExamples},
)
