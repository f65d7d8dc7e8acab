"""Physical validity in 3-D: every distance against an independent computation, the broad phase
against all pairs, and runs that touch a sphere or thread a plate's hole (API and command line)."""
import math

import numpy as np
import pytest
from scipy.optimize import minimize
from scipy.spatial import cKDTree

from coordarm.cli import main
from coordarm.simulation.distance3d import segment_segment_distance
from coordarm.simulation.obstacles3d import bounding_box, capsule_gaps, obstacle3d_from_spec, plate_axes
from coordarm.simulation.physical3d import close_pairs, link_ends, self_gaps
from coordarm.simulation.run import simulate
from coordarm.simulation.scenario import Scenario
from coordarm.symbolic import CollisionError, ConfigError, SpatialChain

RNG = np.random.default_rng(7)


def sampled(a, b, n=801):
    """n points along the segment ab."""
    s = np.linspace(0.0, 1.0, n)[:, None]
    return a + s * (b - a)


# ------------------------------------------------------------------------------------- segment-segment
def test_segment_segment_distance_is_the_minimum_over_both_segments():
    for _ in range(60):
        p1, p2, q1, q2 = RNG.normal(size=(4, 3))
        if RNG.random() < 0.3:                       # nearly parallel pairs too
            q2 = q1 + (p2 - p1) * RNG.uniform(0.3, 2.0) + 1e-7 * RNG.normal(size=3)
        f = lambda x: np.linalg.norm(p1 + x[0] * (p2 - p1) - q1 - x[1] * (q2 - q1))
        pts_p, pts_q = sampled(p1, p2, 401), sampled(q1, q2, 401)
        d = np.linalg.norm(pts_p[:, None] - pts_q[None], axis=-1)
        i, j = np.unravel_index(np.argmin(d), d.shape)
        best = minimize(lambda x: f(x) ** 2, [i / 400, j / 400], bounds=[(0, 1), (0, 1)], method="L-BFGS-B",
                        options={"ftol": 1e-15, "gtol": 1e-12})
        want = min(math.sqrt(best.fun), d[i, j])
        got = float(segment_segment_distance(p1, p2, q1, q2))
        assert got <= want + 1e-12 and want - got < 1e-6, (got, want)


def test_crossing_segments_are_at_distance_zero_and_vectorised_shapes_broadcast():
    got = segment_segment_distance([[-1, 0, 0], [-1, 0, 0.5]], [[1, 0, 0], [1, 0, 0.5]], [0, -1, 0], [0, 1, 0])
    np.testing.assert_allclose(got, [0.0, 0.5], atol=1e-15)


# ------------------------------------------------------------------------------------- capsule-obstacle
def sphere_points(c, r, n=40000):
    k = np.arange(n) + 0.5
    phi, z = np.pi * (1 + 5 ** 0.5) * k, 1 - 2 * k / n
    return c + r * np.column_stack([np.sqrt(1 - z * z) * np.cos(phi), np.sqrt(1 - z * z) * np.sin(phi), z])


def box_points(centre, size, axes, n=120):
    h, g = 0.5 * np.asarray(size), np.linspace(-1, 1, n)
    U, V = np.meshgrid(g, g)
    pts = []
    for k in range(3):
        i, j = [x for x in range(3) if x != k]
        for sgn in (-1, 1):
            p = np.zeros((n * n, 3))
            p[:, i], p[:, j], p[:, k] = U.ravel() * h[i], V.ravel() * h[j], sgn * h[k]
            pts.append(p)
    return np.asarray(centre) + np.vstack(pts) @ np.asarray(axes)


def nearest_on_cloud(cloud, a, b, radius):
    return float(np.min(cKDTree(cloud).query(sampled(a, b, 2001))[0])) - radius


