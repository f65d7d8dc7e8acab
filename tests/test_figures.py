"""The planar stage figure: the stop is drawn, contacts are marked, stages that lie on top of each other get rows."""
import numpy as np
import pytest
from matplotlib.figure import Figure

from coordarm.simulation import figures
from coordarm.simulation.run import simulate
from coordarm.simulation.scenario import load_scenario


@pytest.fixture
def captured(monkeypatch):
    """The figures that ``save_figure`` is given, instead of writing them."""
    seen = []
    monkeypatch.setattr(Figure, "savefig", lambda fig, *a, **k: seen.append(fig))
    return seen


@pytest.fixture(scope="module")
def short_run():
    scenario = load_scenario("hole").with_overrides(links=6, duration=1.0)
    ctrl = scenario.controller()
    return scenario, ctrl, simulate(ctrl, scenario.start(ctrl), scenario.duration, scenario.step, backend="interpreted")


def _labels(fig):
    return [line.get_label() for ax in fig.axes for line in ax.get_lines()]


def test_a_stopped_run_draws_its_last_configuration_red_and_labelled_even_with_stages_beyond_it(short_run, captured,
                                                                                               tmp_path):
    scenario, ctrl, run = short_run
    figures.plot_stages(run, ctrl, tmp_path / "s.png", times=[0.0, 4.0, 8.0, 12.0], obstacles=scenario.obstacles,
                        stopped=True)
    fig, = captured
    ax = fig.axes[0]
    stop = [ln for ln in ax.get_lines() if ln.get_label().startswith("stop at t = ")]
    assert len(stop) == 1 and stop[0].get_label() == f"stop at t = {run.t[-1]:.2f} s"
    xy = np.column_stack(stop[0].get_data())
    np.testing.assert_allclose(xy, ctrl.chain.joints_np(run.q[-1]), atol=1e-12)
    assert ax.get_xlabel() == "y$_1$ [m]" and ax.get_ylabel() == "y$_2$ [m]"
    # a completed run draws no stop
    captured.clear()
    figures.plot_stages(run, ctrl, tmp_path / "c.png", times=[0.0, 0.5], obstacles=scenario.obstacles)
    assert not any(label.startswith("stop") for label in _labels(captured[0]))


def test_contacts_are_marked_on_their_links_at_their_time(short_run, captured, tmp_path):
    scenario, ctrl, run = short_run
    k = len(run.t) // 2
    run.info = dict(getattr(run, "info", None) or {}, contacts=[
        {"kind": "wall", "time": float(run.t[k]), "links": [3], "value": 0.0, "threshold": 0.01,
         "obstacle": "wall 5"}])
    try:
        figures.plot_stages(run, ctrl, tmp_path / "s.png", obstacles=scenario.obstacles)
    finally:
        run.info.pop("contacts")
    ax = captured[0].axes[0]
    mark, = [ln for ln in ax.get_lines() if ln.get_label() == f"contacts: 1, first {run.t[k]:.2f} s"]
    assert "wall 5" in [t.get_text() for t in ax.texts]
    np.testing.assert_allclose(np.column_stack(mark.get_data()), ctrl.chain.centres_np(run.q[k])[[2]], atol=1e-12)


def test_stage_overlap_counts_the_joints_that_lie_on_the_previous_stage():
    xi = 0.1
    a = np.column_stack([np.arange(11) * xi, np.zeros(11)])
    assert figures.stage_overlap(np.stack([a, a]), xi) == 1.0
    assert figures.stage_overlap(np.stack([a, a + [0.0, 5.0]]), xi) == 0.0
    shifted = a + [0.5 + 2.5 * xi, 0.0]        # joints 0..4 of the later stage lie within 2 xi of the first
    expected = np.mean([min(np.hypot(*(p - a).T)) <= 2 * xi for p in shifted])
    assert figures.stage_overlap(np.stack([a, shifted]), xi) == pytest.approx(expected) and 0 < expected < 1


def test_the_stages_of_a_body_fed_along_a_flat_path_are_drawn_one_per_row(captured, tmp_path):
    scenario = load_scenario("pipe").with_overrides(duration=0.6)
    ctrl = scenario.controller()
    run = simulate(ctrl, scenario.start(ctrl), scenario.duration, scenario.step, backend="interpreted")
    figures.plot_stages(run, ctrl, tmp_path / "p.png", stages=3, obstacles=scenario.obstacles)
    fig, = captured
    assert len(fig.axes) == 3 and [ax.get_title(loc="left") for ax in fig.axes] == \
        [f"t = {t:.1f} s" for t in run.t[figures.stage_indices(run, 3)]]
    assert len({ax.get_xlim() for ax in fig.axes}) == 1      # one shared view
