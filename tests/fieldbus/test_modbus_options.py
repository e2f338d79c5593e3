"""The Modbus keys of an axis' drive in a configuration file (``modbus_options``): the keyword
arguments they give a ModbusDriveConfig, and every problem located at its file, line and key
with the allowed values."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest

from motionplc.config import Checker, load_yaml
from motionplc.fieldbus.modbus_drive import ModbusDriveConfig
from motionplc.fieldbus.modbus_options import MODBUS_DRIVE_KEYS, check_modbus_drive
from motionplc.fieldbus.modbus_regmap import RegisterMap

NO_VELOCITY_MAP = """\
format: 1
name: tiny
registers:
  controlword:     {address: 0, type: u16}
  target_position: {address: 1, type: i32}
  statusword:      {address: 10, type: u16}
  position_actual: {address: 11, type: i32}
"""


def check(tmp_path: Path, drive: str) -> tuple[Path, dict[str, Any], list[str]]:
    """``drive`` is the text under ``axes.z.drive:`` (indented by 6); line 4 is its first."""
    cfg = tmp_path / "machine.yaml"
    body = "".join(f"      {line}\n" for line in drive.splitlines())
    cfg.write_text("axes:\n  z:\n    drive:\n" + body, encoding="utf-8")
    data = load_yaml(cfg)
    c = Checker(cfg)
    out = check_modbus_drive(c, data["axes"]["z"]["drive"], "axes.z.drive", tmp_path)
    return cfg, out, c.errors


def test_keys_and_the_config_they_give(tmp_path: Path) -> None:
    assert set(MODBUS_DRIVE_KEYS) == {
        "unit_id",
        "word_order",
        "register_map",
        "following_error_window",
        "following_error_timeout",
        "watchdog",
        "velocity_feed_forward",
        "requests_in_flight",
        "torque_register",  # MC_ReadActualTorque (handled by motionplc.config)
        "rated_torque",
    }
    assert MODBUS_DRIVE_KEYS["unit_id"] and not MODBUS_DRIVE_KEYS["register_map"]
    _, out, errors = check(tmp_path, "bus: mb0\nunit_id: 3")
    assert errors == []
    assert out["device_id"] == 3 and out["register_map"].name == "motionplc-v1"
    assert set(out) == {"device_id", "register_map"}
    (tmp_path / "tiny.yaml").write_text(NO_VELOCITY_MAP, encoding="utf-8")
    _, out, errors = check(
        tmp_path,
        "unit_id: 4\nword_order: little\nregister_map: motionplc-v1\n"
        "following_error_window: 0.002\nfollowing_error_timeout: 0.01\nwatchdog: 0\n"
        "velocity_feed_forward: true\nrequests_in_flight: 2",
    )
    assert errors == []
    cfg = ModbusDriveConfig(port=1502, **out)
    assert cfg.map.word_order == "little" and cfg.watchdog == 0.0 and cfg.velocity_feed_forward
    assert cfg.requests_in_flight == 2
    assert cfg.following_error_window == 0.002 and cfg.following_error_timeout == 0.01
    _, out, errors = check(tmp_path, "unit_id: 4\nregister_map: tiny.yaml")
    assert errors == [] and out["register_map"].name == "tiny"
    assert isinstance(out["register_map"], RegisterMap)
    # inline
    inline = "unit_id: 4\nregister_map:\n" + "".join(
        f"  {x}\n" for x in NO_VELOCITY_MAP.splitlines()
    )
    _, out, errors = check(tmp_path, inline)
    assert errors == [] and out["register_map"].get("position_actual").wire == 11


@pytest.mark.parametrize(
    ("drive", "line", "path", "fragments"),
    [
        ("bus: mb0", 4, "unit_id", ("missing", "allowed: an integer in 1..247")),
        ("unit_id: 0", 4, "unit_id", ("got 0", "1..247")),
        ("unit_id: 248", 4, "unit_id", ("got 248",)),
        ("unit_id: one", 4, "unit_id", ("got string 'one'",)),
        ("unit_id: 1\nword_order: mixed", 5, "word_order", ("allowed: big, little",)),
        ("unit_id: 1\nregister_map: 5", 5, "register_map", ("got 5", "an inline mapping")),
        (
            "unit_id: 1\nregister_map: acme-x",
            5,
            "register_map",
            ("unknown register map 'acme-x'", "allowed: a shipped map (motionplc-v1"),
        ),
        (
            "unit_id: 1\nregister_map: maps/acme.yaml",
            5,
            "register_map",
            ("no such register map file 'maps/acme.yaml'",),
        ),
        (
            "unit_id: 1\nfollowing_error_window: -1",
            5,
            "following_error_window",
            ("got -1", "a number > 0"),
        ),
        (
            "unit_id: 1\nfollowing_error_window: 5000",  # 5e9 counts: not a u32
            5,
            "following_error_window",
            ("got 5000", "following_error_window (u32 at 0x0300", "up to 4294.97 m"),
        ),
        (
            "unit_id: 1\nwatchdog: 70",  # 70000 ms: not a u16
            5,
            "watchdog",
            ("got 70", "70000 is out of range", "up to 65.5355 s"),
        ),
        ("unit_id: 1\nrequests_in_flight: 0", 5, "requests_in_flight", ("1..16",)),
        ("unit_id: 1\nwatchdog: -0.1", 5, "watchdog", ("got -0.1", ">= 0")),
        ("unit_id: 1\nfollowing_error_timeout: 0", 5, "following_error_timeout", ("> 0",)),
        (
            "unit_id: 1\nvelocity_feed_forward: yes please",
            5,
            "velocity_feed_forward",
            ("allowed: true, false",),
        ),
        (
            "unit_id: 1\nregister_map: tiny.yaml\nwatchdog: 0.1",
            6,
            "watchdog",
            ("the register map 'tiny' has no watchdog register",),
        ),
        (
            "unit_id: 1\nregister_map: tiny.yaml\nvelocity_feed_forward: true",
            6,
            "velocity_feed_forward",
            ("no target_velocity register", "allowed: false, or a map with target_velocity"),
        ),
        (
            "unit_id: 1\nregister_map:\n  format: 1\n  registers:\n"
            "    controlword: {address: 0, type: u64}",
            8,
            "register_map.registers.controlword.type",
            ("got string 'u64'", "allowed: u16, i16"),
        ),
    ],
)
def test_errors_are_located(
    tmp_path: Path, drive: str, line: int, path: str, fragments: tuple[str, ...]
) -> None:
    (tmp_path / "tiny.yaml").write_text(NO_VELOCITY_MAP, encoding="utf-8")
    cfg, _, errors = check(tmp_path, drive)
    prefix = f"{cfg}:{line}: axes.z.drive.{path}: "
    found = [e for e in errors if e.startswith(prefix)]
    assert len(found) == 1, errors
    for f in fragments:
        assert f in found[0], (f, found[0])


def test_errors_of_a_map_file_name_that_file(tmp_path: Path) -> None:
    bad = NO_VELOCITY_MAP.replace(
        "type: i32}\n  statusword", "type: i32, table: input}\n  statusword"
    )
    (tmp_path / "bad.yaml").write_text(bad, encoding="utf-8")
    _, out, errors = check(tmp_path, "unit_id: 1\nregister_map: bad.yaml")
    assert errors == [
        f"{tmp_path / 'bad.yaml'}:5: registers.target_position.table: input registers are "
        "read-only; target_position is written (allowed: holding)"
    ]
    assert "register_map" not in out
    (tmp_path / "broken.yaml").write_text("format: 1\nregisters: [\n", encoding="utf-8")
    _, _, errors = check(tmp_path, "unit_id: 1\nregister_map: broken.yaml")
    assert len(errors) == 1 and errors[0].startswith(f"{tmp_path / 'broken.yaml'}:")
    assert "YAML syntax error" in errors[0]
