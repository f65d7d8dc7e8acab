"""Singularity and condition report of a spatial run (universal joints): margins, linearised error dynamics.

The spatial counterpart of :mod:`coordarm.analysis.report`: :func:`write_spatial_report` writes ``report.md``, the figures
``margins.png``, ``links.png`` (:mod:`.spatial_report_figures`) and ``step_responses.png`` (the planar
report's: one deviation loop ``e' = -K e`` is the same), and ``report.json``. The margins are the run's own
arrays (:mod:`.spatial_analysis`); the linearised error dynamics are the closed loop differentiated by
CasADi AD in the task coordinates ``(s, roll, e^2_1, e^2_2, ..., e^m_2)`` (:mod:`.linearise`), whose
design is ``diag(0, -K, ..., -K)``: ``s' = v*`` and every other task error decays like ``exp(-K t)``.
"""
from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np

from .linearise import Linearisation, linearise_run
from .report import sampled_data_lines
from .run_analysis import BLOWUP_FACTOR
from .spatial_analysis import SPATIAL_LABELS, SPATIAL_MARGINS, SpatialAnalysis, analyse_spatial_run

#: Points of the run where the closed loop is linearised.
LINEARISATION_POINTS = 4


def _when(x: float | None) -> str:
    return "never" if x is None else f"{x:.3f} s"


def margin_lines(a: SpatialAnalysis) -> list[str]:
    """The report's margin table: smallest value, where and when, first crossing, blow-up prediction.

    Parameters
    ----------
    a : SpatialAnalysis
        The analysis of the run.

    Returns
    -------
    list of str
        Markdown lines.
    """
    lines = ["## Margins (dimensionless, 0 = singular)", "",
             "| margin | threshold | smallest | at t | where | first below threshold | predicted the blow-up |",
             "|---|---|---|---|---|---|---|"]
    pred = a.predicted()
    for name, (field, _, _) in SPATIAL_MARGINS.items():
        value, when, j = a.minima[name]
        where = "-" if j is None else f"{'link' if name == 'link' else 'joint'} {j}"
        p = pred[name]
        ptxt = ("no blow-up" if p is None else
                (f"**yes**, {a.blowup_time - a.crossings[name]:.3f} s ahead" if p else "no"))
        lines.append(f"| {SPATIAL_LABELS[name]} (`{field}`) | {a.thresholds[name]:g} | {value:.9g} | "
                     f"{when:.3f} s | {where} | {_when(a.crossings[name])} | {ptxt} |")
    return lines


def effort_lines(a: SpatialAnalysis) -> list[str]:
    """The report's lines on ``|u|``, the blow-up and the condition number of the decoupling matrix.

    Parameters
    ----------
    a : SpatialAnalysis
        The analysis of the run.

    Returns
    -------
    list of str
        Markdown lines.
    """
    k = int(np.nanargmax(a.u_norm)) if np.isfinite(a.u_norm).any() else 0
    lines = ["## Blow-up and conditioning", "",
             f"* nominal |u|_inf (median over the run, at least (max v* + K max|e(0)|)/xi): {a.nominal_u:.4g} rad/s",
             f"* first |u|_inf > {BLOWUP_FACTOR:g} x nominal: {_when(a.blowup_time)}",
             f"* largest |u|_inf: {a.u_norm[k]:.4g} rad/s at t = {a.t[k]:.3f} s"]
    if len(a.cond):
        c = int(np.argmax(a.cond))
        lines.append(f"* cond(M) of the 2m x 2m decoupling matrix (unscaled rows s, roll, e) at {len(a.cond)} samples: "
                     f"{np.min(a.cond):.4g} .. {a.cond[c]:.4g} (largest at t = {a.cond_t[c]:.3f} s)")
    else:
        lines.append("* cond(M): not sampled for more than 32 links (an SVD of the 2m x 2m matrix each); "
                     "the O(m) law needs only the link and end margins above")
    return lines


