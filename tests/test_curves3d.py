"""Spatial curves (Line3D, Circle3D/Arc3D): AD vs finite differences, a brute-force closest point,
the Jacobian on the curve = the frame, the planar curves as a special case, the scenario tables."""
import math
import tomllib

import casadi as ca
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from coordarm.symbolic import Circle, ConfigError, Line, Sinusoid
from coordarm.symbolic.curve3d_specs import curve3d_from_spec
from coordarm.symbolic.curves3d import Arc3D, Circle3D, Line3D

AXIS = np.array([0.3, -0.4, 0.8]) / np.linalg.norm([0.3, -0.4, 0.8])


def moving_line():
    return Line3D(point=(lambda t: 0.1 * ca.sin(t), 0.05, lambda t: 0.2 * ca.cos(0.5 * t)),
                  direction=(1.0, 0.2, -0.1), normal=(0.0, 1.0, 0.3), rotation=(AXIS, Sinusoid(0.6, 0.2, 0.1)))


def moving_circle():
    return Circle3D(centre=(lambda t: 0.3 + 0.1 * ca.cos(t), 1.5, lambda t: 0.1 * ca.sin(t)),
                    radius=lambda t: 1.6 + 0.2 * ca.sin(t), normal=(0.2, -0.3, 1.0))


CURVES = {"line": moving_line, "circle": moving_circle}


def outputs(curve):
    """Numeric (psi, Phi, frame) and their AD Jacobians in y and t."""
    y, t = ca.SX.sym("y", 3), ca.SX.sym("t")
    psi, Phi, frame = curve.coordinates(y, t)
    out = ca.vertcat(psi, Phi)
    return ca.Function("f", [y, t], [out, ca.jacobian(out, y), ca.jacobian(out, t), ca.horzcat(*frame)])


def evaluate(f, y, t):
    return [np.asarray(v) for v in f(y, t)]


# --- independent numeric references -------------------------------------------------------------------

def line_reference(t):
    """Point, tangent, n1, n2 of moving_line() at time t, by scipy's rotation (not Rodrigues in the code)."""
    d = np.array([1.0, 0.2, -0.1]) / np.linalg.norm([1.0, 0.2, -0.1])
    n = np.array([0.0, 1.0, 0.3])
    n1 = n - (n @ d) * d
    n1 /= np.linalg.norm(n1)
    rot = Rotation.from_rotvec(AXIS * (0.1 + 0.6 * math.sin(0.2 * t)))
    p = np.array([0.1 * math.sin(t), 0.05, 0.2 * math.cos(0.5 * t)])
    tan, n1 = rot.apply(d), rot.apply(n1)
    return p, tan, n1, np.cross(tan, n1)


def circle_reference(t, n=200001):
    """Dense points of moving_circle() at time t with their angle about the normal from the reference."""
    w = np.array([0.2, -0.3, 1.0]) / np.linalg.norm([0.2, -0.3, 1.0])
    c = np.array([0.3 + 0.1 * math.cos(t), 1.5, 0.1 * math.sin(t)])
    R = 1.6 + 0.2 * math.sin(t)
    c0 = np.array([0.4, 1.5, 0.0])
    e1 = -c0 - (-c0 @ w) * w                      # towards the base from the centre at t = 0
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(w, e1)
    a = np.linspace(-math.pi, math.pi, n)
    return c + R * (np.cos(a)[:, None] * e1 + np.sin(a)[:, None] * e2), R * a, w


# --- tests ---------------------------------------------------------------------------------------------

@pytest.mark.parametrize("name", sorted(CURVES))
def test_ad_derivatives_equal_finite_differences(name, rng):
    f = outputs(CURVES[name]())
    h = 1e-6
    for _ in range(5):
        y, t = rng.normal(size=3) * 0.7 + [0.5, 0.3, 0.2], rng.uniform(-3, 3)
        _, Jy, Jt, _ = evaluate(f, y, t)
        fd_y = np.column_stack([(evaluate(f, y + h * e, t)[0] - evaluate(f, y - h * e, t)[0]).ravel() / (2 * h)
                                for e in np.eye(3)])
        fd_t = (evaluate(f, y, t + h)[0] - evaluate(f, y, t - h)[0]).ravel() / (2 * h)
        np.testing.assert_allclose(Jy, fd_y, atol=1e-7)
        np.testing.assert_allclose(Jt.ravel(), fd_t, atol=1e-7)


