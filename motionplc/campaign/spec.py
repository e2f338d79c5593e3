"""The campaign file: loading, up-front validation and the expansion into scenarios.

A campaign (:class:`Campaign`) is immutable once loaded; :meth:`Campaign.scenario` computes
scenario ``i`` from the grid point ``i // draws`` and the seeded draws of ``(seed, i)``, so a
scenario is the same whatever ran before it, in whichever process.
"""

from __future__ import annotations

import copy
import hashlib
import json
import math
import random
import re
from collections.abc import Iterator, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from motionplc.config import Checker, YamlList, YamlMap, join, load_config, load_yaml
from motionplc.errors import ConfigError, MotionPlcError
from motionplc.schema import campaign as S  # noqa: N812

__all__ = [
    "ENGINE_VERSION",
    "Campaign",
    "Distribution",
    "Fault",
    "Scenario",
    "apply_value",
    "load_campaign",
    "parse_path",
]

ENGINE_VERSION = 2
"""Part of every scenario's key: a result computed by another engine version is rerun."""

MAX_SCENARIOS = 1_000_000
_SEGMENT = re.compile(r"\.([A-Za-z0-9_]+)|\[([0-9]+)\]")
_DIST_KINDS = ("uniform", "loguniform", "normal", "integers", "choice")


# ------------------------------------------------------------------------------ values
@dataclass(frozen=True, slots=True)
class Distribution:
    """A seeded random draw: ``kind`` one of uniform, loguniform, normal, integers, choice."""

    kind: str
    args: tuple[Any, ...]
    clip: tuple[float, float] | None = None

    def draw(self, rng: random.Random) -> Any:
        a = self.args
        if self.kind == "uniform":
            return rng.uniform(a[0], a[1])
        if self.kind == "loguniform":
            return math.exp(rng.uniform(math.log(a[0]), math.log(a[1])))
        if self.kind == "normal":
            x = rng.gauss(a[0], a[1])
            if self.clip is not None:
                x = min(max(x, self.clip[0]), self.clip[1])
            return x
        if self.kind == "integers":
            return rng.randint(a[0], a[1])
        return a[rng.randrange(len(a))]

    def bounds(self) -> tuple[Any, ...]:
        """The values validated up front: the ends of the range, every option."""
        if self.kind == "choice":
            return self.args
        if self.kind == "normal":
            return self.clip if self.clip is not None else (self.args[0],)
        return self.args

    def text(self) -> str:
        return f"{self.kind} {list(self.args)}" + (f" clip {list(self.clip)}" if self.clip else "")


@dataclass(frozen=True, slots=True)
class Fault:
    """One fault of one scenario (every field resolved)."""

    kind: str
    axis: str
    at: float
    duration: float | None = None
    code: int = 0x1000
    persistent: bool = False
    value: float | None = None

    def as_dict(self) -> dict[str, Any]:
        return {
            "fault": self.kind,
            "axis": self.axis,
            "at": self.at,
            "duration": self.duration,
            "code": self.code,
            "persistent": self.persistent,
            "value": self.value,
        }


@dataclass(frozen=True, slots=True)
class _FaultTemplate:
    """A fault as written: fields are values or :class:`Distribution`s."""

    kind: str
    fields: tuple[tuple[str, Any], ...]  # axis, at, duration, code, value (in this order)
    persistent: bool
    probability: float


@dataclass(frozen=True, slots=True)
class Scenario:
    """One simulated run: its number, key (a digest of everything it depends on), the values
    of its varied parameters (path -> value) and its faults."""

    index: int
    key: str
    params: tuple[tuple[str, Any], ...]
    faults: tuple[Fault, ...]

    def param(self, path: str) -> Any:
        return dict(self.params).get(path)

    def sets(self, space: str) -> list[tuple[tuple[str | int, ...], Any]]:
        """The ``(segments, value)`` of the parameters under ``space`` (config, program,
        plant)."""
        out = []
        for path, value in self.params:
            head, segs = parse_path(path)
            if head == space:
                out.append((segs, value))
        return out


