"""The Modbus keys of an axis' ``drive:`` in a configuration file, checked with located errors.

For the configuration parser (:mod:`motionplc.config`)::

    axes:
      z:
        drive:
          bus: mb0                       # a bus of type modbus (checked by the caller)
          counts_per_unit: 1.0e6         # common drive key (the caller's)
          unit_id: 3                     # required, 1..247
          word_order: little             # optional: overrides the register map's
          register_map: acme-ms400.yaml  # a shipped map's name (default motionplc-v1), a path
                                         # relative to the config file, or an inline mapping
          following_error_window: 0.002  # [m or rad] optional, written at setup
          following_error_timeout: 0.01  # [s] optional, written at setup
          watchdog: 0.05                 # [s] optional, 0 = off, written at setup
          velocity_feed_forward: true    # optional (needs a target_velocity register)
          requests_in_flight: 1          # optional, 1..16: requests of a cycle on the wire at
                                         # once (1: each after the previous answer)

:data:`MODBUS_DRIVE_KEYS` lists these keys (key -> required); :func:`check_modbus_drive` checks
their presence and values (a missing ``unit_id`` included) and returns the
:class:`~motionplc.fieldbus.modbus_drive.ModbusDriveConfig` keyword arguments they give.
Unknown keys are the caller's to report (with the union of its own keys and these). Errors read
``FILE:LINE: axes.z.drive.register_map.registers.target_position.type: ... (allowed: ...)``; a
map in its own file is reported with that file's lines; an inline map with the configuration
file's.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from motionplc.config import Checker, YamlMap, join, load_yaml
from motionplc.errors import ConfigError
from motionplc.fieldbus.modbus_regmap import (
    DEFAULT_MAP,
    RegisterMap,
    RegisterValueError,
    check_register_map,
    load_register_map,
    resolve_map_source,
)
from motionplc.schema import config as schema

__all__ = ["MODBUS_DRIVE_KEYS", "check_modbus_drive"]

# keys, ranges and defaults: the schema (motionplc.schema.config.MODBUS_DRIVE)
D = schema.MODBUS_DRIVE
MODBUS_DRIVE_KEYS: dict[str, bool] = schema.MODBUS_DRIVE_KEYS
WORD_ORDERS = schema.WORD_ORDERS


def _register_map(c: Checker, m: YamlMap, path: str, base_dir: Path) -> RegisterMap | None:
    """The map under ``register_map`` (default: the shipped motionplc-v1); None when invalid."""
    p = join(path, "register_map")
    value = m.get("register_map")
    if value is None:
        return load_register_map(DEFAULT_MAP)
    if isinstance(value, YamlMap):
        return check_register_map(c, value, m.line_of("register_map"), p, "inline", c.file)
    if not isinstance(value, str) or not value:
        c.error(
            m.line_of("register_map"),
            p,
            f"got {value!r}",
            "a shipped map's name, a path to a map file, or an inline mapping",
        )
        return None
    try:
        file = resolve_map_source(value, base_dir)
    except ConfigError as exc:
        problem, _, allowed = exc.errors[0].removeprefix("register_map: ").partition(" (allowed: ")
        c.error(m.line_of("register_map"), p, problem, allowed.removesuffix(")"))
        return None
    try:
        data = load_yaml(file)
    except ConfigError as exc:
        c.errors.extend(exc.errors)
        return None
    mc = Checker(file)
    rmap = check_register_map(mc, data, getattr(data, "line", 1) or 1, "", file.stem, str(file))
    c.errors.extend(mc.errors)
    return rmap


def check_modbus_drive(c: Checker, m: YamlMap, path: str, base_dir: Path) -> dict[str, Any]:
    """Check the Modbus keys of the drive mapping ``m`` (at key path ``path``, e.g.
    ``axes.z.drive``; files relative to ``base_dir``); problems go to ``c``. Returns the
    ModbusDriveConfig keyword arguments given (``device_id``, ``register_map`` always; the
    others when present): values the register map cannot hold, setup parameters without their
    register and velocity feed-forward without ``target_velocity`` are errors here."""
    out: dict[str, Any] = {}
    if "unit_id" not in m:
        rng = D["unit_id"].range_text()  # type: ignore[attr-defined]
        c.error(m.line, join(path, "unit_id"), "missing", f"an integer in {rng}")
    unit = c.field(m, "unit_id", path, D["unit_id"])
    if unit is not None:
        out["device_id"] = unit
    order = c.field(m, "word_order", path, D["word_order"])
    if order is not None:
        out["word_order"] = order
    rmap = _register_map(c, m, path, Path(base_dir))
    if rmap is not None:
        out["register_map"] = rmap
    cpu = m.get("counts_per_unit", 1.0e6)
    if isinstance(cpu, bool) or not isinstance(cpu, (int, float)) or not cpu > 0:
        cpu = None  # reported by the caller
    for key, unit_name, factor in (
        ("following_error_window", "m", cpu),
        ("following_error_timeout", "s", 1.0),
        ("watchdog", "s", 1.0),
    ):
        if m.get(key) is None:
            continue
        value = c.field(m, key, path, D[key])
        if value is None:
            continue
        out[key] = value
        if rmap is None:
            continue
        r = rmap.get(key)
        if r is None:
            c.error(
                m.line_of(key),
                join(path, key),
                f"the register map {rmap.name!r} has no {key} register",
                f"a map with {key}, or no {key}",
            )
            continue
        if factor is None:
            continue
        mapped = rmap.with_word_order(order)
        try:
            mapped.encode(key, value * factor)
        except RegisterValueError as exc:
            hi = mapped.value_range(key)[1] / factor
            c.error(
                m.line_of(key),
                join(path, key),
                f"got {value:g}: {exc}",
                f"a number up to {hi:.6g} {unit_name}",
            )
    if m.get("requests_in_flight") is not None:
        n = c.field(m, "requests_in_flight", path, D["requests_in_flight"], None)
        if n is not None:
            out["requests_in_flight"] = n
    if "velocity_feed_forward" in m:
        ff = c.field(m, "velocity_feed_forward", path, D["velocity_feed_forward"])
        out["velocity_feed_forward"] = ff
        if ff and rmap is not None and "target_velocity" not in rmap:
            c.error(
                m.line_of("velocity_feed_forward"),
                join(path, "velocity_feed_forward"),
                f"the register map {rmap.name!r} has no target_velocity register",
                "false, or a map with target_velocity",
            )
    return out
