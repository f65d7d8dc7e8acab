"""Near singularities: the speed governor, re-pivoting of small link pivots, damped least squares."""
import warnings

import casadi as ca
import numpy as np
import pytest

import coordarm.symbolic.recursion as recursion_module
from coordarm.cli import main as cli_main
from coordarm.analysis.replay import load
from coordarm.analysis.singularity import margins
from coordarm.simulation.run import BackendFallbackWarning, simulate
from coordarm.simulation.scenario import Scenario, load_scenario
from coordarm.symbolic import Arc, BuildError, ConfigError, CoordinatingController, Line, PlanarChain, SingularityError
from coordarm.symbolic.near_singular import damping_factor, speed_scale
from coordarm.generated import compile as compile_controller

K = 2.0


# ------------------------------------------------------------------ the governor's factor
def test_speed_scale_is_0_at_the_threshold_1_from_three_thresholds_and_c1_between():
    thr = 0.15
    m = np.linspace(0.0, 0.6, 60001)
    g = speed_scale(m, thr)
    assert np.all(g[m <= thr] == 0) and np.all(g[m >= 3 * thr] == 1)
    assert np.all(np.diff(g) >= 0)
    x = (0.3 - thr) / (2 * thr)                       # closed form in the middle
    assert speed_scale(0.3, thr) == pytest.approx(x * x * (3 - 2 * x), rel=1e-15)
    h = 1e-6                                          # C1: one-sided slopes agree at both knees
    for knee in (thr, 3 * thr):
        left = (speed_scale(knee, thr) - speed_scale(knee - h, thr)) / h
        right = (speed_scale(knee + h, thr) - speed_scale(knee, thr)) / h
        assert abs(left - right) < 1e-4
    sym = ca.SX.sym("m")                              # the same expression compiles into the law
    f = ca.Function("g", [sym], [speed_scale(sym, thr)])
    np.testing.assert_allclose(np.array(f(m[None])).ravel(), g, atol=1e-15)


def pushed_chain(governor):
    """10 links on a line pushed at 0.2 m/s: stretched (longitudinal margin 0.15) after about 2.8 s."""
    return CoordinatingController(PlanarChain(10, 0.1), Line(angle=0.02), K, 0.2, governor=governor)


@pytest.mark.parametrize("backend", ["compiled", "interpreted"])
def test_without_the_governor_the_pushed_chain_stops_and_the_message_suggests_it(backend):
    ctrl = pushed_chain(False)
    with pytest.raises(SingularityError, match="governor") as err:
        simulate(ctrl, ctrl.chain.zigzag(1.2), 20.0, 0.001, backend=backend)
    assert err.value.kind == "longitudinal" and err.value.time < 3.0


@pytest.mark.parametrize("backend", ["compiled", "interpreted"])
def test_the_governor_brings_the_pushed_chain_to_rest_with_bounded_u_and_decaying_deviations(backend):
    ctrl = pushed_chain(True)
    run = simulate(ctrl, ctrl.chain.zigzag(1.2), 20.0, 0.001, backend=backend)
    assert run.info["stopped"] == "completed"
    assert np.all(np.isfinite(run.u)) and np.max(np.abs(run.u)) < 1.0     # it was 2.7 when the run stopped
    assert run.longitudinal.min() > 0.15 and run.v_scale[-1] < 1e-3       # at rest, nearly stretched
    assert 15.0 < run.info["governed"] < 20.0
    # the deviations still decay like exp(-K t): only the s row's right-hand side changed
    E = np.max(np.abs(run.e), axis=1)
    ref = E[0] * np.exp(-K * (run.t - run.t[0]))
    live = ref > 1e-12
    np.testing.assert_allclose(E[live], ref[live], rtol=2e-3, atol=1e-14)
    assert E[-1] < 1e-15
    # and s follows the governed speed: s(0) + integral of v_scale v*
    assert np.max(np.abs(run.s - run.s_reference())) < 1e-6
    assert np.all(np.diff(run.s) > -1e-12)


