"""``compare.png`` of a spatial scenario: every method in its own 3-D panel, then the deviations over time.

Top row: one perspective panel per method (none is drawn over another), each with that method's body
at the same stage times (colour = time), the path at those times (dashed), the obstacles and the base
(on a rail: the rail, grey, and the base on it at each stage), the links that touched an obstacle or
each other ringed red where they first did (:mod:`coordarm.simulation.contact_marks`), in one shared view box with equal scales (axes in metres). Bottom row: the shape deviation (mean
distance of the centres ``y^2..y^m`` from the path, in percent of the body length) and the end point's
arc-length error ``|psi(y^m) - s*(t)|`` over time, on log scales, one line style per method so that
lines that coincide stay visible. The obstacles are drawn light (a body inside a cage stays visible).
"""
from __future__ import annotations

import math
from pathlib import Path
from typing import Any, Sequence

import matplotlib
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
import numpy as np

from coordarm.simulation.contact_marks import CONTACT_STYLE, contact_marks, draw_contact_marks
from coordarm.simulation.s_reference import ArcReference
from coordarm.simulation.figures import stage_indices
from coordarm.simulation.figures3d import curve_points, draw_view3d, target_points3d
from coordarm.simulation.obstacles3d import densified, wireframe
from coordarm.simulation.spatial_view import clip_to_box, rail_ends, spatial_joints, view_box

from .compare_scores import centre_distances, contacts_between

#: Line style of each method in the time plots (colour, dashes, width): later lines are thinner.
STYLES = {"coordinating": ("tab:blue", "-", 2.6), "pinv": ("tab:orange", "--", 2.0),
          "dls": ("tab:green", "-.", 1.6), "ftl": ("tab:red", ":", 1.4)}
#: Legend label of the red rings: each method's panel shows all its stages, so all its contacts.
FIRST = "where links touched (first of each link and obstacle)"
#: Rows of a run sampled for the time plots.
TIME_SAMPLES = 400
#: The log plots' floor (values below are rounding noise): percent and metres.
FLOORS = (1e-12, 1e-14)


def shared_box(results: Sequence[Any], ctrl: Any, obstacles: Sequence[Any]) -> tuple[np.ndarray, np.ndarray]:
    """One view box for every method: their bodies over the run, a bounded path, the bounded obstacles.

    Parameters
    ----------
    results : sequence of MethodRun
        The runs.
    ctrl : SpatialController
        Chain and curve.
    obstacles : sequence of Obstacle3D
        The scenario's obstacles.

    Returns
    -------
    lo, hi : ndarray, shape (3,)
        Corners [m].
    """
    chain, curve = ctrl.chain, ctrl.curve
    pts = [spatial_joints(chain, r.run.q[np.unique(np.linspace(0, len(r.run.t) - 1, 40).round().astype(int))])
           .reshape(-1, 3) for r in results]
    if getattr(curve, "kind", "") in ("path", "waypoints"):
        pts.append(curve.sample(float(results[0].run.t[0]), n=400, extent=0.0))
    pts += [p for ob in obstacles if ob.kind != "plate" or math.isfinite(ob.extent) for p in wireframe(ob)]
    ends = rail_ends(chain, math.inf)
    if ends is not None:                                             # a rail's finite ends are shown
        pts.append(ends[np.all(np.isfinite(ends), axis=1)])
    return view_box(np.concatenate(pts), chain.xi)


