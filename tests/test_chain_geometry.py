"""The compiled geometry of the physical checks (generated.chain_geometry) against the numpy reference and
against all pairs computed one by one."""
import math

import numpy as np
import pytest

from coordarm.generated import chain_geometry
from coordarm.generated.chain_geometry import chain_joints, geometry_library, self_distances
from coordarm.simulation.physical import check_configuration
from coordarm.simulation.scenario import load_scenario
from coordarm.symbolic import PlanarChain
from coordarm.symbolic.geometry import segment_distance
from coordarm.symbolic.geometry import self_distances as reference

pytestmark = pytest.mark.skipif(geometry_library() is None, reason="no working C compiler")


def numpy_trig_is_libm() -> bool:
    """numpy's cos and sin are the C library's (here: numpy 2.4, x86-64 without AVX-512); where numpy has
    SIMD versions of its own (AVX-512) they may differ from libm's by an ulp."""
    x = np.random.default_rng(0).uniform(-20, 20, 20_000)
    return (np.array_equal(np.cos(x), [math.cos(v) for v in x])
            and np.array_equal(np.sin(x), [math.sin(v) for v in x]))


def assert_joints_are_numpys(got, chain, q):
    """The compiled joints (libm's cos and sin) are ``joints_np``'s bit for bit where numpy's trigonometry
    is libm's; elsewhere within the few ulps an ulp of each direction can add along the chain."""
    want = chain.joints_np(q)
    if numpy_trig_is_libm():
        np.testing.assert_array_equal(got, want)
    else:
        np.testing.assert_allclose(got, want, rtol=0, atol=4 * chain.m * chain.xi * np.finfo(float).eps)


def sorted_pairs(found):
    s, a, b, d = found
    order = np.lexsort((b, a, s))
    return s[order], a[order], b[order], d[order]


def assert_same_as_reference(joints, clearance):
    got, want = sorted_pairs(self_distances(joints, clearance)), sorted_pairs(reference(joints, clearance))
    for g, w in zip(got, want):
        assert g.dtype.kind == w.dtype.kind
        np.testing.assert_array_equal(g, w)          # the same pairs, the same distances to the last bit
    return got


def all_close_pairs(joints, clearance):
    """Every pair of non-adjacent links within ``clearance``, each measured on its own (O(m^2) a sample)."""
    m = joints.shape[1] - 1
    i, j = np.triu_indices(m, k=2)
    out = {}
    for k in range(len(joints)):
        dist = segment_distance(joints[k, i], joints[k, i + 1], joints[k, j], joints[k, j + 1])
        out.update({(k, int(a) + 1, int(b) + 1): float(x) for a, b, x in zip(i, j, dist) if x <= clearance})
    return out


@pytest.mark.parametrize("m, rail", [(3, False), (7, True), (24, False), (64, False), (300, True)])
def test_compiled_joints_are_the_numpy_joints_bit_for_bit(m, rail, rng):
    chain = PlanarChain(m, 0.1, base="rail" if rail else "fixed", rail_angle=0.4)
    q = rng.uniform(-3, 3, size=(50, chain.dof))
    assert_joints_are_numpys(chain_joints(chain, q), chain, q)


@pytest.mark.parametrize("m, scale, clearance", [(3, 3.0, 0.0), (12, 2.8, 0.02), (40, 2.8, 0.0), (64, 0.6, 0.05),
                                                 (200, 0.4, 0.01)])
def test_random_chains_give_the_reference_pairs_and_every_pair_within_the_clearance(m, scale, clearance, rng):
    chain = PlanarChain(m, 0.1)
    joints = chain.joints_np(chain.zigzag(1.3)[None] + rng.normal(scale=scale, size=(40, m)))
    s, a, b, d = assert_same_as_reference(joints, clearance)
    close = {(int(k), int(x), int(y)): float(v) for k, x, y, v in zip(s, a, b, d) if v <= clearance}
    assert close == all_close_pairs(joints, clearance)
    assert np.all(b - a >= 2) and len(close) > 0


def test_crossing_touching_and_near_links_are_found_with_the_reference_distances():
    m, clearance = 24, 0.03
    chain = PlanarChain(m, 0.1)
    q = np.zeros((3, m))
    q[0, 1:4] = math.pi / 2                          # a square: link 4 ends on link 1's free end, link 5 on it
    q[1, 1:4] = [math.pi / 2, 0.75 * math.pi, 0.75 * math.pi]     # link 4 crosses link 2
    q[2] = chain.zigzag(1.45)                         # a compact zig-zag, neighbours within the clearance
    joints = chain.joints_np(q)
    s, a, b, d = assert_same_as_reference(joints, clearance)
    found = {(int(k), int(x), int(y)): float(v) for k, x, y, v in zip(s, a, b, d) if v <= clearance}
    assert found[(0, 1, 5)] < 1e-15 and found[(0, 1, 4)] < 1e-15 and found[(1, 2, 4)] == 0.0
    assert len([key for key in found if key[0] == 2]) == 2 * m - 5
    assert found == all_close_pairs(joints, clearance)


def test_a_run_of_the_line_preset_checks_the_same_pairs_as_numpy():
    sc = load_scenario("line").with_overrides(64, 2.0, None)
    ctrl = sc.controller()
    from coordarm.simulation.run import simulate
    run = simulate(ctrl, sc.start(ctrl), 2.0, sc.step, backend="compiled", progress=False)
    q = run.q[::5]
    joints = chain_joints(ctrl.chain, q)
    assert_joints_are_numpys(joints, ctrl.chain, q)
    for clearance in (0.0, ctrl.chain.clearance, 0.05):
        assert_same_as_reference(joints, clearance)


