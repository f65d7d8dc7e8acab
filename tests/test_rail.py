"""Introduction axis (rail): the law against the dense decoupling matrix and closed-form facts."""
import warnings

import numpy as np
import pytest

from coordarm import Arc, Line, Path, PlanarChain, CoordinatingController, simulate
from coordarm.symbolic import OUTPUTS, ConfigError, follow_curve
from coordarm.symbolic.outputs import RAIL_OUTPUTS, packed_width, split
from coordarm.symbolic.motions import Ramp, Sinusoid
from coordarm.generated import compile as compile_controller


def rail_chain(m=10, angle=0.0, limits=(-5.0, 5.0)):
    return PlanarChain(m, 0.1, base="rail", rail_angle=angle, rail_limits=limits)


def test_on_a_straight_path_along_the_rail_the_d_column_is_a_unit_vector_and_d_dot_is_v_star():
    chain = rail_chain(12, angle=0.3)
    ctrl = CoordinatingController(chain, Line(angle=0.3), 2.0, 0.17)
    q = chain.zigzag(1.2, heading=0.3, d=0.4)
    M, rhs = ctrl.decoupling_matrices(q[None], [0.0])
    np.testing.assert_allclose(M[0][:, 0], np.eye(chain.dof)[0], atol=1e-14)        # rows (s, sigma, e)
    fixed = PlanarChain(12, 0.1)
    M0 = CoordinatingController(fixed, Line(angle=0.3), 2.0, 0.17).decoupling_matrix(fixed.zigzag(1.2, 0.3))
    assert np.linalg.det(M[0]) == pytest.approx(np.linalg.det(M0), rel=1e-10)
    for form in ("structured", "dense"):
        u = ctrl.evaluate(q, 0.0, form=form)["u"]
        assert u[0] == pytest.approx(0.17, abs=1e-14)
        np.testing.assert_allclose(u[1:], 0.0, atol=1e-12)  # rounding of the zig-zag on the line


def test_the_d_column_equals_a_finite_difference_of_the_outputs():
    chain = rail_chain(9, angle=-0.2)
    path = Path((-0.4, 0.1), -0.1, [{"line": 0.5}, {"arc": 1.0, "radius": 0.6}, {"line": 1.0}])
    ctrl = CoordinatingController(chain, path, 2.0, 0.1)
    q = follow_curve(ctrl, 1.1, d=0.2)
    q = q + np.random.default_rng(1).normal(scale=0.01, size=chain.dof)

    def outputs(qq):
        g = ctrl.centre_geometry(qq[None], [0.0])
        return np.r_[g["psi"][0, -1], g["psi"][0, -1] - g["psi"][0, 0], g["phi"][0, 1:]]

    M = ctrl.decoupling_matrices(q[None], [0.0])[0][0]
    h = 1e-6
    J = np.array([(outputs(q + h * e) - outputs(q - h * e)) / (2 * h) for e in np.eye(chain.dof)]).T
    np.testing.assert_allclose(M, J, atol=1e-8)


@pytest.mark.parametrize("span", [None, Sinusoid(0.05, 1.0, offset=0.5)], ids=["held", "commanded"])
def test_structured_rail_law_equals_the_dense_solve_at_random_configurations(span):
    chain = rail_chain(14, angle=0.1)
    path = Path((-0.5, 0.0), 0.1, [{"line": 0.6}, {"arc": -1.2, "radius": 0.5}, {"arc": 1.5, "radius": 0.6}],
                offset=(Ramp(0.0, 0.02), 0.0), rotation=Sinusoid(0.05, 0.5))
    ctrl = CoordinatingController(chain, path, 2.0, Sinusoid(0.05, 0.3, offset=0.1), span=span)
    q0 = follow_curve(ctrl, 1.1, d=0.1)
    rng = np.random.default_rng(2)
    for t in (0.0, 0.9, 2.3):
        q = q0 + rng.normal(scale=0.02, size=chain.dof)
        out = ctrl.evaluate(q, t)
        M, rhs = ctrl.decoupling_matrices(q[None], [t])
        u = np.linalg.solve(M[0], rhs[0])
        np.testing.assert_allclose(out["u"], u, rtol=1e-10, atol=1e-10 * np.max(np.abs(u)))
        np.testing.assert_allclose(ctrl.evaluate(q, t, form="dense")["u"], u, rtol=1e-10, atol=1e-12)
        g = ctrl.centre_geometry(q[None], [t])
        assert out["sigma"] == pytest.approx(g["psi"][0, -1] - g["psi"][0, 0], abs=1e-12)
        grad = g["gpsi"][0, 0]
        assert out["rail_margin"] == pytest.approx(abs(grad @ chain.rail_direction) / np.linalg.norm(grad), abs=1e-12)


