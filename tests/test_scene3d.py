"""The Foxglove scene of a spatial run: link cylinders and frames against the chain's own geometry, the schemas."""
import json
from types import SimpleNamespace

import jsonschema
import numpy as np
import pytest

from coordarm.simulation.log_schemas import CDR_HEADER, foxglove_schema
from coordarm.simulation.scene import link_frames
from coordarm.simulation.scene3d import SCENE_EXPONENTS, SpatialSceneBuilder, quaternions, spatial_link_frames
from coordarm.symbolic.chain import PlanarChain
from coordarm.symbolic.curves3d import Line3D
from coordarm.symbolic.motions import Sinusoid
from coordarm.symbolic.paths3d import Path3D
from coordarm.symbolic.spatial_chain import SpatialChain
from coordarm.symbolic.spatial_controller import SpatialController

M, XI = 5, 0.1
#: How far a scene's position or orientation component may lie from its value: half of its unit
#: (SCENE_EXPONENTS: positions in micrometres, quaternion components in 1e-9; a direction turned by a
#: quaternion written so is within a few of those).
POSITION, TURNED = 0.5e-6 * (1 + 1e-9), 4e-9


def rotate(quat, v):
    """``v`` turned by the unit quaternion ``(x, y, z, w)``: v + 2w (u x v) + 2 u x (u x v)."""
    u, w = np.asarray(quat[:3], float), float(quat[3])
    return v + 2 * w * np.cross(u, v) + 2 * np.cross(u, np.cross(u, v))


def xyz(d):
    return np.array([d["x"], d["y"], d["z"]])


def xyzw(d):
    return np.array([d["x"], d["y"], d["z"], d["w"]])


def block(n=7, seed=0):
    """A block of steps: random joint coordinates and plausible law outputs."""
    rng = np.random.default_rng(seed)
    t = np.arange(n) * 0.05
    return SimpleNamespace(t=t, q=0.7 * rng.standard_normal((n, 2 * M)), u=rng.standard_normal((n, 2 * M)),
                           e=rng.standard_normal((n, 2 * (M - 1))), s=0.3 + 0.1 * t, roll=0.01 * t,
                           link_margins=rng.uniform(0.2, 1, (n, M - 1)), v_star=np.full(n, 0.1))


@pytest.fixture(scope="module")
def ctrl():
    curve = Line3D((0.0, 0.0, 0.0), (1, 0, 0), (0, 1, 0), rotation=((0, 1, 0), Sinusoid(0.5, 0.4)))
    return SpatialController(SpatialChain(M, XI), curve, 2.0, 0.1, roll=Sinusoid(0.3, 0.7))


@pytest.fixture(scope="module")
def drawn(ctrl):
    return _drawn(ctrl, "ends")


@pytest.fixture(scope="module")
def drawn_all_frames(ctrl):
    return _drawn(ctrl, "all")


def _drawn(ctrl, frames):
    part = block()
    builder = SpatialSceneBuilder(ctrl, [], frames=frames)
    builder.advance(part)
    ks = np.array([0, 3, 6])
    return part, ks, builder.messages(part, ks, (part.t[ks] * 1e9).round().astype(np.int64))


def test_quaternions_turn_vectors_as_the_matrices(ctrl):
    R = ctrl.chain.frames_np(block(20, seed=4).q).reshape(-1, 3, 3)
    for Rk, qk in zip(R, quaternions(R)):
        assert abs(np.linalg.norm(qk) - 1) < 1e-14
        for v in np.eye(3):
            np.testing.assert_allclose(rotate(qk, v), Rk @ v, atol=1e-14)


def test_link_cylinders_sit_on_the_centres_along_the_link_directions(ctrl, drawn):
    part, ks, msgs = drawn
    scenes = [json.loads(data) for key, _, data in msgs if key == "scene"]
    assert len(scenes) == len(ks)
    centres, dirs = ctrl.chain.centres_np(part.q[ks]), ctrl.chain.directions_np(part.q[ks])
    for scene, c, d in zip(scenes, centres, dirs):
        entity, = scene["entities"]
        cylinders = entity["cylinders"]
        assert len(cylinders) == M
        for j, cyl in enumerate(cylinders):
            np.testing.assert_allclose(xyz(cyl["pose"]["position"]), c[j], rtol=0, atol=POSITION)
            np.testing.assert_allclose(rotate(xyzw(cyl["pose"]["orientation"]), np.array([0.0, 0, 1])), d[j],
                                       rtol=0, atol=TURNED)
            assert cyl["size"]["z"] == XI
        joints = np.array([xyz(s["pose"]["position"]) for s in entity["spheres"][:-1]])
        np.testing.assert_allclose(joints[:-1], c - 0.5 * XI * d, rtol=0, atol=POSITION)
        np.testing.assert_allclose(joints[1:], c + 0.5 * XI * d, rtol=0, atol=POSITION)