def parse_path(path: str) -> tuple[str, tuple[str | int, ...]]:
    """``config.axes.x.limits[0]`` -> ``("config", ("axes", "x", "limits", 0))`` (a segment
    of digits is an index where the value is a list)."""
    head, _, rest = path.partition(".")
    if "[" in head:
        head, _, tail = head.partition("[")
        rest = "[" + tail + ("." + rest if rest else "")
    else:
        rest = "." + rest if rest else ""
    segs: list[str | int] = []
    for m in _SEGMENT.finditer(rest):
        segs.append(m.group(1) if m.group(1) is not None else int(m.group(2)))
    return head, tuple(segs)


def apply_value(data: Any, segs: Sequence[str | int], value: Any) -> str | None:
    """Set the value at ``segs`` of a loaded YAML document; None, or why not (the path does
    not name a value: the last key of a mapping may be new)."""
    node = data
    for i, s in enumerate(segs):
        last = i == len(segs) - 1
        if isinstance(node, list):
            idx = s if isinstance(s, int) else int(s) if str(s).isdigit() else None
            if idx is None or not 0 <= idx < len(node):
                return f"{_seg_text(segs[: i + 1])}: no item {s} (the list has {len(node)})"
            if last:
                node[idx] = value
                return None
            node = node[idx]
        elif isinstance(node, dict):
            key: Any = s
            if isinstance(s, int) or key not in node:
                if isinstance(s, int):
                    return f"{_seg_text(segs[: i + 1])}: not a list"
                if not last:
                    return f"{_seg_text(segs[: i + 1])}: no such key"
            if last:
                node[key] = value
                return None
            node = node[key]
        else:
            return f"{_seg_text(segs[:i])}: not a mapping or a list"
    return "an empty path"


def _seg_text(segs: Sequence[str | int]) -> str:
    out = ""
    for s in segs:
        out = join(out, s)
    return out or "(top level)"


