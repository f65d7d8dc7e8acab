"""``coordarm compare`` on spatial chains: the 3-D baselines, the shape deviation and ftl's laying, each against an
independent computation (finite differences of numpy kinematics, numpy's SVD and pinv, brute-force distances)."""
import json

import casadi as ca
import numpy as np
import pytest

from coordarm.analysis.baselines import EndPointRate, simulate_baseline
from coordarm.analysis.compare import SCORES, compare, parse_methods, score
from coordarm.analysis.follow_leader3d import SpatialLaying, check_rail, tip_components
from coordarm.analysis.spatial_baselines import inverse3, singular_value_ratio3
from coordarm.cli import main as cli_main
from coordarm.simulation.scenario import Scenario
from coordarm.symbolic import ConfigError
from tests.test_follow_leader import SPACING, brute_force_distance

K = 2.0
SPEC = {"name": "bend3d", "chain": {"links": 10, "link_length": 0.1, "joints": "universal", "joint_limit": 1.4},
        "curve": {"kind": "path", "start": [-0.05, 0.0, 0.0], "direction": [1.0, 0.0, 0.0], "normal": [0.0, 1.0, 0.0],
                  "segments": [{"line": 0.4}, {"arc": 0.6, "radius": 0.6, "bank": 0.9}, {"line": 1.0}]},
        "control": {"gain": K, "speed": 0.1}, "start": {"kind": "follow", "beta": 0.6},
        "run": {"duration": 1.0, "step": 0.005}}


def bend3d(**run):
    spec = json.loads(json.dumps(SPEC))
    spec["run"].update(run)
    return Scenario.from_dict(spec)


def end_point_outputs(ctrl, q, t):
    """(psi, phi_1, phi_2) of y^m from numpy kinematics and the curve's numeric Function."""
    y = ctrl.chain.centres_np(q)[-1]
    out = ctrl.curve.functions()(y, t)
    return np.r_[float(out[0]), np.asarray(out[1], float).ravel()]


def fd_task(ctrl, q, t, h=1e-6):
    """The task Jacobian (3, dof) by central differences of :func:`end_point_outputs`."""
    cols = []
    for k in range(len(q)):
        dq = np.zeros(len(q))
        dq[k] = h
        cols.append((end_point_outputs(ctrl, q + dq, t) - end_point_outputs(ctrl, q - dq, t)) / (2 * h))
    return np.column_stack(cols)


@pytest.mark.parametrize("seed", range(3))
def test_spatial_pinv_moves_the_end_point_as_commanded_and_is_numpys_minimum_norm_solution(seed):
    sc = bend3d()
    ctrl = sc.controller()
    centre = sc.start(ctrl)
    rng = np.random.default_rng(seed)
    q = centre + 0.05 * rng.standard_normal(ctrl.chain.dof)
    t = float(rng.uniform(0, 2))
    law = EndPointRate(ctrl, centre)
    u = law.control(q, t)
    h = 1e-6                                             # the outputs along q + eps u: d/deps = (v*, -K Phi)
    rate = (end_point_outputs(ctrl, q + h * u, t) - end_point_outputs(ctrl, q - h * u, t)) / (2 * h)
    out = end_point_outputs(ctrl, q, t)
    np.testing.assert_allclose(rate, np.r_[0.1, -K * out[1:]], rtol=0, atol=1e-7)
    A = fd_task(ctrl, q, t)                              # the static path: r = (v*, -K Phi)
    r = np.r_[0.1, -K * out[1:]]
    z = -(q - centre)
    Ap = np.linalg.pinv(A)
    np.testing.assert_allclose(u, Ap @ r + z - Ap @ (A @ z), rtol=0, atol=1e-6)


