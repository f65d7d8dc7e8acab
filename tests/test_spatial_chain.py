"""The spatial chain (universal joints, docs/guide/spatial.md): kinematics against independent computations."""
import math
import sys
from pathlib import Path

import casadi as ca
import numpy as np
import pytest

from coordarm.symbolic import ConfigError, PlanarChain
from coordarm.symbolic.chain_model import ChainModel, KinematicChain
from coordarm.symbolic.spatial_chain import SpatialChain
from coordarm.symbolic.spatial_controller import SpatialController

sys.path.insert(0, str(Path(__file__).parent))
from spatial_curves_for_tests import Line3D  # noqa: E402


def random_q(chain, rng, spread=0.6):
    """Joint angles with |b| well inside pi/2."""
    q = rng.uniform(-spread, spread, chain.dof)
    return q


def rot(axis, angle):
    """Rotation matrix about a unit axis (numpy, Rodrigues), written out independently of the module."""
    k = np.asarray(axis, float)
    K = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + math.sin(angle) * K + (1 - math.cos(angle)) * K @ K


def frames_by_rodrigues(q):
    """R_j = R_{j-1} Rz(a_j) Ry(b_j) with each elementary rotation from Rodrigues' formula."""
    R, out = np.eye(3), []
    for a, b in q.reshape(-1, 2):
        R = R @ rot([0, 0, 1], a) @ rot([0, 1, 0], b)
        out.append(R)
    return np.array(out)


def test_the_spatial_chain_implements_the_kinematic_interface_only():
    chain = SpatialChain(4, 0.1)
    assert isinstance(chain, KinematicChain) and not isinstance(chain, ChainModel)
    assert isinstance(PlanarChain(4, 0.1), KinematicChain)
    assert (chain.m, chain.xi, chain.dof, chain.rail) == (4, 0.1, 8, False)


def test_frames_directions_and_centres_follow_the_stated_convention():
    chain = SpatialChain(6, 0.3)
    q = random_q(chain, np.random.default_rng(1), 1.2)
    R = frames_by_rodrigues(q)
    np.testing.assert_allclose(chain.frames_np(q), R, atol=1e-14)
    d = R[:, :, 0]
    y = [np.zeros(3)]
    for j in range(1, 6):
        y.append(y[-1] + 0.15 * (d[j - 1] + d[j]))
    np.testing.assert_allclose(chain.centres_np(q), np.array(y), atol=1e-14)
    qs = ca.SX.sym("q", chain.dof)
    f = ca.Function("k", [qs], [chain.centres(qs), chain.directions(qs)])
    yc, dc = f(q)
    np.testing.assert_allclose(np.asarray(yc).T, np.array(y), atol=1e-14)
    np.testing.assert_allclose(np.asarray(dc).T, d, atol=1e-14)


def test_centres_np_vectorise_over_leading_axes():
    chain = SpatialChain(5, 0.2)
    Q = np.random.default_rng(2).uniform(-1, 1, (3, 4, chain.dof))
    Y = chain.centres_np(Q)
    assert Y.shape == (3, 4, 5, 3)
    np.testing.assert_allclose(Y[2, 1], chain.centres_np(Q[2, 1]), atol=1e-15)


def closed_form_jacobians(chain, q):
    """dy^j/dq: joint i's a-axis is R_{i-1} e_z, its b-axis R_{i-1} Rz(a_i) e_y; d d_k/dq_i = axis x d_k (i <= k)."""
    R = frames_by_rodrigues(q)
    m = chain.m
    d = R[:, :, 0]
    dd = np.zeros((m, 3, 2 * m))                      # dd[k] = d d_k / dq
    for i in range(m):
        R_prev = np.eye(3) if i == 0 else R[i - 1]
        ax_a = R_prev[:, 2]
        ax_b = R_prev @ rot([0, 0, 1], q[2 * i]) @ np.array([0.0, 1.0, 0.0])
        for k in range(i, m):
            dd[k][:, 2 * i] = np.cross(ax_a, d[k])
            dd[k][:, 2 * i + 1] = np.cross(ax_b, d[k])
    C = np.zeros((m, 3, 2 * m))
    for j in range(1, m):
        C[j] = C[j - 1] + 0.5 * chain.xi * (dd[j - 1] + dd[j])
    return C


