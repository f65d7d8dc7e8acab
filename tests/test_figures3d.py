"""Figures of a spatial run: the PNG files, the drawn chain against the chain's own geometry, the planar case."""
import struct
from types import SimpleNamespace

import numpy as np
import pytest

from coordarm.simulation import figures, figures3d
from coordarm.symbolic.chain import PlanarChain
from coordarm.symbolic.controller import CoordinatingController
from coordarm.symbolic.curves import Line
from coordarm.symbolic.curves3d import Line3D
from coordarm.symbolic.motions import Sinusoid
from coordarm.symbolic.outputs import SPATIAL_RUN_OUTPUTS
from coordarm.symbolic.paths3d import Path3D
from coordarm.symbolic.spatial_chain import SpatialChain
from coordarm.symbolic.spatial_controller import SpatialController

M, XI, H, STEPS = 6, 0.1, 0.01, 40


def closed_loop(ctrl, q0, steps=STEPS, h=H):
    """The closed loop by the controller's RK4 step, as the arrays a Run holds."""
    f = ctrl.rk4_step(h)
    t = np.arange(steps + 1) * h
    q, rows = [np.asarray(q0, float)], []
    for k in range(steps + 1):
        out = f(q[-1], t[k])
        rows.append([np.asarray(v, float).ravel() for v in out[1:]])
        if k < steps:
            q.append(np.asarray(out[0], float).ravel())
    arrays = {name: np.array([r[i] for r in rows]) for i, name in enumerate(SPATIAL_RUN_OUTPUTS)}
    arrays = {k: v[:, 0] if v.shape[1] == 1 else v for k, v in arrays.items()}
    return SimpleNamespace(t=t, q=np.array(q), v_star=np.full(len(t), 0.1), **arrays)


@pytest.fixture(scope="module")
def swing():
    chain = SpatialChain(M, XI)
    curve = Line3D((0.0, 0.0, 0.0), (1, 0, 0), (0, 1, 0), rotation=((0, 1, 0), Sinusoid(0.6, 0.5, 0.1)))
    q0 = chain.zigzag(1.2, (1, 0, 0), (0, 1, 0))
    ctrl = SpatialController(chain, curve, 2.0, 0.1, roll=Sinusoid(0.4, 0.6), start=q0)
    return ctrl, closed_loop(ctrl, q0)


class Recorder(figures3d.Figure):
    """A matplotlib Figure that remembers itself (the figures module makes and saves its own)."""
    made = []

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        Recorder.made.append(self)


@pytest.fixture
def recorded(monkeypatch):
    Recorder.made = []
    monkeypatch.setattr(figures3d, "Figure", Recorder)
    return Recorder.made


def png_size(path):
    data = path.read_bytes()
    assert data[:8] == b"\x89PNG\r\n\x1a\n"
    return struct.unpack(">II", data[16:24])


def drawn(ax, gid):
    """The data of the lines of ``ax`` with ``gid``: (k, 3) arrays on a 3-D axes, (k, 2) on a 2-D one."""
    out = []
    for line in ax.get_lines():
        if line.get_gid() == gid:
            data = line.get_data_3d() if hasattr(line, "get_data_3d") else line.get_data()
            out.append(np.column_stack([np.asarray(c, float) for c in data]))
    return out


def test_the_figures_are_pngs_of_the_expected_size(swing, tmp_path):
    ctrl, run = swing
    paths = figures3d.spatial_figures(run, SimpleNamespace(name="swing", stages=None, thresholds={"link": 0.1}),
                                      ctrl, tmp_path / "swing", outcome="valid")
    assert [p.name for p in paths] == ["swing_stages.png", "swing_tracking.png"]
    assert png_size(paths[0]) == (1430, 770)       # 13 x 7 in at 110 dpi
    assert png_size(paths[1]) == (1100, 1210)      # 10 x 11 in (the legends right of the panels)


