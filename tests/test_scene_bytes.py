"""The planar ``/scene`` and ``/tf`` messages byte for byte against a straightforward rendering: the message
built as a Python object, ``json.dumps`` with compact separators, each integer slot then written right-aligned
in its kind's width (the widest value of that kind in the batch, a sign if any is negative) with its
exponent. No template, no C kernel, the curve sampled by the curve itself and the target walked with
``point_along`` one row at a time."""
from __future__ import annotations

import json
import math

import numpy as np
import pytest

from coordarm.simulation import scene
from coordarm.simulation.log_schemas import CDR_HEADER
from coordarm.simulation.run import simulate
from coordarm.simulation.scenario import load_scenario
from coordarm.simulation.tracking_record import tracking_records


class Slot:
    """An integer of a message, of a kind (the kinds share a width per batch), written with ``exponent``."""

    def __init__(self, value: float, kind: str, exponent: str):
        self.value, self.kind, self.exponent = int(round(value)), kind, exponent


def render(objects: list) -> list[bytes]:
    """json.dumps of each object; every Slot padded to its kind's width over all the objects."""
    slots: list[list[Slot]] = []
    texts = []
    for obj in objects:
        found: list[Slot] = []

        def token(x, found=found):
            found.append(x)
            return f"@{len(found) - 1}@"
        texts.append(json.dumps(obj, separators=(",", ":"), default=token))
        slots.append(found)
    width = {}
    for kind in {s.kind for row in slots for s in row}:
        values = [s.value for row in slots for s in row if s.kind == kind]
        width[kind] = len(str(max(abs(v) for v in values))) + any(v < 0 for v in values)
    out = []
    for text, row in zip(texts, slots):
        for i, s in enumerate(row):
            text = text.replace(f'"@{i}@"', f"{s.value:>{width[s.kind]}d}{s.exponent}", 1)
        out.append(text.encode())
    return out


def point(x, y, kind, scale=1e6, exponent="e-6"):
    return {"x": Slot(x * scale, kind, exponent), "y": Slot(y * scale, kind, exponent), "z": 0}


def literal_point(x, y):
    """A point of a fixed line (rail, obstacle): integer micrometres, no padding."""
    return {"x": _Raw(f"{round(x * 1e6)}e-6"), "y": _Raw(f"{round(y * 1e6)}e-6"), "z": 0}


class _Raw(Slot):
    def __init__(self, text):
        number, self.exponent = text.split("e")
        self.value, self.kind, self.exponent = int(number), f"raw{id(self)}", "e" + self.exponent


POSE0 = {"position": {"x": 0, "y": 0, "z": 0}, "orientation": {"x": 0, "y": 0, "z": 0, "w": 1}}


def rgba(c):
    return dict(zip("rgba", c))


def fixed_line(points, px, colour):
    return {"type": 0, "pose": POSE0, "thickness": px, "scale_invariant": True,
            "points": [literal_point(x, y) for x, y in points], "color": rgba(colour), "colors": [], "indices": []}


def length(x):
    """A size or depth as the scene writes it: to the micrometre, in its shortest form."""
    return float(f"{x:.6f}")


def sphere(x, y, kind, scale, exponent, diameter, colour):
    d = length(diameter)
    return {"pose": {"position": point(x, y, kind, scale, exponent), "orientation": {"x": 0, "y": 0, "z": 0, "w": 1}},
            "size": {"x": d, "y": d, "z": d}, "color": rgba(colour)}


