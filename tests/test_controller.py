"""The coordinating law: structured O(m) solve vs dense eq. 27, task equations by finite differences."""
import math

import casadi as ca
import numpy as np
import pytest
from hypothesis import assume, given
from hypothesis import strategies as st

from coordarm.symbolic import (
    Circle,
    ConfigError,
    CoordinatingController,
    Line,
    PlanarChain,
    Ramp,
    project_onto_curve,
)
from coordarm.simulation.run import DEFAULT_THRESHOLDS
from tests.curves_for_tests import moving_curve


def random_state(chain, rng, spread=0.15):
    return chain.zigzag(rng.uniform(0.5, 1.4), rng.uniform(-0.5, 0.5)) + rng.normal(0, spread, chain.m)


@pytest.mark.parametrize("kind", ["line", "circle", "arc"])
@given(m=st.integers(2, 40), seed=st.integers(0, 2**31), gain=st.floats(0.1, 20))
def test_structured_solve_equals_dense_eq27_on_random_states(kind, m, seed, gain):
    rng = np.random.default_rng(seed)
    B = rng.uniform(0.5, 2.0, m)
    ctrl = CoordinatingController(PlanarChain(m, 0.1, B=B), moving_curve(kind), gain,
                                  speed=lambda t: 0.1 + 0.05 * ca.sin(t))
    q, t = random_state(ctrl.chain, rng), rng.uniform(0, 10)
    s, d = ctrl.evaluate(q, t, "structured"), ctrl.evaluate(q, t, "dense")
    # Where the law is used: the simulator stops below these margins. The structured recursion
    # divides by the link pivots, so below them it loses digits (a 12-link state with a link
    # margin of 6.4e-5 agreed to 1.8e-10 only; a 39-link one to 3.0e-10).
    assume(s["link_margins"].min() >= DEFAULT_THRESHOLDS["link"]
           and s["longitudinal"] >= DEFAULT_THRESHOLDS["longitudinal"])
    M, rhs = (np.asarray(v) for v in ctrl.decoupling_function()(q, t))
    assert np.linalg.norm(M @ s["u"] - rhs.ravel()) <= 1e-10 * np.linalg.norm(M) * np.linalg.norm(s["u"]) \
        + 1e-12 * np.linalg.norm(rhs)
    # the two forms agree to 1e-10 relative (the bar)
    err = np.linalg.norm(s["u"] - d["u"]) / np.linalg.norm(d["u"])
    assert err <= 1e-10, (err, np.linalg.cond(M))
    for k in ("e", "s", "link_margins", "longitudinal"):
        np.testing.assert_array_equal(s[k], d[k])


def test_non_diagonal_b_uses_its_inverse_and_matches_dense(rng):
    m = 12
    B = np.eye(m) + 0.2 * rng.normal(size=(m, m))
    ctrl = CoordinatingController(PlanarChain(m, 0.1, B=B), moving_curve("circle"), 2.0, 0.1)
    q = random_state(ctrl.chain, rng)
    np.testing.assert_allclose(ctrl.evaluate(q, 0.5)["u"], ctrl.evaluate(q, 0.5, "dense")["u"], rtol=1e-10)


@pytest.mark.parametrize("kind", ["line", "circle", "arc"])
def test_control_makes_task_rates_as_designed_by_finite_differences(kind, rng):
    """d/dt e^j = -K e^j and d/dt s^m = v*, measured by moving q along B u and t together."""
    m, K = 24, 1.7
    ctrl = CoordinatingController(PlanarChain(m, 0.1, B=rng.uniform(0.5, 2, m)), moving_curve(kind), K,
                                  speed=Ramp(0.1, 0.02))
    q, t, h = random_state(ctrl.chain, rng, 0.05), 1.3, 1e-6
    out = ctrl.evaluate(q, t)
    qdot = ctrl.chain.B @ out["u"]
    plus, minus = ctrl.evaluate(q + h * qdot, t + h), ctrl.evaluate(q - h * qdot, t - h)
    edot = (plus["e"] - minus["e"]) / (2 * h)
    sdot = (plus["s"] - minus["s"]) / (2 * h)
    np.testing.assert_allclose(edot, -K * out["e"], atol=1e-7)
    assert sdot == pytest.approx(0.1 + 0.02 * t, abs=1e-7)


@pytest.mark.parametrize("kind", ["line", "circle", "arc"])
@pytest.mark.parametrize("b_kind", ["ones", "diagonal", "full"])
@pytest.mark.parametrize("m", [2, 15])
def test_closed_form_decoupling_matrices_equal_the_ad_ones(kind, b_kind, m, rng):
    """Batched eq. 7 prefix sums (numpy) vs CasADi AD Jacobians, matrix and right-hand side."""
    N = 4
    B = {"ones": None, "diagonal": rng.uniform(0.5, 2, m), "full": np.eye(m) + 0.2 * rng.normal(size=(m, m))}[b_kind]
    ctrl = CoordinatingController(PlanarChain(m, 0.1, B=B), moving_curve(kind), 1.7,
                                  speed=lambda t: 0.1 + 0.05 * ca.sin(t))
    Q = np.array([random_state(ctrl.chain, rng, 0.5) for _ in range(N)])
    T = rng.uniform(0, 5, N)
    M, rhs = ctrl.decoupling_matrices(Q, T)
    assert M.shape == (N, m, m) and rhs.shape == (N, m)
    for k in range(N):
        Ma, ra = (np.asarray(v) for v in ctrl.decoupling_function()(Q[k], T[k]))
        np.testing.assert_allclose(M[k], Ma, rtol=0, atol=1e-14 * np.abs(Ma).max())
        np.testing.assert_allclose(rhs[k], ra.ravel(), rtol=1e-14, atol=1e-15)
        assert ctrl.cond(Q[k], T[k]) == pytest.approx(np.linalg.cond(Ma), rel=1e-9)
    np.testing.assert_allclose(ctrl.conds(Q, T), [np.linalg.cond(x) for x in M], rtol=1e-12)
    np.testing.assert_allclose(ctrl.speeds(T), [ctrl.speed_at(t) for t in T], rtol=1e-15)
    geo, Y = ctrl.centre_geometry(Q, T), ctrl.chain.centres_np(Q)
    for k, j in ((0, 0), (N - 1, m - 1)):   # one point at a time through the geometry Function
        one = [np.asarray(v).ravel() for v in ctrl.task.geometry(Y[k, j], T[k])]
        np.testing.assert_array_equal(geo["gphi"][k, j], one[1])
        np.testing.assert_array_equal(geo["psit"][k, j], one[5][0])
    with pytest.raises(ConfigError, match="Q, T"):
        ctrl.decoupling_matrices(Q[:, 1:], T)


