"""Which margin, at which threshold, fires before ``|u|`` exceeds 10x nominal: ``python -m coordarm.analysis.threshold_study``.

Simulates runs that are pushed into the longitudinal singularity with the stop thresholds
disabled, then prints, per run, the blow-up time and the first time each margin crossed
its threshold, plus the longitudinal margin at the blow-up and the lead time of several
candidate longitudinal thresholds. The evidence behind ``DEFAULT_THRESHOLDS``.
"""
from __future__ import annotations

import casadi as ca
import numpy as np

from coordarm.symbolic import Arc, CoordinatingController, Line, PlanarChain, project_onto_curve

from .report import analyse_run, simulate_through

CANDIDATES = (0.05, 0.1, 0.15, 0.2)


def blowup_cases() -> dict[str, tuple[CoordinatingController, np.ndarray, float]]:
    """``name -> (controller, q0, duration)`` of runs that reach the longitudinal singularity."""
    from coordarm.simulation.scenario import load_scenario

    cases = {}
    for preset, v, dur in (("arc", 0.15, 16.0), ("arc", 0.25, 10.0), ("line", 0.3, 17.0)):
        sc = load_scenario(preset)
        c = sc.controller()
        cases[f"{preset} preset, v* = {v}"] = (CoordinatingController(c.chain, c.curve, c.gain, v), sc.start(c), dur)
    for m, R, v, dur in ((64, 2.0, 0.2, 11.0), (32, 1.0, 0.4, 3.0)):
        c = CoordinatingController(PlanarChain(m, 0.1), Arc(radius=R), 2.0, v)
        cases[f"{m} links, arc R = {R}, v* = {v}"] = (c, project_onto_curve(c, c.chain.zigzag(1.3)), dur)
    chain = PlanarChain(16, 0.1)
    c = CoordinatingController(chain, Line(angle=lambda t: 0.3 * ca.sin(0.5 * t)), 2.0, 0.2)
    cases["16 links, swinging line, v* = 0.2"] = (c, chain.zigzag(1.3), 7.0)
    return cases


def study(samples: int = 600) -> list[dict]:
    """Run every case of :func:`blowup_cases` without stops and analyse it."""
    rows = []
    for name, (ctrl, q0, dur) in blowup_cases().items():
        run = simulate_through(ctrl, q0, dur, 0.001)
        a = analyse_run(ctrl, run.t, run.q, run.u, samples=samples)
        k = min(np.searchsorted(run.t, a.blowup_time), len(run.t) - 1) if a.blowup_time is not None else -1
        lead = {}
        for thr in CANDIDATES:
            hit = np.flatnonzero(~(run.longitudinal >= thr))
            lead[thr] = (a.blowup_time - run.t[hit[0]]) if (len(hit) and a.blowup_time is not None) else None
        rows.append({"name": name, "blowup": a.blowup_time, "crossings": a.crossings, "predicted": a.predicted(),
                     "longitudinal_at_blowup": float(run.longitudinal[k]), "lead": lead})
    return rows


def main() -> None:
    """Print the study as a Markdown table."""
    rows = study()
    print("| run | blow-up [s] | longitudinal at blow-up | " +
          " | ".join(f"lead of {t} [s]" for t in CANDIDATES) + " | sigma_min / 1/cond fire first? |")
    print("|---|---|---|" + "---|" * (len(CANDIDATES) + 1))
    for r in rows:
        fired = ["yes" if r["predicted"][n] else "no" for n in ("sigma_min", "inverse_cond", "inverse_cond_scaled")]
        leads = " | ".join("—" if v is None else f"{v:+.3f}" for v in r["lead"].values())
        print(f"| {r['name']} | {r['blowup']:.3f} | {r['longitudinal_at_blowup']:.4f} | {leads} | "
              f"{' / '.join(fired)} |")


if __name__ == "__main__":
    main()