def test_the_axis_line_joins_the_link_ends_in_the_cylinders_colours_after_the_curve(ctrl, drawn):
    """The links' axes are also a line list (px wide at any zoom) drawn after the curve: segment j runs from
    centre_j - xi/2 d_j to centre_j + xi/2 d_j, in the colour of cylinder j."""
    part, ks, msgs = drawn
    scenes = [json.loads(data) for key, _, data in msgs if key == "scene"]
    centres, dirs = ctrl.chain.centres_np(part.q[ks]), ctrl.chain.directions_np(part.q[ks])
    for scene, c, d in zip(scenes, centres, dirs):
        entity, = scene["entities"]
        curve, *_, axis = entity["lines"]
        assert curve["color"]["g"] == 0.5 and axis["type"] == 2 and axis["scale_invariant"]   # curve first
        ends = np.array([xyz(p) for p in axis["points"]])
        np.testing.assert_allclose(ends[0::2], c - 0.5 * XI * d, rtol=0, atol=POSITION)
        np.testing.assert_allclose(ends[1::2], c + 0.5 * XI * d, rtol=0, atol=POSITION)
        colours = [[k["r"], k["g"], k["b"]] for k in axis["colors"]]
        cylinders = [[k["color"]["r"], k["color"]["g"], k["color"]["b"]] for k in entity["cylinders"]]
        assert colours[0::2] == cylinders and colours[1::2] == cylinders


def test_the_default_frames_are_the_base_at_the_first_centre_and_the_tip_at_the_last_joint(ctrl, drawn):
    part, ks, msgs = drawn
    tfs = [json.loads(data)["transforms"] for key, _, data in msgs if key == "tf"]
    R_all = ctrl.chain.frames_np(part.q[ks])
    for (base, tip), R, c, d in zip(tfs, R_all, ctrl.chain.centres_np(part.q[ks]), ctrl.chain.directions_np(part.q[ks])):
        assert [(x["parent_frame_id"], x["child_frame_id"]) for x in (base, tip)] == [("world", "base"), ("world", "tip")]
        np.testing.assert_allclose(xyz(base["translation"]), c[0], atol=1e-15)
        np.testing.assert_allclose(xyz(tip["translation"]), c[-1] + 0.5 * XI * d[-1], atol=1e-14)
        axes = np.array([rotate(xyzw(tip["rotation"]), v) for v in np.eye(3)]).T
        np.testing.assert_allclose(axes, R[-1], atol=1e-13)


def test_frames_composed_from_world_give_each_link_centre_and_orientation(ctrl, drawn_all_frames):
    part, ks, msgs = drawn_all_frames
    tfs = [json.loads(data)["transforms"] for key, _, data in msgs if key == "tf"]
    R_all = ctrl.chain.frames_np(part.q[ks])
    for transforms, R, c in zip(tfs, R_all, ctrl.chain.centres_np(part.q[ks])):
        assert [(x["parent_frame_id"], x["child_frame_id"]) for x in transforms] == \
            [("world", "link1")] + [(f"link{j}", f"link{j + 1}") for j in range(1, M)]
        pos, quat = np.zeros(3), np.array([0.0, 0, 0, 1])
        for j, x in enumerate(transforms):
            pos = pos + rotate(quat, xyz(x["translation"]))
            rel = xyzw(x["rotation"])
            axes = np.array([rotate(rel, v) for v in np.eye(3)]).T
            world = np.array([rotate(quat, v) for v in axes.T]).T          # parent's rotation after rel
            quat = quaternions(world)
            np.testing.assert_allclose(pos, c[j], atol=1e-14)
            np.testing.assert_allclose(world, R[j], atol=1e-13)


def test_a_planar_pose_gives_the_planar_frames():
    rng = np.random.default_rng(1)
    qp = rng.uniform(-1, 1, (4, M))
    qs = np.zeros((4, 2 * M))
    qs[:, 0::2] = qp
    trans, rot = spatial_link_frames(SpatialChain(M, XI), qs)
    trans2, angle = link_frames(PlanarChain(M, XI).joints_np(qp))
    np.testing.assert_allclose(trans[..., :2], trans2, atol=1e-15)
    assert np.all(trans[..., 2] == 0)
    np.testing.assert_allclose(rot, np.stack([0 * angle, 0 * angle, np.sin(angle / 2), np.cos(angle / 2)], -1),
                               atol=1e-15)


