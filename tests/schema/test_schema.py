"""The schema against the validators, with jsonschema as the independent validator.

* every shipped file is accepted by the JSON Schema of its kind;
* a corpus of malformed files generated from the schema (unknown key, wrong type, below and
  above the range, a required key missing, a bad enum value; for every key of the shipped
  files, and every scalar key their mappings could have) is rejected by the validator (naming
  the key path) and by the JSON Schema;
* the validators' own error cases (tests/config/cases.py) that are structural are rejected by
  the JSON Schema too; the cross-field ones are listed;
* documented bounds: accepted by the validator at the bound, refused just beyond;
* documented defaults are what the loader gives when the key is absent;
* docs/ is what tools/gen_docs.py produces now.
"""

from __future__ import annotations

import math
import random
import sys
from pathlib import Path
from typing import Any

import jsonschema
import pytest

from motionplc import schema
from motionplc.config import load_config, load_yaml
from motionplc.errors import ConfigError
from motionplc.schema import config as S  # noqa: N812
from motionplc.schema.nodes import (
    Bool,
    Choice,
    Integer,
    ListOf,
    MapOf,
    Number,
    Obj,
    OneOf,
    Ref,
    String,
)
from tests.config.cases import CONFIG_CASES, SEQUENCE_CASES
from tests.schema.walk import (
    ROOT,
    get,
    names,
    plain,
    shipped,
    sites,
    validate,
    with_value,
    without,
)

SHIPPED = shipped()


def _validator(kind: str) -> jsonschema.Draft202012Validator:
    s = schema.json_schema(kind)
    jsonschema.Draft202012Validator.check_schema(s)
    return jsonschema.Draft202012Validator(s)


VALIDATORS = {k: _validator(k) for k in schema.KINDS}


def json_ok(kind: str, data: Any) -> bool:
    return VALIDATORS[kind].is_valid(plain(data))


@pytest.mark.parametrize(("kind", "path"), SHIPPED, ids=[p.name for _, p in SHIPPED])
def test_shipped_files_are_accepted_by_their_json_schema(kind: str, path: Path) -> None:
    errors = [
        f"{e.json_path}: {e.message}" for e in VALIDATORS[kind].iter_errors(plain(load_yaml(path)))
    ]
    assert errors == []


def test_shipped_configs_are_accepted_by_the_validator() -> None:
    for kind, path in SHIPPED:
        if kind == "config":
            load_config(path)


# ------------------------------------------------------------------------ mutation corpus
def _beyond(node: Number | Integer) -> list[tuple[str, Any]]:
    """(name, value) just outside each bound."""
    out: list[tuple[str, Any]] = []
    if isinstance(node, Integer):
        if node.lo is not None:
            out.append(("below", node.lo - 1))
        if node.hi is not None:
            out.append(("above", node.hi + 1))
        return out
    if node.gt is not None:
        out.append(("below", node.gt))
    if node.ge is not None:
        out.append(("below", node.ge - max(abs(node.ge) * 1e-3, 1e-9)))
    if node.le is not None:
        out.append(("above", node.le + max(abs(node.le) * 1e-3, 1e-9)))
    return out


def _wrong_type(node: Any) -> Any:
    if isinstance(node, (Number, Integer, Bool)):
        return "not_a_value"
    if isinstance(node, String):
        return 12345
    return 7  # an object, a list, a mapping of names, a choice