def method_scene(run: Any, ctrl: Any, times: np.ndarray, box: tuple[np.ndarray, np.ndarray],
                 obstacles: Sequence[Any], s_ref: np.ndarray) -> dict[str, Any]:
    """What one method's panel draws (the scene of :func:`~coordarm.simulation.figures3d.draw_view3d`).

    Parameters
    ----------
    run : Run
        The method's run.
    ctrl : SpatialController
        Chain and curve.
    times : ndarray, shape (k,)
        Stage times [s] (the samples nearest; those after the run's end are left out).
    box : (ndarray, ndarray)
        The shared view box [m].
    obstacles : sequence of Obstacle3D
        Drawn as clipped wireframes.
    s_ref : ndarray, shape (k,)
        The end point's target arc length at the stage times [m].

    Returns
    -------
    dict
        ``joints``, ``curves``, ``targets``, ``lo``, ``hi``, ``obstacles``, ``bases`` (k, 3) [m], ``rail`` (the
        rail between its limits, clipped; None for a fixed base) and ``times`` (the stage times drawn).
    """
    lo, hi = box
    inside = times <= run.t[-1] + 1e-9
    idx = stage_indices(run, len(times), list(times[inside]))
    reach = float(np.linalg.norm(hi - lo)) + float(np.max(np.abs(np.concatenate([lo, hi]))))
    lines = [clip_to_box(densified(p), lo, hi) for ob in obstacles for p in wireframe(ob)]
    ends = rail_ends(ctrl.chain, reach)
    return dict(joints=spatial_joints(ctrl.chain, run.q[idx]), lo=lo, hi=hi, obstacles=lines,
                bases=ctrl.chain.base_point(run.q[idx]),
                rail=None if ends is None else clip_to_box(densified(ends, 200), lo, hi),
                curves=[clip_to_box(curve_points(ctrl.curve, float(run.t[k]), reach), lo, hi) for k in idx],
                targets=target_points3d(ctrl, s_ref[inside][:len(idx)], run.t[idx]), times=run.t[idx])


def reference_arc_length(ctrl: Any, t: np.ndarray, s0: float) -> np.ndarray:
    """``s*(t) = s0 + integral of v*`` on the grid ``t`` by Simpson's rule on each interval (``v*`` at the midpoints).

    Parameters
    ----------
    ctrl : SpatialController
        Its ``speeds``.
    t : ndarray, shape (N,)
        Increasing times [s].
    s0 : float
        ``s*(t[0])`` [m].

    Returns
    -------
    ndarray, shape (N,)
        [m].
    """
    t = np.asarray(t, float)
    if len(t) < 2:
        return np.full(len(t), float(s0))
    return ArcReference(ctrl.speeds).add(t, s0, ctrl.speeds(t))


