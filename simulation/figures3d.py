"""Figures of a spatial run (universal joints): the robot in 3-D at several times with two orthographic
projections (the paper's Figs. 2-4 in perspective), and the tracking of ``e``, ``s``, the roll and the margins.

Drawn with the matplotlib figure API only (no pyplot figure is opened or left behind); the backend is
whatever the caller selected.
"""
from __future__ import annotations

import math

from pathlib import Path
from typing import Any, Sequence

import matplotlib
import matplotlib.colors
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.ticker import LogFormatter, MaxNLocator, NullFormatter
import numpy as np

from .contact_marks import contact_marks, draw_contact_marks, ended_note, recorded_contacts
from .figures import FLOOR, decay_reference, envelope_indices, legend_beside, stage_indices
from .obstacles3d import densified, wireframe
from .s_reference import ArcReference
from .spatial_view import clip_to_box, rail_ends, roll_command, span_command, spatial_joints, view_box

#: Projections drawn beside the 3-D view: (title, the two coordinates shown).
PROJECTIONS = (("top view (x-y)", (0, 1)), ("side view (x-z)", (0, 2)))
AXIS_NAMES = ("x", "y", "z")


def reference_arc_length(run: Any, speeds: Any = None) -> np.ndarray:
    """``s(0) + integral of v*`` on the run's sample grid (times ``v_scale`` when the run has it).

    Parameters
    ----------
    run : Run or namespace
        ``t`` (N+1,) [s], ``s`` (N+1,) [m], ``v_star`` (N+1,) [m/s]; a :class:`~.result.Run` answers itself
        (:meth:`~.result.Run.s_reference`).
    speeds : callable, optional
        ``v*`` at an array of times [m/s] (``ctrl.speeds``): Simpson's rule for a Run, as its summary;
        None (and for a namespace): the trapezoidal rule.

    Returns
    -------
    ndarray, shape (N+1,)
        The arc length the end point should have [m].
    """
    if callable(getattr(run, "s_reference", None)):
        return run.s_reference(speeds)
    scale = getattr(run, "v_scale", None)
    scale = None if scale is None else np.where(np.isfinite(scale), scale, 1.0)
    return ArcReference().add(run.t, run.s[0], run.v_star, scale)


def target_points3d(ctrl: Any, s_ref: np.ndarray, times: np.ndarray) -> np.ndarray | None:
    """The end point's target on the curve, ``point_at(s*(t), t)``, (k, 3) [m]; None if the curve has no ``point_at``.

    Parameters
    ----------
    ctrl : SpatialController
        The controller (its curve).
    s_ref : ndarray, shape (k,)
        Target arc lengths [m].
    times : ndarray, shape (k,)
        Times [s].

    Returns
    -------
    ndarray, shape (k, 3), or None
        The target points [m].
    """
    try:
        return ctrl.curve.points_at(s_ref, times)
    except (AttributeError, NotImplementedError):
        return None


def curve_points(curve: Any, t: float, reach: float, n: int = 600) -> np.ndarray:
    """``n`` points of the curve at time ``t``, a line's within ``reach`` [m] of its point (from its two ends).

    Parameters
    ----------
    curve : SpatialCurve
        The curve (``sample``; ``kind`` ``"line"`` for a straight line).
    t : float
        Time [s].
    reach : float
        Half-length of a line's drawn piece, or the rays drawn beyond a path's ends [m].
    n : int
        Number of points.

    Returns
    -------
    ndarray, shape (n, 3)
        Points [m].
    """
    if getattr(curve, "kind", "") == "line":
        a, b = curve.sample(t, n=2, extent=reach)
        return a + np.linspace(0.0, 1.0, n)[:, None] * (b - a)
    return curve.sample(t, n=n, extent=reach)


