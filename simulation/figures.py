"""Figures of a run: robot stages over time (paper Figs. 2-4) and tracking/margin plots."""
from __future__ import annotations

from pathlib import Path
from typing import Sequence

import matplotlib.pyplot as plt
from matplotlib.ticker import LogFormatter, NullFormatter
import numpy as np

from coordarm.symbolic import CoordinatingController, PlanarChain
from coordarm.symbolic.paths import Path as PathCurve

from .obstacles import Obstacle, outline
from .run import Run, even_indices


def save_figure(fig: plt.Figure, path: str | Path, dpi: int = 110, tight: bool = True, bbox_inches: str | None = None) -> Path:
    """Lay out ``fig`` (tight, unless it has a layout engine or ``tight`` is False: its margins are set
    already), write it to ``path`` (``bbox_inches="tight"``: the saved box fitted to the drawn artists),
    close it.

    Parameters
    ----------
    fig : matplotlib.figure.Figure
        The figure (closed afterwards).
    path : str or Path
        The file to write (format from its suffix).
    dpi : int
        Resolution [dots per inch].
    tight : bool
        Call ``tight_layout`` first (when the figure has no layout engine).
    bbox_inches : str or None
        Passed to ``savefig``.

    Returns
    -------
    Path
        The file written.
    """
    path = Path(path)
    if tight and fig.get_layout_engine() is None:
        fig.tight_layout()
    fig.savefig(path, dpi=dpi, bbox_inches=bbox_inches)
    plt.close(fig)
    return path


def stage_indices(run: Run, stages: int = 5, times: Sequence[float] | None = None) -> np.ndarray:
    """Indices of the samples nearest to ``times`` [s] (within the run), else ``stages`` evenly spread ones.

    Parameters
    ----------
    run : Run
        The simulated run.
    stages : int
        Number of evenly spread samples when ``times`` is None.
    times : sequence of float or None
        Times [s]; those outside the run are dropped (none left: the last sample).

    Returns
    -------
    ndarray of int
        Increasing distinct row indices into ``run.t``.
    """
    if times is None:
        return even_indices(len(run.t), stages)
    inside = [t for t in times if run.t[0] - 1e-9 <= t <= run.t[-1] + 1e-9] or [run.t[-1]]
    return np.unique([int(np.argmin(np.abs(run.t - t))) for t in inside])


def draw_obstacles(ax: plt.Axes, obstacles: Sequence[Obstacle], labels: bool = True) -> None:
    """Draw every obstacle from its :func:`~coordarm.simulation.obstacles.outline` (discs and polygons filled).

    Parameters
    ----------
    ax : matplotlib.axes.Axes
        Where to draw.
    obstacles : sequence of Obstacle
        The obstacles.
    labels : bool
        Write each obstacle's name at its centre.
    """
    for ob in obstacles:
        pts = outline(ob)
        if ob.kind == "segment":
            ax.plot(pts[:, 0], pts[:, 1], "k-", lw=3, solid_capstyle="butt")
        else:
            ax.fill(pts[:, 0], pts[:, 1], color="0.35", alpha=0.8, lw=1.5, edgecolor="k")
        if labels:
            c = pts.mean(axis=0)
            ax.annotate(ob.name, c, fontsize=7, color="0.2", ha="center", va="center",
                        xytext=(0, 8), textcoords="offset points")


def target_points(run: Run, ctrl: CoordinatingController, idx: np.ndarray) -> np.ndarray | None:
    """The end point's target ``s*(t) = s(0) + integral of v*`` on the curve at rows ``idx``, (len(idx), 2) [m].

    None when the curve cannot map an arc length to a point (a user curve without ``point_at``).

    Parameters
    ----------
    run : Run
        The simulated run.
    ctrl : CoordinatingController
        Its controller (chain and curve).
    idx : ndarray of int, shape (k,)
        Rows of the run.

    Returns
    -------
    ndarray, shape (k, 2), or None
        The target points [m].
    """
    s_ref = run.s_reference()
    try:
        return np.array([ctrl.curve.point_at(float(s_ref[k]), float(run.t[k])) for k in idx])
    except NotImplementedError:
        return None


