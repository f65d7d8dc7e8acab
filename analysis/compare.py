"""The same scenario under coordarm's law and the classic baselines, scored side by side.

Every method's run is scored from its joint trajectory alone, by the same code:

* ``max_deviation``: the largest ``|phi|`` of any central point ``y^2..y^m`` over the run [m]
  (body following; ``y^1`` is the pinned base);
* ``wall_contacts``, ``self_collisions``: samples (at :data:`CONTACT_RATE`) in which some link
  touches an obstacle, or two non-adjacent links touch each other (within the chain's
  clearance; :func:`coordarm.simulation.physical.check_configuration`);
* ``peak_u``, ``peak_joint_rate``: largest ``|u|`` and ``|qdot| = |B u|`` of the revolute joints [rad/s];
* ``peak_rail_rate`` (a robot on a rail only): largest ``|d_dot|`` [m/s];
* ``final_s_error``: ``|psi(y^m) - (s(0) + integral of v*)|`` at the run's last sample [m];
* ``step_time``: wall time of the stepping loop per RK4 step [s] (``ftl``: of its one mapped call per sample).

``ftl`` (:mod:`.follow_leader`) applies to robots on a rail only. The coordinating law of a rail
robot runs in CasADi's virtual machine when its generated C is not available.
"""
from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from coordarm.simulation.obstacles import outline
from coordarm.simulation.choices import COMPARE_METHODS
from coordarm.simulation.run import Run, even_indices, select_backend, simulate
from coordarm.simulation.scenario import Scenario
from coordarm.symbolic import (BuildError, CollisionError, ConfigError, CoordinatingController, PlanarChain,
                               SingularityError)

from .baselines import BACKENDS, BASELINES, EndPointRate, simulate_baseline, stop_at_rail_limit
from .follow_leader import FollowTheLeader, simulate_ftl

#: Methods of ``coordarm compare`` in table order.
METHODS = COMPARE_METHODS
#: Scores of one method, in table and JSON order.
SCORES = ("outcome", "max_deviation", "wall_contacts", "self_collisions", "peak_u", "peak_joint_rate",
          "final_s_error", "step_time", "peak_du_dt")
#: The extra scores of a robot on a rail (``peak_rail_rate`` after ``peak_joint_rate`` in the table; last in the JSON).
RAIL_SCORES = ("peak_rail_rate", "peak_rail_accel")
#: Samples per simulated second at which contacts are counted [Hz].
CONTACT_RATE = 100.0
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

    Raises
    ------
    ConfigError
        A spatial scenario (the baselines are planar).
    """
    if scenario.universal:
        raise ConfigError("chain.joints: 'universal': the baselines (pinv, dls, ftl) and the comparison are "
                          "planar; a spatial scenario is not compared yet")
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
    if method == "ftl" and ctrl.chain.rail:
        return simulate_ftl(FollowTheLeader(ctrl, q0, scenario.t0), scenario.duration, scenario.step, backend)
    raise ConfigError(f"method: {method!r} is not available for scenario {scenario.name!r}")


def score(run: Run, scenario: Scenario) -> dict[str, Any]:
    """The scores of one run (keys :data:`SCORES`), computed from ``run.q`` and ``run.u`` only.

    Parameters
    ----------
    run : Run
        A run of ``scenario``.
    scenario : Scenario
        Its scenario (chain, curve, obstacles, step).

    Returns
    -------
    dict of str to Any
        ``outcome`` (str), ``max_deviation`` [m], ``wall_contacts`` and ``self_collisions``
        (contact sample counts), ``peak_u`` [rad/s], ``peak_joint_rate`` [rad/s],
        ``final_s_error`` [m], ``step_time`` (wall time per step) [s], ``peak_du_dt`` (the
        largest joint acceleration over every step, ``run.info["joint_rates"]``) [rad/s^2]; on a
        rail also ``peak_rail_rate`` [m/s] and ``peak_rail_accel`` [m/s^2].
    """
    ctrl = scenario.controller()
    geo = ctrl.centre_geometry(run.q, run.t)
    s_ref = geo["psi"][0, -1] + np.concatenate(
        [[0.0], np.cumsum(0.5 * np.diff(run.t) * (run.v_star[1:] + run.v_star[:-1]))])
    every = max(1, int(round(1.0 / (CONTACT_RATE * scenario.step))))
    rows = np.unique(np.r_[np.arange(0, len(run.t), every), len(run.t) - 1])
    contacts = scenario.physical(ctrl.chain).check(run.t[rows], run.q[rows])
    u = ctrl.chain.revolute(run.u)
    rates = ctrl.chain.apply_B(u)

    def samples(kind: str) -> int:
        return len({c.time for c in contacts if c.kind == kind})

    out = {"outcome": run.info.get("stopped", "?"),
           "max_deviation": float(np.max(np.abs(geo["phi"][:, 1:]))),
           "wall_contacts": samples("wall"),
           "self_collisions": samples("self"),
           "peak_u": float(np.max(np.abs(u))),
           "peak_joint_rate": float(np.max(np.abs(rates))),
           "final_s_error": float(abs(geo["psi"][-1, -1] - s_ref[-1])),
           "step_time": float(run.info["wall_time"] / run.info["steps"])}
    peaks = run.info.get("joint_rates") or {}           # every step; else (a baseline) the rows kept
    dt = np.diff(run.t)[:, None]
    out["peak_du_dt"] = peaks.get("du_dt", float(np.max(np.abs(np.diff(u, axis=0)) / dt, initial=0.0)))
    if ctrl.chain.rail:
        out["peak_rail_rate"] = float(np.max(np.abs(run.u[:, 0])))
        out["peak_rail_accel"] = peaks.get("rail_accel", float(np.max(np.abs(np.diff(run.u[:, :1], axis=0)) / dt,
                                                                      initial=0.0)))
    return out


def compare(scenario: Scenario, methods: list[str] | None = None, backend: str = "compiled") -> list[MethodRun]:
    """Run and score ``scenario`` under each of ``methods`` (default: all that apply) on ``backend``.

    Parameters
    ----------
    scenario : Scenario
        The scenario.
    methods : list of str or None
        Names from :data:`METHODS` (None or empty: :func:`available_methods`).
    backend : str
        ``"compiled"`` or ``"interpreted"`` (see :func:`run_method`).

    Returns
    -------
    list of MethodRun
        One per method, in order.
    """
    out = []
    for method in methods or available_methods(scenario):
        run = run_method(method, scenario, backend)
        out.append(MethodRun(method, run, score(run, scenario)))
    return out


def to_json(scenario: Scenario, results: list[MethodRun]) -> dict[str, Any]:
    """``{"scenario": name, "methods": {method: {score: value}}}`` (on a rail with :data:`RAIL_SCORES` last).

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
    keys = SCORES + tuple(k for k in RAIL_SCORES if results and k in results[0].scores)
    return {"scenario": scenario.name, "methods": {r.method: {k: r.scores[k] for k in keys} for r in results}}


