"""PNG figures of a singularity report: margins over time, worst link, step responses."""
from __future__ import annotations

from pathlib import Path
from typing import Any

import matplotlib.pyplot as plt
import numpy as np
from matplotlib.ticker import MaxNLocator

from coordarm.simulation.figures import legend_beside, save_figure

from .run_analysis import BLOWUP_FACTOR, LABELS, RunAnalysis
from .singularity import MARGINS
from .stability import sampled_limit, step_responses

COLORS = dict(zip(MARGINS, ("tab:blue", "tab:red", "tab:green", "tab:purple", "tab:olive")))


def mark_blowup(ax: Any, a: Any) -> None:
    """Draw the blow-up time of a run (when there is one) as a dashed vertical line.

    Parameters
    ----------
    ax : matplotlib.axes.Axes
        The panel.
    a : RunAnalysis or SpatialAnalysis
        The analysis of the run (its ``blowup_time`` [s] or None).
    """
    if a.blowup_time is not None:
        ax.axvline(a.blowup_time, color="k", ls="--", lw=1, label=f"|u| > {BLOWUP_FACTOR:g}x nominal")


def plot_effort(ax: Any, t: np.ndarray, u_norm: np.ndarray, nominal_u: float, floor: float) -> None:
    """Draw ``|u|_inf`` over time (floored at ``floor`` for the log scale) and the blow-up level.

    Parameters
    ----------
    ax : matplotlib.axes.Axes
        The panel (log scale).
    t : ndarray, shape (N,)
        Times [s].
    u_norm : ndarray, shape (N,)
        ``|u|_inf`` [rad/s].
    nominal_u : float
        The nominal ``|u|_inf`` [rad/s]; the blow-up level is :data:`BLOWUP_FACTOR` times it.
    floor : float
        Smallest value drawn.
    """
    ax.semilogy(t, np.maximum(u_norm, floor), color="tab:blue", label="|u|$_\\infty$ [rad/s]")
    ax.axhline(BLOWUP_FACTOR * nominal_u, color="tab:blue", ls=":", lw=1,
               label=f"{BLOWUP_FACTOR:g} x nominal |u| [rad/s]")


def plot_margins(a: RunAnalysis, path: str | Path, title: str = "") -> Path:
    """Three panels over time: link and longitudinal margins; matrix margins; ``|u|`` and amplification.

    Margins are drawn with their thresholds and first crossings, and the blow-up time when there is one.

    Parameters
    ----------
    a : RunAnalysis
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
    fig, axes = plt.subplots(3, 1, figsize=(10, 9), sharex=True)       # the legends right of the panels
    floor = 1e-12
    for ax, names in ((axes[0], ("links", "longitudinal")),
                      (axes[1], ("sigma_min", "inverse_cond", "inverse_cond_scaled"))):
        for n in names:
            ax.semilogy(a.t, np.maximum(a.smallest(n), floor), color=COLORS[n], label=LABELS[n])
            ax.axhline(a.thresholds[n], color=COLORS[n], ls=":", lw=1, label=f"threshold {a.thresholds[n]:g}")
            if a.crossings[n] is not None:
                ax.plot(a.crossings[n], a.thresholds[n], "v", color=COLORS[n], ms=8)
        mark_blowup(ax, a)
        ax.set_ylabel("margin [-] (0 = singular)")
        legend_beside(ax)
    axes[0].set_title(title + ": singularity margins (triangles: first below threshold)")
    axes[1].set_title("margins of the decoupling matrix M", fontsize=10)
    plot_effort(axes[2], a.t_all, a.u_norm, a.nominal_u, floor)
    amp = a.margins["amplification"]
    if np.isfinite(amp).any():
        axes[2].semilogy(a.t, amp, color="tab:orange", label="amplification $\\xi$|u|/|v*| [-]")
    axes[2].semilogy(a.t, a.margins["cond"], color="tab:gray", label="cond(M) [-]")
    mark_blowup(axes[2], a)
    axes[2].set_ylabel("|u|, amplification, cond")
    axes[2].set_xlabel("t [s]")
    legend_beside(axes[2])
    axes[2].set_title("control effort", fontsize=10)
    for ax in axes:
        ax.grid(alpha=0.3, which="both")
    return save_figure(fig, path)


def plot_links(a: RunAnalysis, path: str | Path, title: str = "") -> Path:
    """Worst link over time (top) and every link margin as a heat map over time x link (bottom).

    Parameters
    ----------
    a : RunAnalysis
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
    fig, axes = plt.subplots(2, 1, figsize=(8, 7), sharex=True, gridspec_kw={"height_ratios": [1, 2]},
                             layout="constrained")
    axes[0].step(a.t, a.margins["worst_link"], where="post", color="tab:blue", label="worst link (smallest margin)")
    mark_blowup(axes[0], a)
    axes[0].set_ylabel("link index [-]")
    axes[0].yaxis.set_major_locator(MaxNLocator(integer=True))       # links are whole numbers
    axes[0].legend(fontsize=8, loc="best")
    axes[0].set_title(title + ": which link is closest to perpendicular")
    L = a.margins["links"]
    m = L.shape[1] + 1
    im = axes[1].imshow(L.T, aspect="auto", origin="lower", cmap="viridis", vmin=0, vmax=1,
                        extent=(a.t[0], a.t[-1], 1.5, m + 0.5), interpolation="nearest")
    fig.colorbar(im, ax=list(axes), label="link margin |grad phi . n| / |grad phi| [-]")
    axes[1].set_ylabel("link j")
    axes[1].set_xlabel("t [s]")
    axes[1].set_title("link margins (0 = link perpendicular to the curve)", fontsize=10)
    return save_figure(fig, path)


def plot_step_responses(gain: float, period: float, path: str | Path, title: str = "",
                        delays=(0, 1, 2)) -> Path:
    """Step responses of one deviation loop: continuous and digital (ZOH) with delays.

    Parameters
    ----------
    gain : float
        Error gain K > 0 [1/s].
    period : float
        Sampling period h [s]; when ``gain * period < 0.05`` (too fine to show the sampling effect)
        the figure uses half the 2-sample-delay limit instead and says so in its title.
    path : str or Path
        The PNG file to write.
    title : str
        Prefix of the title.
    delays : sequence of int
        Control delays [samples], one sampled response each.

    Returns
    -------
    Path
        The written file.
    """
    fig, ax = plt.subplots(figsize=(10, 4.5))      # the legend right of the axes
    h = period
    if gain * h < 0.05:          # the run's own step is too fine to show the effect: use a telling one
        h = 0.5 * sampled_limit(2) / gain
    for label, (t, y) in step_responses(gain, h, delays).items():
        if label == "continuous":
            ax.plot(t, y, "k-", lw=1.5, label=f"continuous, K = {gain:g} 1/s")
        else:
            ax.step(t, y, where="post", label=f"{label} (K h = {gain * h:.3g})")
    ax.set_xlabel("t [s]")
    ax.set_ylabel("deviation response to a unit reference step [-]")
    note = "" if h == period else f" (h chosen at 0.5x the 2-sample-delay limit; the run's h = {period:g} s)"
    ax.set_title(f"{title}: linear error model, sampled-data and delay effects\n{note}", fontsize=10)
    legend_beside(ax)
    ax.grid(alpha=0.3)
    return save_figure(fig, path)
