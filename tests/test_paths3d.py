"""3-D paths of lines and banked arcs, and 3-D waypoints: against an independent integration of the
path (tangent and a twist-free normal frame by RK4), a brute-force closest point, finite differences,
and the planar paths as a special case."""
import math

import casadi as ca
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from coordarm.symbolic import ConfigError, Path
from coordarm.symbolic.curve3d_specs import curve3d_from_spec
from coordarm.symbolic.paths3d import Path3D, piece_constants, piece_formulas3d

START, DIRECTION, NORMAL = np.array([0.1, -0.2, 0.3]), np.array([1.0, 0.3, 0.2]), np.array([0.0, 0.0, 1.0])
#: A corkscrew: arcs whose turns lie in different planes (banks), one split in two pieces (2.5 rad).
CORKSCREW = [("line", 0.5), ("arc", 1.2, 1.0, 0.0), ("arc", 1.0, 0.8, 1.2), ("line", 0.3),
             ("arc", 2.5, 1.2, -2.0), ("arc", 0.9, 1.0, math.pi / 2), ("line", 0.4)]


def corkscrew(transition=0.0):
    """The corkscrew: G1 (``transition = 0``, what :func:`integrate` walks) or with transitions."""
    return Path3D(START, DIRECTION, NORMAL, CORKSCREW, transition)


def integrate(start, direction, normal, segments, h=2e-4):
    """Dense (s, x, T, N1, N2) of the path by RK4 of x' = T, T' = k1 N1 + k2 N2, N1' = -k1 T, N2' = -k2 T
    (the twist-free frame; an arc is k = 1/R towards cos(bank) N1 + sin(bank) N2)."""
    T = direction / np.linalg.norm(direction)
    N1 = normal - (normal @ T) * T
    N1 /= np.linalg.norm(N1)
    state = np.r_[start, T, N1, np.cross(T, N1)]
    out, s = [(0.0, state.copy())], 0.0
    for seg in segments:
        length, k1, k2 = (seg[1], 0.0, 0.0) if seg[0] == "line" else (
            seg[1] * seg[2], math.cos(seg[3]) / seg[2], math.sin(seg[3]) / seg[2])

        def rhs(z):
            return np.r_[z[3:6], k1 * z[6:9] + k2 * z[9:12], -k1 * z[3:6], -k2 * z[3:6]]
        n = max(1, math.ceil(length / h))
        dh = length / n
        for _ in range(n):
            a = rhs(state)
            b = rhs(state + dh / 2 * a)
            c = rhs(state + dh / 2 * b)
            d = rhs(state + dh * c)
            state = state + dh / 6 * (a + 2 * b + 2 * c + d)
            s += dh
            out.append((s, state.copy()))
    ss = np.array([o[0] for o in out])
    z = np.array([o[1] for o in out])
    return ss, z[:, 0:3], z[:, 3:6], z[:, 6:9], z[:, 9:12]


@pytest.fixture(scope="module")
def reference():
    return integrate(START, DIRECTION, NORMAL, CORKSCREW)


def outputs(curve):
    y, t = ca.SX.sym("y", 3), ca.SX.sym("t")
    psi, Phi, frame = curve.coordinates(y, t)
    out = ca.vertcat(psi, Phi)
    return ca.Function("f", [y, t], [out, ca.jacobian(out, y), ca.jacobian(out, t), ca.horzcat(*frame)])


def evaluate(f, y, t=0.0):
    return [np.asarray(v) for v in f(y, t)]


def test_the_corkscrew_passes_its_points_with_its_transported_frame(reference):
    path, f = corkscrew(), outputs(corkscrew())
    ss, x, T, N1, N2 = reference
    assert path.length == pytest.approx(ss[-1], abs=1e-9)
    for i in np.linspace(0, len(ss) - 1, 40).astype(int):
        np.testing.assert_allclose(path.point_at(ss[i]), x[i], atol=1e-9)
        out, _, _, frame = evaluate(f, x[i])
        np.testing.assert_allclose(out.ravel(), [ss[i], 0.0, 0.0], atol=1e-9)
        np.testing.assert_allclose(frame, np.column_stack([T[i], N1[i], N2[i]]), atol=1e-9)


