"""Clothoid transitions (G2 paths): the closed forms vs independent geometry.

* the whole G2 path against a plain-numpy construction from its definition (the G1 heading
  averaged over a window of length L, integrated with a fine trapezoid rule);
* the closest point on a clothoid piece (fixed Newton steps) against a brute-force minimum of the
  distance, the piece's points from scipy's adaptive quadrature;
* gradients and time derivatives by finite differences, curvature continuity from the geometry.
The O(m) law = dense law and compiled = interpreted on G2 paths: tests/test_paths.py (its
``path_through_base`` has default transitions) and tests/test_path_search.py (``-g2`` cases).
"""
import math

import numpy as np
import pytest
from scipy.integrate import quad
from scipy.optimize import brentq

from coordarm import Path, curve_from_spec
from coordarm.symbolic import ConfigError, CoordinatingController, PlanarChain
from coordarm.symbolic.motions import Ramp, Sinusoid
from coordarm.symbolic.transitions import MAX_SPIRAL

START, HEADING = (0.3, -0.2), 0.4
SEGMENTS = [{"line": 0.5}, {"arc": 1.0, "radius": 0.6}, {"arc": -1.5, "radius": 0.45}, {"line": 1.0}]
L = 0.2


def g1_heading_integral(s, heading, segments):
    """``Theta(s) = int_0^s theta_G1`` (rays beyond both ends), piecewise in closed form."""
    s = np.asarray(s, float)
    out = heading * np.minimum(s, 0.0)                  # the ray before the start
    a, th = 0.0, heading
    for seg in segments:
        if "line" in seg:
            length, k = seg["line"], 0.0
        else:
            length, k = abs(seg["arc"]) * seg["radius"], math.copysign(1.0 / seg["radius"], seg["arc"])
        x = np.clip(s - a, 0.0, length)
        out = out + th * x + 0.5 * k * x * x
        a, th = a + length, th + k * length
    return out + th * np.maximum(s - a, 0.0)


def dense_g2(start, heading, segments, window, h=1e-5, ray=0.5):
    """Independent G2 geometry: heading = G1 heading averaged over ``window``; points by the trapezoid rule."""
    total = sum(sg["line"] if "line" in sg else abs(sg["arc"]) * sg["radius"] for sg in segments)
    s = np.arange(-ray, total + ray, h)
    theta = (g1_heading_integral(s + window / 2, heading, segments)
             - g1_heading_integral(s - window / 2, heading, segments)) / window
    T = np.c_[np.cos(theta), np.sin(theta)]
    steps = 0.5 * h * (T[1:] + T[:-1])
    P = np.vstack([[0.0, 0.0], np.cumsum(steps, axis=0)])
    P += np.asarray(start) - P[np.argmin(np.abs(s))] - s[np.argmin(np.abs(s))] * T[0]
    return P, s, T


def dense_from_curvature(start, heading, segments, transitions, h=1e-5, ray=0.5):
    """Independent G2 geometry for any transitions: the curvature (G1 steps, each replaced by a linear
    ramp of its junction's length centred on it) integrated twice with the trapezoid rule.

    Returns points (N, 2), their arc lengths (N,) and unit tangents (N, 2)."""
    ks = [0.0 if "line" in sg else math.copysign(1.0 / sg["radius"], sg["arc"]) for sg in segments]
    ls = [sg["line"] if "line" in sg else abs(sg["arc"]) * sg["radius"] for sg in segments]
    ends = np.cumsum(ls)
    s = np.arange(-ray, ends[-1] + ray, h)
    kappa = np.select([(s >= a) & (s < b) for a, b in zip(np.r_[0.0, ends[:-1]], ends)], ks, 0.0)
    for S, L, k0, k1 in zip(ends[:-1], transitions, ks[:-1], ks[1:]):
        if L > 0:
            on = np.abs(s - S) <= L / 2
            kappa[on] = k0 + (k1 - k0) * (s[on] - (S - L / 2)) / L
    theta = np.r_[0.0, np.cumsum(0.5 * h * (kappa[1:] + kappa[:-1]))]
    theta += heading - np.interp(0.0, s, theta)
    T = np.c_[np.cos(theta), np.sin(theta)]
    P = np.vstack([[0.0, 0.0], np.cumsum(0.5 * h * (T[1:] + T[:-1]), axis=0)])
    P += np.asarray(start) - np.array([np.interp(0.0, s, P[:, 0]), np.interp(0.0, s, P[:, 1])])
    return P, s, T


def test_a_g2_path_with_different_transitions_matches_its_curvature_integrated():
    path = Path(START, HEADING, SEGMENTS[:1] + [dict(SEGMENTS[1], transition=0.1)] + SEGMENTS[2:], transition=0.25)
    assert path.transitions == [0.1, 0.25, 0.25]
    P, S, T = dense_from_curvature(START, HEADING, SEGMENTS, path.transitions)
    f = path.functions()
    idx = np.random.default_rng(5).integers(0, len(S), 60)
    phi, psi = (np.asarray(v).ravel() for v in f.map(len(idx))(P[idx].T, 0.0))
    np.testing.assert_allclose(phi, 0.0, atol=1e-9)
    np.testing.assert_allclose(psi, S[idx], atol=1e-9)


