"""What Foxglove reads from a log: official schemas, the scene, the link frames, the target."""
import json
import math

import jsonschema
import numpy as np

from coordarm.simulation.obstacles import outline
import pytest
from google.protobuf import descriptor_pb2
from mcap.reader import make_reader

from coordarm.simulation.log_schemas import foxglove_schema
from coordarm.simulation.mcap_writer import RunLogger
from coordarm.simulation.run import simulate
from coordarm.simulation.scenario import load_scenario
from coordarm.simulation.scene import _targets, link_frames, margin_colours, obstacle_outlines, point_along

LINKS, DURATION = 6, 0.6


def _log(name, tmp_path_factory, links=LINKS, duration=DURATION, frames="ends", **overrides):
    scenario = load_scenario(name).with_overrides(links=links, duration=duration, **overrides)
    ctrl = scenario.controller()
    path = tmp_path_factory.mktemp("fox") / f"{name}.mcap"
    with RunLogger(path, scenario, ctrl, chunk_size=16 * 1024, command=["test"], frames=frames) as log:
        run = simulate(ctrl, scenario.start(ctrl), scenario.duration, scenario.step, scenario.t0,
                       backend="interpreted", chunk=97, on_chunk=log.on_chunk)
    return path, run, scenario


@pytest.fixture(scope="module")
def hole(tmp_path_factory):
    return _log("hole", tmp_path_factory)


@pytest.fixture(scope="module")
def hole_all_frames(tmp_path_factory):
    return _log("hole", tmp_path_factory, frames="all")


@pytest.fixture(scope="module")
def arc(tmp_path_factory):
    return _log("arc", tmp_path_factory)


@pytest.fixture(scope="module")
def thread(tmp_path_factory):
    return _log("thread", tmp_path_factory, links=60, duration=0.3)


def _messages(path, topic):
    with open(path, "rb") as f:
        return [(msg.log_time, msg.data) for _, _, msg in make_reader(f).iter_messages(topics=[topic])]


def _stored_schema(path, name):
    with open(path, "rb") as f:
        return next(s for s in make_reader(f).get_summary().schemas.values() if s.name == name)


# ------------------------------------------------------------- the shipped schemas are the official ones
_PROTO_SCALARS = {1: "number", 2: "number", 3: "integer", 4: "integer", 5: "integer", 8: "boolean", 9: "string",
                  12: "string", 13: "integer", 7: "integer"}   # descriptor_pb2.FieldDescriptorProto.Type


def _same_message(js, messages, enums, type_name, where):
    """The JSON Schema ``js`` describes the protobuf message ``type_name`` field for field."""
    if type_name in (".google.protobuf.Timestamp", ".google.protobuf.Duration"):  # foxglove time / duration
        assert js["type"] == "object" and set(js["properties"]) == {"sec", "nsec"}, where
        return
    msg = messages[type_name]
    assert js["type"] == "object" and js["title"] == type_name[1:], where
    assert set(js["properties"]) == {f.name for f in msg.field}, where
    for f in msg.field:
        sub, at = js["properties"][f.name], f"{where}.{f.name}"
        if f.label == descriptor_pb2.FieldDescriptorProto.LABEL_REPEATED:
            assert sub["type"] == "array", at
            sub = sub["items"]
        if f.type == descriptor_pb2.FieldDescriptorProto.TYPE_MESSAGE:
            _same_message(sub, messages, enums, f.type_name, at)
        elif f.type == descriptor_pb2.FieldDescriptorProto.TYPE_ENUM:
            assert sorted(alt["const"] for alt in sub["oneOf"]) == sorted(enums[f.type_name]), at
        else:
            assert sub["type"] == _PROTO_SCALARS[f.type], at