def stamp(ns):
    return {"sec": Slot(ns // 10**9, "sec", ""), "nsec": Slot(ns % 10**9, "nsec", "")}


def reference_scene(ctrl, obstacles, builder, joints, base, t, ns, target, margins):
    chain, xi = ctrl.chain, ctrl.chain.xi
    colours = scene.margin_colours(margins)
    arm = {"type": 2, "pose": POSE0, "thickness": scene.ARM_PX, "scale_invariant": True,
           "points": [point(*joints[j + e], "um") for j in range(chain.m) for e in (0, 1)],
           "color": {"r": 0, "g": 0, "b": 0, "a": 1},
           "colors": [{"r": Slot(c[0] * 1e3, "colour", "e-3"), "g": Slot(c[1] * 1e3, "colour", "e-3"),
                       "b": Slot(c[2] * 1e3, "colour", "e-3"), "a": 1} for c in colours for _ in (0, 1)],
           "indices": []}
    extent = builder.reach
    curve = ctrl.curve.sample(float(t), n=2 if isinstance(ctrl.curve, scene.Line) else 90, extent=extent)
    depth_pose = {"position": {"x": 0, "y": 0, "z": -length(scene.CURVE_DEPTH * xi)},
                  "orientation": {"x": 0, "y": 0, "z": 0, "w": 1}}
    curve_line = {"type": 0, "pose": depth_pose, "thickness": scene.CURVE_PX, "scale_invariant": True,
                  "points": [point(x, y, "curve") for x, y in curve], "color": rgba(scene.CURVE_COLOR), "colors": [],
                  "indices": []}
    cubes = []
    if chain.rail:
        a = chain.rail_angle
        cubes.append({"pose": {"position": point(*base, "um"),
                               "orientation": {"x": 0, "y": 0, "z": math.sin(0.5 * a), "w": math.cos(0.5 * a)}},
                      "size": {"x": length(1.5 * xi), "y": length(xi), "z": length(0.5 * xi)},
                      "color": rgba(scene.CARRIAGE_COLOR)})
    entity = {"timestamp": stamp(ns), "frame_id": "world", "id": "coordarm", "lifetime": {"sec": 0, "nsec": 0},
              "frame_locked": False, "metadata": [], "arrows": [],
              "spheres": [sphere(*target, "target", 1e12, "e-12", max(1.2 * xi, 0.05), scene.TARGET_COLOR)]
              + [sphere(x, y, "um", 1e6, "e-6", 0.45 * xi, scene.JOINT_COLOR) for x, y in joints],
              "cubes": cubes, "cylinders": [], "triangles": [], "texts": [], "models": [],
              "lines": [arm, curve_line]}
    return {"deletions": [], "entities": [entity]}


def reference_fixed(ctrl, obstacles, builder, ns):
    """/scene/fixed: the rail and the obstacles in an entity of their own, once."""
    fixed = [fixed_line(p, scene.RAIL_PX, scene.RAIL_COLOR) for p in scene.rail_lines(ctrl.chain, builder.reach)]
    fixed += [fixed_line(p, scene.WALL_PX, scene.WALL_COLOR) for p in scene.obstacle_outlines(obstacles)]
    entity = {"timestamp": stamp(ns), "frame_id": "world", "id": "fixed", "lifetime": {"sec": 0, "nsec": 0},
              "frame_locked": False, "metadata": [], "arrows": [], "cubes": [], "spheres": [], "cylinders": [],
              "lines": fixed, "triangles": [], "texts": [], "models": []}
    return {"deletions": [], "entities": [entity]}


def transform(ns, parent, child, x, y, angle):
    return {"timestamp": stamp(ns), "parent_frame_id": parent, "child_frame_id": child,
            "translation": {"x": Slot(x * 1e9, "nm", "e-9"), "y": Slot(y * 1e9, "nm", "e-9"), "z": 0},
            "rotation": {"x": 0, "y": 0, "z": Slot(np.sin(0.5 * angle) * 1e15, "q", "e-15"),
                         "w": Slot(np.cos(0.5 * angle) * 1e15, "q", "e-15")}}


def reference_tf(chain, frames, joints, base, ns):
    if frames == "ends":
        d = joints[-1] - joints[-2]
        return {"transforms": [transform(ns, "world", "base", *base, chain.rail_angle if chain.rail else 0.0),
                               transform(ns, "world", "tip", *joints[-1], np.arctan2(d[1], d[0]))]}
    trans, angle = scene.link_frames(joints)
    return {"transforms": [transform(ns, "world" if j == 0 else f"link{j}", f"link{j + 1}", *trans[j], angle[j])
                           for j in range(chain.m)]}


@pytest.mark.parametrize("name, frames", [("hole", "ends"), ("thread", "all"), ("arc", "ends")])
def test_scene_and_tf_messages_are_a_straightforward_json_rendering_byte_for_byte(name, frames):
    sc = load_scenario(name).with_overrides(duration=0.2)
    ctrl = sc.controller()
    blocks = []
    simulate(ctrl, sc.start(ctrl), sc.duration, sc.step, chunk=70, on_chunk=blocks.append)
    builder = scene.SceneBuilder(ctrl, sc.obstacles, frames)
    checked = 0
    for part in blocks:
        s_target = builder.advance(part)
        ks = np.arange(0, len(part.t), 3)
        ns = np.round(part.t[ks] * 1e9).astype(np.uint64)
        got = builder.messages(part, ks, ns)
        if part is blocks[0]:     # /scene/fixed: once, before the first scene, at its time
            assert got[0][:2] == ("fixed", int(ns[0]))
            assert got.pop(0)[2] == render([reference_fixed(ctrl, sc.obstacles, builder, int(ns[0]))])[0]
        assert [key for key, _, _ in got] == ["scene", "tf", "tracking"] * len(ks)
        assert [lt for _, lt, _ in got] == np.repeat(ns, 3).tolist()
        joints, base = ctrl.chain.joints_np(part.q[ks]), ctrl.chain.base_point(part.q[ks])
        # /tracking: the record of tracking_records, its target the point of the curve s_target - s along it
        tracking = np.array([np.frombuffer(data[len(CDR_HEADER):], "<f8") for key, _, data in got if key == "tracking"])
        assert [data[:len(CDR_HEADER)] for key, _, data in got if key == "tracking"] == [CDR_HEADER] * len(ks)
        targets = tracking[:, 3:5]
        np.testing.assert_array_equal(tracking, tracking_records(part, ks, s_target[ks], targets))
        scenes, tfs = [], []
        for i, k in enumerate(ks):
            t = float(part.t[k])
            curve = ctrl.curve.sample(t, n=2 if isinstance(ctrl.curve, scene.Line) else 90, extent=builder.reach)
            end = 0.5 * (joints[i, -2] + joints[i, -1])
            np.testing.assert_allclose(targets[i], scene.point_along(curve, end, s_target[k] - part.s[k]), atol=1e-13)
            scenes.append(reference_scene(ctrl, sc.obstacles, builder, joints[i], base[i], t, int(ns[i]), targets[i],
                                          part.link_margins[k]))
            tfs.append(reference_tf(ctrl.chain, frames, joints[i], base[i], int(ns[i])))
        assert [data for key, _, data in got if key == "scene"] == render(scenes)
        assert [data for key, _, data in got if key == "tf"] == render(tfs)
        checked += len(ks)
    assert checked > 25
