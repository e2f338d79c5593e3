"""The README's "Connecting real drives" example is a valid configuration (no drift)."""

from __future__ import annotations

import shutil
from pathlib import Path

from motionplc.config import load_config

ROOT = Path(__file__).resolve().parents[2]


def test_readme_real_drives_example_validates(tmp_path: Path) -> None:
    text = (ROOT / "README.md").read_text()
    section = text[text.index("## Connecting real drives") :]
    start = section.index("```yaml") + len("```yaml")
    example = section[start : section.index("```", start)]
    (tmp_path / "drives").mkdir()
    shutil.copy(
        ROOT / "tests/interop/data/modbus_servo_map.yaml", tmp_path / "drives" / "kd40.yaml"
    )
    shutil.copy(
        ROOT / "motionplc/fieldbus/data/motionplc_cia402.eds", tmp_path / "drives" / "servo.eds"
    )
    path = tmp_path / "machine.yaml"
    path.write_text("runtime: {tick: 0.001, tasks: {motion: {period: 0.001}}}\n" + example)
    cfg = load_config(path)
    x, z = cfg.axis("x").drive, cfg.axis("z").drive
    assert x.options["eds"] == str(tmp_path / "drives" / "servo.eds")
    assert [p.kind + str(p.number) for p in x.options["pdos"]] == ["rpdo1", "tpdo1", "tpdo2"]
    assert x.options["master_heartbeat_timeout"] == 0.1
    assert z.options["register_map"].name == "kestrel-kd40"
    assert cfg.bus("can0").interface == "pcan" and cfg.bus("can0").drives == "external"