@settings(max_examples=30)
@given(t=st.floats(-4, 4), s=st.floats(-2, 2), x1=st.floats(-0.5, 0.5), x2=st.floats(-0.5, 0.5))
def test_line_psi_phi_are_the_coordinates_of_the_closest_point(t, s, x1, x2):
    p, tan, n1, n2 = line_reference(t)
    y = p + s * tan + x1 * n1 + x2 * n2
    out, _, _, frame = evaluate(outputs(moving_line()), y, t)
    np.testing.assert_allclose(out.ravel(), [s, x1, x2], atol=1e-12)
    np.testing.assert_allclose(frame, np.column_stack([tan, n1, n2]), atol=1e-12)


def test_circle_psi_phi_against_a_brute_force_closest_point(rng):
    f = outputs(moving_circle())
    for _ in range(8):
        t = rng.uniform(-3, 3)
        pts, arc, w = circle_reference(t)
        k = rng.integers(len(pts))
        y = pts[k] + rng.normal(size=3) * 0.3
        i = np.argmin(np.linalg.norm(pts - y, axis=1))
        out, _, _, frame = evaluate(f, y, t)
        tan, n1, n2 = frame.T
        assert out[0, 0] == pytest.approx(arc[i], abs=1e-4)
        np.testing.assert_allclose(out[1:, 0], [n1 @ (y - pts[i]), n2 @ (y - pts[i])], atol=1e-8)
        np.testing.assert_allclose(pts[i] + out[1, 0] * n1 + out[2, 0] * n2, y, atol=1e-4)
        np.testing.assert_allclose(n2, w, atol=1e-12)     # the circle's normal


@pytest.mark.parametrize("name", sorted(CURVES))
def test_on_the_curve_the_jacobian_is_the_frame_orthonormal_and_right_handed(name, rng):
    curve = CURVES[name]()
    f = outputs(curve)
    for _ in range(6):
        t = rng.uniform(-3, 3)
        y = curve.sample(t, n=101, extent=2.0)[rng.integers(101)]
        out, Jy, _, frame = evaluate(f, y, t)
        np.testing.assert_allclose(out[1:, 0], 0.0, atol=1e-12)
        np.testing.assert_allclose(Jy, frame.T, atol=1e-9)
        np.testing.assert_allclose(Jy @ Jy.T, np.eye(3), atol=1e-9)
        assert np.linalg.det(frame) == pytest.approx(1.0, abs=1e-9)


def test_circle_psi_turns_counter_clockwise_about_the_normal_and_has_period_2_pi_r():
    curve = Arc3D(centre=(0.0, 2.0, 0.0), radius=1.0, normal=(0.0, 0.0, 1.0))
    f = outputs(curve)
    assert float(curve.period(0.0)) == pytest.approx(2 * math.pi)
    start = evaluate(f, [0.0, 1.0, 0.0], 0.0)[0].ravel()      # the reference: towards the base
    quarter = evaluate(f, [1.0, 2.0, 0.0], 0.0)[0].ravel()
    np.testing.assert_allclose(start, [0.0, 0.0, 0.0], atol=1e-12)
    np.testing.assert_allclose(quarter, [math.pi / 2, 0.0, 0.0], atol=1e-12)


