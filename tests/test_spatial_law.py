"""The spatial coordinating law (docs/guide/spatial.md): O(m) solve vs dense AD, finite differences of the
task outputs, margins, the closed loop and the planar task stated in 3-D."""
import math
import sys
from pathlib import Path

import casadi as ca
import numpy as np
import pytest

from coordarm.symbolic import ConfigError, CoordinatingController, Line, PlanarChain
from coordarm.symbolic.motions import Sinusoid
from coordarm.symbolic.outputs import SPATIAL_OUTPUTS
from coordarm.symbolic.spatial_chain import SpatialChain
from coordarm.symbolic.spatial_controller import SpatialController
from coordarm.symbolic.spatial_dense import task_outputs_expr

sys.path.insert(0, str(Path(__file__).parent))
from spatial_curves_for_tests import Circle3D, Line3D  # noqa: E402

AXIS = np.array([1.0, 0.2, 0.1]) / np.linalg.norm([1.0, 0.2, 0.1])


def moving_turning_line():
    """A line through the base whose point drifts slowly and which turns about a tilted axis (a line that drifts
    far from a fixed base soon makes the first link stand across it: a singularity, docs/guide/spatial.md)."""
    return Line3D((0.0, lambda t: 0.003 * t, lambda t: 0.002 * ca.sin(t)), AXIS, (0.0, 1.0, 0.0),
                  rotation=((0.0, 0.3, 1.0), Sinusoid(0.3, 0.7)))


def tilted_circle():
    """A circle of radius 1.5 through (near) the base, its plane tilted out of xy; tangent ~ AXIS at the base."""
    w = np.array([0.1, -0.4, 1.0])
    w /= np.linalg.norm(w)
    inward = np.cross(w, AXIS)
    inward /= np.linalg.norm(inward)
    return Circle3D(1.5 * inward + np.array([0.0, 0.0, 0.005]), 1.5, w, -inward)


CURVES = {"line": moving_turning_line, "circle": tilted_circle,
          "static": lambda: Line3D((0.0, 0.01, 0.0), AXIS, (0.0, 0.3, 1.0))}
ROLLS = [None, 0.4, Sinusoid(0.2, 1.3)]


def perturbed_start(chain, rng, spread=0.03, beta=1.0):
    return chain.zigzag(beta, axis=AXIS, fold=(0.0, 1.0, 0.0), roll=0.2) + rng.normal(0, spread, chain.dof)


def task_outputs_function(ctrl):
    q, t = ca.SX.sym("q", ctrl.chain.dof), ca.SX.sym("t")
    return ca.Function("Y", [q, t], [task_outputs_expr(ctrl.chain, ctrl.task, q, t)])


@pytest.mark.parametrize("m", [3, 4, 7, 12, 19])
@pytest.mark.parametrize("curve", sorted(CURVES))
def test_the_structured_solve_equals_the_dense_law(m, curve):
    rng = np.random.default_rng(m)
    chain = SpatialChain(m, 0.1)
    for roll in ROLLS:
        q = perturbed_start(chain, rng, beta=rng.uniform(0.6, 1.3))
        ctrl = SpatialController(chain, CURVES[curve](), 2.0, Sinusoid(0.05, 0.5), roll=roll, start=q)
        t = float(rng.uniform(0, 2))
        fast, dense = ctrl.evaluate(q, t), ctrl.evaluate(q, t, "dense")
        scale = np.abs(dense["u"]).max()
        np.testing.assert_allclose(fast["u"], dense["u"], rtol=0, atol=1e-9 * scale)
        # the MX (mapaccum) form and its SX expansion agree too
        mx = np.asarray(ctrl.law()(q, t)[0]).ravel()
        np.testing.assert_allclose(mx, fast["u"], rtol=0, atol=1e-12 * scale)
        assert fast["end_margin"] > 0 and fast["link_margins"].min() > 0


