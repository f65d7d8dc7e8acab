"""The spatial chain on a rail (feed axis): kinematics, the O(m) law vs the dense AD law, finite differences of
the task outputs (s, sigma, roll, e), the straight feed along the rail and the closed loop."""
import math
import sys
from pathlib import Path

import casadi as ca
import numpy as np
import pytest

from coordarm.symbolic import ConfigError
from coordarm.symbolic.motions import Sinusoid
from coordarm.symbolic.outputs import RAIL_OUTPUTS, SPATIAL_OUTPUTS, spatial_offsets, spatial_packed_width
from coordarm.symbolic.spatial_chain import SpatialChain
from coordarm.symbolic.spatial_controller import SpatialController
from coordarm.symbolic.spatial_dense import task_outputs_expr

sys.path.insert(0, str(Path(__file__).parent))
from spatial_curves_for_tests import Circle3D, Line3D  # noqa: E402

RAIL = np.array([1.0, 0.3, -0.2]) / np.linalg.norm([1.0, 0.3, -0.2])
AXIS = np.array([1.0, 0.2, 0.1]) / np.linalg.norm([1.0, 0.2, 0.1])


def moving_turning_line():
    return Line3D((0.0, lambda t: 0.003 * t, 0.01), AXIS, (0.0, 1.0, 0.0),
                  rotation=((0.0, 0.3, 1.0), Sinusoid(0.3, 0.7)))


def tilted_circle():
    w = np.array([0.1, -0.4, 1.0])
    w /= np.linalg.norm(w)
    inward = np.cross(w, AXIS)
    inward /= np.linalg.norm(inward)
    return Circle3D(1.5 * inward + np.array([0.0, 0.0, 0.005]), 1.5, w, -inward)


CURVES = {"line": moving_turning_line, "circle": tilted_circle}
SPANS = [None, 0.35, Sinusoid(0.05, 1.0)]


def rail_chain(m):
    return SpatialChain(m, 0.1, base="rail", rail_direction=3 * RAIL, rail_limits=(-1.0, 2.0))


def start(chain, rng, spread=0.03, beta=1.0):
    q = chain.zigzag(beta, axis=AXIS, fold=(0.0, 1.0, 0.0), roll=0.2, d=0.05)
    return q + rng.normal(0, spread, chain.dof)


def outputs_function(ctrl):
    q, t = ca.SX.sym("q", ctrl.chain.dof), ca.SX.sym("t")
    return ca.Function("Y", [q, t], [task_outputs_expr(ctrl.chain, ctrl.task, q, t)])


def test_the_rail_chain_puts_d_first_and_slides_the_base_along_the_unit_direction():
    chain, rng = rail_chain(5), np.random.default_rng(1)
    assert chain.rail and chain.dof == 11 and chain.rail_limits == (-1.0, 2.0)
    np.testing.assert_allclose(chain.rail_direction, RAIL, atol=1e-15)
    q = rng.uniform(-1, 1, chain.dof)
    fixed = SpatialChain(5, 0.1)
    # the centres are the fixed chain's, shifted by d r; the frames do not see d
    np.testing.assert_allclose(chain.centres_np(q), fixed.centres_np(q[1:]) + q[0] * RAIL, atol=1e-15)
    np.testing.assert_allclose(chain.frames_np(q), fixed.frames_np(q[1:]), atol=0)
    np.testing.assert_allclose(chain.base_point(q), q[0] * RAIL, atol=1e-15)
    assert chain.rail_position(q) == q[0] and np.all(chain.angles(q) == q[1:])
    qs = ca.SX.sym("q", chain.dof)
    sym = ca.Function("c", [qs], [chain.centres(qs)])
    np.testing.assert_allclose(np.asarray(sym(q)).T, chain.centres_np(q), atol=1e-14)
    # joint angles of the directions round-trip, with d first
    back = chain.joint_angles(chain.directions_np(q), d=q[0])
    np.testing.assert_allclose(chain.centres_np(back), chain.centres_np(q), atol=1e-13)
    assert chain.zigzag(1.0, d=0.4)[0] == 0.4 and len(chain.zigzag(1.0)) == chain.dof
    with pytest.raises(ConfigError, match="shape \\(11,\\) \\(d, a_1"):
        chain.check_q(np.zeros(10))


