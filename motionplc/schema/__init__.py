"""One schema per file kind: the single source of truth for validation and documentation.

Kinds: ``"config"`` (machine configuration, including the bus-specific keys of CANopen and
Modbus drives), ``"sequence"`` (YAML motion sequences; the inputs of each FB type come from
the FB classes) and ``"register_map"`` (Modbus register maps). The validators
(:mod:`motionplc.config`, :mod:`motionplc.fieldbus.canopen_options`,
:mod:`motionplc.fieldbus.modbus_options`, :mod:`motionplc.fieldbus.modbus_regmap`) take their
key sets, ranges and defaults from these trees; :func:`json_schema` and
:func:`reference_markdown` render them. Rules across keys (a period a multiple of the tick,
references to buses, axes and tasks, unique node ids, ...) stay in the validators and are
listed in the reference as checked by the validator, not by the JSON Schema.
"""

from __future__ import annotations

from typing import Any

from motionplc.schema.nodes import FileSchema

__all__ = ["KINDS", "file_schema", "json_schema", "reference_markdown"]

KINDS = ("config", "sequence", "register_map")


def file_schema(kind: str) -> FileSchema:
    """The schema tree of ``kind`` (one of :data:`KINDS`); ValueError naming the kinds."""
    if kind == "config":
        from motionplc.schema.config import CONFIG

        return CONFIG
    if kind == "sequence":
        from motionplc.schema.sequence import sequence_schema

        return sequence_schema()
    if kind == "register_map":
        from motionplc.schema.register_map import REGISTER_MAP

        return REGISTER_MAP
    raise ValueError(f"unknown schema kind {kind!r} (allowed: {', '.join(KINDS)})")


def json_schema(kind: str) -> dict[str, Any]:
    """The JSON Schema (draft 2020-12) of ``kind``: ``additionalProperties: false`` where the
    validator refuses unknown keys, descriptions, defaults, examples, enums, and per FB type
    ``if``/``then`` for sequence calls. A fresh dict each call."""
    from motionplc.schema.render import to_json_schema

    return to_json_schema(file_schema(kind))


def reference_markdown(kind: str) -> str:
    """The reference page of ``kind`` (Markdown): an example file, then every key with its
    type, range, default, description and example, then the rules only the validator checks."""
    from motionplc.schema.render import to_markdown

    return to_markdown(file_schema(kind))