def mutations() -> list[tuple[str, str, Path, tuple, str, tuple]]:
    """(id, kind, source, the change: (where, key, value or DELETE), key path the validator
    must name, what it mutates: (kind, key, how))."""
    out: list[tuple[str, str, Path, tuple, str, tuple]] = []
    for kind, src in SHIPPED:
        fs = schema.file_schema(kind)
        data = load_yaml(src)
        for site in sites(fs, data):
            node = fs.resolve(site.key.node)
            tag = f"{src.name}:{site.path}"
            parent = site.path.rpartition(".")[0] if "." in site.path else ""
            found: list[tuple[str, tuple, str]] = []
            if site.present:
                if site.key.required:
                    found.append(
                        ("missing", (site.where, site.key.name, DELETE), parent or site.path)
                    )
                if "no_such_key" not in get(data, site.where):
                    ukp = f"{parent}.no_such_key" if parent else "no_such_key"
                    found.append(("unknown-beside", (site.where, "no_such_key", 1), ukp))
            scalar = isinstance(node, (Number, Integer, Choice, String, Bool))
            if scalar or (isinstance(node, (Obj, MapOf, ListOf)) and site.present):
                bad = _wrong_type(node)
                if isinstance(node, Choice) and any(isinstance(o, int) for o in node.options):
                    bad = "no_such_value"
                found.append(("wrong-type", (site.where, site.key.name, bad), site.path))
            if isinstance(node, Choice) and all(isinstance(o, str) for o in node.options):
                found.append(("bad-enum", (site.where, site.key.name, "no_such_value"), site.path))
            if isinstance(node, (Number, Integer)):
                for how, v in _beyond(node):
                    found.append((how, (site.where, site.key.name, v), site.path))
            for how, change, path in found:
                out.append((f"{tag}:{how}", kind, src, change, path, (kind, site.key.name, how)))
    return out


DELETE = object()
DOCS = {src: load_yaml(src) for _, src in SHIPPED}


def apply(src: Path, change: tuple) -> Any:
    where, key, value = change
    if value is DELETE:
        return without(DOCS[src], where, key)
    return with_value(DOCS[src], where, key, value)


CORPUS = mutations()
# every (kind, key, kind of mutation) at least once; 40 more sampled (seeded) to stay fast
_seen: dict[tuple, int] = {}
for _i, _m in enumerate(CORPUS):
    _seen.setdefault(_m[5], _i)
_rng = random.Random(14)
SAMPLE = sorted(set(_seen.values()) | set(_rng.sample(range(len(CORPUS)), min(len(CORPUS), 40))))


def test_corpus_covers_every_key_kind() -> None:
    kinds = {m[5][2] for m in CORPUS}
    assert {"missing", "unknown-beside", "wrong-type", "bad-enum", "below", "above"} <= kinds
    assert len(CORPUS) > 300


@pytest.mark.parametrize("i", SAMPLE, ids=[CORPUS[i][0] for i in SAMPLE])
def test_malformed_file_is_rejected_by_both(tmp_path: Path, i: int) -> None:
    _, kind, src, change, path, _ = CORPUS[i]
    data = apply(src, change)
    errors = validate(kind, src, data, tmp_path)
    assert errors, "the validator accepted it"
    assert names(errors, path), errors
    assert not json_ok(kind, data), "the JSON Schema accepted it"


# ------------------------------------------------------------------------ validator cases
# the validators' own error cases that the JSON Schema cannot see: rules across keys
CROSS_FIELD = {
    "period not a multiple of the tick",
    "unknown task of an axis",
    "software limits reversed",
    "modulo with software limits",
    "homing switch without position",
    "axis bound to an undefined bus",
    "duplicate node ids",
    "simulated Modbus drives on a non-loopback host",
    "register map on a simulated Modbus bus",
    "group with an unknown axis",
    "duplicate key",  # YAML: the second value wins in a parsed document
    "YAML syntax error",  # no document: the loader refuses it
    "unit_id on a CAN bus",  # a valid Modbus drive, but the bus named is a CAN bus
    # sequences: names of the configuration and of the sequence's own blocks
    "unknown axis",
    "done on an undeclared block",
    "axis state not allowed",
    "expectation on an unknown field",
    "step with call and wait",
    "sync move on an unknown group",
    "block re-bound to another axis",
    "unknown task",
}