@pytest.mark.parametrize("name", ["SceneUpdate", "FrameTransforms"])
def test_shipped_json_schemas_match_the_foxglove_sdk_message_definitions(name):
    """The shipped JSON Schema and foxglove-sdk's protobuf descriptors (a separate artefact) agree."""
    import foxglove.messages

    schema = getattr(foxglove.messages, name).get_schema()
    assert schema.name == f"foxglove.{name}" and schema.encoding == "protobuf"
    files = descriptor_pb2.FileDescriptorSet.FromString(bytes(schema.data)).file
    messages, enums = {}, {}
    for file in files:
        def walk(msg, prefix):
            messages[f"{prefix}.{msg.name}"] = msg
            for e in msg.enum_type:
                enums[f"{prefix}.{msg.name}.{e.name}"] = [v.number for v in e.value]
            for sub in msg.nested_type:
                walk(sub, f"{prefix}.{msg.name}")
        for msg in file.message_type:
            walk(msg, f".{file.package}")
        for e in file.enum_type:
            enums[f".{file.package}.{e.name}"] = [v.number for v in e.value]
    shipped = foxglove_schema(f"foxglove.{name}")
    jsonschema.Draft202012Validator.check_schema(shipped)
    _same_message(shipped, messages, enums, f".foxglove.{name}", name)


def test_a_schema_with_bare_object_items_is_refused_by_the_comparison():
    """The check above fails on the old hand-written schema's kind of mistake (``items: {type: object}``)."""
    import foxglove.messages

    broken = json.loads(json.dumps(foxglove_schema("foxglove.SceneUpdate")))
    broken["properties"]["entities"]["items"]["properties"]["cubes"]["items"] = {"type": "object"}
    files = descriptor_pb2.FileDescriptorSet.FromString(bytes(foxglove.messages.SceneUpdate.get_schema().data)).file
    messages = {f".{f.package}.{m.name}": m for f in files for m in f.message_type}
    enums = {f".{f.package}.{m.name}.{e.name}": [v.number for v in e.value]
             for f in files for m in f.message_type for e in m.enum_type}
    with pytest.raises((AssertionError, KeyError)):
        _same_message(broken, messages, enums, ".foxglove.SceneUpdate", "SceneUpdate")


# ------------------------------------------------------------------------------- the scene
def test_every_scene_message_validates_and_draws_arm_curve_target_and_walls(hole):
    path, run, scenario = hole
    stored = _stored_schema(path, "foxglove.SceneUpdate")
    assert stored.encoding == "jsonschema"
    schema = json.loads(stored.data)
    assert schema == foxglove_schema("foxglove.SceneUpdate")
    validator = jsonschema.Draft202012Validator(schema)
    chain, ctrl = scenario.chain(), scenario.controller()
    scenes = _messages(path, "/scene")
    assert len(scenes) == len(range(0, len(run.t), 50))
    (first, fixed), = _messages(path, "/scene/fixed")       # the walls: once, at the first scene's time
    validator.validate(json.loads(fixed))
    entity, = json.loads(fixed)["entities"]
    assert first == scenes[0][0] and entity["id"] == "fixed" and entity["lifetime"] == {"sec": 0, "nsec": 0}
    walls = entity["lines"]
    assert len(walls) == len(scenario.obstacles)
    for wall, ob in zip(walls, scenario.obstacles):
        np.testing.assert_allclose([[p["x"], p["y"]] for p in wall["points"]], ob.points, atol=1e-6)
    s_ref = run.s_reference()
    for log_time, data in scenes:
        scene = json.loads(data)
        validator.validate(scene)
        k = int(np.flatnonzero(np.round(run.t * 1e9) == log_time)[0])
        entity, = scene["entities"]
        arm, curve = entity["lines"]            # the walls are not drawn again
        # the arm: a line list, one segment per link (its two joints), coloured by the link's margin
        joints = chain.joints_np(run.q[k])
        pts = np.array([[p["x"], p["y"]] for p in arm["points"]])
        assert arm["type"] == 2 and arm["scale_invariant"] and len(pts) == 2 * LINKS
        np.testing.assert_allclose(pts[0::2], joints[:-1], atol=1e-6)  # 6 decimals in the JSON
        np.testing.assert_allclose(pts[1::2], joints[1:], atol=1e-6)
        colours = np.array([[c["r"], c["g"], c["b"]] for c in arm["colors"]])
        np.testing.assert_allclose(colours[0::2], margin_colours(run.link_margins[k]), atol=1e-3)
        np.testing.assert_array_equal(colours[0::2], colours[1::2])
        # the curve lies a quarter link below the arm's plane: a viewer draws the arm over it
        assert curve["pose"]["position"]["z"] == pytest.approx(-0.25 * chain.xi) and arm["pose"]["position"]["z"] == 0
        line = np.array([[p["x"], p["y"]] for p in curve["points"]])  # evaluated for many times at once
        np.testing.assert_allclose(line, ctrl.curve.sample(run.t[k], n=2, extent=2.2 * LINKS * chain.xi), atol=1e-6)
        sphere, *markers = entity["spheres"]
        np.testing.assert_allclose([[p["pose"]["position"]["x"], p["pose"]["position"]["y"]] for p in markers],
                                   joints, atol=1e-6)
        assert entity["cubes"] == []    # no carriage on a fixed base
        target = np.array([sphere["pose"]["position"]["x"], sphere["pose"]["position"]["y"]])
        phi, psi = (float(v) for v in ctrl.curve.functions()(target, run.t[k]))
        assert abs(phi) < 1e-9 and psi == pytest.approx(s_ref[k], abs=1e-9)


