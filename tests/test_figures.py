"""The planar stage figure: the stop is drawn, contacts are marked, stages that lie on top of each other get rows."""
import numpy as np
import pytest
from matplotlib.colors import to_hex
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


def test_each_panel_marks_only_the_contacts_of_its_phase(short_run, captured, tmp_path):
    scenario, ctrl, run = short_run
    ka, kb = len(run.t) // 4, 3 * len(run.t) // 4
    run.info = dict(getattr(run, "info", None) or {}, contacts=[
        {"kind": "wall", "time": float(run.t[ka]), "links": [2], "obstacle": "wall 5"},
        {"kind": "self", "time": float(run.t[kb]), "links": [3, 5]}])
    panels = [{"title": "(a)", "stages": [0.0, 0.5]}, {"title": "(b)", "stages": [0.6, 1.0]}]
    try:
        figures.plot_panels(run, ctrl, tmp_path / "p.png", panels, obstacles=scenario.obstacles)
    finally:
        run.info.pop("contacts")
    fig, = captured
    rings = [[ln for ln in ax.get_lines() if ln.get_marker() == "o" and isinstance(ln.get_markerfacecolor(), str)
              and ln.get_markerfacecolor() == "none"] for ax in fig.axes]
    np.testing.assert_allclose(np.column_stack(rings[0][0].get_data()), ctrl.chain.centres_np(run.q[ka])[[1]])
    np.testing.assert_allclose(np.column_stack(rings[1][0].get_data()), ctrl.chain.centres_np(run.q[kb])[[2, 4]])
    assert len(rings[0]) == len(rings[1]) == 1
    assert [t.get_text() for t in fig.axes[1].texts if to_hex(t.get_color()) == figures.STOP_COLOR] == ["self"]
    legend = [t.get_text() for t in fig.legends[0].get_texts()]
    assert legend[0] == f"contacts: 2, first {run.t[ka]:.2f} s"


def test_the_reference_decay_ends_at_the_floor_and_is_absent_for_a_start_at_rounding_level():
    t = np.linspace(0.0, 20.0, 2001)
    ref = figures.decay_reference(t, -1e-2, 2.0)
    below = t > np.log(1e-2 / figures.FLOOR) / 2.0            # where 1e-2 exp(-2 t) < 1e-17, solved by hand
    assert np.isnan(ref[below]).all() and below.any()
    np.testing.assert_allclose(ref[~below], 1e-2 * np.exp(-2.0 * t[~below]), rtol=1e-12)
    assert figures.decay_reference(t, 2e-16, 2.0) is None


def test_the_tracking_figure_draws_no_reference_on_the_floor(short_run, captured, tmp_path):
    scenario, ctrl, run = short_run
    figures.plot_tracking(run, 40.0, tmp_path / "t.png")      # K = 40/s: e(0) exp(-K t) reaches 1e-17 within 1 s
    ax = captured[0].axes[0]
    ref, = [ln for ln in ax.get_lines() if ln.get_label().startswith("e(0) exp(")]
    y = np.asarray(ref.get_ydata(), float)
    assert np.isnan(y).any() and np.nanmin(y) >= figures.FLOOR
    legend = ax.get_legend()
    assert legend.get_window_extent().x0 >= ax.get_window_extent().x1      # the legend stands right of the data


def test_the_report_step_responses_keep_their_legend_beside_the_curves(captured, tmp_path):
    from coordarm.analysis.report_figures import plot_step_responses

    plot_step_responses(2.0, 0.1, tmp_path / "s.png", title="x")
    fig, = captured
    ax = fig.axes[0]
    assert ax.get_legend().get_window_extent().x0 >= ax.get_window_extent().x1
    assert ax.get_xlabel() == "t [s]" and ax.get_ylabel().endswith("[-]")


def test_a_long_walls_label_stands_a_quarter_along_it_off_the_wall_and_inside_the_view():
    import matplotlib.pyplot as plt

    from coordarm.simulation.obstacles import outline

    obstacles = load_scenario("pipe").obstacles
    fig, ax = plt.subplots()
    try:
        figures.draw_obstacles(ax, obstacles)
        labels = {t.get_text(): t for t in ax.texts}
        for ob, above in zip(obstacles, (True, False)):      # the left wall (upper) and the right wall (lower)
            pts = outline(ob)
            x, y = labels[ob.name].xy
            lo, hi = pts[:, 0].min(), pts[:, 0].max()
            assert abs(x - (lo + 0.25 * (hi - lo))) < 0.05 * (hi - lo)
            a, b = pts, np.roll(pts, -1, axis=0)             # the outline's edges that cross the label's x
            cross = (a[:, 0] - x) * (b[:, 0] - x) <= 0
            ys = a[cross, 1] + (x - a[cross, 0]) / (b[cross, 0] - a[cross, 0]) * (b[cross, 1] - a[cross, 1])
            assert y == pytest.approx(ys.max() if above else ys.min(), abs=1e-3)
            assert labels[ob.name].xyann[1] * (1 if above else -1) > 0     # written beside it, away from the bore
    finally:
        plt.close(fig)


def test_time_labels_of_end_points_close_together_are_moved_apart(short_run, captured, tmp_path):
    scenario, ctrl, run = short_run
    figures.plot_stages(run, ctrl, tmp_path / "s.png", times=[0.0, 0.3, 0.6])
    ax = captured[0].axes[0]
    ends = ctrl.chain.joints_np(run.q[figures.stage_indices(run, times=[0.0, 0.3, 0.6])])[:, -1]
    extent = np.hypot(np.ptp(ax.get_xlim()), np.ptp(ax.get_ylim()))
    assert np.all(np.hypot(*(ends[1:] - ends[0]).T) < 0.05 * extent)          # all three end points close
    offsets = [t.xyann[1] for t in ax.texts if t.get_text().endswith(" s")]
    assert offsets == [4, -10 - 9, 4 + 18]          # up, down one step further, up two steps further
