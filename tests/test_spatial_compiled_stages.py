"""The later stages of the compiled spatial RK4 step (templates/spatial_law.c, ``CA_LAW_STAGE``): a lean law
that writes only ``u`` and reuses the time features of the stage before at the same time. Checked against four
calls of the full law (the library's ``coordarm_control``) composed into RK4 in numpy, and against a work array
whose time-feature slot holds the stage's time with junk features (it must be recomputed, not read)."""
import numpy as np
import pytest

from coordarm.generated import compile as compile_controller
from coordarm.generated.spatial_variants import spatial_time_features
from coordarm.symbolic.curves3d import Line3D
from coordarm.symbolic.motions import Sinusoid
from coordarm.symbolic.spatial_chain import SpatialChain
from coordarm.symbolic.spatial_controller import SpatialController

AXIS = np.array([1.0, 0.2, 0.1]) / np.linalg.norm([1.0, 0.2, 0.1])


def turning_line_law(base="fixed"):
    chain = SpatialChain(9, 0.1, base=base)
    curve = Line3D((0.0, lambda t: 0.003 * t, 0.002), AXIS, (0.0, 1.0, 0.0),
                   rotation=((0.0, 0.3, 1.0), Sinusoid(0.3, 0.7)))
    ctrl = SpatialController(chain, curve, 2.0, Sinusoid(0.05, 0.5, 0.1), roll=Sinusoid(0.2, 1.3))
    q = chain.zigzag(0.9, axis=AXIS, fold=(0.0, 1.0, 0.0), roll=0.2) + np.random.default_rng(3).normal(0, 0.05, chain.dof)
    if base == "rail":
        q[0] = 0.2
    return ctrl, compile_controller(ctrl), q


@pytest.mark.parametrize("base", ["fixed", "rail"])
def test_the_rk4_step_is_four_calls_of_the_full_law(base):
    ctrl, comp, q = turning_line_law(base)
    t, h = 0.41, 0.02
    k1 = comp.control(q, t)
    k2 = comp.control(q + h / 2 * k1, t + h / 2)
    k3 = comp.control(q + h / 2 * k2, t + h / 2)
    k4 = comp.control(q + h * k3, t + h)
    want = q + h / 6 * (((k1 + 2 * k2) + 2 * k3) + k4)
    got = comp.step(q, t, h)
    assert np.max(np.abs(got - want)) <= 1e-14 * max(1.0, np.max(np.abs(want)))


def test_a_stale_time_feature_slot_in_the_work_array_is_not_read():
    ctrl, comp, q = turning_line_law()
    t, h = 0.41, 0.02
    want = comp.step(q, t, h)
    n_features = int(spatial_time_features(ctrl).numel_out(0))
    work = comp._w                                   # the library's work array (its last n + 2 values: the slot)
    slot = len(work) - (n_features + 2)
    for stale in (t + h / 2, t + h, t):              # the slot claims the time of a later stage, features junk
        work[slot] = stale
        work[slot + 1:] = 1e3
        assert np.array_equal(comp.step(q, t, h), want)
