"""The compiled spatial law's own formulation (generated/spatial_frame.py, spatial_variants.py, spatial_joints.py)
against independent computations: a line's frame geometry against the world geometry and finite differences,
the joint rates with only the spin carried against the interpreted joint step, the branch-free 2x2 singular
values against numpy's SVD, and the law compiled with the scalar kinematics step (COORDARM_SCALAR_KINEMATICS)
against the interpreted law."""
import casadi as ca
import numpy as np
import pytest

from coordarm.generated import compile as compile_controller
from coordarm.generated.spatial_frame import frame_geometry, line_frame
from coordarm.generated.spatial_joints import spatial_joint_prep, spatial_joint_rates
from coordarm.generated.spatial_variants import singular_values_2x2_select
from coordarm.symbolic.curves3d import Line3D
from coordarm.symbolic.motions import Sinusoid
from coordarm.symbolic.spatial_chain import SpatialChain
from coordarm.symbolic.spatial_controller import SpatialController
from coordarm.symbolic.spatial_recursion import SpatialRecursion

AXIS = np.array([1.0, 0.2, 0.1]) / np.linalg.norm([1.0, 0.2, 0.1])


def moving_line():
    return Line3D((0.01, lambda t: 0.003 * t + 0.02 * ca.sin(t), 0.002), AXIS, (0.0, 1.0, 0.0),
                  rotation=((0.0, 0.3, 1.0), Sinusoid(0.3, 0.7)))


def test_line_frame_geometry_is_the_world_geometry_in_the_line_frame():
    ctrl = SpatialController(SpatialChain(4, 0.1), moving_line(), 2.0, 0.1, roll=0.0)
    world, local = ctrl.task.geometry, frame_geometry(ctrl)
    ts = ca.SX.sym("t")
    frame = ca.Function("frame", [ts], list(line_frame(ctrl.task.curve, ts)))
    rng = np.random.default_rng(3)
    for t in (0.0, 0.4, 2.3):
        F, p = (np.array(v) for v in frame(t))
        assert np.allclose(F.T @ F, np.eye(3), atol=1e-14)
        for _ in range(4):
            y = rng.normal(0, 0.7, 3)
            yc = F.T @ (y - p.ravel())
            Phi_w, J_w, Phit_w, psi_w, g_w, psit_w = (np.array(v) for v in world(y, t))
            Phi_c, J_c, Phit_c, psi_c, g_c, psit_c = (np.array(v) for v in local(yc, t))
            assert np.allclose(Phi_c, Phi_w, atol=1e-13) and np.allclose(psi_c, psi_w, atol=1e-13)
            assert np.allclose(J_c, J_w @ F, atol=1e-13) and np.allclose(g_c.ravel(), F.T @ g_w.ravel(), atol=1e-13)
            # the time derivatives are at a fixed point of the base frame: central differences of the world Phi
            h = 1e-6
            fd = (np.array(world(y, t + h)[0]) - np.array(world(y, t - h)[0])) / (2 * h)
            fd_psi = (np.array(world(y, t + h)[3]).item() - np.array(world(y, t - h)[3]).item()) / (2 * h)
            assert np.allclose(Phit_c, fd, atol=1e-8) and np.allclose(Phit_c, Phit_w, atol=1e-13)
            assert abs(psit_c.item() - fd_psi) < 1e-8 and abs(psit_c.item() - psit_w.item()) < 1e-13


def test_joint_rates_with_the_spin_carried_equal_the_interpreted_joint_step():
    rng = np.random.default_rng(5)
    m = 9
    q = rng.uniform(-1.2, 1.2, 2 * m)
    w = rng.normal(0, 1, (2, m))
    step = SpatialRecursion.joint_step()
    carry = np.concatenate([np.eye(3).ravel(order="F"), np.zeros(3)])
    want = []
    for j in range(m):
        carry, out = step(carry, np.concatenate([q[2 * j:2 * j + 2], w[:, j]]))
        want.append(np.array(out).ravel())
    prep, rates = spatial_joint_prep(), spatial_joint_rates()
    a, b = q[0::2], q[1::2]
    x, w1p, w2p = 0.0, 0.0, 0.0
    for j in range(m):
        trig = (np.cos(a[j]), np.sin(a[j]), np.cos(b[j]), np.sin(b[j]), 1 / np.cos(b[j]))
        a_dot, b_dot, margin = (np.array(v).item() for v in rates(*trig, x, w1p, w2p, w[0, j], w[1, j]))
        assert np.allclose([a_dot, b_dot, margin], want[j], rtol=1e-12, atol=1e-12)
        alpha, beta = (np.array(v).item() for v in prep(trig[0], trig[1], trig[3], trig[4], w[0, j], w2p))
        x, w1p, w2p = alpha * x + beta, w[0, j], w[1, j]


@pytest.mark.parametrize("A", [np.array([[0.3, -1.2], [0.7, 0.4]]), np.array([[2.0, 0.0], [0.0, 2.0]]),
                               np.array([[0.6, -0.8], [0.8, 0.6]]) * 1.7, np.array([[1.0, 2.0], [0.5, 1.0]]),
                               np.zeros((2, 2))])
def test_branch_free_singular_values_match_numpy(A):
    X = ca.SX.sym("A", 2, 2)
    f = ca.Function("sv", [X], list(singular_values_2x2_select(X)))
    small, large = (float(v) for v in f(A))
    want = np.linalg.svd(A, compute_uv=False)
    assert abs(large - want[0]) <= 1e-12 * max(1.0, want[0])
    assert abs(small - want[1]) <= 1e-7 * max(1.0, want[0])       # sqrt of a rounding-level gap at equal values


@pytest.mark.parametrize("curve", ["line", "circle"])
def test_scalar_kinematics_fallback_equals_the_interpreted_law(curve):
    from test_spatial_compiled import controller, random_state, assert_close
    ctrl = controller(8, curve)
    comp = compile_controller(ctrl, flags=["-O2", "-DCOORDARM_SCALAR_KINEMATICS"])
    rng = np.random.default_rng(11)
    for t in (0.0, 1.3):
        q = random_state(ctrl.chain, rng)
        want, got = ctrl.evaluate(q, t), comp.evaluate(q, t)
        for name in want:
            assert_close(got[name], want[name])
