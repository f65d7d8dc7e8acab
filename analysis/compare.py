"""The same scenario under coordarm's law and the classic baselines, scored side by side.

Every method's run is scored from its joint trajectory alone, by the same code: the one table of
scores :data:`.compare_scores.SCORE_TABLE` (deviations, the shape deviation as a percentage of the
body length, contacts, peak rates, the end point's arc-length error, the time per step).

Planar chains and spatial chains (universal joints) alike: ``pinv`` and ``dls`` drive the end point
(three task rows in 3-D, :mod:`.spatial_baselines`), ``ftl`` (:mod:`.follow_leader`,
:mod:`.follow_leader3d`) applies to robots on a rail only. The coordinating law of a rail robot runs
in CasADi's virtual machine when its generated C is not available.
"""
from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from coordarm.simulation.contact_marks import contact_marks, draw_contact_marks
from coordarm.simulation.obstacles import outline
from coordarm.simulation.choices import COMPARE_METHODS
from coordarm.simulation.run import Run, even_indices, select_backend, simulate
from coordarm.simulation.scenario import Scenario
from coordarm.symbolic import (BuildError, CollisionError, ConfigError, CoordinatingController, PlanarChain,
                               SingularityError)

from .baselines import BACKENDS, BASELINES, EndPointRate, simulate_baseline, stop_at_rail_limit
from .compare_figures3d import plot_bodies3d
from .compare_scores import CONTACT_RATE, SINCE, contacts_between, RAIL_SCORES, SCORE_TABLE, SCORES, score, score_rows
from .follow_leader import FollowTheLeader, simulate_ftl
from .follow_leader3d import SpatialFollowTheLeader, check_rail

#: Methods of ``coordarm compare`` in table order.
METHODS = COMPARE_METHODS
__all__ = ["CONTACT_RATE", "DEFAULT_DLS", "METHODS", "RAIL_SCORES", "SCORES", "SCORE_TABLE", "MethodRun",
           "available_methods", "compare", "markdown_table", "parse_methods", "run_method", "score", "text_table",
           "to_json", "write_outputs"]
#: Damping of the ``dls`` baseline unless the scenario sets ``[control] damping``.
DEFAULT_DLS = {"kind": "dls", "lambda": 0.01, "band": 0.1}


@dataclass
class MethodRun:
    """One method's run of a scenario and its scores (keys :data:`SCORES`).

    Attributes
    ----------
    method : str
        One of :data:`METHODS`.
    run : Run
        The simulated run.
    scores : dict of str to Any
        Its scores (see :func:`score`).
    """

    method: str
    run: Run
    scores: dict[str, Any] = field(default_factory=dict)


def available_methods(scenario: Scenario) -> tuple[str, ...]:
    """Methods that apply to ``scenario``: all of them on a rail robot; ``ftl`` needs the rail.

    Parameters
    ----------
    scenario : Scenario
        The scenario.

    Returns
    -------
    tuple of str
        Names from :data:`METHODS`, in that order.

    """
    rail = scenario.chain().rail
    return tuple(m for m in METHODS if m != "ftl" or rail)


def parse_methods(text: str | None, scenario: Scenario) -> list[str]:
    """``"coordinating,pinv"`` as a list (default: all that apply); a ConfigError names a bad one.

    Parameters
    ----------
    text : str or None
        Comma-separated method names (the ``--methods`` option), or None for all that apply.
    scenario : Scenario
        The scenario the methods are to run.

    Returns
    -------
    list of str
        The names, duplicates dropped, in the order given.

    Raises
    ------
    ConfigError
        An unknown name, ``ftl`` without a rail, or an empty list.
    """
    if text is None:
        return list(available_methods(scenario))
    names = [n.strip() for n in text.split(",") if n.strip()]
    for n in names:
        if n not in METHODS:
            raise ConfigError(f"--methods: unknown method {n!r}; choose from {', '.join(METHODS)}")
        if n not in available_methods(scenario):
            if scenario.universal:
                try:
                    check_rail(scenario.chain(), scenario.name)
                except ConfigError as err:
                    raise ConfigError(f"--methods: {err}") from None
            raise ConfigError(f"--methods: {n!r} needs a robot with an introduction axis (rail); "
                              f"scenario {scenario.name!r} has none")
    if not names:
        raise ConfigError("--methods: empty list")
    return list(dict.fromkeys(names))