def time_series(run: Any, ctrl: Any, s0: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Times, shape deviation [%] and end-point arc-length error [m] at up to :data:`TIME_SAMPLES` rows.

    Parameters
    ----------
    run : Run
        A method's run.
    ctrl : SpatialController
        Chain and curve.
    s0 : float
        The end point's arc length at the start [m].

    Returns
    -------
    t, shape, s_error : ndarray, each shape (k,)
    """
    rows = np.unique(np.linspace(0, len(run.t) - 1, TIME_SAMPLES).round().astype(int))
    dist, psi = centre_distances(ctrl, run.q[rows], run.t[rows])
    s_ref = reference_arc_length(ctrl, run.t, s0)
    shape = 100.0 * dist[:, 1:].mean(axis=1) / (ctrl.chain.m * ctrl.chain.xi)
    return run.t[rows], shape, np.abs(psi[:, -1] - s_ref[rows])


def draw_time_plots(axes: Sequence[Any], results: Sequence[Any], ctrl: Any) -> None:
    """The shape deviation and the end point's arc-length error of every method over time (log scales).

    Parameters
    ----------
    axes : two matplotlib Axes
        Where to draw.
    results : sequence of MethodRun
        The runs.
    ctrl : SpatialController
        Chain and curve.
    """
    s0 = float(centre_distances(ctrl, results[0].run.q[:1], results[0].run.t[:1])[1][0, -1])
    for r in results:
        t, shape, s_err = time_series(r.run, ctrl, s0)
        colour, dash, width = STYLES.get(r.method, ("k", "-", 1.0))
        for ax, values, floor in zip(axes, (shape, s_err), FLOORS):
            ax.plot(t, np.maximum(values, floor), dash, color=colour, lw=width, label=r.method)
    titles = ("shape deviation: mean distance of the centres from the path",
              "end point: arc-length error |psi(y^m) - s*(t)|")
    labels = ("mean distance / body length [%]", "arc-length error [m]")
    for ax, title, label, floor in zip(axes, titles, labels, FLOORS):
        ax.set_yscale("log")
        ax.set_ylim(bottom=floor * 0.5)
        ax.set_xlabel("t [s]")
        ax.set_ylabel(label)
        ax.set_title(title, fontsize=10, pad=20)
        ax.grid(alpha=0.3, which="both")
        ax.legend(fontsize=8, loc="lower left", bbox_to_anchor=(0.0, 1.0), ncol=len(results), frameon=False,
                  borderaxespad=0.1)                              # above the plot, under its title: off the data


def panel_title(result: Any) -> str:
    """A method's panel title: its name, where it stopped early, and its contact samples if any.

    Parameters
    ----------
    result : MethodRun
        The scored run.

    Returns
    -------
    str
    """
    run, scores = result.run, result.scores
    stopped = run.info.get("stopped", "?")
    notes = [] if stopped == "completed" else [f"{stopped} at {run.t[-1]:.2f} s"]
    notes += [f"{scores[k]} samples with {what}" for k, what in (("wall_contacts", "an obstacle contact"),
                                                                 ("self_collisions", "a self-collision"))
              if scores.get(k)]
    return result.method + (f"\n({'; '.join(notes)})" if notes else "")


def plot_bodies3d(results: Sequence[Any], scenario: Any, path: str | Path, stages: int = 4) -> Path:
    """``compare.png`` of a spatial scenario (see the module's docstring); a PNG.

    Parameters
    ----------
    results : sequence of MethodRun
        The runs to draw (at least one).
    scenario : Scenario
        Their scenario (universal joints).
    path : str or Path
        The PNG to write.
    stages : int
        Stage times, evenly spread over the scenario's duration.

    Returns
    -------
    Path
        The file written.
    """
    ctrl = scenario.controller()
    physical = scenario.physical(ctrl.chain)
    times = scenario.t0 + np.linspace(0.0, scenario.duration, stages)
    box = shared_box(results, ctrl, scenario.obstacles)
    s0 = float(centre_distances(ctrl, results[0].run.q[:1], results[0].run.t[:1])[1][0, -1])
    fine = scenario.t0 + np.linspace(0.0, scenario.duration, 2001)
    s_ref = np.interp(times, fine, reference_arc_length(ctrl, fine, s0))
    n = len(results)
    fig = Figure(figsize=(4.6 * max(n, 2), 9.2))
    grid = fig.add_gridspec(2, max(n, 2) * 2, height_ratios=(1.8, 1.0), left=0.05, right=0.97, bottom=0.07,
                            top=0.86, hspace=0.18, wspace=0.6)
    colours = matplotlib.colormaps["viridis"](np.linspace(0, 0.9, stages))
    for i, r in enumerate(results):
        ax = fig.add_subplot(grid[0, 2 * i:2 * i + 2], projection="3d")
        scene = method_scene(r.run, ctrl, times, box, scenario.obstacles, s_ref)
        drawn = colours[:len(scene["times"])]
        draw_view3d(ax, scene, drawn, [f"t = {t:.1f} s" for t in scene["times"]])
        for line in ax.lines:                 # the obstacles lighter, so that a body inside a cage stays visible
            if line.get_gid() == "obstacle":
                line.set_alpha(0.3)
                line.set_linewidth(0.6)
        ax.set_box_aspect(tuple(box[1] - box[0]), zoom=0.86)      # the z label inside the panel's own cell
        touched = contact_marks(r.run, ctrl.chain, contacts_between(physical, r.run, scenario.step, -np.inf, times[-1]))
        draw_contact_marks(ax, touched, (0, 1, 2), names=False, note=FIRST)
        ax.set_title(panel_title(r), fontsize=11, color=STYLES.get(r.method, ("k",))[0])
    half = max(n, 2)
    draw_time_plots([fig.add_subplot(grid[1, :half]), fig.add_subplot(grid[1, half:])], results, ctrl)
    handles = [Line2D([], [], color=c, lw=2.5) for c in colours]
    handles += [Line2D([], [], ls="--", color="gray"), Line2D([], [], ls="", marker="x", color="gray", mew=2)]
    names = [f"t = {t:.1f} s" for t in times] + ["path at that time", "target s*(t)"]
    if any(line.get_gid() == "contact" for ax in fig.axes for line in ax.get_lines()):
        handles.append(Line2D([], [], **CONTACT_STYLE))
        names.append(FIRST)
    fig.legend(handles, names, loc="upper center", ncol=len(names), fontsize=9, bbox_to_anchor=(0.5, 0.96))
    fig.suptitle(f"{scenario.name}: {ctrl.chain.m} links with universal joints, the same task under each method",
                 fontsize=12)
    path = Path(path)
    fig.savefig(path, dpi=100)
    return path
