"""The compiled law on a path searches each link's closest piece near the previous link's
(coordarm.generated.path_search): it must choose as the full selection does. Checked against the
interpreted law (full CasADi selection) to 1e-12, against the compiled full selection, and the
deviations against a brute-force nearest point written here with complex numbers."""
import cmath
import math

import numpy as np
import pytest

from coordarm.generated.compiled import CompiledController
from coordarm.generated.path_search import search_tables
from coordarm.symbolic import CoordinatingController, Path, PlanarChain, follow_curve
from coordarm.symbolic.recursion import REPIVOT
from coordarm.symbolic.motions import Ramp, Sinusoid
from coordarm.generated import compile as compile_controller
from tests.test_generated import ROUNDING_FACTOR, rounding_sensitivity

#: Paths through the base region: an S with short pieces, a U-turn whose legs come back 0.8 m apart
#: (a chain across it jumps from the first leg's piece to the last's), and a long wiggle of 12 segments.
PATHS = {
    "s-bend": ((-0.4, 0.0), 0.0, [{"line": 0.35}, {"arc": 1.1, "radius": 0.45}, {"line": 0.12},
                                    {"arc": -1.6, "radius": 0.4}, {"arc": 0.7, "radius": 0.6}, {"line": 0.8}]),
    "u-turn": ((-0.3, 0.0), 0.0, [{"line": 1.2}, {"arc": math.pi, "radius": 0.4}, {"line": 1.5}]),
    "wiggle": ((-0.5, 0.0), 0.0, [{"line": 0.2} if i % 2 == 0 else {"arc": 0.7 * (-1) ** (i // 2), "radius": 0.5}
                                  for i in range(12)]),
}
BUILT = {}


def built(name, moving=False, m=24, transition=0.0):
    """A controller on the path and its compiled twins: searched (default) and full selection.

    ``transition = 0``: the G1 path (the brute force below walks it); None: default transitions."""
    key = (name, moving, m, transition)
    if key not in BUILT:
        start, heading, segs = PATHS[name]
        motion = dict(offset=(Ramp(0.0, 0.01), Sinusoid(0.02, 0.8)), rotation=Sinusoid(0.03, 0.5)) if moving else {}
        path = Path(start, heading, segs, transition=transition, **motion)
        ctrl = CoordinatingController(PlanarChain(m, 0.1), path, 2.0,
                                      Sinusoid(0.03, 0.4, offset=0.1))
        BUILT[key] = (ctrl, compile_controller(ctrl), CompiledController(ctrl, path_search=False))
    return BUILT[key]


def nearest_signed_distance(start, heading, segments, p):
    """Brute force: the signed distance from ``p`` to the path (rays beyond both ends), walking the
    segments with complex numbers and taking the nearest point of every one (clamped to it)."""
    z, d, best = complex(*start), cmath.exp(1j * heading), (math.inf, 0.0)
    w = complex(*p)

    def consider(point, tangent):
        nonlocal best
        dist = abs(w - point)
        if dist < best[0]:
            side = (tangent.conjugate() * (w - point)).imag
            best = (dist, math.copysign(dist, side))

    x = ((w - z) * d.conjugate()).real                       # the ray before the start
    consider(z + min(x, 0.0) * d, d)
    for seg in segments:
        if "line" in seg:
            L = seg["line"]
            x = ((w - z) * d.conjugate()).real
            consider(z + min(max(x, 0.0), L) * d, d)
            z = z + L * d
        else:
            A, R = seg["arc"], seg["radius"]
            centre = z + math.copysign(1.0, A) * 1j * d * R
            a = cmath.phase((w - centre) / (z - centre)) * math.copysign(1.0, A)   # in (-pi, pi]
            if a < 0 and abs(A) > math.pi and a + 2 * math.pi <= abs(A):
                a += 2 * math.pi
            a = min(max(a, 0.0), abs(A))
            turn = cmath.exp(1j * math.copysign(a, A))
            consider(centre + (z - centre) * turn, d * turn)
            z, d = centre + (z - centre) * cmath.exp(1j * A), d * cmath.exp(1j * A)
    x = ((w - z) * d.conjugate()).real                       # the ray after the end
    consider(z + max(x, 0.0) * d, d)
    return best[1]


def assert_same_law(ctrl, comp, q, t):
    a, b = comp.evaluate(q, t), ctrl.evaluate(q, t)
    sens = rounding_sensitivity(ctrl.evaluate, q, t)
    for name in a:
        ref = np.atleast_1d(b[name])
        bound = 1e-12 * max(np.max(np.abs(ref)), 1e-3) + ROUNDING_FACTOR * sens[name]
        assert np.max(np.abs(np.atleast_1d(a[name]) - ref)) <= bound, (name, a[name], b[name])
    return a


def on_path_states(ctrl, n, seed, spread=0.02):
    rng = np.random.default_rng(seed)
    for _ in range(n):
        q = follow_curve(ctrl, rng.uniform(0.9, 1.35)) + rng.normal(scale=spread, size=ctrl.chain.m)
        yield q, rng.uniform(0.0, 2.0)


@pytest.mark.parametrize("moving, transition", [(False, 0.0), (True, 0.0), (False, None), (True, None)],
                         ids=["static", "moving", "static-g2", "moving-g2"])
@pytest.mark.parametrize("name", list(PATHS))
def test_searched_law_equals_the_interpreted_full_selection_near_the_path(name, moving, transition):
    ctrl, comp, full = built(name, moving, transition=transition)
    for q, t in on_path_states(ctrl, 8, seed=len(name) + moving):
        a = assert_same_law(ctrl, comp, q, t)
        assert np.min(a["link_margins"]) > REPIVOT        # the searched recursion ran (no re-pivoting)
        b = full.evaluate(q, t)
        for key in a:
            np.testing.assert_allclose(a[key], b[key], rtol=1e-12, atol=1e-12 * max(1.0, np.max(np.abs(b[key]))))


@pytest.mark.parametrize("name", list(PATHS))
def test_searched_deviations_equal_a_brute_force_nearest_point(name):
    ctrl, comp, _ = built(name)
    start, heading, segs = PATHS[name]
    tube = ctrl.curve.tube_radius
    checked = 0
    for q, t in on_path_states(ctrl, 6, seed=7, spread=0.05):
        e = comp.evaluate(q, t)["e"]
        Y = ctrl.chain.centres_np(q)
        for j in range(1, ctrl.chain.m):
            ref = nearest_signed_distance(start, heading, segs, Y[j])
            if abs(ref) < 0.9 * tube:
                assert e[j - 1] == pytest.approx(ref, abs=1e-12), (j, e[j - 1], ref)
                checked += 1
    assert checked > 50


@pytest.mark.parametrize("transition", [0.0, None], ids=["g1", "g2"])
@pytest.mark.parametrize("name", ["s-bend", "wiggle"])
def test_searched_law_equals_the_full_selection_where_a_centre_is_on_a_junction(name, transition):
    """The path is shifted so that the centre of link j lies on the normal of a junction (both
    pieces in range, |phi| equal): whichever the search takes, the law is the full selection's."""
    start, heading, segs = PATHS[name]
    base = Path(start, heading, segs, transition=transition)
    chain = PlanarChain(16, 0.1)
    q = follow_curve(CoordinatingController(chain, base, 2.0, 0.1), 1.2)
    Y = chain.centres_np(q)
    rng = np.random.default_rng(5)
    junctions = [pc for pc in base.pieces[1:] if math.isfinite(pc.length)]
    tried = 0
    for pc in junctions[:4 if transition == 0 else 8]:          # G2: more, shorter pieces
        j = int(rng.integers(2, 14))
        target = pc.p0 + rng.uniform(-0.05, 0.05) * pc.n0         # on the junction's normal
        path = Path(start, heading, segs, offset=tuple(Y[j] - target), transition=transition)
        ctrl = CoordinatingController(chain, path, 2.0, 0.1)
        p = path.path_point(Y[j], 0.0)
        assert np.allclose(np.asarray(p).ravel(), target, atol=1e-15)
        out = assert_same_law(ctrl, compile_controller(ctrl), q, 0.0)
        if np.min(out["link_margins"]) > REPIVOT:
            tried += 1
    assert tried >= 2


def test_a_chain_folding_across_a_u_turn_jumps_between_far_pieces():
    """Centres alternate between the two legs of the U (0.8 m apart): consecutive links' pieces are
    three apart in index, and the search still finds the full selection's."""
    ctrl, comp, full = built("u-turn")
    tb = search_tables(ctrl.curve)
    assert len(tb["flags"]) == 4                              # line, the half turn in two arcs, line
    rng = np.random.default_rng(11)
    m = ctrl.chain.m
    for _ in range(6):
        q = np.zeros(m)
        q[0] = math.pi / 2 + rng.uniform(-0.1, 0.1)               # up from the lower leg towards the upper one
        q[1:] = rng.normal(scale=0.05, size=m - 1)
        q[8] = math.pi * rng.uniform(0.85, 0.95)                 # fold back down
        q[16] = -math.pi * rng.uniform(0.85, 0.95)               # and up again
        Y = ctrl.chain.centres_np(q)
        assert np.max(Y[:, 1]) > 0.5 and np.min(Y[:, 1]) < 0.3    # the chain spans both legs
        a, b = comp.evaluate(q, 0.7), ctrl.evaluate(q, 0.7)
        np.testing.assert_allclose(a["e"], b["e"], rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(a["e"], full.evaluate(q, 0.7)["e"], rtol=1e-12, atol=1e-12)
        start, heading, segs = PATHS["u-turn"]
        ref = [nearest_signed_distance(start, heading, segs, y) for y in Y[1:]]
        np.testing.assert_allclose(np.abs(a["e"]), np.abs(ref), atol=1e-12)


def test_lower_bounds_never_exceed_the_true_distance_between_pieces():
    """The search's tables: every bound is at most the distance between the two pieces, measured
    on dense samples of both (rays sampled 5 m out)."""
    for name, transition in [(name, tr) for name in PATHS for tr in (0.0, None)]:
        path = Path(*PATHS[name], transition=transition)
        tb = search_tables(path)
        samples = []
        for i, pc in enumerate(path.pieces):
            lo = -5.0 if (pc.ray_before or i == 0) else 0.0
            hi = pc.length if math.isfinite(pc.length) else 5.0
            x = np.linspace(lo, hi, 400)
            if pc.c != 0:                                        # a clothoid: its own 24-node quadrature
                samples.append(np.array([pc.point(v)[0] for v in x]))
            elif pc.k == 0:
                samples.append(pc.p0 + x[:, None] * pc.d0)
            else:
                x = np.clip(x, 0.0, pc.length)
                c = pc.centre
                ang = pc.k * x
                r0 = pc.p0 - c
                samples.append(c + np.stack([np.cos(ang) * r0[0] - np.sin(ang) * r0[1],
                                             np.sin(ang) * r0[0] + np.cos(ang) * r0[1]], axis=1))
        for i in range(len(path.pieces)):
            for k in range(tb["start"][i], tb["start"][i + 1]):
                j = tb["others"][k]
                dist = np.min(np.linalg.norm(samples[i][:, None] - samples[j][None], axis=-1))
                assert tb["bounds"][k] <= dist + 1e-12, (name, i, j)
            assert np.all(np.diff(tb["bounds"][tb["start"][i]:tb["start"][i + 1]]) >= 0)


@pytest.mark.parametrize("moving, transition", [(False, 0.0), (True, 0.0), (True, None)],
                         ids=["static", "moving", "moving-g2"])
def test_the_searched_path_law_compiles_without_a_warning(moving, transition, tmp_path):
    from coordarm.generated.build import build
    from coordarm.generated.codegen import generate_source
    ctrl = built("s-bend", moving, m=6, transition=transition)[0]
    source = generate_source(ctrl)
    assert "ca_closest_piece" in source.text and "link_geometry_arc" in source.text
    assert ("link_geometry_spiral" in source.text) == (transition is None)
    lib = build(source, flags="-O2 -Wall -Wextra -Werror", build_dir=tmp_path)
    assert lib.path.is_file() and not lib.cache_hit