@settings(max_examples=30)
@given(t=st.floats(-4, 4), y=st.lists(st.floats(-2, 2), min_size=3, max_size=3))
def test_planar_line_and_circle_stated_in_3d_give_the_planar_phi_psi_and_z(t, y):
    angle = Sinusoid(0.6, 0.2, 0.3)
    point = (lambda tt: 0.1 * ca.sin(tt), 0.05)
    planar = Line(point=point, angle=angle)
    spatial = Line3D(point=(*point, 0.0), direction=(1.0, 0.0, 0.0), normal=(0.0, 1.0, 0.0),
                     rotation=((0.0, 0.0, 1.0), angle))
    centre, radius = (lambda tt: 0.3 + 0.1 * ca.cos(tt), 1.5), (lambda tt: 1.6 + 0.2 * ca.sin(tt))
    pairs = [(planar, spatial), (Circle(centre, radius), Circle3D((*centre, 0.0), radius, (0.0, 0.0, 5.0)))]
    for flat, space in pairs:
        phi, psi = (float(v) for v in flat.functions()(y[:2], t))
        out = evaluate(outputs(space), y, t)[0].ravel()
        np.testing.assert_allclose(out, [psi, phi, y[2]], atol=1e-12)


def test_the_issue_line_table_builds_the_moving_line():
    spec = tomllib.loads("""
kind = "line"
point = [0.0, 0.0, 0.0]
direction = [1.0, 0.0, 0.0]
normal = [0.0, 1.0, 0.0]
rotation = { axis = [0.0, 0.0, 1.0], angle = [0.012, { kind = "sinusoid", amplitude = 0.6, omega = 0.2 }] }
""")
    f = outputs(curve3d_from_spec(spec))
    for t in (0.0, 1.3, 7.0):
        th = 0.012 + 0.6 * math.sin(0.2 * t)
        y = np.array([0.4, -0.3, 0.25])
        expected = [math.cos(th) * y[0] + math.sin(th) * y[1], -math.sin(th) * y[0] + math.cos(th) * y[1], y[2]]
        np.testing.assert_allclose(evaluate(f, y, t)[0].ravel(), expected, atol=1e-12)


def test_circle_and_arc_tables():
    for kind, cls in (("circle", Circle3D), ("arc", Arc3D)):
        curve = curve3d_from_spec({"kind": kind, "centre": [1.0, 0.0, {"kind": "ramp", "rate": 0.1}],
                                   "radius": 2.0, "normal": [0.0, 0.0, 1.0]})
        assert type(curve) is cls
        out = evaluate(outputs(curve), [1.0, 1.5, 1.0], 10.0)[0].ravel()   # centre (1, 0, 1) at t = 10
        np.testing.assert_allclose(out[1:], [0.5, 0.0], atol=1e-12)


@pytest.mark.parametrize("spec, message", [
    ({"kind": "line", "point": [0, 0], "direction": [1, 0, 0], "normal": [0, 1, 0]}, "curve.point: expected three"),
    ({"kind": "line", "point": [0, 0, 0], "direction": [0, 0, 0], "normal": [0, 1, 0]}, "curve.direction: "),
    ({"kind": "line", "point": [0, 0, 0], "direction": [1, 0, 0], "normal": [2, 0, 0]}, "curve.normal: must not be "),
    ({"kind": "line", "point": [0, 0, 0], "direction": [1, 0, 0], "normal": [0, 1, 0],
      "rotation": {"axis": [0, 0, 1]}}, "curve.rotation: expected"),
    ({"kind": "line", "point": [0, 0, 0], "direction": [1, 0, 0]}, "curve.normal: missing"),
    ({"kind": "circle", "centre": [0, 0, 0], "radius": -1.0, "normal": [0, 0, 1]}, "curve.radius: must be > 0"),
    ({"kind": "arc", "centre": [0, 0, 0], "radius": 1.0, "normal": [0, 0, 1], "angle": 1}, "unknown key(s) ['angle']"),
    ({"kind": "helix"}, "curve.kind: expected one of"),
])
def test_bad_tables_name_the_field(spec, message):
    with pytest.raises(ConfigError, match=None) as err:
        curve3d_from_spec(spec)
    assert message in str(err.value)


