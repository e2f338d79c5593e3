"""JSON Schema (draft 2020-12) and Markdown reference pages from a :class:`FileSchema`."""

from __future__ import annotations

import json
import math
from typing import Any

from motionplc.schema.nodes import (
    NO_DEFAULT,
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
    Ref,
    Scalar,
    String,
    fmt_number,
)

__all__ = ["to_json_schema", "to_markdown"]

# .inf is no JSON value: the JSON Schema accepts it as "a number >= 1e308" beside the range
_INF_STANDIN = 1e308
SCHEMA_URL = "https://motionplc.invalid/schema"


def _json_value(x: Any) -> Any:
    if isinstance(x, float) and not math.isfinite(x):
        return None
    if isinstance(x, tuple):
        return [_json_value(v) for v in x]
    if isinstance(x, dict):
        return {str(k): _json_value(v) for k, v in x.items()}
    if isinstance(x, list):
        return [_json_value(v) for v in x]
    return x


def _annotate(out: dict[str, Any], node: Node) -> dict[str, Any]:
    text = node.description
    if node.default_text:
        text += f" Default: {node.default_text}."
    if node.unit:
        text += f" Unit: {node.unit}."
    if node.checks:
        text += " Checked by the validator: " + "; ".join(node.checks) + "."
    if text:
        out["description"] = text.strip()
    if node.has_default and _json_value(node.default) is not None:
        out["default"] = _json_value(node.default)
    if node.example is not NO_DEFAULT:
        ex = _json_value(node.example)
        if ex is not None:
            out["examples"] = [ex]
    return out


def _keys_schema(keys: tuple[Key, ...]) -> tuple[dict[str, Any], list[str]]:
    props = {k.name: _node(k.node) for k in keys}
    required = [k.name for k in keys if k.required]
    return props, required


def _obj(node: Obj) -> dict[str, Any]:
    props, required = _keys_schema(node.keys)
    out: dict[str, Any] = {"type": "object", "properties": props}
    if required:
        out["required"] = required
    if node.cases:
        assert node.switch is not None
        branches = []
        every: dict[str, Any] = {}
        for value, keys in node.cases:
            cprops, _ = _keys_schema(keys)
            every.update({k: {} for k in cprops})
            branches.append(
                {
                    "if": {
                        "properties": {node.switch: {"const": value}},
                        "required": [node.switch],
                    },
                    "then": {"properties": cprops},
                }
            )
        branches.append({"if": {"not": {"required": [node.switch]}}, "then": {"properties": every}})
        out["allOf"] = branches
        if node.closed:
            out["unevaluatedProperties"] = False
    elif node.closed:
        out["additionalProperties"] = False
    if node.title:
        out["title"] = node.title
    return out


def _node(node: Node) -> dict[str, Any]:
    out: dict[str, Any]
    if isinstance(node, Number):
        out = {"type": "number"}
        if node.gt is not None:
            out["exclusiveMinimum"] = node.gt
        if node.ge is not None:
            out["minimum"] = node.ge
        if node.le is not None:
            out["maximum"] = node.le
        if node.lt is not None:
            out["exclusiveMaximum"] = node.lt
        if node.inf_ok and node.le is not None:
            out = {"anyOf": [out, {"type": "number", "minimum": _INF_STANDIN}]}
    elif isinstance(node, Integer):
        out = {"type": "integer"}
        if node.lo is not None:
            out["minimum"] = node.lo
        if node.hi is not None:
            out["maximum"] = node.hi
    elif isinstance(node, Choice):
        out = {"enum": list(node.options)}
    elif isinstance(node, String):
        out = {"type": "string", "minLength": 1}
        if node.pattern:
            out["pattern"] = node.pattern
    elif isinstance(node, Bool):
        out = {"type": "boolean"}
    elif isinstance(node, Scalar):
        out = {"type": ["string", "number", "boolean"]}
    elif isinstance(node, Obj):
        out = _obj(node)
    elif isinstance(node, MapOf):
        out = {"type": "object", "additionalProperties": _node(node.value)}
        if node.key.pattern:
            out["propertyNames"] = {"pattern": node.key.pattern}
        if node.min_items:
            out["minProperties"] = node.min_items
    elif isinstance(node, ListOf):
        out = {"type": "array", "items": _node(node.item)}
        if node.min_items:
            out["minItems"] = node.min_items
        if node.max_items is not None:
            out["maxItems"] = node.max_items
    elif isinstance(node, OneOf):
        if node.discriminator:
            d = node.discriminator
            values = [v for var in node.variants for v in var[d].options]  # type: ignore[index]
            out = {
                "type": "object",
                "required": [d],
                "properties": {d: {"enum": values}},
                "allOf": [
                    {
                        "if": {"properties": {d: {"const": v}}, "required": [d]},
                        "then": _node(var),
                    }
                    for v, var in zip(values, node.variants, strict=True)
                ],
            }
        else:
            out = {"anyOf": [_node(v) for v in node.variants]}
    elif isinstance(node, Ref):
        out = {"$ref": f"#/$defs/{node.name}"}
    else:  # pragma: no cover - every node kind is handled above
        raise TypeError(f"unknown schema node {type(node).__name__}")
    return _annotate(out, node)


