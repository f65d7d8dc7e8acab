"""Chain kinematics: AD Jacobians vs the closed form of eq. 7 vs finite differences."""
import math

import casadi as ca
import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from coordarm.symbolic import ConfigError, PlanarChain


def ad_jacobians(chain, q):
    qs = ca.SX.sym("q", chain.m)
    y = chain.centres(qs)
    J = ca.Function("J", [qs], [ca.jacobian(ca.vec(y), qs)])
    return np.asarray(J(q)).reshape(chain.m, 2, chain.m)      # rows of vec(y) are (y1^1, y2^1, y1^2, ...)


def fd_jacobians(chain, q, h=1e-6):
    cols = []
    for k in range(chain.m):
        dq = np.zeros(chain.m)
        dq[k] = h
        cols.append((chain.centres_np(q + dq) - chain.centres_np(q - dq)) / (2 * h))
    return np.stack(cols, axis=-1)          # (m, 2, m)


@given(m=st.integers(2, 12), seed=st.integers(0, 2**31), xi=st.floats(0.01, 2.0))
def test_ad_jacobian_equals_closed_form_of_eq7_and_finite_differences(m, seed, xi):
    chain = PlanarChain(m, xi)
    q = np.random.default_rng(seed).uniform(-math.pi, math.pi, m)
    closed = chain.jacobians_closed_form(q)
    np.testing.assert_allclose(ad_jacobians(chain, q), closed, atol=1e-13 * max(1, m * xi))
    np.testing.assert_allclose(fd_jacobians(chain, q), closed, atol=1e-8 * m * xi)


def test_symbolic_and_numpy_centres_agree(rng):
    chain = PlanarChain(9, 0.3)
    q = rng.uniform(-3, 3, 9)
    qs = ca.SX.sym("q", 9)
    y = np.asarray(ca.Function("y", [qs], [chain.centres(qs)])(q)).T
    np.testing.assert_allclose(y, chain.centres_np(q), atol=1e-14)
    assert np.all(y[0] == 0)


def test_joints_are_link_ends_at_link_length_apart(rng):
    chain = PlanarChain(7, 0.25)
    q = rng.uniform(-3, 3, 7)
    J = chain.joints_np(q)
    np.testing.assert_allclose(np.linalg.norm(np.diff(J, axis=0), axis=1), 0.25, atol=1e-14)
    np.testing.assert_allclose(0.5 * (J[:-1] + J[1:]), chain.centres_np(q), atol=1e-14)


@pytest.mark.parametrize("beta,heading", [(1.3, 0.0), (0.4, -2.0), (-1.0, 0.7)])
def test_zigzag_puts_centres_on_a_line_spaced_xi_cos_beta(beta, heading):
    chain = PlanarChain(20, 0.1)
    y = chain.centres_np(chain.zigzag(beta, heading))
    d = np.diff(y, axis=0)
    np.testing.assert_allclose(d, np.tile(0.1 * math.cos(beta) * np.array([math.cos(heading), math.sin(heading)]),
                                          (19, 1)), atol=1e-14)
    alpha = np.cumsum(chain.zigzag(beta, heading))
    np.testing.assert_allclose(alpha[::2], heading + beta, atol=1e-14)
    np.testing.assert_allclose(alpha[1::2], heading - beta, atol=1e-14)


@pytest.mark.parametrize("kwargs,field", [
    (dict(links=0, link_length=0.1), "links"), (dict(links=1, link_length=0.1), "links"),
    (dict(links=2.5, link_length=0.1), "links"), (dict(links=True, link_length=0.1), "links"),
    (dict(links=5, link_length=0.0), "link_length"), (dict(links=5, link_length=-1.0), "link_length"),
    (dict(links=5, link_length=float("nan")), "link_length"), (dict(links=5, link_length=float("inf")), "link_length"),
    (dict(links=3, link_length=0.1, B=np.zeros(3)), "B"), (dict(links=3, link_length=0.1, B=np.eye(2)), "B"),
    (dict(links=3, link_length=0.1, B=[1, float("nan"), 1]), "B"),
])
def test_bad_chain_parameters_raise_a_config_error_naming_the_field(kwargs, field):
    with pytest.raises(ConfigError, match=field):
        PlanarChain(**kwargs)


def test_bad_configurations_are_refused_with_the_field_named():
    chain = PlanarChain(4, 0.1)
    with pytest.raises(ConfigError, match="q: need shape"):
        chain.check_q(np.zeros(3))
    with pytest.raises(ConfigError, match="NaN or inf at index 2"):
        chain.check_q([0, 0, float("nan"), 0])
    with pytest.raises(ConfigError, match="beta"):
        chain.zigzag(0.0)
    with pytest.raises(ConfigError, match="beta"):
        chain.zigzag(math.pi / 2)