def stage_scene(run: Any, ctrl: Any, idx: np.ndarray, obstacles: Sequence[Any] = ()) -> dict[str, Any]:
    """What the stage figure draws: joints and curve per stage, the target points and the view box.

    The box holds the chain over the whole run (so that it does not depend on the stages drawn), a
    bounded path whole, every bounded obstacle (an unbounded plate is cut to the box) and a rail's finite
    ends; the curves, the obstacles and the rail are clipped to it.

    Parameters
    ----------
    run : Run or namespace
        ``t`` (N+1,) [s], ``q`` (N+1, 2m) [rad], ``s``, ``v_star``.
    ctrl : SpatialController
        The controller (chain and curve).
    idx : ndarray of int, shape (k,)
        Rows of the stages.
    obstacles : sequence of Obstacle3D
        The scenario's obstacles.

    Returns
    -------
    dict
        ``joints`` (k, m+1, 3), ``curves`` list of (n, 3), ``targets`` (k, 3) or None, ``lo``, ``hi`` (3,) [m],
        ``obstacles`` list of (n, 3) polylines (clipped to the box), ``bases`` (k, 3) [m] (the base at each
        stage), ``rail`` (n, 3) or None (the rail between its limits, clipped to the box) and ``names``: each
        obstacle's name with the points of its clipped wireframe, (n, 3) [m].
    """
    chain, curve = ctrl.chain, ctrl.curve
    every = np.unique(np.linspace(0, len(run.t) - 1, 60).round().astype(int))
    frame = [spatial_joints(chain, run.q[every]).reshape(-1, 3)]
    if getattr(curve, "kind", "") in ("path", "waypoints"):       # a bounded path is shown whole
        frame.append(curve.sample(float(run.t[idx[0]]), n=400, extent=0.0))
    lines = [densified(p) for ob in obstacles for p in wireframe(ob)]
    frame += [p for ob in obstacles if ob.kind != "plate" or math.isfinite(ob.extent) for p in wireframe(ob)]
    bounded_rail = rail_ends(chain, math.inf)
    if bounded_rail is not None:                                     # a rail's finite ends are shown
        frame.append(bounded_rail[np.all(np.isfinite(bounded_rail), axis=1)])
    lo, hi = view_box(np.concatenate(frame), chain.xi)
    reach = float(np.linalg.norm(hi - lo)) + float(np.max(np.abs(np.concatenate([lo, hi]))))
    curves = [clip_to_box(curve_points(curve, float(run.t[k]), reach), lo, hi) for k in idx]
    targets = target_points3d(ctrl, reference_arc_length(run, getattr(ctrl, "speeds", None))[idx], run.t[idx])
    ends = rail_ends(chain, reach)
    names = [(ob.name, np.concatenate([clip_to_box(densified(p), lo, hi).reshape(-1, 3) for p in wireframe(ob)]))
             for ob in obstacles]
    return dict(joints=spatial_joints(chain, run.q[idx]), curves=curves, targets=targets, lo=lo, hi=hi,
                obstacles=[clip_to_box(p, lo, hi) for p in lines], bases=chain.base_point(run.q[idx]),
                rail=None if ends is None else clip_to_box(densified(ends, 200), lo, hi), names=names)


def draw_stage(ax: Any, scene: dict[str, Any], i: int, colour: Any, label: str, axes: Sequence[int]) -> None:
    """Stage ``i`` of ``scene`` on ``ax``: the curve (dashed), the links (thick), the joints (dots), the end point.

    The links' polyline carries the gid ``"links"``, the curve's ``"curve"``.

    Parameters
    ----------
    ax : matplotlib Axes or Axes3D
        Where to draw.
    scene : dict
        From :func:`stage_scene`.
    i : int
        Stage number.
    colour : colour
        Colour of the stage.
    label : str
        Legend label of the links.
    axes : sequence of int
        The coordinates drawn: three on a 3-D axes, two on a projection.
    """
    J, cur = scene["joints"][i], scene["curves"][i]
    ax.plot(*(cur[:, a] for a in axes), "--", color=colour, lw=1.0, alpha=0.8, gid="curve")
    width = 3.0 if len(J) <= 25 else 2.0
    ax.plot(*(J[:, a] for a in axes), "-", color=colour, lw=width, solid_capstyle="round", label=label, gid="links")
    ax.plot(*(J[1:-1, a] for a in axes), "o", color="white", mec=colour, ms=2.6, mew=0.8, gid="joints")
    ax.plot(*(J[-1:, a] for a in axes), "o", color=colour, ms=6, mec="k", mew=0.6, gid="end")
    if scene["targets"] is not None:
        ax.plot(*(scene["targets"][i:i + 1, a] for a in axes), "x", color=colour, ms=8, mew=2, gid="target")
    if scene.get("rail") is not None:           # the base on the rail at this stage (the carriage)
        ax.plot(*(scene["bases"][i:i + 1, a] for a in axes), "s", color=colour, ms=6, mec="k", mew=0.8, gid="base")