def test_capsule_sphere_gap_against_sampled_surface():
    ob = obstacle3d_from_spec({"kind": "sphere", "name": "ball", "centre": [0.2, -0.1, 0.3], "radius": 0.25}, 0)
    cloud = sphere_points(ob.centre, 0.25)
    for _ in range(25):
        a, b = RNG.uniform(-0.8, 0.8, size=(2, 3))
        if np.min(np.linalg.norm(sampled(a, b) - ob.centre, axis=1)) < 0.27:
            continue
        got = float(capsule_gaps(a, b, 0.02, ob))
        want = nearest_on_cloud(cloud, a, b, 0.02)
        assert got <= want + 1e-9 and want - got < 2e-3, (got, want)


def test_capsule_cylinder_gap_against_sampled_axes():
    ob = obstacle3d_from_spec({"kind": "cylinder", "name": "strut", "a": [0.0, 0.5, -1.0], "b": [0.0, 0.5, 1.0],
                               "radius": 0.03, "caps": "round"}, 0)
    axis = sampled(np.array([0.0, 0.5, -1.0]), np.array([0.0, 0.5, 1.0]), 20001)
    for _ in range(25):
        a, b = RNG.uniform(-1.2, 1.2, size=(2, 3))
        want = float(np.min(cKDTree(axis).query(sampled(a, b, 4001))[0])) - 0.03 - 0.01
        got = float(capsule_gaps(a, b, 0.01, ob))
        assert got <= want + 1e-9 and want - got < 2e-4, (got, want)


def test_capsule_box_gap_against_sampled_faces_rotated_box():
    spec = {"kind": "box", "name": "block", "centre": [0.3, -0.4, 0.1], "size": [0.2, 0.3, 0.4],
            "rotation": {"axis": [1.0, 2.0, 0.5], "angle": 0.7}}
    ob = obstacle3d_from_spec(spec, 0)
    k = np.array([1.0, 2.0, 0.5]) / np.linalg.norm([1.0, 2.0, 0.5])
    K = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    R = np.eye(3) + math.sin(0.7) * K + (1 - math.cos(0.7)) * K @ K       # columns: the rotated x, y, z
    cloud = box_points(spec["centre"], spec["size"], R.T)
    inside = lambda p: np.all(np.abs((p - spec["centre"]) @ R) <= 0.5 * np.array(spec["size"]), axis=-1)
    hits = 0
    for _ in range(40):
        a, b = RNG.uniform(-0.6, 1.0, size=(2, 3)) + np.array([0.0, -0.6, 0.0])
        got = float(capsule_gaps(a, b, 0.01, ob))
        if np.any(inside(sampled(a, b, 4001))):
            hits += 1
            assert got == -0.01
            continue
        want = nearest_on_cloud(cloud, a, b, 0.01)
        assert got <= want + 1e-9 and want - got < 3e-3, (got, want)
    assert hits > 0


HOLES = [{"centre": [1.0, 0.0, 0.2], "radius": 0.08}, {"centre": [1.0, -0.15, -0.2], "size": [0.12, 0.06]}]
PLATE = {"name": "casing", "kind": "plate", "point": [1.0, 0.0, 0.0], "normal": [1.0, 0.0, 0.0],
         "thickness": 0.04, "extent": 0.4, "holes": HOLES}


def plate_cloud(n=500):
    """Surface points of PLATE (faces minus holes, hole walls, outer rim), in its frame (u = y, v = z)."""
    g = np.linspace(-0.4, 0.4, n)
    U, V = (x.ravel() for x in np.meshgrid(g, g))
    keep = ~(np.hypot(U - 0.0, V - 0.2) < 0.08) & ~((np.abs(U + 0.15) < 0.06) & (np.abs(V + 0.2) < 0.03))
    U, V = U[keep], V[keep]
    faces = [np.column_stack([U, V, np.full_like(U, w)]) for w in (-0.02, 0.02)]
    w = np.linspace(-0.02, 0.02, 21)
    ang = np.linspace(0, 2 * np.pi, 1200)
    A, W = (x.ravel() for x in np.meshgrid(ang, w))
    wall = [np.column_stack([0.08 * np.cos(A), 0.2 + 0.08 * np.sin(A), W])]
    t = np.linspace(-1, 1, 300)
    T, W2 = (x.ravel() for x in np.meshgrid(t, w))
    for cu, cv, p, q in ((-0.15, -0.2, 0.06, 0.03), (0.0, 0.0, 0.4, 0.4)):
        wall += [np.column_stack([cu + p * T, np.full_like(T, cv + s * q), W2]) for s in (-1, 1)]
        wall += [np.column_stack([np.full_like(T, cu + s * p), cv + q * T, W2]) for s in (-1, 1)]
    return np.vstack(faces + wall)


