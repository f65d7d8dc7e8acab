"""The shipped Foxglove layout: found by ``coordarm layout``, and everything it plots is in a real log."""
import json
import re

import pytest
from mcap.reader import make_reader

from coordarm.cli import main
from coordarm.commands.layout import layout_path

LINKS = 8


def _channel_fields(path):
    """``{topic: {field: length (0 = scalar)}}`` of a log's ros2msg channels (None for JSON ones), the first
    ``/tf`` and ``/scene`` messages."""
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


@pytest.fixture(scope="module")
def logs(tmp_path_factory):
    """Short real logs of both chain kinds, written by ``coordarm run``: planar ``line`` and spatial ``line3d``."""
    out = {}
    for kind, preset in (("planar", "line"), ("spatial", "line3d")):
        path = tmp_path_factory.mktemp("layout") / f"{preset}.mcap"
        assert main(["run", preset, "--links", str(LINKS), "--duration", "0.2", "--backend", "interpreted",
                     "--no-figures", "--quiet", "--out", str(path)]) == 0
        out[kind] = _channel_fields(path)
    return out


def _panels(node):
    if isinstance(node, str):
        return [node]
    return _panels(node["first"]) + _panels(node["second"])


def _resolves(value, fields):
    """Whether the message path ``/topic.field`` or ``/topic.field[i]`` names a field of a logged channel."""
    topic, field, index = re.fullmatch(r"(/[\w/]+)\.(\w+)(?:\[(\d+)\])?", value).groups()
    if fields.get(topic) is None or field not in fields[topic]:
        return False
    length = fields[topic][field]
    return (index is None) == (length == 0) and (index is None or int(index) < length)


def test_coordarm_layout_prints_the_shipped_file_and_copies_it(tmp_path, capsys):
    assert main(["layout"]) == 0
    assert capsys.readouterr().out.strip() == str(layout_path()) and layout_path().is_file()
    out = tmp_path / "coordarm_layout.json"
    assert main(["layout", "--out", str(out)]) == 0
    assert out.read_bytes() == layout_path().read_bytes()
    assert main(["layout", "--out", str(tmp_path / "missing" / "x.json")]) == 2


def test_every_plotted_path_names_a_field_of_a_planar_or_a_spatial_log(logs):
    layout = json.loads(layout_path().read_text())
    assert sorted(_panels(layout["layout"])) == sorted(layout["configById"])
    plots = {k: c for k, c in layout["configById"].items() if k.startswith(("Plot!", "Indicator!"))}
    assert len(plots) == 5
    shown = {kind: set() for kind in logs}     # the plots that draw something in a log of each kind
    for key, config in plots.items():
        series = config["paths"] if key.startswith("Plot!") else [{"value": config["path"], "enabled": True}]
        for s in series:
            found = {kind for kind, (fields, _, _) in logs.items() if _resolves(s["value"], fields)}
            assert found, s["value"]           # no path that neither kind logs
            if s["enabled"]:
                for kind in found:
                    shown[kind].add(key)
    # every plot but the roll draws in both kinds; the roll (a spatial output) draws in a spatial log
    assert shown["planar"] == set(plots) - {"Plot!roll"} and shown["spatial"] == set(plots)
    # the planar-only and spatial-only margins are in the same plot, beside the smallest link margin of both
    margins = [s["value"] for s in plots["Plot!margins"]["paths"]]
    assert _resolves(margins[0], logs["planar"][0]) and _resolves(margins[0], logs["spatial"][0])
    assert [_resolves(v, logs["spatial"][0]) for v in margins[1:]] == [False, True]
    assert [_resolves(v, logs["planar"][0]) for v in margins[1:]] == [True, False]


def test_the_3d_panel_views_world_in_perspective_where_the_scene_and_the_link_frames_are(logs):
    three_d = json.loads(layout_path().read_text())["configById"]["3D!coordarm"]
    camera = three_d["cameraState"]
    # a perspective view from above (not a flat top view, which hides the spatial chain's z) and not edge-on
    assert three_d["followTf"] == "world" and camera["perspective"] is True and 20 <= camera["phi"] <= 70
    assert three_d["scene"]["transforms"]["visible"] and 0 < three_d["scene"]["transforms"]["axisSize"] <= 0.1
    for fields, tf, scene in logs.values():
        assert set(three_d["topics"]) == {"/scene", "/scene/fixed"} <= set(fields)       # the moving and the fixed
        assert three_d["topics"]["/scene"]["visible"] and three_d["topics"]["/scene/fixed"]["visible"]
        assert tf["transforms"][0]["parent_frame_id"] == "world"
        assert {e["frame_id"] for e in scene["entities"]} == {"world"}
    # the spatial scene is drawn in 3-D: a cylinder per link, a sphere per joint and one for the target
    entity = logs["spatial"][2]["entities"][0]
    assert len(entity["cylinders"]) == LINKS and len(entity["spheres"]) == LINKS + 2


def _keys(cls):
    return set(cls()._to_dict())


