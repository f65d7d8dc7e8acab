"""Scenario files: presets, validation with named fields, and fuzzing of the TOML loader."""
import json
import string

import pytest
from hypothesis import given
from hypothesis import strategies as st

from coordarm.simulation.scenario import Scenario, load_scenario, presets
from coordarm.symbolic import ConfigError

from importlib import resources


def preset_text(name):
    return (resources.files("coordarm.simulation") / "presets" / f"{name}.toml").read_text()


def test_presets_are_the_papers_three_scenarios_and_load():
    assert presets() == ["arc", "hole", "line", "line3d", "path3d", "pipe", "pipe3d", "port", "thread"]
    assert load_scenario("line").chain().m == 64 and load_scenario("arc").chain().m == 64
    hole = load_scenario("hole")
    assert hole.chain().m == 50 and [o.name for o in hole.obstacles] == [f"wall {i}" for i in range(1, 6)]
    for name in presets():
        assert load_scenario(name).spec["description"]


@pytest.mark.parametrize("name", ["line", "arc", "hole"])
def test_scenario_json_round_trips(name):
    sc = load_scenario(name)
    again = Scenario.from_dict(json.loads(sc.to_json()))
    assert again.spec == sc.spec and [o.to_spec() for o in again.obstacles] == [o.to_spec() for o in sc.obstacles]


def test_overrides_change_links_duration_and_step():
    sc = load_scenario("line").with_overrides(links=16, duration=1.5, step=0.002)
    assert (sc.chain().m, sc.duration, sc.step) == (16, 1.5, 0.002)
    with pytest.raises(ConfigError, match="chain.links"):
        load_scenario("line").with_overrides(links=0)


def write(tmp_path, text):
    p = tmp_path / "s.toml"
    p.write_text(text)
    return p


@pytest.mark.parametrize("old,new,match", [
    ("links = 64", "links = 0", "chain.links"), ("links = 64", "links = 6.5", "chain.links"),
    ("link_length = 0.1", "link_length = -0.1", "chain.link_length"),
    ("link_length = 0.1", "link_length = nan", "chain.link_length"),
    ("gain = 2.0", "gain = 0.0", "control.gain"), ("gain = 2.0", "gain = -inf", "control.gain"),
    ('kind = "line"', 'kind = "spiral"', "curve.kind"),
    ("speed = 0.1", 'speed = "__import__(\'os\').system(\'true\')"', "control.speed"),
    ("amplitude = 0.6", "amplitude = nan", "curve.angle"),
    ("duration = 20.0", "duration = 0", "run.duration"), ("step = 0.001", "step = 50.0", "run.step"),
    ("beta = 1.3", "beta = 1.6", "start.beta"), ('kind = "zigzag"', 'kind = "random"', "start.kind"),
    ("[run]", "[runn]", "unknown section"), ("heading = 0.0", "headin = 0.0", "unknown key"),
])
def test_invalid_fields_are_named_with_the_file(tmp_path, old, new, match):
    text = preset_text("line")
    assert old in text
    p = write(tmp_path, text.replace(old, new, 1))
    with pytest.raises(ConfigError, match=match) as info:
        load_scenario(p)
    assert str(p) in str(info.value)


def test_unreadable_or_unknown_sources_are_config_errors(tmp_path):
    with pytest.raises(ConfigError, match="neither a preset"):
        load_scenario(tmp_path / "missing.toml")
    with pytest.raises(ConfigError, match="not valid TOML"):
        load_scenario(write(tmp_path, "[chain\nlinks = 3"))
    bad = tmp_path / "bin.toml"
    bad.write_bytes(b"\xff\xfe\x00garbage")
    with pytest.raises(ConfigError, match="bin.toml"):
        load_scenario(bad)


@given(st.text(alphabet=string.printable, max_size=300))
def test_fuzzed_text_loads_or_raises_a_config_error(tmp_path_factory, text):
    p = tmp_path_factory.mktemp("fuzz") / "f.toml"
    p.write_text(text)
    try:
        load_scenario(p)
    except ConfigError:
        pass


@given(st.data())
def test_mutated_presets_load_or_raise_a_config_error(tmp_path_factory, data):
    text = preset_text(data.draw(st.sampled_from(["line", "arc", "hole"])))
    i = data.draw(st.integers(0, len(text) - 1))
    j = data.draw(st.integers(i, min(len(text), i + 20)))
    junk = data.draw(st.text(alphabet=string.printable, max_size=12))
    p = tmp_path_factory.mktemp("mut") / "m.toml"
    p.write_text(text[:i] + junk + text[j:])
    try:
        sc = load_scenario(p)
        sc.controller()
    except ConfigError:
        pass


values = st.one_of(st.none(), st.booleans(), st.integers(-5, 100), st.floats(allow_nan=True),
                   st.text(max_size=5), st.lists(st.floats(-2, 2), max_size=3),
                   st.dictionaries(st.sampled_from(["kind", "start", "rate", "a"]), st.floats(-2, 2), max_size=3))


@given(section=st.sampled_from(["chain", "curve", "control", "start", "run", "thresholds"]),
       key=st.sampled_from(["links", "link_length", "kind", "point", "angle", "radius", "gain", "speed", "law",
                            "beta", "heading", "curve", "duration", "step", "t0", "link", "longitudinal"]),
       value=values)
def test_random_field_values_load_or_raise_a_config_error(section, key, value):
    spec = load_scenario("line").spec
    spec.setdefault(section, {})[key] = value
    try:
        Scenario.from_dict(spec).controller()
    except ConfigError:
        pass


@pytest.mark.parametrize("name", presets())
def test_a_presets_description_quotes_its_own_link_count_and_fold_angle(name):
    """The description ``coordarm init`` copies and the docs list says ``N links`` and ``beta = X`` only as
    the keys have them (path3d's said 48 links and beta = 0.6 while the keys had 80 and 0.68)."""
    import re

    sc = load_scenario(name)
    text = sc.spec["description"]
    links = [int(n) for n in re.findall(r"(\d+) links", text)]
    betas = [float(b) for b in re.findall(r"beta = ([0-9.]*[0-9])", text)]
    assert all(n == sc.spec["chain"]["links"] for n in links), (links, sc.spec["chain"]["links"])
    assert all(b == sc.spec["start"]["beta"] for b in betas), (betas, sc.spec["start"]["beta"])
