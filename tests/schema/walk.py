"""Walk a loaded YAML document together with its schema: every key the document has and
every scalar key its mappings could have, with the node and key path of each."""

from __future__ import annotations

import copy
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from motionplc.config import YamlList, YamlMap, join, load_config, load_yaml
from motionplc.errors import ConfigError
from motionplc.fieldbus.modbus_regmap import load_register_map
from motionplc.schema.nodes import (
    Bool,
    Choice,
    FileSchema,
    Integer,
    Key,
    ListOf,
    MapOf,
    Node,
    Number,
    Obj,
    OneOf,
    String,
)
from motionplc.sequence import load_sequence

ROOT = Path(__file__).resolve().parents[2]
SEQUENCE_CONFIG = {
    "demo_sequence.yaml": "demo.yaml",
    "gantry_sequence.yaml": "gantry.yaml",
    "gantry_groups_sequence.yaml": "gantry.yaml",
    "packaging_sequence.yaml": "packaging.yaml",
    "single_axis_sequence.yaml": "single_axis_can.yaml",
    "vcan0_external_sequence.yaml": "vcan0_external.yaml",
}
SCALARS = (Number, Integer, Choice, String, Bool)


@dataclass(frozen=True)
class Site:
    """A mapping of the document (``where``: a path of dict keys / list indices from the
    root), one of its schema keys, and the key path the validator names."""

    where: tuple[Any, ...]
    key: Key
    path: str
    present: bool
    owner: int  # id of the schema object the key belongs to


def plain(x: Any) -> Any:
    """YamlMap / YamlList as plain dicts and lists (for jsonschema)."""
    if isinstance(x, dict):
        return {k: plain(v) for k, v in x.items()}
    if isinstance(x, list):
        return [plain(v) for v in x]
    return x


def _pick(fs: FileSchema, node: Node, value: Any) -> Node | None:
    """The form of a OneOf (or the definition of a Ref) that ``value`` has."""
    node = fs.resolve(node)
    if not isinstance(node, OneOf):
        return node
    if node.discriminator and isinstance(value, dict):
        try:
            return node.variant(value.get(node.discriminator))
        except KeyError:
            return None
    forms = [fs.resolve(v) for v in node.variants]
    if isinstance(value, dict):
        objs = [v for v in forms if isinstance(v, (Obj, MapOf))]
        for v in objs:  # the drive: by its id key
            if isinstance(v, Obj) and any(k.required and k.name in value for k in v.keys):
                if all(k in v or (v.cases and v.switch) for k in value):
                    return v
        for v in objs:
            if isinstance(v, Obj) and all(k in v for k in value):
                return v
        return objs[0] if objs else None
    if isinstance(value, list):
        return next((v for v in forms if isinstance(v, ListOf)), None)
    return next((v for v in forms if isinstance(v, SCALARS)), None)


def sites(fs: FileSchema, data: Any) -> Iterator[Site]:
    """Every key of every mapping of ``data`` that the schema describes as an object."""
    yield from _walk(fs, fs.root, data, (), "")


def _walk(fs: FileSchema, node: Node, value: Any, where: tuple, path: str) -> Iterator[Site]:
    node_r = _pick(fs, node, value)
    if node_r is None:
        return
    if isinstance(node_r, Obj) and isinstance(value, dict):
        keys = list(node_r.keys)
        if node_r.switch and node_r.switch in value:
            keys += node_r.case_keys(value[node_r.switch])
        for k in keys:
            kp = join(path, k.name)
            yield Site(where, k, kp, k.name in value, id(node_r))
            if k.name in value:
                yield from _walk(fs, k.node, value[k.name], (*where, k.name), kp)
    elif isinstance(node_r, MapOf) and isinstance(value, dict):
        for name, v in value.items():
            yield from _walk(fs, node_r.value, v, (*where, name), join(path, name))
    elif isinstance(node_r, ListOf) and isinstance(value, list):
        for i, v in enumerate(value):
            yield from _walk(fs, node_r.item, v, (*where, i), join(path, i))


def get(data: Any, where: tuple) -> Any:
    for w in where:
        data = data[w]
    return data


def with_value(data: Any, where: tuple, key: str, value: Any) -> Any:
    out = copy.deepcopy(data)
    get(out, where)[key] = value
    return out


def without(data: Any, where: tuple, key: str) -> Any:
    out = copy.deepcopy(data)
    del get(out, where)[key]
    return out


def validate(kind: str, source: Path, data: Any, tmp: Path) -> list[str]:
    """The validator's errors for ``data`` written as ``source``'s kind (a sequence with its
    configuration), [] when it is accepted."""
    import yaml

    f = tmp / source.name
    f.write_text(yaml.safe_dump(plain(data), sort_keys=False), encoding="utf-8")
    try:
        if kind == "config":
            load_config(f)
        elif kind == "register_map":
            load_register_map(f)
        else:
            load_sequence(f, load_config(ROOT / "configs" / SEQUENCE_CONFIG[source.name]))
    except ConfigError as exc:
        return list(exc.errors)
    return []


def names(errors: list[str], path: str) -> bool:
    """Whether an error line is about ``path`` (or a key inside it)."""
    forms = [path, f"(top level).{path}"]
    return any(f" {p}: " in e or f" {p}." in e or f" {p}[" in e for e in errors for p in forms)


def shipped() -> list[tuple[str, Path]]:
    """Every shipped file with its kind."""
    out: list[tuple[str, Path]] = []
    for p in sorted((ROOT / "configs").glob("*.yaml")):
        out.append(("sequence" if "sequence" in p.name else "config", p))
    for p in sorted((ROOT / "motionplc/fieldbus/data/modbus_maps").glob("*.yaml")):
        out.append(("register_map", p))
    for p in sorted((ROOT / "tests/interop/data").glob("*.yaml")):
        out.append(("register_map", p))
    return out


def load(p: Path) -> Any:
    return load_yaml(p)


_ = (YamlMap, YamlList)
