"""Animation of a replayed run: the chain, the curve at that time and the obstacles, as a GIF.

Each frame is labelled with the scenario, the time and the outcome, has its axes labelled in
metres, and shows the rail and the moving base of a rail robot; the recorded contacts (``--allow-contact``)
are marked as on the stage figure (:mod:`coordarm.simulation.contact_marks`) from their time on, the body
drawn red in the frame of a new contact and the title counting them; a bar under the axes shows how far
into the run the frame is, and a progress bar on stderr follows the rendering.
"""
from __future__ import annotations

from pathlib import Path

import matplotlib.pyplot as plt
from matplotlib.lines import Line2D
import numpy as np
from PIL import Image

from coordarm.simulation.contact_marks import (CONTACT_COLOUR, CONTACT_STYLE, MOST_MARKED, contact_marks,
                                               draw_contact_marks)
from coordarm.simulation.figures import draw_obstacles, draw_rail
from coordarm.simulation.obstacles import outline
from coordarm.simulation.progress import Progress
from coordarm.symbolic import CoordinatingController

from .replay import Replay


class FrameProgress(Progress):
    """The progress bar of the rendering: frames done instead of simulated time.

    Parameters
    ----------
    total : float
        Number of frames to render.
    label : str
        Text before the bar.
    stream : file-like or None
        Where the bar is written (None: ``sys.stderr``).
    unit : str
        Unused here (:meth:`status` names frames); kept from :class:`Progress`.
    """

    def status(self, done: float, elapsed: float) -> str:
        """Frames done of all and wall time spent.

        Parameters
        ----------
        done : float
            Frames rendered.
        elapsed : float
            Wall time since the start [s].

        Returns
        -------
        str
            The text after the bar.
        """
        return f"frame {done:.0f}/{self.total:.0f}  {elapsed:.1f} s wall"


def frame_indices(t: np.ndarray, fps: float, max_frames: int) -> np.ndarray:
    """Sample rows for the frames: real time at ``fps`` if that fits in ``max_frames``, else sped up.

    Parameters
    ----------
    t : ndarray, shape (N,)
        Sample times [s], increasing.
    fps : float
        Frames per second of the video [1/s].
    max_frames : int
        Most frames to render.

    Returns
    -------
    ndarray of int, shape (F,)
        Increasing distinct row indices into ``t``, ``F <= max_frames``.
    """
    span = float(t[-1] - t[0]) if len(t) else 0.0
    frames = int(min(max(2, round(span * fps) + 1), max_frames))
    targets = np.linspace(t[0], t[-1], frames)
    return np.unique(np.clip(np.searchsorted(t, targets), 0, len(t) - 1))


def frame_legend(rail: bool, contacts: bool) -> tuple[list[Line2D], list[str]]:
    """The legend of a planar GIF frame: the body, the curve, the base (and the rail), the contact rings.

    Parameters
    ----------
    rail : bool
        The robot is on a rail.
    contacts : bool
        The run recorded contacts.

    Returns
    -------
    handles : list of Line2D
    labels : list of str
    """
    items = [(Line2D([], [], color="tab:blue", lw=1.5), "body (red: a new contact)" if contacts else "body"),
             (Line2D([], [], ls="--", color="tab:orange", lw=1), "curve at that time"),
             (Line2D([], [], ls="", marker="s", color="k", ms=5), "base" + " (on the rail)" * rail)]
    if rail:
        items.append((Line2D([], [], color="0.55", lw=5, alpha=0.5), "rail"))
    if contacts:
        items.append((Line2D([], [], **CONTACT_STYLE), "contact"))
    return [h for h, _ in items], [lab for _, lab in items]


def frame_contacts(times: np.ndarray, frame_times: np.ndarray, i: int) -> tuple[slice, str]:
    """The contacts marked on frame ``i`` (the latest :data:`~coordarm.simulation.contact_marks.MOST_MARKED` of
    those at or before its time) and the note of its title.

    Parameters
    ----------
    times : ndarray, shape (C,)
        The recorded contacts' times [s], increasing.
    frame_times : ndarray, shape (F,)
        The frames' times [s].
    i : int
        Frame number.

    Returns
    -------
    marked : slice
        Into the contacts; ``marked.stop`` is how many happened up to frame ``i``.
    note : str
        ``""`` before the first contact, else ``", contacts: n so far"``, ending ``" (contact)"`` when one
        happened since the previous frame.
    """
    upto = int(np.searchsorted(times, frame_times[i], side="right"))
    if not upto:
        return slice(0, 0), ""
    new = times[upto - 1] > (frame_times[i - 1] if i else -np.inf)
    return slice(max(0, upto - MOST_MARKED), upto), f", contacts: {upto} so far" + (" (contact)" * bool(new))


