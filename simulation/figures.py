"""Figures of a run: robot stages over time (paper Figs. 2-4) and tracking/margin plots."""
from __future__ import annotations

from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

from coordarm.symbolic import CoordinatingController

from .run import Run, even_indices


def save_figure(fig, path: str | Path, dpi: int = 110) -> Path:
    """Lay out ``fig`` (tight, unless it has a layout engine), write it to ``path``, close it."""
    path = Path(path)
    if fig.get_layout_engine() is None:
        fig.tight_layout()
    fig.savefig(path, dpi=dpi)
    plt.close(fig)
    return path


def stage_indices(run: Run, stages: int = 5) -> np.ndarray:
    """Indices of ``stages`` samples evenly spread over the run (first and last included)."""
    return even_indices(len(run.t), stages)


def plot_stages(run: Run, ctrl: CoordinatingController, path: str | Path, stages: int = 5,
                walls: np.ndarray | None = None, title: str = "") -> Path:
    """Draw the chain at several times with the curve at those times; save a PNG.

    Returns
    -------
    Path
        The written file.
    """
    idx = stage_indices(run, stages)
    joints = ctrl.chain.joints_np(run.q[idx])
    fig, ax = plt.subplots(figsize=(7, 6.5))
    colors = plt.cm.viridis(np.linspace(0, 0.9, len(idx)))
    pts = joints.reshape(-1, 2)
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    if walls is not None and len(walls):
        w = np.asarray(walls).reshape(-1, 2)
        lo, hi = np.minimum(lo, w.min(axis=0)), np.maximum(hi, w.max(axis=0))
    pad = 0.1 * max(hi - lo) + ctrl.chain.xi
    lo, hi = lo - pad, hi + pad
    extent = float(np.linalg.norm(hi - lo))
    for k, c, J in zip(idx, colors, joints):
        cur = ctrl.curve.sample(float(run.t[k]), extent=extent)
        ax.plot(cur[:, 0], cur[:, 1], "--", color=c, lw=0.8, alpha=0.7)
        ax.plot(J[:, 0], J[:, 1], "-", color=c, lw=1.4, label=f"t = {run.t[k]:.1f} s")
        ax.plot(J[-1, 0], J[-1, 1], "o", color=c, ms=4)
    if walls is not None:
        for a, b in np.asarray(walls).reshape(-1, 2, 2):
            ax.plot([a[0], b[0]], [a[1], b[1]], "k-", lw=3, solid_capstyle="butt")
    ax.plot(0, 0, "ks", ms=6, label="base")
    ax.set_xlim(lo[0], hi[0])
    ax.set_ylim(lo[1], hi[1])
    ax.set_aspect("equal")
    ax.set_xlabel("y$_1$ [m]")
    ax.set_ylabel("y$_2$ [m]")
    ax.set_title(title or f"{ctrl.chain.m}-link robot: stages of the motion (dashed: the curve then)")
    ax.legend(loc="best", fontsize=8)
    ax.grid(alpha=0.3)
    return save_figure(fig, path)


def plot_tracking(run: Run, gain: float, path: str | Path, thresholds: dict[str, float] | None = None,
                  title: str = "") -> Path:
    """Three panels over time: ``max|e|`` vs ``e(0) exp(-K t)``, ``s`` tracking error, margins."""
    t = run.t
    fig, axes = plt.subplots(3, 1, figsize=(7, 8), sharex=True)
    emax = np.max(np.abs(run.e), axis=1)
    axes[0].semilogy(t, np.maximum(emax, 1e-17), label="max$_j$ |e$^j$|")
    if emax[0] > 0:
        axes[0].semilogy(t, emax[0] * np.exp(-gain * (t - t[0])), "--", label=f"e(0) exp(-{gain:g} t)")
    axes[0].set_ylabel("deviation [m]")
    axes[0].legend(fontsize=8)
    axes[1].plot(t, run.s - run.s_reference(), label="s - (s(0) + ∫v*)")
    axes[1].set_ylabel("s tracking error [m]")
    axes[1].legend(fontsize=8)
    axes[2].plot(t, np.min(run.link_margins, axis=1), label="smallest link margin")
    axes[2].plot(t, run.longitudinal, label="longitudinal margin")
    for name, thr in (thresholds or {}).items():
        axes[2].axhline(thr, ls=":", color="red" if name == "longitudinal" else "gray",
                        label=f"{name} threshold")
    axes[2].set_ylabel("margin [-]")
    axes[2].set_xlabel("t [s]")
    axes[2].set_ylim(bottom=0)
    axes[2].legend(fontsize=8)
    for ax in axes:
        ax.grid(alpha=0.3)
    axes[0].set_title(title or "tracking and singularity margins")
    return save_figure(fig, path)