def test_eigenvalue_ratio_and_inverse_of_the_3x3_gram_matrix_match_numpy():
    G = ca.SX.sym("G", 3, 3)
    f = ca.Function("f", [G], [singular_value_ratio3(G), inverse3(G)])
    rng = np.random.default_rng(3)
    cases = [rng.standard_normal((3, 7)) for _ in range(20)]
    cases += [np.outer(rng.standard_normal(3), rng.standard_normal(7)),  # rank 1
              rng.standard_normal((3, 2)) @ rng.standard_normal((2, 7)),                                 # rank 2
              np.hstack([2.0 * np.eye(3), np.zeros((3, 4))]),                                            # G = 4 I
              np.diag([1.0, 1e-4, 0.3]) @ rng.standard_normal((3, 3))]
    for A in cases:
        sv = np.linalg.svd(A, compute_uv=False)
        ratio, inv = f(A @ A.T)
        assert float(ratio) == pytest.approx(sv[-1] / sv[0], abs=1e-7)
        if sv[-1] / sv[0] > 1e-3:
            np.testing.assert_allclose(np.asarray(inv), np.linalg.inv(A @ A.T), rtol=1e-9)


def test_spatial_dls_is_the_damped_solve_inside_its_band_and_pinv_outside():
    sc = bend3d()
    ctrl = sc.controller()
    q = sc.start(ctrl)
    pinv, narrow = EndPointRate(ctrl, q), EndPointRate(ctrl, q, {"lambda": 0.01, "band": 1e-9})
    np.testing.assert_allclose(narrow.control(q, 0.3), pinv.control(q, 0.3), rtol=0, atol=1e-14)
    wide = EndPointRate(ctrl, q, {"lambda": 0.05, "band": 1.0})
    A = fd_task(ctrl, q, 0.3)
    sv = np.linalg.svd(A, compute_uv=False)
    lam2 = 0.05 ** 2 * (1 - (sv[-1] / sv[0]) ** 2)
    r = np.r_[0.1, -K * end_point_outputs(ctrl, q, 0.3)[1:]]
    np.testing.assert_allclose(wide.control(q, 0.3), A.T @ np.linalg.solve(A @ A.T + lam2 * np.eye(3), r),
                               rtol=0, atol=1e-7)


def test_compiled_spatial_baseline_steps_equal_the_interpreted_ones():
    sc = bend3d()
    ctrl = sc.controller()
    q0 = sc.start(ctrl)
    law = EndPointRate(ctrl, q0, {"lambda": 0.05, "band": 1.0})
    runs = [simulate_baseline(law, q0, 0.1, 0.005, chunk=10, backend=b) for b in ("compiled", "interpreted")]
    assert runs[0].info["backend"] == "compiled" and len(runs[0].t) == 21
    np.testing.assert_allclose(runs[0].q, runs[1].q, rtol=0, atol=1e-12)


def test_shape_deviation_and_max_deviation_are_brute_force_distances_of_the_centres():
    sc = bend3d(duration=2.0)
    ctrl = sc.controller()
    q0 = sc.start(ctrl)
    run = simulate_baseline(EndPointRate(ctrl, q0), q0, 2.0, 0.005, backend="interpreted")
    scores = score(run, sc)
    Y = ctrl.chain.centres_np(run.q)[:, 1:]                                 # y^2..y^m at every sample
    dist = brute_force_distance(ctrl.curve, Y.reshape(-1, 3))
    sagitta = SPACING ** 2 / (8 * 0.6)
    expected = 100 * dist.mean() / (10 * 0.1)                                # % of the body length m xi
    assert expected > 0.05                                                  # pinv lets the body leave the path
    assert scores["shape_deviation"] == pytest.approx(expected, abs=100 * sagitta)
    assert scores["max_deviation"] == pytest.approx(dist.max(), abs=sagitta)
    assert list(scores) == list(SCORES)


def test_planar_shape_deviation_is_the_brute_force_mean_distance_too():
    spec = {"chain": {"links": 8, "link_length": 0.1},
            "curve": {"kind": "path", "start": [-0.05, 0.0], "heading": 0.0,
                      "segments": [{"line": 0.4}, {"arc": 0.8, "radius": 0.5}, {"line": 1.0}]},
            "control": {"gain": K, "speed": 0.15}, "start": {"kind": "follow", "beta": 1.0},
            "run": {"duration": 1.5, "step": 0.005}}
    sc = Scenario.from_dict(spec)
    ctrl = sc.controller()
    q0 = sc.start(ctrl)
    run = simulate_baseline(EndPointRate(ctrl, q0), q0, 1.5, 0.005, backend="interpreted")
    dist = brute_force_distance(ctrl.curve, ctrl.chain.centres_np(run.q)[:, 1:].reshape(-1, 2))
    expected = 100 * dist.mean() / (8 * 0.1)
    assert expected > 0.05
    assert score(run, sc)["shape_deviation"] == pytest.approx(expected, abs=100 * SPACING ** 2 / (8 * 0.5))