def test_psi_phi_against_a_brute_force_closest_point(reference, rng):
    f = outputs(corkscrew())
    ss, x, T, N1, N2 = reference
    for _ in range(30):
        k = rng.integers(len(ss))
        y = x[k] + rng.uniform(-0.5, 0.5) * N1[k] + rng.uniform(-0.5, 0.5) * N2[k]   # in the tube (min R 0.8)
        i = np.argmin(np.linalg.norm(x - y, axis=1))
        out = evaluate(f, y)[0].ravel()
        offset = y - x[i]
        assert out[0] == pytest.approx(ss[i] + T[i] @ offset, abs=1e-6)
        np.testing.assert_allclose(out[1:], [N1[i] @ offset, N2[i] @ offset], atol=5e-5)


def test_beyond_the_ends_the_path_continues_as_rays(reference):
    f = outputs(corkscrew())
    ss, x, T, N1, N2 = reference
    for s, k, sign in ((-0.7, 0, -1), (ss[-1] + 0.9, -1, 1)):
        y = x[k] + sign * abs(s - ss[k]) * T[k] + 0.3 * N1[k] - 0.2 * N2[k]
        np.testing.assert_allclose(evaluate(f, y)[0].ravel(), [s, 0.3, -0.2], atol=1e-9)


def test_ad_derivatives_equal_finite_differences(reference, rng):
    f = outputs(corkscrew())
    ss, x, T, N1, N2 = reference
    h = 1e-6
    for _ in range(10):
        k = rng.integers(len(ss))
        y = x[k] + rng.uniform(-0.5, 0.5) * N1[k] + rng.uniform(-0.5, 0.5) * N2[k]
        _, Jy, Jt, _ = evaluate(f, y, 0.7)
        fd = np.column_stack([(evaluate(f, y + h * e)[0] - evaluate(f, y - h * e)[0]).ravel() / (2 * h)
                              for e in np.eye(3)])
        np.testing.assert_allclose(Jy, fd, atol=1e-7)
        np.testing.assert_allclose(Jt, 0.0, atol=0)          # the path does not move


def test_on_the_path_the_jacobian_is_the_frame_orthonormal_and_right_handed(reference):
    f = outputs(corkscrew())
    ss, x, *_ = reference
    for i in np.linspace(0, len(ss) - 1, 25).astype(int):
        _, Jy, _, frame = evaluate(f, x[i])
        np.testing.assert_allclose(Jy, frame.T, atol=1e-9)
        np.testing.assert_allclose(frame.T @ frame, np.eye(3), atol=1e-12)
        assert np.linalg.det(frame) == pytest.approx(1.0, abs=1e-12)


def test_the_frame_does_not_twist_along_the_path(reference):
    """``n_1' . n_2 = 0`` by finite differences of the symbolic frame along the arc length (and
    ``n_1' . t = -k_1``: the derivative is not zero, the frame turns with the curve)."""
    path, f = corkscrew(), outputs(corkscrew())
    ds = 1e-5
    for s in np.linspace(0.05, path.length - 0.05, 60):
        n1 = [evaluate(f, path.point_at(s + e))[3][:, 1] for e in (-ds, ds)]
        tan, _, n2 = evaluate(f, path.point_at(s))[3].T
        dn1 = (n1[1] - n1[0]) / (2 * ds)
        assert abs(dn1 @ n2) < 1e-8
        piece = path.piece_at(s)
        k1 = math.cos(piece.bank) / piece.radius if piece.radius else 0.0
        assert dn1 @ tan == pytest.approx(-k1, abs=1e-6)


def test_psi_phi_are_continuous_across_the_junctions_inside_the_tube(reference):
    path = corkscrew()
    ss, x, T, N1, N2 = reference
    inner = path.pieces
    for before, after in zip(inner[:-1], inner[1:]):
        k = np.argmin(abs(ss - after.s0))
        for o1, o2 in ((0.3, -0.2), (-0.6, 0.1), (0.0, 0.7)):
            y = ca.DM(x[k] + o1 * N1[k] + o2 * N2[k])
            a = [np.asarray(ca.vertcat(v[0], v[1], *v[2])).ravel()
                 for v in (piece_formulas3d(ca.DM(piece_constants(pc)), y) for pc in (before, after))]
            np.testing.assert_allclose(a[0], a[1], atol=1e-9)
            np.testing.assert_allclose(a[0][:3], [after.s0, o1, o2], atol=1e-6)


