"""Curves: orthonormalised description, time derivatives by AD vs finite differences, motions."""
import math

import casadi as ca
import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from coordarm.symbolic import (Arc, Circle, ConfigError, CoordinatingController, Line, PlanarChain, Smoothstep,
                      Sinusoid, curve_from_spec, motion_from_spec, motion_to_spec)

MOVING = {
    "line": lambda: Line(point=(lambda t: 0.1 * ca.sin(t), 0.05 * 1.0), angle=lambda t: 0.6 * ca.sin(0.2 * t)),
    "circle": lambda: Circle(center=(lambda t: 0.3 + 0.1 * ca.cos(t), 1.5), radius=lambda t: 1.6 + 0.2 * ca.sin(t)),
    "arc": lambda: Arc(point=(0.0, 0.0), angle=Sinusoid(0.4, 0.25), radius=Sinusoid(0.3, 0.2, offset=2.0)),
}


def geometry(curve):
    return CoordinatingController(PlanarChain(2, 0.1), curve, 1.0, 0.0).task.geometry


def point_on_curve(curve, t, u):
    """A point of the curve at time t, from its sampled polyline (parameter u in [0, 1))."""
    pts = curve.sample(t, n=2001, extent=3.0)
    return pts[int(u * 2000)]


@pytest.mark.parametrize("name", sorted(MOVING))
@given(t=st.floats(-5, 5), u=st.floats(0, 0.999))
def test_jacobian_of_psi_phi_is_a_rotation_on_the_curve(name, t, u):
    curve = MOVING[name]()
    y = point_on_curve(curve, t, u)
    phi, gphi, _, _, gpsi, _ = (np.asarray(v).ravel() for v in geometry(curve)(y, t))
    assert abs(phi[0]) < 1e-12
    J = np.vstack([gpsi, gphi])
    np.testing.assert_allclose(J @ J.T, np.eye(2), atol=1e-12)
    assert np.linalg.det(J) == pytest.approx(1.0, abs=1e-12)   # T(alpha*) of eq. 11, not a reflection


@pytest.mark.parametrize("name", sorted(MOVING))
def test_time_derivatives_by_ad_match_finite_differences(name, rng):
    geo = geometry(MOVING[name]())
    for _ in range(10):
        y, t, h = rng.uniform(-1, 1, 2), rng.uniform(-3, 3), 1e-6
        phit, psit = float(geo(y, t)[2]), float(geo(y, t)[5])
        fd = [(float(geo(y, t + h)[k]) - float(geo(y, t - h)[k])) / (2 * h) for k in (0, 3)]
        assert phit == pytest.approx(fd[0], abs=1e-8)
        assert psit == pytest.approx(fd[1], abs=1e-8)


def test_line_psi_grows_along_its_direction_and_phi_is_signed_distance():
    geo = geometry(Line(point=(1.0, 2.0), angle=math.pi / 6))
    d, n = np.array([math.cos(math.pi / 6), math.sin(math.pi / 6)]), np.array([-0.5, math.sqrt(3) / 2])
    y = np.array([1.0, 2.0]) + 0.7 * d + 0.3 * n
    assert float(geo(y, 0)[3]) == pytest.approx(0.7, abs=1e-14)
    assert float(geo(y, 0)[0]) == pytest.approx(0.3, abs=1e-14)


def test_circle_is_counter_clockwise_with_psi_continuous_away_from_the_cut():
    R = 2.0
    geo = geometry(Circle(center=(0.0, R), radius=R))       # reference: the base, at angle -pi/2
    a = np.linspace(-math.pi / 2 - 3.0, -math.pi / 2 + 3.0, 601)
    psi = np.array([float(geo([R * math.cos(x), R + R * math.sin(x)], 0)[3]) for x in a])
    np.testing.assert_allclose(psi, R * (a + math.pi / 2), atol=1e-12)
    assert float(geo([0.0, 0.0], 0)[0]) == pytest.approx(0.0, abs=1e-15)
    assert float(geo([0.0, 0.5], 0)[0]) == pytest.approx(0.5)           # inside: positive


def test_arc_passes_through_its_point_tangent_to_its_angle():
    arc = Arc(point=(0.2, -0.1), angle=0.9, radius=1.5)
    geo = geometry(arc)
    phi, gphi, _, psi, gpsi, _ = (np.asarray(v).ravel() for v in geo([0.2, -0.1], 0.0))
    assert abs(phi[0]) < 1e-15 and abs(psi[0]) < 1e-15
    np.testing.assert_allclose(gpsi, [math.cos(0.9), math.sin(0.9)], atol=1e-15)


def test_smoothstep_is_c2_between_its_end_values():
    m = Smoothstep(1.0, 3.0, 2.0, 4.0)
    t = ca.SX.sym("t")
    f = ca.Function("f", [t], [m(t), ca.jacobian(m(t), t), ca.jacobian(ca.jacobian(m(t), t), t)])
    for tt, want in [(1.0, 1.0), (2.0, 1.0), (3.0, 2.0), (4.0, 3.0), (9.0, 3.0)]:
        assert float(f(tt)[0]) == pytest.approx(want)
    for tt in (2.0, 4.0):
        assert abs(float(f(tt)[1])) < 1e-12 and abs(float(f(tt)[2])) < 1e-12
    with pytest.raises(ConfigError, match="t1"):
        Smoothstep(0, 1, 2.0, 2.0)


@pytest.mark.parametrize("spec", [0.3, {"kind": "ramp", "start": 1.0, "rate": 0.5},
                                  [0.012, {"kind": "sinusoid", "amplitude": 0.6, "omega": 0.2}],
                                  {"kind": "smoothstep", "start": 0.0, "end": 0.8, "t0": 0.0, "t1": 5.0}])
def test_motion_specs_round_trip_through_data(spec):
    m = motion_from_spec(spec, "x")
    m2 = motion_from_spec(motion_to_spec(m), "x")
    for t in (0.0, 1.3, 7.0):
        assert float(ca.DM(m(ca.DM(t)))) == float(ca.DM(m2(ca.DM(t))))


@pytest.mark.parametrize("spec,match", [
    ("__import__('os')", "x: expected a number"), ({"kind": "exec"}, "x.kind"),
    ({"kind": "sinusoid", "amplitude": 1}, "omega"), ({"kind": "ramp", "rate": float("nan")}, "x.rate"),
    ({"kind": "ramp", "speed": 1}, "unknown key"), ([], "empty list"), (True, "expected a number"),
])
def test_bad_motion_specs_raise_config_errors_naming_the_field(spec, match):
    with pytest.raises(ConfigError, match=match):
        motion_from_spec(spec, "x")


def test_curve_specs_round_trip_and_bad_ones_are_named():
    for spec in ({"kind": "line", "point": [0.0, 0.1], "angle": 0.2},
                 {"kind": "arc", "point": [0.0, 0.0], "angle": 0.1, "radius": 2.0},
                 {"kind": "circle", "center": [0.0, 2.0], "radius": 2.0, "reference": -1.0}):
        assert curve_from_spec(curve_from_spec(spec).to_spec()).to_spec() == curve_from_spec(spec).to_spec()
    with pytest.raises(ConfigError, match="curve.kind"):
        curve_from_spec({"kind": "spline"})
    with pytest.raises(ConfigError, match="curve.point"):
        curve_from_spec({"kind": "line", "point": [0.0], "angle": 0.0})
    with pytest.raises(ConfigError, match="curve.radius"):
        Circle(center=(0, 1), radius=-1.0)
    with pytest.raises(ConfigError, match="curve.angle"):
        Line(angle=float("nan"))