def test_coordinating_scores_on_a_spatial_scenario_are_the_laws_own_outputs():
    sc = bend3d()
    coord = compare(sc, ["coordinating"])[0]
    run, scores = coord.run, coord.scores
    e = run.e.reshape(len(run.t), -1, 2)                        # (phi_1, phi_2) of y^2..y^m, from the simulator
    norms = np.linalg.norm(e, axis=2)
    assert scores["max_deviation"] == pytest.approx(norms.max(), rel=1e-6, abs=1e-15)
    assert scores["shape_deviation"] == pytest.approx(100 * norms.mean() / 1.0, rel=1e-6, abs=1e-13)
    assert scores["final_s_error"] == pytest.approx(abs(run.s[-1] - run.s_reference()[-1]), abs=1e-12)
    assert scores["peak_u"] == pytest.approx(np.max(np.abs(run.u)), rel=1e-12)


def path_laying(m=10):
    spec = json.loads(json.dumps(SPEC))
    spec["chain"]["links"] = m
    sc = Scenario.from_dict(spec)
    ctrl = sc.controller()
    q0 = sc.start(ctrl)
    return sc, ctrl, q0, SpatialLaying(ctrl, tip_components(ctrl, q0, 0.0))


def test_ftl_laying_puts_every_centre_on_the_path_behind_the_end_point_at_its_target():
    sc, ctrl, q0, laying = path_laying(16)
    s0 = float(ctrl.curve.functions()(ctrl.chain.centres_np(q0)[-1], 0.0)[0])
    back = laying.lay(0.0, s0)
    np.testing.assert_allclose(back["q"], q0, rtol=0, atol=1e-9)           # the follow start, laid from the base
    np.testing.assert_allclose(back["base"], 0.0, rtol=0, atol=1e-9)
    for shift in (0.2, 0.45, 0.7):                                         # the end point into, through the bend
        laid = laying.lay(0.0, s0 + shift)
        assert laid["worst"] < 1e-9 and laid["s_error"] < 1e-9
        Y = ctrl.chain.centres_np(laid["q"]) + laid["base"]                # forward kinematics from the base point
        np.testing.assert_allclose(Y, laid["centres"], rtol=0, atol=1e-12)
        assert np.max(brute_force_distance(ctrl.curve, Y)) < SPACING ** 2 / (8 * 0.6) + 1e-12
        s = np.array([float(ctrl.curve.functions()(y, 0.0)[0]) for y in Y])
        assert s[-1] == pytest.approx(s0 + shift, abs=1e-9) and np.all(np.diff(s) > 0)
        d = ctrl.chain.directions_np(laid["q"])                            # rear end of link j+1 to y^j: xi/2
        rear = Y[1:] - 0.05 * d[1:]
        np.testing.assert_allclose(np.linalg.norm(rear - Y[:-1], axis=1), 0.05, rtol=0, atol=1e-12)
        tangent = np.array([np.asarray(ctrl.curve.functions()(Y[-1], 0.0)[k], float).ravel() for k in (2, 3, 4)])
        np.testing.assert_allclose(tangent @ d[-1], laying.tip, rtol=0, atol=1e-12)   # the tip link's roll kept


def test_ftl_laying_on_a_straight_line_is_the_start_zigzag_moved_along_it():
    spec = {"chain": {"links": 9, "link_length": 0.1, "joints": "universal"},
            "curve": {"kind": "line", "point": [0.0, 0.0, 0.0], "direction": [0.6, 0.8, 0.0], "normal": [0.0, 0.0, 1.0]},
            "control": {"gain": K, "speed": 0.1}, "start": {"kind": "zigzag", "beta": 0.9, "roll": 0.4},
            "run": {"duration": 1.0}}
    sc = Scenario.from_dict(spec)
    ctrl = sc.controller()
    q0 = sc.start(ctrl)
    laying = SpatialLaying(ctrl, tip_components(ctrl, q0, 0.0))
    s0 = float(ctrl.curve.functions()(ctrl.chain.centres_np(q0)[-1], 0.0)[0])
    laid = laying.lay(0.0, s0 + 0.37)
    np.testing.assert_allclose(laid["q"], q0, rtol=0, atol=1e-12)
    np.testing.assert_allclose(laid["base"], 0.37 * np.array([0.6, 0.8, 0.0]), rtol=0, atol=1e-12)


