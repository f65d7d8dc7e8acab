"""The scene's fast paths against the plain ones: the scene's integers against rounding each group of numbers
on its own and laying them out one by one, the arm's ends and colours (slots showing the joints' and the links'
integers) as json.loads reads them, several curve sizes in one batch against one batch per size, and the
straight line's ends (its Function called through a buffer) against the curve's sampling."""
from __future__ import annotations

import json
from decimal import Decimal

import numpy as np
import pytest

from coordarm.simulation import scene
from coordarm.simulation.frame_transforms import stamps
from coordarm.simulation.run import simulate
from coordarm.simulation.scenario import load_scenario


def _plain_numbers(margins, stamp, joints, base, targets):
    """The integers rounded group by group and laid out row by row: stamp, target [pm], joints [µm], carriage
    [µm], each link's colour (r, g, b) [1e-3]."""
    k = joints.shape[0]
    colours = np.round(scene.margin_colours(margins) * 1e3).astype(np.int64)           # (k, m, 3)
    rows = []
    for i in range(k):
        row = [stamp[i], np.round(targets[i] * 1e12), np.round(joints[i] * 1e6).ravel()]
        if base is not None:
            row.append(np.round(base[i] * 1e6))
        row.append(colours[i].ravel())
        rows.append(np.concatenate(row).astype(np.int64))
    return np.array(rows)


@pytest.mark.parametrize("rail", [False, True])
def test_scene_numbers_are_the_numbers_rounded_and_laid_out_one_by_one(rail, rng):
    k, m = 5, 7
    joints = rng.normal(0.0, 3.0, (k, m + 1, 2))
    joints[0, 0] = (-0.5e-6, 2.5e-6)               # ties: to even, as np.round
    margins = rng.uniform(-0.2, 0.8, (k, m - 1))
    margins[1, 2], margins[2, 0] = np.nan, np.inf
    base = rng.normal(0.0, 1.0, (k, 2)) if rail else None
    targets = rng.normal(0.0, 5.0, (k, 2))
    stamp = stamps(rng.integers(0, 10**11, k))
    extra = 3                                       # the curve's columns follow; left alone
    values = np.full((k, scene.head_columns(m, rail) + extra), -7, np.int64)
    out = scene.scene_numbers(values, margins, stamp, joints, base, targets)
    assert out is values
    np.testing.assert_array_equal(values[:, :-extra], _plain_numbers(margins, stamp, joints, base, targets))
    assert (values[:, -extra:] == -7).all()


def _first_block(name, links, duration):
    """The controller, first block of steps and scene builder of preset ``name``."""
    sc = load_scenario(name).with_overrides(links=links, duration=duration)
    ctrl = sc.controller()
    blocks = []
    simulate(ctrl, sc.start(ctrl), sc.duration, sc.step, on_chunk=blocks.append)
    return ctrl, blocks[0], scene.SceneBuilder(ctrl, sc.obstacles)


def test_the_scene_shows_each_links_ends_and_colour_from_the_joints_and_the_links_numbers():
    """The scene's arm as json.loads reads it: segment j from joint j to joint j+1, both ends of link j in its
    colour, the joint spheres at the joints."""
    ctrl, part, builder = _first_block("thread", 5, 0.02)
    builder.advance(part)
    ks = np.array([0, len(part.t) - 1])
    got = [json.loads(d, parse_float=Decimal) for key, _, d in builder.messages(part, ks, np.array([0, 10**7]))
           if key == "scene"]
    joints = np.round(ctrl.chain.joints_np(part.q[ks]) * 1e6).astype(np.int64)            # [µm]
    colours = np.round(scene.margin_colours(part.link_margins[ks]) * 1e3).astype(np.int64)  # [1e-3]

    def scaled(items, names, scale):
        return np.array([[int(x[n] * scale) for n in names] for x in items])
    for i, doc in enumerate(got):
        entity = doc["entities"][0]
        arm = entity["lines"][0]
        np.testing.assert_array_equal(scaled(arm["points"], "xy", 10**6), np.repeat(joints[i], 2, axis=0)[1:-1])
        np.testing.assert_array_equal(scaled(arm["colors"], "rgb", 10**3), np.repeat(colours[i], 2, axis=0))
        centres = scaled([s["pose"]["position"] for s in entity["spheres"][1:]], "xy", 10**6)
        np.testing.assert_array_equal(centres, joints[i])


def test_curves_of_several_sizes_give_each_size_the_messages_of_its_own_batch():
    ctrl, part, builder = _first_block("arc", 6, 0.05)
    ks = np.arange(0, len(part.t), 5)[:6]
    q = part.q[ks]
    joints, stamp = ctrl.chain.joints_np(q), stamps(np.round(part.t[ks] * 1e9).astype(np.int64))
    targets = joints[:, -1] + 0.01
    curves = [ctrl.curve.sample(float(t), n=2 + i % 2, extent=1.0) for i, t in enumerate(part.t[ks])]
    got = builder._scenes(part.link_margins[ks], stamp, joints, None, targets, curves)
    for size in (2, 3):
        rows = [i for i, c in enumerate(curves) if len(c) == size]
        alone = builder._scenes(part.link_margins[ks][rows], stamp[rows], joints[rows], None, targets[rows],
                                np.array([curves[i] for i in rows]))
        assert [got[i] for i in rows] == alone
    assert all(b'"points":[' in text for text in got)


def test_the_straight_lines_ends_are_the_curves_own_sampling_to_rounding():
    sc = load_scenario("line").with_overrides(links=6)
    ctrl = sc.controller()
    builder = scene.SceneBuilder(ctrl, sc.obstacles)
    times = np.linspace(0.0, 37.0, 41)
    ends = builder.line_ends(times)
    assert ends.shape == (41, 2, 2)
    want = np.array([ctrl.curve.sample(float(t), n=2, extent=builder.reach) for t in times])
    np.testing.assert_allclose(ends, want, rtol=0, atol=1e-13)
    assert np.array_equal(builder.line_ends(times[:7]), ends[:7])       # another block length: the same values
    assert builder.line_ends(times[:0]) is None
    assert scene.SceneBuilder(load_scenario("arc").controller(), []).line_ends(times) is None


def test_scenes_as_views_are_the_scenes_as_bytes():
    ctrl, part, builder = _first_block("thread", 5, 0.02)
    builder.advance(part)
    ks, ns = np.array([0, 3, 7]), np.array([0, 3 * 10**6, 7 * 10**6])
    plain = builder.messages(part, ks, ns)
    assert plain[0][0] == "fixed"                    # once, the first time
    builder.views = True
    views = builder.messages(part, ks, ns)
    assert [(k, n, bytes(d)) for k, n, d in views] == plain[1:]
    assert [type(d) for k, _, d in views if k == "scene"] == [memoryview] * 3
