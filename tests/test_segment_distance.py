"""The 3-D distances in C (segment-segment, point-segment, segment-box, segment-plate) against their numpy
reference, bit for bit (random, degenerate and broadcast operands), and a spatial run's contacts with and
without the kernel."""
import numpy as np
import pytest

from coordarm.generated import segment_distance
from coordarm.generated.segment_distance import distance_library
from coordarm.simulation.distance3d import (GOLDEN_STEPS, box_frame, plate_search_numpy, point_segment_distance3,
                                            point_segment_distance3_numpy, segment_box_distance,
                                            segment_box_distance_numpy, segment_plate_distance, segment_segment_distance,
                                            segment_segment_distance_numpy)
from coordarm.simulation.obstacles3d import obstacle3d_from_spec

pytestmark = pytest.mark.skipif(distance_library() is None, reason="no working C compiler")


def segments(rng, n):
    """n random segment pairs, a fifth of them each: parallel, one or both of zero length, sharing an end."""
    p1, p2, q1, q2 = (rng.normal(size=(n, 3)) for _ in range(4))
    k = n // 5
    q2[:k] = q1[:k] + (p2[:k] - p1[:k]) * rng.uniform(0.2, 3.0, (k, 1))    # parallel
    p2[k:2 * k] = p1[k:2 * k]                                              # a point and a segment
    p2[2 * k:3 * k], q2[2 * k:3 * k] = p1[2 * k:3 * k], q1[2 * k:3 * k]    # two points
    q1[3 * k:4 * k] = p2[3 * k:4 * k]                                      # sharing an end
    return p1, p2, q1, q2


def test_the_kernel_gives_the_references_distances_to_the_last_bit(rng):
    p1, p2, q1, q2 = segments(rng, 50_000)
    got = segment_segment_distance(p1, p2, q1, q2)
    assert got.shape == (50_000,)
    np.testing.assert_array_equal(got, segment_segment_distance_numpy(p1, p2, q1, q2))
    np.testing.assert_array_equal(point_segment_distance3(p1, q1, q2), point_segment_distance3_numpy(p1, q1, q2))
    assert np.all(got[2 * 10_000:3 * 10_000] == np.linalg.norm(p1 - q1, axis=1)[2 * 10_000:3 * 10_000])


@pytest.mark.parametrize("shapes", [((3,), (4, 7, 3), (4, 7, 3), (3,)),          # an obstacle's axis: one segment
                                    ((4, 7, 3), (4, 7, 3), (3,), (3,)),
                                    ((4, 1, 3), (4, 7, 3), (7, 3), (1, 7, 3)),    # broadcast along other axes
                                    ((3,), (3,), (3,), (3,))])
def test_operands_broadcast_as_numpy_does(rng, shapes):
    ops = [rng.normal(size=s) for s in shapes]
    got = segment_segment_distance(*ops)
    want = segment_segment_distance_numpy(*ops)
    assert got.shape == want.shape == np.broadcast_shapes(*shapes)[:-1]
    np.testing.assert_array_equal(got, want)
    np.testing.assert_array_equal(point_segment_distance3(*ops[:3]), point_segment_distance3_numpy(*ops[:3]))


def test_operands_that_are_not_3_vectors_go_to_numpy_which_refuses_them(rng):
    assert segment_distance.segment_segment(np.zeros((5, 2)), np.ones((5, 2)), np.zeros(2), np.ones(2)) is None
    assert segment_distance.point_segment(np.zeros((5, 3)), np.ones((4, 3)), np.zeros(3)) is None
    with pytest.raises(ValueError):
        point_segment_distance3(np.zeros((5, 3)), np.ones((4, 3)), np.zeros(3))


def test_a_nan_end_gives_nan_as_numpy_does(rng):
    p1, p2, q1, q2 = segments(rng, 10)
    p1[3, 1] = np.nan
    got = segment_segment_distance(p1, p2, q1, q2)
    assert np.isnan(got[3]) and np.isfinite(np.delete(got, 3)).all()
    np.testing.assert_array_equal(got, segment_segment_distance_numpy(p1, p2, q1, q2))


def near_obstacle(rng, n, scale):
    """n random segments around the origin (size ``scale``), a sixth each: of zero length, parallel to an axis
    (a zero component: divisions by zero), lying in a coordinate plane, ending on the origin's axes."""
    a = rng.normal(size=(n, 3)) * scale
    b = a + rng.normal(size=(n, 3)) * scale
    k = n // 6
    b[:k] = a[:k]
    b[k:2 * k, 0] = a[k:2 * k, 0]
    b[2 * k:3 * k, 1:] = a[2 * k:3 * k, 1:]
    a[3 * k:4 * k, 2] = b[3 * k:4 * k, 2] = 0.0
    b[4 * k:5 * k, :2] = 0.0
    return a, b