def test_a_g2_path_matches_its_definition_built_independently():
    path = Path(START, HEADING, SEGMENTS, transition=L)
    assert path.transitions == [L, L, L]
    P, S, T = dense_g2(START, HEADING, SEGMENTS, L)
    f = path.functions()
    rng = np.random.default_rng(0)
    idx = rng.integers(0, len(S), 80)
    off = rng.uniform(-0.2, 0.2, 80)
    pts = P[idx] + off[:, None] * np.c_[-T[idx, 1], T[idx, 0]]
    phi, psi = (np.asarray(v).ravel() for v in f.map(len(pts))(pts.T, 0.0))
    np.testing.assert_allclose(phi, off, atol=1e-9)       # trapezoid rule, h = 1e-5: ~1e-10
    np.testing.assert_allclose(psi, S[idx], atol=1e-9)
    # the end: same total length and turning as the G1 path, the end point moved by the transitions only
    d = path.pieces[-1].d0
    assert path.pieces[-1].s0 == pytest.approx(path.length - 1.0 + L / 2, abs=1e-12)
    assert math.atan2(d[1], d[0]) == pytest.approx(HEADING + 1.0 - 1.5, abs=1e-14)


def brute_force_on_piece(pc, p):
    """Closest point of the clothoid piece to p: the nearest of 81 samples brackets the foot of the
    normal, ``t(x) . (p - q(x)) = 0``, solved by bisection (brentq); points by scipy's adaptive quad."""
    def point(x):
        th = lambda v: pc.k * v + 0.5 * pc.c * v * v  # noqa: E731
        X = quad(lambda v: math.cos(th(v)), 0.0, x, epsabs=1e-17, epsrel=1e-15)[0]
        Y = quad(lambda v: math.sin(th(v)), 0.0, x, epsabs=1e-17, epsrel=1e-15)[0]
        a = th(x)
        return pc.p0 + X * pc.d0 + Y * pc.n0, pc.d0 * math.cos(a) + pc.n0 * math.sin(a)

    def foot(x):
        q, t = point(x)
        return float(t @ (p - q))
    xs = np.linspace(-0.2, 1.2, 81) * pc.length
    k = int(np.argmin([np.sum((point(x)[0] - p) ** 2) for x in xs]))
    x = brentq(foot, xs[max(k - 1, 0)], xs[min(k + 1, 80)], xtol=1e-16, rtol=1e-15)
    q, t = point(x)
    return float(t[0] * (p - q)[1] - t[1] * (p - q)[0]), pc.s0 + x


@pytest.mark.filterwarnings("ignore::scipy.integrate.IntegrationWarning")   # quad at its rounding floor
@pytest.mark.parametrize("spec", [dict(kind="path", start=list(START), heading=HEADING, segments=SEGMENTS,
                                       transition=0.3),
                                  dict(kind="waypoints", points=[[-0.5, 0.0], [4.5, 0.0], [5.5, 0.5], [9.0, 0.5]],
                                       radius=2.0)], ids=["path", "thread-waypoints"])
def test_newton_closest_point_on_every_clothoid_converges_to_1e13(spec):
    path = curve_from_spec(spec)
    f = path.functions()
    spirals = [pc for pc in path.pieces if pc.c != 0]
    assert spirals and all(abs(pc.k * pc.length + 0.5 * pc.c * pc.length ** 2) <= MAX_SPIRAL + 1e-12
                           for pc in spirals)
    rng = np.random.default_rng(1)
    worst = 0.0
    for pc in spirals:
        band = 0.25 / max(abs(pc.k), abs(pc.k + pc.c * pc.length))   # a quarter of the tube there
        for _ in range(4):
            x = rng.uniform(0.02, 0.98) * pc.length
            q, t = pc.point(x)
            p = q + rng.uniform(-band, band) * np.array([-t[1], t[0]])
            ref = brute_force_on_piece(pc, p)
            got = [float(v) for v in f(path.to_world(p[None], 0.0)[0], 0.0)]
            worst = max(worst, abs(got[0] - ref[0]), abs(got[1] - ref[1]))
    assert worst < 1e-13


