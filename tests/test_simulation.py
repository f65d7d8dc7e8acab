"""Simulation vs closed form: e(t) = e(0) exp(-K t), s(t) = s(0) + ∫v*; singularity stops; bad input."""
import io
import subprocess
import sys

import casadi as ca
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.integrate import quad

from coordarm.simulation import ConfigError, SingularityError, simulate
from coordarm.simulation.obstacles import link_distances
from coordarm.simulation.progress import LINE, Progress, bar_line
from coordarm.simulation.run import DEFAULT_THRESHOLDS
from coordarm.simulation.scenario import load_scenario
from coordarm.symbolic import Arc, CoordinatingController, Line, PlanarChain, project_onto_curve


@pytest.fixture(scope="module", params=["line", "arc", "hole"])
def preset_run(request):
    sc = load_scenario(request.param)
    ctrl = sc.controller()
    return sc, ctrl, simulate(ctrl, sc.start(ctrl), sc.duration, sc.step, sc.t0, thresholds=sc.thresholds)


def test_preset_errors_decay_like_exp_minus_k_t(preset_run):
    sc, ctrl, run = preset_run
    assert run.info["stopped"] == "completed" and run.t[-1] == pytest.approx(sc.duration)
    predicted = run.e[0] * np.exp(-ctrl.gain * (run.t - run.t[0]))[:, None]
    assert np.max(np.abs(run.e[0])) > 1e-2                    # a visible transient to check against
    np.testing.assert_allclose(run.e, predicted, atol=1e-12)
    early = run.t - run.t[0] < 1.0
    np.testing.assert_allclose(run.e[early], predicted[early], rtol=1e-8, atol=1e-15)


def test_preset_end_point_tracks_the_commanded_speed(preset_run):
    sc, ctrl, run = preset_run
    v = ctrl.speed_function()

    def integral(a, b):      # adaptive quadrature split at whole seconds, where the presets' motions switch
        cuts = [a, *np.arange(np.floor(a) + 1, b), b]
        return sum(quad(lambda x: float(v(x)), lo, hi, epsabs=1e-14, limit=200)[0] for lo, hi in zip(cuts, cuts[1:]))
    for k in np.linspace(0, len(run.t) - 1, 15).astype(int):
        assert run.s[k] == pytest.approx(run.s[0] + integral(run.t[0], run.t[k]), abs=1e-12)


def test_hole_preset_body_passes_the_hole_without_touching_a_wall():
    sc = load_scenario("hole")
    ctrl = sc.controller()
    run = simulate(ctrl, sc.start(ctrl), sc.duration, sc.step)
    joints = ctrl.chain.joints_np(run.q)
    assert min(link_distances(joints, ob).min() for ob in sc.obstacles) > 0.01
    wall_mid = sc.obstacles[0].points[0] - np.array([0.06 * -np.sin(0.8), 0.06 * np.cos(0.8)])
    past = joints[-1, -1] @ np.array([np.cos(0.8), np.sin(0.8)])
    assert past > wall_mid @ np.array([np.cos(0.8), np.sin(0.8)]) + 0.5   # the end is well beyond the wall


def test_wall_check_sees_a_link_across_a_wall():
    from coordarm.simulation.obstacles import obstacles_from_spec
    joints = np.array([[[0.0, 0.0], [1.0, 0.0], [2.0, 0.0]]])
    near, far = obstacles_from_spec([{"a": [1.5, -1.0], "b": [1.5, 1.0]}, {"a": [5.0, -1.0], "b": [5.0, 1.0]}])
    np.testing.assert_array_equal(link_distances(joints, near), [[0.5, 0.0]])
    np.testing.assert_array_equal(link_distances(joints, far), [[4.0, 3.0]])