def test_decoupling_matrix_is_the_jacobian_of_the_task_map(rng):
    m = 10
    ctrl = CoordinatingController(PlanarChain(m, 0.1), moving_curve("arc"), 2.0, 0.0)
    q, t, h = random_state(ctrl.chain, rng), 0.4, 1e-6
    M = ctrl.decoupling_matrix(q, t)

    def task(qq):
        o = ctrl.evaluate(qq, t)
        return np.concatenate([[o["s"]], o["e"]])
    fd = np.column_stack([(task(q + h * np.eye(m)[k]) - task(q - h * np.eye(m)[k])) / (2 * h) for k in range(m)])
    np.testing.assert_allclose(M, fd, atol=1e-8)


@pytest.mark.parametrize("beta", [1.5, 1.3, 0.7, 0.1])
def test_margins_on_a_straight_zigzag_are_cos_and_sin_of_the_fold(beta):
    m = 32
    ctrl = CoordinatingController(PlanarChain(m, 0.1), Line(angle=0.3), 2.0, 0.1)
    out = ctrl.evaluate(ctrl.chain.zigzag(beta, 0.3), 0.0)
    np.testing.assert_allclose(out["link_margins"], math.cos(beta), atol=1e-12)
    assert out["longitudinal"] == pytest.approx((m - 1) / m * math.sin(beta), abs=1e-12)
    assert out["longitudinal_pivot"] == pytest.approx(-(m - 1) * 0.1 * math.sin(beta), abs=1e-12)


def test_projection_puts_every_centre_on_the_curve():
    ctrl = CoordinatingController(PlanarChain(40, 0.1), moving_curve("arc"), 2.0, 0.1)
    q = project_onto_curve(ctrl, ctrl.chain.zigzag(1.2), t0=0.7)
    assert np.max(np.abs(ctrl.evaluate(q, 0.7)["e"])) < 1e-11


def test_projection_onto_an_unreachable_curve_is_a_config_error():
    ctrl = CoordinatingController(PlanarChain(10, 0.1), Circle(center=(5.0, 5.0), radius=0.01), 2.0, 0.1)
    with pytest.raises(ConfigError, match="link 2 cannot be placed"):
        project_onto_curve(ctrl, ctrl.chain.zigzag(1.2))


@pytest.mark.parametrize("gain", [0.0, -1.0, float("nan"), float("inf"), "2", True])
def test_non_positive_or_non_finite_gain_is_refused(gain):
    with pytest.raises(ConfigError, match="gain"):
        CoordinatingController(PlanarChain(4, 0.1), Line(), gain, 0.1)


def test_other_bad_controller_inputs_are_named():
    chain = PlanarChain(4, 0.1)
    with pytest.raises(ConfigError, match="speed"):
        CoordinatingController(chain, Line(), 1.0, float("nan"))
    with pytest.raises(ConfigError, match="law"):
        CoordinatingController(chain, Line(), 1.0, 0.1, law="sparse")
    with pytest.raises(ConfigError, match="curve"):
        CoordinatingController(chain, "line", 1.0, 0.1)
    ctrl = CoordinatingController(chain, Line(), 1.0, 0.1)
    with pytest.raises(ConfigError, match="NaN"):
        ctrl.control([0.1, float("nan"), 0.0, 0.0], 0.0)
    with pytest.raises(ConfigError, match="t: must be finite"):
        ctrl.control(chain.zigzag(1.0), float("inf"))


@pytest.mark.parametrize("threshold", ["abc", None, [0.1], float("nan"), float("inf"), True])
@pytest.mark.parametrize("governor", [False, True])
def test_a_bad_governor_threshold_is_refused_naming_it_with_the_governor_on_or_off(threshold, governor):
    """Off, it was converted unchecked: a traceback (ValueError/TypeError) or NaN, True kept as 1.0."""
    with pytest.raises(ConfigError, match=r"^governor_threshold: need a"):
        CoordinatingController(PlanarChain(4, 0.1), Line(), 1.0, 0.1, governor=governor, governor_threshold=threshold)


def test_a_governor_threshold_outside_0_1_is_unused_and_kept_with_the_governor_off():
    ctrl = CoordinatingController(PlanarChain(4, 0.1), Line(), 1.0, 0.1, governor_threshold=0.0)
    assert ctrl.governor_threshold == 0.0           # a scenario's longitudinal threshold 0 without the governor
    with pytest.raises(ConfigError, match=r"governor_threshold: need a number in \(0, 1\), got 0.0"):
        CoordinatingController(PlanarChain(4, 0.1), Line(), 1.0, 0.1, governor=True, governor_threshold=0.0)