def run_method(method: str, scenario: Scenario, backend: str = "compiled") -> Run:
    """Simulate ``scenario`` under ``method``; a run stopped early says why in ``info["stopped"]``.

    Every run ends where it would leave the rail's limits (``rail_limit``, see
    :func:`.baselines.stop_at_rail_limit`).

    Parameters
    ----------
    method : str
        One of :data:`METHODS`.
    scenario : Scenario
        The scenario.
    backend : str
        ``"compiled"`` (generated C for every method, built before the clock starts; the
        coordinating law of a rail robot falls back to the interpreted law where its C cannot be
        generated) or ``"interpreted"`` (CasADi's virtual machine for every method).

    Returns
    -------
    Run
        The run, cut at the rail's limits.

    Raises
    ------
    ConfigError
        ``backend`` is not one of ``BACKENDS``.
    BuildError
        ``backend="compiled"`` and a library cannot be built.
    """
    if backend not in BACKENDS:
        raise ConfigError(f"backend: expected one of {BACKENDS}, got {backend!r}")
    ctrl = scenario.controller()
    return stop_at_rail_limit(_run(method, scenario, ctrl, backend), ctrl.chain)


def _run(method: str, scenario: Scenario, ctrl: CoordinatingController, backend: str) -> Run:
    """:func:`run_method` before the rail's limits are applied."""
    q0 = scenario.start(ctrl)
    if method == "coordinating":
        try:
            backend, _, _ = select_backend(ctrl, backend)
        except BuildError:
            if not ctrl.chain.rail:
                raise
            backend = "interpreted"    # no generated C of the rail law on this version yet
        try:   # the loop's own wall time (info["wall_time"]) excludes the build and the start checks
            run = simulate(ctrl, q0, scenario.duration, scenario.step, scenario.t0, backend=backend,
                           thresholds=scenario.thresholds, progress=False)
        except (SingularityError, CollisionError) as err:   # no physical= here: contacts are scored
            run = err.run
        run.info["steps"] = max(len(run.t) - 1, 1)
        return run
    if method in BASELINES:
        damping = (scenario.config.control.damping or DEFAULT_DLS) if method == "dls" else None
        law = EndPointRate(ctrl, q0, damping)
        return simulate_baseline(law, q0, scenario.duration, scenario.step, scenario.t0, backend=backend)
    if method == "ftl" and scenario.universal:
        check_rail(ctrl.chain, scenario.name)
        return simulate_ftl(SpatialFollowTheLeader(ctrl, q0, scenario.t0), scenario.duration, scenario.step,
                            backend)
    if method == "ftl" and ctrl.chain.rail:
        return simulate_ftl(FollowTheLeader(ctrl, q0, scenario.t0), scenario.duration, scenario.step, backend)
    raise ConfigError(f"method: {method!r} is not available for scenario {scenario.name!r}")


def compare(scenario: Scenario, methods: list[str] | None = None, backend: str = "compiled",
            progress: bool = False) -> list[MethodRun]:
    """Run and score ``scenario`` under each of ``methods`` (default: all that apply) on ``backend``.

    Parameters
    ----------
    scenario : Scenario
        The scenario.
    methods : list of str or None
        Names from :data:`METHODS` (None or empty: :func:`available_methods`).
    backend : str
        ``"compiled"`` or ``"interpreted"`` (see :func:`run_method`).
    progress : bool
        A bar on stderr, a step per method done.

    Returns
    -------
    list of MethodRun
        One per method, in order.
    """
    from coordarm.simulation.progress import Progress

    out = []
    todo = methods or available_methods(scenario)
    bar = Progress(len(todo), label="compare", unit="{done:.0f}/{total:.0f} methods") if progress else None
    for i, method in enumerate(todo):
        run = run_method(method, scenario, backend)
        out.append(MethodRun(method, run, score(run, scenario)))
        if bar:
            bar.update(i + 1)
    if bar:
        bar.close()
    return out