def test_tracking_channel_holds_s_its_target_a_point_of_the_curve_there_and_the_plotted_norms(arc):
    path, run, scenario = arc
    ctrl = scenario.controller()
    s_ref = run.s_reference()
    rows = _messages(path, "/tracking")
    assert len(rows) == len(range(0, len(run.t), 50))
    for log_time, data in rows:
        t, s, s_target, x, y, max_e, min_link, norm_u, log_e, s_error, log_s = np.frombuffer(data[4:], "<f8")
        k = int(np.flatnonzero(run.t == t)[0])
        assert s == run.s[k] and s_target == s_ref[k]   # bit for bit: same sums in the same order
        assert s_error == s - s_target
        assert log_e == pytest.approx(math.log10(max(max_e, 1e-18)), abs=1e-14)
        assert log_s == pytest.approx(math.log10(max(abs(s_error), 1e-18)), abs=1e-14)
        assert max_e == max(abs(v) for v in run.e[k]) and min_link == min(run.link_margins[k])
        assert norm_u == pytest.approx(math.sqrt(sum(v * v for v in run.u[k])), rel=1e-15)
        phi, psi = (float(v) for v in ctrl.curve.functions()(np.array([x, y]), t))
        # the arc is drawn as a 90-point polyline: its chords sit within R(1 - cos(pi/89)) of the circle
        assert abs(phi) < 2e-3 and psi == pytest.approx(s_target, abs=2e-3)


def test_point_along_walks_a_closed_polyline_across_its_seam():
    a = np.linspace(0, 2 * math.pi, 721)
    circle = np.column_stack([np.cos(a), np.sin(a)])
    p = point_along(circle, np.array([math.cos(-0.1), math.sin(-0.1)]), 0.3)   # starts before the seam
    np.testing.assert_allclose(p, [math.cos(0.2), math.sin(0.2)], atol=1e-5)
    open_line = np.array([[0.0, 0.0], [1.0, 0.0]])
    np.testing.assert_allclose(point_along(open_line, np.array([0.5, 0.2]), 0.25), [0.75, 0.0])
    np.testing.assert_allclose(point_along(open_line, np.array([0.5, 0.2]), 5.0), [1.0, 0.0])