def draw_rail(ax: plt.Axes, chain: PlanarChain, lo: np.ndarray, hi: np.ndarray) -> None:
    """The introduction axis: its travel ``[low, high]`` along its direction, clipped to the view.

    Parameters
    ----------
    ax : matplotlib.axes.Axes
        Where to draw.
    chain : PlanarChain
        A chain on a rail (``rail_limits`` [m], ``rail_direction``).
    lo, hi : ndarray, shape (2,)
        Corners of the view [m].
    """
    reach = float(np.linalg.norm(hi - lo)) + float(np.linalg.norm(lo)) + float(np.linalg.norm(hi))
    a, b = (min(max(v, -reach), reach) for v in chain.rail_limits)
    ends = np.outer([a, b], chain.rail_direction)
    ax.plot(ends[:, 0], ends[:, 1], "-", color="0.55", lw=5, alpha=0.5, solid_capstyle="butt",
            label="rail", zorder=0)


def _draw_stages(ax, run: Run, ctrl: CoordinatingController, idx: np.ndarray, obstacles: Sequence[Obstacle],
                 frame: np.ndarray | None = None, legend_outside: bool = False) -> float:
    """The chain at rows ``idx`` with the curve at those times, the obstacles and the base, on ``ax``.

    Returns the height-to-width ratio of the drawn extent (the axes' equal-aspect shape)."""
    joints = ctrl.chain.joints_np(run.q[idx])
    colors = plt.cm.viridis(np.linspace(0, 0.9, len(idx)))
    pts = joints.reshape(-1, 2) if frame is None else frame
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    if obstacles and frame is None:
        w = np.concatenate([outline(ob) for ob in obstacles])
        lo, hi = np.minimum(lo, w.min(axis=0)), np.maximum(hi, w.max(axis=0))
    if isinstance(ctrl.curve, PathCurve) and frame is None:     # a bounded path is shown whole
        w = ctrl.curve.sample(float(run.t[idx[0]]), extent=1.0)
        lo, hi = np.minimum(lo, w.min(axis=0)), np.maximum(hi, w.max(axis=0))
    pad = 0.1 * max(hi - lo) + ctrl.chain.xi
    lo, hi = lo - pad, hi + pad
    extent = float(np.linalg.norm(hi - lo))
    targets = target_points(run, ctrl, idx)
    for i, (k, c, J) in enumerate(zip(idx, colors, joints)):
        cur = ctrl.curve.sample(float(run.t[k]), extent=extent)
        ax.plot(cur[:, 0], cur[:, 1], "--", color=c, lw=0.8, alpha=0.7)
        ax.plot(J[:, 0], J[:, 1], "-", color=c, lw=1.4, label=f"t = {run.t[k]:.1f} s")
        ax.plot(J[-1, 0], J[-1, 1], "o", color=c, ms=4)
        if targets is not None:
            ax.plot(*targets[i], "x", color=c, ms=7, mew=1.5, label="target s*(t)" if i == len(idx) - 1 else None)
    draw_obstacles(ax, obstacles)
    if ctrl.chain.rail:
        draw_rail(ax, ctrl.chain, lo, hi)
        base = ctrl.chain.base_point(run.q[idx])
        ax.plot(base[:, 0], base[:, 1], "ks", ms=5, label="base (on the rail)")
    else:
        ax.plot(0, 0, "ks", ms=6, label="base")
    ax.set_xlim(lo[0], hi[0])
    ax.set_ylim(lo[1], hi[1])
    ax.set_aspect("equal")
    ax.set_xlabel("y$_1$ [m]")
    ax.set_ylabel("y$_2$ [m]")
    ax.plot([], [], "--", color="gray", lw=0.8, label="curve at that time")
    if legend_outside:
        ax.legend(loc="upper left", bbox_to_anchor=(1.02, 1.0), fontsize=8, borderaxespad=0)
    else:
        ax.legend(loc="best", fontsize=8)
    ax.grid(alpha=0.3)
    return float((hi[1] - lo[1]) / (hi[0] - lo[0]))