def animate(replay: Replay, path: str | Path, fps: float = 15.0, max_frames: int = 200,
            ctrl: CoordinatingController | None = None, progress: bool = True) -> Path:
    """Write a GIF of the run in ``replay`` to ``path``.

    Parameters
    ----------
    replay : Replay
        The loaded log.
    path : str or Path
        GIF to write.
    fps : float
        Frames per second of the GIF (real time when at most ``max_frames`` frames, else sped up).
    max_frames : int
        Most frames.
    ctrl : CoordinatingController, optional
        The run's controller (rebuilt from the log if None).
    progress : bool
        Show a progress bar on stderr while rendering.

    Returns
    -------
    Path
        The written file.
    """
    ctrl = ctrl or replay.controller()
    idx = frame_indices(replay.t, fps, max_frames)
    joints = ctrl.chain.joints_np(replay.q[idx])
    obstacles = list(replay.scenario.obstacles)
    pts = np.concatenate([joints.reshape(-1, 2)] + [outline(ob) for ob in obstacles])
    pad = ctrl.chain.xi + 0.05 * float(np.ptp(pts, axis=0).max())
    lo, hi = pts.min(axis=0) - pad, pts.max(axis=0) + pad
    extent = float(np.linalg.norm(hi - lo))
    rail = ctrl.chain.rail
    bases = ctrl.chain.base_point(replay.q[idx]) if rail else np.zeros((len(idx), 2))
    width, left, right, below, above = 5.5, 0.8, 0.2, 1.05, 0.4       # inches: the axes fit the scene's shape
    height = float(np.clip((width - left - right) * (hi[1] - lo[1]) / (hi[0] - lo[0]), 1.6, 6.0)) + below + above
    fig, ax = plt.subplots(figsize=(width, height))
    fig.subplots_adjust(left=left / width, right=1 - right / width, bottom=below / height, top=1 - above / height)
    x0, x1, y_bar = left / width, 1 - right / width, 0.12 / height
    draw_obstacles(ax, obstacles)
    if rail:
        draw_rail(ax, ctrl.chain, lo, hi)
    (base,) = ax.plot([], [], "ks", ms=5, animated=True, zorder=5)
    (curve,) = ax.plot([], [], "--", color="tab:orange", lw=1, animated=True)
    (arm,) = ax.plot([], [], "-o", color="tab:blue", lw=1.5, ms=1.5, animated=True)
    label = ax.set_title("", fontsize=9)
    label.set_animated(True)
    ax.set_xlim(lo[0], hi[0])
    ax.set_ylim(lo[1], hi[1])
    ax.set_aspect("equal")
    ax.set_xlabel("y$_1$ [m]")
    ax.set_ylabel("y$_2$ [m]")
    ax.grid(alpha=0.3)
    name, outcome = replay.scenario.name, replay.outcome.get("status", "?")
    t_end = float(replay.t[-1])
    # how far into the run: a bar along the bottom edge of the figure, under the axes and their labels
    fig.add_artist(plt.Line2D([x0, x1], [y_bar, y_bar], color="0.85", lw=4, transform=fig.transFigure,
                              solid_capstyle="butt"))
    bar = plt.Line2D([], [], color="tab:green", lw=4, transform=fig.transFigure, solid_capstyle="butt",
                     animated=True)
    fig.add_artist(bar)

    marks = contact_marks(replay.to_run(), ctrl.chain)
    rings = [draw_contact_marks(ax, [m], names=False, animated=True) for m in marks]   # one set per contact
    times = np.array([m.time for m in marks])
    fig.legend(*frame_legend(rail, bool(marks)), loc="lower center", bbox_to_anchor=(0.5, 0.2 / height),
               ncol=5, fontsize=7, frameon=False, handlelength=1.6, columnspacing=1.0)

    def draw(i: int):
        k = idx[i]
        c = ctrl.curve.sample(float(replay.t[k]), n=200, extent=extent)
        curve.set_data(c[:, 0], c[:, 1])
        arm.set_data(joints[i, :, 0], joints[i, :, 1])
        base.set_data(bases[i, :1], bases[i, 1:])
        seen, note = frame_contacts(times, replay.t[idx], i)
        arm.set_color(CONTACT_COLOUR if note.endswith("(contact)") else "tab:blue")
        label.set_text(f"{name}: t = {replay.t[k]:.2f} / {t_end:.2f} s ({outcome}){note}")
        frac = (replay.t[k] - replay.t[0]) / max(t_end - replay.t[0], 1e-12)
        bar.set_data([x0, x0 + (x1 - x0) * frac], [y_bar, y_bar])
        return [curve, arm, base, label, bar] + [a for r in rings[seen] for a in r]

    # Blitting: the axes, grid and obstacles are rendered once; each frame redraws only the
    # moving artists on a copy of that background (the full redraw cost 0.2 s a frame).
    fig.canvas.draw()
    background = fig.canvas.copy_from_bbox(fig.bbox)
    meter = FrameProgress(len(idx), label="animation") if progress else None
    def render(i: int) -> Image.Image:
        fig.canvas.restore_region(background)
        for artist in draw(i):
            fig.draw_artist(artist)
        return Image.fromarray(np.asarray(fig.canvas.buffer_rgba())[..., :3])

    # One palette for every frame, from the last one (it has every colour, the full progress bar).
    palette = render(len(idx) - 1).quantize(colors=64, method=Image.Quantize.FASTOCTREE)
    frames = []
    for i in range(len(idx)):
        frames.append(render(i).quantize(palette=palette, dither=Image.Dither.NONE))
        if meter:
            meter.update(i + 1)
    if meter:
        meter.close()
    plt.close(fig)
    path = Path(path)
    frames[0].save(path, save_all=True, append_images=frames[1:], duration=round(1000 / fps), loop=0)
    return path