def linearisation_lines(lins: list[Linearisation], K: float) -> list[str]:
    """The report's table of the linearised error dynamics at points of the run.

    Parameters
    ----------
    lins : list of Linearisation
        The closed loop linearised at points of the run (tasks ``(s, roll, e)``; on a rail ``(s, sigma, roll, e)``).
    K : float
        The design gain [1/s].

    Returns
    -------
    list of str
        Markdown lines.
    """
    n = len(lins[0].q) if lins else 0
    rail, free = n % 2 == 1, lins[0].free if lins else 1          # on a rail q = (d, a_1, b_1, ...): 2m + 1
    tasks = "s, sigma, roll" if rail else "s, roll"
    held = "s' = v* and a held span sigma' = 0 (two eigenvalues 0)" if free == 2 else "s' = v*"
    zeros = ", ".join(["0"] * free)
    deviations = n - 2 - int(rail)
    decaying = "the span, the roll error" if rail and free == 1 else "the roll error"
    lines = ["## Linearised error dynamics", "",
             "Closed loop linearised by CasADi AD at points of the run, mapped to task coordinates "
             f"({tasks}, e^2_1, e^2_2, ..., e^m_2) including the change of the task map along the trajectory; "
             f"the design is diag({zeros}, -K, ..., -K) with K = {K:g} 1/s: {held}, and {decaying} and the "
             f"{max(deviations, 0)} normal deviations decay like exp(-K t) ({max(n - free, 0)} eigenvalues -K).", "",
             f"| t [s] | max abs(A - design) | eigenvalue{'s' if free > 1 else ''} of {'s, sigma' if free > 1 else 's'} "
             f"| largest abs(eigenvalue + K), other {max(n - free, 0)} | frozen-Jacobian error |", "|---|---|---|---|---|"]
    for L in lins:
        ev = L.eigenvalues()
        order = np.argsort(np.abs(ev))
        zero_ev, rest = ev[order[:free]], ev[order[free:]]
        shown_zero = ", ".join(f"{z.real:.2e}{z.imag:+.1e}j" for z in zero_ev)
        lines.append(f"| {L.t:.3f} | {L.deviation_from_design(K):.2e} | {shown_zero} | "
                     f"{np.max(np.abs(rest + K)):.2e} | {L.deviation_from_design(K, frozen=True):.3g} |")
    if not lins:
        lines.append("| - | no finite state to linearise at | | | |")
    return lines


def findings_lines(a: SpatialAnalysis, lins: list[Linearisation], K: float) -> list[str]:
    """The report's summary: which margins crossed their thresholds (or the closest one), the blow-up, the
    linearisation's distance from the design.

    Parameters
    ----------
    a : SpatialAnalysis
        The analysis of the run.
    lins : list of Linearisation
        The closed loop linearised along the run.
    K : float
        The design gain [1/s].

    Returns
    -------
    list of str
        Markdown bullet lines.
    """
    crossed = [f"{SPATIAL_LABELS[n]} at {c:.3f} s" for n, c in a.crossings.items() if c is not None]
    if crossed:
        lines = ["* below threshold: " + "; ".join(crossed)]
    else:
        ratio = {n: a.minima[n][0] / a.thresholds[n] for n in SPATIAL_MARGINS}
        n = min(ratio, key=ratio.get)
        lines = [f"* every margin stayed above its threshold; the closest: {SPATIAL_LABELS[n]}, "
                 f"{a.minima[n][0]:.3g} = {ratio[n]:.3g} x its threshold, at t = {a.minima[n][1]:.3f} s"]
    lines.append(f"* blow-up (|u|_inf > {BLOWUP_FACTOR:g} x nominal): {_when(a.blowup_time)}")
    if lins:
        worst = max(L.deviation_from_design(K) for L in lins)
        zeros, free = ", ".join(["0"] * lins[0].free), "s and the held span" if lins[0].free == 2 else "s"
        lines.append(f"* linearised error dynamics at {len(lins)} points: the design diag({zeros}, -K, ..., -K) to "
                     f"{worst:.1e} 1/s (every task error but {free} decays like exp(-{K:g} t))")
    return lines


def spatial_markdown(a: SpatialAnalysis, scenario: Any, ctrl: Any, run: Any, step: float | None,
                     figures: list[Path], lins: list[Linearisation]) -> str:
    """The spatial report as Markdown text.

    Parameters
    ----------
    a : SpatialAnalysis
        The analysis of the run.
    scenario : Scenario
        Its scenario (``name``, ``source``).
    ctrl : SpatialController
        Its controller (links, link length, gain ``K`` [1/s]).
    run : Run or Replay
        The run (its outcome).
    step : float or None
        The run's step [s]; None leaves out the sampled-data lines.
    figures : list of Path
        Figure files, linked by file name.
    lins : list of Linearisation
        The closed loop linearised along the run.

    Returns
    -------
    str
        The Markdown text, ending in a newline.
    """
    m, K = ctrl.chain.m, ctrl.gain
    lines = [f"# Singularity report: {scenario.name}", "",
             f"* scenario: `{scenario.source}`, {m} links of {ctrl.chain.xi} m with universal joints "
             f"({2 * m} joint angles a_j, b_j" + (", d first: a rail along "
                                                   f"{np.round(ctrl.chain.rail_direction, 4).tolist()}" if ctrl.chain.rail
                                                   else "") + f"), K = {K:g} 1/s",
             f"* run: t = {a.t[0]:.3f} .. {a.t[-1]:.3f} s, {len(a.t)} samples; outcome: {outcome_of(run)['status']}"]
    if getattr(run, "rail_margin", None) is not None:
        k = int(np.argmin(run.rail_margin))
        lines.append(f"* rail: d from {run.q[0, 0]:.4f} to {run.q[-1, 0]:.4f} m (limits {list(ctrl.chain.rail_limits)}), "
                     f"span sigma {run.sigma[0]:.4f} -> {run.sigma[-1]:.4f} m; rail margin "
                     f"abs(grad psi(y^1) . rail) / abs(grad psi(y^1)) min {run.rail_margin[k]:.6g} at t = {run.t[k]:.3f} s")
    lines += ["", "## Findings", ""] + findings_lines(a, lins, K) + [""]
    lines += margin_lines(a) + [""] + effort_lines(a) + [""] + linearisation_lines(lins, K)
    lines += sampled_data_lines(K, step)
    lines += ["", "## Figures", ""] + [f"![{p.stem}]({p.name})" for p in figures]
    return "\n".join(lines) + "\n"


