"""Figures of a run: robot stages over time (paper Figs. 2-4) and tracking/margin plots."""
from __future__ import annotations

from pathlib import Path
from typing import Any, Sequence

import matplotlib.pyplot as plt
from matplotlib.ticker import LogFormatter, NullFormatter
import numpy as np

from coordarm.symbolic import CoordinatingController, PlanarChain
from coordarm.symbolic.paths import Path as PathCurve

from .contact_marks import CONTACT_COLOUR, contact_marks, contact_note, draw_contact_marks, recorded_contacts
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

    A wall (a segment, no thickness) is a thin line with a dot at each end, so that a narrow opening
    between two walls stays visible at any scale; labels stand beside their obstacle (off a wall, across
    from its middle) on a white box, never struck through.

    Parameters
    ----------
    ax : matplotlib.axes.Axes
        Where to draw.
    obstacles : sequence of Obstacle
        The obstacles.
    labels : bool
        Write each obstacle's name beside it.
    """
    for ob in obstacles:
        pts = outline(ob)
        c = pts.mean(axis=0)
        offset = np.array([0.0, 10.0])
        if ob.kind == "segment":
            ax.plot(pts[:, 0], pts[:, 1], "-", color="k", lw=1.6, solid_capstyle="butt", zorder=2)
            ax.plot(pts[:, 0], pts[:, 1], "o", color="k", ms=3, zorder=2)
            d = pts[-1] - pts[0]
            n = np.array([-d[1], d[0]]) / max(float(np.hypot(*d)), 1e-300)
            offset = 12.0 * (n if n[1] >= 0 else -n)       # beside the wall, on its upper side
        else:
            ax.fill(pts[:, 0], pts[:, 1], color="0.35", alpha=0.8, lw=1.5, edgecolor="k", zorder=2)
            # a long wall is labelled a quarter along it (over its straight start, not off its end and out of
            # the view, nor across a bend), a compact obstacle at its middle
            span = np.ptp(pts, axis=0)
            xm = pts[:, 0].min() + (0.25 if span[0] > 3 * span[1] else 0.5) * span[0]
            ring = np.vstack([pts, pts[:1]])                     # the outline, 20 points per edge
            dense = (ring[:-1, None] + np.linspace(0, 1, 20)[:, None] * (ring[1:] - ring[:-1])[:, None]).reshape(-1, 2)
            mid = dense[np.abs(dense[:, 0] - xm) <= np.partition(np.abs(dense[:, 0] - xm), 3)[3]]
            if len(obstacles) > 1 and c[1] < np.mean([outline(o).mean(axis=0)[1] for o in obstacles]):
                c, offset = mid[np.argmin(mid[:, 1])], np.array([0.0, -9.0])   # a lower wall: label below it
            else:
                c, offset = mid[np.argmax(mid[:, 1])], np.array([0.0, 9.0])    # else above its top
        if labels:
            ax.annotate(ob.name, c, fontsize=7, color="0.15", ha="center", va="center", xytext=tuple(offset),
                        textcoords="offset points", zorder=6,
                        bbox=dict(boxstyle="round,pad=0.15", fc="white", ec="none", alpha=0.85))


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
    s_ref = run.s_reference(getattr(ctrl, "speeds", None))
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


#: Colour of the stage at which a run stopped (that of the contact marks).
STOP_COLOR = CONTACT_COLOUR


def _view_box(run: Run, ctrl: CoordinatingController, idx: np.ndarray, obstacles: Sequence[Obstacle],
              frame: np.ndarray | None) -> tuple[np.ndarray, np.ndarray]:
    """Corners ``lo, hi`` [m] of the view: the drawn poses (or ``frame``), the obstacles, a bounded path."""
    pts = ctrl.chain.joints_np(run.q[idx]).reshape(-1, 2) if frame is None else frame
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    if obstacles and frame is None:
        w = np.concatenate([outline(ob) for ob in obstacles])
        lo, hi = np.minimum(lo, w.min(axis=0)), np.maximum(hi, w.max(axis=0))
    if isinstance(ctrl.curve, PathCurve) and frame is None:     # a bounded path is shown whole
        w = ctrl.curve.sample(float(run.t[idx[0]]), extent=1.0)
        lo, hi = np.minimum(lo, w.min(axis=0)), np.maximum(hi, w.max(axis=0))
    pad = 0.1 * max(hi - lo) + ctrl.chain.xi
    return lo - pad, hi + pad


def _draw_stages(ax, run: Run, ctrl: CoordinatingController, idx: np.ndarray, obstacles: Sequence[Obstacle],
                 frame: np.ndarray | None = None, legend: str = "right", stop: int | None = None,
                 palette: np.ndarray | None = None, window: tuple[float, float] | None = None) -> float:
    """The chain at rows ``idx`` with the curve at those times, the obstacles, the rail and the base, on ``ax``.

    Earlier stages fade (lighter, thinner) under later ones so that a body moving along itself does not
    smear into one line; each stage's time is written at its end point. Row ``stop`` (in ``idx``) is
    the configuration at which the run stopped, drawn red and marked; contacts recorded in
    ``run.info["contacts"]`` (those in ``window`` = (after, up to) [s], when given) are marked on their
    links. ``legend``: ``"right"`` (beside the axes) or ``"none"``; ``palette``: the stages' colours
    (default viridis). Returns the height-to-width ratio of the drawn extent (the axes' equal-aspect shape)."""
    joints = ctrl.chain.joints_np(run.q[idx])
    colors = plt.cm.viridis(np.linspace(0, 0.9, len(idx))) if palette is None else palette
    lo, hi = _view_box(run, ctrl, idx, obstacles, frame)
    extent = float(np.linalg.norm(hi - lo))
    targets = target_points(run, ctrl, idx)
    n = len(idx)
    for i, (k, c, J) in enumerate(zip(idx, colors, joints)):
        last = k == stop
        c = STOP_COLOR if last else c
        alpha = 1.0 if last or n == 1 else 0.35 + 0.65 * i / (n - 1)
        cur = ctrl.curve.sample(float(run.t[k]), extent=extent)
        ax.plot(cur[:, 0], cur[:, 1], "--", color=c, lw=0.8, alpha=0.6 * alpha, zorder=1)
        ax.plot(J[:, 0], J[:, 1], "-", color=c, lw=1.0 + 1.2 * alpha, alpha=alpha, zorder=3 + i,
                label=f"stop at t = {run.t[k]:.2f} s" if last else None)
        ax.plot(J[-1, 0], J[-1, 1], "o", color=c, ms=4, zorder=3 + i)
        crowd = 9 * sum(float(np.hypot(*(J[-1] - P[-1]))) < 0.05 * extent for P in joints[:i])  # end points near
        ax.annotate(f"{run.t[k]:.{2 if last else 1}f} s", J[-1], xytext=(4, -10 - crowd if i % 2 else 4 + crowd),
                    textcoords="offset points", fontsize=7, color=c, zorder=32,
                    bbox=dict(boxstyle="round,pad=0.1", fc="white", ec="none", alpha=0.7))
        if targets is not None:
            ax.plot(*targets[i], "x", color=c, ms=7, mew=1.5, zorder=3 + i)
    if stop is not None:
        ax.plot(*joints[list(idx).index(stop)][-1], "*", color=STOP_COLOR, ms=14, mec="k", mew=0.6, zorder=30)
    _mark_contacts(ax, run, ctrl, window)
    draw_obstacles(ax, obstacles)
    if ctrl.chain.rail:
        draw_rail(ax, ctrl.chain, lo, hi)
        base = ctrl.chain.base_point(run.q[idx])
        ax.plot(base[:, 0], base[:, 1], "ks", ms=5, zorder=25, label="base (on the rail)")
    else:
        ax.plot(0, 0, "ks", ms=6, zorder=25, label="base")
    ax.set_xlim(lo[0], hi[0])
    ax.set_ylim(lo[1], hi[1])
    ax.set_aspect("equal")
    ax.set_xlabel("y$_1$ [m]")
    ax.set_ylabel("y$_2$ [m]")
    ax.plot([], [], "-", color=colors[-1], lw=2, label="body (earlier: lighter)" if n > 1 else "body")
    ax.plot([], [], "--", color="gray", lw=0.8, label="curve at that time")
    if targets is not None:
        ax.plot([], [], "x", color="gray", ms=7, mew=1.5, label="target s*(t)")
    if legend == "right":
        ax.legend(loc="upper left", bbox_to_anchor=(1.02, 1.0), fontsize=8, borderaxespad=0)
    ax.grid(alpha=0.3)
    return float((hi[1] - lo[1]) / (hi[0] - lo[0]))


def _mark_contacts(ax, run: Run, ctrl: CoordinatingController, window: tuple[float, float] | None = None) -> None:
    """The first contacts in ``run.info["contacts"]`` (within ``window`` [s], when given) as
    :func:`~.contact_marks.draw_contact_marks` rings on their links, at their time."""
    marks = contact_marks(run, ctrl.chain)
    if window is not None:
        marks = [c for c in marks if window[0] < c.time <= window[1]]
    if marks:
        draw_contact_marks(ax, marks, count=len(marks))


def plot_stages(run: Run, ctrl: CoordinatingController, path: str | Path, stages: int = 5,
                obstacles: Sequence[Obstacle] = (), title: str = "",
                times: Sequence[float] | None = None, stopped: bool = False) -> Path:
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
    stopped : bool
        The run stopped before its end: its last sample is drawn too, red and marked as the stop.

    Returns
    -------
    Path
        The written file.
    """
    idx, stop = _with_stop(run, stage_indices(run, stages, times), stopped)
    contacts = recorded_contacts(run)
    if contacts:                         # the body at its first contact, where the rings are
        idx = np.union1d(idx, [int(np.argmin(np.abs(run.t - float(contacts[0]["time"]))))]).astype(int)
    lo, hi = _view_box(run, ctrl, idx, list(obstacles), None)
    flat = (hi[1] - lo[1]) < FLAT * (hi[0] - lo[0])
    if flat and len(idx) >= 3 and stage_overlap(ctrl.chain.joints_np(run.q[idx]), ctrl.chain.xi) > OVERLAP:
        return _plot_stage_rows(run, ctrl, path, idx, stop, list(obstacles), title)
    # Fixed margins, as in plot_tracking: tight_layout measured every text first (1.46x slower). The
    # figure's height follows the scene's aspect (a long, flat path gets a flat figure, not white bands).
    # The legend stands right of the scene, never over the chain.
    width, left, right, below, above = 9.0, 0.75, 2.3, 0.6, 0.4       # inches
    fig, ax = plt.subplots(figsize=(width, 6.5))
    aspect = _draw_stages(ax, run, ctrl, idx, list(obstacles), stop=stop)
    height = float(np.clip((width - left - right) * aspect, 2.4, 8.0)) + below + above
    fig.set_size_inches(width, height)
    fig.subplots_adjust(left=left / width, right=1 - right / width, bottom=below / height, top=1 - above / height)
    ax.set_title(title or f"{ctrl.chain.m}-link robot: stages of the motion", fontsize=11)
    return save_figure(fig, path, tight=False)


#: Stages that overlap more than this (:func:`stage_overlap`; a body moving along itself, fed by a rail
#: or through a pipe) in a view less than :data:`FLAT` high per unit of width are drawn one per row on a
#: shared view instead of on top of each other.
OVERLAP, FLAT = 0.3, 0.6


def stage_overlap(joints: np.ndarray, xi: float) -> float:
    """How much consecutive stages lie on top of each other: the mean, over pairs of consecutive stages,
    of the share of the later stage's joints within ``2 xi`` of a joint of the earlier one.

    Parameters
    ----------
    joints : ndarray, shape (k, m+1, 2)
        The joints of each stage [m].
    xi : float
        Link length [m].

    Returns
    -------
    float
        0 (apart) to 1 (on top of each other); 0 for fewer than two stages.
    """
    if len(joints) < 2:
        return 0.0
    shares = [np.mean(np.min(np.linalg.norm(b[:, None, :] - a[None, :, :], axis=-1), axis=1) <= 2 * xi)
              for a, b in zip(joints[:-1], joints[1:])]
    return float(np.mean(shares))


def _plot_stage_rows(run: Run, ctrl: CoordinatingController, path: str | Path, idx: np.ndarray,
                     stop: int | None, obstacles: list[Obstacle], title: str) -> Path:
    """The stages of a flat scene one per row (same view, same colours as on one axes); save a PNG."""
    frame = ctrl.chain.joints_np(run.q[idx]).reshape(-1, 2)
    if obstacles:
        frame = np.concatenate([frame] + [outline(ob) for ob in obstacles])
    if isinstance(ctrl.curve, PathCurve):
        frame = np.concatenate([frame, ctrl.curve.sample(float(run.t[idx[0]]), extent=1.0)])
    colors = plt.cm.viridis(np.linspace(0, 0.9, len(idx)))
    width, left, right = 9.0, 0.75, 2.3
    lo, hi = _view_box(run, ctrl, idx, obstacles, frame)
    row = float(np.clip((width - left - right) * (hi[1] - lo[1]) / (hi[0] - lo[0]), 0.9, 3.0))
    gap, below, above = 0.4, 0.55, 0.75                                  # inches
    height = row * len(idx) + gap * (len(idx) - 1) + below + above
    fig, axes = plt.subplots(len(idx), 1, figsize=(width, height), sharex=True, sharey=True)
    for i, (ax, k) in enumerate(zip(axes, idx)):       # each row marks the contacts since the row above
        window = (float(run.t[idx[i - 1]]) if i else -np.inf, float(run.t[k]) if i < len(idx) - 1 else np.inf)
        _draw_stages(ax, run, ctrl, np.array([k]), obstacles, frame=frame, legend="right" if i == 0 else "none",
                     stop=stop if k == stop else None, palette=colors[i:i + 1], window=window)
        ax.set_title(f"t = {run.t[k]:.{2 if k == stop else 1}f} s" + (" (stop)" if k == stop else ""),
                     fontsize=9, loc="left")
        if i < len(idx) - 1:
            ax.set_xlabel("")
    if recorded_contacts(run):      # the first row's legend names the rings drawn in any row
        axes[0].legend(*_panel_legend(axes, run, 0), loc="upper left", bbox_to_anchor=(1.02, 1.0), fontsize=8,
                       borderaxespad=0)
    fig.subplots_adjust(left=left / width, right=1 - right / width, bottom=below / height, top=1 - above / height,
                        hspace=gap / row)
    fig.suptitle(title or f"{ctrl.chain.m}-link robot: stages of the motion", fontsize=11)
    return save_figure(fig, path, tight=False)


def _with_stop(run: Run, idx: np.ndarray, stopped: bool) -> tuple[np.ndarray, int | None]:
    """``idx`` with the last row (the stop) added if ``stopped``, and that row (None if not stopped)."""
    if not stopped or not len(run.t):
        return idx, None
    stop = len(run.t) - 1
    return np.union1d(idx, [stop]).astype(int), stop


def plot_panels(run: Run, ctrl: CoordinatingController, path: str | Path, panels: Sequence[dict],
                obstacles: Sequence[Obstacle] = (), title: str = "", stopped: bool = False) -> Path:
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
    stopped : bool
        The run stopped before its end: every panel asking for a later time also draws the stop (red,
        marked); a panel whose times all come after it draws only the stop.

    Returns
    -------
    Path
        The written file.
    """
    frame = ctrl.chain.joints_np(run.q[even_indices(len(run.t), 50)]).reshape(-1, 2)
    if obstacles:
        frame = np.concatenate([frame] + [outline(ob) for ob in obstacles])
    fig, axes = plt.subplots(1, len(panels), figsize=(5.2 * len(panels), 5.4), squeeze=False)
    ends = [max(p["stages"]) if p["stages"] else -np.inf for p in panels]
    for i, (ax, panel) in enumerate(zip(axes[0], panels)):    # each panel marks the contacts of its phase
        inside = [t for t in panel["stages"] if t <= run.t[-1] + 1e-9]
        idx = stage_indices(run, times=inside) if inside else np.zeros(0, int)
        later = stopped and len(inside) < len(panel["stages"])
        idx, stop = _with_stop(run, idx, later)
        window = (ends[i - 1] if i else -np.inf, ends[i] if i < len(panels) - 1 else np.inf)
        _draw_stages(ax, run, ctrl, idx if len(idx) else np.array([len(run.t) - 1]), list(obstacles), frame=frame,
                     legend="none", stop=stop, window=window)
        ax.set_title(panel["title"], fontsize=10)
    handles, labels = _panel_legend(axes[0], run)
    fig.legend(handles, labels, loc="lower center", ncol=min(len(labels), 5), fontsize=8, frameon=False,
               bbox_to_anchor=(0.5, -0.06))
    fig.suptitle(title or f"{ctrl.chain.m}-link robot: phases of the motion")
    # tight_layout leaves equal-aspect panels' x labels outside the canvas: the saved box is fitted instead
    return save_figure(fig, path, tight=False, bbox_inches="tight")


def _panel_legend(axes, run: Run, source: int = -1) -> tuple[list, list[str]]:
    """The legend entries of panel ``source``; the rings' entry (of any panel) names every contact of the run."""
    handles, labels = axes[source].get_legend_handles_labels()
    pairs = [(h, lab) for h, lab in zip(handles, labels) if not lab.startswith("contacts: ")]
    rings = [h for ax in axes for h, lab in zip(*ax.get_legend_handles_labels()) if lab.startswith("contacts: ")]
    contacts = recorded_contacts(run)
    if rings:
        pairs.insert(0, (rings[0], contact_note(len(contacts), float(contacts[0]["time"]))))
    return [h for h, _ in pairs], [lab for _, lab in pairs]


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


def legend_beside(ax: plt.Axes) -> None:
    """The legend of ``ax`` right of it, top-aligned, off the data (leave room: the figure's right margin).

    Parameters
    ----------
    ax : matplotlib.axes.Axes
        A plot with labelled lines.
    """
    ax.legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0)