def test_run_nearing_the_longitudinal_singularity_stops_with_time_margin_and_no_garbage():
    chain = PlanarChain(64, 0.1)
    ctrl = CoordinatingController(chain, Arc(radius=2.0), 2.0, 0.2)
    q0 = project_onto_curve(ctrl, chain.zigzag(1.3))
    seen = []
    with pytest.raises(SingularityError) as info:
        simulate(ctrl, q0, 30.0, 0.001, on_chunk=seen.append)
    err = info.value
    assert err.kind == "longitudinal" and err.link is None
    unfold = 63 * 0.1 * (1 - np.cos(1.3)) / 0.2   # time for v* to stretch the compact body fully [s]
    assert 0.8 * unfold < err.time < unfold and err.margin < DEFAULT_THRESHOLDS["longitudinal"] == 0.15
    assert "t = " in str(err) and "longitudinal margin" in str(err)
    run = err.run
    assert run.t[-1] == err.time and np.all(np.isfinite(run.q)) and np.all(run.longitudinal[:-1] >= 0.15)
    full = np.concatenate([p.t for p in seen])                # the logger saw every step up to the stop
    np.testing.assert_allclose(np.diff(full), 0.001, rtol=1e-9)
    assert full[-1] == run.t[-1] and run.info["kept_every"] == 2   # 30,000 steps > KEEP_ROWS: every 2nd kept
    assert np.isin(run.t, full).all() and len(full) // 2 <= len(run.t) < len(full) // 2 + 4 * len(seen) + 2
    nominal = np.max(np.abs(run.u[:100]))
    assert np.max(np.abs(run.u)) < 10 * nominal               # stopped before |u| blew up


@pytest.mark.parametrize("backend", ["compiled", "interpreted"])
def test_kept_rows_of_a_logged_run_are_the_rows_the_rule_picks_from_the_full_run(backend):
    """The rows kept in memory (gathered chunk by chunk into arrays allocated once) equal, value for
    value, the rows of the unthinned run that the rule names: every 10th step, each chunk's smallest
    link and longitudinal margins, largest |u| and last row, and the final state."""
    chain = PlanarChain(8, 0.1)
    ctrl = CoordinatingController(chain, Line(angle=lambda t: 0.3 * ca.sin(t)), 2.0, 0.05)
    q0, n_steps, chunk = chain.zigzag(1.3), 3000, 700
    full = simulate(ctrl, q0, 3.0, 0.001, backend=backend, chunk=chunk)
    kept = simulate(ctrl, q0, 3.0, 0.001, backend=backend, chunk=chunk, on_chunk=lambda part: None, keep=300)
    assert kept.info["kept_every"] == 10 and len(full.t) == n_steps + 1
    want = set(range(0, n_steps, 10)) | {n_steps}
    for k0 in range(0, n_steps, chunk):
        rows = np.arange(k0, min(k0 + chunk, n_steps))
        want |= {int(rows[np.argmin(full.link_margins[rows].min(axis=1))]), int(rows[np.argmin(full.longitudinal[rows])]),
                 int(rows[np.argmax(np.abs(full.u[rows]).max(axis=1))]), int(rows[-1])}
    index = np.array(sorted(want))
    assert kept.array_names() == full.array_names()
    for a in full.array_names():
        np.testing.assert_array_equal(getattr(kept, a), getattr(full, a)[index], err_msg=a)
    np.testing.assert_array_equal(kept.speed_factor(), full.speed_factor()[index])


def test_margin_lows_are_each_rows_smallest_margin_and_decide_like_the_arrays(rng):
    """``margin_lows`` against a row-by-row Python minimum (NaN where the row has one); the first violation
    found from them is the one found from the arrays alone, at random thresholds, with NaNs and infinities."""
    from coordarm.simulation.log_layout import PLANAR
    from coordarm.simulation.stepping import margin_lows, margin_violation
    checks = PLANAR.margins
    for _ in range(50):
        n = int(rng.integers(1, 40))
        arrays = {"link_margins": rng.uniform(0, 1, (n, 7)), "longitudinal": rng.uniform(0, 1, n)}
        for a in arrays.values():
            a.flat[rng.integers(0, a.size, int(rng.integers(0, 3)))] = rng.choice([np.nan, np.inf, -np.inf])
        lows = margin_lows(arrays, checks)
        rows = [float("nan") if any(v != v for v in r) else min(r) for r in arrays["link_margins"].tolist()]
        np.testing.assert_array_equal(lows["link_margins"], rows)
        assert lows["longitudinal"] is arrays["longitudinal"]
        thr = {"link": float(rng.uniform(0, 0.3)), "longitudinal": float(rng.uniform(0, 0.3))}
        got, want = margin_violation(arrays, checks, thr, lows), margin_violation(arrays, checks, thr)
        assert (got is None) == (want is None)
        if got is not None:       # (row, kind, link, margin): the margin compared as bits (NaN equals NaN)
            assert got[:3] == want[:3] and np.float64(got[3]).tobytes() == np.float64(want[3]).tobytes()