def draw_base(ax: Any, axes: Sequence[int], scene: dict[str, Any] | None = None) -> None:
    """The base (the first link's centre) as a black square on ``ax``; on a rail the rail too.

    A fixed base is the origin; on a rail (``scene["rail"]``) the rail is a thick grey line between its
    limits (gid ``"rail"``; :func:`draw_stage` draws the base on it at each stage, a square in the stage's colour).

    Parameters
    ----------
    ax : matplotlib Axes or Axes3D
        Where to draw.
    axes : sequence of int
        The coordinates drawn.
    scene : dict, optional
        From :func:`stage_scene` (without it, or without a rail: the base at the origin).
    """
    if scene is None or scene.get("rail") is None:
        ax.plot(*([0.0] for _ in axes), "s", color="k", ms=7, label="base", gid="base")
        return
    ax.plot(*(scene["rail"][:, a] for a in axes), "-", color="0.35", lw=3.0, alpha=0.6,
            label="rail (squares: the base)", gid="rail")


def draw_obstacles(ax: Any, scene: dict[str, Any], axes: Sequence[int]) -> None:
    """The obstacles' wireframes (grey, half transparent: a body in a cage shows; gid ``"obstacle"``), as clipped in
    ``scene["obstacles"]`` (none if absent).

    Parameters
    ----------
    ax : matplotlib Axes or Axes3D
        Where to draw.
    scene : dict
        From :func:`stage_scene`, with ``obstacles``: a list of (n, 3) polylines [m].
    axes : sequence of int
        The coordinates shown (0 = x, 1 = y, 2 = z).
    """
    for p in scene.get("obstacles", ()):
        ax.plot(*(p[:, a] for a in axes), "-", color="0.4", lw=0.7, alpha=0.5, gid="obstacle")   # a body inside shows


#: Most obstacles named on a projection (a pipe built of dozens of rods is left unnamed).
MOST_NAMED = 6


def label_obstacles(ax: Any, scene: dict[str, Any], axes: Sequence[int]) -> None:
    """Each obstacle's name above its highest point in the projection on ``axes`` (none above :data:`MOST_NAMED`).

    Parameters
    ----------
    ax : matplotlib Axes
        A projection.
    scene : dict
        From :func:`stage_scene` (its ``names``; none if absent).
    axes : sequence of int
        The two coordinates shown.
    """
    named = scene.get("names") or []
    if len(named) > MOST_NAMED:
        return
    for name, pts in named:
        pts = pts[np.all(np.isfinite(pts), axis=1)]
        if len(pts):
            top = pts[np.argmax(pts[:, axes[1]])]
            ax.annotate(name, (top[axes[0]], top[axes[1]]), xytext=(0, 6), textcoords="offset points", ha="center",
                        va="bottom", fontsize=7, color="0.15", zorder=6,
                        bbox=dict(boxstyle="round,pad=0.15", fc="white", ec="none", alpha=0.85))


def draw_view3d(ax: Any, scene: dict[str, Any], colours: np.ndarray, labels: Sequence[str]) -> None:
    """The stages in perspective on a 3-D axes, equal scales on x, y, z (box aspect = the box's extents).

    Parameters
    ----------
    ax : Axes3D
        Where to draw.
    scene : dict
        From :func:`stage_scene`.
    colours : ndarray, shape (k, 4)
        Colour of each stage.
    labels : sequence of str
        Legend label of each stage.
    """
    lo, hi = scene["lo"], scene["hi"]
    for i, (c, label) in enumerate(zip(colours, labels)):
        draw_stage(ax, scene, i, c, label, (0, 1, 2))
    draw_base(ax, (0, 1, 2), scene)
    draw_obstacles(ax, scene, (0, 1, 2))
    ax.set_xlim(lo[0], hi[0])
    ax.set_ylim(lo[1], hi[1])
    ax.set_zlim(lo[2], hi[2])
    ax.set_box_aspect(tuple(hi - lo), zoom=1.08)
    ax.set_proj_type("persp", focal_length=1.6)
    ax.view_init(elev=24, azim=-58)
    for name, setter in zip(AXIS_NAMES, (ax.set_xlabel, ax.set_ylabel, ax.set_zlabel)):
        setter(f"{name} [m]", labelpad=2)
    for axis in (ax.xaxis, ax.yaxis, ax.zaxis):
        axis.set_major_locator(MaxNLocator(5))
    ax.tick_params(labelsize=7, pad=1)