def test_a_rail_run_feeds_the_body_in_holds_the_span_and_tracks_s():
    chain = rail_chain(16, angle=0.0, limits=(0.0, 3.0))
    path = Path((-0.2, 0.0), 0.0, [{"line": 0.8}, {"arc": 0.8, "radius": 0.8}, {"line": 2.0}])
    ctrl = CoordinatingController(chain, path, 2.0, 0.2)
    q0 = follow_curve(ctrl, 1.1, d=0.0)
    run = simulate(ctrl, q0, 2.0, 0.002, backend="interpreted")       # the base stays on the straight part
    assert run.q.shape[1] == 17 and run.sigma is not None
    np.testing.assert_allclose(run.sigma, run.sigma[0], atol=1e-9)                 # held span
    np.testing.assert_allclose(run.s, run.s_reference(), atol=1e-9)               # s tracks v*
    assert np.max(np.abs(run.e)) < 1e-7          # RK4 (h = 2 ms) meets the curvature jumps at the junctions
    assert run.q[-1, 0] == pytest.approx(0.4, abs=1e-9)                           # the rail fed the body in at v*


def test_leaving_the_rail_limits_stops_like_a_collision():
    from coordarm import CollisionError
    from coordarm.simulation.physical import Physical
    chain = rail_chain(8, limits=(0.0, 0.3))
    ctrl = CoordinatingController(chain, Line(), 2.0, 0.2)
    with pytest.raises(CollisionError, match=r"rail limit at t = 1.50\d s: the rail position d = \+0.30\d+ m"):
        simulate(ctrl, chain.zigzag(1.2), 3.0, 0.01, backend="interpreted", physical=Physical(chain))


def test_bad_rail_parameters_are_refused():
    with pytest.raises(ConfigError, match="base: expected one of"):
        PlanarChain(4, 0.1, base="wheel")
    with pytest.raises(ConfigError, match="rail_limits"):
        PlanarChain(4, 0.1, base="rail", rail_limits=(1.0, 0.0))
    with pytest.raises(ConfigError, match="span: only a chain on a rail"):
        CoordinatingController(PlanarChain(4, 0.1), Line(), 1.0, 0.1, span=0.3)
    with pytest.raises(ConfigError, match=r"q: need shape \(5,\) \(d, then"):
        CoordinatingController(rail_chain(4), Line(), 1.0, 0.1).evaluate(np.zeros(4))


#: Curves through the rail's base region, each moving, for the compiled-law tests.
RAIL_CURVES = {
    "line": lambda: Line((0.0, Sinusoid(0.01, 1.0)), angle=Sinusoid(0.05, 0.5, offset=0.2)),
    "arc": lambda: Arc((0.0, Sinusoid(0.02, 0.7)), angle=0.2, radius=Sinusoid(0.1, 0.4, offset=1.5)),
    "path": lambda: Path((-0.392, -0.0795), 0.2, [{"line": 0.6}, {"arc": 0.9, "radius": 0.7}, {"line": 0.3},
                                                  {"arc": -1.2, "radius": 0.5}, {"line": 1.0}],
                         offset=(Ramp(0.0, 0.02), 0.0), rotation=Sinusoid(0.05, 0.7)),
}
COMPILED = {}


def compiled_rail(kind, span, form="structured", governor=False):
    """A rail controller (diagonal B, moving curve and speed) and its compiled twin, built once."""
    key = (kind, span, form, governor)
    if key not in COMPILED:
        chain = PlanarChain(11, 0.1, base="rail", rail_angle=0.2, B=np.linspace(0.5, 1.5, 11))
        ctrl = CoordinatingController(chain, RAIL_CURVES[kind](), 2.0, Sinusoid(0.05, 0.3, offset=0.1), law=form,
                                      span=None if span == "held" else Sinusoid(0.05, 1.0, offset=0.5),
                                      governor=governor)
        COMPILED[key] = (ctrl, compile_controller(ctrl))
    return COMPILED[key]


