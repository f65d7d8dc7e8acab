"""Physical checks against brute force: segment distances, self-contacts, obstacles, joint limits, starts."""
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from coordarm.simulation.obstacles import link_distances, obstacles_from_spec, outline
from coordarm.simulation.physical import check_configuration
from coordarm.simulation.scenario import Scenario
from coordarm.symbolic import Arc, CoordinatingController, Line, PlanarChain, project_onto_curve
from coordarm.symbolic.errors import ConfigError
from coordarm.symbolic.geometry import segment_distance, self_distances


def brute_segment_distance(p1, p2, q1, q2, n=2001):
    """Smallest distance from n points along p1p2 to the segment q1q2 (projection clipped by hand).

    An upper bound of the true distance, within one sampling step of it.
    """
    a = p1 + np.linspace(0, 1, n)[:, None] * (p2 - p1)
    t = np.clip(((a - q1) @ (q2 - q1)) / ((q2 - q1) @ (q2 - q1)), 0, 1)
    return float(np.min(np.linalg.norm(a - (q1 + t[:, None] * (q2 - q1)), axis=-1)))


coords = st.floats(-2, 2, allow_nan=False)


@settings(max_examples=200, deadline=None)
@given(st.lists(coords, min_size=8, max_size=8))
def test_segment_distance_matches_dense_sampling(v):
    p1, p2, q1, q2 = (np.array(v[i:i + 2]) for i in range(0, 8, 2))
    if np.allclose(p1, p2) or np.allclose(q1, q2):
        return
    d = float(segment_distance(p1, p2, q1, q2))
    brute, step = brute_segment_distance(p1, p2, q1, q2), np.linalg.norm(p2 - p1) / 2000
    assert brute - step - 1e-12 <= d <= brute + 1e-12


def test_crossing_segments_are_at_distance_zero_and_parallel_ones_at_their_gap():
    assert segment_distance(np.array([0, 0.]), np.array([1, 1.]), np.array([0, 1.]), np.array([1, 0.])) == 0
    assert segment_distance(np.array([0, 0.]), np.array([1, 0.]), np.array([0, .3]), np.array([1, .3])) == pytest.approx(.3)


@settings(max_examples=30, deadline=None)
@given(st.integers(3, 40), st.integers(0, 2**31 - 1))
def test_sort_and_sweep_finds_every_close_pair_of_all_pairs(m, seed):
    rng = np.random.default_rng(seed)
    q = rng.uniform(-2.8, 2.8, size=(3, m))
    chain = PlanarChain(m, 0.1)
    J = chain.joints_np(q)
    s, la, lb, d = self_distances(J, 0.02)
    got = {(int(k), int(a), int(b)): float(x) for k, a, b, x in zip(s, la, lb, d) if x < 0.02}
    want = {}
    for k in range(3):                    # all pairs, O(m^2), independently
        for a in range(m):
            for b in range(a + 2, m):
                x = float(segment_distance(J[k, a], J[k, a + 1], J[k, b], J[k, b + 1]))
                if x < 0.02:
                    want[(k, a + 1, b + 1)] = x
    assert got.keys() == want.keys()
    for key in got:
        assert got[key] == pytest.approx(want[key], abs=1e-15)


def test_sweep_over_many_samples_of_a_folding_chain_equals_all_pairs_with_contacts_and_touching():
    """Hundreds of samples at once (the flat indices of every sample's pairs), compact zig-zags
    shaken until links cross, touch end to end (distance exactly 0) and come within the clearance:
    the pairs within the clearance and their distances equal the all-pairs computation per sample,
    and the distances are those of a pair-by-pair scalar call."""
    m, clearance = 24, 0.03
    chain = PlanarChain(m, 0.1)
    rng = np.random.default_rng(11)
    q = chain.zigzag(1.45)[None] + rng.normal(scale=0.25, size=(200, m))
    q[0] = [0.0, math.pi / 2, math.pi / 2, math.pi / 2] + [0.0] * (m - 4)   # link 5 ends on link 1's end
    J = chain.joints_np(q)
    s, la, lb, d = self_distances(J, clearance)
    got = {(int(k), int(a), int(b)): float(x) for k, a, b, x in zip(s, la, lb, d) if x < clearance}
    i, j = np.triu_indices(m, k=2)
    want = {}
    for k in range(len(q)):
        dist = segment_distance(J[k, i], J[k, i + 1], J[k, j], J[k, j + 1])
        want.update({(k, int(a) + 1, int(b) + 1): float(x) for a, b, x in zip(i, j, dist) if x < clearance})
    assert got.keys() == want.keys() and got == want
    assert sum(x == 0 for x in got.values()) > 20 and sum(0 < x < clearance for x in got.values()) > 20
    assert got[(0, 1, 5)] < 1e-15                                          # touching, to rounding
    for (k, a, b), x in list(got.items())[::7]:
        assert float(segment_distance(J[k, a - 1], J[k, a], J[k, b - 1], J[k, b])) == x