def planar_to_3d(segments):
    """Planar segments (+ = left) as 3-D ones in the xy plane with n_1 = the left normal (right: bank pi)."""
    return [("line", s[1]) if s[0] == "line" else ("arc", abs(s[1]), s[2], 0.0 if s[1] > 0 else math.pi)
            for s in segments]


def assert_planar_equal(flat, space, rng, tube):
    pts = flat.sample(0.0, n=200, extent=5.0)
    g, f = flat.functions(), outputs(space)
    for _ in range(30):
        p = pts[rng.integers(len(pts))] + rng.uniform(-tube, tube, size=2) / math.sqrt(2)
        z = rng.uniform(-1, 1)
        phi, psi = (float(v) for v in g(p, 0.0))
        np.testing.assert_allclose(evaluate(f, [p[0], p[1], z])[0].ravel(), [psi, phi, z], atol=1e-11)


def test_a_planar_path_stated_in_3d_gives_the_planar_phi_psi_and_z(rng):
    segments = [("line", 0.6), ("arc", 1.1, 0.9), ("arc", -2.4, 1.2), ("line", 0.3), ("arc", -0.7, 0.8)]
    h = 0.4
    flat = Path((0.2, -0.1), h, segments)
    space = Path3D((0.2, -0.1, 0.0), (math.cos(h), math.sin(h), 0.0), (-math.sin(h), math.cos(h), 0.0),
                   planar_to_3d(segments))
    assert_planar_equal(flat, space, rng, 0.7)


def test_planar_waypoints_in_3d_reproduce_the_planar_waypoints(rng):
    pts = [[0.0, 0.0], [1.0, 0.2], [1.6, 1.2], [0.8, 1.9], [1.2, 3.0]]
    flat = Path.from_waypoints(pts, 0.3)
    space = Path3D.from_waypoints([[*p, 0.0] for p in pts], 0.3)
    assert_planar_equal(flat, space, rng, 0.25)


def test_waypoints_in_3d_fillet_each_corner_in_the_plane_of_its_legs():
    P = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.5, 1.0, 0.5], [1.5, 1.5, 1.8], [0.5, 2.0, 2.0]])
    r = 0.25
    path = curve3d_from_spec({"kind": "waypoints", "points": P.tolist(), "radius": r, "transition": 0})
    f = outputs(path)
    ends = [evaluate(f, P[0])[0].ravel(), evaluate(f, P[-1])[0].ravel()]
    np.testing.assert_allclose(ends, [[0, 0, 0], [path.length, 0, 0]], atol=1e-12)
    for k in range(1, len(P) - 1):
        a, b = P[k] - P[k - 1], P[k + 1] - P[k]
        turn = math.acos(a @ b / np.linalg.norm(a) / np.linalg.norm(b))
        out = evaluate(f, P[k])[0].ravel()        # the corner lies r (1/cos(turn/2) - 1) from the fillet
        assert np.hypot(out[1], out[2]) == pytest.approx(r * (1 / math.cos(turn / 2) - 1), abs=1e-12)
        for leg in (P[k - 1] + 0.5 * a, P[k] + 0.5 * b):        # the legs' middles lie on the path
            np.testing.assert_allclose(evaluate(f, leg)[0].ravel()[1:], 0.0, atol=1e-12)
    normals = [np.cross(P[k] - P[k - 1], P[k + 1] - P[k]) for k in range(1, len(P) - 1)]
    arcs = [pc for pc in path.pieces if pc.radius > 0]
    assert len(arcs) == len(normals)
    for arc, n in zip(arcs, normals):
        for x in np.linspace(0, arc.length, 7):              # each fillet in the plane of its corner's legs
            assert abs((arc.point_at(x) - arc.p0) @ n) < 1e-12


@settings(max_examples=15)
@given(st.lists(st.tuples(st.floats(0.1, 2.0), st.floats(0.5, 1.5), st.floats(-math.pi, math.pi),
                          st.floats(0.0, 0.6)), min_size=1, max_size=4))