def random_rail_states(ctrl, n, seed, beta=(0.8, 1.3)):
    """States near the curve: the chain laid along it (fold angle in ``beta``) from a random rail position,
    then perturbed."""
    rng = np.random.default_rng(seed)
    for _ in range(n):
        t = rng.uniform(0.0, 3.0)
        q = follow_curve(ctrl, rng.uniform(*beta), t0=t, d=rng.uniform(-0.1, 0.2))
        yield q + rng.normal(scale=0.03, size=ctrl.chain.dof), t


def assert_compiled_equals_interpreted(comp, ctrl, q, t):
    """Every packed output of the compiled law equals the interpreted one to 1e-12 relative plus
    the state's own one-ulp sensitivity (as the fixed-base random-state tests); returns the interpreted."""
    from tests.test_generated import ROUNDING_FACTOR, rounding_sensitivity
    a, b = comp.evaluate(q, t), ctrl.evaluate(q, t)
    assert set(a) == set(b) == set(OUTPUTS + RAIL_OUTPUTS)
    sens = rounding_sensitivity(ctrl.evaluate, q, t)
    for name in a:
        ref = np.atleast_1d(b[name])
        bound = 1e-12 * max(np.max(np.abs(ref)), 1e-3) + ROUNDING_FACTOR * sens[name]
        assert np.max(np.abs(np.atleast_1d(a[name]) - ref)) <= bound, (name, a[name], b[name])
    np.testing.assert_array_equal(comp.control(q, t), a["u"])
    return b


@pytest.mark.parametrize("form", ["structured", "dense"])
@pytest.mark.parametrize("span", ["held", "commanded"])
@pytest.mark.parametrize("kind", list(RAIL_CURVES))
def test_compiled_rail_law_equals_the_interpreted_law_to_1e12_at_random_states(kind, span, form):
    ctrl, comp = compiled_rail(kind, span, form)
    assert comp.n == 12 and comp.n_out == packed_width(11, rail=True)
    for q, t in random_rail_states(ctrl, 6, seed=len(kind) + 10 * len(span) + len(form)):
        b = assert_compiled_equals_interpreted(comp, ctrl, q, t)
        assert b["rail_margin"] > 0.5 and b["longitudinal"] > 0.01 and b["v_scale"] == 1.0
        assert b["u"].shape == (12,)


@pytest.mark.parametrize("span", ["held", "commanded"])
@pytest.mark.parametrize("kind", ["line", "path"])
def test_compiled_governed_rail_law_runs_both_passes_and_equals_the_interpreted_law(kind, span):
    """The governor on a rail: the C's second pass (head with the governed rail rate) at slowed states."""
    ctrl, comp = compiled_rail(kind, span, governor=True)
    plain = compiled_rail(kind, span)[1]
    scales = []
    for q, t in random_rail_states(ctrl, 10, seed=7 + len(kind) + len(span), beta=(0.2, 1.0)):
        b = assert_compiled_equals_interpreted(comp, ctrl, q, t)
        scales.append(b["v_scale"])
        if b["v_scale"] < 0.9:                   # the governed rail rate is not the plain law's
            assert abs(b["u"][0] - plain.evaluate(q, t)["u"][0]) > 1e-3
    assert sum(0 < g < 1 for g in scales) >= 4 and max(scales) == 1.0, scales


@pytest.mark.parametrize("span", ["held", "commanded"])
def test_compiled_rail_step_and_chunk_equal_the_interpreted_rk4_step(span):
    ctrl, comp = compiled_rail("path", span)
    h, (q, _) = 2e-3, next(random_rail_states(ctrl, 1, seed=3))
    times = 0.4 + h * np.arange(15)
    Q, D = comp.chunk(q, times, h)
    assert Q.shape == (15, 12)
    step = ctrl.rk4_step(h)
    x = q
    for k, t in enumerate(times):
        res = [np.asarray(v).ravel() for v in step(x, t)]
        np.testing.assert_allclose(comp.step(x, t, h), res[0], rtol=1e-12, atol=1e-12)
        d = split(D[k], 11, rail=True)
        for name, ref in zip(ctrl.run_outputs, res[1:]):
            np.testing.assert_allclose(np.atleast_1d(d[name]), ref, rtol=1e-12, atol=1e-12, err_msg=name)
        x = res[0]
        np.testing.assert_allclose(Q[k], x, rtol=1e-12, atol=1e-12)


