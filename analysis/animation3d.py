"""Animation of a replayed spatial run (universal joints) as a GIF: the chain in a 3-D perspective view.

Each frame shows the links, the curve at that time, the end point's target, the rail and the base on it
(when there is one), the obstacles and the recorded contacts so far (as on the planar GIF), drawn by the stage figure's helpers of
:mod:`coordarm.simulation.figures3d`; the camera is fixed and framed on the whole motion (equal scales on
x, y, z). Frames are sampled like the planar GIF's (:func:`coordarm.analysis.animation.frame_indices`).
"""
from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from PIL import Image

from coordarm.simulation.contact_marks import CONTACT_COLOUR, CONTACT_STYLE, contact_marks, draw_contact_marks
from coordarm.simulation.figures3d import draw_stage, draw_view3d, stage_scene

from .animation import FrameProgress, frame_contacts, frame_indices
from .replay import Replay

#: Colour of the chain, its curve and target in every frame (the planar GIF's arm colour).
ARM_COLOUR = "tab:blue"
#: Size of a frame [inch] at :data:`DPI` (600 x 500 pixels).
FRAME_SIZE = (6.0, 5.0)
#: Dots per inch of a frame.
DPI = 100


def spatial_frame_scene(replay: Replay, ctrl: Any, idx: np.ndarray) -> dict[str, Any]:
    """What each frame draws (see :func:`coordarm.simulation.figures3d.stage_scene`), one stage per frame.

    Parameters
    ----------
    replay : Replay
        The loaded log of a spatial run.
    ctrl : SpatialController
        Its controller.
    idx : ndarray of int, shape (F,)
        Sample rows of the frames.

    Returns
    -------
    dict
        ``joints`` (F, m+1, 3), ``curves``, ``targets``, ``lo``, ``hi`` (the view box over the whole run) [m],
        ``obstacles``, ``bases``, ``rail``.
    """
    return stage_scene(replay.to_run(), ctrl, idx, tuple(replay.scenario.obstacles))


def spatial_view_figure(scene: dict[str, Any], contacts: bool = False) -> tuple[Figure, Any]:
    """The fixed frame of the animation: the axes, the obstacles, the rail (or the base) and a legend; no stage.

    Parameters
    ----------
    scene : dict
        From :func:`spatial_frame_scene`.
    contacts : bool
        The run recorded contacts: the legend names their rings.

    Returns
    -------
    fig : Figure
        The figure, :data:`FRAME_SIZE` at :data:`DPI`, drawn once (its camera projection is set).
    ax : Axes3D
        The perspective axes (equal scales, labelled ``x [m]``, ``y [m]``, ``z [m]``).
    """
    fig = Figure(figsize=FRAME_SIZE, dpi=DPI)
    FigureCanvasAgg(fig)
    ax = fig.add_axes((0.0, 0.06, 0.97, 0.88), projection="3d")
    draw_view3d(ax, {**scene, "joints": [], "curves": []}, np.empty((0, 4)), [])   # the box, camera, labels
    ax.set_box_aspect(tuple(scene["hi"] - scene["lo"]), zoom=0.92)     # room for the z label in the frame
    handles = [Line2D([], [], color=ARM_COLOUR, lw=2.5), Line2D([], [], ls="--", color=ARM_COLOUR, lw=1.0)]
    names = ["links (dot: end point)", "curve at that time"]
    if scene["targets"] is not None:
        handles.append(Line2D([], [], ls="", marker="x", color=ARM_COLOUR, ms=7, mew=2))
        names.append("target s*(t)")
    rail = scene.get("rail") is not None
    handles.append(Line2D([], [], color="0.35", lw=3.0, alpha=0.6) if rail
                   else Line2D([], [], ls="", marker="s", color="k", ms=6))
    names.append("rail (square: the base)" if rail else "base")
    if scene.get("obstacles"):
        handles.append(Line2D([], [], color="0.4", lw=0.8))
        names.append("obstacles")
    if contacts:
        handles.append(Line2D([], [], **CONTACT_STYLE))
        names.append("contact (links red: a new one)")
    fig.legend(handles, names, loc="lower left", fontsize=7, frameon=True, ncols=2)
    fig.canvas.draw()
    return fig, ax


