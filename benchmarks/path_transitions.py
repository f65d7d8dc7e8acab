"""Joint accelerations on the path presets with and without clothoid transitions (issue 28).

For ``thread`` and ``pipe`` (planar paths on a rail) runs the preset as shipped (default
transitions) and as a G1 path (``transition = 0``) at two RK4 steps, and prints per run the peak
``|du/dt|`` (every step, :class:`~coordarm.simulation.joint_rates.JointRates`), its 99.9th
percentile over the steps, the largest ``|u|``, the rail's peak ``|d''|`` and the largest
deviation ``max |e|`` over the run (the junction deviations). Then draws
``docs/figures/path_transitions.png``: the curvature along ``thread``'s path, G1 and G2, and the
rate of the joint with the G1 peak around that junction crossing, both runs.

Run: ``python benchmarks/path_transitions.py [--steps 0.002,0.001] [--figure PATH]``.
"""
from __future__ import annotations

import argparse
import os
from pathlib import Path

import numpy as np

from coordarm import load_scenario, simulate
from coordarm.simulation.scenario import Scenario

ROOT = Path(__file__).resolve().parents[1]


def variant(name: str, transition: float | None) -> Scenario:
    """The preset, or with ``curve.transition`` set (0: the G1 path)."""
    sc = load_scenario(name)
    if transition is None:
        return sc
    spec = sc.spec
    spec["curve"]["transition"] = transition
    return Scenario.from_dict(spec)


def measured(sc: Scenario, step: float) -> tuple[dict, object]:
    """Peak |du/dt| and the rest of one run at ``step`` (compiled)."""
    ctrl = sc.controller()
    run = simulate(ctrl, sc.start(ctrl), sc.duration, step, sc.t0, backend="compiled", progress=False)
    r = int(ctrl.chain.rail)
    acc = np.abs(np.diff(run.u[:, r:], axis=0)) / np.diff(run.t)[:, None]
    peaks = run.info["joint_rates"]
    return {"peak": peaks["du_dt"], "joint": peaks["du_dt_joint"], "time": peaks["du_dt_time"],
            "p999": float(np.percentile(acc.max(axis=1), 99.9)), "max_u": float(np.max(np.abs(run.u[:, r:]))),
            "rail": peaks.get("rail_accel", float("nan")), "max_e": float(np.max(np.abs(run.e))),
            "status": run.info["stopped"]}, run


def figure(path: Path, runs: dict) -> None:
    """Curvature along thread's path (G1, G2) and the G1 peak joint's rate around its junction crossing."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (ax1, ax2) = plt.subplots(2, 1, figsize=(8, 6.4))
    for label, tr, style in (("G1 (transition = 0)", 0.0, "C3--"), ("G2 (default transitions)", None, "C0-")):
        curve = variant("thread", tr).curve() if callable(getattr(Scenario, "curve", None)) else None
        curve = curve if curve is not None else variant("thread", tr).controller().curve
        s = np.linspace(-0.2, curve.length + 0.2, 4000)
        ax1.plot(s, curve.curvature_at(s), style, label=label)
    ax1.set(xlabel="arc length s [m]", ylabel="curvature [1/m]",
            title="thread: curvature along the path (fillets of 2 m; transitions 0.5 m and 0.174 m)")
    ax1.legend(loc="lower left")
    ax1.grid(alpha=0.3)
    g1, g2 = runs["G1"], runs["G2"]
    info = g1[0]
    j, t_peak = info["joint"], info["time"]
    for (m, run), label, style in ((g1, "G1", "C3-"), (g2, "G2", "C0-")):
        keep = (run.t > t_peak - 1.5) & (run.t < t_peak + 1.5)
        ax2.plot(run.t[keep], run.u[keep, j], style, label=f"{label}: peak |du/dt| over the run {m['peak']:.3g} rad/s²")
    ax2.set(xlabel="t [s]", ylabel=f"u_{j} [rad/s]",
            title=f"thread: rate of joint {j} as link centres cross a junction (G1 peak at t = {t_peak:.2f} s), step 2 ms")
    ax2.legend(loc="best")
    ax2.grid(alpha=0.3)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--steps", default="0.002,0.001")
    ap.add_argument("--figure", default=str(ROOT / "docs" / "figures" / "path_transitions.png"))
    args = ap.parse_args()
    steps = [float(v) for v in args.steps.split(",")]
    print(f"load {os.getloadavg()[0]:.1f}")
    print("| preset | path | step [s] | peak \\|du/dt\\| [rad/s²] (joint, t) | 99.9th pct | max \\|u\\| [rad/s] | "
          "peak \\|d''\\| [m/s²] | max \\|e\\| [m] | outcome |")
    print("|---|---|---|---|---|---|---|---|---|")
    keep = {}
    for name in ("thread", "pipe"):
        for label, tr in (("G1", 0.0), ("G2", None)):
            for step in steps:
                m, run = measured(variant(name, tr), step)
                print(f"| {name} | {label} | {step:g} | {m['peak']:.4g} ({m['joint']}, {m['time']:.3f} s) | "
                      f"{m['p999']:.3g} | {m['max_u']:.3g} | {m['rail']:.3g} | {m['max_e']:.2e} | {m['status']} |")
                if name == "thread" and step == steps[0]:
                    keep[label] = (m, run)
    figure(Path(args.figure), keep)
    print(f"figure {args.figure}")


if __name__ == "__main__":
    main()