def test_to_spec_round_trips_and_numbers_mx_and_sx_points_give_the_same_values():
    line = curve3d_from_spec({"kind": "line", "point": [0.1, {"kind": "ramp", "rate": 0.2}, 0.0],
                              "direction": [1.0, 1.0, 0.0], "normal": [0.0, 0.0, 1.0],
                              "rotation": {"axis": [0.0, 1.0, 0.0], "angle": {"kind": "ramp", "rate": 0.3}}})
    circle = curve3d_from_spec({"kind": "arc", "centre": [1.0, 0.0, 0.5], "radius": 2.0, "normal": [1.0, 0.0, 1.0]})
    y, t = np.array([0.4, -0.7, 1.1]), 2.5
    for curve in (line, circle):
        expected = evaluate(outputs(curve), y, t)[0].ravel()
        np.testing.assert_allclose(evaluate(outputs(curve3d_from_spec(curve.to_spec())), y, t)[0].ravel(),
                                   expected, atol=1e-14)
        ym, tm = ca.MX.sym("y", 3), ca.MX.sym("t")
        fm = ca.Function("fm", [ym, tm], [ca.vertcat(curve.psi(ym, tm), curve.Phi(ym, tm))])
        np.testing.assert_allclose(np.asarray(fm(y, t)).ravel(), expected, atol=1e-14)
        numeric = ca.vertcat(curve.psi(y, t), curve.Phi(y.tolist(), t))
        np.testing.assert_allclose(np.asarray(ca.evalf(numeric)).ravel(), expected, atol=1e-14)


def test_unwrap_s_makes_psi_continuous_around_a_circle_in_3d():
    from coordarm.symbolic.curves import unwrap_s
    curve = Circle3D(centre=(0.5, 0.0, 0.2), radius=0.8, normal=(0.0, 1.0, 1.0))
    f = outputs(curve)
    angles = np.linspace(0, 4 * math.pi, 301)                 # two turns, crossing the branch cut
    s = np.array([evaluate(f, curve.point_at(0.8 * a), 0.0)[0][0, 0] for a in angles])
    assert np.max(np.abs(np.diff(s))) > 4.0                    # psi jumps by 2 pi R at the cut
    np.testing.assert_allclose(unwrap_s(curve, np.zeros_like(s), s), 0.8 * angles, atol=1e-9)


def test_points_at_many_times_are_point_at_pair_by_pair_bit_for_bit():
    """A line does it at once (its motions on a row of times); a circle and a path pair by pair."""
    from coordarm.symbolic.paths3d import Path3D
    t = np.linspace(0.0, 12.0, 97)
    s = np.linspace(-1.0, 2.5, 97)
    still = Line3D(point=(0.1, -0.2, 0.3), direction=(0.0, 1.0, 1.0), normal=(1.0, 0.0, 0.0))
    scalar_only = Line3D(point=(lambda t: 0.1 * float(t), 0.0, 0.0), rotation=((0, 0, 1), lambda t: 0.2 * float(t)))
    path = Path3D((0, 0, 0), (1, 0, 0), (0, 1, 0), [("line", 0.3), ("arc", 1.5, 0.4, 1.2)])
    for curve in (moving_line(), still, scalar_only, moving_circle(), path):
        got = curve.points_at(s, t)
        assert got.shape == (len(t), 3)
        np.testing.assert_array_equal(got, [curve.point_at(a, b) for a, b in zip(s, t)])
    p, tan, _, _ = line_reference(3.0)                   # and against scipy's rotation
    np.testing.assert_allclose(moving_line().points_at([0.7], [3.0])[0], p + 0.7 * tan, rtol=0, atol=1e-15)


def test_evaluate_many_is_evaluate_at_each_time_for_every_motion():
    from coordarm.symbolic.motions import Constant, Ramp, Smoothstep, Sum
    from coordarm.symbolic.params import evaluate, evaluate_many
    t = np.linspace(-1.0, 6.0, 141)
    motions = [Constant(0.3), Ramp(0.1, -0.05), Sinusoid(0.6, 0.2, 0.1, 0.4), Smoothstep(0.0, 2.0, 1.0, 4.0),
               Sum((Smoothstep(0.0, 1.0, 0.5, 2.0), Sinusoid(0.1, 3.0))), lambda t: 0.25,
               lambda t: math.exp(float(t)) / 100]                 # a callable of one number: time by time
    for m in motions:
        np.testing.assert_array_equal(evaluate_many(m, t), [evaluate(m, x) for x in t])