#: Floor of the logarithmic error plots [m or rad]: below it lie only rounding errors.
FLOOR = 1e-17
#: A start's error at or below this [m or rad] is rounding, not a deviation whose decay could be compared.
ROUNDING = 1e-14


def decay_reference(t: np.ndarray, e0: float, gain: float, floor: float = FLOOR) -> np.ndarray | None:
    """The reference decay ``e0 exp(-K (t - t[0]))``, NaN (not drawn) where it falls below ``floor``.

    The reference ends where it reaches the floor instead of lying on it (below the floor there are only
    rounding errors, no decay to compare); a start at the rounding level (``e0 <= ROUNDING``) has none.

    Parameters
    ----------
    t : ndarray, shape (k,)
        Times [s].
    e0 : float
        The error at ``t[0]`` [m or rad] (its size is used).
    gain : float
        K [1/s].
    floor : float
        Where the reference ends [m or rad].

    Returns
    -------
    ndarray, shape (k,), or None
        The reference [m or rad], None when ``|e0| <= ROUNDING``.
    """
    e0 = abs(float(e0))
    if not e0 > ROUNDING:
        return None
    ref = e0 * np.exp(-gain * (np.asarray(t, float) - t[0]))
    return np.where(ref >= floor, ref, np.nan)


def plot_tracking(run: Run, gain: float, path: str | Path, thresholds: dict[str, float] | None = None,
                  title: str = "", speeds: Any = None) -> Path:
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
    speeds : callable, optional
        ``v*`` at an array of times [m/s] (``ctrl.speeds``): the s reference by Simpson's rule, as the
        summary's (:meth:`~.result.Run.s_reference`); None: the trapezoidal rule on the rows.

    Returns
    -------
    Path
        The file written.
    """
    emax = np.max(np.abs(run.e), axis=1)
    s_err = run.s - run.s_reference(speeds)
    link, longitudinal = np.min(run.link_margins, axis=1), run.longitudinal
    keep = envelope_indices(np.column_stack([np.log10(np.maximum(emax, FLOOR)), s_err, link, longitudinal]))
    t = run.t[keep]
    # Fixed margins (room for the tick labels, axis labels and title of these three panels): tight_layout
    # would measure every text first, which took longer than drawing the figure.
    # the legends stand right of the panels, off the data
    fig, axes = plt.subplots(3, 1, figsize=(9.2, 8), sharex=True,
                             gridspec_kw=dict(left=0.1, right=0.74, bottom=0.06, top=0.95, hspace=0.16))
    axes[0].semilogy(t, np.maximum(emax[keep], FLOOR), label="max$_j$ |e$^j$|")
    reference = decay_reference(t, emax[0], gain)
    if reference is not None:
        axes[0].semilogy(t, reference, "--", label=f"e(0) exp(-{gain:g} t)")
    # Plain "1e-05" tick labels: the default 10^k labels are typeset with mathtext, a quarter of the figure's time.
    axes[0].yaxis.set_major_formatter(LogFormatter())
    axes[0].yaxis.set_minor_formatter(NullFormatter())
    axes[0].set_ylabel("deviation [m]")
    legend_beside(axes[0])
    axes[1].plot(t, s_err[keep], label="s - (s(0) + ∫v*)")
    axes[1].set_ylabel("s tracking error [m]")
    legend_beside(axes[1])
    axes[2].plot(t, link[keep], label="smallest link margin")
    axes[2].plot(t, longitudinal[keep], label="longitudinal margin")
    for name, thr in (thresholds or {}).items():
        axes[2].axhline(thr, ls=":", color="red" if name == "longitudinal" else "gray",
                        label=f"{name} threshold")
    axes[2].set_ylabel("margin [-]")
    axes[2].set_xlabel("t [s]")
    axes[2].set_ylim(bottom=0)
    legend_beside(axes[2])
    for ax in axes:
        ax.grid(alpha=0.3)
    axes[0].set_title(title or "tracking and singularity margins")
    return save_figure(fig, path, tight=False)
