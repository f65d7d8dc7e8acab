"""Baselines and ``coordarm compare``: checked against independent computations and the README's table."""
import json
import re
from pathlib import Path

import casadi as ca
import numpy as np
import pytest

from coordarm.analysis.baselines import EndPointRate, simulate_baseline
from coordarm.analysis.compare import SCORE_TABLE, SCORES, compare, markdown_table, parse_methods, score
from coordarm.cli import main as cli_main
from coordarm.simulation.scenario import Scenario, load_scenario
from coordarm.symbolic import Arc, ConfigError, CoordinatingController, Line, PlanarChain

REPO = Path(__file__).resolve().parents[1]
K = 2.0


def arc_ctrl(m=12):
    return CoordinatingController(PlanarChain(m, 0.1), Arc(radius=1.6, angle=lambda t: 0.3 * ca.sin(t)), K,
                                  lambda t: 0.1 + 0.05 * ca.sin(t))


def end_point_rates(ctrl, q, u, t):
    """(d psi/dt, d phi/dt) of y^m under qdot = u, from eq. 7's closed-form Jacobian and the curve's gradients."""
    C = ctrl.chain.jacobians_closed_form(q)[-1]
    geo = ctrl.centre_geometry(q[None], [t])
    ydot = C @ u
    return (geo["gpsi"][0, -1] @ ydot + geo["psit"][0, -1], geo["gphi"][0, -1] @ ydot + geo["phit"][0, -1],
            geo["phi"][0, -1])


@pytest.mark.parametrize("seed", range(5))
def test_pinv_end_point_velocity_is_the_commanded_one(seed):
    ctrl = arc_ctrl()
    rng = np.random.default_rng(seed)
    centre = ctrl.chain.zigzag(1.2)
    q = centre + 0.2 * rng.standard_normal(12)
    t = float(rng.uniform(0, 3))
    u = EndPointRate(ctrl, centre).control(q, t)
    sdot, phidot, phi = end_point_rates(ctrl, q, u, t)
    assert sdot == pytest.approx(ctrl.speed_at(t), abs=1e-9)
    assert phidot == pytest.approx(-K * phi, abs=1e-9)


@pytest.mark.parametrize("seed", range(3))
def test_pinv_on_a_rail_moves_the_end_point_as_commanded_and_centres_only_the_revolute_joints(seed):
    from coordarm.symbolic import Path, follow_curve
    chain = PlanarChain(12, 0.1, base="rail", rail_angle=0.1, rail_limits=(-5.0, 5.0))
    path = Path((-0.4, -0.04), 0.1, [{"line": 0.8}, {"arc": 0.9, "radius": 0.8}, {"line": 2.0}])
    ctrl = CoordinatingController(chain, path, K, lambda t: 0.1 + 0.05 * ca.sin(t))
    centre = follow_curve(ctrl, 1.1, d=0.2)
    rng = np.random.default_rng(seed)
    q = centre + 0.05 * rng.standard_normal(chain.dof)
    t = float(rng.uniform(0, 3))
    law = EndPointRate(ctrl, centre)
    u = law.control(q, t)
    sdot, phidot, phi = end_point_rates(ctrl, q, u, t)   # eq. 7 with the rail column
    assert sdot == pytest.approx(ctrl.speed_at(t), abs=1e-9)
    assert phidot == pytest.approx(-K * phi, abs=1e-9)
    _, A, r = law.task(q, t)
    free = u - np.linalg.pinv(A) @ r                     # the null-space part: (I - A^+ A) z, z_d = 0
    z = -(q - centre)
    z[0] = 0.0
    np.testing.assert_allclose(free, z - np.linalg.pinv(A) @ (A @ z), atol=1e-12)


def test_pinv_at_the_centre_is_the_minimum_norm_solution_of_numpy():
    ctrl = arc_ctrl()
    q = ctrl.chain.zigzag(1.0)
    law = EndPointRate(ctrl, q)
    _, A, r = law.task(q, 0.5)
    C = ctrl.chain.jacobians_closed_form(q)[-1]
    geo = ctrl.centre_geometry(q[None], [0.5])
    np.testing.assert_allclose(A, np.vstack([geo["gpsi"][0, -1] @ C, geo["gphi"][0, -1] @ C]), atol=1e-14)
    np.testing.assert_allclose(law.control(q, 0.5), np.linalg.pinv(A) @ r, atol=1e-12)


def test_pinv_null_space_term_pulls_towards_the_centre_without_touching_the_task():
    ctrl = arc_ctrl()
    centre = ctrl.chain.zigzag(1.2)
    q = centre + 0.1
    law = EndPointRate(ctrl, centre)
    _, A, r = law.task(q, 0.0)
    u = law.control(q, 0.0)
    free = u - np.linalg.pinv(A) @ r
    np.testing.assert_allclose(A @ free, 0, atol=1e-12)
    assert free @ (q - centre) < 0                      # towards the centre