def test_targets_on_straight_segments_in_one_pass_equal_point_along_one_by_one(rng):
    curves = [rng.normal(size=(2, 2)) * 3 for _ in range(100)]
    starts, distances = rng.normal(size=(100, 2)), rng.normal(size=100) * 4   # many beyond the ends
    one_by_one = np.array([point_along(c, p, x) for c, p, x in zip(curves, starts, distances)])
    np.testing.assert_allclose(_targets(curves, starts, distances), one_by_one, rtol=0, atol=1e-13)


def test_obstacle_outlines_draw_each_wall_segment_disc_and_polygon():
    from coordarm.simulation.obstacles import obstacles_from_spec
    walls = np.array([[[0, 0], [1, 0]], [[2, 2], [3, 1]]], float)
    obs = obstacles_from_spec([{"a": list(w[0]), "b": list(w[1])} for w in walls]
                              + [{"center": [1.0, 1.0], "radius": 0.5}, {"points": [[0, 0], [1, 0], [0, 1]]}])
    outlines = obstacle_outlines(obs)
    assert len(outlines) == 4 and all(np.array_equal(o, w) for o, w in zip(outlines, walls))
    np.testing.assert_allclose(np.linalg.norm(outlines[2] - [1, 1], axis=1), 0.5)     # a closed circle
    np.testing.assert_array_equal(outlines[3], [[0, 0], [1, 0], [0, 1], [0, 0]])       # a closed polygon


# ------------------------------------------------------------------------------ the link frames
def test_margin_colours_run_from_red_at_0_through_orange_at_a_quarter_to_blue_from_a_half():
    red, orange, violet, blue = (0.85, 0.1, 0.1), (0.95, 0.6, 0.1), (0.6, 0.3, 0.8), (0.15, 0.45, 0.9)
    got = margin_colours(np.array([[0.0, 0.25, 0.5, 0.9, 0.125, np.nan, 0.375, 0.4375]]))[0]
    np.testing.assert_allclose(got[0], blue)            # link 1 has no margin
    np.testing.assert_allclose(got[1:5], [red, orange, blue, blue], atol=1e-15)
    np.testing.assert_allclose(got[5], [(r + o) / 2 for r, o in zip(red, orange)], atol=1e-15)
    np.testing.assert_allclose(got[6], red)             # a NaN margin reads as singular
    np.testing.assert_allclose(got[7], violet, atol=1e-15)
    np.testing.assert_allclose(got[8], [(v + b) / 2 for v, b in zip(violet, blue)], atol=1e-15)
    # saturated all along (no grey between orange and blue): max - min channel above 0.3
    scale = margin_colours(np.linspace(0, 0.5, 201)[None])[0, 1:]
    assert np.min(scale.max(axis=1) - scale.min(axis=1)) > 0.3


def test_the_default_frames_are_base_and_tip_from_world(hole, thread):
    for path, run, scenario in (hole, thread):
        chain = scenario.chain()
        validator = jsonschema.Draft202012Validator(json.loads(_stored_schema(path, "foxglove.FrameTransforms").data))
        for log_time, data in _messages(path, "/tf"):
            tf = json.loads(data)
            validator.validate(tf)
            k = int(np.flatnonzero(np.round(run.t * 1e9) == log_time)[0])
            base, tip = tf["transforms"]
            assert (base["parent_frame_id"], base["child_frame_id"], tip["parent_frame_id"], tip["child_frame_id"]) \
                == ("world", "base", "world", "tip")
            joints = chain.joints_np(run.q[k])
            np.testing.assert_allclose([base["translation"]["x"], base["translation"]["y"]],
                                       chain.centres_np(run.q[k])[0], atol=1e-9)
            np.testing.assert_allclose([tip["translation"]["x"], tip["translation"]["y"]], joints[-1], atol=1e-9)
            # the tip's x axis lies along the last link
            angle = 2 * math.atan2(tip["rotation"]["z"], tip["rotation"]["w"])
            d = joints[-1] - joints[-2]
            assert math.remainder(angle - math.atan2(d[1], d[0]), 2 * math.pi) == pytest.approx(0.0, abs=1e-12)