def _file_digest(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def _jsonable(x: Any) -> Any:
    if isinstance(x, float) and not math.isfinite(x):
        return repr(x)
    return x


# ------------------------------------------------------------------------------ campaign
@dataclass(frozen=True)
class Execution:
    scheduler: str | None = None
    workers: int | None = None
    batch: int | None = None
    output: str | None = None
    trace: bool = False


@dataclass(frozen=True)
class Verdict:
    program: str = "required"
    reaction_time: float | None = None
    max_following_error: float | None = None


@dataclass(frozen=True)
class Campaign:
    """A loaded, validated campaign (see :func:`load_campaign`)."""

    path: str
    name: str
    config_path: str
    program_path: str | None
    group: str | None
    seed: int
    draws: int
    seconds: float | None
    timeout: float
    grid: tuple[tuple[str, tuple[Any, ...]], ...]
    random: tuple[tuple[str, Distribution], ...]
    faults: tuple[_FaultTemplate, ...]
    verdict: Verdict
    execution: Execution
    digest: str = ""  # config and program files, seed, engine version, verdict, limits
    axes: tuple[str, ...] = ()
    warnings: tuple[str, ...] = field(default=())

    @property
    def grid_points(self) -> int:
        n = 1
        for _, values in self.grid:
            n *= len(values)
        return n

    def __len__(self) -> int:
        return self.grid_points * self.draws

    @property
    def parameters(self) -> list[str]:
        """Every varied path (grid, random, fault fields), in the order of the table."""
        out = [p for p, _ in self.grid] + [p for p, _ in self.random]
        for i, f in enumerate(self.faults):
            if f.probability < 1.0:
                out.append(f"faults[{i}].injected")
            for name, v in f.fields:
                p = f"faults[{i}].{name}"
                if isinstance(v, Distribution) and p not in out:
                    out.append(p)
        return out

    def scenario(self, index: int) -> Scenario:
        if not 0 <= index < len(self):
            raise IndexError(f"scenario {index}: the campaign has {len(self)} (0..{len(self) - 1})")
        point, _draw = divmod(index, self.draws)
        params: dict[str, Any] = {}
        # the grid point: the last path fastest
        rest = point
        sizes = [len(v) for _, v in self.grid]
        picks = [0] * len(sizes)
        for j in range(len(sizes) - 1, -1, -1):
            rest, picks[j] = divmod(rest, sizes[j])
        for (path, values), k in zip(self.grid, picks, strict=True):
            params[path] = values[k]
        rng = random.Random(f"motionplc-campaign:{self.seed}:{index}")
        for path, dist in self.random:
            params[path] = dist.draw(rng)
        faults: list[Fault] = []
        for i, tpl in enumerate(self.faults):
            # always the same draws, injected or not (the other values do not shift)
            injected = rng.random() < tpl.probability
            values: dict[str, Any] = {}
            for name, v in tpl.fields:
                p = f"faults[{i}].{name}"
                if p in params:  # a grid value
                    values[name] = params[p]
                elif isinstance(v, Distribution):
                    values[name] = params[p] = v.draw(rng)
                else:
                    values[name] = v
            if tpl.probability < 1.0:
                params[f"faults[{i}].injected"] = injected
            if not injected:  # drawn all the same (the others do not shift), not used
                for name, v in tpl.fields:
                    p = f"faults[{i}].{name}"
                    if isinstance(v, Distribution):
                        params[p] = None
            if injected:
                faults.append(
                    Fault(
                        tpl.kind,
                        str(values["axis"]),
                        float(values["at"]),
                        None if values.get("duration") is None else float(values["duration"]),
                        int(values.get("code") or 0x1000),
                        tpl.persistent,
                        None if values.get("value") is None else float(values["value"]),
                    )
                )
        ordered = tuple((p, params[p]) for p in self.parameters if p in params)
        key_src = json.dumps(
            [self.digest, index, [(p, _jsonable(v)) for p, v in ordered]], sort_keys=True
        )
        key = hashlib.sha256(key_src.encode()).hexdigest()[:32]
        return Scenario(index, key, ordered, tuple(faults))

    def scenarios(self, indices: Sequence[int] | None = None) -> Iterator[Scenario]:
        for i in range(len(self)) if indices is None else indices:
            yield self.scenario(i)

    def rerun_command(self, index: int) -> str:
        return f"motionplc campaign {self.path} --only {index}"


# ------------------------------------------------------------------------------ loading
def _dist(c: Checker, m: Any, line: int, path: str) -> Distribution | None:
    dm = c.mapping(m, line, path, S.DISTRIBUTION.table(), "a distribution (a mapping)")
    if dm is None:
        return None
    kinds = [k for k in _DIST_KINDS if k in dm]
    if len(kinds) != 1:
        c.error(
            dm.line,
            path,
            "no distribution" if not kinds else f"{' and '.join(kinds)} together",
            "exactly one of " + ", ".join(_DIST_KINDS),
        )
        return None
    kind = kinds[0]
    args = dm[kind]
    kp = join(path, kind)
    if not isinstance(args, list) or not args:
        c.error(dm.line_of(kind), kp, "not a list", "a list (see the reference)")
        return None
    if kind == "choice":
        if any(isinstance(a, (dict, list)) for a in args):
            c.error(dm.line_of(kind), kp, "a mapping or list among the options", "scalars")
            return None
        if "clip" in dm:
            c.error(dm.key_lines["clip"], join(path, "clip"), "only with normal")
        return Distribution("choice", tuple(args))
    ints = kind == "integers"
    ok = len(args) == 2 and all(
        isinstance(a, int if ints else (int, float))
        and not isinstance(a, bool)
        and (ints or math.isfinite(a))
        for a in args
    )
    if not ok:
        what = (
            "[lo, hi] integers"
            if ints
            else "[mean, sd] numbers"
            if kind == "normal"
            else ("[lo, hi] finite numbers")
        )
        c.error(dm.line_of(kind), kp, f"got {args!r}", what)
        return None
    a0, a1 = args
    if kind == "normal":
        if a1 < 0:
            c.error(dm.line_of(kind), kp, f"standard deviation {a1:g}", ">= 0")
            return None
    elif a0 > a1:
        c.error(dm.line_of(kind), kp, f"lo {a0} > hi {a1}", "lo <= hi")
        return None
    if kind == "loguniform" and not a0 > 0:
        c.error(dm.line_of(kind), kp, f"lo {a0:g}", "> 0")
        return None
    clip = None
    if "clip" in dm:
        cp = join(path, "clip")
        cv = dm["clip"]
        if kind != "normal":
            c.error(dm.key_lines["clip"], cp, "only with normal")
            return None
        if (
            not isinstance(cv, list)
            or len(cv) != 2
            or not all(isinstance(x, (int, float)) and not isinstance(x, bool) for x in cv)
            or not cv[0] <= cv[1]
        ):
            c.error(dm.line_of("clip"), cp, f"got {cv!r}", "[lo, hi] numbers, lo <= hi")
            return None
        clip = (float(cv[0]), float(cv[1]))
    if ints:
        return Distribution(kind, (int(a0), int(a1)))
    return Distribution(kind, (float(a0), float(a1)), clip)


class _Targets:
    """The loaded configuration and program a campaign's values are checked against."""

    def __init__(self, c: Checker, base: Path, top: YamlMap) -> None:
        from motionplc.gcode_runner import is_gcode

        self.c = c
        self.config_path = (base / top["config"]).resolve()
        self.config_data = load_yaml(self.config_path)
        self.config = load_config(self.config_path)
        self.program_path: Path | None = None
        self.program_kind = ""
        self.program_data: Any = None
        self.module: Any = None
        if top.get("program") is not None:
            self.program_path = (base / top["program"]).resolve()
            p = self.program_path
            if is_gcode(str(p)):
                from motionplc.gcode_runner import load_gcode_job

                self.program_kind = "gcode"
                load_gcode_job(str(p), self.config, top.get("group"))
            elif p.suffix == ".py":
                from motionplc.program import load_program

                self.program_kind = "python"
                self.module = load_program(p).module
            elif p.suffix.lower() in (".yaml", ".yml"):
                from motionplc.sequence import parse_sequence

                self.program_kind = "sequence"
                self.program_data = load_yaml(p)
                parse_sequence(self.program_data, p, self.config)
            else:
                raise ConfigError(
                    f"{c.file}:{top.line_of('program')}: program: unknown program type "
                    f"{p.suffix or '(none)'!r} (allowed: .yaml sequence, .py program, G-code)"
                )
        self.checked: dict[tuple[str, str], str | None] = {}

    def refusal(self, path: str, value: Any) -> str | None:
        """Why ``value`` at ``path`` is refused (the validator's first lines), or None."""
        memo = (path, json.dumps(_jsonable(value)))
        if memo in self.checked:
            return self.checked[memo]
        why = self._refusal(path, value)
        self.checked[memo] = why
        return why

    def _refusal(self, path: str, value: Any) -> str | None:
        from motionplc.config import parse_config

        head, segs = parse_path(path)
        if not segs:
            return "names no value"
        if head == "config":
            data = copy.deepcopy(self.config_data)
            why = apply_value(data, segs, value)
            if why is not None:
                return f"{self.config_path.name}: {why}"
            try:
                parse_config(data, self.config_path)
            except ConfigError as exc:
                return _first_errors(exc)
            return None
        if head == "program":
            if self.program_path is None:
                return "the campaign has no program"
            if self.program_kind == "gcode":
                return "a G-code program has no values to vary (vary the configuration)"
            if self.program_kind == "python":
                if len(segs) != 1 or not isinstance(segs[0], str):
                    return "a Python program's value is a module constant: program.NAME"
                old = getattr(self.module, segs[0], _MISSING)
                if old is _MISSING:
                    return f"{self.program_path.name}: no module constant {segs[0]!r}"
                if not _same_kind(old, value):
                    return f"{type(value).__name__} for the constant {segs[0]} = {old!r}"
                return None
            from motionplc.sequence import parse_sequence

            data = copy.deepcopy(self.program_data)
            why = apply_value(data, segs, value)
            if why is not None:
                return f"{self.program_path.name}: {why}"
            try:
                parse_sequence(data, self.program_path, self.config)
            except ConfigError as exc:
                return _first_errors(exc)
            return None
        if head == "plant":
            return plant_refusal(self.config, segs, value)
        return None


_MISSING = object()


def _same_kind(old: Any, new: Any) -> bool:
    if isinstance(old, bool) or isinstance(new, bool):
        return isinstance(old, bool) and isinstance(new, bool)
    if isinstance(old, (int, float)):
        return isinstance(new, (int, float))
    return type(old) is type(new)


def _first_errors(exc: ConfigError) -> str:
    errs = list(exc.errors)
    text = "; ".join(errs[:2])
    if len(errs) > 2:
        text += f"; and {len(errs) - 2} more"
    return text


def plant_refusal(config: Any, segs: Sequence[str | int], value: Any) -> str | None:
    """Why ``plant.<axis>.<name> = value`` cannot be applied, or None."""
    from dataclasses import replace

    from motionplc.fieldbus.plant import PlantParams

    if len(segs) != 2 or not all(isinstance(s, str) for s in segs):
        return "plant.<axis>.<parameter>"
    axis, name = segs
    names = [a.name for a in config.axes]
    if axis not in names:
        return f"no axis {axis!r} (axes: {', '.join(names)})"
    if name not in S.PLANT_PARAMS:
        return f"no plant parameter {name!r} (allowed: {', '.join(S.PLANT_PARAMS)})"
    if not _simulated_drive(config, str(axis)):
        return f"axis {axis!r} is not on a simulated CiA 402 drive (a bus with drives: simulated)"
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        return f"got {value!r} (allowed: a finite number)"
    try:
        replace(PlantParams(), **{str(name): float(value)})
    except ValueError as exc:
        return str(exc).replace("PlantParams.", "")
    return None


def _simulated_drive(config: Any, axis: str) -> str | None:
    """``"canopen"``/``"modbus"`` when ``axis`` is on a simulated drive of a bus, else None."""
    ax = config.axis(axis)
    d = ax.drive
    if d.kind == "ideal" or d.bus is None:
        return None
    if config.bus(d.bus).drives != "simulated":
        return None
    return "canopen" if d.kind == "canopen" else "modbus"


def load_campaign(path: str | Path) -> Campaign:
    """Load and validate a campaign file: every problem at once as a located
    :class:`~motionplc.errors.ConfigError` (``FILE:LINE: key: problem (allowed: ...)``); the
    machine configuration and the program are loaded and every grid value and distribution
    bound is checked by their own validators."""
    p = Path(path)
    data = load_yaml(p)
    c = Checker(p)
    top = c.mapping(data, getattr(data, "line", 1), "(top level)", S.TOP.table())
    if top is None:
        c.raise_if_any()
        raise AssertionError("unreachable")
    T = S.TOP  # noqa: N806
    name = c.field(top, "name", "", T["name"]) or p.stem
    if not re.match(r"^[A-Za-z0-9_.-]+$", name):
        c.error(top.line_of("name"), "name", f"got {name!r}", "letters, digits, _ . -")
    cfg_file = c.field(top, "config", "", T["config"])
    prog_file = c.field(top, "program", "", T["program"])
    group = c.field(top, "group", "", T["group"])
    seed = c.field(top, "seed", "", T["seed"])
    draws = c.field(top, "draws", "", T["draws"])
    seconds = c.field(top, "seconds", "", T["seconds"])
    timeout = c.field(top, "timeout", "", T["timeout"])
    base = p.resolve().parent
    for key, f in (("config", cfg_file), ("program", prog_file)):
        if f is not None and not (base / f).is_file():
            c.error(top.line_of(key), key, f"no such file: {base / f}", "a file relative to this")
    c.raise_if_any()
    try:
        targets = _Targets(c, base, top)
    except MotionPlcError as exc:  # the configuration's or the program's own located errors
        lines = list(getattr(exc, "errors", None) or [str(exc)])
        where = f"{p}:{top.line_of('config')}"
        raise ConfigError(
            [f"{where}: the configuration or the program is refused:", *lines]
        ) from None

    grid: list[tuple[str, tuple[Any, ...]]] = []
    if top.get("grid") is not None:
        gm = c.mapping(top["grid"], top.line_of("grid"), "grid", None)
        for gpath, values in (gm or {}).items():
            gp = join("grid", gpath)
            if not _path_ok(c, gm, gpath, gp):
                continue
            if not isinstance(values, list) or not values:
                c.error(gm.line_of(gpath), gp, f"got {_kind(values)}", "a non-empty list of values")
                continue
            for i, v in enumerate(values):
                if isinstance(v, (dict, list)) or v is None:
                    c.error(values.line_of(i), join(gp, i), f"got {_kind(v)}", "a scalar")
                    continue
                _check_value(c, targets, gpath, v, values.line_of(i), join(gp, i))
            grid.append((gpath, tuple(values)))
    rand: list[tuple[str, Distribution]] = []
    if top.get("random") is not None:
        rm = c.mapping(top["random"], top.line_of("random"), "random", None)
        for rpath, body in (rm or {}).items():
            rp = join("random", rpath)
            if not _path_ok(c, rm, rpath, rp):
                continue
            if any(rpath == g for g, _ in grid):
                c.error(rm.key_lines[rpath], rp, "also in grid", "a path in grid or random")
                continue
            d = _dist(c, body, rm.line_of(rpath), rp)
            if d is None:
                continue
            for v in d.bounds():
                _check_value(c, targets, rpath, v, rm.line_of(rpath), rp)
            rand.append((rpath, d))
    faults = _parse_faults(c, top, targets, {g for g, _ in grid})
    for gpath, values in grid:  # grid values of fault fields
        head, segs = parse_path(gpath)
        if head == "faults":
            line = top["grid"].key_lines[gpath]
            _check_fault_path(c, targets, faults, segs, line, join("grid", gpath), values)
    for rpath, _d in rand:
        head, segs = parse_path(rpath)
        if head == "faults":
            line = top["random"].key_lines[rpath]
            c.error(
                line,
                join("random", rpath),
                "a fault field's distribution goes in the fault",
                f"faults[{segs[0] if segs else 0}]: {{...: {{uniform: [...]}}}}",
            )
    verdict = _parse_verdict(c, top)
    execution = _parse_execution(c, top)
    n = 1
    for _, v in grid:
        n *= len(v)
    if draws is not None and n * draws > MAX_SCENARIOS:
        c.error(
            top.line_of("draws"),
            "draws",
            f"{n} grid points x {draws} draws = {n * draws}",
            f"at most {MAX_SCENARIOS:,} scenarios",
        )
    c.raise_if_any()
    digest_src = json.dumps(
        {
            "engine": ENGINE_VERSION,
            "config": _file_digest(targets.config_path),
            "program": None if targets.program_path is None else _file_digest(targets.program_path),
            "group": group,
            "seed": seed,
            "seconds": seconds,
            "verdict": [verdict.program, verdict.reaction_time, verdict.max_following_error],
            "faults": [(f.kind, f.persistent, f.probability) for f in faults],
        },
        sort_keys=True,
    )
    return Campaign(
        path=str(p),
        name=name,
        config_path=str(targets.config_path),
        program_path=None if targets.program_path is None else str(targets.program_path),
        group=group,
        seed=int(seed or 0),
        draws=int(draws or 1),
        seconds=seconds,
        timeout=float(timeout),
        grid=tuple(grid),
        random=tuple(rand),
        faults=tuple(faults),
        verdict=verdict,
        execution=execution,
        digest=hashlib.sha256(digest_src.encode()).hexdigest(),
        axes=tuple(a.name for a in targets.config.axes),
        warnings=tuple(targets.config.warnings),
    )


def _kind(x: Any) -> str:
    from motionplc.config import _tname

    return _tname(x)


def _path_ok(c: Checker, m: YamlMap, path: Any, where: str) -> bool:
    if not isinstance(path, str) or not re.match(S.PATH_PATTERN, path):
        c.error(
            m.key_lines.get(path, m.line),
            where,
            "not a parameter path",
            "config.<key path>, program.<key path>, plant.<axis>.<parameter>, faults[i].<field>",
        )
        return False
    return True


def _check_value(c: Checker, t: _Targets, path: str, value: Any, line: int, where: str) -> None:
    head, _ = parse_path(path)
    if head == "faults":
        return  # checked with the faults
    why = t.refusal(path, value)
    if why is not None:
        c.error(line, where, f"{value!r} is refused: {why}")


_FAULT_FIELDS = ("axis", "at", "duration", "code", "value")
_FAULT_NUMBER = {
    "at": S.FAULT["at"].variants[0],  # type: ignore[attr-defined]
    "duration": S.FAULT["duration"].variants[0],  # type: ignore[attr-defined]
    "value": S.FAULT["value"].variants[0],  # type: ignore[attr-defined]
}


def _fault_value_refusal(config: Any, kind: str, name: str, v: Any) -> str | None:
    if name == "axis":
        names = [a.name for a in config.axes]
        if v not in names:
            return f"no axis {v!r} (axes: {', '.join(names)})"
        sim = _simulated_drive(config, str(v))
        if sim is None:
            return f"axis {v!r} is not on a simulated drive (a bus with drives: simulated)"
        if sim == "modbus" and kind not in ("drive", "load_step"):
            return f"a {kind} fault needs a CAN bus; axis {v!r} is on Modbus (allowed: drive)"
        return None
    if name == "code":
        if isinstance(v, bool) or not isinstance(v, int) or not 1 <= v <= 0xFFFF:
            return f"got {v!r} (allowed: an integer in 1..0xFFFF)"
        return None
    node = _FAULT_NUMBER[name]
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not node.accepts(float(v)):
        return f"got {v!r} (allowed: a number {node.range_text()})"
    return None


def _parse_faults(
    c: Checker, top: YamlMap, t: _Targets, grid_paths: set[str]
) -> list[_FaultTemplate]:
    out: list[_FaultTemplate] = []
    if top.get("faults") is None:
        return out
    fl = top["faults"]
    if not isinstance(fl, YamlList):
        c.error(top.line_of("faults"), "faults", f"got {_kind(fl)}", "a list of faults")
        return out
    for i, body in enumerate(fl):
        fp = join("faults", i)
        fm = c.mapping(body, fl.line_of(i), fp, S.FAULT.table())
        if fm is None:
            continue
        kind = c.field(fm, "fault", fp, S.FAULT["fault"])
        prob = c.field(fm, "probability", fp, S.FAULT["probability"])
        persistent = c.field(fm, "persistent", fp, S.FAULT["persistent"])
        if kind is None:
            continue
        if "code" in fm and kind != "drive":
            c.error(fm.key_lines["code"], join(fp, "code"), f"not used by a {kind} fault")
        if "persistent" in fm and kind != "drive":
            c.error(fm.key_lines["persistent"], join(fp, "persistent"), f"not used by {kind}")
        if kind == "load_step" and "value" not in fm:
            c.error(fm.line, join(fp, "value"), "missing", "required by a load_step")
        if "value" in fm and kind != "load_step":
            c.error(fm.key_lines["value"], join(fp, "value"), f"not used by a {kind} fault")
        if "duration" in fm and kind in ("drive", "load_step"):
            c.error(fm.key_lines["duration"], join(fp, "duration"), f"not used by {kind}")
        fields: list[tuple[str, Any]] = []
        for name in _FAULT_FIELDS:
            if name not in fm:
                continue
            v = fm[name]
            vp = join(fp, name)
            line = fm.line_of(name)
            if isinstance(v, dict):
                d = _dist(c, v, line, vp)
                if d is None:
                    continue
                if f"faults[{i}].{name}" in grid_paths:
                    c.error(line, vp, "a distribution and a grid axis", "one of them")
                for b in d.bounds():
                    why = _fault_value_refusal(t.config, kind, name, b)
                    if why is not None:
                        c.error(line, vp, f"{d.text()}: {b!r}: {why}")
                fields.append((name, d))
            else:
                why = _fault_value_refusal(t.config, kind, name, v)
                if why is not None:
                    c.error(line, vp, why)
                fields.append((name, v))
        out.append(_FaultTemplate(kind, tuple(fields), bool(persistent), float(prob)))
    return out


def _check_fault_path(
    c: Checker,
    t: _Targets,
    faults: list[_FaultTemplate],
    segs: tuple[str | int, ...],
    line: int,
    where: str,
    values: Sequence[Any],
) -> None:
    if len(segs) != 2 or not isinstance(segs[0], int) or segs[1] not in _FAULT_FIELDS:
        c.error(line, where, "not a fault field", "faults[i]." + "|".join(_FAULT_FIELDS))
        return
    i, name = segs
    if not 0 <= i < len(faults):
        c.error(line, where, f"no fault {i} (the campaign has {len(faults)})")
        return
    tpl = faults[i]
    if name not in dict(tpl.fields):
        c.error(line, where, f"faults[{i}] has no {name} (give it a value there)")
        return
    for v in values:
        why = _fault_value_refusal(t.config, tpl.kind, str(name), v)
        if why is not None:
            c.error(line, where, f"{v!r}: {why}")


def _parse_verdict(c: Checker, top: YamlMap) -> Verdict:
    if top.get("verdict") is None:
        return Verdict()
    vm = c.mapping(top["verdict"], top.line_of("verdict"), "verdict", S.VERDICT.table())
    if vm is None:
        return Verdict()
    V = S.VERDICT  # noqa: N806
    return Verdict(
        c.field(vm, "program", "verdict", V["program"]),
        c.field(vm, "reaction_time", "verdict", V["reaction_time"]),
        c.field(vm, "max_following_error", "verdict", V["max_following_error"]),
    )


def _parse_execution(c: Checker, top: YamlMap) -> Execution:
    if top.get("execution") is None:
        return Execution()
    em = c.mapping(top["execution"], top.line_of("execution"), "execution", S.EXECUTION.table())
    if em is None:
        return Execution()
    E = S.EXECUTION  # noqa: N806
    sched = em.get("scheduler")
    if sched is not None and not (
        isinstance(sched, str) and re.match(E["scheduler"].pattern or "", sched)  # type: ignore[attr-defined]
    ):
        c.error(
            em.line_of("scheduler"),
            "execution.scheduler",
            f"got {_kind(sched)}",
            "tcp://127.0.0.1:PORT (a scheduler on this machine's loopback)",
        )
        sched = None
    return Execution(
        sched,
        c.field(em, "workers", "execution", E["workers"]),
        c.field(em, "batch", "execution", E["batch"]),
        c.field(em, "output", "execution", E["output"]),
        bool(c.field(em, "trace", "execution", E["trace"])),
    )