def test_dls_equals_pinv_outside_its_band_and_is_damped_inside():
    ctrl = arc_ctrl()
    q = ctrl.chain.zigzag(1.2)
    pinv, dls = EndPointRate(ctrl, q), EndPointRate(ctrl, q, {"lambda": 0.01, "band": 1e-6})
    np.testing.assert_allclose(dls.control(q, 0.2), pinv.control(q, 0.2), atol=1e-14)
    wide = EndPointRate(ctrl, q, {"lambda": 0.05, "band": 1.0})
    _, A, r = wide.task(q, 0.2)
    sv = np.linalg.svd(A, compute_uv=False)
    lam2 = 0.05 ** 2 * (1 - (sv[1] / sv[0]) ** 2)
    np.testing.assert_allclose(wide.control(q, 0.2), A.T @ np.linalg.solve(A @ A.T + lam2 * np.eye(2), r),
                               atol=1e-12)


def test_a_baseline_run_tracks_the_end_point_and_stops_at_a_singular_task():
    ctrl = CoordinatingController(PlanarChain(6, 0.1), Line(angle=0.01), K, 0.1)
    q0 = ctrl.chain.zigzag(1.2)
    run = simulate_baseline(EndPointRate(ctrl, q0), q0, 1.0, 0.001)
    sc = score(run, Scenario.from_dict({"chain": {"links": 6, "link_length": 0.1},
                                        "curve": {"kind": "line", "angle": 0.01},
                                        "control": {"gain": K, "speed": 0.1}, "start": {"beta": 1.2},
                                        "run": {"duration": 1.0}}))
    assert sc["outcome"] == "completed" and sc["final_s_error"] < 1e-9
    stretched = EndPointRate(CoordinatingController(PlanarChain(6, 0.1), Line(), K, 0.1), np.zeros(6))
    bad = simulate_baseline(stretched, np.zeros(6), 1.0, 0.001)    # A A^T singular at a straight chain
    assert bad.info["stopped"] == "singularity" and len(bad.t) == 1


def test_contacts_are_counted_per_sample_for_a_folded_chain_and_a_wall():
    spec = {"chain": {"links": 6, "link_length": 0.1, "joint_limit": 3.14}, "curve": {"kind": "line"},
            "control": {"gain": K, "speed": 0.1}, "start": {"beta": 1.2}, "run": {"duration": 0.02, "step": 0.01},
            "obstacles": [{"a": [0.15, -1.0], "b": [0.15, 1.0]}]}
    sc = Scenario.from_dict(spec)
    chain = sc.chain()
    run = simulate_baseline(EndPointRate(sc.controller(), chain.zigzag(1.2)), chain.zigzag(1.2), 0.02, 0.01)
    folded = np.array([0, 2.8, 2.8, 2.8, 0, 0])        # links 1 and 4 cross, all left of x = 0.15 m
    run.q[:] = np.stack([folded, folded, chain.zigzag(1.2)])  # the zig-zag reaches x = 0.2 m, past the wall
    J = chain.joints_np(run.q)
    assert J[:2, :, 0].max() < 0.15 < J[2, :, 0].max()
    scores = score(run, sc)
    assert scores["self_collisions"] == 2 and scores["wall_contacts"] == 1


def test_compare_png_rings_the_links_that_touched_since_the_previous_panel_where_they_touched(monkeypatch, tmp_path):
    from matplotlib.figure import Figure

    from coordarm.analysis.compare import MethodRun, plot_bodies
    from coordarm.analysis.compare_scores import SINCE, contacts_between

    spec = {"chain": {"links": 6, "link_length": 0.1, "joint_limit": 3.14}, "curve": {"kind": "line"},
            "control": {"gain": K, "speed": 0.1}, "start": {"beta": 1.2}, "run": {"duration": 0.03, "step": 0.01},
            "obstacles": [{"name": "post", "a": [0.15, -1.0], "b": [0.15, 1.0]}]}
    sc = Scenario.from_dict(spec)
    chain = sc.chain()
    run = simulate_baseline(EndPointRate(sc.controller(), chain.zigzag(1.2)), chain.zigzag(1.2), 0.03, 0.01)
    folded = np.array([0, 2.8, 0.0, 0.0, 0, 0])       # within x < 0.15 m, no crossing
    run.q[:] = np.stack([folded, folded, chain.zigzag(1.2), folded])     # past the wall at t = 0.02 s only
    found = contacts_between(sc.physical(chain), run, sc.step, 0.01, 0.03)
    assert [(c.kind, c.time, c.obstacle) for c in found] == [("wall", 0.02, "post")]
    assert contacts_between(sc.physical(chain), run, sc.step, -np.inf, 0.01) == []
    seen = []
    monkeypatch.setattr(Figure, "savefig", lambda fig, *a, **k: seen.append(fig))
    plot_bodies([MethodRun("pinv", run)], sc, tmp_path / "c.png", stages=2)   # panels at t = 0 and 0.03 s
    first, last = seen[0].axes
    assert not [ln for ln in first.get_lines() if ln.get_gid() == "contact"]
    ring, = [ln for ln in last.get_lines() if ln.get_gid() == "contact"]
    np.testing.assert_allclose(np.column_stack(ring.get_data()),
                               chain.centres_np(run.q[2])[[j - 1 for j in found[0].links]], atol=1e-12)
    assert SINCE in [t.get_text() for t in seen[0].legends[0].get_texts()]
    assert {"post"} <= {t.get_text() for t in first.texts}                  # the walls named in the first panel


