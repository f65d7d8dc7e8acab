"""Animation of a replayed run: the chain, the curve at that time and the walls, as a GIF."""
from __future__ import annotations

from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
from matplotlib.animation import FuncAnimation, PillowWriter

from coordarm.symbolic import CoordinatingController

from .replay import Replay


def frame_indices(t: np.ndarray, fps: float, max_frames: int) -> np.ndarray:
    """Sample rows for the frames: real time at ``fps`` if that fits in ``max_frames``, else sped up."""
    span = float(t[-1] - t[0]) if len(t) else 0.0
    frames = int(min(max(2, round(span * fps) + 1), max_frames))
    targets = np.linspace(t[0], t[-1], frames)
    return np.unique(np.clip(np.searchsorted(t, targets), 0, len(t) - 1))


def animate(replay: Replay, path: str | Path, fps: float = 15.0, max_frames: int = 200,
            ctrl: CoordinatingController | None = None) -> Path:
    """Write a GIF of the run in ``replay`` to ``path`` (``ctrl``: its controller, rebuilt if None)."""
    ctrl = ctrl or replay.controller()
    idx = frame_indices(replay.t, fps, max_frames)
    joints = ctrl.chain.joints_np(replay.q[idx])
    walls = np.asarray(replay.scenario.obstacles).reshape(-1, 2, 2)
    pts = np.concatenate([joints.reshape(-1, 2), walls.reshape(-1, 2)])
    pad = ctrl.chain.xi + 0.05 * float(np.ptp(pts, axis=0).max())
    lo, hi = pts.min(axis=0) - pad, pts.max(axis=0) + pad
    extent = float(np.linalg.norm(hi - lo))
    fig, ax = plt.subplots(figsize=(5, 5))
    for a, b in walls:
        ax.plot([a[0], b[0]], [a[1], b[1]], "k-", lw=3, solid_capstyle="butt")
    ax.plot(0, 0, "ks", ms=5)
    (curve,) = ax.plot([], [], "--", color="tab:orange", lw=1)
    (arm,) = ax.plot([], [], "-o", color="tab:blue", lw=1.5, ms=1.5)
    label = ax.set_title("")
    ax.set_xlim(lo[0], hi[0])
    ax.set_ylim(lo[1], hi[1])
    ax.set_aspect("equal")
    ax.grid(alpha=0.3)
    name = replay.scenario.name

    def draw(i: int):
        k = idx[i]
        c = ctrl.curve.sample(float(replay.t[k]), n=200, extent=extent)
        curve.set_data(c[:, 0], c[:, 1])
        arm.set_data(joints[i, :, 0], joints[i, :, 1])
        label.set_text(f"{name}: t = {replay.t[k]:.2f} s")
        return curve, arm, label

    anim = FuncAnimation(fig, draw, frames=len(idx), blit=False)
    path = Path(path)
    anim.save(path, writer=PillowWriter(fps=fps))
    plt.close(fig)
    return path