def test_a_rail_run_compiled_by_auto_equals_the_interpreted_run():
    chain = rail_chain(16, angle=0.0, limits=(0.0, 3.0))
    path = Path((-0.2, 0.0), 0.0, [{"line": 0.8}, {"arc": 0.8, "radius": 0.8}, {"line": 2.0}])
    ctrl = CoordinatingController(chain, path, 2.0, 0.2, span=Ramp(1.2, 0.01))
    q0 = follow_curve(ctrl, 1.1, d=0.0)
    with warnings.catch_warnings():
        warnings.simplefilter("error")                    # no fallback warning: a rail compiles
        a = simulate(ctrl, q0, 1.0, 0.002)
    b = simulate(ctrl, q0, 1.0, 0.002, backend="interpreted")
    assert a.info["backend"] == "compiled" and b.info["backend"] == "interpreted"
    for field in ("q", "u", "e", "s", "sigma", "rail_margin", "link_margins", "longitudinal"):
        np.testing.assert_allclose(getattr(a, field), getattr(b, field), rtol=1e-12, atol=1e-12, err_msg=field)


@pytest.mark.parametrize("governor", [False, True], ids=["plain", "governed"])
@pytest.mark.parametrize("form", ["structured", "dense"])
@pytest.mark.parametrize("span", ["held", "commanded"])
def test_every_rail_library_compiles_without_a_warning(span, form, governor, tmp_path):
    from coordarm.generated.build import build
    from coordarm.generated.codegen import generate_source
    chain = PlanarChain(4, 0.1, base="rail", rail_angle=0.3, B=np.array([1.0, 2.0, 0.5, 1.5]))
    ctrl = CoordinatingController(chain, Line(angle=0.3), 2.0, 0.05, law=form, governor=governor,
                                  span=None if span == "held" else Ramp(0.25, 0.01))
    lib = build(generate_source(ctrl, form), flags="-O2 -Wall -Wextra -Werror", build_dir=tmp_path)
    assert lib.path.is_file() and not lib.cache_hit


@pytest.mark.parametrize("span", [None, Ramp(0.4, 0.05)], ids=["held", "commanded"])
def test_closed_form_rail_decoupling_matrices_equal_the_ad_ones(span):
    chain = PlanarChain(9, 0.1, base="rail", rail_angle=0.3, B=np.linspace(0.7, 1.3, 9))
    path = Path((-0.3, -0.1), 0.3, [{"line": 0.5}, {"arc": -0.8, "radius": 0.9}], offset=(Ramp(0.0, 0.03), 0.0))
    ctrl = CoordinatingController(chain, path, 2.0, 0.1, span=span)
    rng = np.random.default_rng(8)
    Q = follow_curve(ctrl, 1.0, d=0.05)[None] + rng.normal(scale=0.02, size=(4, chain.dof))
    T = np.array([0.0, 0.4, 1.1, 2.0])
    M, rhs = ctrl.decoupling_matrices(Q, T)
    for k in range(4):
        Mk, rk = (np.asarray(v) for v in ctrl.decoupling_function()(Q[k], T[k]))
        np.testing.assert_allclose(M[k], Mk, rtol=0, atol=1e-13)
        np.testing.assert_allclose(rhs[k], rk.ravel(), rtol=0, atol=1e-13)


def test_only_the_governed_rail_turns_on_the_second_pass_of_the_c_glue():
    from coordarm.generated.codegen import generate_source
    chain = PlanarChain(4, 0.1, base="rail")
    texts = {(g, rail): generate_source(CoordinatingController(chain if rail else PlanarChain(4, 0.1), Line(), 2.0,
                                                               0.1, governor=g)).text
             for g in (False, True) for rail in (False, True)}
    assert [k for k, text in texts.items() if "#define CA_GOVERNED" in text] == [(True, True)]