def draw_projection(ax: Any, scene: dict[str, Any], colours: np.ndarray, title: str, axes: Sequence[int]) -> None:
    """The stages projected orthographically on the plane of coordinates ``axes``, equal scales.

    Parameters
    ----------
    ax : matplotlib Axes
        Where to draw.
    scene : dict
        From :func:`stage_scene`.
    colours : ndarray, shape (k, 4)
        Colour of each stage.
    title : str
        Panel title.
    axes : sequence of int
        The two coordinates shown (0 = x, 1 = y, 2 = z).
    """
    lo, hi = scene["lo"], scene["hi"]
    for i, c in enumerate(colours):
        draw_stage(ax, scene, i, c, "", axes)
    draw_base(ax, axes, scene)
    draw_obstacles(ax, scene, axes)
    label_obstacles(ax, scene, axes)
    ax.set_xlim(lo[axes[0]], hi[axes[0]])
    ax.set_ylim(lo[axes[1]], hi[axes[1]])
    ax.set_aspect("equal")
    ax.set_xlabel(f"{AXIS_NAMES[axes[0]]} [m]")
    ax.set_ylabel(f"{AXIS_NAMES[axes[1]]} [m]")
    ax.set_title(title, fontsize=10)
    ax.tick_params(labelsize=8)
    ax.grid(alpha=0.3)


def plot_spatial_stages(run: Any, ctrl: Any, path: str | Path, times: Sequence[float] | None = None,
                        stages: int = 4, title: str = "", obstacles: Sequence[Any] = (), stopped: bool = False) -> Path:
    """The chain at several times with the curve at those times: a perspective view and two projections; a PNG.

    Earlier stages are drawn lighter (as on the planar figure) so that a body moving along itself does
    not smear into one. Contacts recorded in ``run.info["contacts"]`` are marked as on the planar figure
    (:mod:`~.contact_marks`: red rings on the touching links, the body at the first contact drawn too).

    Parameters
    ----------
    run : Run or namespace
        ``t`` (N+1,) [s], ``q`` (N+1, 2m) [rad], ``s`` [m], ``v_star`` [m/s].
    ctrl : SpatialController
        Its controller (chain and curve).
    path : str or Path
        The PNG to write.
    times : sequence of float, optional
        Stage times [s] (the nearest samples; times outside the run are skipped).
    stages : int
        Number of evenly spread stages when ``times`` is None.
    title : str
        Figure title (empty: a default naming the link count).
    obstacles : sequence of Obstacle3D
        Drawn as wireframes, clipped to the view box.
    stopped : bool
        The run stopped before its end: its last sample is drawn too, red, labelled as the stop.

    Returns
    -------
    Path
        The file written.
    """
    idx = stage_indices(run, stages, times)
    if stopped and len(run.t):                   # the configuration at the stop, drawn red
        idx = np.union1d(idx, [len(run.t) - 1]).astype(int)
    marks = contact_marks(run, ctrl.chain)
    if marks:                                    # the body at its first contact, where the rings are
        idx = np.union1d(idx, [int(np.argmin(np.abs(run.t - marks[0].time)))]).astype(int)
    scene = stage_scene(run, ctrl, idx, obstacles)
    colours = matplotlib.colormaps["viridis"](np.linspace(0, 0.9, len(idx)))
    colours[:, 3] = np.linspace(0.35, 1.0, len(idx)) if len(idx) > 1 else 1.0   # earlier stages lighter (no smear)
    labels = [f"t = {run.t[k]:.2f} s" for k in idx]
    if stopped and len(run.t):
        colours[-1] = matplotlib.colors.to_rgba("#d62728")
        labels[-1] = f"stop at t = {run.t[-1]:.2f} s"
    fig = Figure(figsize=(13.0, 7.0))
    grid = fig.add_gridspec(2, 2, width_ratios=(1.5, 1.0), left=0.02, right=0.84, bottom=0.07, top=0.92,
                            wspace=0.22, hspace=0.28)
    ax3 = fig.add_subplot(grid[:, 0], projection="3d")
    draw_view3d(ax3, scene, colours, labels)
    ax3.set_box_aspect(tuple(scene["hi"] - scene["lo"]), zoom=0.94)    # the box and its z label inside the cell
    draw_contact_marks(ax3, marks, (0, 1, 2), names=False)
    ax3.text2D(0.5, 0.97, "perspective", transform=ax3.transAxes, ha="center", fontsize=10)
    for (name, axes), cell in zip(PROJECTIONS, (grid[0, 1], grid[1, 1])):
        ax = fig.add_subplot(cell)
        draw_projection(ax, scene, colours, name, axes)
        draw_contact_marks(ax, marks, axes)
    handles, names = ax3.get_legend_handles_labels()
    extra = [(Line2D([], [], ls="--", color="gray", lw=1.0), "curve at that time"),
             (Line2D([], [], ls="", marker="o", color="gray", mec="k", ms=6), "end point")]
    if scene["targets"] is not None:
        extra.append((Line2D([], [], ls="", marker="x", color="gray", ms=8, mew=2), "target s*(t)"))
    fig.legend(handles + [h for h, _ in extra], names + [n for _, n in extra], loc="upper right",
               bbox_to_anchor=(0.995, 0.92), fontsize=9, frameon=True)
    fig.suptitle(title or f"{ctrl.chain.m}-link spatial robot: stages of the motion", fontsize=12)
    path = Path(path)
    fig.savefig(path, dpi=110)
    return path


