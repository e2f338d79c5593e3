"""The YAML side of a CANopen drive's options (under an axis' ``drive:``).

:func:`check_canopen_drive` checks the keys of :data:`CANOPEN_DRIVE_KEYS` in one ``drive:``
mapping and returns keyword arguments of
:class:`~motionplc.fieldbus.canopen_drive.CanopenDriveConfig`; every problem is reported
through ``Checker.error`` with the line, the key path and the allowed values (nothing raises).
The caller (``motionplc.config``) handles the other drive keys (``kind``, ``bus``, ``node_id``,
``counts_per_unit``) and passes the axis' following error as the default window.

.. code-block:: yaml

    drive:
      eds: drives/servo.eds            # relative to the configuration file
      heartbeat: {producer: 0.05, consumer: 0.2}   # s; consumer = the drive watches the master
      node_guarding: {guard_time: 0.1, life_time_factor: 3}   # instead of heartbeat.producer
      pdo:
        rpdo1: {objects: [0x6040, 0x607A], cob_id: 0x201, transmission: 1}
        tpdo1: {objects: [0x6041, 0x6064]}
        tpdo2: {objects: [0x606C, {index: 0x603F, optional: true}]}
      scaling: {encoder_resolution: [4096, 1], gear_ratio: [10, 1], feed_constant: [5000, 1],
                polarity: 0}                # or: scaling: read
      mode_timeout: 0.5
      setup_timeout: 2.0
      following_error_window: 0.002    # m
      following_error_timeout: 0.01    # s

Objects are written as an index (``0x6041`` or ``"0x6041"``), ``"index:sub"`` or
``{index, sub, optional}``.
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

from motionplc.config import Checker, YamlList, YamlMap, join
from motionplc.fieldbus.canopen_startup import (
    RPDO_OBJECTS,
    TPDO_OBJECTS,
    PdoSpec,
    ScalingSpec,
    check_layout,
)
from motionplc.schema import config as schema
from motionplc.schema.nodes import Integer, Obj

__all__ = ["CANOPEN_DRIVE_KEYS", "check_canopen_drive"]

# keys, ranges and defaults: the schema (motionplc.schema.config.CANOPEN_DRIVE)
D = schema.CANOPEN_DRIVE
CANOPEN_DRIVE_KEYS: dict[str, bool] = schema.CANOPEN_DRIVE_KEYS
HEARTBEAT_KEYS = schema.HEARTBEAT.table()
GUARDING_KEYS = schema.GUARDING.table()
_RPDO1 = schema.PDO["rpdo1"]
assert isinstance(_RPDO1, Obj)
PDO_ENTRY_KEYS = _RPDO1.table()
_OBJECT = next(v for v in _RPDO1["objects"].item.variants if isinstance(v, Obj))  # type: ignore[attr-defined]
OBJECT_KEYS = _OBJECT.table()
_SCALING = next(v for v in schema.SCALING.variants if isinstance(v, Obj))
SCALING_KEYS = _SCALING.table()
PDO_NAME = re.compile(r"^(rpdo|tpdo)([1-4])$")
OBJECT_TEXT = re.compile(r"^\s*(0[xX][0-9a-fA-F]+|\d+)\s*(?::\s*(0[xX][0-9a-fA-F]+|\d+)\s*)?$")
OBJECT_FORMS = 'an index (0x6041 or "0x6041"), "index:sub", or {index, sub, optional}'


def _int(x: Any) -> bool:
    return isinstance(x, int) and not isinstance(x, bool)


def check_canopen_drive(
    c: Checker,
    m: YamlMap,
    path: str,
    base_dir: str | Path | None = None,
    following_error_window: float | None = None,
) -> dict[str, Any]:
    """CanopenDriveConfig keyword arguments from the CANopen keys of ``m`` (a ``drive:``
    mapping at ``path``); unknown keys are the caller's business. ``base_dir``: directory of
    the configuration file (``eds`` is relative to it). ``following_error_window``: the
    default window (the axis' following error) when the key is absent."""
    out: dict[str, Any] = {}
    if "eds" in m:
        eds = c.string(m, "eds", path)
        if eds is not None:
            p = Path(eds)
            if not p.is_absolute() and base_dir is not None:
                p = Path(base_dir) / p
            if not p.is_file():
                c.error(m.line_of("eds"), join(path, "eds"), f"no such file: {p}", "an EDS file")
            else:
                out["eds"] = str(p)

    guarding = False
    if "node_guarding" in m and m["node_guarding"] is not None:
        gp = join(path, "node_guarding")
        g = c.mapping(m["node_guarding"], m.line_of("node_guarding"), gp, GUARDING_KEYS)
        if g is not None:
            guard = c.field(g, "guard_time", gp, schema.GUARDING["guard_time"])
            factor = c.field(g, "life_time_factor", gp, schema.GUARDING["life_time_factor"])
            if guard is not None:
                guarding = True
                out["guard_time"] = guard
                out["heartbeat_period"] = 0.0
            if factor is not None:
                out["life_time_factor"] = factor
    if "heartbeat" in m and m["heartbeat"] is not None:
        hp = join(path, "heartbeat")
        h = c.mapping(m["heartbeat"], m.line_of("heartbeat"), hp, HEARTBEAT_KEYS)
        if h is not None:
            if "producer" in h and guarding:
                c.error(
                    h.line_of("producer"),
                    join(hp, "producer"),
                    "heartbeat.producer and node_guarding are exclusive",
                    "one of them",
                )
            else:
                producer = c.field(h, "producer", hp, schema.HEARTBEAT["producer"])
                if producer is not None:
                    out["heartbeat_period"] = producer
            consumer = c.field(h, "consumer", hp, schema.HEARTBEAT["consumer"])
            if consumer is not None:
                out["master_heartbeat_timeout"] = consumer

    if "pdo" in m and m["pdo"] is not None:
        node = m.get("node_id")
        node_id = node if _int(node) and 1 <= node <= 127 else 1
        pdos = _check_pdos(c, m["pdo"], m.line_of("pdo"), join(path, "pdo"), node_id)
        if pdos is not None:
            out["pdos"] = pdos

    if "scaling" in m and m["scaling"] is not None:
        scaling = _check_scaling(c, m["scaling"], m.line_of("scaling"), join(path, "scaling"))
        if scaling is not None:
            out["scaling_objects"] = scaling

    for key in ("mode_timeout", "setup_timeout"):
        value = c.field(m, key, path, D[key])
        if value is not None:
            out[key] = value
    window = c.field(m, "following_error_window", path, D["following_error_window"])
    window = window if window is not None else following_error_window
    if window is not None:
        out["following_error_window"] = window
    timeout = c.field(m, "following_error_timeout", path, D["following_error_timeout"])
    if timeout is not None:
        out["following_error_timeout"] = timeout
    return out


def _check_object(
    c: Checker, x: Any, line: int, path: str, kind: str
) -> tuple[int, int, bool] | None:
    index: Any = None
    sub: Any = 0
    optional = False
    if _int(x):
        index = x
    elif isinstance(x, str):
        match = OBJECT_TEXT.match(x)
        if match is None:
            c.error(line, path, f"got string {x!r}", OBJECT_FORMS)
            return None
        index = int(match.group(1), 0)
        sub = int(match.group(2), 0) if match.group(2) else 0
    elif isinstance(x, YamlMap):
        om = c.mapping(x, line, path, OBJECT_KEYS)
        if om is None or "index" not in om:
            return None
        raw = om["index"]
        if _int(raw):
            index = raw
        elif isinstance(raw, str) and OBJECT_TEXT.match(raw) and ":" not in raw:
            index = int(raw.strip(), 0)
        else:
            c.error(om.line_of("index"), join(path, "index"), f"got {raw!r}", "an object index")
            return None
        sub = c.field(om, "sub", path, _OBJECT["sub"])
        optional = c.field(om, "optional", path, _OBJECT["optional"])
        line = om.line_of("index")
    else:
        c.error(line, path, f"got {type(x).__name__}", OBJECT_FORMS)
        return None
    table = RPDO_OBJECTS if kind == "rpdo" else TPDO_OBJECTS
    if index not in table:
        listed = ", ".join(f"0x{i:04X}" for i in table)
        shown = f"0x{index:04X}" if 0 <= index <= 0xFFFF else str(index)
        c.error(line, path, f"object {shown} cannot be mapped in a {kind.upper()}", listed)
        return None
    if sub != 0:
        c.error(line, path, f"object 0x{index:04X} sub-index {sub}", "sub-index 0")
        return None
    return index, 0, optional


def _check_pdos(
    c: Checker, x: Any, line: int, path: str, node_id: int
) -> tuple[PdoSpec, ...] | None:
    pm = c.mapping(x, line, path)
    if pm is None:
        return None
    specs: list[PdoSpec] = []
    ok = True
    for name, entry in pm.items():
        ep = join(path, name)
        match = PDO_NAME.match(str(name))
        if match is None:
            c.error(
                pm.key_lines.get(name, pm.line), ep, "unknown key", "rpdo1..rpdo4, tpdo1..tpdo4"
            )
            ok = False
            continue
        kind, number = match.group(1), int(match.group(2))
        em = c.mapping(entry, pm.line_of(name), ep, PDO_ENTRY_KEYS)
        if em is None or "objects" not in em:
            ok = False
            continue
        objs = em["objects"]
        op = join(ep, "objects")
        if not isinstance(objs, YamlList) or not objs:
            c.error(em.line_of("objects"), op, "got " + repr(objs), "a non-empty list of objects")
            ok = False
            continue
        objects = []
        for i, item in enumerate(objs):
            obj = _check_object(c, item, objs.line_of(i), join(op, i), kind)
            if obj is None:
                ok = False
            else:
                objects.append(obj)
        cob_id = c.field(em, "cob_id", ep, _RPDO1["cob_id"])
        trans = c.field(em, "transmission", ep, _RPDO1["transmission"])
        if not ok or trans is None:
            continue
        try:
            specs.append(PdoSpec(kind, number, tuple(objects), cob_id, trans))
        except ValueError as exc:
            c.error(pm.line_of(name), ep, _strip(str(exc)))
            ok = False
    if not ok:
        return None
    layout = tuple(sorted(specs, key=lambda s: (s.kind, s.number)))
    try:
        check_layout(layout, node_id)
    except ValueError as exc:
        c.error(pm.line, path, _strip(str(exc)))
        return None
    return layout


def _strip(text: str) -> str:
    return text[len("pdos: ") :] if text.startswith("pdos: ") else text


def _check_scaling(c: Checker, x: Any, line: int, path: str) -> ScalingSpec | str | None:
    if x == "read":
        return "read"
    if not isinstance(x, YamlMap):
        c.error(line, path, f"got {x!r}", "read, or a mapping of scaling objects")
        return None
    sm = c.mapping(x, line, path, SCALING_KEYS)
    if sm is None:
        return None
    kwargs: dict[str, Any] = {}
    ok = True
    for key in ("encoder_resolution", "gear_ratio", "feed_constant"):
        if key not in sm or sm[key] is None:
            continue
        pair = sm[key]
        item = _SCALING[key].item  # type: ignore[attr-defined]
        assert isinstance(item, Integer) and item.lo is not None and item.hi is not None
        if (
            isinstance(pair, list)
            and len(pair) == 2
            and all(_int(v) and item.lo <= v <= item.hi for v in pair)
        ):
            kwargs[key] = (pair[0], pair[1])
        else:
            c.error(
                sm.line_of(key),
                join(path, key),
                f"got {pair!r}",
                f"[numerator, denominator], integers in {item.range_text()}",
            )
            ok = False
    polarity = c.field(sm, "polarity", path, _SCALING["polarity"])
    if polarity is not None:
        kwargs["polarity"] = polarity
    if not ok:
        return None
    return ScalingSpec(**kwargs)
