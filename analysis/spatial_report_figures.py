"""PNG figures of a spatial chain's report: margins and control effort over time, margins per link and joint."""
from __future__ import annotations

from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

from coordarm.simulation.figures import legend_beside, save_figure

from .report_figures import mark_blowup, plot_effort
from .spatial_analysis import SPATIAL_LABELS, SPATIAL_MARGINS, SpatialAnalysis

COLORS = {"link": "tab:blue", "end": "tab:red", "joint": "tab:green"}


def plot_spatial_margins(a: SpatialAnalysis, path: str | Path, title: str = "") -> Path:
    """Two panels over time: the three margins with thresholds; ``|u|_inf`` and cond of the decoupling matrix.

    Parameters
    ----------
    a : SpatialAnalysis
        The analysis of the run.
    path : str or Path
        The PNG file to write.
    title : str
        Prefix of the top panel's title (scenario and link count).

    Returns
    -------
    Path
        The written file.
    """
    fig, axes = plt.subplots(2, 1, figsize=(10.5, 7.5), sharex=True, layout="constrained")   # legends beside
    floor = 1e-12
    ax = axes[0]
    for value in sorted(set(a.thresholds.values())):      # one line per threshold, naming its margins
        names = [n for n in SPATIAL_MARGINS if a.thresholds[n] == value]
        ax.axhline(value, color=COLORS[names[0]] if len(names) == 1 else "0.4", ls=":", lw=1,
                   label=f"threshold {value:g} ({', '.join(names)})")
    for name in SPATIAL_MARGINS:
        ax.semilogy(a.t, np.maximum(a.smallest(name), floor), color=COLORS[name], label=SPATIAL_LABELS[name])
        if a.crossings[name] is not None:
            ax.plot(a.crossings[name], a.thresholds[name], "v", color=COLORS[name], ms=8)
    mark_blowup(ax, a)
    ax.set_ylabel("margin [-] (0 = singular)")
    legend_beside(ax)
    ax.set_title(title + "\nsingularity margins (triangles: first below threshold)", fontsize=10)
    ax = axes[1]
    plot_effort(ax, a.t, a.u_norm, a.nominal_u, floor)
    if len(a.cond):
        ax.semilogy(a.cond_t, a.cond, ".-", color="tab:gray", label="cond(M), decoupling matrix [-]")
    mark_blowup(ax, a)
    if a.nominal_u > 0:           # a run starting at rest: keep |u| ~ 0 from squeezing the scale
        ax.set_ylim(bottom=max(ax.get_ylim()[0], 1e-3 * a.nominal_u))
    ax.set_ylabel("|u| [rad/s], cond [-]" if len(a.cond) else "|u| [rad/s]")
    ax.set_xlabel("t [s]")
    legend_beside(ax)
    ax.set_title("control effort" + ("" if len(a.cond) else " (cond(M) not sampled above 32 links)"), fontsize=10)
    for ax in axes:
        ax.grid(alpha=0.3, which="both")
    return save_figure(fig, path)


def plot_spatial_links(a: SpatialAnalysis, path: str | Path, title: str = "") -> Path:
    """Link margins (links 2..m) and joint margins ``|cos b_j|`` (joints 1..m) as heat maps over time.

    Parameters
    ----------
    a : SpatialAnalysis
        The analysis of the run.
    path : str or Path
        The PNG file to write.
    title : str
        Prefix of the top panel's title (scenario and link count).

    Returns
    -------
    Path
        The written file.
    """
    fig, axes = plt.subplots(2, 1, figsize=(8, 7), sharex=True, layout="constrained")
    t0, t1 = a.t[0], a.t[-1] if a.t[-1] > a.t[0] else a.t[0] + 1e-9
    for ax, name, first, what in ((axes[0], "link", 2, "link j"), (axes[1], "joint", 1, "joint j")):
        v = a.margins[name]
        im = ax.imshow(v.T, aspect="auto", origin="lower", cmap="viridis", vmin=0, vmax=1,
                       extent=(t0, t1, first - 0.5, first + v.shape[1] - 0.5), interpolation="nearest")
        value, when, j = a.minima[name]
        ax.plot(when, j, "x", color="tab:red", ms=9, mew=2, clip_on=False,
                label=f"smallest {value:.3g}: {what.split()[0]} {j} at t = {when:.2f} s")
        ax.set_ylabel(what)
        ax.legend(fontsize=8, loc="upper right")
        fig.colorbar(im, ax=ax, label="margin [-]")
    axes[0].set_title(title + "\nlink margins: 2x2 link pivots (0 = singular)", fontsize=10)
    axes[1].set_title("joint margins |cos b_j| (0 = the joint's own singularity, b_j = $\\pm\\pi$/2)", fontsize=10)
    axes[1].set_xlabel("t [s]")
    return save_figure(fig, path)
