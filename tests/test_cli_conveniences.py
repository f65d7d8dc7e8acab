"""``coordarm init PRESET FILE`` and ``coordarm run --set NAME=VALUE``."""
import tomllib

import pytest

from coordarm.cli import main
from coordarm.simulation.overrides import parse_setting, with_settings
from coordarm.simulation.scenario import Scenario, load_scenario
from coordarm.symbolic import ConfigError


def test_init_writes_the_preset_toml_which_loads_as_the_preset(tmp_path, capsys):
    out = tmp_path / "mine.toml"
    assert main(["init", "thread", str(out)]) == 0
    assert capsys.readouterr().out.strip() == str(out)
    assert load_scenario(str(out)).spec == load_scenario("thread").spec
    assert out.read_text().startswith('name = "thread"')     # the preset's text, comments and all
    assert main(["init", "thread", str(out)]) == 2 and "exists" in capsys.readouterr().err
    assert main(["init", "thread", str(out), "--overwrite"]) == 0
    assert main(["init", "nope", str(tmp_path / "x.toml")]) == 2 and "not a preset" in capsys.readouterr().err


def test_set_changes_the_named_fields_as_an_edited_toml_would(tmp_path):
    path = tmp_path / "hole.toml"
    assert main(["init", "hole", str(path)]) == 0
    data = tomllib.loads(path.read_text())      # the same change made by hand in the data
    data["control"]["speed"] = 0.05
    data["chain"]["links"] = 20
    data["control"]["governor"] = True
    by_hand = Scenario.from_dict(data, "by hand")
    got = with_settings(load_scenario(str(path)), ["control.speed=0.05", "links=20", "control.governor=true"])
    assert got.spec == by_hand.spec and got.name == "hole"
    assert with_settings(by_hand, []) is by_hand


@pytest.mark.parametrize("text, message", [
    ("nogood", "expected NAME=VALUE"), ("links=1,2", "one value per setting"), ("links=1:4:4", "one value"),
    ("=3", "expected NAME=VALUE"), ("control.speedx=1", "not a field")])
def test_a_bad_setting_is_one_error_naming_set(text, message):
    with pytest.raises(ConfigError, match=message) as info:
        with_settings(load_scenario("hole"), [text])
    assert str(info.value).startswith("--set") and "--vary" not in str(info.value).partition("sweep")[0]


def test_a_value_the_scenario_refuses_names_set_and_the_field():
    with pytest.raises(ConfigError, match=r"^--set: control.gain: need a finite number"):
        with_settings(load_scenario("hole"), ["control.gain=abc"])
    assert parse_setting("control.gain=2.5") == ("control.gain", 2.5)


def test_run_set_reaches_the_run(tmp_path, capsys):
    out = tmp_path / "h.mcap"
    assert main(["run", "hole", "--set", "links=7", "--duration", "0.05", "--backend", "interpreted",
                 "--no-figures", "--out", str(out)]) == 0
    assert "7 links" in capsys.readouterr().out