def test_ftl_on_a_spatial_chain_without_a_rail_is_refused_with_a_clear_message(capsys, tmp_path):
    sc = bend3d()
    assert parse_methods(None, sc) == ["coordinating", "pinv", "dls"]
    with pytest.raises(ConfigError, match="needs a robot on a rail"):
        parse_methods("coordinating,ftl", sc)
    with pytest.raises(ConfigError, match="fixed base"):
        check_rail(sc.chain(), "bend3d")
    toml = tmp_path / "bend3d.toml"
    toml.write_text(scenario_toml())
    assert cli_main(["compare", str(toml), "--methods", "ftl"]) == 2
    err = capsys.readouterr().err
    assert "ftl" in err and "rail" in err and "Traceback" not in err


def scenario_toml() -> str:
    return """name = "bend3d"
[chain]
links = 10
link_length = 0.1
joints = "universal"
joint_limit = 1.4
[curve]
kind = "path"
start = [-0.05, 0.0, 0.0]
direction = [1.0, 0.0, 0.0]
normal = [0.0, 1.0, 0.0]
segments = [{ line = 0.4 }, { arc = 0.6, radius = 0.6, bank = 0.9 }, { line = 1.0 }]
[control]
gain = 2.0
speed = 0.1
[start]
kind = "follow"
beta = 0.6
[run]
duration = 1.0
step = 0.005
"""


def test_compare_cli_on_a_spatial_scenario_writes_every_method_as_generated_c(tmp_path, capsys):
    toml = tmp_path / "bend3d.toml"
    toml.write_text(scenario_toml())
    out = tmp_path / "cmp"
    assert cli_main(["compare", str(toml), "--out", str(out)]) == 0
    printed = capsys.readouterr().out
    assert "shape dev [% of length]" in printed and "10 links" in printed
    data = json.loads((out / "compare.json").read_text())
    assert list(data["methods"]) == ["coordinating", "pinv", "dls"]
    for scores in data["methods"].values():
        assert list(scores) == list(SCORES) and scores["outcome"] == "completed"
    md = (out / "compare.md").read_text()
    assert "every method as generated C" in md and "| pinv | completed |" in md
    assert data["methods"]["coordinating"]["shape_deviation"] < data["methods"]["pinv"]["shape_deviation"]
    assert (out / "compare.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def rail_scenario(segments, links=12, limits=(0.0, 5.0), speed=0.2, direction=(1.0, 0.0, 0.0), duration=1.0,
                  step=0.01):
    return Scenario.from_dict({
        "name": "rail3d-small",
        "chain": {"links": links, "link_length": 0.1, "joints": "universal", "joint_limit": 1.4,
                  "base": {"kind": "rail", "direction": list(direction), "limits": list(limits)}},
        "curve": {"kind": "path", "start": [-0.3 * c for c in direction], "direction": list(direction),
                  "normal": [0.0, 1.0, 0.0], "segments": segments},
        "control": {"gain": K, "speed": speed}, "start": {"kind": "follow", "beta": 0.6},
        "run": {"duration": duration, "step": step}})


def test_spatial_ftl_on_a_straight_path_along_the_rail_feeds_at_v_star_with_every_joint_at_rest():
    from coordarm.analysis.follow_leader import simulate_ftl
    from coordarm.analysis.follow_leader3d import SpatialFollowTheLeader
    direction = (0.6, 0.0, 0.8)
    sc = rail_scenario([{"line": 5.0}], direction=direction, speed=0.17)
    ctrl = sc.controller()
    q0 = sc.start(ctrl)
    run = simulate_ftl(SpatialFollowTheLeader(ctrl, q0), 1.0, 0.01, "interpreted")
    assert run.info["stopped"] == "completed" and len(run.t) == 101
    np.testing.assert_allclose(run.u[:, 0], 0.17, rtol=0, atol=1e-10)                 # d_dot = v*
    np.testing.assert_allclose(run.q[:, 0], q0[0] + 0.17 * run.t, rtol=0, atol=1e-12)
    np.testing.assert_allclose(run.u[:, 1:], 0.0, rtol=0, atol=1e-10)                 # joints at rest
    np.testing.assert_allclose(run.q[:, 1:], np.broadcast_to(q0[1:], run.q[:, 1:].shape), rtol=0, atol=1e-12)


