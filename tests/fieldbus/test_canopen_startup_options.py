"""The YAML options of a CANopen drive (``canopen_options.check_canopen_drive``)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest

from motionplc.config import Checker, load_yaml
from motionplc.fieldbus.canopen_drive import CanopenDriveConfig, PdoSpec, ScalingSpec
from motionplc.fieldbus.canopen_options import CANOPEN_DRIVE_KEYS, check_canopen_drive
from motionplc.fieldbus.virtual_cia402 import eds_path


def parse(tmp_path: Path, text: str, **kw: Any) -> tuple[dict[str, Any], list[str]]:
    f = tmp_path / "axis.yaml"
    f.write_text("drive:\n" + "".join(f"  {line}\n" for line in text.strip("\n").split("\n")))
    doc = load_yaml(f)
    c = Checker(f)
    out = check_canopen_drive(c, doc["drive"], "axes.x.drive", base_dir=tmp_path, **kw)
    return out, [e.split(": ", 1)[1] for e in c.errors]


def test_full_example_gives_config_arguments(tmp_path: Path) -> None:
    (tmp_path / "servo.eds").write_text(eds_path().read_text())
    out, errors = parse(
        tmp_path,
        """
eds: servo.eds
heartbeat: {consumer: 0.2}
node_guarding: {guard_time: 0.1, life_time_factor: 4}
pdo:
  rpdo1: {objects: [0x6040, 0x607A], cob_id: 0x201, transmission: 1}
  tpdo1: {objects: [0x6041, "0x6064"]}
  tpdo2: {objects: ["0x606C:0", {index: 0x603F, optional: true}], transmission: 2}
scaling: {encoder_resolution: [4096, 1], gear_ratio: [10, 1], feed_constant: [5000, 1], polarity: 0}
mode_timeout: 0.3
setup_timeout: 1.5
following_error_timeout: 0.01
""",
        following_error_window=0.002,
    )
    assert errors == []
    assert out == {
        "eds": str(tmp_path / "servo.eds"),
        "guard_time": 0.1,
        "heartbeat_period": 0.0,
        "life_time_factor": 4,
        "master_heartbeat_timeout": 0.2,
        "pdos": (
            PdoSpec("rpdo", 1, ((0x6040, 0, False), (0x607A, 0, False)), 0x201, 1),
            PdoSpec("tpdo", 1, ((0x6041, 0, False), (0x6064, 0, False)), None, 1),
            PdoSpec("tpdo", 2, ((0x606C, 0, False), (0x603F, 0, True)), None, 2),
        ),
        "scaling_objects": ScalingSpec((4096, 1), (10, 1), (5000, 1), 0),
        "mode_timeout": 0.3,
        "setup_timeout": 1.5,
        "following_error_window": 0.002,
        "following_error_timeout": 0.01,
    }
    cfg = CanopenDriveConfig(node_id=1, **out)  # accepted as is
    assert cfg.layout()[2].trans_type == 2
    assert set(CANOPEN_DRIVE_KEYS) >= {
        "eds",
        "heartbeat",
        "node_guarding",
        "pdo",
        "scaling",
        "mode_timeout",
        "setup_timeout",
        "following_error_window",
        "following_error_timeout",
    }


def test_scaling_read_and_heartbeat_producer(tmp_path: Path) -> None:
    out, errors = parse(tmp_path, "scaling: read\nheartbeat: {producer: 0.02}")
    assert errors == []
    assert out == {"scaling_objects": "read", "heartbeat_period": 0.02}


@pytest.mark.parametrize(
    ("text", "error"),
    [
        (
            "eds: nothere.eds",
            "axes.x.drive.eds: no such file: {tmp}/nothere.eds (allowed: an EDS file)",
        ),
        (
            "node_guarding: {guard_time: 0.1}\nheartbeat: {producer: 0.05}",
            "axes.x.drive.heartbeat.producer: heartbeat.producer and node_guarding are exclusive "
            "(allowed: one of them)",
        ),
        (
            "node_guarding: {guard_time: 0.1, life_time_factor: 0}",
            "axes.x.drive.node_guarding.life_time_factor: got 0 (allowed: an integer in 1..255)",
        ),
        (
            "pdo: {tpdo1: {objects: [0x6040]}}",
            "axes.x.drive.pdo.tpdo1.objects[0]: object 0x6040 cannot be mapped in a TPDO "
            "(allowed: 0x6041, 0x6064, 0x606C, 0x603F, 0x60F4, 0x6061)",
        ),
        (
            "pdo: {tpdo5: {objects: [0x6041]}}",
            "axes.x.drive.pdo.tpdo5: unknown key (allowed: rpdo1..rpdo4, tpdo1..tpdo4)",
        ),
        (
            'pdo: {tpdo1: {objects: ["x6041"]}}',
            "axes.x.drive.pdo.tpdo1.objects[0]: got string 'x6041' (allowed: an index (0x6041 or "
            '"0x6041"), "index:sub", or {index, sub, optional})',
        ),
        (
            "pdo: {rpdo1: {objects: [0x6040, 0x607A]}, tpdo1: {objects: [0x6041, 0x6064, 0x606C]}}",
            "axes.x.drive.pdo.tpdo1: tpdo1: 80 bits exceed the 64-bit limit of a PDO",
        ),
        (
            "pdo: {rpdo1: {objects: [0x6040]}, tpdo1: {objects: [0x6041, 0x6064]}}",
            "axes.x.drive.pdo: no RPDO carries 0x607A (target position, required)",
        ),
        (
            "pdo: {rpdo1: {objects: [0x6040, 0x607A], transmission: 255},"
            " tpdo1: {objects: [0x6041, 0x6064]}}",
            "axes.x.drive.pdo.rpdo1.transmission: got 255 (allowed: an integer in 1..240)",
        ),
        (
            "pdo: {rpdo1: {objects: [0x6040, 0x607A], cob_id: 0x800},"
            " tpdo1: {objects: [0x6041, 0x6064]}}",
            "axes.x.drive.pdo.rpdo1.cob_id: got 2048 (allowed: an integer in 1..2047)",
        ),
        (
            "scaling: {gear_ratio: [10, 0]}",
            "axes.x.drive.scaling.gear_ratio: got [10, 0] (allowed: [numerator, denominator], "
            "integers in 1..4294967295)",
        ),
        (
            "scaling: readback",
            "axes.x.drive.scaling: got 'readback' (allowed: read, or a mapping of scaling objects)",
        ),
        (
            "mode_timeout: -1",
            "axes.x.drive.mode_timeout: got -1 (allowed: a number >= 0 and <= 60)",
        ),
    ],
)
def test_errors_name_the_key_and_the_allowed_values(tmp_path: Path, text: str, error: str) -> None:
    out, errors = parse(tmp_path, text)
    assert errors == [error.replace("{tmp}", str(tmp_path))]
