"""Singularity and condition report of a run: which margin predicts a blow-up, and when.

Works from any object with arrays ``t`` (N,), ``q`` (N, m) and ``u`` (N, m) — a
:class:`simulation.run.Run` or a replayed log — plus its :class:`simulation.scenario.Scenario`.
The analysis itself (margins, crossings, the blow-up) is :func:`.run_analysis.analyse_run`;
:func:`write_report` writes it as ``report.md`` with the figures of :mod:`.report_figures`,
and ``report.json`` (smallest margins with time and link, the blow-up, the outcome, collisions).
"""
from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np

from coordarm.simulation.summary import rate_lines
from coordarm.simulation.run import even_indices
from coordarm.symbolic import CoordinatingController, SingularityError

from .linearise import linearise_run
from .orthonormal import check_orthonormal
from .run_analysis import BLOWUP_FACTOR, LABELS, RunAnalysis, analyse_run
from .run_analysis import default_samples  # noqa: F401  (the report's sampling, read by coordarm report)
from .singularity import MARGINS
from .stability import RK4_LIMIT, delay_margin, max_stable_delay, sampled_limit

#: Stop thresholds that never stop a run, so that a blow-up shows.
NO_STOP = {"link": 0.0, "longitudinal": 0.0}


def simulate_through(ctrl: CoordinatingController, q0, duration: float, step: float, t0: float = 0.0,
                     backend: str = "auto", progress: bool = False) -> Any:
    """Simulate without singularity stops; a run that ends in non-finite margins is kept up to there.

    Parameters
    ----------
    ctrl : CoordinatingController
        The controller.
    q0 : (dof,) array_like
        Start configuration [rad] (``d`` [m] first on a rail).
    duration : float
        Simulated time span [s].
    step : float
        RK4 step [s].
    t0 : float
        Start time [s].
    backend : {"auto", "compiled", "interpreted"}
        :func:`~coordarm.simulation.run.simulate`'s backend (past a blow-up the trajectory
        depends on rounding, so the compiled and interpreted laws part there).
    progress : bool
        A progress bar on stderr (the simulation of a ``coordarm report SCENARIO``).

    Returns
    -------
    Run
        The whole run, or, when non-finite margins stopped it, the rows computed until then.
    """
    from coordarm.simulation.run import simulate

    try:
        return simulate(ctrl, q0, duration, step, t0, thresholds=NO_STOP, progress=progress, backend=backend)
    except SingularityError as err:        # only non-finite margins stop it: keep what was computed
        return err.run

def _fmt(x: float | None, unit: str = " s") -> str:
    return "never" if x is None else f"{x:.3f}{unit}"