def in_plate(local):
    u, v, w = local[..., 0], local[..., 1], local[..., 2]
    solid = (np.abs(w) <= 0.02) & (np.abs(u) <= 0.4) & (np.abs(v) <= 0.4)
    return solid & ~(np.hypot(u, v - 0.2) < 0.08) & ~((np.abs(u + 0.15) < 0.06) & (np.abs(v + 0.2) < 0.03))


def test_plate_axes_are_the_documented_ones():
    np.testing.assert_allclose(plate_axes(np.array([1.0, 0.0, 0.0])), [[0, 1, 0], [0, 0, 1], [1, 0, 0]], atol=1e-15)
    np.testing.assert_allclose(plate_axes(np.array([0.0, 0.0, 1.0])), [[1, 0, 0], [0, 1, 0], [0, 0, 1]], atol=1e-15)


def test_capsule_plate_gap_against_sampled_surface_near_holes_and_rims():
    ob = obstacle3d_from_spec(PLATE, 0)
    to_local = lambda p: (p - np.array([1.0, 0.0, 0.0]))[..., [1, 2, 0]]      # u = y, v = z, w = x - 1
    tree = cKDTree(plate_cloud())
    centres = [(0.0, 0.2), (-0.15, -0.2), (0.4, 0.1), (0.1, 0.1)]
    through, checked = 0, 0
    for i in range(200):
        cu, cv = centres[i % 4]
        mid = np.array([1.0 + RNG.uniform(-0.08, 0.08), cu + RNG.uniform(-0.1, 0.1), cv + RNG.uniform(-0.1, 0.1)])
        d = RNG.normal(size=3)
        if i % 2:
            d[0] += 3 * np.sign(d[0])                # steep: through the plate or its holes
        a, b = mid - 0.12 * d / np.linalg.norm(d), mid + 0.12 * d / np.linalg.norm(d)
        got = float(capsule_gaps(a, b, 0.005, ob))
        axis = sampled(a, b, 4001)
        if np.any(in_plate(to_local(axis))):
            assert got == -0.005
            continue
        through += bool(np.any(np.abs(axis[:, 0] - 1.0) < 0.02))
        want = float(np.min(tree.query(to_local(axis))[0])) - 0.005
        checked += 1
        assert got <= want + 1e-9 and want - got < 2e-3, (i, got, want)
    assert through >= 5 and checked >= 30


def test_a_segment_through_a_hole_is_at_the_holes_radius_and_a_tilted_one_at_its_rim():
    ob = obstacle3d_from_spec(PLATE, 0)
    straight = capsule_gaps(np.array([0.8, 0.0, 0.2]), np.array([1.2, 0.0, 0.2]), 0.01, ob)
    assert abs(straight - (0.08 - 0.01)) < 1e-12
    off = capsule_gaps(np.array([0.8, 0.03, 0.2]), np.array([1.2, 0.03, 0.2]), 0.0, ob)
    assert abs(off - 0.05) < 1e-12
    # a segment along w offset by 0.05 in u, ending 0.01 above the face over the hole: nearest the rim point
    top = capsule_gaps(np.array([1.03, 0.0, 0.25]), np.array([1.3, 0.0, 0.25]), 0.0, ob)
    assert abs(top - math.hypot(0.01, 0.08 - 0.05)) < 1e-9
    # leaving the slab inside the hole towards the rim: v = 0.2 + 0.2 s, w = 0.1 s; the nearest point is on
    # the rim at s = 0.36 (d/ds of (0.08 - 0.2 s)^2 + (0.1 s - 0.02)^2 = 0), below both ends' 0.04 and 0.08
    rim = capsule_gaps(np.array([1.0, 0.0, 0.2]), np.array([1.1, 0.0, 0.4]), 0.0, ob)
    assert abs(rim - math.sqrt(0.008 ** 2 + 0.016 ** 2)) < 1e-9