@pytest.mark.parametrize(
    ("kind", "name", "text"),
    [("config", n, t) for n, t, _ in CONFIG_CASES]
    + [("sequence", n, t) for n, t, _ in SEQUENCE_CASES],
    ids=[n for n, _, _ in CONFIG_CASES] + ["seq: " + n for n, _, _ in SEQUENCE_CASES],
)
def test_structural_validator_cases_are_rejected_by_the_json_schema(
    tmp_path: Path, kind: str, name: str, text: str
) -> None:
    f = tmp_path / "f.yaml"
    f.write_text(text)
    if name == "YAML syntax error":
        with pytest.raises(ConfigError, match="YAML syntax error"):
            load_yaml(f)
        return
    # a rule across keys is the validator's only: the JSON Schema accepts such a file (the list
    # stays exact: a case the schema starts to refuse fails here and leaves CROSS_FIELD)
    assert json_ok(kind, load_yaml(f)) == (name in CROSS_FIELD)


def test_cross_field_cases_exist() -> None:
    all_names = {n for n, _, _ in CONFIG_CASES} | {n for n, _, _ in SEQUENCE_CASES}
    assert CROSS_FIELD <= all_names


# ------------------------------------------------------------------------ bounds
def _bound_sites() -> list[tuple[str, str, Path, Any, str, Any, Any]]:
    out = []
    for kind, src in SHIPPED:
        fs = schema.file_schema(kind)
        data = load_yaml(src)
        for site in sites(fs, data):
            node = fs.resolve(site.key.node)
            if not isinstance(node, (Number, Integer)):
                continue
            beyond = dict(_beyond(node))
            at = {
                "below": node.lo
                if isinstance(node, Integer)
                else (node.ge if node.ge is not None else None),
                "above": node.hi if isinstance(node, Integer) else node.le,
            }
            for side, inside in at.items():
                if inside is None or side not in beyond:
                    continue
                out.append(
                    (f"{src.name}:{site.path}:{side}", kind, src, data, site, inside, beyond[side])
                )
    return out


BOUNDS = _bound_sites()
# bounds that depend on another key (the validator's rule, listed in the reference): a
# register address is in register_base..register_base + 65535
CONTEXT_BOUNDS = {"address"}
_bseen: dict[tuple, int] = {}
for _i, _b in enumerate(BOUNDS):
    if _b[4].key.name not in CONTEXT_BOUNDS:
        _bseen.setdefault((_b[1], _b[4].key.name, _b[0].rsplit(":", 1)[1]), _i)
BOUND_SAMPLE = sorted(_bseen.values())


@pytest.mark.parametrize("i", BOUND_SAMPLE, ids=[BOUNDS[i][0] for i in BOUND_SAMPLE])
def test_documented_bound_accepted_and_just_beyond_refused(tmp_path: Path, i: int) -> None:
    _, kind, src, data, site, inside, outside = BOUNDS[i]
    errors = validate(kind, src, with_value(data, site.where, site.key.name, inside), tmp_path)
    range_errors = [e for e in errors if f" {site.path}: got " in e]
    assert range_errors == [], f"{site.path} = {inside} (the documented bound) refused"
    errors = validate(kind, src, with_value(data, site.where, site.key.name, outside), tmp_path)
    assert any(f" {site.path}: got " in e for e in errors), f"{site.path} = {outside} accepted"


# ------------------------------------------------------------------------ defaults
MINIMAL = """\
runtime:
  tasks:
    motion: {watchdog: {time: 0.01}}
  realtime: {}
buses:
  can0: {type: can}
  mb0: {type: modbus}
axes:
  x:
    limits: {v_max: 1.0, a_max: 2.0}
    homing: {}
    drive: {bus: can0, node_id: 1}
  y:
    limits: {v_max: 1.0, a_max: 2.0}
    drive: {bus: mb0, unit_id: 1}
groups:
  g: {axes: [x, y]}
"""


