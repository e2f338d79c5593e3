"""Reference texts a user reads (issue 30 point 6): PDO objects in hexadecimal, the heartbeat
defaults stated (and equal to the drive's), ``transition_mode`` documented on the moves it acts
on, and a mistyped key reported once, as the root cause."""

from __future__ import annotations

import dataclasses
import re
from pathlib import Path

import pytest

from motionplc.config import load_config
from motionplc.errors import ConfigError
from motionplc.schema import reference_markdown

ROOT = Path(__file__).resolve().parents[2]


def test_pdo_objects_in_hex() -> None:
    page = reference_markdown("config")
    rows = [r for r in page.splitlines() if r.startswith("| `objects` |")]
    assert len(rows) == 8  # RPDO 1-4, TPDO 1-4
    for row in rows:
        assert re.search(r"one of `0x6040`|one of `0x6041`", row), row
        assert not re.search(r"`2\d{4}`", row), row  # no decimal index (24640 = 0x6040)


def test_heartbeat_defaults_are_the_drives() -> None:
    from motionplc.fieldbus.canopen_drive import CanopenDriveConfig

    defaults = {f.name: f.default for f in dataclasses.fields(CanopenDriveConfig)}
    page = reference_markdown("config")
    (producer,) = [r for r in page.splitlines() if r.startswith("| `producer` |")]
    (consumer,) = [r for r in page.splitlines() if r.startswith("| `consumer` |")]
    assert producer.split(" | ")[2].startswith(f"{defaults['heartbeat_period']:g} (")
    assert consumer.split(" | ")[2].startswith(f"{defaults['master_heartbeat_timeout']:g} (off)")


def test_transition_mode_on_the_moves_that_take_it() -> None:
    page = reference_markdown("sequence")
    sections = re.split(r"\n### `type: ", page)
    texts = {}
    for sec in sections[1:]:
        name = sec.split("`", 1)[0]
        for row in sec.splitlines():
            if row.startswith("| `transition_mode` |"):
                texts[name] = row.split(" | ")[3]
    blended = {"MC_MoveLinearAbsolute", "MC_MoveLinearRelative"}
    blended |= {"MC_MoveCircularAbsolute", "MC_MoveCircularRelative"}
    at_rest = {"MC_MoveDirectAbsolute", "MC_MoveDirectRelative"}
    at_rest |= {"MC_MovePassingPoints", "MC_MoveBSpline"}
    assert set(texts) == blended | at_rest
    for fb in blended:
        assert texts[fb].startswith("The corner between the move before and this one"), fb
    for fb in at_rest:
        assert texts[fb].startswith("Accepted as PLCopen defines it, without effect"), fb
    assert "next path move" not in page


def test_a_mistyped_axis_key_is_reported_once(tmp_path: Path) -> None:
    text = (ROOT / "configs" / "gantry.yaml").read_text(encoding="utf-8")
    old = "    limits: {v_max: 1.0, a_max: 4.0"
    assert old in text
    cfg = tmp_path / "g.yaml"
    cfg.write_text(text.replace(old, "    limts: {v_max: 1.0, a_max: 4.0", 1))
    with pytest.raises(ConfigError) as exc:
        load_config(cfg)
    lines = str(exc.value).splitlines()
    assert len(lines) == 1, lines  # not also "limits: missing" and "unknown axis 'x'"
    assert re.search(
        r"g\.yaml:\d+: axes\.x\.limts: unknown key \(did you mean 'limits'\? a required key\)",
        lines[0],
    )
