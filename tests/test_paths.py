"""Composite paths: the CasADi closed forms vs an independent plain-numpy geometry (dense sampling)."""
import math

import numpy as np
import pytest

from coordarm import Path, curve_from_spec
from coordarm.analysis.orthonormal import check_orthonormal
from coordarm.symbolic import ConfigError, CoordinatingController, PlanarChain, project_onto_curve
from coordarm.symbolic.motions import Ramp, Sinusoid
from coordarm.generated import compile as compile_controller

ISSUE_PATH = {"kind": "path", "start": [0.3, -0.2], "heading": 0.4, "transition": 0,
              "segments": [{"line": 0.5}, {"arc": 1.0, "radius": 0.6}, {"arc": -1.5, "radius": 0.45},
                           {"line": 1.0}]}
RAY = 3.0


def dense_polyline(start, heading, segments, h=2e-5):
    """Independent geometry: the path walked with complex numbers, rays of length RAY at both ends.

    Returns points (N, 2), their arc lengths (N,) and unit tangents (N, 2).
    """
    z, d = complex(*start), complex(math.cos(heading), math.sin(heading))
    pts, ss, tans = [], [], []
    s_back = np.arange(-RAY, 0.0, h)
    pts.append(z + s_back * d), ss.append(s_back), tans.append(np.full(len(s_back), d))
    s = 0.0
    for seg in segments:
        if "line" in seg:
            x = np.arange(0.0, seg["line"], h)
            pts.append(z + x * d), ss.append(s + x), tans.append(np.full(len(x), d))
            z, s = z + seg["line"] * d, s + seg["line"]
        else:
            A, R = seg["arc"], seg["radius"]
            L = abs(A) * R
            x = np.arange(0.0, L, h)
            turn = np.exp(1j * np.sign(A) * x / R)
            centre = z + np.sign(A) * 1j * d * R
            pts.append(centre + (z - centre) * turn), ss.append(s + x), tans.append(d * turn)
            z, d, s = centre + (z - centre) * np.exp(1j * A), d * np.exp(1j * A), s + L
    x = np.arange(0.0, RAY, h)
    pts.append(z + x * d), ss.append(s + x), tans.append(np.full(len(x), d))
    P, S, T = (np.concatenate(v) for v in (pts, ss, tans))
    return np.c_[P.real, P.imag], S, np.c_[T.real, T.imag]


def brute_force(y, dense):
    """Nearest dense sample to each of the points ``y`` (K, 2): its ``(phi, psi)``."""
    P, S, T = dense
    out = []
    for p in np.atleast_2d(y):
        dv = p - P
        k = int(np.argmin(np.einsum("ij,ij->i", dv, dv)))
        out.append((T[k, 0] * dv[k, 1] - T[k, 1] * dv[k, 0], S[k]))
    return np.array(out)


def random_tube_points(path, rng, n, frac=0.8):
    """Points within ``frac`` of the tube around the path (including the rays), in the path frame."""
    s = rng.uniform(-1.0, path.length + 1.0, n)
    off = rng.uniform(-frac, frac, n) * min(path.tube_radius, 0.3)
    pts = []
    for si, oi in zip(s, off):
        p = path.point_at(si)
        ds = 1e-6
        t = (path.point_at(si + ds) - path.point_at(si - ds)) / (2 * ds)
        t /= np.linalg.norm(t)
        pts.append(p + oi * np.array([-t[1], t[0]]))
    return np.array(pts), s, off


@pytest.mark.parametrize("spec", [ISSUE_PATH,
                                  {"kind": "path", "start": [0, 0], "heading": -1.0, "transition": 0,
                                   "segments": [{"arc": 2.5, "radius": 0.5}, {"line": 0.3}, {"arc": -4.0, "radius": 0.4}]}],
                         ids=["issue-example", "arcs-at-both-ends-and-a-long-arc"])