def test_every_panel_setting_is_a_field_of_foxglove_sdks_typed_layout_classes():
    """Setting names are spelled as foxglove-sdk's ``foxglove.layouts`` classes (generated by Foxglove) spell them."""
    import foxglove.layouts as fl

    configs = json.loads(layout_path().read_text())["configById"]
    title = {"foxglovePanelTitle"}   # how the app stores a panel's title in configById
    three_d = configs["3D!coordarm"]
    assert set(three_d) <= _keys(fl.ThreeDeeConfig) | title
    assert set(three_d["cameraState"]) <= _keys(fl.ThreeDeeCameraState)
    assert set(three_d["scene"]) <= _keys(fl.BaseRendererSceneSettings)
    assert set(three_d["scene"]["transforms"]) <= _keys(fl.BaseRendererTransforms)
    assert all(set(v) <= _keys(fl.BaseRendererSceneUpdateTopicSettings) for v in three_d["topics"].values())
    assert all(set(v) <= _keys(fl.BaseRendererGridLayerSettings) for v in three_d["layers"].values())
    assert three_d["followMode"] in ("follow-pose", "follow-heading", "follow-position", "follow-none")
    for key, config in configs.items():
        if key.startswith("Plot!"):
            assert set(config) <= _keys(fl.PlotConfig) | title, key
            assert all(set(series) <= _keys(fl.PlotSeries) for series in config["paths"]), key
            assert config["xAxisVal"] == "timestamp" and config["legendDisplay"] in ("top", "left")   # off the data


def test_the_deviations_are_plotted_as_logarithms_that_read_at_every_scale():
    plot = json.loads(layout_path().read_text())["configById"]["Plot!deviation"]
    shown = [p["value"] for p in plot["paths"] if p["enabled"]]
    assert shown == ["/tracking.log10_max_abs_e", "/tracking.log10_abs_s_error"] and plot["yAxisLabel"] == "log10 m"


@pytest.mark.parametrize("preset", ["line", "hole", "pipe", "thread", "path3d"])
def test_layout_for_a_scenario_aims_the_camera_so_that_the_whole_scene_is_in_view(preset, tmp_path):
    """Every drawn point lies inside the view cone of the fitted camera, whatever its azimuth (the cone
    is computed here from the camera's distance, polar angle and vertical field of view)."""
    import math

    import numpy as np

    from coordarm.simulation.scenario import load_scenario
    from coordarm.simulation.scene_view import scene_points

    out = tmp_path / "fitted.json"
    assert main(["layout", "--for", preset, "--out", str(out)]) == 0
    layout = json.loads(out.read_text())
    camera = layout["configById"]["3D!coordarm"]["cameraState"]
    shipped = json.loads(layout_path().read_text())
    # the other panels are the shipped ones, less what draws nothing for this chain kind
    spatial = load_scenario(preset).universal
    kept = {k: v for k, v in shipped["configById"].items() if k != "3D!coordarm" and (spatial or k != "Plot!roll")}
    drop = "/margins.longitudinal" if spatial else "/margins.end_margin"
    kept["Plot!margins"] = {**kept["Plot!margins"],
                            "paths": [s for s in kept["Plot!margins"]["paths"] if s["value"] != drop]}
    assert {k: v for k, v in layout["configById"].items() if k != "3D!coordarm"} == kept
    assert sorted(_panels(layout["layout"])) == sorted(layout["configById"])
    points = scene_points(load_scenario(preset))
    centre = np.array(camera["targetOffset"])
    half = math.radians(camera["fovy"]) / 2
    phi = math.radians(camera["phi"])
    for theta in (0.0, math.pi / 2, 1.0):
        eye = centre + camera["distance"] * np.array([math.sin(phi) * math.cos(theta),
                                                      math.sin(phi) * math.sin(theta), math.cos(phi)])
        axis = (centre - eye) / np.linalg.norm(centre - eye)
        rays = points - eye
        angles = np.arccos(np.clip(rays @ axis / np.linalg.norm(rays, axis=1), -1, 1))
        assert np.max(angles) < 0.8 * half, (preset, np.degrees(np.max(angles)))   # room for a narrow panel
    # frame labels scaled to the scene: 8 % of the radius of the sphere around its box
    radius = 0.5 * np.linalg.norm(np.ptp(points, axis=0))
    assert layout["configById"]["3D!coordarm"]["scene"]["transforms"]["labelSize"] == pytest.approx(0.08 * radius,
                                                                                                     abs=1e-3)
    # aimed at the scene: the box's centre
    np.testing.assert_allclose(centre, 0.5 * (points.min(axis=0) + points.max(axis=0)), atol=1e-3)


def test_layout_for_needs_out_and_a_readable_scene(tmp_path, capsys):
    assert main(["layout", "--for", "thread"]) == 2
    assert "--for" in capsys.readouterr().err
    assert main(["layout", "--for", str(tmp_path / "missing.mcap"), "--out", str(tmp_path / "x.json")]) == 2