def to_json_schema(fs: FileSchema) -> dict[str, Any]:
    """The JSON Schema (draft 2020-12) of a file kind."""
    out: dict[str, Any] = {
        "$schema": "https://json-schema.org/draft/2020-12/schema",
        "$id": f"{SCHEMA_URL}/{fs.kind}.schema.json",
        "title": f"motionplc {fs.title.lower()}",
        "description": fs.intro,
    }
    body = _node(fs.root)
    body.pop("title", None)
    out.update(body)
    if fs.defs:
        out["$defs"] = {name: _node(node) for name, node in fs.defs.items()}
    return out


def dumps(schema: dict[str, Any]) -> str:
    """The JSON text written to docs/schema (stable: sorted as built, 2-space indent)."""
    return json.dumps(schema, indent=2, ensure_ascii=False, allow_nan=False) + "\n"


# --------------------------------------------------------------------------------- markdown
def _val(x: Any) -> str:
    if isinstance(x, bool):
        return "true" if x else "false"
    if isinstance(x, (int, float)):
        return fmt_number(x)
    if isinstance(x, (tuple, list)):
        return "[" + ", ".join(_val(v) for v in x) + "]"
    if isinstance(x, dict):
        return "{" + ", ".join(f"{k}: {_val(v)}" for k, v in x.items()) + "}"
    return str(x)


def _anchor(path: str) -> str:
    keep = "".join(ch if ch.isalnum() or ch in "-_ " else "" for ch in path.lower())
    return keep.replace(" ", "-")