def _default_getters() -> dict[tuple[int, str], Any]:
    """(id of the object node, key) -> how to read the loaded value of MINIMAL."""
    return {
        **{
            (id(S.RUNTIME), k): (lambda c, k=k: getattr(c.runtime, k))
            for k in (
                "tick",
                "clock",
                "overrun",
                "trace_capacity",
                "trace_bytes",
                "blend_replans_per_cycle",
            )
        },
        (id(S.TASK), "priority"): lambda c: c.runtime.tasks[0].priority,
        (id(S.WATCHDOG), "sensitivity"): lambda c: c.runtime.tasks[0].watchdog_sensitivity,
        (id(S.REALTIME), "cpus"): lambda c: c.runtime.rt_cpus,
        (id(S.REALTIME), "lock_memory"): lambda c: c.runtime.rt_lock_memory,
        **{
            (id(S.CAN_BUS), k): (lambda c, k=k: getattr(c.bus("can0"), k))
            for k in (
                "drives",
                "interface",
                "bitrate",
                "max_frames_per_cycle",
                "master_node_id",
                "sync_cob_id",
                "sdo_timeout",
            )
        },
        **{
            (id(S.MODBUS_BUS), k): (lambda c, k=k: getattr(c.bus("mb0"), k))
            for k in ("drives", "host", "port", "timeout")
        },
        (id(S.AXIS), "units"): lambda c: c.axis("x").units,
        (id(S.AXIS), "queue_depth"): lambda c: c.axis("x").queue_depth,
        (id(S.LIMITS), "j_max"): lambda c: c.axis("x").limits.j_max,
        (id(S.HOMING), "method"): lambda c: c.axis("x").homing.method,
        (id(S.CANOPEN_DRIVE), "counts_per_unit"): lambda c: c.axis("x").drive.counts_per_unit,
        (id(S.MODBUS_DRIVE), "counts_per_unit"): lambda c: c.axis("y").drive.counts_per_unit,
        **{
            (id(S.GROUP), k): (lambda c, k=k: getattr(c.group("g"), k))
            for k in ("queue_depth", "tolerance", "v_share", "blend_share")
        },
    }


# defaults that apply inside drive options the minimal file does not have (checked in
# tests/fieldbus), or that the backend (not the loader) applies
NOT_LOADER_DEFAULTS = {
    "type",
    "life_time_factor",
    "transmission",
    "sub",
    "optional",
    "register_map",
    "velocity_feed_forward",
    "requests_in_flight",
}


def test_documented_defaults_are_the_loaders(tmp_path: Path) -> None:
    f = tmp_path / "m.yaml"
    f.write_text(MINIMAL)
    cfg = load_config(f)
    getters = _default_getters()
    checked = 0

    def objs(node: Any, seen: set[int]) -> list[Obj]:
        if isinstance(node, Ref):  # the inline register map: test_register_map_defaults
            return []
        if id(node) in seen:
            return []
        seen.add(id(node))
        out = [node] if isinstance(node, Obj) else []
        kids = []
        if isinstance(node, Obj):
            kids = [k.node for k in node.keys]
        elif isinstance(node, (MapOf,)):
            kids = [node.value]
        elif isinstance(node, ListOf):
            kids = [node.item]
        elif isinstance(node, OneOf):
            kids = list(node.variants)
        for kid in kids:
            out += objs(kid, seen)
        return out

    for obj in objs(S.TOP, set()):
        for k in obj.keys:
            if not k.node.has_default or isinstance(k.node, (Obj, MapOf)):
                continue
            if (id(obj), k.name) not in getters:
                assert k.name in NOT_LOADER_DEFAULTS, (
                    f"no check of the default of {obj.title}.{k.name}"
                )
                continue
            got = getters[(id(obj), k.name)](cfg)
            want = k.node.default
            if isinstance(want, float) and math.isinf(want):
                assert got == want
            else:
                assert got == (tuple(want) if isinstance(want, list) else want), (obj.title, k.name)
            checked += 1
    assert checked >= 25