def plot_stages(run: Run, ctrl: CoordinatingController, path: str | Path, stages: int = 5,
                obstacles: Sequence[Obstacle] = (), title: str = "",
                times: Sequence[float] | None = None) -> Path:
    """Draw the chain at several times with the curve at those times; save a PNG.

    Parameters
    ----------
    run : Run
        The run (its ``t`` and ``q`` give the chain at each stage).
    ctrl : CoordinatingController
        Its controller (chain and curve to draw).
    path : str or Path
        PNG to write.
    stages : int
        Number of evenly spread stages when ``times`` is not given.
    obstacles : sequence of Obstacle
        Obstacles to draw.
    title : str
        Figure title (default: the link count and "stages of the motion").
    times : sequence of float, optional
        Stage times [s] (the nearest samples are drawn; times outside the run are skipped).

    Returns
    -------
    Path
        The written file.
    """
    # Fixed margins, as in plot_tracking: tight_layout measured every text first (1.46x slower). The
    # figure's height follows the scene's aspect (a long, flat path gets a flat figure, not white bands).
    # The legend stands right of the scene, never over the chain.
    width, left, right, below, above = 9.0, 0.75, 1.9, 0.6, 0.4       # inches
    fig, ax = plt.subplots(figsize=(width, 6.5))
    aspect = _draw_stages(ax, run, ctrl, stage_indices(run, stages, times), list(obstacles), legend_outside=True)
    height = float(np.clip((width - left - right) * aspect, 2.4, 8.0)) + below + above
    fig.set_size_inches(width, height)
    fig.subplots_adjust(left=left / width, right=1 - right / width, bottom=below / height, top=1 - above / height)
    ax.set_title(title or f"{ctrl.chain.m}-link robot: stages of the motion", fontsize=11)
    return save_figure(fig, path, tight=False)


def plot_panels(run: Run, ctrl: CoordinatingController, path: str | Path, panels: Sequence[dict],
                obstacles: Sequence[Obstacle] = (), title: str = "") -> Path:
    """One labelled panel per phase (paper Fig. 4): ``panels`` = ``[{"title": "(a) ...", "stages": [t, ...]}]``.

    All panels share the view of the whole run so that the phases line up.

    Parameters
    ----------
    run : Run
        The simulated run.
    ctrl : CoordinatingController
        Its controller (chain and curve).
    path : str or Path
        The PNG to write.
    panels : sequence of dict
        ``{"title": str, "stages": [t, ...]}`` per panel, times [s].
    obstacles : sequence of Obstacle
        Obstacles to draw.
    title : str
        Figure title (empty: a default naming the link count).

    Returns
    -------
    Path
        The written file.
    """
    frame = ctrl.chain.joints_np(run.q[even_indices(len(run.t), 50)]).reshape(-1, 2)
    if obstacles:
        frame = np.concatenate([frame] + [outline(ob) for ob in obstacles])
    fig, axes = plt.subplots(1, len(panels), figsize=(5.2 * len(panels), 5.4), squeeze=False)
    for ax, panel in zip(axes[0], panels):
        _draw_stages(ax, run, ctrl, stage_indices(run, times=panel["stages"]), list(obstacles), frame=frame)
        ax.set_title(panel["title"], fontsize=10)
    fig.suptitle(title or f"{ctrl.chain.m}-link robot: phases of the motion")
    # tight_layout leaves equal-aspect panels' x labels outside the canvas: the saved box is fitted instead
    return save_figure(fig, path, tight=False, bbox_inches="tight")