def test_curvature_is_continuous_and_linear_on_the_transitions():
    path = Path(START, HEADING, SEGMENTS, transition=L)
    h = 1e-4
    s = np.arange(0.01, path.length - 0.01, h)
    pts = np.array([path.point_at(v) for v in s])
    d1 = np.gradient(pts, h, axis=0)
    heading = np.unwrap(np.arctan2(d1[:, 1], d1[:, 0]))
    kappa = np.gradient(heading, h)[2:-2]                # from the geometry alone
    ends = np.array([pc.s0 for pc in path.pieces[1:]])
    away = np.min(np.abs(s[2:-2, None] - ends[None]), axis=1) > 3 * h    # differences across a kink of kappa: O(h)
    np.testing.assert_allclose(kappa[away], path.curvature_at(s)[2:-2][away], atol=1e-6)
    rate = max(abs(pc.c) for pc in path.pieces)          # (1/0.45 + 1/0.6) / L at the S junction
    assert np.max(np.abs(np.diff(kappa))) < 1.05 * rate * h  # no jump: one step of the ramp at most
    g1 = Path(START, HEADING, SEGMENTS, transition=0)
    assert np.max(np.abs(np.diff(g1.curvature_at(s)))) > 3.5  # the G1 path jumps by 1/0.6 + 1/0.45


def test_gradients_and_time_derivatives_on_transitions_match_finite_differences():
    moving = Path(START, HEADING, SEGMENTS, transition=L, offset=(Sinusoid(0.2, 0.7), Ramp(0.0, 0.05)),
                  rotation=Sinusoid(0.3, 0.5))
    geo = CoordinatingController(PlanarChain(3, 0.1), moving, 1.0, 0.0).task.geometry
    f = moving.functions()
    rng = np.random.default_rng(2)
    checked = 0
    for pc in (pc for pc in moving.pieces if pc.c != 0):
        q, t_ = pc.point(rng.uniform(0.1, 0.9) * pc.length)
        p = q + rng.uniform(-0.1, 0.1) * np.array([-t_[1], t_[0]])
        for t in (0.0, 1.3):
            y = moving.to_world(p[None], t)[0]
            phi, gphi, phit, psi, gpsi, psit = (np.asarray(v).ravel() for v in geo(y, t))
            h = 1e-6
            for k in range(2):
                e = np.eye(2)[k] * h
                plus, minus = f(y + e, t), f(y - e, t)
                assert gphi[k] == pytest.approx((float(plus[0]) - float(minus[0])) / (2 * h), abs=1e-8)
                assert gpsi[k] == pytest.approx((float(plus[1]) - float(minus[1])) / (2 * h), abs=1e-8)
            plus, minus = f(y, t + h), f(y, t - h)
            assert phit[0] == pytest.approx((float(plus[0]) - float(minus[0])) / (2 * h), abs=1e-8)
            assert psit[0] == pytest.approx((float(plus[1]) - float(minus[1])) / (2 * h), abs=1e-8)
            assert np.linalg.norm(gphi) == pytest.approx(1.0, abs=1e-14)     # a distance's gradient
            checked += 1
    assert checked >= 8


def test_default_transitions_fit_the_segments_and_zero_is_the_g1_path():
    pipe = [{"line": 2.2}, {"arc": -0.5, "radius": 1.5}, {"line": 0.4}, {"arc": 0.5, "radius": 1.5}, {"line": 0.45}]
    assert Path((0, 0), 0, pipe).transitions == [0.375] * 4                  # R/4, fits the 0.4 m line
    thread = Path.from_waypoints([[-0.5, 0.0], [4.5, 0.0], [5.5, 0.5], [9.0, 0.5]], 2.0)
    middle = thread.segments[2][1]                                           # the short line between the fillets
    assert thread.transitions == pytest.approx([0.5, middle, middle, 0.5])
    g1 = Path((0, 0), 0, pipe, transition=0)
    assert all(pc.c == 0 for pc in g1.pieces) and len(g1.pieces) == 5
    own = Path((0, 0), 0, [pipe[0], dict(pipe[1], transition=0.1)] + pipe[2:], transition=0)
    assert own.transitions == [0.1, 0.0, 0.0, 0.0]
    assert curve_from_spec(own.to_spec()).to_spec() == own.to_spec()
    assert curve_from_spec(thread.to_spec()).transitions == thread.transitions


@pytest.mark.parametrize("spec, match", [
    (dict(transition=-0.1), r"curve.transition: need a length >= 0"),
    (dict(transition=True), r"curve.transition: need a length >= 0"),
    (dict(transition=1.0), r"curve.segments\[1\]: 0.75 m is too short for its transitions"),
    (dict(segments=[{"line": 1.0, "transition": 0.1}, {"arc": 1.0, "radius": 1.0}]),
     r"curve.segments\[0\].transition: the first segment has no junction"),
    (dict(segments=[{"line": 1.0}, {"arc": 1.0, "radius": 1.0, "transition": "x"}]),
     r"curve.segments\[1\].transition: need a length")])
def test_bad_transitions_are_refused_naming_the_field(spec, match):
    base = {"kind": "path", "start": [0, 0], "heading": 0,
            "segments": [{"line": 2.2}, {"arc": -0.5, "radius": 1.5}, {"line": 0.4}]}
    with pytest.raises(ConfigError, match=match):
        curve_from_spec({**base, **spec})