@pytest.mark.parametrize("m", [3, 8, 19])
def test_the_structured_solve_equals_the_dense_law_at_arbitrary_states(m):
    rng, chain = np.random.default_rng(100 + m), SpatialChain(m, 0.1)
    for curve in sorted(CURVES):
        ctrl = SpatialController(chain, CURVES[curve](), 2.0, 0.1, roll=Sinusoid(0.2, 1.3))
        q, t = rng.uniform(-1.2, 1.2, chain.dof), float(rng.uniform(0, 2))     # far from any zig-zag
        dense = ctrl.evaluate(q, t, "dense")["u"]
        np.testing.assert_allclose(ctrl.control(q, t), dense, rtol=0, atol=1e-9 * np.abs(dense).max())


@pytest.mark.parametrize("curve", sorted(CURVES))
def test_the_law_gives_the_commanded_output_rates_by_finite_differences(curve):
    rng, chain = np.random.default_rng(11), SpatialChain(6, 0.1)
    q = perturbed_start(chain, rng)
    v, roll, K, t = Sinusoid(0.05, 0.5), Sinusoid(0.2, 1.3), 2.0, 0.7
    ctrl = SpatialController(chain, CURVES[curve](), K, v, roll=roll)
    Y = task_outputs_function(ctrl)
    out = ctrl.evaluate(q, t)
    h = 1e-5
    Ydot = (np.asarray(Y(q + h * out["u"], t + h)) - np.asarray(Y(q - h * out["u"], t - h))).ravel() / (2 * h)
    theta_star = 0.2 * math.sin(1.3 * t)
    theta_star_dot = 0.2 * 1.3 * math.cos(1.3 * t)
    np.testing.assert_allclose(Ydot[0], 0.05 * math.sin(0.5 * t), atol=1e-8)
    np.testing.assert_allclose(Ydot[1], theta_star_dot - K * (out["roll"] - theta_star), atol=1e-8)
    np.testing.assert_allclose(Ydot[2:], -K * out["e"], atol=1e-8)
    Y0 = np.asarray(Y(q, t)).ravel()
    np.testing.assert_allclose([Y0[0], Y0[1]], [out["s"], out["roll"]], atol=1e-14)
    np.testing.assert_allclose(Y0[2:], out["e"], atol=1e-14)


def test_the_decoupling_matrix_is_the_finite_difference_jacobian_of_the_outputs():
    rng, chain = np.random.default_rng(12), SpatialChain(5, 0.1)
    q = perturbed_start(chain, rng)
    ctrl = SpatialController(chain, moving_turning_line(), 2.0, 0.1, roll=0.0)
    Y = task_outputs_function(ctrl)
    M = np.asarray(ctrl.decoupling_function()(q, 0.4)[0])
    h = 1e-6
    fd = np.stack([(np.asarray(Y(q + h * e, 0.4)) - np.asarray(Y(q - h * e, 0.4))).ravel() / (2 * h)
                   for e in np.eye(chain.dof)], axis=1)
    np.testing.assert_allclose(M, fd, atol=1e-8)


def test_margins_are_the_singular_values_of_the_link_pivots_and_the_joint_cosines():
    rng, chain = np.random.default_rng(13), SpatialChain(8, 0.1)
    curve = Line3D((0.0, 0.01, 0.0), AXIS, (0.0, 0.3, 1.0))
    q = perturbed_start(chain, rng, 0.1)
    out = SpatialController(chain, curve, 2.0, 0.1, roll=0.0).evaluate(q)
    n1, n2 = curve.base_frame[1], curve.base_frame[2]
    R = chain.frames_np(q)
    expected = [np.linalg.svd(np.array([n1, n2]) @ R[j][:, 1:3], compute_uv=False)[-1] for j in range(1, 8)]
    np.testing.assert_allclose(out["link_margins"], expected, atol=1e-13)
    np.testing.assert_allclose(out["joint_margins"], np.abs(np.cos(q[1::2])), atol=1e-15)