HEADERS = ("method", "outcome", "max dev [m]", "wall", "self", "peak u [rad/s]", "peak rate [rad/s]",
           "final s err [m]", "step [µs]")
#: The column of a rail robot, after ``peak rate``.
RAIL_HEADER = "peak rail rate [m/s]"


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
#: Lengths below this are rounding noise in the table (the JSON keeps them) [m].
LENGTH_FLOOR = 1e-9


def _length(value: float) -> str:
    return "< 1e-9" if value < LENGTH_FLOOR else f"{value:.3g}"


def headers(results: list[MethodRun]) -> list[str]:
    """The table's column titles (a rail robot's runs get :data:`RAIL_HEADER`).

    Parameters
    ----------
    results : list of MethodRun
        The scored runs.

    Returns
    -------
    list of str
        The titles, with units.
    """
    out = list(HEADERS)
    if results and "peak_rail_rate" in results[0].scores:
        out.insert(HEADERS.index("peak rate [rad/s]") + 1, RAIL_HEADER)
    return out


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
    rows = []
    for r in results:
        s = r.scores
        row = [r.method, s["outcome"], _length(s["max_deviation"]), str(s["wall_contacts"]),
               str(s["self_collisions"]), f"{s['peak_u']:.3g}", f"{s['peak_joint_rate']:.3g}",
               _length(s["final_s_error"]), f"{1e6 * s['step_time']:.1f}"]
        if "peak_rail_rate" in s:
            row.insert(HEADERS.index("peak rate [rad/s]") + 1, f"{s['peak_rail_rate']:.3g}")
        rows.append(row)
    return rows


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

    A scene much wider than tall (a path) gets one panel per row.

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
    from coordarm.simulation.figures import plt, save_figure

    ctrl = scenario.controller()
    chain = ctrl.chain
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
    for ax, t in zip(axes.ravel(), times):
        cur = ctrl.curve.sample(float(t), extent=extent)
        ax.plot(cur[:, 0], cur[:, 1], "k--", lw=0.8, alpha=0.6)
        if chain.rail:
            rail = rail_segment(chain, lo, hi)
            ax.plot(rail[:, 0], rail[:, 1], "-", color="0.6", lw=5, alpha=0.5, solid_capstyle="butt",
                    label="rail", zorder=0)
        for w in walls:
            ax.plot(w[:, 0], w[:, 1], "k-", lw=3, solid_capstyle="butt")
        for r in results:
            k = int(np.argmin(np.abs(r.run.t - t)))
            late = r.run.t[-1] < t - 0.5 * scenario.step
            J = chain.joints_np(r.run.q[k])
            ax.plot(J[:, 0], J[:, 1], "-", color=colours[r.method], lw=1.4, alpha=0.35 if late else 1.0,
                    label=r.method + (f" (stopped at {r.run.t[-1]:.2f} s)" if late else ""))
            base = chain.base_point(r.run.q[k])
            ax.plot(base[0], base[1], "s", color=colours[r.method] if chain.rail else "k", ms=5)
        ax.set_xlim(lo[0], hi[0])
        ax.set_ylim(lo[1], hi[1])
        ax.set_aspect("equal")
        ax.set_title(f"t = {t:.1f} s")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7, loc="best")
    what = "the curve" + (", grey: the rail, squares: the bases" if chain.rail else "")
    fig.suptitle(f"{scenario.name}: {chain.m} links, the same task under each method (dashed: {what})")
    return save_figure(fig, path)


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
    plot_bodies(results, scenario, paths["png"])
    paths["md"].write_text(
        f"# {scenario.name}: coordinating control and the baselines\n\n{markdown_table(results)}\n\n"
        f"Scores from each run's joint trajectory ({scenario.duration:g} s, RK4 step {scenario.step:g} s, "
        f"{engines(results)}); "
        f"contacts are samples at {CONTACT_RATE:g} Hz.\n\n"
        f"![bodies at the same times](compare.png)\n")
    return paths