@pytest.mark.parametrize("kwargs, match", [({"rail_direction": (0, 0, 0)}, "rail_direction"),
                                           ({"rail_direction": (1, 0)}, "rail_direction"),
                                           ({"rail_limits": (1.0, 0.0)}, "rail_limits"),
                                           ({"base": "drum"}, "base")])
def test_a_bad_rail_is_refused_naming_the_field(kwargs, match):
    with pytest.raises(ConfigError, match=match):
        SpatialChain(4, 0.1, **{"base": "rail", **kwargs})


def test_a_span_needs_a_rail():
    with pytest.raises(ConfigError, match="span"):
        SpatialController(SpatialChain(4, 0.1), moving_turning_line(), 2.0, 0.1, roll=0.0, span=0.3)


@pytest.mark.parametrize("m", [3, 7, 12])
@pytest.mark.parametrize("curve", sorted(CURVES))
def test_the_structured_rail_law_equals_the_dense_law(m, curve):
    rng, chain = np.random.default_rng(m), rail_chain(m)
    for span in SPANS:
        q = start(chain, rng, beta=rng.uniform(0.6, 1.3))
        ctrl = SpatialController(chain, CURVES[curve](), 2.0, Sinusoid(0.05, 0.5), roll=Sinusoid(0.2, 1.3), span=span)
        t = float(rng.uniform(0, 2))
        fast, dense = ctrl.evaluate(q, t), ctrl.evaluate(q, t, "dense")
        scale = np.abs(dense["u"]).max()
        np.testing.assert_allclose(fast["u"], dense["u"], rtol=0, atol=1e-9 * scale)
        mx = np.asarray(ctrl.law()(q, t)[0]).ravel()
        np.testing.assert_allclose(mx, fast["u"], rtol=0, atol=1e-12 * scale)
        assert fast["rail_margin"] > 0 and fast["end_margin"] > 0


@pytest.mark.parametrize("span", SPANS)
@pytest.mark.parametrize("curve", sorted(CURVES))
def test_the_rail_law_gives_the_commanded_output_rates_by_finite_differences(curve, span):
    rng, chain = np.random.default_rng(21), rail_chain(6)
    q = start(chain, rng)
    v, roll, K, t = Sinusoid(0.05, 0.5), Sinusoid(0.2, 1.3), 2.0, 0.7
    ctrl = SpatialController(chain, CURVES[curve](), K, v, roll=roll, span=span)
    Y = outputs_function(ctrl)
    out = ctrl.evaluate(q, t)
    h = 1e-5
    Ydot = (np.asarray(Y(q + h * out["u"], t + h)) - np.asarray(Y(q - h * out["u"], t - h))).ravel() / (2 * h)
    if span is None:
        sigma_dot = 0.0
    elif callable(span):
        sigma_dot = 0.05 * math.cos(t) - K * (out["sigma"] - 0.05 * math.sin(t))
    else:
        sigma_dot = -K * (out["sigma"] - span)
    theta_star, theta_star_dot = 0.2 * math.sin(1.3 * t), 0.2 * 1.3 * math.cos(1.3 * t)
    np.testing.assert_allclose(Ydot[0], 0.05 * math.sin(0.5 * t), atol=1e-8)
    np.testing.assert_allclose(Ydot[1], sigma_dot, atol=1e-8)
    np.testing.assert_allclose(Ydot[2], theta_star_dot - K * (out["roll"] - theta_star), atol=1e-8)
    np.testing.assert_allclose(Ydot[3:], -K * out["e"], atol=1e-8)
    Y0 = np.asarray(Y(q, t)).ravel()
    np.testing.assert_allclose(Y0[:3], [out["s"], out["sigma"], out["roll"]], atol=1e-14)
    np.testing.assert_allclose(Y0[3:], out["e"], atol=1e-14)


def test_the_rail_margin_is_the_cosine_between_the_rail_and_the_path():
    chain = rail_chain(5)
    ctrl = SpatialController(chain, Line3D((0.0, 0.0, 0.0), AXIS, (0.0, 1.0, 0.0)), 2.0, 0.1, roll=0.0)
    out = ctrl.evaluate(start(chain, np.random.default_rng(3)))
    assert out["rail_margin"] == pytest.approx(abs(np.dot(RAIL, AXIS)), abs=1e-14)


