"""The joint named at a blow-up is numbered as the user sees the joints: a rail's ``d`` apart, joints from 1
(planar and universal chains on a rail, a spike put into a real run's control at a known joint)."""
import numpy as np
import pytest

from coordarm.analysis.run_analysis import BLOWUP_FACTOR, analyse_run
from coordarm.analysis.spatial_analysis import analyse_spatial_run
from coordarm.simulation.run import simulate
from coordarm.simulation.scenario import Scenario
from coordarm import CoordinatingController, Path, PlanarChain
from coordarm.symbolic import follow_curve
from test_spatial_rail_run import rail_scenario


@pytest.fixture(scope="module")
def planar_rail_run():
    """16 links on a rail along x (q = (d, theta_1, ..., theta_16)), 0.2 s along a path."""
    chain = PlanarChain(16, 0.1, base="rail", rail_angle=0.0, rail_limits=(0.0, 3.0))
    ctrl = CoordinatingController(chain, Path((-0.2, 0.0), 0.0, [{"line": 0.8}, {"arc": 0.8, "radius": 0.8}]), 2.0, 0.2)
    return ctrl, simulate(ctrl, follow_curve(ctrl, 1.1, d=0.0), 0.2, 0.002, backend="interpreted")


@pytest.fixture(scope="module")
def spatial_rail_run():
    """10 universal joints on a rail (q = (d, a_1, b_1, ..., a_10, b_10)), 0.1 s."""
    scenario = Scenario.from_dict(rail_scenario(run={"duration": 0.1, "step": 0.004}), "rail.toml")
    ctrl = scenario.controller()
    return ctrl, simulate(ctrl, scenario.start(ctrl), scenario.duration, scenario.step, backend="interpreted")


def spiked(u, row, column, size):
    out = np.array(u, dtype=float)
    out[row, column] = size
    return out


@pytest.mark.parametrize("column, joint", [(1, 1), (5, 5), (16, 16)])      # u = (d_dot, u_1, ..., u_16)
def test_a_planar_rail_runs_blow_up_names_the_joint_not_counting_the_rail(planar_rail_run, column, joint):
    ctrl, run = planar_rail_run
    quiet = analyse_run(ctrl, run.t, run.q, run.u, samples=50)
    assert quiet.blowup_time is None and quiet.blowup_link is None
    u = spiked(run.u, 60, column, 1e3 * BLOWUP_FACTOR * quiet.nominal_u)
    a = analyse_run(ctrl, run.t, run.q, u, samples=50)
    assert a.blowup_time == pytest.approx(run.t[60]) and (a.blowup_link, a.blowup_rail) == (joint, False)


def test_a_planar_blow_up_of_the_rail_is_the_rail_not_joint_1(planar_rail_run):
    ctrl, run = planar_rail_run
    nominal = analyse_run(ctrl, run.t, run.q, run.u, samples=50).nominal_u
    a = analyse_run(ctrl, run.t, run.q, spiked(run.u, 60, 0, 1e3 * BLOWUP_FACTOR * nominal), samples=50)
    assert (a.blowup_link, a.blowup_rail) == (None, True)


# u = (d_dot, a_1', b_1', a_2', b_2', ...): columns 1, 2 are joint 1; 19, 20 joint 10; 0 the rail
@pytest.mark.parametrize("column, joint, rail", [(1, 1, False), (2, 1, False), (7, 4, False), (20, 10, False),
                                                 (0, None, True)])
def test_a_spatial_rail_runs_blow_up_names_the_universal_joint_from_1(spatial_rail_run, column, joint, rail):
    ctrl, run = spatial_rail_run
    assert run.u.shape[1] == 21
    quiet = analyse_spatial_run(ctrl, run)
    assert quiet.blowup_time is None and quiet.blowup_joint is None
    run.u, original = spiked(run.u, 10, column, 1e3 * BLOWUP_FACTOR * quiet.nominal_u), run.u
    try:
        a = analyse_spatial_run(ctrl, run)
    finally:
        run.u = original
    assert a.blowup_time == pytest.approx(run.t[10]) and (a.blowup_joint, a.blowup_rail) == (joint, rail)