def test_schema_constants_equal_the_kernels() -> None:
    from motionplc.blocks import axis

    assert (S.LIMIT_LO, S.LIMIT_HI, S.POSITION_MAX) == (
        axis.AXIS_LIMIT_MIN,
        axis.AXIS_LIMIT_MAX,
        axis.POSITION_MAX,
    )


def test_sequence_tables_agree_with_the_parser() -> None:
    import motionplc.sequence as seq
    from motionplc.schema import sequence as seq_schema

    assert seq_schema.TOP.table() == seq._TOP
    assert seq_schema.STEP.table() == seq._STEP
    assert seq_schema.COND.table() == seq._COND


def test_sequence_call_inputs_come_from_the_fb_classes() -> None:
    from motionplc.blocks import MC_MoveAbsolute

    call = schema.file_schema("sequence").defs["call"]
    assert isinstance(call, Obj)
    keys = {k.name for k in call.case_keys("MC_MoveAbsolute")}
    assert keys == set(MC_MoveAbsolute.INPUTS) - {"axis"}
    js = schema.json_schema("sequence")["$defs"]["call"]
    branch = next(
        b
        for b in js["allOf"]
        if b["if"].get("properties", {}).get("type", {}).get("const") == "MC_MoveAbsolute"
    )
    assert "buffer_mode" in branch["then"]["properties"]
    assert "BUFFERED" in branch["then"]["properties"]["buffer_mode"]["enum"]
    bad = {
        "steps": [
            {"call": [{"block": "m", "type": "MC_MoveAbsolute", "axis": "x", "distance": 1.0}]}
        ]
    }
    assert not json_ok("sequence", bad)  # distance is MC_MoveRelative's
    good = {
        "steps": [
            {"call": [{"block": "m", "type": "MC_MoveAbsolute", "axis": "x", "position": 1.0}]}
        ]
    }
    assert json_ok("sequence", good)


def test_unknown_kind_is_a_clear_error() -> None:
    with pytest.raises(ValueError, match="allowed: config, sequence, register_map"):
        schema.json_schema("machine")


# ------------------------------------------------------------------------ docs
def test_docs_are_up_to_date() -> None:
    sys.path.insert(0, str(ROOT / "tools"))
    try:
        import gen_docs
    finally:
        sys.path.pop(0)
    stale = [
        str(rel)
        for rel, text in gen_docs.generated().items()
        if not (ROOT / rel).is_file() or (ROOT / rel).read_text(encoding="utf-8") != text
    ]
    assert stale == [], "run .venv/bin/python tools/gen_docs.py"


def test_reference_lists_every_key() -> None:
    for kind in schema.KINDS:
        page = schema.reference_markdown(kind)
        fs = schema.file_schema(kind)
        own = [d for n, d in fs.defs.items() if n not in fs.pages]
        for site_obj in [fs.resolve(fs.root), *[fs.resolve(d) for d in own]]:
            if isinstance(site_obj, Obj):
                for k in site_obj.keys:
                    assert f"| `{k.name}` |" in page, (kind, k.name)


def test_register_map_defaults_are_the_loaders() -> None:
    from motionplc.fieldbus.modbus_regmap import load_register_map
    from motionplc.schema import register_map as rm

    rmap = load_register_map(
        {
            "format": 1,
            "registers": {
                "controlword": {"address": 1, "type": "u16"},
                "target_position": {"address": 2, "type": "i32"},
                "statusword": {"address": 10, "type": "u16"},
                "position_actual": {"address": 12, "type": "i32"},
            },
        }
    )
    assert rmap.word_order == rm.TOP["word_order"].default
    assert rmap.register_base == rm.TOP["register_base"].default
    assert rmap.write_function == rm.FUNCTIONS["write"].default
    assert rmap.exchange == rm.FUNCTIONS["exchange"].default
    reg = rmap.get("target_position")
    assert reg is not None
    entry = rm.entry("target_position")
    assert (reg.table, reg.scale) == (entry["table"].default, entry["scale"].default)