def outcome_of(run: Any) -> dict:
    """How the run ended: a replayed log's ``outcome``, else ``{"status": run.info["stopped"]}``.

    Parameters
    ----------
    run : Run or Replay
        The run.

    Returns
    -------
    dict
        At least ``"status"``.
    """
    return getattr(run, "outcome", None) or {"status": getattr(run, "info", {}).get("stopped", "unknown")}


def write_spatial_report(run: Any, scenario: Any, out_dir: str | Path, ctrl: Any = None) -> Path:
    """Write ``report.md``, ``report.json`` and the PNG figures of a spatial run.

    Parameters
    ----------
    run : Run or Replay
        A spatial run (``t``, ``q``, ``u``, ``e``, ``link_margins``, ``end_margin``, ``joint_margins``).
    scenario : Scenario
        Its scenario (thresholds, name).
    out_dir : path
        Directory for the report (created).
    ctrl : SpatialController, optional
        The controller (default: built from ``scenario`` with the run's link count).

    Returns
    -------
    Path
        The Markdown file.
    """
    from .report_figures import plot_step_responses
    from .spatial_report_figures import plot_spatial_links, plot_spatial_margins

    q = np.asarray(run.q, dtype=float)
    if ctrl is None:
        links = q.shape[1] // 2
        ctrl = (scenario if scenario.chain().m == links else scenario.with_overrides(links=links)).controller()
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    a = analyse_spatial_run(ctrl, run, scenario.thresholds)
    step = float(scenario.step)                 # the run's RK4 step (a log may keep every n-th row only)
    keep = np.ones(len(a.t), bool) if a.blowup_time is None else \
        a.t < a.blowup_time - 0.1 * (a.blowup_time - a.t[0])      # where the law is still well conditioned
    ok = np.all(np.isfinite(q), axis=1) & np.isfinite(np.asarray(run.t, float))
    lins = linearise_run(ctrl, a.t[keep], q[ok][keep], LINEARISATION_POINTS) if keep.any() else []
    title = f"{scenario.name}: {ctrl.chain.m} links (universal joints)"
    figs = [plot_spatial_margins(a, out / "margins.png", title),
            plot_spatial_links(a, out / "links.png", title),
            plot_step_responses(ctrl.gain, step or 0.001, out / "step_responses.png", title)]
    path = out / "report.md"
    path.write_text(spatial_markdown(a, scenario, ctrl, run, step, figs, lins), encoding="utf-8")
    (out / "report.json").write_text(json.dumps(spatial_json(a, run, scenario, ctrl, lins), indent=2) + "\n",
                                     encoding="utf-8")
    return path


def spatial_json(a: SpatialAnalysis, run: Any, scenario: Any, ctrl: Any, lins: list[Linearisation]) -> dict:
    """Machine-readable results: smallest margins (value, time, link or joint), blow-up, outcome, linearisation.

    Parameters
    ----------
    a : SpatialAnalysis
        The analysis of the run.
    run : Run or Replay
        The run (its outcome).
    scenario : Scenario
        Its scenario (name).
    ctrl : SpatialController
        Its controller (links, gain).
    lins : list of Linearisation
        The closed loop linearised along the run.

    Returns
    -------
    dict
        JSON-ready; ``linearisation`` lists per point ``t`` [s], ``deviation`` (max abs(A - design)) [1/s]
        and the ``eigenvalues`` (real parts) [1/s].
    """
    margins = {}
    for name, (field, _, _) in SPATIAL_MARGINS.items():
        value, when, j = a.minima[name]
        margins[name] = {"array": field, "value": value if np.isfinite(value) else None, "time": when,
                         "index": j, "threshold": a.thresholds[name], "first_below": a.crossings[name]}
    blowup = None if a.blowup_time is None else {"time": a.blowup_time, "joint": a.blowup_joint,
                                                 "nominal_u": a.nominal_u, "factor": BLOWUP_FACTOR,
                                                 **({"rail": a.blowup_rail} if ctrl.chain.rail else {})}
    return {"scenario": scenario.name, "chain_kind": "universal", "links": ctrl.chain.m,
            "t_start": float(a.t[0]), "t_end": float(a.t[-1]), "outcome": outcome_of(run), "margins": margins,
            "blowup": blowup, "nominal_u": a.nominal_u,
            "cond_max": float(np.max(a.cond)) if len(a.cond) else None,
            "linearisation": [{"t": L.t, "deviation": L.deviation_from_design(ctrl.gain),
                               "eigenvalues": [float(x) for x in L.eigenvalues().real]} for L in lins]}