def test_messages_validate_and_the_tracking_record(ctrl, drawn):
    part, ks, msgs = drawn
    assert [k for k, _, _ in msgs] == ["fixed"] + ["scene", "tf", "tracking"] * len(ks)     # fixed: once, first
    assert [n for _, n, _ in msgs[1:]][::3] == (part.t[ks] * 1e9).round().astype(int).tolist() and \
        msgs[0][1] == msgs[1][1]
    scene_v = jsonschema.Draft7Validator(foxglove_schema("foxglove.SceneUpdate"))
    tf_v = jsonschema.Draft7Validator(foxglove_schema("foxglove.FrameTransforms"))
    for key, _, data in msgs:
        if key in ("scene", "fixed"):
            scene_v.validate(json.loads(data))
        elif key == "tf":
            tf_v.validate(json.loads(data))
    records = np.array([np.frombuffer(d[len(CDR_HEADER):], "<f8") for k, _, d in msgs if k == "tracking"])
    names = [n for n, _ in SpatialSceneBuilder.TRACKING_FIELDS]
    assert records.shape == (len(ks), len(names))
    rec = dict(zip(names, records.T))
    t = part.t[ks]
    np.testing.assert_array_equal(rec["t"], t)
    np.testing.assert_allclose(rec["s_target"], part.s[0] + 0.1 * t, atol=1e-15)
    target = np.array([ctrl.curve.point_at(s, tt) for s, tt in zip(rec["s_target"], t)])
    np.testing.assert_allclose(np.column_stack([rec["target_x"], rec["target_y"], rec["target_z"]]), target,
                               atol=1e-15)
    np.testing.assert_allclose(rec["roll_target"], 0.3 * np.sin(0.7 * t), atol=1e-15)
    np.testing.assert_array_equal(rec["max_abs_e"], np.abs(part.e[ks]).max(axis=1))


def test_a_path_is_drawn_whole_in_3d():
    chain = SpatialChain(M, XI)
    curve = Path3D((0, 0, 0), (1, 0, 0), (0, 1, 0), [("line", 0.3), ("arc", 1.5, 0.4, 1.2)])
    ctrl = SpatialController(chain, curve, 2.0, 0.1, roll=0.0)
    builder = SpatialSceneBuilder(ctrl, [])
    part = block(3)
    builder.advance(part)
    msgs = builder.messages(part, np.array([0, 2]), np.array([0, 10**8]))
    line = json.loads(next(d for k, _, d in msgs if k == "scene"))["entities"][0]["lines"][0]
    pts = np.array([xyz(p) for p in line["points"]])
    assert np.ptp(pts[:, 2]) > 0.1                        # the banked arc leaves the plane z = 0
    dist = np.min(np.linalg.norm(pts[:, None] - curve.sample(0.0, 40, extent=0.0)[None], axis=2), axis=0)
    assert dist.max() < 0.02                              # every part of the path is drawn


def same_numbers(got, want, path=""):
    """``got`` (a parsed message) is ``want`` (the entity's dicts) with each number written to its unit
    (:data:`SCENE_EXPONENTS`: colours 1e-3, orientations 1e-9, the target 1e-12, positions 1e-6): the same
    structure and keys, every number within half a unit (ties to even), strings and booleans equal."""
    if isinstance(want, dict):
        assert isinstance(got, dict) and list(got) == list(want), path
        for k in want:
            same_numbers(got[k], want[k], f"{path}.{k}")
    elif isinstance(want, list):
        assert isinstance(got, list) and len(got) == len(want), path
        for i, (g, w) in enumerate(zip(got, want)):
            same_numbers(g, w, f"{path}[{i}]")
    elif isinstance(want, (bool, str)) or want is None:
        assert got == want and type(got) is type(want), path
    else:
        unit = ("colour" if ".color" in path or ".colors" in path else "orientation" if ".orientation" in path
                else "target" if path.startswith(".spheres[-1]") else "position")
        half = 0.5 * 10.0 ** -SCENE_EXPONENTS[unit]
        assert abs(got - want) <= half * (1 + 1e-9) + 1e-16 * abs(want), (path, got, want)


