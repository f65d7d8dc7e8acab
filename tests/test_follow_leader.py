"""Follow-the-leader (ftl) of a rail robot: closed-form facts on a straight path, brute-force geometry on a bent one."""
import numpy as np
import pytest
from scipy.spatial import cKDTree

from coordarm.analysis.follow_leader import FollowTheLeader, simulate_ftl
from coordarm.symbolic import ConfigError, CoordinatingController, Line, Path, PlanarChain, follow_curve

#: Spacing of the brute-force polyline of the path [m].
SPACING = 2e-4


def rail_ctrl(curve, m=10, speed=0.2, angle=0.0, limits=(-5.0, 5.0)):
    chain = PlanarChain(m, 0.1, base="rail", rail_angle=angle, rail_limits=limits)
    return CoordinatingController(chain, curve, 2.0, speed)


def bent_path():
    return Path((-0.3, 0.0), 0.0, [{"line": 1.3}, {"arc": 0.8, "radius": 0.7}, {"arc": -0.6, "radius": 0.9},
                                   {"line": 1.5}])


def test_on_a_straight_path_along_the_rail_ftl_feeds_at_v_star_and_the_joints_rest():
    ctrl = rail_ctrl(Line(angle=0.3), angle=0.3, speed=0.17)
    q0 = follow_curve(ctrl, 1.2, d=0.1)
    run = simulate_ftl(FollowTheLeader(ctrl, q0), 1.0, 0.01, "interpreted")
    assert run.info["stopped"] == "completed" and len(run.t) == 101
    np.testing.assert_allclose(run.u[:, 0], 0.17, rtol=0, atol=1e-12)            # d_dot = v*
    np.testing.assert_allclose(run.q[:, 0], 0.1 + 0.17 * run.t, rtol=0, atol=1e-12)
    np.testing.assert_allclose(run.u[:, 1:], 0.0, rtol=0, atol=1e-11)            # joints at rest
    np.testing.assert_allclose(run.q[:, 1:], np.broadcast_to(q0[1:], run.q[:, 1:].shape), rtol=0, atol=1e-13)


def brute_force_distance(path, points):
    """Distance of each point to the path drawn as a polyline of vertices SPACING apart (its chords lie
    within the sagitta SPACING^2 / (8 R) of the path)."""
    s = np.arange(-1.0, path.length + 1.0, SPACING)
    poly = np.array([path.point_at(x) for x in s])
    _, k = cKDTree(poly).query(points)
    best = np.full(len(points), np.inf)
    for a, b in ((k - 1, k), (k, k + 1)):
        a, b = np.clip(a, 0, len(poly) - 1), np.clip(b, 0, len(poly) - 1)
        seg = poly[b] - poly[a]
        lam = np.clip(np.einsum("ij,ij->i", points - poly[a], seg) / np.maximum(np.einsum("ij,ij->i", seg, seg),
                                                                                1e-300), 0, 1)
        best = np.minimum(best, np.linalg.norm(points - poly[a] - lam[:, None] * seg, axis=1))
    return best


def test_on_a_bent_path_every_central_point_stays_on_it_and_the_end_point_leads_at_v_star():
    path = bent_path()
    ctrl = rail_ctrl(path, m=30, speed=0.25)
    q0 = follow_curve(ctrl, 1.1, d=0.0)
    law = FollowTheLeader(ctrl, q0)
    run = simulate_ftl(law, 3.6, 0.01, "compiled")       # the base stays on the first, straight part
    assert run.info["stopped"] == "completed"
    Y = ctrl.chain.centres_np(run.q)                                  # forward kinematics of the logged q
    s_end = np.array([ctrl.task.geometry(y, 0.0)[3] for y in Y[:, -1]], dtype=float).ravel()
    assert s_end[0] < 1.86 and s_end[-1] > 2.4        # from the first bend (s = 1.3..1.86) past the second (..2.4)
    dist = brute_force_distance(path, Y.reshape(-1, 2))
    sagitta = SPACING ** 2 / (8 * 0.7)
    assert np.max(dist) < sagitta + 1e-12
    assert np.max(dist) > 0.1 * sagitta                                # the chords' own error: the check is sharp
    # the end point is where v* puts it
    np.testing.assert_allclose(s_end, law.s0 + 0.25 * run.t, rtol=0, atol=1e-10)
    # the laid chain moves continuously: steps of at most 0.03 rad per 10 ms (about 3 rad/s where links cross
    # the bends' curvature jumps; a jump to another root of a link's placement would move a joint by ~2 beta)
    assert np.max(np.abs(np.diff(run.q, axis=0))) < 0.05
    # the fold's span changes as links cross the bends: the rail speeds up and slows down around v*
    assert run.u[:, 0].min() < 0.2 and run.u[:, 0].max() > 0.3


def test_compiled_ftl_equals_the_interpreted_one():
    ctrl = rail_ctrl(bent_path(), m=8)
    law = FollowTheLeader(ctrl, follow_curve(ctrl, 1.1, d=0.5))
    runs = [simulate_ftl(law, 3.0, 0.05, b) for b in ("compiled", "interpreted")]
    assert runs[0].info["backend"] == "compiled"
    np.testing.assert_allclose(runs[0].q, runs[1].q, rtol=0, atol=1e-12)


def test_ftl_stops_at_the_rail_limit_and_needs_a_rail_and_a_start_on_the_path():
    ctrl = rail_ctrl(Line(), limits=(-0.1, 0.3))
    q0 = follow_curve(ctrl, 1.2, d=0.0)
    run = simulate_ftl(FollowTheLeader(ctrl, q0), 3.0, 0.01, "compiled")
    assert run.info["stopped"] == "rail_limit" and run.q[-1, 0] <= 0.3 < run.q[-1, 0] + 0.2 * 0.01 + 1e-12
    assert run.t[-1] == pytest.approx(1.5, abs=0.011)
    with pytest.raises(ConfigError, match="rail"):
        FollowTheLeader(CoordinatingController(PlanarChain(5, 0.1), Line(), 2.0, 0.1), np.zeros(5))
    with pytest.raises(ConfigError, match="on the path"):
        FollowTheLeader(ctrl, ctrl.chain.zigzag(1.2, heading=0.1))