def to_json(scenario: Scenario, results: list[MethodRun]) -> dict[str, Any]:
    """``{"scenario": name, "methods": {method: {score: value}}}``, scores in :data:`SCORE_TABLE` order.

    Parameters
    ----------
    scenario : Scenario
        The scenario compared.
    results : list of MethodRun
        Its scored runs.

    Returns
    -------
    dict of str to Any
        The JSON-ready summary.
    """
    return {"scenario": scenario.name, "methods": {r.method: dict(r.scores) for r in results}}


#: How each backend runs the methods (for compare.md).
ENGINES = {"compiled": "as generated C", "interpreted": "in CasADi's virtual machine"}


def engines(results: list[MethodRun]) -> str:
    """How the methods ran, e.g. ``"every method as generated C"`` or ``"coordinating in ..., pinv, dls as ..."``.

    Parameters
    ----------
    results : list of MethodRun
        The scored runs (their ``run.info["backend"]``).

    Returns
    -------
    str
        The phrase.
    """
    used = {r.method: r.run.info.get("backend", "interpreted") for r in results}
    if len(set(used.values())) == 1:
        return f"every method {ENGINES[next(iter(used.values()))]}"
    return ", ".join(", ".join(m for m in used if used[m] == b) + f" {ENGINES[b]}"
                     for b in ENGINES if b in used.values())


def headers(results: list[MethodRun]) -> list[str]:
    """The table's column titles, with units (:data:`SCORE_TABLE`'s rows the runs have).

    Parameters
    ----------
    results : list of MethodRun
        The scored runs.

    Returns
    -------
    list of str
        ``"method"``, then one title per score.
    """
    return ["method"] + [row.header for row in score_rows(results[0].scores if results else {})]


def table_rows(results: list[MethodRun]) -> list[list[str]]:
    """The table's cells, one row per method.

    Parameters
    ----------
    results : list of MethodRun
        The scored runs.

    Returns
    -------
    list of list of str
        One row per run, columns as :func:`headers`.
    """
    rows = score_rows(results[0].scores if results else {})
    return [[r.method] + [row.cell(r.scores[row.key]) for row in rows] for r in results]


def text_table(results: list[MethodRun]) -> str:
    """The scores as an aligned plain-text table.

    Parameters
    ----------
    results : list of MethodRun
        The scored runs.

    Returns
    -------
    str
        The table, lines joined by newlines.
    """
    rows = [headers(results)] + table_rows(results)
    widths = [max(len(row[i]) for row in rows) for i in range(len(rows[0]))]
    lines = ["  ".join(c.ljust(w) for c, w in zip(row, widths)).rstrip() for row in rows]
    lines.insert(1, "  ".join("-" * w for w in widths))
    return "\n".join(lines)


def markdown_table(results: list[MethodRun]) -> str:
    """The scores as a Markdown table.

    Parameters
    ----------
    results : list of MethodRun
        The scored runs.

    Returns
    -------
    str
        The table, lines joined by newlines.
    """
    head = headers(results)
    rows = [head, ["---"] * len(head)] + table_rows(results)
    return "\n".join("| " + " | ".join(row) + " |" for row in rows)


def stage_times(scenario: Scenario, stages: int = 4) -> np.ndarray:
    """``stages`` times evenly spread over the scenario, start and end included [s].

    Parameters
    ----------
    scenario : Scenario
        Its ``t0`` and ``duration`` [s].
    stages : int
        Number of times.

    Returns
    -------
    ndarray, shape (stages,)
        The times [s].
    """
    return scenario.t0 + np.linspace(0.0, scenario.duration, stages)