def test_bad_plates_are_errors_naming_the_field():
    cases = [({"holes": [{"centre": [1.0, 0.0, 0.2], "radius": -1}]}, "obstacles[1].holes[0].radius"),
             ({"holes": [{"centre": [1.3, 0.0, 0.2], "radius": 0.05}]}, "obstacles[1].holes[0].centre"),
             ({"holes": [{"centre": [1.0, 0.38, 0.0], "radius": 0.05}]}, "obstacles[1].holes[0]: the hole reaches"),
             ({"holes": [{"centre": [1.0, 0.0, 0.2], "radius": 0.05}, {"centre": [1.0, 0.0, 0.25], "size": [0.1, 0.1]}]},
              "obstacles[1].holes[1]: overlaps"),
             ({"thickness": 0}, "obstacles[1].thickness"), ({"normal": [0, 0, 0]}, "obstacles[1].normal"),
             ({"depth": 1}, "obstacles[1].depth")]
    for change, field in cases:
        with pytest.raises(ConfigError) as err:
            obstacle3d_from_spec({**PLATE, **change}, 1)
        assert str(err.value).startswith(field), str(err.value)
    with pytest.raises(ConfigError, match=r"obstacles\[0\].caps"):
        obstacle3d_from_spec({"kind": "cylinder", "a": [0, 0, 0], "b": [0, 0, 1], "radius": 0.1, "caps": "flat"}, 0)


# --------------------------------------------------------------------------------------- self-collision
def test_broad_phase_finds_exactly_the_pairs_brute_force_finds():
    total = 0
    for m in (5, 17, 60, 200):
        chain = SpatialChain(m, 0.1)
        q = RNG.normal(scale=0.9, size=(3, 2 * m))
        a, b, _ = link_ends(chain, q)
        radius, clearance = 0.03, 0.01
        s, i, j, gap = self_gaps(a, b, radius, clearance)
        found = {(int(k), int(x), int(y)) for k, x, y, g in zip(s, i, j, gap) if g <= clearance}
        I, J = np.triu_indices(m, 2)
        d = segment_segment_distance(a[:, I], b[:, I], a[:, J], b[:, J]) - 2 * radius
        ks, ps = np.nonzero(d <= clearance)
        want = {(int(k), int(I[p]), int(J[p])) for k, p in zip(ks, ps)}
        assert found == want
        total += len(want)
        s2, i2, j2 = close_pairs(np.minimum(a, b), np.maximum(a, b), 2 * radius + clearance)
        assert np.all(np.abs(i2 - j2) > 1)
    assert total > 20


@pytest.mark.parametrize("compiled", [True, False])
def test_the_box_sweep_finds_every_pair_of_boxes_within_reach(compiled):
    """close_pairs (in C) and close_pairs_numpy give exactly the non-adjacent pairs whose boxes come within
    reach along x, y and z, compared pair by pair; a NaN sample has none of its NaN links' pairs."""
    from coordarm.simulation.physical3d import close_pairs_numpy

    sweep, rng = close_pairs if compiled else close_pairs_numpy, np.random.default_rng(12)
    total = 0
    for m, scale, reach in ((5, 0.9, 0.0), (17, 0.4, 0.02), (60, 1.2, 0.01), (200, 0.3, 0.05)):
        chain = SpatialChain(m, 0.1)
        q = rng.normal(scale=scale, size=(12, 2 * m))
        q[3, m:] = np.nan if m > 5 else q[3, m:]
        a, b, _ = link_ends(chain, q)
        lo, hi = np.minimum(a, b), np.maximum(a, b)
        found = set(zip(*[x.tolist() for x in sweep(lo, hi, reach)]))
        I, J = np.triu_indices(m, 2)
        near = np.ones((len(q), len(I)), bool)
        for c in range(3):
            near &= (lo[:, J, c] <= hi[:, I, c] + reach) & (lo[:, I, c] <= hi[:, J, c] + reach)
        ks, ps = np.nonzero(near)
        want = {(int(k), int(I[p]), int(J[p])) for k, p in zip(ks, ps)}
        assert found == want
        total += len(want)
    assert total > 100