def test_phi_psi_match_brute_force_nearest_point(spec):
    path = curve_from_spec(spec)
    f = path.functions()
    dense = dense_polyline(spec["start"], spec["heading"], spec["segments"])
    rng = np.random.default_rng(1)
    pts, s_true, off_true = random_tube_points(path, rng, 60)
    ref = brute_force(pts, dense)
    phi, psi = (np.asarray(v).ravel() for v in f.map(len(pts))(pts.T, 0.0))
    np.testing.assert_allclose(phi, ref[:, 0], atol=1e-8)
    np.testing.assert_allclose(psi, ref[:, 1], atol=2e-5)          # sample spacing 2e-5 m
    own = np.abs(ref[:, 0] - off_true) < 1e-6        # the point's own foot is the nearest (the path may curl back)
    assert own.sum() >= 50
    np.testing.assert_allclose(phi[own], off_true[own], atol=1e-9)
    np.testing.assert_allclose(psi[own], s_true[own], atol=1e-9)


def test_junction_points_are_c1_by_finite_differences():
    path = curve_from_spec(ISSUE_PATH)
    geo = CoordinatingController(PlanarChain(3, 0.1), path, 1.0, 0.0).task.geometry
    f = path.functions()
    for s_j, heading in ((0.5, 0.4), (1.1, 1.4), (1.775, -0.1)):    # the three junctions
        for off in (-0.2, 0.0, 0.3):
            p = path.point_at(s_j)
            t = np.array([math.cos(heading), math.sin(heading)])
            n = np.array([-t[1], t[0]])
            y = p + off * n
            phi, gphi, _, psi, gpsi, _ = (np.asarray(v).ravel() for v in geo(y, 0.0))
            assert phi == pytest.approx(off, abs=1e-12) and psi == pytest.approx(s_j, abs=1e-12)
            h = 1e-7      # phi is C1 but not C2 across a junction: a difference there is O(h / R) accurate
            for k in range(2):
                e = np.eye(2)[k] * h
                for side in (1, -1):                  # one-sided differences from both sides agree
                    dphi = side * (float(f(y + side * e, 0)[0]) - float(f(y, 0)[0])) / h
                    assert dphi == pytest.approx(gphi[k], abs=5 * h / 0.45)
            np.testing.assert_allclose(gphi, n, atol=1e-12)      # both sides agree: the normal there
            if off == 0.0:
                np.testing.assert_allclose(gpsi, t / np.linalg.norm(t), atol=1e-12)


def test_rigid_motion_moves_phi_psi_and_their_time_derivatives_match_finite_differences():
    moving = Path((0.3, -0.2), 0.4, ISSUE_PATH["segments"], offset=(Sinusoid(0.2, 0.7), Ramp(0.0, 0.05)),
                  rotation=Sinusoid(0.3, 0.5), transition=0)
    geo = CoordinatingController(PlanarChain(3, 0.1), moving, 1.0, 0.0).task.geometry
    f = moving.functions()
    rng = np.random.default_rng(2)
    pts, s_true, off_true = random_tube_points(moving, rng, 20)
    for t in (0.0, 1.7):
        th, o = 0.3 * math.sin(0.5 * t), np.array([0.2 * math.sin(0.7 * t), 0.05 * t])
        R = np.array([[math.cos(th), -math.sin(th)], [math.sin(th), math.cos(th)]])
        world = moving.start + o + (pts - moving.start) @ R.T           # rotate about start, then shift
        for y, s0, e0 in zip(world, s_true, off_true):
            phi, _, phit, psi, _, psit = geo(y, t)
            phi, phit, psi, psit = (float(v) for v in (phi, phit, psi, psit))
            assert phi == pytest.approx(e0, abs=1e-10) and psi == pytest.approx(s0, abs=1e-10)
            h = 1e-5
            plus, minus = f(y, t + h), f(y, t - h)
            assert phit == pytest.approx((float(plus[0]) - float(minus[0])) / (2 * h), abs=1e-8)
            assert psit == pytest.approx((float(plus[1]) - float(minus[1])) / (2 * h), abs=1e-8)


