"""The campaign file: validation with located errors, the expansion into scenarios."""

from __future__ import annotations

from pathlib import Path

import pytest

from motionplc.campaign import load_campaign
from motionplc.errors import ConfigError
from tests.campaign.conftest import ROOT, write_campaign


def _errors(tmp: Path, body: str) -> str:
    with pytest.raises(ConfigError) as ei:
        load_campaign(write_campaign(tmp, body))
    return str(ei.value)


def test_shipped_example_loads() -> None:
    c = load_campaign(ROOT / "configs/campaigns/demo_faults.yaml")
    assert len(c) == c.grid_points * c.draws > 0
    assert "plant.y.kp" in c.parameters and "faults[0].at" in c.parameters


def test_scenarios_are_a_function_of_seed_and_index(small: Path) -> None:
    a, b = load_campaign(small), load_campaign(small)
    assert len(a) == 4
    assert [a.scenario(i) for i in range(4)] == [b.scenario(i) for i in reversed(range(4))][::-1]
    s = [a.scenario(i) for i in range(4)]
    assert len({x.key for x in s}) == 4
    # the grid: the last path fastest, each point `draws` times
    assert [x.param("program.steps[1].call[0].velocity") for x in s] == [0.1] * 2 + [0.2] * 2
    fe = [x.param("config.axes.x.following_error") for x in s]
    assert all(0.002 <= v <= 0.01 for v in fe) and len(set(fe)) == 4
    for x in s:
        assert (len(x.faults) == 1) == x.param("faults[0].injected")
        if x.faults:
            assert 0.01 <= x.faults[0].at <= 0.15


def test_another_seed_other_draws(tmp_path: Path, small: Path) -> None:
    other = write_campaign(
        tmp_path,
        small.read_text().split("program: short.yaml\n")[1].replace("seed: 7", "seed: 8"),
        "d.yaml",
    )
    a, b = load_campaign(small), load_campaign(other)
    assert a.scenario(0).params != b.scenario(0).params


def test_a_grid_value_refused_by_the_configuration_is_located(tmp_path: Path) -> None:
    text = _errors(tmp_path, "grid:\n  config.axes.x.limits.a_max: [1.0, -2.0]\n")
    assert "c.yaml:4: grid.config.axes.x.limits.a_max[1]: -2.0 is refused" in text
    assert "demo.yaml" in text and "axes.x.limits.a_max" in text and "> 0" in text


def test_distribution_bounds_are_checked_by_the_sequence_validator(tmp_path: Path) -> None:
    text = _errors(tmp_path, "random:\n  program.steps[1].call[0].velocity: {uniform: [-1, 1]}\n")
    assert "c.yaml:4: random.program.steps[1].call[0].velocity: -1.0 is refused" in text


def test_paths_that_name_nothing(tmp_path: Path) -> None:
    text = _errors(
        tmp_path,
        "grid:\n  config.axes.z.limits.a_max: [1.0]\n  program.steps[9].name: [a]\n"
        "  plant.x.stiffness: [1]\n  velocity: [1]\n",
    )
    assert (
        "c.yaml:4: grid.config.axes.z.limits.a_max[0]: 1.0 is refused: demo.yaml: axes.z: no"
        in text
    )
    assert "steps[9]: no item 9" in text
    assert "no plant parameter 'stiffness'" in text
    assert "grid.velocity: not a parameter path" in text


def test_faults_are_checked(tmp_path: Path) -> None:
    text = _errors(
        tmp_path,
        "faults:\n  - {fault: drive, axis: z, at: 0.1}\n  - {fault: melt, axis: x, at: 0}\n"
        "  - {fault: load_step, axis: x, at: -1}\n  - {fault: bus_off, axis: x, at: 0.1, "
        "code: 5}\n",
    )
    assert "faults[0].axis: no axis 'z' (axes: x, y)" in text
    assert "faults[1].fault: got string 'melt'" in text
    assert "faults[2].value: missing" in text and "faults[2].at: got -1" in text
    assert "faults[3].code: not used by a bus_off fault" in text


def test_distributions_are_checked(tmp_path: Path) -> None:
    text = _errors(
        tmp_path,
        "random:\n  config.axes.x.following_error: {uniform: [2, 1]}\n"
        "  config.axes.y.following_error: {uniform: [1, 2], choice: [1]}\n"
        "  config.runtime.tick: {normal: [0.001, -1]}\n",
    )
    assert "random.config.axes.x.following_error.uniform: lo 2 > hi 1" in text
    assert "uniform and choice together" in text
    assert "standard deviation -1" in text


def test_unknown_keys_and_missing_files(tmp_path: Path) -> None:
    p = tmp_path / "bad.yaml"
    p.write_text("config: nowhere.yaml\ndraw: 3\n", encoding="utf-8")
    with pytest.raises(ConfigError) as ei:
        load_campaign(p)
    text = str(ei.value)
    assert "bad.yaml:2: (top level).draw: unknown key" in text
    assert "bad.yaml:1: config: no such file" in text


def test_scheduler_must_be_loopback(tmp_path: Path) -> None:
    text = _errors(tmp_path, "execution: {scheduler: 'tcp://10.0.0.1:8786'}\n")
    assert "execution.scheduler" in text and "127.0.0.1" in text


def test_shipped_example_is_valid_for_the_json_schema() -> None:
    import jsonschema

    from motionplc.config import load_yaml
    from motionplc.schema.campaign import CAMPAIGN
    from motionplc.schema.render import to_json_schema
    from tests.schema.walk import plain

    s = to_json_schema(CAMPAIGN)
    jsonschema.Draft202012Validator.check_schema(s)
    v = jsonschema.Draft202012Validator(s)
    assert not list(v.iter_errors(plain(load_yaml(ROOT / "configs/campaigns/demo_faults.yaml"))))
    assert not v.is_valid({"config": "a.yaml", "grid": {"velocity": [1]}})  # not a path
    assert not v.is_valid({"config": "a.yaml", "faults": [{"fault": "melt", "axis": "x", "at": 0}]})
