"""A run that keeps only some rows in memory still summarises every step: the s tracking error and the
governed time accumulated chunk by chunk (:mod:`coordarm.simulation.every_step`) against the same run with
every row kept, and the extreme rows each chunk keeps against brute-force maxima over every row."""
import numpy as np
import pytest

from coordarm.simulation.every_step import STracking, summary_rows
from coordarm.simulation.choices import SUMMARY_ROWS
from coordarm.simulation.run import simulate
from coordarm.simulation.scenario import load_scenario
from coordarm.simulation.session import run_scenario
from coordarm.simulation.summary import summary_lines
from coordarm.symbolic import CoordinatingController, Line, PlanarChain


def pushed(governor: bool = True) -> CoordinatingController:
    """10 links pushed at 0.2 m/s along a line: the governor slows v* from about 2.5 s on."""
    return CoordinatingController(PlanarChain(10, 0.1), Line(angle=0.02), 2.0, 0.2, governor=governor)


def every_row_and_thinned(ctrl, q0, duration, keep, chunk=700):
    """The same simulation twice: every row kept (unlogged), and streamed chunk by chunk (``on_chunk``)
    keeping about ``keep`` rows; returns both runs and the streamed chunks."""
    full = simulate(ctrl, q0, duration, 0.001, backend="compiled", chunk=chunk)
    parts = []
    thin = simulate(ctrl, q0, duration, 0.001, backend="compiled", chunk=chunk, on_chunk=parts.append, keep=keep)
    return full, thin, parts


def test_the_s_tracking_maximum_over_every_step_is_the_every_row_runs_to_the_bit_and_survives_thinning():
    ctrl = pushed()
    full, thin, parts = every_row_and_thinned(ctrl, ctrl.chain.zigzag(1.2), 6.0, keep=300)
    assert len(thin.t) < len(full.t) // 10 and full.info["kept_every"] == 1
    brute = np.abs(full.s - full.s_reference(ctrl.speeds))      # Run.s_reference over every row
    assert full.speed_factor().min() < 0.5                      # governed: the reference is v_scale v*
    for run in (full, thin):
        assert run.info["max_s_tracking_error"] == np.max(brute)       # bitwise
        assert run.info["max_s_tracking_error_time"] == full.t[np.argmax(brute)]
        assert run.summary()["max_s_tracking_error"] == np.max(brute)
    # the thinned rows alone would give another (smaller or inexact) value: the info is what counts
    assert np.max(np.abs(thin.s - thin.s_reference(ctrl.speeds))) != np.max(brute)
    tracking = STracking(ctrl.speeds)
    for part in parts:
        tracking.add(part)
    assert tracking.info()["max_s_tracking_error"] == np.max(brute)


def test_the_governed_time_is_counted_over_every_step_not_over_the_kept_rows():
    ctrl = pushed()
    full, thin, _ = every_row_and_thinned(ctrl, ctrl.chain.zigzag(1.2), 6.0, keep=300)
    steps = np.count_nonzero(full.speed_factor() < 1)
    assert steps > 1000
    assert full.info["governed"] == pytest.approx(0.001 * steps, rel=1e-12)
    assert thin.info["governed"] == full.info["governed"]
    assert full.governed_time() == pytest.approx(full.info["governed"], rel=1e-9)   # the rows' own count


def test_each_chunk_keeps_the_row_of_the_largest_joint_against_its_limit():
    sc = load_scenario("thread").with_overrides(None, 4.0, None)
    ctrl = sc.controller()
    full, thin, parts = every_row_and_thinned(ctrl, sc.start(ctrl), sc.duration, keep=50)
    chain = ctrl.chain
    ratio = lambda q: np.max(np.abs(chain.revolute(q)[:, 1:]) / chain.joint_limits, axis=1)   # noqa: E731
    assert np.max(ratio(thin.q)) == np.max(ratio(full.q))
    for part in parts:
        (row,) = summary_rows(part, chain)
        assert ratio(part.q)[row] == np.max(ratio(part.q))
    lines = lambda run: [x for x in summary_lines(run, sc) if x.startswith(("joints", "s tracking"))]  # noqa: E731
    assert lines(thin) == lines(full)