def markdown(analysis: RunAnalysis, scenario: Any, ctrl: CoordinatingController, step: float | None,
             figures: list[Path], checks: dict) -> str:
    """The report as Markdown text (tables of margins, predictions, linearisation, sampled-data limits).

    Parameters
    ----------
    analysis : RunAnalysis
        The analysis of the run (:func:`.run_analysis.analyse_run`).
    scenario : Scenario
        Its scenario (``name`` and ``source`` are printed).
    ctrl : CoordinatingController
        Its controller (link count and length, gain ``K`` [1/s]).
    step : float or None
        The run's step [s]; None leaves out the sampled-data lines.
    figures : list of Path
        Figure files, linked by file name (they sit next to the report).
    checks : dict
        ``"orthonormal"``: the curve check's message (str); ``"linearisations"``: a list of
        :class:`.linearise.Linearisation` along the run; ``"joint_rates"``: the run's peak joint
        accelerations (:attr:`~coordarm.simulation.joint_rates.JointRates.peaks`), optional.

    Returns
    -------
    str
        The Markdown text, ending in a newline.
    """
    a = analysis
    m, K = ctrl.chain.m, ctrl.gain
    lines = [f"# Singularity report: {scenario.name}", "",
             f"* scenario: `{scenario.source}`, {m} links of {ctrl.chain.xi} m, K = {K:g} 1/s",
             f"* run: t = {a.t_all[0]:.3f} .. {a.t_all[-1]:.3f} s, {len(a.t_all)} samples "
             f"(margins at {len(a.t)} of them)",
             f"* curve description: {checks['orthonormal']}", "",
             "## Margins (dimensionless, 0 = singular)", "",
             "| margin | threshold | smallest (at) | first below threshold | predicted the blow-up |",
             "|---|---|---|---|---|"]
    pred = a.predicted()
    for name in MARGINS:
        lo, when = a.minima[name]
        p = pred[name]
        ptxt = ("no blow-up" if p is None else
                (f"**yes**, {a.blowup_time - a.crossings[name]:.3f} s ahead" if p else "no"))
        lines.append(f"| {LABELS[name]} | {a.thresholds[name]:g} | {lo:.3g} ({when:.3f} s) | "
                     f"{_fmt(a.crossings[name])} | {ptxt} |")
    worst = a.margins["worst_link"]
    k = int(np.argmin(a.smallest("links")))
    amps = a.margins["amplification"]
    amp = f"{np.nanmax(amps):.4g}" if np.isfinite(amps).any() else "n/a (v* = 0 throughout)"
    lines += ["", f"Worst link over the run: link {int(worst[k])} at t = {a.t[k]:.3f} s; "
              f"links that were ever the worst: {sorted(set(int(w) for w in worst))[:20]}.", "",
              "## Blow-up", "",
              f"* nominal |u|_inf (median over the run, at least (max v* + K max|e(0)|)/xi): {a.nominal_u:.4g} rad/s",
              f"* first |u|_inf > {BLOWUP_FACTOR:g} x nominal: {_fmt(a.blowup_time)}",
              f"* largest |u|_inf: {np.nanmax(a.u_norm):.4g} rad/s; largest cond(M): "
              f"{np.nanmax(a.margins['cond']):.4g}; largest amplification xi|u|/|v*|: {amp}"]
    lines += [f"* {line} (every step of the run)" for line in rate_lines(checks.get("joint_rates"))]
    if a.blowup_time is not None:
        good = [LABELS[n] for n, p in pred.items() if p]
        lines.append(f"* predicted by: {', '.join(good) if good else 'no margin at its threshold'}")
    lines += ["", "## Linearised error dynamics", "",
              "Closed loop linearised by CasADi AD at points of the run, mapped to task coordinates "
              "(s, e^2..e^m) including the change of the task map along the trajectory; the design is "
              f"diag(0, -K, ..., -K) with K = {K:g}.", "",
              "| t [s] | max abs(A - design) | eigenvalue farthest from design | frozen-Jacobian error |",
              "|---|---|---|---|"]
    for L in checks["linearisations"]:
        ev = L.eigenvalues()
        target = np.array([0.0] * L.free + [-K] * (len(L.q) - L.free))
        far = ev[np.argmax(np.abs(ev - target))]
        frozen = L.deviation_from_design(K, frozen=True)
        lines.append(f"| {L.t:.3f} | {L.deviation_from_design(K):.2e} | {far.real:.6g}{far.imag:+.2g}j | {frozen:.3g} |")
    lines += sampled_data_lines(K, step)
    lines += ["", "## Figures", ""] + [f"![{p.stem}]({p.name})" for p in figures]
    return "\n".join(lines) + "\n"


def sampled_data_lines(K: float, step: float | None) -> list[str]:
    """The report's section on sampled-data and delay limits of one deviation loop ``e' = -K e``.

    Parameters
    ----------
    K : float
        Error gain [1/s].
    step : float or None
        The run's step [s]; None leaves out the sampled-data lines (the delay margin stays).

    Returns
    -------
    list of str
        Markdown lines, starting with an empty line and the section heading.
    """
    lines = ["", "## Sampled-data and delay limits (per deviation, python-control model)", ""]
    if step:
        lines.append(f"* RK4 step h = {step:g} s: K h = {K * step:.4g} (RK4 stable for K h < {RK4_LIMIT:.4f})")
        lines.append(f"* as a digital controller with period h and zero-order hold: stable for K h < "
                     f"{sampled_limit(0):g}; with an n-sample delay for K h < 2 sin(pi/(2(2n+1))) "
                     f"(n = 1: {sampled_limit(1):.4g}, n = 2: {sampled_limit(2):.4g}); "
                     f"at this h up to {max_stable_delay(K, step)} samples of delay")
    lines.append(f"* continuous loop: delay margin pi/(2K) = {delay_margin(K):.4g} s")
    return lines