@pytest.mark.parametrize("obstacles", [[], [{"kind": "sphere", "centre": [0.3, 0.1, 0.0], "radius": 0.05},
                                            {"kind": "cylinder", "a": [0.0, 0.3, 0.0], "b": [0.4, 0.3, 0.1], "radius": 0.02}]])
def test_a_scene_message_is_its_whole_entity_written_to_the_units_the_walls_once_in_the_fixed_one(ctrl, obstacles):
    """The template's message parses to the entity of :meth:`scene_entity` (floats) with each number written to
    its unit, the sizes and colours that do not move are its text exactly; the walls are not in it but in the
    one ``/scene/fixed`` message before the first scene, their corners to the micrometre; a pose that is not
    finite is encoded from the dicts."""
    from coordarm.simulation.obstacles3d import obstacle3d_from_spec, wireframe
    from coordarm.simulation.scene import margin_colours

    obs = [obstacle3d_from_spec(o, i) for i, o in enumerate(obstacles)]
    builder = SpatialSceneBuilder(ctrl, obs)
    part = block(9, seed=3)
    builder.advance(part)
    ks = np.array([0, 4, 8])
    ns = (part.t[ks] * 1e9).round().astype(np.int64) + 3 * 10**9
    msgs = builder.messages(part, ks, ns)
    assert [k for k, _, _ in msgs].count("fixed") == 1 and msgs[0][:2] == ("fixed", int(ns[0]))
    fixed = json.loads(msgs[0][2])["entities"]
    assert len(fixed) == 1 and fixed[0]["id"] == "fixed" and fixed[0]["frame_id"] == "world"
    assert fixed[0]["timestamp"] == {"sec": 3, "nsec": int(ns[0]) - 3 * 10**9} and fixed[0]["lifetime"] == {"sec": 0, "nsec": 0}
    walls = [p for ob in obs for p in wireframe(ob)]
    assert len(fixed[0]["lines"]) == len(walls)
    for line, points in zip(fixed[0]["lines"], walls):               # corners to the micrometre, written short
        got_points = np.array([xyz(p) for p in line["points"]])
        np.testing.assert_allclose(got_points, points, rtol=0, atol=POSITION)
        np.testing.assert_array_equal(got_points, [[round(float(x), 6) for x in p] for p in points])
    scenes = [d for k, _, d in msgs if k == "scene"]
    poses, curves, targets = builder.poses(part.q[ks]), builder.curves(part.t[ks]), builder.targets(part, ks)
    for pose, rgb in zip(poses, margin_colours(part.link_margins[ks])):
        pose["colours"] = rgb
    for scene, pose, curve, target, n in zip(scenes, poses, curves, targets, ns.tolist()):
        whole = builder.scene_entity(pose, curve, target, n)
        got = json.loads(scene)
        assert got["deletions"] == [] and len(got["entities"]) == 1
        entity = got["entities"][0]
        same_numbers({**entity, "spheres[-1]": entity["spheres"][-1]}, {**whole, "spheres[-1]": whole["spheres"][-1]})
        assert entity["timestamp"] == {"sec": 3, "nsec": n - 3 * 10**9} and entity["id"] == "coordarm"
        assert [line["type"] for line in entity["lines"]] == [0, 2]          # the curve and the axes, no walls
        assert [c["size"] for c in entity["cylinders"]] == [c["size"] for c in whole["cylinders"]]
        assert all(len(repr(v)) <= 8 for c in entity["cylinders"] + entity["spheres"] for v in c["size"].values())
    assert [k for k, _, _ in builder.messages(part, ks, ns)].count("fixed") == 0     # once per builder
    part.q[4, 3] = np.nan                                            # not finite: the dicts' JSON (NaN)
    builder.advance(part)
    nan_scenes = [d for k, _, d in builder.messages(part, ks, ns) if k == "scene"]
    assert b"NaN" in nan_scenes[1]


def test_a_lines_drawn_ends_and_the_targets_are_sample_and_point_at_time_by_time(ctrl):
    part = block(9)
    builder = SpatialSceneBuilder(ctrl, [])
    builder.advance(part)
    ks = np.arange(9)
    drawn = builder.curves(part.t)
    want = [ctrl.curve.sample(float(t), n=2, extent=builder.reach) for t in part.t]
    assert len(drawn) == 9 and all(np.array_equal(d, w) for d, w in zip(drawn, want))
    np.testing.assert_array_equal(builder.targets(part, ks),
                                  [ctrl.curve.point_at(float(builder.s_target[k]), float(part.t[k])) for k in ks])