def test_drawn_links_are_the_centres_plus_minus_half_a_link_along_d(swing, tmp_path, recorded):
    ctrl, run = swing
    times = [0.0, 0.2, 0.4]
    figures3d.plot_spatial_stages(run, ctrl, tmp_path / "s.png", times=times)
    fig = recorded[0]
    ax3, top, side = fig.axes
    assert ax3.name == "3d"
    rows = [int(np.argmin(np.abs(run.t - t))) for t in times]
    c, d = ctrl.chain.centres_np(run.q[rows]), ctrl.chain.directions_np(run.q[rows])
    for k, (lines3, lines_top, lines_side) in enumerate(zip(drawn(ax3, "links"), drawn(top, "links"),
                                                            drawn(side, "links"))):
        assert lines3.shape == (M + 1, 3)
        np.testing.assert_allclose(lines3[:-1], c[k] - 0.5 * XI * d[k], atol=1e-14)    # each link's start
        np.testing.assert_allclose(lines3[1:], c[k] + 0.5 * XI * d[k], atol=1e-14)     # and its end
        np.testing.assert_allclose(lines_top, lines3[:, [0, 1]], atol=0)
        np.testing.assert_allclose(lines_side, lines3[:, [0, 2]], atol=0)
    assert len(drawn(ax3, "links")) == len(times)
    # equal scales: the 3-D box's aspect is the data box's extents
    lims = np.array([ax3.get_xlim(), ax3.get_ylim(), ax3.get_zlim()])
    aspect = np.asarray(ax3.get_box_aspect(), float)
    np.testing.assert_allclose(aspect / aspect[0], np.diff(lims).ravel() / np.diff(lims[0]), rtol=1e-9)


def test_recorded_contacts_are_ringed_on_their_links_in_all_three_views_and_counted_in_the_title(swing, tmp_path,
                                                                                                  recorded):
    ctrl, run = swing
    k = 17
    contact = {"kind": "self", "time": float(run.t[k]), "links": [2, 5], "value": 0.0, "threshold": 0.0}
    figures3d.spatial_figures(SimpleNamespace(**vars(run), info={"contacts": [contact]}), SimpleNamespace(name="swing"),
                              ctrl, tmp_path / "c", outcome="completed")
    fig = recorded[0]
    ax3, top, side = fig.axes
    at = ctrl.chain.centres_np(run.q[k])[[1, 4]]                   # links 2 and 5 at the contact's time
    (ring3,), (ring_top,), (ring_side,) = drawn(ax3, "contact"), drawn(top, "contact"), drawn(side, "contact")
    np.testing.assert_allclose(ring3, at, atol=1e-14)
    np.testing.assert_allclose(ring_top, at[:, [0, 1]], atol=1e-14)
    np.testing.assert_allclose(ring_side, at[:, [0, 2]], atol=1e-14)
    assert len(drawn(ax3, "links")) == 5                  # four stages (rows 0, 13, 27, 40) and the body at the contact
    assert fig._suptitle.get_text() == "swing: 6 links, universal joints (completed, 1 contact): stages of the motion"
    assert f"contacts: 1, first {run.t[k]:.2f} s" in [t.get_text() for t in fig.legends[0].get_texts()]


def test_the_top_projection_of_a_planar_run_is_the_planar_figure(tmp_path, recorded, monkeypatch):
    rng = np.random.default_rng(3)
    qp = 0.4 * rng.standard_normal((5, M))                 # planar joint angles q_j
    qs = np.zeros((5, 2 * M))
    qs[:, 0::2] = qp                                       # a_j = q_j, b_j = 0
    t = np.linspace(0.0, 1.0, 5)
    common = dict(t=t, s=np.zeros(5), v_star=np.zeros(5))
    run3 = SimpleNamespace(q=qs, **common)
    ctrl3 = SpatialController(SpatialChain(M, XI), Line3D(), 2.0, 0.0, roll=0.0)
    figures3d.plot_spatial_stages(run3, ctrl3, tmp_path / "s3.png", stages=5)
    top = recorded[0].axes[1]

    planar_figs = []
    monkeypatch.setattr(figures, "save_figure", lambda fig, path, **kw: planar_figs.append(fig))
    ctrl2 = CoordinatingController(PlanarChain(M, XI), Line(), 2.0, 0.0)
    run2 = SimpleNamespace(q=qp, s_reference=lambda speeds=None: np.zeros(5), **common)
    figures.plot_stages(run2, ctrl2, tmp_path / "s2.png", stages=5)
    planar = [np.column_stack(line.get_data()) for line in planar_figs[0].axes[0].get_lines()
              if line.get_linestyle() == "-" and len(line.get_xdata()) == M + 1]
    figures.plt.close(planar_figs[0])
    assert len(planar) == 5
    for mine, theirs in zip(drawn(top, "links"), planar):
        np.testing.assert_allclose(mine, theirs, atol=1e-14)
    side = drawn(recorded[0].axes[2], "links")
    assert all(np.all(s[:, 1] == 0) for s in side)         # a planar run stays in z = 0