def test_methods_are_checked_and_ftl_needs_a_rail(capsys):
    sc = load_scenario("line")
    assert parse_methods(None, sc) == ["coordinating", "pinv", "dls"]
    assert parse_methods("dls, pinv,dls", sc) == ["dls", "pinv"]
    for bad, msg in (("pinv,foo", "unknown method"), ("ftl", "rail"), (",", "empty")):
        with pytest.raises(ConfigError, match=msg):
            parse_methods(bad, sc)
    assert cli_main(["compare", "line", "--methods", "ftl"]) == 2
    assert "rail" in capsys.readouterr().err


def readme_table(scenario: str) -> list[list[str]]:
    section = (REPO / "docs" / "guide" / "why-coordinating.md").read_text()
    lines = section[section.index(f"`coordarm compare {scenario}`:"):].splitlines()
    first = next(i for i, line in enumerate(lines) if line.startswith("| "))
    end = next(i for i, line in enumerate(lines[first:], first) if not line.startswith("| "))
    return [[c.strip() for c in line.strip("|").split("|")] for line in lines[first:end]]


def same_columns_as_readme(md: list[list[str]], readme: list[list[str]]) -> list[list[str]]:
    """The columns of ``md`` that the README's table shows (by title), in its order, the timing column left out
    (the README may show fewer scores than compare.md writes)."""
    keep = [md[0].index(title) for title in readme[0] if title != "step [µs]"]
    return [[row[i] for i in keep] for row in md]


def test_compare_hole_end_to_end_reproduces_the_readme_table(tmp_path, capsys):
    out = tmp_path / "cmp"
    assert cli_main(["compare", "hole", "--out", str(out)]) == 0
    printed = capsys.readouterr().out
    data = json.loads((out / "compare.json").read_text())
    assert set(data) == {"scenario", "methods"} and data["scenario"] == "hole"
    assert list(data["methods"]) == ["coordinating", "pinv", "dls"]
    for scores in data["methods"].values():
        assert list(scores) == list(SCORES)
    assert (out / "compare.png").stat().st_size > 10_000 and "compare.png" in (out / "compare.md").read_text()
    assert "coordinating" in printed and "pinv" in printed
    # the numbers in the README's table, all but the timing column, are these
    md = [[c.strip() for c in line.strip("|").split("|")]
          for line in (out / "compare.md").read_text().splitlines() if line.startswith("| ")]
    readme = readme_table("hole")
    assert same_columns_as_readme(md, readme) == [[c for c, title in zip(row, readme[0]) if title != "step [µs]"]
                                                  for row in readme]
    # independent checks of the coordinating scores: the law's own e and s, logged by the simulator
    sc = load_scenario("hole")
    coord = compare(sc, ["coordinating"])[0]
    run = coord.run
    assert data["methods"]["coordinating"]["max_deviation"] == pytest.approx(np.max(np.abs(run.e)), rel=1e-9)
    assert data["methods"]["coordinating"]["final_s_error"] == pytest.approx(
        abs(run.s[-1] - run.s_reference()[-1]), abs=1e-12)
    assert data["methods"]["coordinating"]["peak_u"] == pytest.approx(np.max(np.abs(run.u)), rel=1e-12)


def test_a_method_that_stops_early_is_scored_up_to_its_stop_and_drawn(tmp_path):
    sc = Scenario.from_dict({"name": "pushed", "chain": {"links": 10, "link_length": 0.1},
                             "curve": {"kind": "line", "angle": 0.02}, "control": {"gain": K, "speed": 0.2},
                             "start": {"beta": 1.2}, "run": {"duration": 4.0}})
    results = compare(sc, ["coordinating", "pinv"])
    coord, pinv = (r.scores for r in results)
    assert coord["outcome"] == "singularity" and results[0].run.t[-1] == pytest.approx(2.807)
    assert coord["final_s_error"] < 1e-9 and np.isfinite(coord["peak_u"])
    assert pinv["outcome"] in ("completed", "singularity")
    from coordarm.analysis.compare import write_outputs
    paths = write_outputs(sc, results, tmp_path)
    assert "| coordinating | singularity |" in paths["md"].read_text()
    assert json.loads(paths["json"].read_text())["methods"]["coordinating"]["outcome"] == "singularity"


