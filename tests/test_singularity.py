"""Singularity margins: zero exactly at constructed singular configurations, equal to the law's pivots."""
import casadi as ca
import numpy as np
import pytest
from hypothesis import given, strategies as st

from coordarm.analysis.singularity import margins, run_margins
from coordarm.simulation.run import DEFAULT_THRESHOLDS
from coordarm.symbolic.recursion import REPIVOT
from coordarm.symbolic import Arc, ConfigError, CoordinatingController, Line, PlanarChain, project_onto_curve


def line_ctrl(m, speed=0.1):
    return CoordinatingController(PlanarChain(m, 0.1), Line(), 2.0, speed)


@pytest.mark.parametrize("m", [4, 9, 64])
@pytest.mark.parametrize("beta", [0.05, 0.4, 1.3])
def test_zigzag_on_a_line_has_the_closed_form_margins(m, beta):
    ctrl = line_ctrl(m)
    mg = margins(ctrl, ctrl.chain.zigzag(beta), 0.0)
    assert mg["longitudinal"] == pytest.approx((m - 1) / m * np.sin(beta), rel=1e-12)
    np.testing.assert_allclose(mg["links"], np.cos(beta), rtol=1e-12)
    assert mg["links"].shape == (m - 1,)
    assert mg["worst_link"] == 2


def test_worst_link_ignores_rounding_noise_but_not_a_real_dip():
    from coordarm.analysis.singularity import TIE, _worst_link

    rng = np.random.default_rng(3)
    tied = np.cos(1.3) + rng.normal(0, 1e-14, (50, 63))     # a converged zig-zag: equal up to rounding
    assert np.unique(np.argmin(tied, axis=1)).size > 1      # plain argmin chatters between links
    assert np.all(_worst_link(tied) == 2)
    dip = tied.copy()
    dip[:, 40] -= 10 * TIE                                   # link 42 really is the worst
    assert np.all(_worst_link(dip) == 42)


@given(m=st.integers(3, 12), seed=st.integers(0, 10_000), radius=st.floats(0.8, 5.0))
def test_margins_equal_the_structured_solve_pivots_at_random_configurations(m, seed, radius):
    chain = PlanarChain(m, 0.1)
    ctrl = CoordinatingController(chain, Arc(angle=lambda t: 0.3 * ca.sin(t), radius=radius), 2.0, 0.1)
    q = chain.zigzag(1.1) + 0.05 * np.random.default_rng(seed).standard_normal(m)
    mg, law = margins(ctrl, q, 0.7), ctrl.evaluate(q, 0.7)
    plain = mg["links"] >= REPIVOT             # below REPIVOT the law re-pivots and reports the better of two
    np.testing.assert_allclose(mg["links"][plain], law["link_margins"][plain], rtol=1e-9, atol=1e-12)
    assert np.all(law["link_margins"][~plain] >= mg["links"][~plain])
    assert mg["longitudinal"] == pytest.approx(law["longitudinal"], rel=1e-8)   # QR null vector vs recursion
    assert mg["u_max"] == pytest.approx(np.max(np.abs(law["u"])), rel=1e-8)      # dense solve vs recursion
    v = ctrl.speed_at(0.7)
    assert mg["amplification"] == pytest.approx(0.1 * np.linalg.norm(law["u"]) / abs(v), rel=1e-8)
    M = ctrl.decoupling_matrix(q, 0.7)
    assert mg["cond"] == pytest.approx(np.linalg.cond(M), rel=1e-9)
    assert mg["sigma_min"] == pytest.approx(np.linalg.svd(M, compute_uv=False)[-1] / 0.1, rel=1e-9)


def test_fully_stretched_chain_zeroes_the_longitudinal_margin_and_the_matrix_margins():
    ctrl = line_ctrl(8)
    mg = margins(ctrl, np.zeros(8))            # every link along the line
    assert mg["longitudinal"] == 0.0
    assert mg["sigma_min"] < 1e-15 and mg["inverse_cond"] < 1e-15 and mg["inverse_cond_scaled"] < 1e-15
    np.testing.assert_allclose(mg["links"], 1.0)      # ... while every link margin is perfect
    assert not np.isfinite(mg["u_max"])