def test_tracking_series_against_the_run(swing):
    ctrl, run = swing
    ser = figures3d.tracking_series(run, ctrl)
    np.testing.assert_allclose(ser["roll_star"], 0.4 * np.sin(0.6 * run.t), atol=1e-15)
    np.testing.assert_allclose(ser["roll_err"], run.roll - 0.4 * np.sin(0.6 * run.t), atol=1e-12)
    np.testing.assert_allclose(ser["s_err"], run.s - run.s[0] - 0.1 * run.t, atol=1e-12)
    assert np.array_equal(ser["emax"], np.abs(run.e).max(axis=1))
    assert np.array_equal(ser["joint"], run.joint_margins.min(axis=1))
    # the law works: the deviations and the roll error decay like exp(-K t)
    assert ser["emax"][-1] <= 1.01 * ser["emax"][0] * np.exp(-2.0 * run.t[-1])
    assert abs(ser["roll_err"][-1]) <= 1.01 * abs(ser["roll_err"][0]) * np.exp(-2.0 * run.t[-1])


def test_a_bounded_path_is_in_the_view_box(tmp_path, recorded):
    chain = SpatialChain(M, XI)
    curve = Path3D((0, 0, 0), (1, 0, 0), (0, 1, 0), [("line", 0.4), ("arc", 1.2, 0.3, 1.0)])
    q0 = chain.zigzag(1.2, (1, 0, 0), (0, 1, 0))
    ctrl = SpatialController(chain, curve, 2.0, 0.1, start=q0)
    run = closed_loop(ctrl, q0, steps=5)
    figures3d.plot_spatial_stages(run, ctrl, tmp_path / "p.png")
    ax3 = recorded[0].axes[0]
    whole = curve.sample(0.0, n=50, extent=0.0)
    lo, hi = np.array([ax3.get_xlim(), ax3.get_ylim(), ax3.get_zlim()]).T
    assert np.all(whole >= lo) and np.all(whole <= hi)
    for cur in drawn(ax3, "curve"):                       # drawn curves stay inside the box
        inside = cur[np.all(np.isfinite(cur), axis=1)]
        assert len(inside) and np.all(inside >= lo) and np.all(inside <= hi)


def test_a_bounded_obstacle_away_from_the_arm_is_in_the_view_box_and_drawn(swing, tmp_path, recorded):
    from coordarm.simulation.obstacles3d import obstacles3d_from_spec

    ctrl, run = swing
    ball = {"name": "ball", "kind": "sphere", "centre": [0.3, 1.5, 0.4], "radius": 0.1}
    plate = {"name": "wall", "kind": "plate", "point": [0.5, 0, 0], "normal": [1, 0, 0], "thickness": 0.02}
    obstacles = obstacles3d_from_spec([ball, plate])
    figures3d.plot_spatial_stages(run, ctrl, tmp_path / "o.png", obstacles=obstacles)
    ax3 = recorded[0].axes[0]
    lo, hi = np.array([ax3.get_xlim(), ax3.get_ylim(), ax3.get_zlim()]).T
    far = np.array(ball["centre"]) + np.array([[0, 0.1, 0], [0, 0, 0.1], [0, -0.1, 0]])   # points of the sphere
    assert np.all(far >= lo) and np.all(far <= hi)
    lines = [p[np.all(np.isfinite(p), axis=1)] for p in drawn(ax3, "obstacle")]
    assert lines and all(np.all(p >= lo - 1e-12) and np.all(p <= hi + 1e-12) for p in lines if len(p))
    # the unbounded plate is cut to the box, not drawn at its nominal extent
    assert hi[1] - lo[1] < 10
    # each projection names the obstacles above their highest point (the sphere's top: its centre + radius)
    for ax, (a, b) in zip(recorded[0].axes[1:], ((0, 1), (0, 2))):
        names = {t.get_text(): t.xy for t in ax.texts}
        assert set(names) == {"ball", "wall"}
        assert names["ball"][1] == pytest.approx(ball["centre"][b] + ball["radius"], abs=0.01)
        assert names["ball"][0] == pytest.approx(ball["centre"][a], abs=0.02)


def test_earlier_stages_are_lighter_and_the_obstacles_half_transparent(swing, tmp_path, recorded):
    from coordarm.simulation.obstacles3d import obstacles3d_from_spec

    ctrl, run = swing
    ball = obstacles3d_from_spec([{"name": "ball", "kind": "sphere", "centre": [0.3, 0.5, 0.4], "radius": 0.1}])
    figures3d.plot_spatial_stages(run, ctrl, tmp_path / "f.png", times=[0.0, 0.2, 0.4], obstacles=ball)
    for ax in recorded[0].axes:
        alphas = [line.get_color()[3] for line in ax.get_lines() if line.get_gid() == "links"]
        assert alphas[0] < alphas[1] < alphas[2] == 1.0
        assert {line.get_alpha() for line in ax.get_lines() if line.get_gid() == "obstacle"} == {0.5}
