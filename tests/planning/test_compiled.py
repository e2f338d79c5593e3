"""The compiled planning core (mypyc) against its pure-Python sources.

* The switch: ``MOTIONPLC_PURE_PYTHON=1`` loads the ``.py`` sources although the extensions are
  installed; a stale or incomplete build falls back to the sources (all of them) by itself.
* Bit-identical results: several thousand random ``plan`` / ``plan_velocity`` cases (general
  states, also outside the limits, asymmetric and second-order limits) and ``plan_sync`` of 3
  axes give the same durations, phase times and jerks (compared as exact float bits), and the
  same errors, compiled in this process and pure in a subprocess with the switch.
* The planning test suite runs once more in pure mode (a subprocess), so that the README's
  single test command runs it on both cores.
* Public error behaviour and immutability hold on whichever core is in use (this file runs in
  both modes): bad input is a ``PlanningError`` naming the field, never a ``TypeError`` from
  a compiled signature.

Without the compiled core (no C compiler at install, ``MOTIONPLC_NO_MYPYC=1``, or a source
edited since the build) the comparisons skip and say why.

Run as a script (``python test_compiled.py SEED N_PLAN N_SYNC``) it prints the results of the
random cases as JSON: that is the pure side of the comparison.
"""

from __future__ import annotations

import ast
import importlib
import json
import math
import os
import shutil
import subprocess
import sys
import sysconfig
from collections.abc import Callable
from dataclasses import FrozenInstanceError
from pathlib import Path
from typing import Any

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[2]
if str(ROOT) not in sys.path:  # run as a script: tests.planning._cases is imported from here
    sys.path.insert(0, str(ROOT))

from motionplc import _purepy, compiled_core  # noqa: E402
from motionplc.errors import PlanningError  # noqa: E402
from motionplc.planning import (  # noqa: E402
    COMPILED,
    Limits,
    Profile,
    State,
    plan,
    plan_batch,
    plan_sync,
    plan_velocity,
)
from tests.planning._cases import Case, generate_cases, generate_multi_cases  # noqa: E402

SEED = 15
N_PLAN = 4000  # position cases (plus a velocity-interface plan of each)
N_SYNC = 300  # 3-axis plan_sync cases

STATUS = compiled_core()
needs_compiled = pytest.mark.skipif(
    not STATUS.compiled, reason=f"no compiled planning core in use ({STATUS.reason})"
)


def _hex(x: float) -> str:
    return float(x).hex()


def _profile_bits(prof: Profile) -> list[Any]:
    return [_hex(prof.duration), prof.kind, [[_hex(d), _hex(j)] for d, j in prof.segments]]


def _plan_bits(c: Any) -> list[Any]:
    return _profile_bits(plan(c.start(), c.target(), c.limits()))


def _velocity_bits(c: Any) -> list[Any]:
    return _profile_bits(plan_velocity(c.start(), c.vf, c.limits(), c.af))


def _sync_bits(m: Any) -> list[Any]:
    traj = plan_sync(m.starts(), m.targets(), m.limits())
    return [_hex(traj.duration), *(_profile_bits(p) for p in traj.profiles)]


def _call(fn: Any, *args: Any, **kwargs: Any) -> list[Any]:
    try:
        return fn(*args, **kwargs)
    except PlanningError as exc:
        return ["PlanningError", str(exc)]