def tracking_series(run: Any, ctrl: Any) -> dict[str, np.ndarray]:
    """The curves of the tracking figure at every sample.

    Parameters
    ----------
    run : Run or namespace
        ``t``, ``e`` (N+1, 2(m-1)), ``s``, ``roll``, ``v_star``, ``link_margins`` (N+1, m-1),
        ``end_margin`` (N+1,), ``joint_margins`` (N+1, m).
    ctrl : SpatialController
        Its controller (roll command).

    Returns
    -------
    dict of str to ndarray, each shape (N+1,)
        ``emax`` [m], ``s_err`` [m], ``roll`` and ``roll_star`` [rad], ``roll_err`` [rad] (wrapped to
        (-pi, pi]), ``link``, ``end``, ``joint`` margins [-]; on a rail (``run.sigma``) also ``span_err`` [m]
        (``sigma - sigma*``, or ``sigma - sigma(0)`` when held) and the ``rail`` margin [-].
    """
    roll = np.asarray(run.roll, float)
    roll_star = roll_command(ctrl, run.t)
    s_err = run.s - reference_arc_length(run, getattr(ctrl, "speeds", None))
    out = dict(emax=np.max(np.abs(run.e), axis=1), s_err=s_err, roll=roll,
               roll_star=roll_star, roll_err=np.angle(np.exp(1j * (roll - roll_star))),
               link=np.min(run.link_margins, axis=1), end=np.asarray(run.end_margin, float),
               joint=np.min(run.joint_margins, axis=1))
    if getattr(run, "sigma", None) is not None:
        sigma = np.asarray(run.sigma, float)
        target = span_command(ctrl, run.t)
        out.update(span_err=sigma - (sigma[0] if target is None else target), rail=np.asarray(run.rail_margin, float))
    return out


def draw_decay(ax: Any, t: np.ndarray, values: np.ndarray, gain: float, label: str, ylabel: str,
               symbol: str) -> None:
    """``|values|`` on a log scale (floored at :data:`FLOOR`) with ``|values(0)| exp(-K t)`` down to that floor
    (:func:`~.figures.decay_reference`: none when ``|values(0)|`` is at the rounding level).

    Parameters
    ----------
    ax : matplotlib Axes
        Where to draw.
    t : ndarray, shape (k,)
        Times [s].
    values : ndarray, shape (k,)
        The error [m or rad].
    gain : float
        K [1/s].
    label : str
        Legend label of the error.
    ylabel : str
        Axis label (with the unit).
    symbol : str
        The error's symbol in the reference's label (``"e(0)"``).
    """
    size = np.abs(values)
    ax.semilogy(t, np.maximum(size, FLOOR), label=label)
    reference = decay_reference(t, size[0], gain, FLOOR)
    if reference is not None:
        ax.semilogy(t, reference, "--", label=f"{symbol} exp(-{gain:g} t)")
    ax.yaxis.set_major_formatter(LogFormatter())
    ax.yaxis.set_minor_formatter(NullFormatter())
    ax.set_ylabel(ylabel)
    legend_beside(ax)