def test_ad_jacobians_of_the_centres_equal_the_closed_form_and_finite_differences():
    chain = SpatialChain(7, 0.15)
    rng = np.random.default_rng(3)
    qs = ca.SX.sym("q", chain.dof)
    jac = ca.Function("J", [qs], [ca.jacobian(ca.vec(chain.centres(qs)), qs)])
    for _ in range(3):
        q = random_q(chain, rng, 1.0)
        J_ad = np.asarray(jac(q)).reshape(chain.m, 3, chain.dof)   # vec(centres) is column-major: (link, xyz)
        np.testing.assert_allclose(J_ad, closed_form_jacobians(chain, q), atol=1e-13)
        h = 1e-6
        fd = np.stack([(chain.centres_np(q + h * e) - chain.centres_np(q - h * e)) / (2 * h)
                       for e in np.eye(chain.dof)], axis=-1)
        np.testing.assert_allclose(J_ad, fd, atol=1e-9)


def test_with_every_b_zero_the_chain_is_the_planar_chain():
    m = 8
    a = np.random.default_rng(4).uniform(-1, 1, m)
    q = np.zeros(2 * m)
    q[0::2] = a
    y = SpatialChain(m, 0.1).centres_np(q)
    np.testing.assert_allclose(y[:, :2], PlanarChain(m, 0.1).centres_np(a), atol=1e-14)
    np.testing.assert_array_equal(y[:, 2], 0.0)
    zz = SpatialChain(m, 0.1).zigzag(1.1)
    np.testing.assert_allclose(zz[0::2], PlanarChain(m, 0.1).zigzag(1.1), atol=1e-14)
    np.testing.assert_allclose(zz[1::2], 0.0, atol=1e-15)


def test_zigzag_lays_the_stated_directions_with_centres_on_the_axis():
    chain, beta, roll = SpatialChain(9, 0.1), 1.2, 0.7
    axis = np.array([1.0, 0.5, -0.3]) / np.linalg.norm([1.0, 0.5, -0.3])
    fold = np.array([0.2, 1.0, 0.4])
    q = chain.zigzag(beta, axis=axis, fold=fold, roll=roll)
    f = fold - fold.dot(axis) * axis
    f /= np.linalg.norm(f)
    f_rolled = rot(axis, roll) @ f
    expected = [math.cos(beta) * axis + (-1) ** (j + 1) * math.sin(beta) * f_rolled for j in range(1, 10)]
    np.testing.assert_allclose(chain.directions_np(q), np.array(expected), atol=1e-13)
    y = chain.centres_np(q)
    np.testing.assert_allclose(y, np.arange(9)[:, None] * 0.1 * math.cos(beta) * axis, atol=1e-13)


def test_joint_angles_recover_the_joint_coordinates_from_the_directions():
    chain = SpatialChain(10, 0.1)
    q = random_q(chain, np.random.default_rng(5), 1.4)
    np.testing.assert_allclose(chain.joint_angles(chain.directions_np(q)), q, atol=1e-12)


@pytest.mark.parametrize("bad", [np.zeros(5), np.r_[np.zeros(7), np.nan]])
def test_check_q_names_the_field(bad):
    with pytest.raises(ConfigError, match="q0"):
        SpatialChain(4, 0.1).check_q(bad, "q0")


@pytest.mark.parametrize("kwargs", [{"beta": 1.6}, {"beta": 1.0, "fold": (1.0, 0.0, 0.0)},
                                    {"beta": 1.0, "axis": (0.0, 0.0, 0.0)}])
def test_zigzag_refuses_a_bad_fold(kwargs):
    with pytest.raises(ConfigError):
        SpatialChain(4, 0.1).zigzag(**kwargs)


def test_joint_rates_from_link_rates_match_finite_differences_of_the_directions():
    chain = SpatialChain(7, 0.1)
    rng = np.random.default_rng(6)
    ctrl = SpatialController(chain, Line3D((0, 0, 0), (1, 0, 0), (0, 1, 0)), 2.0, 0.1, roll=0.0)
    q_s, w_s = ca.MX.sym("q", chain.dof), ca.MX.sym("w", 2, chain.m)
    rates = ca.Function("rates", [q_s, w_s], list(ctrl.recursion.joint_rates(q_s, w_s)))
    for _ in range(3):
        q, qdot = random_q(chain, rng, 1.2), rng.normal(size=chain.dof)
        h = 1e-6
        d_dot = (chain.directions_np(q + h * qdot) - chain.directions_np(q - h * qdot)) / (2 * h)
        R = chain.frames_np(q)
        w = np.stack([R[j][:, 1:3].T @ d_dot[j] for j in range(chain.m)], axis=1)   # d_j' = E_j w_j
        got, margins = rates(q, w)
        np.testing.assert_allclose(np.asarray(got).ravel(), qdot, atol=1e-7)
        np.testing.assert_allclose(np.asarray(margins).ravel(), np.abs(np.cos(q[1::2])), atol=1e-15)
