"""Linearised closed loop in task coordinates: eigenvalues -K (m-1 times) and 0 along s, to 1e-8."""
import casadi as ca
import numpy as np
import pytest

from coordarm.analysis.linearise import linearisation_function, linearise, linearise_run
from coordarm.simulation import simulate
from coordarm.symbolic import Arc, CoordinatingController, Line, PlanarChain, project_onto_curve


@pytest.fixture(scope="module")
def arc_run():
    chain = PlanarChain(8, 0.1)
    curve = Arc(angle=lambda t: 0.4 * ca.sin(0.25 * t), radius=lambda t: 2.0 + 0.3 * ca.sin(0.2 * t))
    ctrl = CoordinatingController(chain, curve, 2.0, lambda t: 0.08 + 0.02 * ca.sin(t))
    start = CoordinatingController(chain, Arc(radius=2.2), 2.0, 0.0)
    q0 = project_onto_curve(start, chain.zigzag(1.3))
    return ctrl, simulate(ctrl, q0, 3.0, 0.001)


@pytest.mark.parametrize("form", ["structured", "dense"])
def test_task_matrix_is_the_design_diag_0_minus_k_along_a_trajectory(arc_run, form):
    ctrl, run = arc_run
    K = ctrl.gain
    for L in linearise_run(ctrl, run.t, run.q, points=4, form=form):
        assert L.deviation_from_design(K) < 1e-8
        ev = np.sort_complex(L.eigenvalues())
        np.testing.assert_allclose(ev, np.sort_complex(np.array([-K] * 7 + [0.0], dtype=complex)), atol=1e-8)
        # the s direction: no feedback, driven by v* alone; e directions decay like exp(-K t)
        np.testing.assert_allclose(L.task_matrix[0], 0.0, atol=1e-8)
        assert L.task_rate[0] == pytest.approx(ctrl.speed_at(L.t), abs=1e-12)
        e = ctrl.evaluate(L.q, L.t)["e"]
        np.testing.assert_allclose(L.task_rate[1:], -K * e, atol=1e-12)


def test_frozen_jacobian_alone_is_not_the_error_dynamics_while_the_chain_moves(arc_run):
    ctrl, run = arc_run
    L = linearise(ctrl, run.q[500], run.t[500])
    target = np.diag([0.0] + [-ctrl.gain] * 7)
    assert np.max(np.abs(L.frozen_task_matrix - target)) > 0.1
    assert L.deviation_from_design(ctrl.gain) < 1e-8


def test_change_of_the_task_map_matches_central_differences_along_the_flow(arc_run):
    ctrl, run = arc_run
    fn = linearisation_function(ctrl)
    q, t = run.q[1200], float(run.t[1200])
    H, F, Hdot, _ = (np.asarray(x) for x in fn(q, t))
    f = ctrl.chain.B @ ctrl.control(q, t)
    d = 1e-5
    fd = (np.asarray(fn(q + d * f, t + d)[0]) - np.asarray(fn(q - d * f, t - d)[0])) / (2 * d)
    np.testing.assert_allclose(Hdot, fd, atol=1e-8)
    Fd = np.column_stack([(ctrl.control(q + d * e, t) - ctrl.control(q - d * e, t)) / (2 * d) for e in np.eye(8)])
    np.testing.assert_allclose(F, Fd, atol=1e-7)


def test_linearisation_on_a_line_with_nondiagonal_b():
    rng = np.random.default_rng(3)
    B = np.eye(6) + 0.1 * rng.standard_normal((6, 6))
    ctrl = CoordinatingController(PlanarChain(6, 0.1, B), Line(angle=lambda t: 0.2 * ca.sin(t)), 3.0, 0.1,
                                  law="dense")
    L = linearise(ctrl, ctrl.chain.zigzag(1.1, 0.05), 0.4)
    assert L.deviation_from_design(3.0) < 1e-8
