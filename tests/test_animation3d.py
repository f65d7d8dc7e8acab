"""The GIF of a spatial run (``coordarm replay`` of a universal chain's log): its frames, and that they show the arm
where the chain is (link centres and the end point projected with the frame's camera, read in the GIF's pixels)."""
import numpy as np
import pytest
from matplotlib.colors import to_rgb
from mpl_toolkits.mplot3d import proj3d
from PIL import Image

import coordarm
from coordarm.analysis.animation3d import ARM_COLOUR, animate3d, spatial_frame_scene, spatial_view_figure
from coordarm.analysis.replay import load
from coordarm.cli import main


@pytest.fixture(scope="module", params=["line3d", "pipe3d"])
def logged(request, tmp_path_factory):
    """A real 1 s run of a preset (line3d: a fixed base; pipe3d: on a rail, inside obstacles) and its log."""
    path = tmp_path_factory.mktemp(request.param) / f"{request.param}.mcap"
    coordarm.run_scenario(request.param, duration=1.0, log=path, figures=False)
    return load(path)


def pixels(ax, points, height):
    """(col, row) of the 3-D ``points`` (k, 3) [m] in the frame (rows from the top), with ``ax``'s camera."""
    x, y, _ = proj3d.proj_transform(*points.T, ax.get_proj())
    xy = ax.transData.transform(np.column_stack([x, y]))
    return np.column_stack([xy[:, 0], height - xy[:, 1]]).round().astype(int)


def is_arm(frame, cols_rows, reach=1):
    """Whether a pixel of the arm's colour lies within ``reach`` pixels of each (col, row)."""
    rgb = np.asarray(frame.convert("RGB"), float)
    arm = np.linalg.norm(rgb - 255 * np.array(to_rgb(ARM_COLOUR)), axis=-1) < 40
    return np.array([arm[r - reach:r + reach + 1, c - reach:c + reach + 1].any() for c, r in cols_rows])


def test_the_gif_has_one_frame_per_sampled_time_and_each_shows_the_arm_where_the_chain_is(logged, tmp_path):
    gif = animate3d(logged, tmp_path / "a.gif", fps=15, progress=False)
    image = Image.open(gif)
    assert image.n_frames == 16                       # 1 s at 15 frames/s: t = 0, 1/15, ..., 1
    assert abs(image.info["duration"] - 1000 / 15) < 10       # GIF delays are in 10 ms
    assert gif.stat().st_size < 400_000
    rows = np.searchsorted(logged.t, np.linspace(0.0, 1.0, 16))
    ctrl = logged.controller()
    fig, ax = spatial_view_figure(spatial_frame_scene(logged, ctrl, rows))
    assert image.size == tuple(fig.canvas.get_width_height())
    width, height = image.size
    background = Image.fromarray(np.asarray(fig.canvas.buffer_rgba())[..., :3])
    for k in (0, 8, 15):
        q = logged.q[rows[k]]
        centres = ctrl.chain.centres_np(q)                                    # (m, 3), not the drawn polyline
        end = centres[-1] + 0.5 * ctrl.chain.xi * ctrl.chain.directions_np(q)[-1]
        at = pixels(ax, np.vstack([centres, end]), height)
        assert np.all((at >= 2) & (at < [width - 2, height - 2]))           # the whole arm is in the frame
        image.seek(k)
        shown = is_arm(image, at)
        assert shown.mean() >= 0.95 and shown[-1], (k, shown.mean())
        assert is_arm(background, at).mean() <= 0.05                          # no arm there without the frame's


def test_the_frames_are_sped_up_to_at_most_max_frames(logged, tmp_path):
    assert Image.open(animate3d(logged, tmp_path / "b.gif", fps=30, max_frames=10, progress=False)).n_frames == 10


def test_replay_of_a_spatial_log_writes_its_gif(logged, tmp_path, capsys):
    assert main(["replay", str(logged.path), "--out", str(tmp_path), "--fps", "2"]) == 0
    gif = tmp_path / f"{logged.path.stem}.gif"
    assert f"animation     {gif}" in capsys.readouterr().out.splitlines()
    assert Image.open(gif).n_frames == 3                # 1 s at 2 frames/s


def test_a_recorded_contact_is_ringed_where_its_link_was_from_its_time_on(logged, tmp_path):
    rows = np.searchsorted(logged.t, np.linspace(0.0, 1.0, 6))
    when, link = float(logged.t[rows[2]]) - 1e-3, 3                  # between frames 1 and 2
    logged.outcome = dict(logged.outcome, contacts=[{"kind": "self", "time": when, "links": [link, link + 2]}])
    try:
        image = Image.open(animate3d(logged, tmp_path / "c.gif", fps=5, progress=False))
    finally:
        logged.outcome.pop("contacts")
    ctrl = logged.controller()
    fig, ax = spatial_view_figure(spatial_frame_scene(logged, ctrl, rows), contacts=True)
    at = pixels(ax, ctrl.chain.centres_np(logged.q[np.argmin(np.abs(logged.t - when))])[[link - 1]], image.size[1])[0]

    def red_near(k):
        image.seek(k)
        rgb = np.asarray(image.convert("RGB"), float)
        red = np.linalg.norm(rgb - [214, 39, 40], axis=-1) < 40
        return red[at[1] - 12:at[1] + 13, at[0] - 12:at[0] + 13].sum()

    assert red_near(1) == 0 and red_near(2) > 20 and red_near(5) > 20