def test_link_singularity_stops_naming_the_link():
    chain = PlanarChain(8, 0.1)
    ctrl = CoordinatingController(chain, Line(angle=lambda t: 0.3 * ca.sin(t)), 2.0, -0.05)
    with pytest.raises(SingularityError) as info:     # pushing back folds the chain until a link stands across
        simulate(ctrl, chain.zigzag(1.3), 20.0, 0.001)
    assert info.value.kind == "link" and 2 <= info.value.link <= 8 and "link" in str(info.value)


def test_singular_start_is_refused_before_any_work():
    chain = PlanarChain(16, 0.1)
    ctrl = CoordinatingController(chain, Line(), 2.0, 0.1)
    with pytest.raises(ConfigError, match="q0: start configuration is .*singular: link margin of link"):
        simulate(ctrl, chain.zigzag(1.5699), 1.0)
    with pytest.raises(ConfigError, match="longitudinal"):
        simulate(ctrl, chain.zigzag(0.01), 1.0)


def test_curve_missing_the_base_is_refused_naming_the_time():
    chain = PlanarChain(8, 0.1)
    ctrl = CoordinatingController(chain, Line(point=(0.0, lambda t: 0.05 * t)), 2.0, 0.1)
    with pytest.raises(ConfigError, match=r"curve: passes 0.1\d* m from the base at t = 2.0"):
        simulate(ctrl, chain.zigzag(1.0), 5.0)


@pytest.mark.parametrize("kwargs,match", [(dict(duration=0.0), "duration"), (dict(duration=float("nan")), "duration"),
                                          (dict(step=-1e-3), "step"), (dict(step=2.0), "step"),
                                          (dict(chunk=0), "chunk"), (dict(backend="gpu"), "backend")])
def test_bad_run_parameters_are_refused(kwargs, match):
    chain = PlanarChain(4, 0.1)
    ctrl = CoordinatingController(chain, Line(), 2.0, 0.1)
    args = {"duration": 1.0, "step": 1e-3, **kwargs}
    with pytest.raises(ConfigError, match=match):
        simulate(ctrl, chain.zigzag(1.0), **args)


def test_chunking_does_not_change_the_result():
    chain = PlanarChain(12, 0.1)
    ctrl = CoordinatingController(chain, Line(angle=lambda t: 0.2 * ca.sin(t)), 2.0, 0.1)
    a = simulate(ctrl, chain.zigzag(1.2, 0.05), 0.5, 0.001, chunk=500)
    b = simulate(ctrl, chain.zigzag(1.2, 0.05), 0.5, 0.001, chunk=37)
    np.testing.assert_array_equal(a.q, b.q)
    np.testing.assert_array_equal(a.e, b.e)


def test_progress_bar_reports_each_tenth_on_a_pipe():
    buf = io.StringIO()
    bar = Progress(10.0, stream=buf)
    for k in range(101):
        bar.update(0.1 * k)
    lines = buf.getvalue().splitlines()
    assert len(lines) == 11 and "100.0%" in lines[-1] and "t = 10.00/10.00 s" in lines[-1]


@settings(max_examples=300, deadline=None)
@given(done=st.floats(-5.0, 15.0, allow_nan=False), total=st.floats(1e-3, 1e4), label=st.sampled_from(["run", "sweep", "a b"]))
def test_the_progress_line_is_the_line_tqdm_formats(done, total, label):
    """:func:`bar_line` against tqdm's own ``format_meter`` for the same ``bar_format``, with ``done`` clipped
    to [0, total] as the bar clips it (tqdm drops the bar past 100 %), on hand-picked edges and random values."""
    from tqdm.std import tqdm

    for d in (done, 0.0, -5e-324, total, total * (1 - 1e-12), total / 30 * 7, total / 3, done * total / 10):
        shown = min(max(0.0, d), total)          # (0.0 first: a -0.0 is shown as 0.0 %)
        expected = tqdm.format_meter(shown, total, 0.0, prefix=label, ascii=" #", bar_format=LINE, status="S")
        assert bar_line(label, d, total, "S") == expected