# ------------------------------------------------------------------------------------------------ runs
def spatial(obstacles=(), **chain):
    return {"chain": {"links": 8, "link_length": 0.1, "joints": "universal", "joint_limit": 1.4, **chain},
            "curve": {"kind": "line", "point": [0.0, 0.0, 0.0], "direction": [1.0, 0.0, 0.0], "normal": [0.0, 1.0, 0.0]},
            "control": {"gain": 2.0, "speed": 0.1}, "start": {"kind": "zigzag", "beta": 0.6},
            "run": {"duration": 1.0, "step": 0.01}, "obstacles": list(obstacles)}


BALL = {"kind": "sphere", "name": "ball", "centre": [0.75, 0.0, 0.0], "radius": 0.05}


def run(sc, **kw):
    ctrl = sc.controller()
    return simulate(ctrl, sc.start(ctrl), sc.duration, sc.step, backend="interpreted", progress=False,
                    physical=sc.physical(ctrl.chain), **kw)


def test_a_run_into_a_sphere_stops_naming_the_link_and_the_ball():
    with pytest.raises(CollisionError) as err:
        run(Scenario.from_dict(spatial([BALL])))
    c = err.value.contact
    assert (c.kind, c.obstacle, c.links) == ("wall", "ball", (8,)) and c.value <= 0 and 0 < c.time < 1.0
    allowed = run(Scenario.from_dict(spatial([BALL])), allow_contact=True)
    assert allowed.t[-1] == pytest.approx(1.0) and allowed.info["contacts"][0]["obstacle"] == "ball"


def test_a_chain_threads_a_plates_hole_but_not_a_smaller_one():
    plate = {"kind": "plate", "name": "casing", "point": [0.3, 0.0, 0.0], "normal": [1.0, 0.0, 0.0],
             "thickness": 0.02, "holes": [{"centre": [0.3, 0.0, 0.0], "radius": 0.06}]}
    done = run(Scenario.from_dict(spatial([plate])))
    assert done.t[-1] == pytest.approx(1.0) and not done.info.get("contacts")
    gap = Scenario.from_dict(spatial([plate])).physical().clearances(done.q, done.t)["casing"][0]
    assert 0 < gap < 0.06
    small = dict(plate, holes=[{"centre": [0.3, 0.0, 0.0], "radius": 0.035}])
    with pytest.raises(ConfigError, match="'casing'"):
        Scenario.from_dict(spatial([small]), "small.toml").start()


def test_self_overlap_and_bends_at_the_start_are_refused_naming_links():
    with pytest.raises(ConfigError, match="links 1 and 3"):
        Scenario.from_dict(spatial(radius=0.2)).start()
    with pytest.raises(ConfigError, match="joint 2"):
        Scenario.from_dict(spatial(joint_limit=1.0)).start()


TOML = """
[chain]
links = 8
link_length = 0.1
joints = "universal"
joint_limit = 1.4
[curve]
kind = "line"
point = [0.0, 0.0, 0.0]
direction = [1.0, 0.0, 0.0]
normal = [0.0, 1.0, 0.0]
[control]
gain = 2.0
speed = 0.1
[start]
beta = 0.6
[run]
duration = 1.0
step = 0.01
[[obstacles]]
name = "ball"
kind = "sphere"
centre = [CX, 0.0, 0.0]
radius = 0.05
"""


@pytest.mark.parametrize("cx, code, words", [(0.3, 2, "'ball'"), (0.75, 4, "link 8 touches or crosses 'ball'")])
def test_the_command_line_exits_2_for_a_bad_start_and_4_for_a_contact(tmp_path, capsys, cx, code, words):
    path = tmp_path / "ball.toml"
    path.write_text(TOML.replace("CX", str(cx)))
    out = tmp_path / "ball.mcap"
    assert main(["run", str(path), "--backend", "interpreted", "--no-figures", "--out", str(out)]) == code
    text = capsys.readouterr()
    assert words in text.out + text.err