@pytest.mark.parametrize("m", [4, 9])
def test_on_a_straight_path_along_the_rail_the_law_feeds_the_rail_at_v_star_with_the_joints_at_rest(m):
    chain, v = rail_chain(m), 0.13
    ctrl = SpatialController(chain, Line3D((0.0, 0.0, 0.0), RAIL, (0.0, 0.0, 1.0)), 2.0, v, roll=None,
                             start=chain.zigzag(1.1, axis=RAIL, fold=(0.0, 0.0, 1.0), roll=0.4, d=0.2))
    q = chain.zigzag(1.1, axis=RAIL, fold=(0.0, 0.0, 1.0), roll=0.4, d=0.2)
    for form in ("structured", "dense"):
        out = ctrl.evaluate(q, 0.3, form)
        assert out["u"][0] == pytest.approx(v, abs=1e-13)
        np.testing.assert_allclose(out["u"][1:], 0.0, atol=1e-12)
    # and it stays so along the run: the compact body slides in, every centre on the line
    step = ctrl.rk4_step(0.01)
    for k in range(50):
        q = np.asarray(step(q, 0.01 * k)[0]).ravel()
    assert q[0] == pytest.approx(0.2 + 50 * 0.01 * v, abs=1e-12)
    np.testing.assert_allclose(q[1:], chain.zigzag(1.1, axis=RAIL, fold=(0.0, 0.0, 1.0), roll=0.4)[1:], atol=1e-12)


def test_the_rail_closed_loop_holds_the_span_and_decays_like_exp_minus_K_t():
    # a rail along a line that slides along itself: the base stays near the line. (A base carried off the
    # line by a few mm in the fold plane turns link 1 across the line when the span is held: with the
    # fold beta near pi/2, sin(beta_1) = sin(beta_2) + offset / (xi/2) soon reaches 1, a singularity.)
    rng = np.random.default_rng(14)
    chain = SpatialChain(10, 0.1, base="rail", rail_direction=AXIS)
    q = start(chain, rng, 0.02, beta=1.2)
    K, v, h, steps = 2.0, 0.1, 0.005, 200
    line = Line3D(tuple((lambda t, a=a, o=o: o + 0.02 * a * ca.sin(t)) for a, o in zip(AXIS, (0.0, 0.0, 0.004))),
                  AXIS, (0.0, 1.0, 0.0))
    ctrl = SpatialController(chain, line, K, v, roll=0.3, start=q)
    step = ctrl.rk4_step(h)
    out0, t = ctrl.evaluate(q, 0.0), 0.0
    for _ in range(steps):
        q = np.asarray(step(q, t)[0]).ravel()
        t += h
    out, decay = ctrl.evaluate(q, t), math.exp(-K * t)
    np.testing.assert_allclose(out["e"], out0["e"] * decay, rtol=0, atol=1e-9)
    np.testing.assert_allclose(out["s"], out0["s"] + v * t, rtol=0, atol=1e-9)
    np.testing.assert_allclose(out["sigma"], out0["sigma"], rtol=0, atol=1e-9)
    np.testing.assert_allclose(out["roll"] - 0.3, (out0["roll"] - 0.3) * decay, rtol=0, atol=1e-9)
    assert np.abs(out0["e"]).max() > 1e-3 and abs(q[0] - 0.05) > 1e-3


def test_the_rail_law_names_its_outputs_and_packs_them_after_the_spatial_ones():
    chain = rail_chain(4)
    ctrl = SpatialController(chain, moving_turning_line(), 2.0, 0.1, roll=0.0)
    assert ctrl.law().name_out() == list(SPATIAL_OUTPUTS + RAIL_OUTPUTS)
    widths = {name: np.size(v) for name, v in ctrl.evaluate(start(chain, np.random.default_rng(2))).items()}
    assert widths == {"u": 9, "e": 6, "s": 1, "roll": 1, "link_margins": 3, "end_margin": 1, "joint_margins": 4,
                      "sigma": 1, "rail_margin": 1}
    assert spatial_packed_width(4, True) == sum(widths.values())
    assert list(spatial_offsets(4, True))[-2:] == ["sigma", "rail_margin"]
    sizes = {m: SpatialController(rail_chain(m), moving_turning_line(), 2.0, 0.1, roll=0.0, span=0.3).law().n_nodes()
             for m in (4, 40)}
    assert sizes[4] == sizes[40]
