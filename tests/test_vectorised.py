"""The vectorised generated law (all link angles' cos/sin in one loop, then the recursion) agrees
with the interpreted CasADi law, uses the vector math library where there is one, and falls back
to scalar trigonometry cleanly."""
import platform

import numpy as np
import pytest

from coordarm.symbolic import OUTPUTS, CoordinatingController, Line, PlanarChain
from coordarm.symbolic.outputs import packed_width
from coordarm.generated import compile as compile_controller
from tests.test_generated import ROUNDING_FACTOR, assert_outputs_agree, rounding_sensitivity

COMPILED = {}


def line_controller(m):
    import casadi as ca
    return CoordinatingController(PlanarChain(m, 0.1), Line(angle=lambda t: 0.6 * ca.sin(0.2 * t)), 2.0, 0.1)


def compiled(m, flags=None):
    key = (m, flags)
    if key not in COMPILED:
        ctrl = COMPILED[(m, None)][0] if (m, None) in COMPILED else line_controller(m)
        COMPILED[key] = (ctrl, compile_controller(ctrl, flags=flags))
    return COMPILED[key]


def curled_states(chain, n, seed):
    """Well-conditioned states: gentle zig-zags with a slow bend (every margin well above 0)."""
    rng = np.random.default_rng(seed)
    for _ in range(n):
        q = chain.zigzag(rng.uniform(0.2, 0.4), rng.uniform(-0.3, 0.3))
        q[1:] += rng.uniform(-0.5, 0.5) / chain.m       # a total bend of at most 0.5 rad
        yield q, rng.uniform(0, 10)


def library_bytes(comp):
    return comp.library.path.read_bytes()


@pytest.mark.parametrize("m", [8, 64, 256, 1024])
def test_vectorised_law_agrees_with_interpreted_on_well_conditioned_states(m):
    """1e-12 relative up to m = 64; beyond, the interpreted law itself moves by more than 1e-12
    (1.4e-11 relative at m = 1024) when q moves by one ulp, so the bound is that sensitivity."""
    ctrl, comp = compiled(m)
    for q, t in curled_states(ctrl.chain, 3, seed=m):
        a, b = comp.evaluate(q, t), ctrl.evaluate(q, t)
        assert b["longitudinal"] > 0.1 and np.min(b["link_margins"]) > 0.1
        rounding = rounding_sensitivity(ctrl.evaluate, q, t) if m > 64 else None
        for name in OUTPUTS:
            x, y = np.atleast_1d(a[name]), np.atleast_1d(b[name])
            bound = 1e-12 * max(np.max(np.abs(y)), 1e-3)
            if rounding is not None:
                bound += ROUNDING_FACTOR * rounding[name]
            assert np.max(np.abs(x - y)) <= bound, name


@pytest.mark.parametrize("m", [64, 1024])
def test_vectorised_law_on_an_ill_conditioned_zigzag_is_within_its_rounding_sensitivity(m):
    ctrl, comp = compiled(m)
    q, t = ctrl.chain.zigzag(1.0), 0.7
    assert_outputs_agree(comp.evaluate(q, t), ctrl.evaluate(q, t),
                         rounding=rounding_sensitivity(ctrl.evaluate, q, t))


@pytest.mark.skipif(platform.machine() != "x86_64" or platform.libc_ver()[0] != "glibc",
                    reason="the vector math library is glibc's on x86-64")
def test_default_build_calls_the_vector_cos_and_sin_of_libmvec():
    _, comp = compiled(64)
    data = library_bytes(comp)
    assert b"_ZGV" in data and b"v_cos" in data and b"v_sin" in data


def test_scalar_fallback_builds_without_vector_math_and_agrees():
    ctrl, comp = compiled(64, "-O3 -fno-math-errno -DCOORDARM_SCALAR_TRIG")
    assert b"_ZGV" not in library_bytes(comp)
    for q, t in curled_states(ctrl.chain, 3, seed=1):
        assert_outputs_agree(comp.evaluate(q, t), ctrl.evaluate(q, t),
                             rounding=rounding_sensitivity(ctrl.evaluate, q, t))


def test_rk4_chunk_of_the_vectorised_law_agrees_with_interpreted_steps():
    ctrl, comp = compiled(64)
    q, h = next(curled_states(ctrl.chain, 1, seed=3))[0], 1e-3
    times = 1.0 + h * np.arange(10)
    Q, _ = comp.chunk(q, times, h)
    step, x = ctrl.rk4_step(h), q
    for k, t in enumerate(times):
        x = np.asarray(step(x, t)[0]).ravel()
        np.testing.assert_allclose(Q[k], x, rtol=0, atol=1e-12 * np.max(np.abs(x)))


def test_non_finite_state_is_still_refused_with_the_default_flags():
    from coordarm.symbolic import ConfigError
    ctrl, comp = compiled(8)
    q = ctrl.chain.zigzag(1.0)
    q[3] = np.nan
    with pytest.raises(ConfigError, match="index 3"):
        comp.control(q, 0.0)
    with pytest.raises(ConfigError, match="t: must be finite"):
        comp.control(ctrl.chain.zigzag(1.0), float("inf"))


def test_control_and_evaluate_write_into_caller_arrays_in_place():
    ctrl, comp = compiled(8)
    q, t = next(curled_states(ctrl.chain, 1, seed=4))
    u = np.full(8, np.nan)
    assert comp.control(q, t, out=u) is u
    np.testing.assert_array_equal(u, comp.control(q, t))
    packed = np.full(packed_width(8), np.nan)
    res = comp.evaluate(q, t, out=packed)
    assert np.shares_memory(res["u"], packed) and np.shares_memory(res["e"], packed)
    for name, v in comp.evaluate(q, t).items():
        np.testing.assert_array_equal(res[name], v, err_msg=name)
    np.testing.assert_array_equal(packed[:8], u)
    q2 = q + 0.01                      # the same arrays again, new contents: read and written afresh
    q[:] = q2
    comp.control(q, t + 1, out=u)
    np.testing.assert_array_equal(u, comp.control(q2.tolist(), t + 1))


def test_in_place_calls_check_their_arrays():
    from coordarm.symbolic import ConfigError
    ctrl, comp = compiled(8)
    q = ctrl.chain.zigzag(1.0)
    for bad in (np.zeros(7), np.zeros(8, dtype=np.float32), np.zeros(16)[::2], [0.0] * 8):
        with pytest.raises(ConfigError, match="out: need"):
            comp.control(q, 0.0, out=bad)
    ro = np.zeros(8)
    ro.flags.writeable = False
    with pytest.raises(ConfigError, match="out: need"):
        comp.control(q, 0.0, out=ro)
    with pytest.raises(ConfigError, match="out: need"):
        comp.evaluate(q, 0.0, out=np.zeros(8))
    strided = np.repeat(q, 2)[::2]     # not contiguous: copied, still right
    np.testing.assert_array_equal(comp.control(strided, 0.5, out=np.empty(8)), comp.control(q, 0.5))
    q_nan = q.copy()
    q_nan[5] = np.nan
    with pytest.raises(ConfigError, match="index 5"):
        comp.control(q_nan, 0.0, out=np.empty(8))