def stage_artists(ax: Any, scene: dict[str, Any], i: int, colour: Any = ARM_COLOUR) -> list[Any]:
    """Draw frame ``i``'s moving parts (curve, links, joints, end point, target, base on the rail); return them.

    Parameters
    ----------
    ax : Axes3D
        From :func:`spatial_view_figure`.
    scene : dict
        From :func:`spatial_frame_scene`.
    i : int
        Frame number.
    colour : colour
        Of the links, the curve and the target (red in the frame of a new contact).

    Returns
    -------
    list of Artist
        The artists added (remove them before the next frame).
    """
    before = set(ax.lines)
    draw_stage(ax, scene, i, colour, "", (0, 1, 2))
    return [a for a in ax.lines if a not in before]


def animate3d(replay: Replay, path: str | Path, fps: float = 15.0, max_frames: int = 200, ctrl: Any = None,
              progress: bool = True) -> Path:
    """Write a GIF of the spatial run in ``replay`` to ``path``: the chain in perspective, one frame per sampled time.

    Parameters
    ----------
    replay : Replay
        The loaded log of a spatial run (universal joints, on a fixed base or a rail).
    path : str or Path
        GIF to write.
    fps : float
        Frames per second of the GIF (real time when at most ``max_frames`` frames, else sped up).
    max_frames : int
        Most frames.
    ctrl : SpatialController, optional
        The run's controller (rebuilt from the log if None).
    progress : bool
        Show a progress bar on stderr while rendering.

    Returns
    -------
    Path
        The written file (``len(frame_indices(replay.t, fps, max_frames))`` frames, 64 colours).
    """
    ctrl = ctrl or replay.controller()
    idx = frame_indices(replay.t, fps, max_frames)
    scene = spatial_frame_scene(replay, ctrl, idx)
    marks = contact_marks(replay.to_run(), ctrl.chain)
    times = np.array([m.time for m in marks])
    fig, ax = spatial_view_figure(scene, contacts=bool(marks))
    name, outcome = replay.scenario.name, replay.outcome.get("status", "?")
    t_end = float(replay.t[-1])
    label = fig.text(0.5, 0.965, "", ha="center", va="center", fontsize=9, animated=True)
    # Blitting: the panes, the axes, the obstacles and the rail are rendered once (fixed camera); each
    # frame draws only its own artists on a copy of that background.
    background = fig.canvas.copy_from_bbox(fig.bbox)

    def render(i: int) -> Image.Image:
        fig.canvas.restore_region(background)
        seen, note = frame_contacts(times, replay.t[idx], i)
        label.set_text(f"{name}: t = {replay.t[idx[i]]:.2f} / {t_end:.2f} s ({outcome}){note}")
        colour = CONTACT_COLOUR if note.endswith("(contact)") else ARM_COLOUR
        moving = stage_artists(ax, scene, i, colour) + draw_contact_marks(ax, marks[seen], (0, 1, 2), names=False)
        for artist in moving + [label]:
            fig.draw_artist(artist)
        for artist in moving:
            artist.remove()
        return Image.fromarray(np.asarray(fig.canvas.buffer_rgba())[..., :3])

    meter = FrameProgress(len(idx), label="animation") if progress else None
    palette = render(len(idx) - 1).quantize(colors=64, method=Image.Quantize.FASTOCTREE)
    frames = []
    for i in range(len(idx)):
        frames.append(render(i).quantize(palette=palette, dither=Image.Dither.NONE))
        if meter:
            meter.update(i + 1)
    if meter:
        meter.close()
    path = Path(path)
    frames[0].save(path, save_all=True, append_images=frames[1:], duration=round(1000 / fps), loop=0)
    return path