def test_wireframes_lie_on_the_obstacles_and_the_scene_and_figure_draw_them(tmp_path):
    from coordarm.simulation.obstacles3d import wireframe
    from coordarm.simulation.scene3d import SpatialSceneBuilder

    ball = obstacle3d_from_spec(BALL, 0)
    for p in wireframe(ball):
        np.testing.assert_allclose(np.linalg.norm(p - [0.75, 0.0, 0.0], axis=1), 0.05, atol=1e-12)
    plate = obstacle3d_from_spec(PLATE, 0)
    lines = wireframe(plate)
    assert len(lines) == 2 * (1 + len(HOLES))
    rim = lines[1]                                        # the circular hole's rim on the face x = 0.98
    np.testing.assert_allclose(np.hypot(rim[:, 1], rim[:, 2] - 0.2), 0.08, atol=1e-12)
    np.testing.assert_allclose(rim[:, 0], 0.98, atol=1e-12)
    box = obstacle3d_from_spec({"kind": "box", "centre": [0.1, 0.2, 0.3], "size": [0.2, 0.4, 0.6]}, 0)
    corners = np.vstack(wireframe(box))
    np.testing.assert_allclose(np.abs(corners - [0.1, 0.2, 0.3]), np.broadcast_to([0.1, 0.2, 0.3], corners.shape),
                               atol=1e-12)
    sc = Scenario.from_dict(spatial([BALL]))
    ctrl = sc.controller()
    assert len(SpatialSceneBuilder(ctrl, sc.obstacles)._fixed_lines) == 3
    done = run(Scenario.from_dict(spatial([BALL])), allow_contact=True)
    from coordarm.simulation.figures3d import spatial_figures
    import matplotlib.image
    stages, _ = spatial_figures(done, sc, ctrl, tmp_path / "ball")
    assert matplotlib.image.imread(stages).shape[2] in (3, 4)


def test_allow_contact_records_the_contact_and_the_summary_shows_it_and_the_clearance(tmp_path, capsys):
    path = tmp_path / "ball.toml"
    path.write_text(TOML.replace("CX", "0.75"))
    args = ["run", str(path), "--backend", "interpreted", "--no-figures", "--out", str(tmp_path / "b.mcap")]
    assert main(args + ["--allow-contact"]) == 0
    out = capsys.readouterr().out
    assert "contacts      1 distinct (allowed), first: wall at t = 0.700 s, links [8]" in out
    gap = float(out.split("clearance     'ball': min ")[1].split()[0])
    ball = obstacle3d_from_spec(BALL, 0)
    assert gap < 0 and gap == pytest.approx(float(capsule_gaps(*tip_at_end(path), 0.01, ball)), abs=1e-4)


def tip_at_end(path):
    """The last link's axis at the end of the allowed run, from a run of the same scenario here."""
    sc = Scenario.from_dict(__import__("tomllib").loads(path.read_text()))
    done = run(sc, allow_contact=True)
    a, b, _ = link_ends(sc.chain(), done.q[-1:])
    return a[0, -1], b[0, -1]


def test_segments_just_above_a_rectangular_hole_against_the_sampled_face():
    ob = obstacle3d_from_spec({"kind": "plate", "point": [0, 0, 0], "normal": [0, 0, 1.0], "thickness": 0.02,
                               "holes": [{"centre": [0, 0, 0], "size": [0.3, 0.1]}]}, 0)
    g = np.linspace(-0.4, 0.4, 801)
    U, V = (x.ravel() for x in np.meshgrid(g, g))
    keep = ~((np.abs(U) < 0.15) & (np.abs(V) < 0.05))
    tree = cKDTree(np.column_stack([U[keep], V[keep], np.full(keep.sum(), 0.01)]))
    for _ in range(100):
        a, b = (np.r_[RNG.uniform(-0.2, 0.2, 2), RNG.uniform(0.011, 0.05)] for _ in range(2))
        got = float(capsule_gaps(a, b, 0.0, ob))
        want = float(tree.query(sampled(a, b, 3001))[0].min())
        assert got <= want + 1e-9 and want - got < 2e-3, (got, want)