def envelope_indices(Y: np.ndarray, points: int = 2000) -> np.ndarray:
    """Sample indices that draw every column of ``Y`` (n, k) as its full line would look.

    The samples are cut into about ``points / 2`` buckets and each column's smallest and largest
    sample in each bucket is kept (with the first and last sample): every extreme survives, and
    a figure a few hundred pixels wide is drawn from a few thousand vertices instead of n.

    Parameters
    ----------
    Y : ndarray, shape (n, k) or (n,)
        The lines, one per column (non-finite values count as 0).
    points : int
        About how many samples to keep per column.

    Returns
    -------
    ndarray of int
        Increasing distinct row indices (all of them when ``n <= points``).
    """
    Y = np.asarray(Y, dtype=float).reshape(len(Y), -1)
    n = len(Y)
    if n <= points:
        return np.arange(n)
    size = -(-n // max(1, points // 2))
    nb = -(-n // size)
    base = np.arange(nb) * size
    padded = np.concatenate([Y, np.repeat(Y[-1:], nb * size - n, axis=0)])
    picks = [np.array([0, n - 1])]
    for col in padded.T:
        col = np.where(np.isfinite(col), col, 0.0).reshape(nb, size)
        picks += [base + col.argmin(axis=1), base + col.argmax(axis=1)]
    return np.unique(np.minimum(np.concatenate(picks), n - 1))


def plot_tracking(run: Run, gain: float, path: str | Path, thresholds: dict[str, float] | None = None,
                  title: str = "") -> Path:
    """Three panels over time: ``max|e|`` vs ``e(0) exp(-K t)``, ``s`` tracking error, margins.

    Each line is drawn from its :func:`envelope_indices` (a few thousand samples), not every step.

    Parameters
    ----------
    run : Run
        The simulated run.
    gain : float
        Error gain K [1/s] of the reference decay.
    path : str or Path
        The PNG to write.
    thresholds : dict of str to float or None
        Margin thresholds [-] drawn as dotted lines, by name.
    title : str
        Title of the top panel (empty: a default).

    Returns
    -------
    Path
        The file written.
    """
    emax = np.max(np.abs(run.e), axis=1)
    s_err = run.s - run.s_reference()
    link, longitudinal = np.min(run.link_margins, axis=1), run.longitudinal
    keep = envelope_indices(np.column_stack([np.log10(np.maximum(emax, 1e-17)), s_err, link, longitudinal]))
    t = run.t[keep]
    # Fixed margins (room for the tick labels, axis labels and title of these three panels): tight_layout
    # would measure every text first, which took longer than drawing the figure.
    fig, axes = plt.subplots(3, 1, figsize=(7, 8), sharex=True,
                             gridspec_kw=dict(left=0.13, right=0.97, bottom=0.06, top=0.95, hspace=0.08))
    axes[0].semilogy(t, np.maximum(emax[keep], 1e-17), label="max$_j$ |e$^j$|")
    if emax[0] > 0:
        # held at the same 1e-17 m floor as the data: below it lie only rounding errors, not a decay to compare
        axes[0].semilogy(t, np.maximum(emax[0] * np.exp(-gain * (t - t[0])), 1e-17), "--",
                         label=f"e(0) exp(-{gain:g} t)")
    # Plain "1e-05" tick labels: the default 10^k labels are typeset with mathtext, a quarter of the figure's time.
    axes[0].yaxis.set_major_formatter(LogFormatter())
    axes[0].yaxis.set_minor_formatter(NullFormatter())
    axes[0].set_ylabel("deviation [m]")
    axes[0].legend(fontsize=8)
    axes[1].plot(t, s_err[keep], label="s - (s(0) + ∫v*)")
    axes[1].set_ylabel("s tracking error [m]")
    axes[1].legend(fontsize=8)
    axes[2].plot(t, link[keep], label="smallest link margin")
    axes[2].plot(t, longitudinal[keep], label="longitudinal margin")
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
    return save_figure(fig, path, tight=False)