def test_a_rail_robot_s_scene_draws_the_rail_its_stops_and_the_carriage_under_the_base(thread):
    path, run, scenario = thread
    chain = scenario.chain()
    (_, fixed), = _messages(path, "/scene/fixed")           # the rail and its stops, before the walls
    rail, low, high, *walls = json.loads(fixed)["entities"][0]["lines"]
    assert len(walls) == len(scenario.obstacles)
    np.testing.assert_allclose([[p["x"], p["y"]] for p in rail["points"]], [[-0.1, 0.0], [4.0, 0.0]], atol=1e-6)
    for stop, d in ((low, -0.1), (high, 4.0)):    # across the rail (along y) at each limit
        np.testing.assert_allclose([p["x"] for p in stop["points"]], [d, d], atol=1e-6)
        assert stop["points"][0]["y"] < 0 < stop["points"][1]["y"]
    for log_time, data in _messages(path, "/scene"):
        entity, = json.loads(data)["entities"]
        k = int(np.flatnonzero(np.round(run.t * 1e9) == log_time)[0])
        assert len(entity["lines"]) == 2                # the arm and the curve
        carriage, = entity["cubes"]
        d = run.q[k][0]
        np.testing.assert_allclose([carriage["pose"]["position"]["x"], carriage["pose"]["position"]["y"]],
                                   [d, 0.0], atol=1e-6)


def test_frame_transforms_validate_and_chain_every_link_from_world(hole_all_frames):
    path, run, scenario = hole_all_frames
    chain = scenario.chain()
    validator = jsonschema.Draft202012Validator(json.loads(_stored_schema(path, "foxglove.FrameTransforms").data))
    msgs = _messages(path, "/tf")
    assert len(msgs) == len(range(0, len(run.t), 50))
    for log_time, data in msgs:
        tf = json.loads(data)
        validator.validate(tf)
        k = int(np.flatnonzero(np.round(run.t * 1e9) == log_time)[0])
        q = run.q[k]
        items = tf["transforms"]
        assert [(i["parent_frame_id"], i["child_frame_id"]) for i in items] == \
            [("world", "link1")] + [(f"link{j}", f"link{j + 1}") for j in range(1, LINKS)]
        # compose the chain from world and compare with the chain's own centres and absolute angles
        pos, ang = np.zeros(2), 0.0
        centres = chain.centres_np(q)
        for j, item in enumerate(items):
            assert item["timestamp"] == {"sec": log_time // 10**9, "nsec": log_time % 10**9}
            tr, rot = item["translation"], item["rotation"]
            pos = pos + np.array([[math.cos(ang), -math.sin(ang)], [math.sin(ang), math.cos(ang)]]) @ [tr["x"], tr["y"]]
            ang += 2 * math.atan2(rot["z"], rot["w"])
            np.testing.assert_allclose(pos, centres[j], atol=(j + 1) * 1e-9)  # translations are sent in whole nm
            assert math.remainder(ang - np.sum(q[:j + 1]), 2 * math.pi) == pytest.approx(0.0, abs=1e-12)


def test_link_frames_match_the_closed_form_of_a_fixed_base_chain(rng):
    chain = load_scenario("line").with_overrides(links=7).chain()
    q = rng.uniform(-2.5, 2.5, size=(5, 7))
    trans, angle = link_frames(chain.joints_np(q))
    xi = chain.xi
    np.testing.assert_allclose(trans[:, 1:, 0], xi / 2 * (1 + np.cos(q[:, 1:])), atol=1e-14)
    np.testing.assert_allclose(trans[:, 1:, 1], xi / 2 * np.sin(q[:, 1:]), atol=1e-14)
    np.testing.assert_allclose(angle[:, 1:], q[:, 1:], atol=1e-13)
    np.testing.assert_allclose(trans[:, 0], chain.centres_np(q)[:, 0], atol=1e-14)