def rail_segment(chain: PlanarChain, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """The rail's ends (2, 2) [m]: its limits, cut to the box ``lo``..``hi`` where they are farther or infinite.

    Parameters
    ----------
    chain : PlanarChain
        A chain on a rail (``rail_limits`` [m], ``rail_direction``).
    lo, hi : ndarray, shape (2,)
        Corners of the plotted box [m].

    Returns
    -------
    ndarray, shape (2, 2)
        The two ends [m], one per row.
    """
    reach = float(np.linalg.norm(np.abs(lo) + np.abs(hi)))
    ends = np.clip(np.array(chain.rail_limits), -reach, reach)
    return ends[:, None] * chain.rail_direction


def plot_bodies(results: list[MethodRun], scenario: Scenario, path: str | Path, stages: int = 4) -> Path:
    """One panel per stage time with every method's body (and the curve, the walls, the rail) then; a PNG.

    A scene much wider than tall (a path) gets one panel per row. The links that touched a wall or the body
    itself since the previous panel (:func:`~.compare_scores.contacts_between`) are ringed red where they
    touched (:mod:`coordarm.simulation.contact_marks`); the walls are named in the first panel.

    Parameters
    ----------
    results : list of MethodRun
        The runs to draw.
    scenario : Scenario
        Their scenario.
    path : str or Path
        The PNG to write.
    stages : int
        Number of panels (times from :func:`stage_times`).

    Returns
    -------
    Path
        The file written.
    """
    from coordarm.simulation.figures import draw_obstacles, plt, save_figure

    ctrl = scenario.controller()
    chain = ctrl.chain
    physical = scenario.physical(chain)
    times = stage_times(scenario, stages)
    colours = dict(zip(METHODS, ("tab:blue", "tab:orange", "tab:green", "tab:red")))
    pts = [chain.joints_np(r.run.q[even_indices(len(r.run.t), 50)]).reshape(-1, 2) for r in results]
    walls = [outline(ob) for ob in scenario.obstacles]
    allp = np.concatenate(pts + walls)
    lo, hi = allp.min(axis=0) - 0.2, allp.max(axis=0) + 0.2
    extent = float(np.linalg.norm(hi - lo))
    wide = (hi - lo)[0] > 1.8 * (hi - lo)[1]
    shape, size = ((len(times), 1), (13.0, 0.6 + 13.0 * (hi - lo)[1] / (hi - lo)[0] * len(times))) if wide else \
        ((1, len(times)), (4.2 * len(times), 4.4))
    fig, axes = plt.subplots(*shape, figsize=size, squeeze=False, layout="constrained")
    # each method its own colour, width and dash, widest first, so a body drawn on top of another shows both
    widths = dict(zip(METHODS, (4.0, 2.8, 1.6, 1.0)))
    dashes = dict(zip(METHODS, ("-", "-", (0, (4, 2)), (0, (1, 1.5)))))
    for i, (ax, t) in enumerate(zip(axes.ravel(), times)):
        cur = ctrl.curve.sample(float(t), extent=extent)
        ax.plot(cur[:, 0], cur[:, 1], "k--", lw=0.8, alpha=0.6, label="curve")
        if chain.rail:
            rail = rail_segment(chain, lo, hi)
            ax.plot(rail[:, 0], rail[:, 1], "-", color="0.6", lw=5, alpha=0.5, solid_capstyle="butt",
                    label="rail", zorder=0)
        draw_obstacles(ax, scenario.obstacles, labels=ax is axes.flat[0])     # walls named in the first panel
        for r in results:
            k = int(np.argmin(np.abs(r.run.t - t)))
            late = r.run.t[-1] < t - 0.5 * scenario.step
            J = chain.joints_np(r.run.q[k])
            ax.plot(J[:, 0], J[:, 1], linestyle=dashes[r.method], color=colours[r.method], lw=widths[r.method],
                    alpha=0.35 if late else 0.9, zorder=3)
            base = chain.base_point(r.run.q[k])
            ax.plot(base[0], base[1], "s", color=colours[r.method] if chain.rail else "k", ms=5, zorder=4)
            after = times[i - 1] if i else -np.inf           # the contacts since the previous panel, where they were
            touched = contact_marks(r.run, chain, contacts_between(physical, r.run, scenario.step, after, t))
            draw_contact_marks(ax, touched, names=False, note=SINCE)
        ax.set_xlim(lo[0], hi[0])
        ax.set_ylim(lo[1], hi[1])
        ax.set_aspect("equal")
        ax.set_xlabel("y$_1$ [m]")
        ax.set_ylabel("y$_2$ [m]")
        ax.set_title(f"t = {t:.1f} s")
        ax.grid(alpha=0.3)
    handles, labels = method_legend(results, times, colours, widths, dashes, chain.rail)
    rings = [h for ax in axes.flat for h, lab in zip(*ax.get_legend_handles_labels()) if lab == SINCE]
    handles, labels = handles + rings[:1], labels + [SINCE] * bool(rings)
    fig.legend(handles, labels, loc="outside lower center", ncol=len(labels), fontsize=8, frameon=False)
    what = "the curve" + (", grey: the rail, squares: the bases" if chain.rail else "")
    fig.suptitle(f"{scenario.name}: {chain.m} links, the same task under each method (dashed: {what})")
    return save_figure(fig, path)


def method_legend(results: list[MethodRun], times: np.ndarray, colours: dict, widths: dict, dashes: dict,
                  rail: bool = False) -> tuple[list, list[str]]:
    """The legend entries of ``compare.png``'s methods, opaque, each saying when it stopped if it did early.

    Parameters
    ----------
    results : list of MethodRun
        The runs drawn.
    times : ndarray
        The panels' times [s].
    colours, widths, dashes : dict
        Each method's colour, line width and dash pattern.
    rail : bool
        The robot is on a rail (drawn grey).

    Returns
    -------
    handles : list of Line2D
    labels : list of str
    """
    from matplotlib.lines import Line2D

    handles, labels = [Line2D([], [], ls="--", color="k", lw=0.8, alpha=0.6)], ["curve"]
    if rail:
        handles.append(Line2D([], [], color="0.6", lw=5, alpha=0.5))
        labels.append("rail")
    for r in results:
        handles.append(Line2D([], [], linestyle=dashes[r.method], color=colours[r.method], lw=widths[r.method]))
        early = r.run.t[-1] < times[-1] - 1e-9
        labels.append(r.method + (f" (stopped at {r.run.t[-1]:.2f} s)" if early else ""))
    return handles, labels


def write_outputs(scenario: Scenario, results: list[MethodRun], out: Path, backend: str = "compiled"
                  ) -> dict[str, Path]:
    """``compare.json``, ``compare.md`` and ``compare.png`` in the directory ``out``.

    Parameters
    ----------
    scenario : Scenario
        The scenario compared.
    results : list of MethodRun
        Its scored runs.
    out : Path
        Output directory (created if missing).
    backend : str
        Unused: the Markdown names each run's backend from :func:`engines`.

    Returns
    -------
    dict of str to Path
        ``{"json": ..., "md": ..., "png": ...}``.
    """
    out.mkdir(parents=True, exist_ok=True)
    paths = {"json": out / "compare.json", "md": out / "compare.md", "png": out / "compare.png"}
    paths["json"].write_text(json.dumps(to_json(scenario, results), indent=2) + "\n")
    if scenario.universal:
        plot_bodies3d(results, scenario, paths["png"])
    else:
        plot_bodies(results, scenario, paths["png"])
    paths["md"].write_text(
        f"# {scenario.name}: coordinating control and the baselines\n\n{markdown_table(results)}\n\n"
        f"Scores from each run's joint trajectory ({scenario.duration:g} s, RK4 step {scenario.step:g} s, "
        f"{engines(results)}); "
        f"contacts are samples at {CONTACT_RATE:g} Hz.\n\n"
        f"![bodies at the same times](compare.png)\n")
    return paths