def test_spatial_ftl_on_a_rail_keeps_every_centre_on_a_banked_path_and_the_end_point_at_s_star():
    from coordarm.analysis.follow_leader import simulate_ftl
    from coordarm.analysis.follow_leader3d import SpatialFollowTheLeader
    sc = rail_scenario([{"line": 1.6}, {"arc": 0.7, "radius": 0.6, "bank": 1.0}, {"arc": 0.6, "radius": 0.7,
                                                                                  "bank": 2.5}, {"line": 2.0}],
                       links=20, speed=0.25, duration=3.0)
    ctrl = sc.controller()
    q0 = sc.start(ctrl)
    law = SpatialFollowTheLeader(ctrl, q0)
    runs = [simulate_ftl(law, 3.0, 0.01, b) for b in ("compiled", "interpreted")]
    # the same body (centres by forward kinematics) from both; the joint angles of the same directions differ by
    # more (rounding grows by about 1 / cos b_j per joint when the angles are read off the directions)
    np.testing.assert_allclose(*(ctrl.chain.centres_np(r.q) for r in runs), rtol=0, atol=1e-12)
    run = runs[0]
    assert run.info["stopped"] == "completed" and run.info["backend"] == "compiled"
    Y = ctrl.chain.centres_np(run.q)                                  # forward kinematics of q = (d, a, b, ...)
    np.testing.assert_allclose(Y[:, 0], run.q[:, :1] * np.array([1.0, 0.0, 0.0]), rtol=0, atol=1e-15)
    s_end = np.array([float(ctrl.curve.functions()(y, 0.0)[0]) for y in Y[:, -1]])
    assert 1.6 < s_end[0] < 2.02 and s_end[-1] > 2.44            # from the first banked arc past the second
    dist = brute_force_distance(ctrl.curve, Y.reshape(-1, 3))
    assert np.max(dist) < SPACING ** 2 / (8 * 0.6) + 1e-12
    np.testing.assert_allclose(s_end, law.s0 + 0.25 * run.t, rtol=0, atol=1e-10)
    assert np.max(np.abs(np.diff(run.q[:, 1:], axis=0))) < 0.05         # the laid chain moves continuously


def test_spatial_ftl_needs_a_start_on_the_path():
    from coordarm.analysis.follow_leader3d import SpatialFollowTheLeader
    sc = rail_scenario([{"line": 5.0}])
    ctrl = sc.controller()
    q0 = sc.start(ctrl)
    bent = q0.copy()
    bent[3] += 0.05
    with pytest.raises(ConfigError, match="on the path"):
        SpatialFollowTheLeader(ctrl, bent)


def test_compare_on_a_spatial_rail_robot_runs_all_four_methods(tmp_path):
    from coordarm.analysis.compare import SCORE_TABLE, write_outputs
    sc = rail_scenario([{"line": 1.0}, {"arc": 0.8, "radius": 0.6, "bank": 1.2}, {"line": 2.0}], links=10,
                       limits=(0.0, 0.5), speed=0.2, duration=3.0, step=0.005)
    assert parse_methods(None, sc) == ["coordinating", "pinv", "dls", "ftl"]
    results = compare(sc)
    by = {r.method: r for r in results}
    for r in results:
        assert list(r.scores) == [row.key for row in SCORE_TABLE]          # peak_rail_rate included
        assert r.run.q[:, 0].max() <= 0.5
    ftl = by["ftl"]
    assert ftl.scores["max_deviation"] < 1e-9 and ftl.scores["final_s_error"] < 1e-9
    assert ftl.scores["outcome"] in ("completed", "rail_limit")
    coord = by["coordinating"].run
    assert by["coordinating"].scores["peak_rail_rate"] == pytest.approx(np.max(np.abs(coord.u[:, 0])), rel=1e-12)
    paths = write_outputs(sc, results, tmp_path)
    assert "peak rail rate [m/s]" in paths["md"].read_text() and paths["png"].stat().st_size > 10_000
