"""Small campaigns on the demo machine: a short sequence (power on, one move of x) so that a
scenario is a few hundred cycles."""

from __future__ import annotations

from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
DEMO = ROOT / "configs" / "demo.yaml"

SEQUENCE = """\
timeout: 2
steps:
  - name: power on
    call:
      - {block: pwr_x, type: MC_Power, axis: x, enable: true}
      - {block: pwr_y, type: MC_Power, axis: y, enable: true}
    until: {done: [pwr_x, pwr_y]}
    timeout: 1.0
  - name: move
    call:
      - {block: mx, type: MC_MoveAbsolute, axis: x, position: 0.02, velocity: 0.2}
    until: {done: mx}
    expect: {x.position: 0.02, within: 1.0e-9}
"""


def write_campaign(tmp: Path, body: str, name: str = "c.yaml") -> Path:
    (tmp / "short.yaml").write_text(SEQUENCE, encoding="utf-8")
    p = tmp / name
    p.write_text(f"config: {DEMO}\nprogram: short.yaml\n" + body, encoding="utf-8")
    return p


SMALL = """\
seed: 7
draws: 2
grid:
  program.steps[1].call[0].velocity: [0.1, 0.2]
random:
  config.axes.x.following_error: {uniform: [0.002, 0.01]}
faults:
  - {fault: drive, axis: x, at: {uniform: [0.01, 0.15]}, probability: 0.5}
verdict: {program: unless_fault, reaction_time: 0.01}
"""


@pytest.fixture
def small(tmp_path: Path) -> Path:
    return write_campaign(tmp_path, SMALL)