def test_random_banked_paths_match_the_integrated_path_and_have_the_frame_as_jacobian(arcs):
    segments = []
    for angle, radius, bank, line in arcs:
        segments += [("arc", angle, radius, bank)] + ([("line", line)] if line > 0.05 else [])
    path = Path3D(START, DIRECTION, NORMAL, segments, transition=0)
    ss, x, T, N1, N2 = integrate(START, DIRECTION, NORMAL, segments, h=2e-3)
    f = outputs(path)
    reach = np.linspace(0.0, 20.0, 2001)[1:, None]                   # the extensions, 20 m each way
    curve_s = np.concatenate([ss[0] - reach[::-1, 0], ss, ss[-1] + reach[:, 0]])
    curve_x = np.concatenate([x[0] - reach[::-1] * T[0], x, x[-1] + reach * T[-1]])
    for i in np.linspace(0, len(ss) - 1, 8).astype(int):
        y = x[i] + 0.2 * N1[i] - 0.3 * N2[i]
        out, Jy, _, frame = evaluate(f, x[i])
        np.testing.assert_allclose(out.ravel(), [ss[i], 0, 0], atol=1e-8)
        np.testing.assert_allclose(frame, np.column_stack([T[i], N1[i], N2[i]]), atol=1e-8)
        np.testing.assert_allclose(Jy, frame.T, atol=1e-9)
        # y's closest point is x[i] only if no other part of the curve comes nearer: a path that turns
        # back on itself (three 2 rad arcs of radius 1 close a circle), or the straight lines that extend
        # it before its start and after its end, can pass within 0.36 m of y
        far = np.abs(curve_s - ss[i]) > 0.6
        if np.min(np.linalg.norm(curve_x[far] - y, axis=1)) < np.linalg.norm(y - x[i]) + 0.1:
            continue
        np.testing.assert_allclose(evaluate(f, y)[0].ravel(), [ss[i], 0.2, -0.3], atol=1e-8)


def test_path_table_and_bad_segments_name_the_field():
    spec = {"kind": "path", "start": START.tolist(), "direction": DIRECTION.tolist(), "normal": NORMAL.tolist(),
            "segments": [{"line": s[1]} if s[0] == "line" else {"arc": s[1], "radius": s[2], "bank": s[3]}
                         for s in CORKSCREW]}
    path = curve3d_from_spec(spec)
    assert path.segments == corkscrew().segments
    again = curve3d_from_spec(path.to_spec())                      # the round trip through data
    y = [0.7, 0.4, 0.9]
    np.testing.assert_allclose(evaluate(outputs(again), y)[0], evaluate(outputs(path), y)[0], atol=1e-12)
    for seg, message in (({"arc": -1.0, "radius": 1.0}, "curve.segments[1].arc: turning angle must be > 0"),
                         ({"arc": 1.0, "radius": 0.0}, "curve.segments[1].radius: must be > 0"),
                         ({"arc": 1.0}, "curve.segments[1]: expected"),
                         ({"line": 0.0}, "curve.segments[1].line: length must be > 0")):
        with pytest.raises(ConfigError) as err:
            curve3d_from_spec({**spec, "segments": [{"line": 1.0}, seg]})
        assert message in str(err.value)
    with pytest.raises(ConfigError, match="does not fit"):
        curve3d_from_spec({"kind": "waypoints", "points": [[0, 0, 0], [0.1, 0, 0], [0.1, 0.1, 0]], "radius": 1.0})
    with pytest.raises(ConfigError, match=r"curve.points\[1\]: the path turns back"):
        Path3D.from_waypoints([[0, 0, 0], [1, 0, 0], [0, 0, 0]], 0.1)


def test_mx_points_give_the_same_values_as_sx():
    path = corkscrew()
    ym = ca.MX.sym("y", 3)
    psi, Phi, frame = path.coordinates(ym, 0.0)
    fm = ca.Function("fm", [ym], [ca.vertcat(psi, Phi, *frame)])
    fs = outputs(path)
    for y in ([0.7, 0.4, 0.9], [2.0, 0.5, 1.0], [-0.3, -0.4, 0.2]):
        out, _, _, frame = evaluate(fs, y)
        np.testing.assert_allclose(np.asarray(fm(y)).ravel(), np.r_[out.ravel(), frame.T.ravel()], atol=1e-14)


