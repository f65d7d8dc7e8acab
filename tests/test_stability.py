"""Sampled-data and delay limits: closed form vs python-control vs the simulated nonlinear loop."""
import math

import casadi as ca
import numpy as np
import pytest

from coordarm.simulation.limits import GainStepWarning
from coordarm.analysis.stability import (RK4_LIMIT, control_limit, delay_margin, error_loop, grows, max_stable_delay,
                                sampled_limit, simulated_limit, spectral_radius, step_responses)
from coordarm.simulation import simulate
from coordarm.simulation.sampled import simulate_sampled
from coordarm.symbolic import ConfigError, CoordinatingController, Line, PlanarChain, SingularityError, follow_curve

K = 20.0


@pytest.fixture(scope="module")
def static_line():
    chain = PlanarChain(8, 0.1)
    return CoordinatingController(chain, Line(angle=1e-5), K, 0.0), chain.zigzag(1.2)


@pytest.mark.parametrize("n", range(5))
def test_python_control_limit_equals_the_closed_form(n):
    assert control_limit(2.0, 0.05, n) == pytest.approx(2 * math.sin(math.pi / (2 * (2 * n + 1))), rel=1e-10)
    assert sampled_limit(n) == pytest.approx(control_limit(2.0, 0.05, n), rel=1e-10)
    lim = sampled_limit(n)
    assert spectral_radius(2.0, 0.99 * lim / 2.0, n) < 1 < spectral_radius(2.0, 1.01 * lim / 2.0, n)


def test_limits_of_the_simple_cases_and_delay_margins():
    assert sampled_limit(0) == 2.0 and sampled_limit(1) == pytest.approx(1.0)
    assert abs(1 - RK4_LIMIT + RK4_LIMIT**2 / 2 - RK4_LIMIT**3 / 6 + RK4_LIMIT**4 / 24) == pytest.approx(1.0)
    assert RK4_LIMIT == pytest.approx(2.785293563405282, abs=1e-12)
    assert delay_margin(2.0) == pytest.approx(math.pi / 4, rel=1e-9)
    assert 0 < delay_margin(2.0, 0.1) < math.pi / 4        # the hold's half-sample lag costs margin
    assert max_stable_delay(2.0, 0.26) == 2 and max_stable_delay(2.0, 1.01) == -1
    assert error_loop(2.0, 0.1, 2).dt == 0.1
    resp = step_responses(2.0, 0.1)
    t, y = resp["continuous"]
    np.testing.assert_allclose(y, 1 - np.exp(-2.0 * t), atol=1e-3)
    with pytest.raises(ConfigError, match="delay"):
        sampled_limit(-1)
    with pytest.raises(ConfigError, match="gain"):
        control_limit(0.0, 0.1)


@pytest.mark.parametrize("n", [0, 1, 2])
def test_simulated_limit_agrees_with_the_prediction(static_line, n):
    ctrl, q0 = static_line
    sim = simulated_limit(ctrl, q0, n, rel_tol=2e-3)
    assert sim == pytest.approx(sampled_limit(n), rel=0.03)          # target 10 %; measured 0.2-1.3 %


@pytest.mark.parametrize("n", [0, 1, 2])
def test_moving_curve_just_inside_converges_and_just_outside_diverges(n):
    chain = PlanarChain(8, 0.1)
    ctrl = CoordinatingController(chain, Line(angle=lambda t: 0.01 + 0.05 * ca.sin(0.3 * t)), K, 0.02)
    q0 = chain.zigzag(1.2)
    h_in, h_out = 0.95 * sampled_limit(n) / K, 1.05 * sampled_limit(n) / K
    inside = simulate_sampled(ctrl, q0, 600 * h_in, h_in, n)
    e = inside.error_norm()
    assert inside.info["stopped"] == "completed" and e[-1] < 0.01 * e[0] and e.max() < 1.1 * e[0]
    assert grows(ctrl, q0, h_out, n)
    assert not grows(ctrl, q0, h_in, n)


def test_rk4_step_limit_is_seen_by_the_continuous_simulator():
    chain = PlanarChain(8, 0.1)
    ctrl = CoordinatingController(chain, Line(angle=1e-3), 2.0, 0.0)
    # on the line up to 1e-6 rad: the deviations stay small enough to follow RK4's linear factor
    # R(-K h) (0.88 a step at 0.97 of the limit, 1.13 at 1.03) for the whole run, so the outcome does
    # not hang on where a large, nonlinear divergence happens to settle
    q0 = follow_curve(ctrl, 1.2) + np.random.default_rng(3).normal(scale=1e-6, size=chain.m)
    peaks = []
    for f in (0.97, 1.03):
        h = f * RK4_LIMIT / 2.0
        try:
            with pytest.warns(GainStepWarning, match="RK4 diverges" if f > 1 else "K h = 2.70"):  # said beforehand
                run = simulate(ctrl, q0, 200 * h, h, thresholds={"link": 0.0, "longitudinal": 0.0})
            e = np.max(np.abs(run.e), axis=1)
        except SingularityError as err:
            e = np.max(np.abs(err.run.e), axis=1)
        peaks.append(e.max() / e[0])
    assert peaks[0] <= 1.0 and peaks[1] > 100


def test_sampled_simulator_follows_the_discrete_error_model(static_line):
    ctrl, q0 = static_line
    h = 0.01
    run = simulate_sampled(ctrl, q0, 1.0, h)
    k = np.arange(len(run.t))[:, None]
    np.testing.assert_allclose(run.e, run.e[0] * (1 - K * h) ** k, atol=1e-9 * np.abs(run.e[0]).max())
    # with a 2-sample delay: e_{k+1} = e_k - K h e_{k-2}, the buffer holding the start measurement
    run = simulate_sampled(ctrl, q0, 1.0, h, delay=2)
    model = np.empty_like(run.e)
    model[0] = run.e[0]
    for j in range(1, len(run.t)):
        model[j] = model[j - 1] - K * h * model[max(j - 3, 0)]
    np.testing.assert_allclose(run.e, model, atol=1e-8 * np.abs(run.e[0]).max())


@pytest.mark.parametrize("kwargs,match", [(dict(period=0.0), "period"), (dict(delay=-1), "delay"),
                                          (dict(delay=1.5), "delay"), (dict(duration=float("inf")), "duration"),
                                          (dict(period=2.0), "period")])
def test_sampled_simulator_refuses_bad_input(static_line, kwargs, match):
    ctrl, q0 = static_line
    args = {"duration": 1.0, "period": 0.01, **kwargs}
    with pytest.raises(ConfigError, match=match):
        simulate_sampled(ctrl, q0, **args)


def test_rk4_limit_is_the_correctly_rounded_root():
    from fractions import Fraction
    cubic = lambda x: Fraction(x) ** 3 - 4 * Fraction(x) ** 2 + 12 * Fraction(x) - 24   # noqa: E731
    below, above = np.nextafter(RK4_LIMIT, 0.0), np.nextafter(RK4_LIMIT, 3.0)
    assert cubic(below) < 0 < cubic(above)       # the root lies within one ulp either side
    assert abs(cubic(RK4_LIMIT)) <= min(abs(cubic(below)), abs(cubic(above)))