def test_path_is_orthonormalised_on_it_at_several_times():
    moving = Path((0.3, -0.2), 0.4, ISSUE_PATH["segments"], offset=(0.0, Ramp(0.0, 0.01)),
                  rotation=Sinusoid(0.2, 1.0))
    res = check_orthonormal(moving, times=[0.0, 2.0], points=200)
    assert res.ok and res.worst_deviation < 1e-12 and res.off_curve < 1e-12


def test_waypoints_fillets_against_independent_corner_geometry():
    pts = [[0.0, 0.0], [1.0, 0.0], [1.5, 0.8], [2.5, 0.8]]
    r = 0.3
    path = Path.from_waypoints(pts, r, transition=0)
    f = path.functions()
    P = np.array(pts)
    for i in (1, 2):                                  # each fillet: tangent points at r tan(a/2) from the corner
        a_in, a_out = P[i] - P[i - 1], P[i + 1] - P[i]
        a_in, a_out = a_in / np.linalg.norm(a_in), a_out / np.linalg.norm(a_out)
        turn = math.atan2(a_in[0] * a_out[1] - a_in[1] * a_out[0], a_in @ a_out)
        trim = r * math.tan(abs(turn) / 2)
        bisector = (a_out - a_in) / np.linalg.norm(a_out - a_in)
        centre = P[i] + bisector * r / math.cos(turn / 2)
        for tp in (P[i] - trim * a_in, P[i] + trim * a_out):
            assert float(f(tp, 0)[0]) == pytest.approx(0.0, abs=1e-12)
        assert float(f(centre + 0.5 * r * (P[i] - centre) / np.linalg.norm(P[i] - centre), 0)[0]) == \
            pytest.approx(math.copysign(0.5 * r, turn), abs=1e-12)
    # the end point's arc length: legs minus trims plus arc lengths
    legs = np.linalg.norm(np.diff(P, axis=0), axis=1)
    D = np.diff(P, axis=0)
    turns = [math.atan2(u[0] * v[1] - u[1] * v[0], u @ v) for u, v in zip(D[:-1], D[1:])]
    total = legs.sum() - sum(2 * r * math.tan(abs(a) / 2) - r * abs(a) for a in turns)
    assert float(f(P[-1], 0)[1]) == pytest.approx(total, abs=1e-12)
    assert path.to_spec()["kind"] == "waypoints"
    assert curve_from_spec(path.to_spec()).segments == path.segments


@pytest.mark.parametrize("points, radius, match", [
    ([[0, 0], [1, 0], [1, 0.2], [2, 0.2]], 0.3, "does not fit between curve.points"),
    ([[0, 0], [1, 0], [1, 0], [2, 1]], 0.1, r"curve.points\[1\] and curve.points\[2\] coincide"),
    ([[0, 0]], 0.1, "at least two points"),
    ([[0, 0], [1, 0], [2, 1]], -0.1, "curve.radius: must be > 0")])
def test_bad_waypoints_are_refused_naming_the_field(points, radius, match):
    with pytest.raises(ConfigError, match=match):
        curve_from_spec({"kind": "waypoints", "points": points, "radius": radius})


@pytest.mark.parametrize("segments, match", [([], "non-empty"), ([{"line": -1}], r"segments\[0\].line: length"),
                                             ([{"arc": 0.0, "radius": 1}], r"segments\[0\].arc"),
                                             ([{"arc": 1.0}], r"segments\[0\]: expected"),
                                             ([{"line": 1, "radius": 2}], r"segments\[0\]: expected")])
def test_bad_segments_are_refused_naming_the_field(segments, match):
    with pytest.raises(ConfigError, match=match):
        curve_from_spec({"kind": "path", "start": [0, 0], "heading": 0, "segments": segments})