def test_a_spatial_chunk_keeps_the_row_of_its_largest_roll_tracking_error():
    sc = load_scenario("path3d").with_overrides(8, 1.0, None)
    ctrl = sc.controller()
    full, thin, parts = every_row_and_thinned(ctrl, sc.start(ctrl), sc.duration, keep=20, chunk=200)
    assert thin.summary()["max_roll_tracking_error"] == full.summary()["max_roll_tracking_error"]
    assert thin.summary()["max_s_tracking_error"] == full.summary()["max_s_tracking_error"]
    wrapped = np.abs(np.angle(np.exp(1j * (full.extra["roll"] - full.extra["roll_star"]))))
    assert full.summary()["max_roll_tracking_error"] == np.max(wrapped)
    for part in parts:
        (row,) = summary_rows(part, ctrl.chain)
        err = np.abs(np.angle(np.exp(1j * (part.extra["roll"] - part.extra["roll_star"]))))
        assert err[row] == np.max(err)


def test_a_run_without_figures_keeps_fewer_rows_and_prints_the_same_summary(tmp_path):
    with_figures = run_scenario("line", duration=3.0, log=tmp_path / "a.mcap", figures=True, stages=[0.0])
    without = run_scenario("line", duration=3.0, log=tmp_path / "b.mcap", figures=False)
    assert len(without.run.t) <= SUMMARY_ROWS + 50 < len(with_figures.run.t)
    keep = [x for x in with_figures.lines if not x.startswith(("log ", "figure", "library"))]
    assert [x for x in without.lines if not x.startswith(("log ", "figure", "library"))] == keep


@pytest.mark.parametrize("log_rate", [None, 100.0, 1.0])
def test_a_run_checks_the_arm_at_200_hz_whatever_the_log_rate(tmp_path, monkeypatch, log_rate):
    """The physical checks' stride is CHECK_RATE's, not the log's (a 1 Hz log once meant 1 Hz checks,
    between which a passing contact went unseen)."""
    import coordarm.simulation.run as run_module
    from coordarm.simulation.run import CHECK_RATE, check_stride

    strides, real = [], run_module.simulate

    def observed(*args, **kwargs):
        strides.append(kwargs["check_every"])
        return real(*args, **kwargs)

    monkeypatch.setattr(run_module, "simulate", observed)
    result = run_scenario("line", duration=0.5, log=tmp_path / "c.mcap", figures=False, log_rate=log_rate)
    assert result.exit_status == 0 and strides == [check_stride(0.001)] == [round(1 / (CHECK_RATE * 0.001))]
    assert check_stride(0.1) == 1           # a step longer than the check period: every step


def test_a_tracking_error_that_turns_non_finite_is_kept_as_nan_from_its_row_on():
    ctrl = pushed(False)
    full = simulate(ctrl, ctrl.chain.zigzag(1.2), 1.0, 0.001, backend="compiled")
    first, second = full.rows(slice(0, 400)), full.rows(slice(400, 800))
    second.s = second.s.copy()
    second.s[50] = np.inf
    tracking = STracking()
    with np.errstate(all="raise"):                     # and no floating-point warning on the way
        for part in (first, second, full.rows(slice(800, None))):
            tracking.add(part)
    assert np.isnan(tracking.max) and tracking.time == second.t[50]


@pytest.mark.parametrize("preset", ["path3d", "thread"])
def test_the_s_reference_is_the_exact_integral_of_a_speed_ramp_and_the_law_tracks_it_to_rounding(preset):
    """A smoothstep speed ramp (cubic in t): Simpson's rule with v* at each step's middle integrates it
    exactly, against scipy's adaptive quadrature of v*; the trapezoidal rule is off by O(step^2), which the
    summary used to report as the law's s tracking error (3e-8 m on path3d, 8e-8 m on thread)."""
    from scipy.integrate import quad

    sc = load_scenario(preset).with_overrides(None, 2.0, None)
    ctrl = sc.controller()
    run = simulate(ctrl, sc.start(ctrl), sc.duration, sc.step, sc.t0, backend="compiled", thresholds=sc.thresholds)
    assert run.speed_factor().min() == 1.0                               # ungoverned: v_scale v* = v*
    rows = np.linspace(0, len(run.t) - 1, 40).astype(int)
    exact = np.array([run.s[0] + quad(lambda x: float(ctrl.speed_at(x)), run.t[0], run.t[k], limit=200,
                                      epsabs=1e-14, epsrel=1e-14)[0] for k in rows])
    simpson, trapezoid = run.s_reference(ctrl.speeds)[rows], run.s_reference()[rows]
    # (up to the rounding of summing 1000-2000 steps of ~1e-4 m onto s ~ 3 m: ~1e-14)
    np.testing.assert_allclose(simpson, exact, rtol=0, atol=1e-13)
    assert np.max(np.abs(trapezoid - exact)) > 1e-9                     # the ramp is not affine
    assert run.info["max_s_tracking_error"] < 1e-12
    assert run.info["max_s_tracking_error"] == np.max(np.abs(run.s - run.s_reference(ctrl.speeds)))