def g2_curvature(segments, L):
    """The G2 curvature vector ``s -> (k1, k2)`` in the twist-free frame, from its definition: the G1
    steps replaced over ``[S - L/2, S + L/2]`` by a linear ramp when the two vectors are parallel, else
    by a ramp down to 0 and one up from 0 (written here apart from coordarm's)."""
    K = [np.zeros(2) if sg[0] == "line" else np.array([math.cos(sg[3]), math.sin(sg[3])]) / sg[2] for sg in segments]
    ends = np.cumsum([sg[1] if sg[0] == "line" else sg[1] * sg[2] for sg in segments])

    def k(s):
        for S, ka, kb in zip(ends[:-1], K[:-1], K[1:]):
            if abs(s - S) <= L / 2 and not np.array_equal(ka, kb):
                lam = (s - S + L / 2) / L
                if abs(ka[0] * kb[1] - ka[1] * kb[0]) < 1e-12:
                    return (1 - lam) * ka + lam * kb
                return ka * (1 - 2 * lam) if lam < 0.5 else kb * (2 * lam - 1)
        i = min(int(np.searchsorted(ends, s, side="right")), len(K) - 1)
        return K[i] if s >= 0 else np.zeros(2)
    return k, ends[-1]


def integrate_profile(start, direction, normal, k, total, h=1e-4):
    """Dense (s, x, T, N1, N2) by RK4 of the twist-free frame equations with the curvature ``k(s)``."""
    T = direction / np.linalg.norm(direction)
    N1 = normal - (normal @ T) * T
    N1 /= np.linalg.norm(N1)
    z = np.r_[start, T, N1, np.cross(T, N1)]

    def rhs(s, z):
        k1, k2 = k(s)
        return np.r_[z[3:6], k1 * z[6:9] + k2 * z[9:12], -k1 * z[3:6], -k2 * z[3:6]]
    n = math.ceil(total / h)
    dh = total / n
    out = [z.copy()]
    for i in range(n):
        s = i * dh
        a = rhs(s, z)
        b = rhs(s + dh / 2, z + dh / 2 * a)
        c = rhs(s + dh / 2, z + dh / 2 * b)
        d = rhs(s + dh, z + dh * c)
        z = z + dh / 6 * (a + 2 * b + 2 * c + d)
        out.append(z.copy())
    Z = np.array(out)
    return np.arange(n + 1) * dh, Z[:, 0:3], Z[:, 3:6], Z[:, 6:9], Z[:, 9:12]


def test_a_g2_corkscrew_matches_its_curvature_integrated_and_its_derivatives_fd(rng):
    L = 0.3
    path = corkscrew(L)
    assert path.transitions == [L] * 6 and any(pc.c != 0 for pc in path.pieces)
    k, total = g2_curvature(CORKSCREW, L)
    ss, x, T, N1, N2 = integrate_profile(START, DIRECTION / np.linalg.norm(DIRECTION), NORMAL, k, total)
    assert path.length == pytest.approx(total, abs=1e-12)
    f = outputs(path)
    for i in np.linspace(0, len(ss) - 1, 60).astype(int):
        np.testing.assert_allclose(path.point_at(ss[i]), x[i], atol=1e-9)
        e = rng.uniform(-0.15, 0.15, 2)
        y = x[i] + e[0] * N1[i] + e[1] * N2[i]
        out, J, _, frame = evaluate(f, y)
        np.testing.assert_allclose(out.ravel(), [ss[i], e[0], e[1]], atol=1e-9)
        np.testing.assert_allclose(frame, np.c_[T[i], N1[i], N2[i]], atol=1e-9)
        h = 1e-6                                                # AD through the Newton steps = FD
        fd = np.column_stack([(evaluate(f, y + h * v)[0] - evaluate(f, y - h * v)[0]).ravel() / (2 * h)
                              for v in np.eye(3)])
        np.testing.assert_allclose(J, fd, atol=1e-8)
    kappa = np.array([np.linalg.norm(k(s)) for s in ss])
    assert np.max(np.abs(np.diff(kappa))) < 1.01 * (1 / 0.8) / (L / 2) * (ss[1] - ss[0])   # no jump (G2)