def random_results(seed: int, n_plan: int, n_sync: int) -> dict[str, list[Any]]:
    """Durations, kinds, segment durations and jerks (float bits) of the random cases."""
    general = generate_cases(n_plan // 2, seed)
    outside = generate_cases(n_plan // 4, seed + 1, outside_fraction=0.5, boundary_fraction=0.2)
    skewed = generate_cases(n_plan // 8, seed + 2, asymmetric_fraction=1.0, nonzero=True)
    second = generate_cases(n_plan - len(general) - len(outside) - len(skewed), seed + 3, order=2)
    cases = general + outside + skewed + second
    out: dict[str, list[Any]] = {"plan": [], "velocity": [], "sync": []}
    for c in cases:
        out["plan"].append(_call(_plan_bits, c))
        out["velocity"].append(_call(_velocity_bits, c))
    for m in generate_multi_cases(n_sync, seed + 4, 3):
        out["sync"].append(_call(_sync_bits, m))
    # plan_batch of every plannable case and as many rest-to-rest ones (asymmetric limits for
    # half): compiled row by row, as plain Python through numpy (more than 64 problems)
    ok = [c for c, r in zip(cases, out["plan"], strict=True) if r[0] != "PlanningError"]
    rng = np.random.default_rng(seed + 5)
    for k in range(len(ok)):
        p0, pf = (float(x) for x in rng.normal(0.0, 4.0, 2))
        v, a, j = (float(x) for x in rng.uniform(0.1, 10.0, 3))
        lo = (-float(rng.uniform(0.1, 10.0)), -float(rng.uniform(0.1, 10.0))) if k % 2 else ()
        ok.append(Case(p0, 0.0, 0.0, pf, 0.0, 0.0, v, a, j, *lo))
    cols = [np.array([getattr(c, f) for c in ok], dtype=float) for f in Case.__slots__[:9]]
    lo_v = np.array([c.lo_v if c.lo_v is not None else -c.v_max for c in ok])
    lo_a = np.array([c.lo_a if c.lo_a is not None else -c.a_max for c in ok])
    b = plan_batch(*cols, lo_v, lo_a)
    fields = (b.duration, b.t, b.durations, b.j, b.p, b.v, b.a, b.end_p, b.end_v, b.end_a)
    out["batch"] = [
        [b.kind[i], int(b.n_segments[i]), *(x[i].tobytes().hex() for x in fields)]
        for i in range(len(b))
    ]  # (one row per result: a difference names its problem)
    return out


def _pure_env() -> dict[str, str]:
    env = dict(os.environ)
    env[_purepy.ENV_PURE] = "1"
    return env


# -- the switch and the build ----------------------------------------------------------------
def test_module_lists_agree() -> None:
    """setup.py compiles exactly the modules the switch knows about."""
    tree = ast.parse((ROOT / "setup.py").read_text())
    listed = next(
        ast.literal_eval(node.value)
        for node in tree.body
        if isinstance(node, ast.Assign)
        and any(getattr(t, "id", "") == "COMPILED_MODULES" for t in node.targets)
    )
    assert tuple(listed) == _purepy.COMPILED_MODULES


def test_status_matches_the_loaded_modules(summary: Callable[[str], None]) -> None:
    for name in _purepy.COMPILED_MODULES:
        file = importlib.import_module(name).__file__ or ""  # not only planning modules
        assert file.endswith(".py") != STATUS.compiled, (name, file, STATUS)
    assert COMPILED is STATUS.compiled
    summary(f"planning core: {STATUS.reason}")


@pytest.mark.skipif(os.environ.get("CI") != "true", reason="checked on CI only (CI=true)")
def test_ci_uses_the_compiled_core() -> None:
    """Where a C compiler exists, CI's install compiled the core (no silent fallback)."""
    cc = (sysconfig.get_config_var("CC") or "cc").split()[0]
    if shutil.which(cc) is None:
        pytest.skip(f"no C compiler {cc!r}: the pure-Python fallback is expected")
    if os.environ.get("MOTIONPLC_NO_MYPYC", "") not in ("", "0"):
        pytest.skip("MOTIONPLC_NO_MYPYC is set")
    if os.environ.get(_purepy.ENV_PURE, "") not in ("", "0"):
        pytest.skip(f"{_purepy.ENV_PURE} is set")
    assert STATUS.compiled, STATUS.reason


def test_switch_loads_the_sources() -> None:
    code = (
        "import importlib, motionplc\n"
        "from motionplc.planning import plan\n"
        "s = motionplc.compiled_core()\n"
        "mods = motionplc._purepy.COMPILED_MODULES\n"
        "files = [importlib.import_module(m).__file__ for m in mods]\n"
        "print(s.compiled, all(f.endswith('.py') for f in files), s.reason)\n"
    )
    res = subprocess.run(
        [sys.executable, "-c", code], env=_pure_env(), capture_output=True, text=True, cwd=ROOT
    )
    assert res.returncode == 0, res.stderr
    assert res.stdout.split()[:2] == ["False", "True"], res.stdout
    assert _purepy.ENV_PURE in res.stdout


def _fake_build(tmp_path: Path, digests: dict[str, str] | None) -> Path:
    """A package tree with empty 'extensions' and a manifest with the given digests."""
    suffix = _purepy.importlib.machinery.EXTENSION_SUFFIXES[0]
    tmp_path.mkdir(parents=True, exist_ok=True)
    (tmp_path / (_purepy.SHARED_LIB + suffix)).write_bytes(b"")
    for m in _purepy.COMPILED_MODULES:
        *pkg, name = m.split(".")[1:]  # its place in the package (planning/, blocks/, ...)
        where = tmp_path.joinpath(*pkg)
        where.mkdir(parents=True, exist_ok=True)
        (where / (name + ".py")).write_text(f"# {name}\n")
        (where / (name + suffix)).write_bytes(b"")
    if digests is not None:
        (tmp_path / _purepy.MANIFEST).write_text(json.dumps({"modules": digests}))
    return tmp_path


def test_stale_or_incomplete_build_uses_the_sources(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    import hashlib

    good = {
        m: hashlib.sha256(f"# {m.rpartition('.')[2]}\n".encode()).hexdigest()
        for m in _purepy.COMPILED_MODULES
    }
    monkeypatch.setattr(_purepy, "_PKG_DIR", str(_fake_build(tmp_path, good)))
    assert _purepy._compiled_available() == (True, "compiled (mypyc)")
    # a source edited after the build
    (tmp_path / "planning" / "_third.py").write_text("# edited\n")
    ok, why = _purepy._compiled_available()
    assert not ok and "motionplc.planning._third changed" in why
    # no manifest (a build interrupted before it was written)
    (tmp_path / _purepy.MANIFEST).unlink()
    ok, why = _purepy._compiled_available()
    assert not ok and "manifest" in why
    # one extension missing
    _fake_build(tmp_path / "b", good)
    monkeypatch.setattr(_purepy, "_PKG_DIR", str(tmp_path / "b"))
    suffix = _purepy.importlib.machinery.EXTENSION_SUFFIXES[0]
    (tmp_path / "b" / "planning" / ("roots" + suffix)).unlink()
    ok, why = _purepy._compiled_available()
    assert not ok and "motionplc.planning.roots has no compiled extension" in why


# -- compiled against pure ---------------------------------------------------------------------
@needs_compiled
def test_bit_identical_to_pure_python(summary: Callable[[str], None]) -> None:
    compiled = random_results(SEED, N_PLAN, N_SYNC)
    res = subprocess.run(
        [sys.executable, __file__, str(SEED), str(N_PLAN), str(N_SYNC)],
        env=_pure_env(),
        capture_output=True,
        text=True,
        cwd=ROOT,
    )
    assert res.returncode == 0, res.stderr[-3000:]
    pure = json.loads(res.stdout)
    assert pure.pop("core")[0] is False
    n_err = 0
    for key, rows in compiled.items():
        assert len(rows) == len(pure[key])
        for i, (c, p) in enumerate(zip(rows, pure[key], strict=True)):
            assert c == p, f"{key} case {i}: compiled {c} != pure {p}"
            n_err += c[0] == "PlanningError"
    n = sum(len(r) for r in compiled.values())
    summary(f"compiled == pure on {n} results ({n_err} PlanningErrors, same messages)")
    assert n_err < n // 10  # the cases are mostly plannable: the comparison is not of errors


@needs_compiled
def test_planning_suite_in_pure_python(summary: Callable[[str], None]) -> None:
    """The planning tests once more on the sources (the main run used the compiled core). The
    path planners (tests/planning/paths) are not compiled: they ran on their sources already.
    The quick set (``-m "not slow"``): the long property and oracle runs compare against the
    compiled core's results, which test_bit_identical_to_pure_python compares with the sources'
    on 16,300 cases."""
    res = subprocess.run(
        [
            sys.executable,
            "-m",
            "pytest",
            str(ROOT / "tests" / "planning"),
            "--ignore",
            str(ROOT / "tests" / "planning" / "paths"),
            "-m",
            "not slow",
            "-q",
            "-x",
            "-p",
            "no:cacheprovider",
        ],
        env=_pure_env(),
        capture_output=True,
        text=True,
        cwd=ROOT,
    )
    failed = [ln for ln in res.stdout.splitlines() if ln.startswith(("FAILED", "ERROR"))]
    last = res.stdout.strip().splitlines()[-1:] or ["(no output)"]
    assert res.returncode == 0, (
        "the planning suite fails in pure-Python mode (MOTIONPLC_PURE_PYTHON=1):\n"
        + "\n".join(failed + last)
        + ("\n" + res.stderr[-2000:] if res.stderr.strip() else "")
    )
    summary(f"pure-Python planning suite: {res.stdout.strip().splitlines()[-1]}")


@needs_compiled
def test_kernel_traces_compiled_equal_pure(tmp_path: Path, summary: Callable[[str], None]) -> None:
    """The compiled axis kernel (blocks._axis_core) and planning core run the cycle bit for bit
    as their sources do: tools/kernel_digests.py's random FB sequences and its 8-axis virtual
    CAN scenarios (the trace of every cycle, the FB outputs, the frames) in both modes."""
    digests = []
    for mode, env in (("compiled", dict(os.environ)), ("pure", _pure_env())):
        got = {}
        for only, n_random in (("random", "24"), ("can:", "0")):
            out = tmp_path / f"{mode}-{only.strip(':')}.json"
            res = subprocess.run(
                [sys.executable, str(ROOT / "tools" / "kernel_digests.py"), "--random", n_random]
                + ["--only", only, "--json", str(out)],
                env=dict(env, PYTHONPATH=str(ROOT), PYTHONHASHSEED="0"),
                capture_output=True,
                text=True,
                cwd=ROOT,
            )
            assert res.returncode == 0, res.stderr[-2000:]
            got.update(json.loads(out.read_text()))
        digests.append(got)
    compiled, pure = digests
    assert len(compiled) == 26 and not any(v.startswith("EXCEPTION") for v in compiled.values())
    differ = sorted(k for k in compiled if compiled[k] != pure.get(k))
    assert not differ, f"compiled and pure kernels differ in {differ}"
    summary(f"kernel digests compiled == pure on {len(compiled)} scenarios (24 random, 2 CAN)")


# -- error behaviour and immutability on the core in use -----------------------------------------
LIM = Limits(v_max=1.8, a_max=1.2, j_max=1.0)
BAD_VALUES = [
    ("nan", math.nan),
    ("inf", math.inf),
    ("None", None),
    ("str", "1.0"),
    ("bool", True),
    ("numpy int", np.int64(1)),
    ("numpy float32", np.float32(0.5)),
    ("huge", 1e13),
    ("complex", 1j),
]


@pytest.mark.parametrize(("what", "value"), BAD_VALUES, ids=[b[0] for b in BAD_VALUES])
@pytest.mark.parametrize("field", ["p", "v", "a"])
def test_bad_state_value_is_a_planning_error(what: str, value: object, field: str) -> None:
    bad = State(**{field: value})  # type: ignore[arg-type]
    with pytest.raises(PlanningError, match=rf"start\.{field} must be a finite number"):
        plan(bad, State(1.0), LIM)
    with pytest.raises(PlanningError, match=rf"target\.{field} must be a finite number"):
        plan(State(), bad, LIM)
    with pytest.raises(PlanningError, match=rf"start\.{field} must be a finite number"):
        plan_velocity(bad, 0.5, LIM)


@pytest.mark.parametrize(("what", "value"), BAD_VALUES, ids=[b[0] for b in BAD_VALUES])
def test_bad_velocity_target_is_a_planning_error(what: str, value: object) -> None:
    with pytest.raises(PlanningError, match=r"v_target must be a finite number"):
        plan_velocity(State(), value, LIM)  # type: ignore[arg-type]
    with pytest.raises(PlanningError, match=r"a_target must be a finite number"):
        plan_velocity(State(), 0.5, LIM, value)  # type: ignore[arg-type]


@pytest.mark.parametrize("bad", [None, 1.0, "State()", (0.0, 0.0, 0.0)])
def test_wrong_argument_types_are_planning_errors(bad: object) -> None:
    with pytest.raises(PlanningError, match=r"start must be a State"):
        plan(bad, State(1.0), LIM)  # type: ignore[arg-type]
    with pytest.raises(PlanningError, match=r"target must be a State"):
        plan(State(), bad, LIM)  # type: ignore[arg-type]
    with pytest.raises(PlanningError, match=r"limits must be a Limits"):
        plan(State(), State(1.0), bad)  # type: ignore[arg-type]
    with pytest.raises(PlanningError, match=r"start must be a State"):
        plan_velocity(bad, 0.5, LIM)  # type: ignore[arg-type]


def test_ints_and_float_subclasses_are_accepted_like_floats() -> None:
    ref = plan(State(0.0, 0.0, 0.0), State(3.0), LIM)
    assert plan(State(0, 0, 0), State(3), LIM).segments == ref.segments
    assert plan(State(np.float64(0.0)), State(np.float64(3.0)), LIM).segments == ref.segments
    ref_v = plan_velocity(State(), 1.0, LIM)
    assert plan_velocity(State(), 1, LIM).segments == ref_v.segments
    assert plan_velocity(State(), np.float64(1.0), LIM).segments == ref_v.segments


def test_values_stay_immutable() -> None:
    prof = plan(State(), State(2.0, v=0.3), LIM)
    with pytest.raises(AttributeError, match="immutable"):
        prof.duration = 1.0  # type: ignore[misc]
    with pytest.raises(AttributeError, match="immutable"):
        del prof.duration
    with pytest.raises(FrozenInstanceError):
        prof.end.p = 0.0  # type: ignore[misc]
    with pytest.raises(FrozenInstanceError):
        LIM.v_max = 2.0  # type: ignore[misc]
    with pytest.raises(AttributeError):
        prof.segments[0].jerk = 0.0  # type: ignore[misc]


if __name__ == "__main__":
    seed, n_plan, n_sync = (int(x) for x in sys.argv[1:4])
    results: dict[str, Any] = random_results(seed, n_plan, n_sync)
    results["core"] = list(compiled_core())
    json.dump(results, sys.stdout)