def test_spec_round_trip_and_unknown_keys():
    spec = dict(ISSUE_PATH, offset=[0.0, {"kind": "ramp", "rate": 0.01}], rotation=0.0)
    path = curve_from_spec(spec)
    assert curve_from_spec(path.to_spec()).to_spec() == path.to_spec()
    with pytest.raises(ConfigError, match=r"unknown key\(s\) \['radius'\] for kind 'path'"):
        curve_from_spec(dict(ISSUE_PATH, radius=1.0))
    with pytest.raises(ConfigError, match=r"curve.heading: missing"):
        curve_from_spec({"kind": "path", "start": [0, 0], "segments": [{"line": 1}]})


def path_through_base():
    """A 4-segment path passing through the base (origin), heading along +x."""
    return Path((-0.6, 0.0), 0.0, [{"line": 0.8}, {"arc": 1.2, "radius": 0.5}, {"arc": -1.0, "radius": 0.7},
                                   {"line": 0.5}])


def test_law_structured_equals_dense_at_random_configurations_across_junctions():
    chain = PlanarChain(16, 0.1)
    path = path_through_base()
    ctrl = CoordinatingController(chain, path, 2.0, 0.1)
    q = project_onto_curve(ctrl, chain.zigzag(1.1), 0.0)
    y = chain.centres_np(q)
    s = np.asarray(ctrl.centre_geometry(q[None], [0.0])["psi"]).ravel()
    assert s.min() < 0.8 < s.max()                   # the body spans the first junction (s = 0.8)
    rng = np.random.default_rng(3)
    for _ in range(8):
        qk = q + rng.normal(scale=0.02, size=chain.m)
        out = ctrl.evaluate(qk, 0.3)
        M, rhs = ctrl.decoupling_matrices(qk[None], [0.3])
        u_dense = np.linalg.solve(M[0], rhs[0])
        np.testing.assert_allclose(out["u"], u_dense, rtol=1e-10, atol=1e-10 * np.max(np.abs(u_dense)))


def test_compiled_path_law_agrees_with_the_interpreted_law(tmp_path):
    chain = PlanarChain(12, 0.1)
    path = Path((-0.6, 0.0), 0.0, [{"line": 0.8}, {"arc": 1.2, "radius": 0.5}, {"arc": -1.0, "radius": 0.7}],
                offset=(Sinusoid(0.02, 1.0), 0.0), rotation=Sinusoid(0.1, 0.5))
    ctrl = CoordinatingController(chain, path, 2.0, 0.1)
    fast = compile_controller(ctrl, build_dir=tmp_path)
    rng = np.random.default_rng(4)
    q0 = project_onto_curve(ctrl, chain.zigzag(1.1), 0.0)
    for t in (0.0, 0.7, 2.1):
        q = q0 + rng.normal(scale=0.03, size=chain.m)
        a, b = ctrl.evaluate(q, t), fast.evaluate(q, t)
        for k in a:
            np.testing.assert_allclose(b[k], a[k], rtol=1e-12, atol=1e-12)


def test_a_point_leaving_the_tube_stops_the_run_naming_link_time_and_radius():
    from coordarm import TubeError, simulate
    from coordarm.simulation.limits import GainStepWarning
    from coordarm.symbolic import follow_curve
    chain = PlanarChain(20, 0.1)
    path = Path((0.0, 0.0), 0.0, [{"line": 0.4}, {"arc": 1.0, "radius": 0.25}, {"line": 1.5}], transition=0)
    ctrl = CoordinatingController(chain, path, 40.0, 0.0)
    q0 = follow_curve(ctrl, 1.0) + np.random.default_rng(5).normal(scale=1e-3, size=chain.m)
    # K h = 4 is beyond RK4's stability limit (2.79): the deviations grow until one leaves the tube
    with pytest.raises(TubeError, match=r"left the path's tube at t = .* link \d+ is .* smallest radius 0.25 m") as err, \
            pytest.warns(GainStepWarning, match="RK4 diverges"):                  # said before the run starts
        simulate(ctrl, q0, 5.0, 0.1, backend="interpreted", thresholds={"link": 0.0, "longitudinal": 0.0})
    run = err.value.run
    assert err.value.kind == "tube" and run.info["stopped"] == "tube"
    assert np.max(np.abs(run.e[-1])) >= 0.25 > np.max(np.abs(run.e[-2]))
    assert err.value.time == run.t[-1] and err.value.margin == np.max(np.abs(run.e[-1]))