def test_a_spatial_scenario_with_obstacles_round_trips_through_its_spec():
    data = spatial([PLATE, BALL, {"kind": "box", "centre": [0, 1, 0], "size": [0.1, 0.1, 0.1],
                                  "rotation": {"axis": [0, 0, 1], "angle": 0.3}}], radius=0.02, clearance=0.005)
    sc = Scenario.from_dict(data)
    again = Scenario.from_dict(sc.spec)
    assert again.spec == sc.spec and [o.name for o in again.obstacles] == ["casing", "ball", "box 3"]
    ph = again.physical()
    assert (ph.radius, ph.clearance, ph.limit) == (0.02, 0.005, 1.4)
    assert Scenario.from_dict(spatial()).physical().radius == pytest.approx(0.01)
    with pytest.raises(ConfigError, match=r"^bad.toml: obstacles\[1\].holes\[0\].radius"):
        Scenario.from_dict(spatial([BALL, dict(PLATE, holes=[{"centre": [1.0, 0.0, 0.2], "radius": "big"}])]),
                           "bad.toml")
    with pytest.raises(ConfigError, match=r"^bad.toml: chain.radius: only a universal chain"):
        Scenario.from_dict({**data, "chain": {"links": 6, "link_length": 0.1, "radius": 0.01}, "obstacles": []},
                           "bad.toml")


# ------------------------------------------------------------------------------------- broad phase
BROAD = [{"kind": "sphere", "centre": [0.45, 0.05, 0.0], "radius": 0.06},
         {"kind": "cylinder", "a": [0.7, -1.0, 0.03], "b": [0.72, 1.0, -0.02], "radius": 0.02},
         {"kind": "box", "centre": [0.25, -0.1, 0.05], "size": [0.1, 0.12, 0.08],
          "rotation": {"axis": [1.0, 2.0, 0.5], "angle": 0.7}},
         {"kind": "plate", "point": [0.95, 0.0, 0.0], "normal": [1.0, 0.2, 0.1], "thickness": 0.02, "extent": 0.3,
          "holes": [{"centre": [0.95, 0.0, 0.05], "radius": 0.06}]},
         {"kind": "plate", "point": [0.0, 0.0, -0.12], "normal": [0.0, 0.0, 1.0], "thickness": 0.01}]


def test_an_obstacles_bounding_box_holds_its_sampled_surface():
    obs = [obstacle3d_from_spec(o, i) for i, o in enumerate(BROAD)]
    sphere, cylinder, box, plate, floor = obs
    R = box.axes
    clouds = {"sphere": sphere_points(sphere.centre, sphere.radius),
              "cylinder": np.vstack([sphere_points(c, cylinder.radius, 4000) for c in sampled(cylinder.centre, cylinder.end, 201)]),
              "box": box_points(box.centre, 2 * box.half, R, 60),
              "plate": box_points(plate.centre, 2 * plate.half, plate.axes, 60)}
    for ob in obs[:4]:
        lo, hi = bounding_box(ob)
        cloud = clouds[ob.kind]
        assert np.all(cloud >= lo - 1e-12) and np.all(cloud <= hi + 1e-12), ob.kind
        assert np.allclose(cloud.min(axis=0), lo, atol=2e-3) and np.allclose(cloud.max(axis=0), hi, atol=2e-3), ob.kind
    lo, hi = bounding_box(floor)                          # unbounded in its plane, its thickness along z
    assert np.all(np.isinf(lo[:2])) and np.all(np.isinf(hi[:2])) and np.allclose([lo[2], hi[2]], [-0.125, -0.115])