@pytest.mark.parametrize("damping", [None, {"lambda": 0.05, "band": 1.0}])
def test_compiled_baseline_steps_equal_the_interpreted_ones(damping):
    ctrl = arc_ctrl(8)
    q0 = ctrl.chain.zigzag(1.2)
    law = EndPointRate(ctrl, q0, damping)
    runs = [simulate_baseline(law, q0, 0.25, 0.001, chunk=100, backend=b) for b in ("compiled", "interpreted")]
    assert runs[0].info["backend"] == "compiled" and len(runs[0].t) == 251
    np.testing.assert_allclose(runs[0].q, runs[1].q, rtol=0, atol=1e-12)
    np.testing.assert_allclose(runs[0].u, runs[1].u, rtol=0, atol=1e-12)
    with pytest.raises(ConfigError, match="backend"):
        law.chunk(0.001, 10, "gpu")


def small_rail_scenario() -> Scenario:
    """16 links on a rail 0.8 m long, a path with one bend; the span grows 0.3 m from t = 1 s."""
    spec = {"name": "rail-small",
            "chain": {"links": 16, "link_length": 0.1, "base": {"kind": "rail", "angle": 0.0, "limits": [-0.1, 0.7]}},
            "curve": {"kind": "path", "start": [-0.3, 0.0], "heading": 0.0,
                      "segments": [{"line": 1.3}, {"arc": 0.5, "radius": 1.0}, {"line": 2.0}]},
            "control": {"gain": K, "speed": {"kind": "smoothstep", "start": 0.0, "end": 0.2, "t0": 0.0, "t1": 1.0}},
            "start": {"kind": "follow", "beta": 1.1}, "run": {"duration": 5.0, "step": 0.002}}
    held = Scenario.from_dict(spec)
    ctrl = held.controller()
    sigma0 = float(ctrl.evaluate(held.start(ctrl), 0.0)["sigma"])
    spec["control"]["span"] = [sigma0, {"kind": "smoothstep", "start": 0.0, "end": 0.3, "t0": 1.0, "t1": 4.5}]
    return Scenario.from_dict(spec)


def test_compare_on_a_rail_robot_runs_all_four_methods_and_holds_them_to_the_rail(tmp_path):
    sc = small_rail_scenario()
    assert parse_methods(None, sc) == ["coordinating", "pinv", "dls", "ftl"]
    results = compare(sc)
    by = {r.method: r for r in results}
    coord, ftl = by["coordinating"], by["ftl"]
    # the coordinating law unfolds the body, so its rail stays short of the limit; ftl cannot unfold
    assert coord.scores["outcome"] == "completed" and coord.run.q[:, 0].max() < 0.7
    assert coord.scores["max_deviation"] == pytest.approx(np.max(np.abs(coord.run.e)), rel=1e-9)
    assert coord.scores["final_s_error"] == pytest.approx(abs(coord.run.s[-1] - coord.run.s_reference()[-1]),
                                                          abs=1e-12)
    assert coord.scores["peak_rail_rate"] == pytest.approx(np.max(np.abs(coord.run.u[:, 0])), rel=1e-12)
    assert ftl.scores["outcome"] == "rail_limit" and ftl.run.q[-1, 0] <= 0.7 < ftl.run.q[-1, 0] + 0.2 * 0.002 + 1e-9
    assert ftl.scores["max_deviation"] < 1e-9 and ftl.scores["final_s_error"] < 1e-9
    for r in results:                                   # every method is cut at the rail's end
        assert r.run.q[:, 0].max() <= 0.7
        assert (r.scores["outcome"] == "rail_limit") == (len(r.run.t) < len(coord.run.t))
    from coordarm.analysis.compare import write_outputs
    paths = write_outputs(sc, results, tmp_path)
    data = json.loads(paths["json"].read_text())
    for scores in data["methods"].values():
        assert list(scores) == [row.key for row in SCORE_TABLE]
    assert "peak rail rate [m/s]" in paths["md"].read_text() and paths["png"].stat().st_size > 10_000


def test_compare_thread_reproduces_the_readme_table(tmp_path):
    out = tmp_path / "thread"
    assert cli_main(["compare", "thread", "--out", str(out)]) == 0
    md = [[c.strip() for c in line.strip("|").split("|")]
          for line in (out / "compare.md").read_text().splitlines() if line.startswith("| ")]
    readme = readme_table("thread")
    assert same_columns_as_readme(md, readme) == [[c for c, title in zip(row, readme[0]) if title != "step [µs]"]
                                                  for row in readme]