def test_a_run_loads_no_progress_library():
    """The bar is formatted here, not by tqdm (30 ms of imports, a tenth of a 30 s command)."""
    code = ("import sys; from coordarm.simulation.progress import Progress; import io; b = Progress(1.0, stream=io.StringIO()); "
            "[b.update(k / 10) for k in range(11)]; print(sorted(m for m in ('tqdm', 'logging', 'importlib.metadata') if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "[]"


def test_the_interpreted_chunk_function_is_built_once_per_step_and_does_not_keep_its_controller_alive():
    import gc
    import weakref

    from coordarm.simulation.run import chunk_function

    chain = PlanarChain(4, 0.1)
    ctrl = CoordinatingController(chain, Line(angle=0.1), 1.0, 0.05)
    fn = chunk_function(ctrl, 0.01, 5)
    assert chunk_function(ctrl, 0.01, 5) is fn and chunk_function(ctrl, 0.02, 5) is not fn
    Q = np.asarray(fn(chain.zigzag(1.2, 0.05), 0.01 * np.arange(5)[None])[0])
    step, q = ctrl.rk4_step(0.01), chain.zigzag(1.2, 0.05)
    for k in range(5):                                           # the chunk is five single steps
        q = np.asarray(step(q, 0.01 * k)[0]).ravel()
        np.testing.assert_allclose(Q[:, k], q, rtol=1e-13, atol=1e-15)
    alive = weakref.ref(ctrl)
    del ctrl, fn, step
    gc.collect()
    assert alive() is None


def test_a_run_from_states_has_no_law_diagnostics_and_keeps_its_rows():
    from coordarm.simulation.run import Run

    t = np.linspace(0.0, 0.3, 4)
    q, u = np.arange(20.0).reshape(4, 5), np.ones((4, 5))
    run = Run.from_states(t, q, u, 0.1 * np.ones(4), links=5, info={"stopped": "completed"})
    assert run.e.shape == run.link_margins.shape == (4, 4) and run.s.shape == run.longitudinal.shape == (4,)
    assert np.isnan(run.e).all() and np.isnan(run.s).all() and np.isnan(run.link_margins).all()
    assert np.isnan(run.longitudinal).all() and run.sigma is None and np.array_equal(run.speed_factor(), np.ones(4))
    head = run.rows(slice(0, 2), dict(run.info, stopped="rail_limit"))
    assert np.array_equal(head.q, q[:2]) and np.array_equal(head.t, t[:2]) and head.info["stopped"] == "rail_limit"
    assert run.info["stopped"] == "completed"


def test_a_stopped_run_holds_only_its_own_rows():
    """A run stopped early keeps arrays of its own length (not views of arrays sized for the whole run)."""
    chain = PlanarChain(8, 0.1)
    ctrl = CoordinatingController(chain, Line(angle=lambda t: 0.3 * ca.sin(t)), 2.0, -0.05)
    with pytest.raises(SingularityError) as info:
        simulate(ctrl, chain.zigzag(1.3), 20.0, 0.001)
    run = info.value.run
    assert len(run.t) < 20000 // 2
    for a in run.array_names():
        v = getattr(run, a)
        assert v.base is None or v.base.shape[0] == len(run.t), a


@pytest.mark.parametrize("preset", ["line", "arc", "hole", "thread", "line3d", "path3d", "port"])
def test_base_offsets_in_one_call_equal_the_offsets_one_time_at_a_time(preset):
    """The mapped offsets the start check uses are the scalar ``base_offset`` values, bit for bit."""
    sc = load_scenario(preset)
    ctrl = sc.controller()
    T = np.linspace(0.0, 40.0, 57)
    np.testing.assert_array_equal(ctrl.base_offsets(T), [ctrl.base_offset(float(t)) for t in T])
