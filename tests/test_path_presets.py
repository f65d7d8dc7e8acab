"""The presets `thread` and `pipe` (paths on a rail): real CLI runs, checked from their logs with
independent geometry (plain numpy, written apart from coordarm's), and reported."""
import numpy as np
import pytest

from coordarm.analysis.replay import load
from coordarm.cli import main
from coordarm.simulation.run import simulate
from coordarm.simulation.scenario import load_scenario
from coordarm.symbolic import curve_from_spec
from test_outcomes import crossing_pairs
from test_transitions import dense_from_curvature


def rail_joints(q, xi, rail_angle):
    """Link end points (N, m+1, 2): link 1's centre at d along the rail, angles summed (eq. 5)."""
    base = q[:, :1] * np.array([np.cos(rail_angle), np.sin(rail_angle)])
    alpha = np.cumsum(q[:, 1:], axis=1)
    steps = xi * np.stack([np.cos(alpha), np.sin(alpha)], axis=-1)
    start = base[:, None] - 0.5 * steps[:, :1]
    return np.concatenate([start, start + np.cumsum(steps, axis=1)], axis=1)


def wall_segments(spec):
    """Every obstacle as edges (K, 2, 2): a segment, or a closed polygon's edges."""
    edges = []
    for ob in spec["obstacles"]:
        if "points" in ob:
            P = np.array(ob["points"], float)
            edges += list(np.stack([P, np.roll(P, -1, axis=0)], axis=1))
        else:
            edges.append(np.array([ob["a"], ob["b"]], float))
    return np.array(edges)


def inside_polygon(pts, P):
    """Even-odd rule: which of the points (K, 2) lie inside the polygon P (n, 2)."""
    x, y = pts[:, 0:1], pts[:, 1:2]
    a, b = P, np.roll(P, -1, axis=0)
    cond = (a[:, 1] > y) != (b[:, 1] > y)
    with np.errstate(divide="ignore", invalid="ignore"):
        xc = a[:, 0] + (y - a[:, 1]) * (b[:, 0] - a[:, 0]) / (b[:, 1] - a[:, 1])
    return (np.sum(cond & (x < xc), axis=1) % 2) == 1


@pytest.mark.parametrize("preset", ["thread", "pipe"])
def test_path_preset_completes_physically_valid_and_reports(preset, tmp_path):
    out = tmp_path / f"{preset}.mcap"
    assert main(["run", preset, "--quiet", "--no-figures", "--log-rate", "20", "--out", str(out)]) == 0
    rep = load(out)                                  # everything below comes from the log alone
    spec = rep.scenario_dict
    assert rep.outcome["status"] == "completed" and not rep.problems
    ch = spec["chain"]
    m, xi, base = ch["links"], ch["link_length"], ch["base"]
    assert rep.q.shape[1] == m + 1 and rep.t[-1] == pytest.approx(spec["run"]["duration"])
    lo, hi = base["limits"]
    assert np.all((rep.q[:, 0] >= lo) & (rep.q[:, 0] <= hi))                # the rail within its limits
    assert rep.q[-1, 0] - rep.q[0, 0] > 1.0                                 # it fed the body in
    assert np.max(np.abs(rep.q[:, 2:])) <= 2.8                             # joint limits q_2..q_m
    J = rail_joints(rep.q, xi, base["angle"])
    assert len(crossing_pairs(J)) == 0                                      # no self-contact
    edges = wall_segments(spec)
    for w in edges:                                                         # no link crosses a wall edge
        both = np.concatenate([J, np.broadcast_to(w, (len(J), 2, 2))], axis=1)
        assert not np.any(crossing_pairs(both)[:, 2] == J.shape[1] + 1)
    for ob in spec["obstacles"]:                                            # no joint inside a polygon
        if "points" in ob:
            assert not inside_polygon(J.reshape(-1, 2), np.array(ob["points"], float)).any(), ob["name"]
    # the centres stay on the path: phi from the path rebuilt from the logged scenario, independently
    # of the run's own e (dense sampling of the path, brute-force nearest point)
    path = curve_from_spec(spec["curve"])
    assert min(path.transitions) > 0.17                                      # G2: clothoids at every junction
    segs = [{"line": a} if kind == "line" else {"arc": a, "radius": r} for kind, a, r in path.segments]
    dense = dense_from_curvature(path.start, path.heading, segs, path.transitions, h=1e-4)[0]
    for k in (len(J) // 2, len(J) - 1):
        centres = 0.5 * (J[k, :-1] + J[k, 1:])[1:]                          # y^2..y^m
        d = np.min(np.linalg.norm(centres[:, None] - dense[None], axis=-1), axis=1)
        assert np.max(d) < 1e-4                                             # samples 0.1 mm apart
    assert np.max(np.abs(rep.e)) < 1e-11                                   # rounding, also at the junctions
    # joint accelerations (every step): at least 10x below the G1 path's (issue 28: 36.5 and 18.9 rad/s^2)
    assert rep.outcome["joint_rates"]["du_dt"] < {"thread": 3.65, "pipe": 1.89}[preset]
    # the end point went where v* says; the span did what [control] span says (exp(-K t) feedback)
    np.testing.assert_allclose(rep.s, rep.s[0] + np.concatenate([[0], np.cumsum(
        0.5 * np.diff(rep.t) * (rep.v_star[1:] + rep.v_star[:-1]))]), atol=2e-4)   # trapezoid over 50 ms samples
    assert rep.sigma[-1] - rep.sigma[0] > 1.0
    # the far wall (thread) / the far end of the pipe (pipe) is reached
    end = J[-1, -1]
    if preset == "thread":
        assert end[0] > 6.2                                                 # past wall 2 at x = 6.2
    else:
        assert rep.s[-1] > 4.3                                              # 0.2 m from the far end (4.55 m)
    rep_out = tmp_path / "report"
    assert main(["report", str(out), "--out", str(rep_out)]) == 0
    assert (rep_out / "report.md").read_text().count("|") > 10


@pytest.mark.parametrize("preset", ["thread", "pipe"])
def test_path_preset_runs_the_same_compiled_and_interpreted(preset):
    """The whole preset (its obstacles checked) on both backends: same outcome, same trajectory."""
    scenario = load_scenario(preset)
    ctrl = scenario.controller()
    q0 = scenario.start(ctrl)
    runs = {}
    for backend in ("compiled", "interpreted"):
        runs[backend] = simulate(ctrl, q0, scenario.duration, scenario.step, scenario.t0, backend=backend,
                                 thresholds=scenario.thresholds, physical=scenario.physical(ctrl.chain),
                                 check_every=25, progress=False)
        assert runs[backend].info["backend"] == backend and not runs[backend].info["contacts"]
    a, b = runs["compiled"], runs["interpreted"]
    assert a.q.shape == b.q.shape == (round(scenario.duration / scenario.step) + 1, ctrl.chain.m + 1)
    for field in ("q", "u", "s", "sigma", "rail_margin", "longitudinal"):
        np.testing.assert_allclose(getattr(a, field), getattr(b, field), rtol=1e-9, atol=1e-10, err_msg=field)
