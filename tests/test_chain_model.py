"""The chain interface the law builder is written against, and the carry layout of the recursion."""
import casadi as ca
import numpy as np
import pytest

from coordarm.symbolic import CoordinatingController, Line, PlanarChain
from coordarm.symbolic.carry import CARRY, Carry
from coordarm.symbolic.chain_model import ChainModel


def test_the_planar_chain_implements_the_chain_interface():
    assert isinstance(PlanarChain(3, 0.1), ChainModel)
    assert isinstance(PlanarChain(3, 0.1, base="rail"), ChainModel)


def test_the_carry_fields_tile_the_carry_column_in_order():
    covered = []
    for name in Carry._fields:
        index = CARRY.index(name)
        covered += [index] if isinstance(index, int) else list(range(index.start, index.stop))
    assert covered == list(range(CARRY.size)) and CARRY.size == 12


@pytest.mark.parametrize("B", [None, [0.5, 2.0, 1.5, 3.0], "full"])
def test_controls_from_link_rates_solve_B_u_for_the_joint_rates(B):
    rng = np.random.default_rng(3)
    if B == "full":
        B = np.eye(4) + 0.3 * rng.normal(size=(4, 4))
    chain = PlanarChain(4, 0.1, B=B)
    w = rng.normal(size=4)                                  # link rates alpha_j'
    u = np.asarray(chain.controls_from_link_rates(ca.DM(w))).ravel()
    qdot = np.diff(w, prepend=0.0)                          # alpha_j = q_1 + ... + q_j
    np.testing.assert_allclose(chain.B @ u, qdot, rtol=1e-12, atol=1e-14)


@pytest.mark.parametrize("base", ["fixed", "rail"])
def test_the_recursion_carries_the_centres_and_angles_of_the_forward_kinematics(base):
    chain = PlanarChain(6, 0.2, base=base, rail_limits=(-1.0, 1.0))
    ctrl = CoordinatingController(chain, Line(point=(0.0, 0.05), angle=0.1), 2.0, 0.1)
    q = chain.zigzag(0.7, d=0.3) if chain.rail else chain.zigzag(0.7)
    q = q + np.random.default_rng(5).normal(0, 0.1, chain.dof)
    rec, qr = ctrl.recursion, chain.revolute(q)
    carry = (rec.rail_head()(q[0], qr[0], 0.0, 0.0)[0] if chain.rail else rec.first_carry()(qr[0]))
    step, w = rec.link_step(), rec.time_features()(0.0)
    centres, alpha = chain.centres_np(q), np.cumsum(qr)
    for j in range(chain.m):
        if j:
            carry = step(carry, qr[j], w)[0]
        c = CARRY.unpack(np.asarray(carry).ravel())
        np.testing.assert_allclose(c.y, centres[j], atol=1e-14)
        np.testing.assert_allclose([c.alpha, *c.direction], [alpha[j], np.cos(alpha[j]), np.sin(alpha[j])],
                                   atol=1e-14)
