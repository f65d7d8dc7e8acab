"""The one RK4 step (coordarm.symbolic.integrator) against independent formulas, in numpy and CasADi."""
import casadi as ca
import numpy as np
import pytest

from coordarm.symbolic.integrator import rk4


def test_a_linear_system_steps_by_the_fourth_order_taylor_polynomial_of_its_exponential(rng):
    A = rng.normal(size=(4, 4))
    x, h = rng.normal(size=4), 0.1
    taylor = sum(np.linalg.matrix_power(h * A, k) @ x / np.prod(np.arange(1, k + 1)) for k in range(5))
    np.testing.assert_allclose(rk4(lambda y, t: A @ y, x, 0.0, h), taylor, rtol=1e-13, atol=1e-15)


def test_a_right_hand_side_of_time_alone_is_integrated_by_simpsons_rule():
    f = lambda t: np.array([np.cos(3 * t), t ** 5])         # noqa: E731
    t, h = 0.4, 0.05
    simpson = h / 6 * (f(t) + 4 * f(t + h / 2) + f(t + h))
    np.testing.assert_allclose(rk4(lambda y, s: f(s), np.zeros(2), t, h), simpson, rtol=1e-14)


def test_casadi_graphs_and_numpy_arrays_step_alike_and_a_given_first_stage_is_used_as_is(rng):
    def f(y, t):
        return -y ** 3 + np.sin(t) if isinstance(y, np.ndarray) else -y ** 3 + ca.sin(t)

    x, t, h = rng.normal(size=3), 0.7, 0.02
    xs, ts = ca.SX.sym("x", 3), ca.SX.sym("t")
    step = ca.Function("step", [xs, ts], [rk4(f, xs, ts, h)])
    np.testing.assert_allclose(np.asarray(step(x, t)).ravel(), rk4(f, x, t, h), rtol=1e-14)
    assert np.array_equal(rk4(f, x, t, h, k1=f(x, t)), rk4(f, x, t, h))
    calls = []
    rk4(lambda y, s: calls.append(s) or f(y, s), x, t, h, k1=f(x, t))
    assert calls == pytest.approx([t + h / 2, t + h / 2, t + h])   # three more evaluations, not four