def test_follow_curve_lays_a_zigzag_along_a_bent_path():
    from coordarm.symbolic import follow_curve
    chain = PlanarChain(30, 0.1)
    ctrl = CoordinatingController(chain, path_through_base(), 2.0, 0.1)
    q = follow_curve(ctrl, 1.1)
    g = ctrl.centre_geometry(q[None], [0.0])
    assert np.max(np.abs(g["phi"][0, 1:])) < 1e-9 and np.all(np.diff(g["psi"][0]) > 0)
    assert g["psi"][0, -1] > 1.4                      # past the second junction
    np.testing.assert_allclose(chain.centres_np(q)[0], 0.0)


@pytest.mark.parametrize("curve", [Path((0.3, -0.2), 0.4, ISSUE_PATH["segments"], rotation=Sinusoid(0.3, 1.0)),
                                   curve_from_spec({"kind": "line", "point": [0.1, 0.2], "angle": 0.3}),
                                   curve_from_spec({"kind": "circle", "center": [0.0, 1.0], "radius": 1.0}),
                                   curve_from_spec({"kind": "arc", "point": [0.0, 0.0], "angle": 0.2, "radius": 1.5})],
                         ids=["path", "line", "circle", "arc"])
def test_point_at_inverts_psi_and_lies_on_the_curve(curve):
    f = curve.functions()
    for s in (-0.3, 0.2, 0.9, 1.6, 2.8):
        p = curve.point_at(s, 0.7)
        phi, psi = (float(v) for v in f(p, 0.7))
        assert phi == pytest.approx(0.0, abs=1e-12) and psi == pytest.approx(s, abs=1e-12)


def test_the_scene_draws_the_whole_path_and_the_end_points_target(tmp_path):
    import json

    from mcap.reader import make_reader

    from coordarm import load_scenario, simulate
    from coordarm.simulation.mcap_writer import RunLogger
    scenario = load_scenario("line").with_overrides(links=10, duration=0.5, step=0.01)
    chain = scenario.chain()
    path = path_through_base()
    ctrl = CoordinatingController(chain, path, 2.0, Ramp(0.05, 0.2))
    from coordarm.symbolic import follow_curve
    out = tmp_path / "p.mcap"
    with RunLogger(out, scenario, ctrl, scene_rate=10) as log:
        run = simulate(ctrl, follow_curve(ctrl, 1.1), 0.5, 0.01, on_chunk=log.on_chunk)
    with open(out, "rb") as f:
        scenes = [(m.log_time, json.loads(m.data)) for _, _, m in make_reader(f).iter_messages(topics=["/scene"])]
    assert len(scenes) >= 5
    for ns, sc in scenes:
        t = ns / 1e9
        ent = sc["entities"][0]
        curve = np.array([[p["x"], p["y"]] for p in ent["lines"][1]["points"]])
        assert np.linalg.norm(curve[0] - np.array([-0.6, 0.0])) <= 0.5 + 1e-6          # from the start (a ray)
        assert np.linalg.norm(curve[-1] - path.point_at(path.length)) <= 0.5 + 1e-6     # to the end (a ray)
        target = ent["spheres"][0]["pose"]["position"]
        s_star = run.s[0] + 0.05 * t + 0.1 * t ** 2                                    # s(0) + integral of v*
        # the scene walks the drawn polyline (90 points) from the end point: a chord's accuracy
        np.testing.assert_allclose([target["x"], target["y"]], path.point_at(s_star), atol=5e-3)