def test_the_broad_phase_keeps_every_contact_of_all_pairs():
    """Physical3D.check measures only the links whose boxes meet an obstacle's: the same contacts, with the same
    gaps, as measuring every link against every obstacle, on folded and stretched poses among five obstacles;
    also in samples whose joints are NaN from some joint on (their links up to it still count)."""
    from coordarm.simulation.physical import Contact
    from coordarm.simulation.physical3d import Physical3D
    from coordarm.symbolic.geometry import touching

    obs = [obstacle3d_from_spec(o, i) for i, o in enumerate(BROAD)]
    chain = SpatialChain(12, 0.1)
    rng = np.random.default_rng(11)
    q = rng.normal(scale=0.35, size=(300, chain.dof))
    for k in range(0, 300, 7):
        q[k, rng.integers(4, chain.dof):] = np.nan
    t = np.arange(300) * 0.01
    for clearance in (0.0, 0.01):
        phys = Physical3D(chain, math.pi, 0.015, clearance, obs)
        got = [x for x in phys.check(t, q) if x.kind == "wall"]
        a, b, _ = link_ends(chain, q)
        want = []
        for ob in obs:
            g = capsule_gaps(a, b, 0.015, ob, within=clearance)
            want += [(k, Contact("wall", float(t[k]), (int(j) + 1,), float(g[k, j]), clearance, ob.name))
                     for k, j in zip(*np.nonzero(touching(g, clearance)))]
        want = [c for _, c in sorted(want, key=lambda x: (int(x[0]), x[1].links))]
        assert len({c.obstacle for c in got}) == 5 and len(got) > 100
        assert any(np.isnan(q[round(c.time / 0.01)]).any() for c in got)   # some in a partly NaN sample
        assert got == want


def all_pairs_clearances(phys, q, t):
    """Physical3D.clearances as it was: every (row, link) pair measured, argmin over them all."""
    from coordarm.simulation.distance3d import plate_point_distance
    a, b, _ = link_ends(phys.chain, q)
    out = {}
    for ob in phys.obstacles:
        within = math.inf
        if ob.kind == "plate":
            within = float(np.min(plate_point_distance((a - ob.centre) @ ob.axes.T, ob.half[2], ob.extent,
                                                       ob.holes))) - phys.radius
        g = capsule_gaps(a, b, phys.radius, ob, within=within)
        k, j = np.unravel_index(int(np.argmin(g)), g.shape)
        out[ob.name] = (float(g[k, j]), float(t[k]), int(j) + 1)
    return out


@pytest.mark.parametrize("case", ["broad", "broad with a NaN row", "pipe3d", "port"])
def test_the_summarys_clearances_measure_only_the_blocks_that_may_hold_the_smallest_gap(case):
    """Physical3D.clearances (links' bounding spheres over blocks of rows bound each obstacle's gaps; only the
    blocks that may hold the smallest are measured) gives what measuring every pair gives: the same gap, time
    and link, on random poses among a sphere, a cylinder, a box and two plates (one with a hole) and on the
    pipe3d (44 cylinders) and port (plate with a hole, sphere, box) runs."""
    from coordarm.simulation.physical3d import Physical3D
    from coordarm.simulation.run import even_indices
    from coordarm.simulation.scenario import load_scenario

    if case.startswith("broad"):         # row counts that are, and are not, whole blocks of 32
        chain = SpatialChain(12, 0.1)
        phys = Physical3D(chain, math.pi, 0.015, 0.0, [obstacle3d_from_spec(o, i) for i, o in enumerate(BROAD)])
        poses = []
        for n, seed in [(500, 21), (33, 0), (33, 2), (100, 1), (1, 3)]:
            q = np.random.default_rng(seed).normal(scale=0.35, size=(n, chain.dof))
            if "NaN" in case:
                q[n // 2, 9] = np.nan
            poses.append(q)
    else:
        sc = load_scenario(case)
        ctrl = sc.controller()
        run = simulate(ctrl, sc.start(ctrl), sc.duration, sc.step, sc.t0, backend="compiled", progress=False)
        phys, poses = sc.physical(ctrl.chain), [run.q[even_indices(len(run.t), 2000)]]
    for q in poses:
        t = np.arange(len(q)) * 0.01
        got = phys.clearances(q, t)
        want = all_pairs_clearances(phys, q, t)
        assert list(got) == list(want) and all(np.array_equal(got[k], want[k], equal_nan=True) for k in want)
        assert len(want) >= 3