class _Page:
    def __init__(self, fs: FileSchema) -> None:
        self.fs = fs
        self.sections: list[tuple[str, Obj | None, Node]] = []  # (path, obj, node)
        self.seen_refs: set[str] = set()
        self.checks: list[tuple[str, str]] = []

    def heading(self, path: str) -> str:
        return f"`{path}`" if path else "Top level"

    def link(self, path: str) -> str:
        return f"[`{path}`](#{_anchor(self.heading(path))})"

    def type_of(self, node: Node, path: str) -> str:
        """Type text, walking into containers (sections are added for objects)."""
        node_r = node
        if isinstance(node, Ref):
            return self.ref(node.name)
        if isinstance(node_r, Obj):
            self.visit(node_r, path)
            return f"mapping, see {self.link(path)}"
        if isinstance(node_r, MapOf):
            inner = self.type_of(node_r.value, f"{path}.<name>")
            what = node_r.key.what or "name"
            return f"mapping of {what} -> {inner}"
        if isinstance(node_r, ListOf):
            inner = self.type_of(node_r.item, f"{path}[i]")
            n = ""
            if node_r.min_items and node_r.max_items == node_r.min_items:
                n = f" of {node_r.min_items}"
            elif node_r.min_items:
                n = f" (at least {node_r.min_items})"
            return f"list{n} of {inner}"
        if isinstance(node_r, OneOf):
            forms = []
            for i, v in enumerate(node_r.variants):
                vp = path if not isinstance(v, Obj) else f"{path} ({v.title or f'form {i + 1}'})"
                forms.append(self.type_of(v, vp))
            return " **or** ".join(forms)
        if isinstance(node_r, Number):
            rng = node_r.range_text()
            return "number" + ("" if rng == "any" else f" ({rng})")
        if isinstance(node_r, Integer):
            rng = node_r.range_text()
            return "integer" + ("" if rng == "any" else f" ({rng})")
        if isinstance(node_r, Choice):
            if node_r.hex_digits:
                return "one of " + ", ".join(f"`{node_r.option_text(o)}`" for o in node_r.options)
            return "one of " + ", ".join(f"`{_val(o)}`" for o in node_r.options)
        if isinstance(node_r, String):
            return "string" + (f" ({node_r.what})" if node_r.what else "")
        return node_r.type_text()

    def ref(self, name: str) -> str:
        if name in self.fs.pages:
            page = self.fs.pages[name]
            return f"an inline {name.replace('_', ' ')}, see [{page}]({page})"
        if name not in self.seen_refs:
            self.seen_refs.add(name)
            target = self.fs.defs[name]
            if isinstance(target, Obj):
                self.visit(target, f"<{name}>")
            else:
                self.sections.append((f"<{name}>", None, target))
                self.type_of(target, f"<{name}>")
        return self.link(f"<{name}>")

    def visit(self, obj: Obj, path: str) -> None:
        if any(p == path for p, _, _ in self.sections):
            return
        self.sections.append((path, obj, obj))
        for k in obj.keys:
            self.type_of(k.node, join(path, k.name))
        for _value, keys in obj.cases:
            for k in keys:
                self.type_of(k.node, join(path, k.name))

    def row(self, k: Key, path: str) -> str:
        n = k.node
        kp = join(path, k.name)
        typ = self.type_of(n, kp)
        if n.has_default:
            default = f"`{_val(n.default)}`"
        elif n.default_text:
            default = n.default_text
        else:
            default = "required" if k.required else "—"
        text = n.description
        if n.unit:
            text += f" [{n.unit}]"
        if n.example is not NO_DEFAULT:
            text += f" Example: `{_val(n.example)}`."
        for c in self._checks_of(n):
            text += f" *Validator:* {c}."
            self.checks.append((kp, c))
        cells = (f"`{k.name}`", typ, default, text.strip())
        return "| " + " | ".join(c.replace("|", "\\|") for c in cells) + " |"

    def _checks_of(self, n: Node) -> tuple[str, ...]:
        out = list(n.checks)
        if isinstance(n, (MapOf, ListOf)):
            inner = n.value if isinstance(n, MapOf) else n.item
            if not isinstance(inner, (Obj, Ref, OneOf)):
                out.extend(inner.checks)
        return tuple(out)

    def table(self, keys: tuple[Key, ...], path: str) -> list[str]:
        lines = ["| key | type | default | description |", "|---|---|---|---|"]
        lines += [self.row(k, path) for k in keys]
        return lines

    def render(self) -> str:
        fs = self.fs
        root = fs.resolve(fs.root)
        assert isinstance(root, Obj)
        self.visit(root, "")
        out = [
            f"# {fs.title} — reference",
            "",
            "<!-- generated by tools/gen_docs.py from motionplc.schema; do not edit -->",
            "",
            fs.intro,
            "",
            f"JSON Schema for editors: [`../schema/{fs.kind}.schema.json`]"
            f"(../schema/{fs.kind}.schema.json) (see [docs/README.md](../README.md)).",
            "",
            "```yaml",
            fs.example.rstrip("\n"),
            "```",
            "",
            "Defaults apply when a key is absent. *Validator:* marks a rule across keys "
            "that `motionplc validate` checks and the JSON Schema cannot.",
            "",
        ]
        done: list[str] = []
        i = 0
        while i < len(self.sections):
            path, obj, node = self.sections[i]
            i += 1
            if path in done:
                continue
            done.append(path)
            out.append(f"## {self.heading(path)}")
            out.append("")
            if obj is None:
                out.append(f"{node.description} Type: {self.type_of(node, path)}.")
                out.append("")
                continue
            if obj.description:
                out.append(obj.description)
                out.append("")
            if obj.keys:
                out += self.table(obj.keys, path)
                out.append("")
            for c in obj.checks:
                out.append(f"*Validator:* {c}.")
                self.checks.append((path or "(top level)", c))
                out.append("")
            for value, keys in obj.cases:
                out.append(f"### `{obj.switch}: {value}`")
                out.append("")
                out += self.table(keys, path)
                out.append("")
        out.append("## Checked by the validator, not by the JSON Schema")
        out.append("")
        seen = set()
        for where, c in self.checks:
            if (where, c) in seen:
                continue
            seen.add((where, c))
            out.append(f"* `{where}`: {c}")
        out.append("")
        return "\n".join(out)


def join(path: str, key: str) -> str:
    return f"{path}.{key}" if path else key


def to_markdown(fs: FileSchema) -> str:
    """The reference page of a file kind (every key: type, range, default, description,
    example; the cross-field rules at the end)."""
    return _Page(fs).render()