def plot_spatial_tracking(run: Any, ctrl: Any, path: str | Path, thresholds: dict[str, float] | None = None,
                          title: str = "") -> Path:
    """Five panels over time: ``max|e|`` and the roll error vs ``exp(-K t)``, the ``s`` error, roll vs its command,
    the margins; a PNG.

    Parameters
    ----------
    run : Run or namespace
        See :func:`tracking_series`.
    ctrl : SpatialController
        Its controller (gain, roll command).
    path : str or Path
        The PNG to write.
    thresholds : dict of str to float, optional
        Margin thresholds [-] drawn as dotted lines, by name.
    title : str
        Figure title (empty: a default).

    Returns
    -------
    Path
        The file written.
    """
    ser = tracking_series(run, ctrl)
    keep = envelope_indices(np.column_stack([np.log10(np.maximum(ser["emax"], FLOOR)), ser["s_err"], ser["roll"],
                                             ser["link"], ser["end"], ser["joint"]]))
    t, s = run.t[keep], {k: v[keep] for k, v in ser.items()}
    fig = Figure(figsize=(10.0, 11.0))      # the legends stand right of the panels, off the data
    axes = fig.subplots(5, 1, sharex=True, gridspec_kw=dict(left=0.1, right=0.7, bottom=0.05, top=0.95,
                                                            hspace=0.14))
    draw_decay(axes[0], t, s["emax"], ctrl.gain, "max$_j$ |e$^j$| (normal deviations)", "deviation [m]",
               "max|e(0)|")
    axes[1].plot(t, s["s_err"], label="s - (s(0) + ∫v*)")
    if "span_err" in s:                                     # a rail: the span's error too
        axes[1].plot(t, s["span_err"], label="span σ - σ*" if getattr(ctrl, "span", None) is not None
                     else "span σ - σ(0) (held)")
    axes[1].set_ylabel("s error [m]")
    axes[2].plot(t, s["roll"], label="roll θ")
    axes[2].plot(t, s["roll_star"], "--", label="command θ*")
    axes[2].set_ylabel("roll [rad]")
    draw_decay(axes[3], t, s["roll_err"], ctrl.gain, "|θ - θ*|", "roll error [rad]", "|θ(0) - θ*(0)|")
    axes[4].plot(t, s["link"], label="smallest link margin")
    axes[4].plot(t, s["end"], label="end margin")
    axes[4].plot(t, s["joint"], label="smallest joint margin |cos b$_j$|")
    if "rail" in s:
        axes[4].plot(t, s["rail"], label="rail margin")
    for name, value in (thresholds or {}).items():
        axes[4].axhline(value, ls=":", color="red" if name == "longitudinal" else "gray", label=f"{name} threshold")
    axes[4].set_ylim(bottom=0)
    axes[4].set_ylabel("margin [-]")
    axes[4].set_xlabel("t [s]")
    for ax in axes:
        ax.grid(alpha=0.3)
    for ax in axes[1:3].tolist() + [axes[4]]:
        legend_beside(ax)
    fig.suptitle(title or "tracking and singularity margins", fontsize=11)
    path = Path(path)
    fig.savefig(path, dpi=110)
    return path


def spatial_figures(run: Any, scenario: Any, ctrl: Any, stem: str | Path, stages: Sequence[float] | None = None,
                    outcome: str | None = None) -> list[Path]:
    """Stage and tracking figures of a spatial run as ``<stem>_stages.png`` and ``<stem>_tracking.png``.

    Parameters
    ----------
    run : Run or namespace
        ``t`` (N+1,) [s], ``q`` (N+1, 2m) [rad], ``e`` (N+1, 2(m-1)) [m], ``s`` [m], ``roll`` [rad],
        ``link_margins`` (N+1, m-1), ``end_margin`` (N+1,), ``joint_margins`` (N+1, m), ``v_star`` [m/s].
    scenario : Scenario or None
        Its scenario (``name``, ``stages``, ``thresholds``; each optional).
    ctrl : SpatialController
        Its controller (chain, curve, gain, roll command).
    stem : str or Path
        Path of the figures without suffix, e.g. ``logs/line3d``.
    stages : sequence of float, optional
        Stage times [s] (default: the scenario's, else 4 evenly spread).
    outcome : str, optional
        How the run ended, shown in the titles (``"singularity"``, ...).

    Returns
    -------
    list of Path
        The stage figure, then the tracking figure.
    """
    stem = Path(stem)
    name = getattr(scenario, "name", "") or "spatial run"
    ended = ended_note(outcome, len(recorded_contacts(run)))
    title = f"{name}: {ctrl.chain.m} links, universal joints" + (f" ({ended})" if ended else "")
    times = stages if stages is not None else getattr(scenario, "stages", None)
    thresholds = getattr(scenario, "thresholds", None)
    return [plot_spatial_stages(run, ctrl, stem.with_name(stem.name + "_stages.png"), times=times,
                                title=f"{title}: stages of the motion", obstacles=getattr(scenario, "obstacles", ()),
                                stopped=outcome not in (None, "", "completed")),
            plot_spatial_tracking(run, ctrl, stem.with_name(stem.name + "_tracking.png"), thresholds=thresholds,
                                  title=f"{title}: tracking and margins")]