def test_obstacles_parse_with_default_names_from_1_and_draw_their_outline():
    obs = obstacles_from_spec([{"a": [0, 0], "b": [1, 0]}, {"center": [2, 0], "radius": 0.5, "name": "post"},
                               {"points": [[0, 1], [1, 1], [1, 2]]}])
    assert [o.name for o in obs] == ["wall 1", "post", "wall 3"]
    assert [o.kind for o in obs] == ["segment", "circle", "polygon"]
    ring = outline(obs[1])
    np.testing.assert_allclose(np.linalg.norm(ring - [2, 0], axis=1), 0.5)
    np.testing.assert_array_equal(outline(obs[2])[[0, -1]], [[0, 1], [0, 1]])     # closed
    with pytest.raises(ConfigError, match=r"obstacles\[0\]"):
        obstacles_from_spec([{"center": [0, 0]}])
    with pytest.raises(ConfigError, match="unique"):
        obstacles_from_spec([{"a": [0, 0], "b": [1, 0], "name": "x"}, {"a": [0, 1], "b": [1, 1], "name": "x"}])


def test_link_distances_to_a_disc_and_a_polygon_including_a_link_inside():
    disc, poly = obstacles_from_spec([{"center": [0.5, 1.0], "radius": 0.25},
                                      {"points": [[-1, -1], [3, -1], [3, -0.5], [-1, -0.5]]}])
    J = np.array([[[0.0, 0.0], [1.0, 0.0], [1.0, -0.7], [1.2, -0.6]]])   # link 3 lies inside the box
    # nearest points by hand: (0.5, 0), the corner (1, 0), the end (1.2, -0.6)
    np.testing.assert_allclose(link_distances(J, disc)[0], [0.75, math.hypot(0.5, 1.0) - 0.25,
                                                            math.hypot(0.7, 1.6) - 0.25], rtol=1e-12)
    np.testing.assert_allclose(link_distances(J, poly)[0], [0.5, 0.0, 0.0])


def test_check_configuration_reports_limits_self_contacts_and_walls_with_names():
    chain = PlanarChain(6, 0.1, joint_limit=[2.8, 2.8, 1.0, 2.8, 2.8])
    q = np.array([0.0, 0.3, 0.0, 1.2, 0.0, 0.0])       # joint 4 past its per-joint limit of 1.0
    wall, = obstacles_from_spec([{"a": [0.2, -1], "b": [0.2, 1], "name": "door"}])   # across link 3
    found = check_configuration(chain, q, [wall])
    kinds = [(c.kind, c.links, c.obstacle) for c in found]
    assert ("joint_limit", (3, 4), None) in kinds
    assert [x for x in kinds if x[0] == "wall"] == [("wall", (3,), "door")]
    assert [x for x in kinds if x[0] == "joint_limit"] == [("joint_limit", (3, 4), None)]
    folded = np.array([0.0, 2.7, 2.7, 2.7, 0.0, 0.0])  # links 1 and 4 come back across each other
    found = check_configuration(PlanarChain(6, 0.1), folded)
    assert any(c.kind == "self" for c in found)
    assert check_configuration(PlanarChain(6, 0.1), PlanarChain(6, 0.1).zigzag(1.3)) == []


def test_joint_limit_and_clearance_are_validated():
    with pytest.raises(ConfigError, match="joint_limit"):
        PlanarChain(4, 0.1, joint_limit=[2.8, 2.8])
    with pytest.raises(ConfigError, match="joint 3"):
        PlanarChain(4, 0.1, joint_limit=[2.8, 4.0, 2.8])
    with pytest.raises(ConfigError, match="clearance"):
        PlanarChain(4, 0.1, clearance=-1.0)
    spec = {"chain": {"links": 4, "link_length": 0.1, "joint_limit": "x"}, "curve": {"kind": "line"},
            "control": {"gain": 1.0}}
    with pytest.raises(ConfigError, match="chain.joint_limit"):
        Scenario.from_dict(spec)