@pytest.mark.parametrize("beta", [0.16, 0.2, 0.3, 1.2])     # margins 0.14 (below), 0.18, 0.27 (in the band), 0.84
def test_governed_dense_and_structured_laws_agree_and_scale_only_the_speed(beta):
    gov, plain = pushed_chain(True), pushed_chain(False)
    q = gov.chain.zigzag(beta)
    out = gov.evaluate(q, 0.3)
    assert out["v_scale"] == pytest.approx(float(speed_scale(out["longitudinal"], 0.15)), abs=1e-15)
    np.testing.assert_allclose(gov.evaluate(q, 0.3, form="dense")["u"], out["u"], rtol=1e-9, atol=1e-12)
    M, r = (np.array(x) for x in plain.decoupling_function()(q, 0.3))
    r = r.ravel()
    r[0] -= (1 - out["v_scale"]) * 0.2                 # the s row asks for v_scale v* instead of v*
    np.testing.assert_allclose(out["u"], np.linalg.solve(M, r), rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(compile_controller(gov).evaluate(q, 0.3)["u"], out["u"], rtol=1e-12, atol=1e-14)


def test_governor_from_the_scenario_and_the_cli_logs_v_scale_and_governed_time(tmp_path, capsys):
    spec = {"name": "pushed", "chain": {"links": 10, "link_length": 0.1},
            "curve": {"kind": "line", "angle": 0.02}, "control": {"gain": K, "speed": 0.2},
            "start": {"beta": 1.2}, "run": {"duration": 6.0, "step": 0.001}}
    path = tmp_path / "pushed.toml"
    path.write_text("name = 'pushed'\n[chain]\nlinks = 10\nlink_length = 0.1\n[curve]\nkind = 'line'\n"
                    "angle = 0.02\n[control]\ngain = 2.0\nspeed = 0.2\n[start]\nbeta = 1.2\n"
                    "[run]\nduration = 6.0\n")
    assert Scenario.from_dict(spec).controller().governor is False
    assert Scenario.from_dict(spec).with_overrides(governor=True).controller().governor is True
    log = tmp_path / "p.mcap"
    assert cli_main(["run", str(path), "--out", str(log), "--no-figures", "--quiet"]) == 3
    assert "governor" in capsys.readouterr().err
    assert cli_main(["run", str(path), "--governor", "--out", str(log), "--overwrite", "--no-figures", "--quiet"]) == 0
    out = capsys.readouterr().out
    assert "governor      v* slowed during" in out
    rep = load(log)
    assert rep.outcome["status"] == "completed" and rep.outcome["governed"] > 2.0
    assert rep.v_scale[0] == 1.0 and rep.v_scale[-1] < 0.05
    assert rep.outcome["governed"] == pytest.approx(0.001 * np.count_nonzero(rep.v_scale < 1), abs=1e-9)
    spec["control"]["governor"] = "yes"
    with pytest.raises(ConfigError, match="control.governor"):
        Scenario.from_dict(spec)
    spec["control"]["governor"], spec["thresholds"] = True, {"longitudinal": 0.0}
    with pytest.raises(ConfigError, match="thresholds.longitudinal"):
        Scenario.from_dict(spec)


# ------------------------------------------------------------------ re-pivoting
def perpendicular(curve, m=8, link=3, heading=0.0):
    """A zig-zag with link ``link + 1`` (1-based) turned to stand exactly across a line at ``heading`` [rad]."""
    ctrl = CoordinatingController(PlanarChain(m, 0.1), curve, K, lambda t: 0.1 + 0.05 * ca.sin(t))
    q = ctrl.chain.zigzag(1.0, heading)
    d = np.pi / 2 + heading - np.cumsum(q)[link]
    q[link] += d
    q[link + 1] -= d
    return ctrl, q


def dense_reference(ctrl, q, t):
    """u from numpy's dense solve of the decoupling matrix built by AD (eq. 26)."""
    M, r = ctrl.decoupling_function()(q, t)
    return np.linalg.solve(np.array(M), np.array(r).ravel())


@pytest.mark.parametrize("t", [0.0, 0.3])
def test_a_link_exactly_across_the_curve_is_re_pivoted_structured_equals_dense(t):
    ctrl, q = perpendicular(Line(angle=lambda t: 0.3 * t), heading=0.3 * t)
    assert margins(ctrl, q, t)["links"][2] < 1e-15          # link 4 exactly across the (turning) line
    ref = dense_reference(ctrl, q, t)
    interp = ctrl.evaluate(q, t)
    compiled = compile_controller(ctrl).evaluate(q, t)
    for got in (interp, compiled):
        np.testing.assert_allclose(got["u"], ref, rtol=0, atol=1e-9 * np.max(np.abs(ref)))
        assert got["link_margins"].min() > 0.02 and np.isfinite(got["longitudinal"])
    np.testing.assert_allclose(compiled["u"], interp["u"], atol=1e-12)


@pytest.mark.parametrize("backend", ["compiled", "interpreted"])
def test_a_run_starting_with_a_link_across_the_curve_runs_and_every_deviation_decays(backend):
    ctrl, q = perpendicular(Line(angle=lambda t: 0.3 * t))
    run = simulate(ctrl, q, 0.3, 1e-4, backend=backend)          # it was a singular start before; |u| ~ 40
    assert run.info["stopped"] == "completed"
    ref = run.e[0] * np.exp(-K * (run.t - run.t[0]))[:, None]   # e^j(t) = e^j(0) exp(-K t), link by link
    np.testing.assert_allclose(run.e, ref, rtol=0, atol=1e-9)
    assert np.max(np.abs(run.s - run.s_reference())) < 1e-9


def test_without_re_pivoting_the_structured_solve_fails_at_that_link(monkeypatch):
    monkeypatch.setattr(recursion_module, "REPIVOT", 0.0)
    ctrl, q = perpendicular(Line(angle=lambda t: 0.3 * t))
    ref = dense_reference(ctrl, q, 0.0)
    u = ctrl.evaluate(q, 0.0)["u"]
    assert not (np.all(np.isfinite(u)) and np.allclose(u, ref, atol=1e-6))


@pytest.mark.parametrize("link", [1, 4, 6])
def test_re_pivoting_on_an_arc_agrees_with_the_dense_law_near_and_at_the_perpendicular(link):
    ctrl, q = perpendicular(Arc(radius=1.5, angle=lambda t: 0.2 * ca.sin(t)), link=link)
    comp = compile_controller(ctrl)
    for eps in (0.0, 1e-9, 1e-3, -0.02):          # at, and on both sides of, the perpendicular
        qe = q.copy()
        qe[link] += eps
        qe[link + 1] -= eps
        ref = dense_reference(ctrl, qe, 0.4)
        scale = np.max(np.abs(ref))
        np.testing.assert_allclose(ctrl.evaluate(qe, 0.4)["u"], ref, atol=1e-9 * scale)
        np.testing.assert_allclose(comp.evaluate(qe, 0.4)["u"], ref, atol=1e-9 * scale)
        np.testing.assert_allclose(ctrl.evaluate(qe, 0.4, form="dense")["u"], ref, atol=1e-9 * scale)


def test_a_truly_singular_matrix_still_reports_a_zero_margin():
    ctrl = CoordinatingController(PlanarChain(6, 0.1), Line(), K, 0.1)
    out = ctrl.evaluate(np.zeros(6))                  # stretched along the line: longitudinal singularity
    assert out["longitudinal"] == 0.0


# ------------------------------------------------------------------ damped least squares
def test_damping_factor_closed_form():
    np.testing.assert_allclose(damping_factor(np.array([0.0, 0.05, 0.1, 0.5]), 0.01, 0.1),
                               [1e-4, 0.75e-4, 0.0, 0.0], atol=1e-20)


def near_stretched(damping):
    ctrl = CoordinatingController(PlanarChain(10, 0.1), Line(angle=0.02), K, 0.2, damping=damping)
    return ctrl, ctrl.chain.zigzag(0.06)              # longitudinal margin about 0.054


@pytest.mark.parametrize("form", ["structured", "dense"])
def test_dls_inside_the_band_is_the_damped_solution_and_outside_it_the_exact_one(form):
    dls = {"kind": "dls", "lambda": 0.01, "band": 0.1}
    ctrl, q = near_stretched(dls)
    plain, _ = near_stretched(None)
    out = ctrl.evaluate(q, 0.0, form=form)
    margin = min(out["link_margins"].min(), out["longitudinal"])
    assert margin < 0.1
    M, r = (np.array(x) for x in ctrl.decoupling_function()(q, 0.0))
    r = r.ravel()
    lam2 = 1e-4 * (1 - (margin / 0.1) ** 2)
    ref = M.T @ np.linalg.solve(M @ M.T + lam2 * np.eye(10), r)
    np.testing.assert_allclose(out["u"], ref, rtol=1e-9, atol=1e-12)
    assert np.linalg.norm(out["u"]) < np.linalg.norm(plain.evaluate(q)["u"])     # damping buys smaller |u|
    np.testing.assert_allclose(compile_controller(ctrl, form).evaluate(q, 0.0)["u"], ref, rtol=1e-9, atol=1e-12)
    far = ctrl.chain.zigzag(1.2)                      # margins far outside the band: no damping
    np.testing.assert_allclose(ctrl.evaluate(far, 0.0, form=form)["u"], plain.evaluate(far)["u"], atol=1e-12)


@pytest.mark.parametrize("bad, field", [({"kind": "svd"}, "damping.kind"), ({"kind": "dls", "lambda": -1}, "damping.lambda"),
                                        ({"kind": "dls", "band": 2.0}, "damping.band"), ({"kind": "dls", "x": 1}, "damping")])
def test_bad_damping_tables_are_config_errors_naming_the_field(bad, field):
    with pytest.raises(ConfigError, match=field):
        CoordinatingController(PlanarChain(4, 0.1), Line(), K, 0.1, damping=bad)
    spec = load_scenario("line").spec
    spec["control"]["damping"] = bad
    with pytest.raises(ConfigError, match="control." + field):
        Scenario.from_dict(spec)


# ------------------------------------------------------------------ the governor on a rail
SIGMA0 = 9 * 0.1 * np.cos(1.2)            # the span of the 10-link zig-zag at beta = 1.2


def pushed_rail_chain(governor):
    """10 links on a rail along a line 0.01 m beside it; the commanded span grows 0.2 m/s from the zig-zag's
    0.326 m, so the body is stretched (longitudinal margin 0.15 at a span of 0.887 m) after about 2.8 s."""
    chain = PlanarChain(10, 0.1, base="rail", rail_limits=(-1.0, 5.0))
    return CoordinatingController(chain, Line(point=(0.0, 0.01)), K, 0.1, span=lambda t: SIGMA0 + 0.2 * t,
                                  governor=governor)


def test_without_the_governor_the_pushed_rail_chain_stops_at_the_longitudinal_singularity():
    ctrl = pushed_rail_chain(False)
    with pytest.raises(SingularityError, match="governor") as err:
        simulate(ctrl, ctrl.chain.zigzag(1.2, d=0.0), 5.0, 0.001, backend="interpreted")
    assert err.value.kind == "longitudinal" and 2.5 < err.value.time < 3.0


@pytest.fixture(scope="module")
def governed_rail_runs():
    """The pushed rail chain with the governor, run 5 s by ``auto`` (compiled: no fallback) and interpreted."""
    ctrl = pushed_rail_chain(True)
    with warnings.catch_warnings():
        warnings.simplefilter("error", BackendFallbackWarning)        # the governed rail compiles
        fast = simulate(ctrl, ctrl.chain.zigzag(1.2, d=0.0), 5.0, 0.001, backend="auto")
    return fast, simulate(ctrl, ctrl.chain.zigzag(1.2, d=0.0), 5.0, 0.001, backend="interpreted")


def test_the_governed_rail_run_compiled_equals_the_interpreted_run(governed_rail_runs):
    fast, ref = governed_rail_runs
    assert fast.info["backend"] == "compiled" and ref.info["backend"] == "interpreted"
    assert fast.v_scale.min() < 0.05                                   # both passes mattered
    for field in ("q", "u", "e", "s", "sigma", "rail_margin", "link_margins", "longitudinal", "v_scale"):
        np.testing.assert_allclose(getattr(fast, field), getattr(ref, field), rtol=1e-12, atol=1e-12, err_msg=field)


def test_the_governor_slows_the_pushed_rail_chain_which_completes_with_bounded_u_and_decaying_deviations(
        governed_rail_runs):
    run = governed_rail_runs[1]
    assert run.info["stopped"] == "completed" and run.info["backend"] == "interpreted"
    assert np.all(np.isfinite(run.u)) and np.max(np.abs(run.u)) < 1.2     # it was 2.7 when the run stopped
    assert np.max(np.abs(run.u[-1])) < 0.01                                 # coming to rest
    assert run.longitudinal.min() > 0.15 and run.v_scale.min() < 0.05 and run.info["governed"] > 2.0
    assert run.sigma[-1] < SIGMA0 + 0.2 * 5.0 - 0.3 and run.sigma[-1] > 0.85    # held back, nearly stretched
    E = np.max(np.abs(run.e), axis=1)             # e rows untouched: exp(-K t) from 0.01 m
    ref = E[0] * np.exp(-K * run.t)
    np.testing.assert_allclose(E, ref, rtol=2e-3, atol=1e-14)
    assert np.max(np.abs(run.s - run.s_reference())) < 1e-6          # s follows v_scale v*


@pytest.mark.parametrize("beta", [0.17, 0.2, 0.3, 1.2])     # margins 0.15 (at the threshold), 0.18, 0.27, 0.84
def test_governed_rail_law_solves_the_decoupling_system_with_scaled_commands(beta):
    gov, plain = pushed_rail_chain(True), pushed_rail_chain(False)
    q, t = gov.chain.zigzag(beta, d=0.2), 0.3
    out = gov.evaluate(q, t)
    g = out["v_scale"]
    assert g == pytest.approx(float(speed_scale(out["longitudinal"], 0.15)), abs=1e-15)
    assert out["longitudinal"] == pytest.approx(plain.evaluate(q, t)["longitudinal"], abs=1e-15)
    M, rhs = (x[0] for x in plain.decoupling_matrices(q[None], [t]))
    sigma_dot = 0.2 - K * (out["sigma"] - (SIGMA0 + 0.2 * t))
    rhs[0] -= (1 - g) * 0.1                        # the s row asks for v_scale v*,
    rhs[1] -= (1 - g) * sigma_dot                  # the span row for v_scale sigma_dot
    u = np.linalg.solve(M, rhs)
    np.testing.assert_allclose(out["u"], u, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(gov.evaluate(q, t, form="dense")["u"], u, rtol=1e-9, atol=1e-12)
    if beta == 1.2:
        assert g == 1 and np.allclose(out["u"], plain.evaluate(q, t)["u"], rtol=0, atol=1e-15)
    else:
        assert g < 1


def test_the_governed_rail_law_compiles_in_the_dense_form_and_equals_the_interpreted_one():
    ctrl = pushed_rail_chain(True)
    fast = compile_controller(ctrl, form="dense")
    for beta in (0.2, 0.3, 1.2):
        q = ctrl.chain.zigzag(beta, d=0.2)
        ref = ctrl.evaluate(q, 0.3, form="dense")
        out = fast.evaluate(q, 0.3)
        assert out["v_scale"] == pytest.approx(ref["v_scale"], abs=1e-14)
        np.testing.assert_allclose(out["u"], ref["u"], rtol=1e-12, atol=1e-14)
    structured = compile_controller(ctrl)                 # its C runs the recursion twice
    for beta in (0.2, 0.3, 1.2):
        q = ctrl.chain.zigzag(beta, d=0.2)
        ref, out = ctrl.evaluate(q, 0.3), structured.evaluate(q, 0.3)
        assert out["v_scale"] == pytest.approx(ref["v_scale"], abs=1e-14)
        np.testing.assert_allclose(out["u"], ref["u"], rtol=1e-12, atol=1e-14)


@pytest.mark.parametrize("span", [None, lambda t: SIGMA0 + 0.2 * t], ids=["held", "commanded"])
def test_the_governed_rail_law_re_pivoted_in_both_passes_compiles_and_equals_the_interpreted_one(monkeypatch, span):
    """With REPIVOT above every margin the C takes its re-pivoting branch at every state (for v_scale, then
    again with the governed head); the interpreted law always uses the re-pivoting step."""
    monkeypatch.setattr(recursion_module, "REPIVOT", 2.0)
    chain = PlanarChain(10, 0.1, base="rail", rail_limits=(-1.0, 5.0))
    ctrl = CoordinatingController(chain, Line(point=(0.0, 0.01)), K, 0.1, span=span, governor=True)
    comp = compile_controller(ctrl)
    for beta in (0.2, 0.3, 1.2):
        q = chain.zigzag(beta, d=0.2)
        ref, out = ctrl.evaluate(q, 0.3), comp.evaluate(q, 0.3)
        assert (ref["v_scale"] < 1) == (beta < 1)
        for name in ref:
            np.testing.assert_allclose(out[name], ref[name], rtol=1e-12, atol=1e-14, err_msg=name)