def write_report(run: Any, scenario: Any, out_dir: str | Path, ctrl: CoordinatingController | None = None,
                 samples: int | None = None) -> Path:
    """Write ``report.md`` and its PNG figures for ``run`` (any object with ``t``, ``q``, ``u``).

    Parameters
    ----------
    run : object
        Has arrays ``t`` (N,), ``q`` (N, m), ``u`` (N, m).
    scenario : Scenario
        The scenario of the run (thresholds, curve, name).
    out_dir : path
        Directory for the report (created).
    ctrl : CoordinatingController, optional
        The controller (default: built from ``scenario`` with the run's link count).
    samples : int, optional
        Margin samples before refinement (default :func:`default_samples`).

    Returns
    -------
    Path
        The Markdown file.
    """
    from .report_figures import plot_links, plot_margins, plot_step_responses

    q = np.asarray(run.q, dtype=float)
    if ctrl is None:
        chain = scenario.chain()
        links = q.shape[1] - int(chain.rail)
        sc = scenario if chain.m == links else scenario.with_overrides(links=links)
        ctrl = sc.controller()
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    a = analyse_run(ctrl, run.t, q, run.u, scenario.thresholds, samples)
    t = np.asarray(run.t, dtype=float)
    step = float(np.median(np.diff(t))) if len(t) > 1 else None
    ok = np.all(np.isfinite(q), axis=1)
    lin_t = t[ok]
    if a.blowup_time is not None:              # linearise where the law is still well conditioned
        keep = lin_t < a.blowup_time - 0.1 * (a.blowup_time - lin_t[0])
        lin_t, lin_q = lin_t[keep], q[ok][keep]
    else:
        lin_q = q[ok]
    checks = {"orthonormal": check_orthonormal(ctrl.curve, times=np.linspace(t[0], t[-1], 3),
                                               warn=False).message(),
              "linearisations": linearise_run(ctrl, lin_t, lin_q, 4) if len(lin_t) else [],
              "joint_rates": ((getattr(run, "outcome", None) or {}).get("joint_rates")
                              or getattr(run, "info", {}).get("joint_rates"))}
    title = f"{scenario.name}: {ctrl.chain.m} links"
    figs = [plot_margins(a, out / "margins.png", title),
            plot_links(a, out / "links.png", title),
            plot_step_responses(ctrl.gain, step or 0.001, out / "step_responses.png", title)]
    path = out / "report.md"
    path.write_text(markdown(a, scenario, ctrl, step, figs, checks) + log_condition(run), encoding="utf-8")
    (out / "report.json").write_text(json.dumps(summary_json(a, run, scenario, ctrl), indent=2) + "\n",
                                     encoding="utf-8")
    return path


def log_condition(run: Any) -> str:
    """A Markdown section saying that the log read was cut off or damaged, with its problems ("" if intact).

    Parameters
    ----------
    run : object
        The run reported on; a :class:`~coordarm.analysis.replay.Replay` says its condition.

    Returns
    -------
    str
        The section, or "".
    """
    condition = run.condition() if hasattr(run, "condition") else None
    problems = list(getattr(run, "problems", []) or [])
    if condition is None and not problems:
        return ""
    lines = ["", "## Condition of the log", ""]
    lines += [f"* **{condition}**"] if condition else []
    lines += [f"* {p}" for p in problems]
    return "\n".join(lines) + "\n"


def summary_json(a: RunAnalysis, run: Any, scenario: Any, ctrl: CoordinatingController) -> dict:
    """Machine-readable results: smallest margins (time, link), blow-up, outcome, collisions, clearance.

    Parameters
    ----------
    a : RunAnalysis
        The analysis of the run.
    run : object
        The run or replayed log (``t``, ``q``; ``outcome`` or ``info["stopped"]``).
    scenario : Scenario
        Its scenario (obstacles).
    ctrl : CoordinatingController
        Its controller (chain with joint limits and clearance).

    Returns
    -------
    dict
        JSON-ready; ``clearance`` maps each obstacle's name to its smallest distance [m], time and link.
    """
    from coordarm.simulation.physical import Physical, distinct

    worst = a.margins["worst_link"]
    margins = {}
    for name in MARGINS:
        value, when = a.minima[name]
        k = int(np.argmin(np.abs(a.t - when)))
        margins[name] = {"value": _num(value), "time": when, "threshold": a.thresholds[name],
                         "first_below": a.crossings[name],
                         "link": int(worst[k]) if name == "links" else None}
    outcome = getattr(run, "outcome", None) or {"status": getattr(run, "info", {}).get("stopped", "unknown")}
    q, t = np.asarray(run.q, float), np.asarray(run.t, float)
    rows = even_indices(len(t), 2000)
    rows = rows[np.all(np.isfinite(q[rows]), axis=1)]
    physical = Physical(ctrl.chain, list(scenario.obstacles))
    found = distinct(physical.check(t[rows], q[rows]))
    clearance = {name: {"distance": d, "time": when, "link": link}
                 for name, (d, when, link) in physical.clearances(q[rows], t[rows]).items()}
    blowup = None if a.blowup_time is None else {
        "time": a.blowup_time, "link": a.blowup_link, "nominal_u": a.nominal_u, "factor": BLOWUP_FACTOR,
        **({"rail": a.blowup_rail} if ctrl.chain.rail else {})}
    return {"scenario": scenario.name, "links": ctrl.chain.m, "t_start": float(t[0]), "t_end": float(t[-1]),
            "outcome": outcome, "margins": margins, "blowup": blowup, "nominal_u": a.nominal_u,
            "collisions": [c.to_dict() for c in found], "clearance": clearance}


def _num(x: float) -> float | None:
    return float(x) if np.isfinite(x) else None
