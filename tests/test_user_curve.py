"""A user-defined Curve: checked when the controller is built, run, compiled, logged and replayed."""
import casadi as ca
import numpy as np
import pytest

from coordarm import ConfigError, CoordinatingController, Curve, LogError, PlanarChain, load_scenario, simulate
from coordarm.analysis.replay import load
from coordarm.simulation.mcap_writer import RunLogger
from coordarm.generated import compile as compile_controller


class MyLine(Curve):
    """A user's own straight line through the origin at ``angle`` (written without coordarm's Line)."""

    def __init__(self, angle):
        self.angle = angle

    def phi(self, y, t):
        return -ca.sin(self.angle) * y[0] + ca.cos(self.angle) * y[1]

    def psi(self, y, t):
        return ca.cos(self.angle) * y[0] + ca.sin(self.angle) * y[1]

    def sample(self, t, n=400, extent=10.0):
        s = np.linspace(-extent, extent, n)
        return s[:, None] * np.array([np.cos(self.angle), np.sin(self.angle)])


class Stretched(MyLine):
    def psi(self, y, t):
        return 2 * super().psi(y, t)


class NoSample(Curve):
    def phi(self, y, t):
        return y[1]

    def psi(self, y, t):
        return y[0]


def test_a_user_curve_runs_compiles_and_matches_the_built_in_line():
    from coordarm import Line
    chain = PlanarChain(8, 0.1)
    mine = CoordinatingController(chain, MyLine(0.3), 2.0, 0.1)
    ref = CoordinatingController(chain, Line(angle=0.3), 2.0, 0.1)
    q = chain.zigzag(1.2, 0.3) + 0.01
    np.testing.assert_allclose(mine.control(q), ref.control(q), rtol=1e-13, atol=1e-15)
    np.testing.assert_allclose(compile_controller(mine).control(q), ref.control(q), rtol=1e-12, atol=1e-14)


def test_a_user_curve_that_is_not_orthonormalised_is_refused_when_the_controller_is_built():
    with pytest.raises(ConfigError, match=r"curve: user-defined Stretched: curve is not orthonormalised"):
        CoordinatingController(PlanarChain(4, 0.1), Stretched(0.2), 2.0, 0.1)
    with pytest.raises(ConfigError, match=r"must implement sample"):
        CoordinatingController(PlanarChain(4, 0.1), NoSample(), 2.0, 0.1)


def test_the_log_records_a_user_curve_and_replay_needs_it_passed_in(tmp_path):
    scenario = load_scenario("line").with_overrides(links=8, duration=0.2, step=0.01)
    chain = scenario.chain()
    ctrl = CoordinatingController(chain, MyLine(0.0), 2.0, 0.1)
    out = tmp_path / "user.mcap"
    with RunLogger(out, scenario, ctrl) as log:
        run = simulate(ctrl, chain.zigzag(1.3), 0.2, 0.01, on_chunk=log.on_chunk)
    with pytest.raises(LogError, match=r"user-defined curve \(test_user_curve.MyLine\).*pass the curve"):
        load(out)
    rep = load(out, curve=MyLine(0.0))
    assert rep.scenario_dict["curve"] == {"kind": "user-defined", "class": "test_user_curve.MyLine"}
    np.testing.assert_allclose(rep.q, run.q)
    assert isinstance(rep.controller().curve, MyLine)
