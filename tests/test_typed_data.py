"""Typed data: the scenario's tables as frozen objects, the choice enums, the number tests."""
import dataclasses
import json
import tomllib
from importlib import resources

import numpy as np
import pytest

from coordarm.simulation.choices import BACKENDS, COMPRESSIONS, Backend, Compression, Outcome
from coordarm.simulation.mcap_writer import RunLogger
from coordarm.simulation.outcome import outcome_of
from coordarm.simulation.scenario import load_scenario, presets
from coordarm.symbolic import ConfigError, SingularityError
from coordarm.symbolic.checks import is_integer, is_real
from coordarm.symbolic.laws import LAWS, Law


def preset_data(name):
    return tomllib.loads((resources.files("coordarm.simulation") / "presets" / f"{name}.toml").read_text())


@pytest.mark.parametrize("name", ["line", "arc", "hole", "pipe", "thread"])
def test_typed_tables_hold_the_values_of_the_file(name):
    data, config = preset_data(name), load_scenario(name).config
    assert config.name == data["name"] and config.description == data["description"]
    assert (config.chain.links, config.chain.link_length) == (data["chain"]["links"], data["chain"]["link_length"])
    assert config.chain.base == data["chain"].get("base")
    assert config.control.gain == data["control"]["gain"] and config.control.speed == data["control"].get("speed")
    assert config.control.law == data["control"].get("law", "structured")
    assert config.start.kind == data.get("start", {}).get("kind", "zigzag")
    assert (config.run.duration, config.run.step) == (data["run"]["duration"], data["run"]["step"])
    assert config.curve == data["curve"] and len(config.obstacles) == len(data.get("obstacles", []))
    panels = data.get("figures", {}).get("panels")
    assert (config.figures.panels is None) == (panels is None)
    if panels:
        assert [(p.title, p.stages) for p in config.figures.panels] == [(p["title"], p["stages"]) for p in panels]


def test_an_integer_stays_an_integer_in_the_stored_json():
    sc = load_scenario("line").with_overrides(links=8)
    data = json.loads(sc.to_json())
    assert data["chain"]["links"] == 8 and isinstance(data["chain"]["links"], int)
    assert json.dumps(data["control"]["gain"]) == "2.0"    # as the file wrote it: 2.0, not 2


def test_a_scenario_is_frozen_and_its_spec_a_fresh_copy():
    sc = load_scenario("line")
    with pytest.raises(dataclasses.FrozenInstanceError):
        sc.config.chain.links = 3
    spec = sc.spec
    spec["chain"]["links"] = 3
    assert sc.spec["chain"]["links"] == 64 and sc.chain().m == 64


def test_enum_members_are_their_strings():
    assert LAWS == ("structured", "dense") and [type(v) for v in LAWS] == [str, str]
    assert BACKENDS == ("auto", "compiled", "interpreted") and COMPRESSIONS == ("lz4", "none", "zstd")
    assert Law.DENSE == "dense" and f"{Backend.AUTO}" == "auto" and json.dumps(Compression.ZSTD) == '"zstd"'
    assert json.dumps({"status": Outcome.COLLISION}) == '{"status": "collision"}'


def test_the_log_outcome_statuses_are_the_outcome_values():
    assert outcome_of(None, 1.0)["status"] == "completed"
    err = SingularityError(1.0, 3, 0.01, "link", 0.02)
    assert outcome_of(err, 1.0)["status"] == "singularity"
    assert outcome_of(KeyboardInterrupt(), 1.0)["status"] == "interrupted"
    assert outcome_of(RuntimeError("x"), 1.0)["status"] == "error"


@pytest.mark.parametrize("value,real,integer", [
    (1, True, True), (-2.5, True, False), (2.0, True, False), (np.float64(0.5), True, False),
    (True, False, False), (False, False, False), ("1", False, False), (None, False, False), ([1], False, False)])
def test_real_and_integer_exclude_bools(value, real, integer):
    assert is_real(value) is real and is_integer(value) is integer


def test_numpy_scalars_are_numbers_only_when_asked():
    assert not is_integer(np.int64(3)) and is_integer(np.int64(3), numpy=True)
    assert not is_real(np.float32(0.5)) and is_real(np.float32(0.5), numpy=True)
    assert not is_real(np.bool_(True), numpy=True) and not is_integer(np.bool_(True), numpy=True)


def test_run_logger_refuses_an_unknown_keyword_before_creating_a_file(tmp_path):
    path = tmp_path / "x.mcap"
    with pytest.raises(TypeError):
        RunLogger(path, load_scenario("line"), log_rat=10.0)
    assert list(tmp_path.iterdir()) == []


def test_every_preset_names_a_valid_law():
    for name in presets():
        assert load_scenario(name).config.control.law in list(Law)
    with pytest.raises(ConfigError, match="control.law"):
        load_scenario("line").with_overrides(law="sparse")