def test_many_pairs_are_gathered_in_a_second_call_and_a_non_finite_sample_runs_the_reference(rng):
    chain = PlanarChain(30, 0.1)
    joints = chain.joints_np(rng.normal(scale=0.05, size=(4, 30)) + np.tile([0.0, math.pi] * 15, (4, 1)))
    got = assert_same_as_reference(joints, 0.5)      # a chain folded onto itself: every pair within reach
    assert len(got[0]) > 16 * 4 + 1024
    joints[1, 5, 0] = np.nan
    assert_same_as_reference(joints, 0.02)


def test_without_a_compiler_the_checks_run_numpy_with_the_same_contacts(monkeypatch, rng):
    chain = PlanarChain(16, 0.1, clearance=0.01)
    q = chain.zigzag(1.45)[None] + rng.normal(scale=0.4, size=(60, 16))
    compiled = check_configuration(chain, q)
    monkeypatch.setattr(chain_geometry, "geometry_library", lambda: None)
    fallback = check_configuration(chain, q)
    assert any(c.kind == "self" for c in compiled)
    if numpy_trig_is_libm():                         # the same joints, so the same contacts to the last bit
        assert fallback == compiled
    else:                                            # joints an ulp apart: the same contacts, distances to ulps
        assert [(c.kind, c.time, c.links) for c in fallback] == [(c.kind, c.time, c.links) for c in compiled]
        np.testing.assert_allclose([c.value for c in fallback], [c.value for c in compiled], rtol=0, atol=1e-14)



# ------------------------------------------------------------------------------------- spatial link frames
@pytest.mark.parametrize("m, rail", [(2, False), (3, True), (40, True), (257, False)])
def test_compiled_spatial_frames_are_the_numpy_frames_bit_for_bit(m, rail, rng):
    """The C frames repeat ``link_frames`` from numpy's own cosines and sines: the same bits (also -0.0), and
    NaN where numpy has NaN (a NaN or infinite angle from its joint on)."""
    from coordarm.generated.chain_geometry import spatial_frames
    from coordarm.symbolic import SpatialChain

    chain = SpatialChain(m, 0.05, base="rail" if rail else "fixed")
    q = rng.uniform(-3.5, 3.5, size=(60, chain.dof))
    q[:, -1] = 0.0                                      # exact zeros in the last joint's products
    got, want = spatial_frames(chain, q), chain.frames_np(q)
    assert got.shape == (60, m, 3, 3) and got.tobytes() == want.tobytes()
    q[7, chain.dof // 2] = np.nan
    q[9, -2] = np.inf
    with np.errstate(invalid="ignore"):
        got, want = spatial_frames(chain, q), chain.frames_np(q)
    np.testing.assert_array_equal(got, want)            # NaN where numpy has NaN
    link = (chain.dof // 2 - rail) // 2                 # the link of the NaN joint angle
    assert np.isfinite(got[7, :link]).all() and np.isnan(got[7, link + 1:]).all()
    assert spatial_frames(chain, q[:0]).shape == (0, m, 3, 3)


def test_the_numpy_frames_are_the_matrix_products_and_the_casadi_frames(rng):
    """``link_frames`` (each entry added left to right, no fused multiply-add) equals the chained matrix products
    ``Rz(a_j) Ry(b_j)`` as ``@`` makes them and the symbolic chain's frames, to rounding."""
    import casadi as ca

    from coordarm.symbolic import SpatialChain
    from coordarm.symbolic.spatial_chain import joint_rotation_np

    chain = SpatialChain(30, 0.1)
    q = rng.uniform(-3, 3, size=(20, chain.dof))
    R = chain.frames_np(q)
    J = joint_rotation_np(q[:, 0::2], q[:, 1::2])
    product = J[:, 0]
    for j in range(chain.m):
        product = J[:, 0] if j == 0 else product @ J[:, j]
        np.testing.assert_allclose(R[:, j], product, rtol=0, atol=64 * np.finfo(float).eps)
    qs = ca.SX.sym("q", chain.dof)
    frames = ca.Function("f", [qs], [ca.horzcat(*[ca.reshape(F.T, 9, 1) for F in chain.frames(qs)])])
    for k in range(3):
        np.testing.assert_allclose(np.asarray(frames(q[k])).T.reshape(chain.m, 3, 3), R[k], rtol=0, atol=1e-13)


def test_without_a_compiler_the_spatial_checks_run_numpy_with_the_same_contacts(monkeypatch, rng):
    from coordarm.simulation.physical3d import Physical3D
    from coordarm.symbolic import SpatialChain

    chain = SpatialChain(16, 0.1)
    phys = Physical3D(chain, 1.2, 0.02, 0.01)
    q = chain.zigzag(0.8)[None] + rng.normal(scale=0.5, size=(60, chain.dof))
    t = np.arange(60) * 0.01
    compiled = phys.check(t, q)
    monkeypatch.setattr(chain_geometry, "geometry_library", lambda: None)
    assert any(c.kind == "self" for c in compiled) and any(c.kind == "joint_limit" for c in compiled)
    assert phys.check(t, q) == compiled                 # the same frames, so the same contacts to the last bit
