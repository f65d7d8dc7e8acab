"""``simulate_baseline`` refuses a bad simulated time, step or start time with a ConfigError naming it, like
``simulate`` (before: a ZeroDivisionError, a silent empty run, or a run of the wrong length)."""
import numpy as np
import pytest

from coordarm.analysis.baselines import EndPointRate, simulate_baseline
from coordarm.simulation.run import simulate
from coordarm.symbolic import ConfigError, CoordinatingController, Line, PlanarChain

BAD = [(1.0, 0.0, 0.0, r"^step: must be > 0, got 0.0$"),
       (1.0, -0.01, 0.0, r"^step: must be > 0"),
       (1.0, float("nan"), 0.0, r"^step: need a finite number, got nan$"),
       (float("inf"), 0.01, 0.0, r"^duration: need a finite number, got inf$"),
       (-1.0, 0.01, 0.0, r"^duration: must be > 0, got -1.0$"),
       (0.0, 0.01, 0.0, r"^duration: must be > 0"),
       ("1", 0.01, 0.0, r"^duration: need a finite number, got '1'$"),
       (0.01, 0.1, 0.0, r"^step: 0.1 s is longer than the duration 0.01 s$"),
       (1.0, 0.01, float("nan"), r"^t0: need a finite number, got nan$")]


@pytest.fixture(scope="module")
def law():
    ctrl = CoordinatingController(PlanarChain(6, 0.1), Line(), 1.0, 0.1)
    return EndPointRate(ctrl, ctrl.chain.zigzag(1.0))


@pytest.mark.parametrize("duration, step, t0, match", BAD)
def test_a_bad_duration_step_or_start_is_a_config_error_naming_it(law, duration, step, t0, match):
    with pytest.raises(ConfigError, match=match):
        simulate_baseline(law, law.ctrl.chain.zigzag(1.0), duration, step, t0)
    with pytest.raises(ConfigError, match=match):                 # the same words as the coordinating law's run
        simulate(law.ctrl, law.ctrl.chain.zigzag(1.0), duration, step, t0)


def test_good_settings_still_run(law):
    run = simulate_baseline(law, law.ctrl.chain.zigzag(1.0), 0.05, 0.01, 0.5)
    np.testing.assert_allclose(run.t, 0.5 + 0.01 * np.arange(6))