@pytest.mark.parametrize("roll", [None, Sinusoid(0.3, 1.0)])
def test_the_closed_loop_decays_like_exp_minus_K_t_and_tracks_speed_and_roll(roll):
    rng, chain = np.random.default_rng(14), SpatialChain(12, 0.1)
    q = perturbed_start(chain, rng, 0.02, beta=1.2)
    K, v, h, steps = 2.0, 0.1, 0.005, 300
    ctrl = SpatialController(chain, moving_turning_line(), K, v, roll=roll, start=q)
    step = ctrl.rk4_step(h)
    out0 = ctrl.evaluate(q, 0.0)
    target = (lambda t: 0.3 * math.sin(t)) if roll is not None else (lambda t: out0["roll"])
    t = 0.0
    for _ in range(steps):
        q = np.asarray(step(q, t)[0]).ravel()
        t += h
    out = ctrl.evaluate(q, t)
    decay = math.exp(-K * t)
    np.testing.assert_allclose(out["e"], out0["e"] * decay, rtol=0, atol=1e-9)
    np.testing.assert_allclose(out["s"], out0["s"] + v * t, rtol=0, atol=1e-9)
    np.testing.assert_allclose(out["roll"] - target(t), (out0["roll"] - target(0.0)) * decay, rtol=0, atol=1e-9)
    assert np.abs(out0["e"]).max() > 1e-3           # the check is not vacuous


def test_a_planar_task_stated_in_3d_gives_the_planar_law():
    m, xi, K = 10, 0.1, 2.0
    point = (0.01, lambda t: 0.02 * ca.sin(t))
    angle = Sinusoid(0.6, 0.2)
    planar = CoordinatingController(PlanarChain(m, xi), Line(point=point, angle=angle), K, 0.1)
    line3d = Line3D((point[0], point[1], 0.0), (1.0, 0.0, 0.0), (0.0, 1.0, 0.0), rotation=((0.0, 0.0, 1.0), angle))
    spatial = SpatialController(SpatialChain(m, xi), line3d, K, 0.1, roll=0.0)
    rng = np.random.default_rng(15)
    for t in (0.0, 0.9):
        a = PlanarChain(m, xi).zigzag(1.2) + rng.normal(0, 0.05, m)
        q = np.zeros(2 * m)
        q[0::2] = a
        u = spatial.control(q, t)
        np.testing.assert_allclose(u[1::2], 0.0, atol=1e-12)
        np.testing.assert_allclose(u[0::2], planar.control(a, t), rtol=0, atol=1e-12)
    held = SpatialController(SpatialChain(m, xi), line3d, K, 0.1, start=q)
    assert held.roll_target(0.0) == 0.0


def test_the_structured_law_graph_does_not_grow_with_the_links():
    curve = CURVES["static"]()
    sizes = {m: SpatialController(SpatialChain(m, 0.1), curve, 2.0, 0.1, roll=0.0).law().n_nodes() for m in (4, 40)}
    assert sizes[4] == sizes[40]


def test_the_face_names_its_outputs_and_refuses_bad_arguments():
    chain, curve = SpatialChain(4, 0.1), CURVES["static"]()
    ctrl = SpatialController(chain, curve, 2.0, 0.1, roll=0.0)
    assert ctrl.law().name_out() == list(SPATIAL_OUTPUTS)
    widths = {name: np.size(v) for name, v in ctrl.evaluate(chain.zigzag(1.0, axis=AXIS)).items()}
    assert widths == {"u": 8, "e": 6, "s": 1, "roll": 1, "link_margins": 3, "end_margin": 1, "joint_margins": 4}
    with pytest.raises(ConfigError, match="start"):
        SpatialController(chain, curve, 2.0, 0.1)
    with pytest.raises(ConfigError, match="SpatialChain"):
        SpatialController(PlanarChain(4, 0.1), curve, 2.0, 0.1, roll=0.0)
    with pytest.raises(ConfigError, match="3-D curve"):
        SpatialController(chain, Line(), 2.0, 0.1, roll=0.0)
    with pytest.raises(ConfigError, match="gain"):
        SpatialController(chain, curve, -1.0, 0.1, roll=0.0)
