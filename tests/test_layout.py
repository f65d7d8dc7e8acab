"""The shipped Foxglove layout: found by ``coordarm layout``, and everything it plots is in a real log."""
import json
import re

import pytest
from mcap.reader import make_reader

from coordarm.cli import main
from coordarm.commands.layout import layout_path
from coordarm.simulation.mcap_writer import RunLogger
from coordarm.simulation.run import simulate
from coordarm.simulation.scenario import load_scenario

LINKS = 5


@pytest.fixture(scope="module")
def log(tmp_path_factory):
    scenario = load_scenario("hole").with_overrides(links=LINKS, duration=0.2)
    ctrl = scenario.controller()
    path = tmp_path_factory.mktemp("layout") / "hole.mcap"
    with RunLogger(path, scenario, ctrl) as logger:
        simulate(ctrl, scenario.start(ctrl), scenario.duration, scenario.step, backend="interpreted",
                 on_chunk=logger.on_chunk)
    with open(path, "rb") as f:
        reader = make_reader(f)
        summary = reader.get_summary()
        tf = json.loads(next(m.data for _, _, m in reader.iter_messages(topics=["/tf"])))
        scene = json.loads(next(m.data for _, _, m in make_reader(open(path, "rb")).iter_messages(topics=["/scene"])))
    fields = {}
    for ch in summary.channels.values():
        schema = summary.schemas[ch.schema_id]
        if schema.encoding == "ros2msg":
            fields[ch.topic] = {name: int(n) if n else 0 for n, name in
                                re.findall(r"float64(?:\[(\d+)\])? (\w+)", schema.data.decode())}
        else:
            fields[ch.topic] = None
    return fields, tf, scene


def _panels(node):
    if isinstance(node, str):
        return [node]
    return _panels(node["first"]) + _panels(node["second"])


def test_coordarm_layout_prints_the_shipped_file_and_copies_it(tmp_path, capsys):
    assert main(["layout"]) == 0
    assert capsys.readouterr().out.strip() == str(layout_path()) and layout_path().is_file()
    out = tmp_path / "coordarm_layout.json"
    assert main(["layout", "--out", str(out)]) == 0
    assert out.read_bytes() == layout_path().read_bytes()
    assert main(["layout", "--out", str(tmp_path / "missing" / "x.json")]) == 2


def test_every_plotted_path_names_a_field_of_a_logged_channel(log):
    fields, _, _ = log
    layout = json.loads(layout_path().read_text())
    assert sorted(_panels(layout["layout"])) == sorted(layout["configById"])
    plots = [c for k, c in layout["configById"].items() if k.startswith("Plot!")]
    assert len(plots) == 4
    for config in plots:
        for series in config["paths"]:
            topic, field, index = re.fullmatch(r"(/[\w/]+)\.(\w+)(?:\[(\d+)\])?", series["value"]).groups()
            assert topic in fields and fields[topic] is not None, series["value"]
            assert field in fields[topic], series["value"]
            length = fields[topic][field]
            assert (index is None) == (length == 0) and (index is None or int(index) < length), series["value"]


def test_the_3d_panel_looks_down_on_world_where_the_scene_and_the_link_frames_are(log):
    fields, tf, scene = log
    three_d = json.loads(layout_path().read_text())["configById"]["3D!coordarm"]
    assert three_d["followTf"] == "world" and three_d["cameraState"]["perspective"] is False
    assert set(three_d["topics"]) <= set(fields) and three_d["topics"]["/scene"]["visible"]
    assert tf["transforms"][0]["parent_frame_id"] == "world"
    assert {e["frame_id"] for e in scene["entities"]} == {"world"}