def test_stretched_chain_on_a_circle_zeroes_the_longitudinal_margin():
    # A chain along the circle with all centres on it and the end point at its farthest reach:
    # there s^m is stationary along the family of on-curve configurations.
    from coordarm.analysis.workspace import curve_zigzag
    chain = PlanarChain(6, 0.1)
    ctrl = CoordinatingController(chain, Arc(radius=1.0), 2.0, 0.1)
    s_end = lambda b: ctrl.evaluate(curve_zigzag(6, 0.1, b, 1.0))["s"]
    from scipy.optimize import minimize_scalar
    best = minimize_scalar(lambda b: -s_end(b), bounds=(-0.3, 0.3), method="bounded", options={"xatol": 1e-12})
    q = curve_zigzag(6, 0.1, best.x, 1.0)
    assert np.max(np.abs(ctrl.evaluate(q)["e"])) < 1e-14
    assert margins(ctrl, q)["longitudinal"] < 1e-6
    assert margins(ctrl, curve_zigzag(6, 0.1, best.x + 0.3, 1.0))["longitudinal"] > 0.1


def test_link_perpendicular_to_the_curve_zeroes_its_margin_but_not_the_dense_matrix():
    ctrl = line_ctrl(8)
    q = ctrl.chain.zigzag(1.0)
    alpha = np.cumsum(q)
    d = np.pi / 2 - alpha[3]                   # turn link 4 alone to stand across the line
    q[3] += d
    q[4] -= d
    mg = margins(ctrl, q)
    assert mg["worst_link"] == 4 and abs(mg["links"][2]) < 1e-15
    np.testing.assert_allclose(np.delete(mg["links"], 2), np.cos(1.0), rtol=1e-12)
    # The full decoupling matrix is fine there: the law re-pivots that link, so its margin stays clear.
    assert mg["cond"] < 1e4 and mg["sigma_min"] > 1e-3 and np.isfinite(mg["u_max"])
    law = ctrl.evaluate(q)["link_margins"]
    np.testing.assert_allclose(np.delete(law, 2), np.delete(mg["links"], 2), atol=1e-15)
    assert law[2] > DEFAULT_THRESHOLDS["link"]
    assert mg["longitudinal"] > 0.1


def test_cond_misses_the_longitudinal_singularity_that_the_longitudinal_margin_sees():
    ctrl = line_ctrl(64)
    mgs = [margins(ctrl, ctrl.chain.zigzag(b)) for b in (1.3, 0.3, 0.05)]
    long = [m["longitudinal"] for m in mgs]
    assert long[0] / long[2] > 15                              # the margin falls 19x ...
    conds = [m["cond"] for m in mgs]
    assert max(conds) / min(conds) < 1.01                      # ... while cond(M) does not move
    amp = [m["amplification"] for m in mgs]
    assert amp[2] / amp[0] > 5                                 # and |u| per unit v* grows


def test_run_margins_matches_pointwise_margins_and_checks_shapes():
    chain = PlanarChain(6, 0.1)
    ctrl = CoordinatingController(chain, Arc(radius=1.5), 2.0, 0.1)
    q0 = project_onto_curve(ctrl, chain.zigzag(1.2))
    Q = q0 + 0.01 * np.arange(7)[:, None]
    T = np.linspace(0, 1, 7)
    r = run_margins(ctrl, T, Q, batch=3)
    assert r["links"].shape == (7, 5) and r["longitudinal"].shape == (7,)
    for k in (0, 4, 6):
        mg = margins(ctrl, Q[k], T[k])
        for key, v in mg.items():
            np.testing.assert_allclose(r[key][k], v, rtol=1e-12)
    with pytest.raises(ConfigError, match="q: need shape"):
        run_margins(ctrl, T, Q[:, :5])


def test_margins_with_a_non_diagonal_input_matrix_equal_the_law():
    rng = np.random.default_rng(7)
    B = np.eye(7) + 0.2 * rng.standard_normal((7, 7))
    chain = PlanarChain(7, 0.1, B)
    ctrl = CoordinatingController(chain, Arc(radius=1.5), 2.0, 0.1, law="dense")
    q = chain.zigzag(1.0) + 0.05 * rng.standard_normal(7)
    mg, law = margins(ctrl, q, 0.2), ctrl.evaluate(q, 0.2)
    assert mg["longitudinal"] == pytest.approx(law["longitudinal"], rel=1e-8)
    assert mg["u_max"] == pytest.approx(np.max(np.abs(law["u"])), rel=1e-8)