def test_projected_start_on_an_arc_is_a_compact_valid_zigzag_on_the_curve():
    """The arc case of the issue: the old projection put 29 of 63 joints at +-pi."""
    chain = PlanarChain(64, 0.1)
    ctrl = CoordinatingController(chain, Arc(radius=2.2), 2.0, 0.0)
    q = project_onto_curve(ctrl, chain.zigzag(1.3))
    assert np.max(np.abs(ctrl.evaluate(q, 0.0)["e"])) < 1e-11
    assert np.all(np.abs(q[1:]) < 2.7) and np.all(np.abs(q[1:]) > 2.5)      # compact: about 2 beta
    assert check_configuration(chain, q) == []
    # independent: the body spans about (m-1) xi cos(beta) of arc, not the stretched 6.3 m
    s_end = ctrl.evaluate(q, 0.0)["s"]
    assert s_end == pytest.approx(63 * 0.1 * math.cos(1.3), rel=0.05)


def test_a_start_that_needs_a_joint_beyond_its_limit_names_the_link():
    chain = PlanarChain(10, 0.1, joint_limit=0.5)
    ctrl = CoordinatingController(chain, Line(angle=0.0), 2.0, 0.0)
    with pytest.raises(ConfigError, match="link 2 cannot be placed"):
        project_onto_curve(ctrl, chain.zigzag(1.3))


def test_a_zigzag_start_beyond_the_joint_limit_is_a_config_error_naming_the_joint():
    spec = {"chain": {"links": 8, "link_length": 0.1}, "curve": {"kind": "line"}, "control": {"gain": 1.0},
            "start": {"kind": "zigzag", "beta": 1.45}}
    with pytest.raises(ConfigError, match="joint 2 .*limit"):
        Scenario.from_dict(spec).start()


@settings(max_examples=15, deadline=None)
@given(st.integers(5, 40), st.floats(0.8, 5.0), st.floats(0.4, 1.35), st.floats(-3.0, 3.0), st.booleans())
def test_projected_starts_are_on_the_curve_within_limits_or_refused_naming_a_link(m, radius, beta, angle, flip):
    chain = PlanarChain(m, 0.1)
    ctrl = CoordinatingController(chain, Arc(angle=angle, radius=radius), 2.0, 0.0)
    try:
        q = project_onto_curve(ctrl, chain.zigzag(-beta if flip else beta, angle))
    except ConfigError as exc:
        assert "link" in str(exc)
        return
    assert np.max(np.abs(ctrl.evaluate(q, 0.0)["e"])) < 1e-9
    assert np.all(np.abs(q[1:]) <= 2.8)
    J = chain.joints_np(q)                       # independent all-pairs check of the result
    for a in range(m):
        for b in range(a + 2, m):
            assert segment_distance(J[a], J[a + 1], J[b], J[b + 1]) > 0


def loop_over_edges(joints, obstacle):
    """The distance as computed before the bounding-box pruning: every edge measured, the minimum."""
    from coordarm.simulation.obstacles import edges, inside_polygon
    from coordarm.symbolic.geometry import segment_distance
    a, b = joints[:, :-1], joints[:, 1:]
    d = np.full(a.shape[:-1], np.inf)
    for e0, e1 in edges(obstacle):
        d = np.minimum(d, segment_distance(a, b, e0, e1))
    if obstacle.kind == "polygon":
        d = np.where(inside_polygon(a, obstacle.points), 0.0, d)
    return d


def test_pruned_link_distances_equal_every_edge_measured_bit_for_bit():
    """The pipe's two wall polygons (28 corners each) and a wall segment, against chains laid through
    the pipe, shaken (links crossing the walls and lying inside them), plus a NaN sample; the C kernel's
    distances (the samples without NaN) too."""
    from coordarm.generated.chain_geometry import edge_distances
    from coordarm.simulation.obstacles import edges
    from coordarm.simulation.scenario import load_scenario
    sc = load_scenario("pipe")
    ctrl = sc.controller()
    chain = ctrl.chain
    rng = np.random.default_rng(3)
    Q = sc.start(ctrl)[None] + rng.normal(scale=0.06, size=(200, chain.dof))
    Q[:, 0] += rng.uniform(0.0, 2.5, 200)                   # slid along the rail, into the bends
    Q[-1, 5] = np.nan
    J = chain.joints_np(Q)
    wall = obstacles_from_spec([{"name": "w", "a": [1.0, -0.3], "b": [2.5, 0.4]}])[0]
    for ob in [*sc.obstacles, wall]:
        ref, new = loop_over_edges(J, ob), link_distances(J, ob)      # a NaN sample: numpy's pruned search
        np.testing.assert_array_equal(new, ref)
        assert (ref == 0).sum() > 100 and (ref > 0.05).sum() > 100 and np.isnan(ref[-1, 4:]).all()
        compiled = edge_distances(J[:-1], edges(ob), ob.points if ob.kind == "polygon" else None)
        if compiled is not None:                                       # all finite: in C, the same bits
            assert compiled.tobytes() == ref[:-1].tobytes() == link_distances(J[:-1], ob).tobytes()