def test_the_box_kernel_gives_the_references_distances_to_the_last_bit(rng):
    a, b = near_obstacle(rng, 60_000, 0.2)
    axes = np.linalg.qr(rng.normal(size=(3, 3)))[0]
    for R in (axes, np.eye(3)):                      # rotated; aligned (exact zeros in the frame)
        got = segment_box_distance(a, b, [0.02, -0.01, 0.03], R, [0.1, 0.2, 0.05])
        np.testing.assert_array_equal(got, segment_box_distance_numpy(a, b, [0.02, -0.01, 0.03], R, [0.1, 0.2, 0.05]))
        assert 0.05 < np.mean(got == 0) < 0.6 and np.all(got >= 0)      # inside or through it, and outside
    a, b = rng.normal(size=(4, 7, 3)), rng.normal(size=(4, 7, 3))           # leading axes kept
    got = segment_box_distance(a, b, np.zeros(3), axes, [0.3, 0.2, 0.1])
    assert got.shape == (4, 7)
    np.testing.assert_array_equal(got, segment_box_distance_numpy(a, b, np.zeros(3), axes, [0.3, 0.2, 0.1]))
    a[1, 2, 0] = np.nan
    got = segment_box_distance(a, b, np.zeros(3), axes, [0.3, 0.2, 0.1])
    assert np.isnan(got[1, 2]) and np.isfinite(np.delete(got.ravel(), 9)).all()


PLATES = [{"kind": "plate", "point": [0.0, 0.0, 0.0], "normal": [0.0, 0.0, 1.0], "thickness": 0.02, "extent": 0.4,
           "holes": [{"centre": [0.1, 0.1, 0.0], "radius": 0.05}, {"centre": [-0.2, -0.1, 0.0], "size": [0.1, 0.06]}]},
          {"kind": "plate", "point": [0.05, 0.0, 0.0], "normal": [1.0, 0.2, 0.1], "thickness": 0.03,
           "holes": [{"centre": [0.03, 0.1, 0.0], "size": [0.08, 0.2]}]},
          {"kind": "plate", "point": [0.0, 0.0, 0.01], "normal": [0.0, 0.0, 1.0], "thickness": 0.01}]


@pytest.mark.parametrize("spec", PLATES, ids=["square, circle and rectangle", "unbounded, tilted", "no holes"])
def test_the_plate_kernel_gives_the_references_distances_to_the_last_bit(rng, spec):
    plate = obstacle3d_from_spec(spec, 0)
    a, b = near_obstacle(rng, 6_000, 0.15)
    got = segment_plate_distance(a, b, plate)
    pa, pd = box_frame(a, b, plate.centre, plate.axes)
    want = plate_search_numpy(pa, pd, plate.half[2], plate.extent, plate.holes)
    np.testing.assert_array_equal(got, want)
    assert 0.05 < np.mean(got == 0) < 0.9 and np.all(got >= 0)
    within = segment_plate_distance(a, b, plate, within=0.02)          # beyond: the slab's bound, no search
    near = within <= 0.02
    np.testing.assert_array_equal(within[near], want[near])
    assert np.all(within[~near] <= want[~near]) and np.any(~near)
    assert segment_distance.segment_plate(pa, pd[:-1], 0.01, np.inf, (), GOLDEN_STEPS) is None   # shapes differ


def test_without_a_compiler_a_spatial_run_checks_the_same_contacts(monkeypatch):
    """A spatial chain through a cylinder, a sphere, a box and a plate: the same contacts (values to the last
    bit) whether the distances come from the kernel or from numpy."""
    from coordarm.simulation.obstacles3d import obstacle3d_from_spec
    from coordarm.simulation.physical3d import Physical3D
    from coordarm.symbolic import SpatialChain

    chain = SpatialChain(12, 0.1)
    obstacles = [obstacle3d_from_spec({"kind": "cylinder", "a": [0.5, -1, 0.02], "b": [0.5, 1, 0.02], "radius": 0.03}, 0),
                 obstacle3d_from_spec({"kind": "sphere", "centre": [0.9, 0.05, 0.0], "radius": 0.06}, 1),
                 obstacle3d_from_spec({"kind": "box", "centre": [0.7, 0.0, -0.03], "size": [0.05, 0.05, 0.05]}, 2),
                 obstacle3d_from_spec({"kind": "plate", "point": [0.3, 0.0, 0.0], "normal": [1.0, 0.0, 0.0],
                                       "thickness": 0.02, "holes": [{"centre": [0.3, 0.0, 0.0], "radius": 0.04}]}, 3)]
    rng = np.random.default_rng(5)
    q = 0.02 * rng.normal(size=(40, chain.dof))                  # nearly straight along x: through the cylinder
    q[20:, 1::2] += 2.6 * (np.arange(chain.m) % 2 == 1)          # folded: links alongside each other
    phys = Physical3D(chain, 2.0, 0.02, 0.005, obstacles)
    t = np.arange(40) * 0.01
    compiled = phys.check(t, q)
    monkeypatch.setattr(segment_distance, "distance_library", lambda: None)
    assert segment_distance.segment_segment(np.zeros(3), np.ones(3), np.zeros(3), np.ones(3)) is None
    assert {c.kind for c in compiled} >= {"wall", "self"}
    assert {c.obstacle for c in compiled if c.kind == "wall"} >= {"cylinder 1", "box 3", "plate 4"}
    assert phys.check(t, q) == compiled
