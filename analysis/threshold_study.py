"""Which margin, at which threshold, fires before ``|u|`` exceeds 10x nominal: ``python -m coordarm.analysis.threshold_study``.

Simulates runs that are pushed into the longitudinal singularity with the stop thresholds
disabled, then prints, per run, the blow-up time and the first time each margin crossed
its threshold, plus the longitudinal margin at the blow-up and the lead time of several
candidate longitudinal thresholds. The evidence behind ``DEFAULT_THRESHOLDS``. Each case is
one point of a :func:`coordarm.simulation.sweep.sweep` (``--workers N``: on a local Dask cluster).
"""
from __future__ import annotations

from typing import TYPE_CHECKING, Any

import casadi as ca
import numpy as np

from coordarm.simulation.choices import Outcome
from coordarm.symbolic import Arc, CoordinatingController, Line, PlanarChain, project_onto_curve

from .report import simulate_through
from .run_analysis import analyse_run

if TYPE_CHECKING:
    import pandas as pd

CANDIDATES = (0.05, 0.1, 0.15, 0.2)


def blowup_cases() -> dict[str, tuple[CoordinatingController, np.ndarray, float]]:
    """``name -> (controller, q0, duration)`` of runs that reach the longitudinal singularity.

    Returns
    -------
    dict of str to (CoordinatingController, ndarray, float)
        Per case: the controller, the start joint angles ``q0`` (m,) [rad] and the duration [s].
    """
    from coordarm.simulation.scenario import load_scenario

    cases = {}
    for preset, v, dur in (("arc", 0.15, 34.0), ("arc", 0.25, 30.0), ("line", 0.3, 17.0)):
        sc = load_scenario(preset)
        c = sc.controller()
        cases[f"{preset} preset, v* = {v}"] = (CoordinatingController(c.chain, c.curve, c.gain, v), sc.start(c), dur)
    for m, R, v, dur in ((64, 2.0, 0.2, 26.0), (32, 1.0, 0.4, 7.0)):
        c = CoordinatingController(PlanarChain(m, 0.1), Arc(radius=R), 2.0, v)
        cases[f"{m} links, arc R = {R}, v* = {v}"] = (c, project_onto_curve(c, c.chain.zigzag(1.3)), dur)
    chain = PlanarChain(16, 0.1)
    c = CoordinatingController(chain, Line(angle=lambda t: 0.3 * ca.sin(0.5 * t)), 2.0, 0.2)
    cases["16 links, swinging line, v* = 0.2"] = (c, chain.zigzag(1.3), 7.0)
    return cases


def threshold_point(spec: dict, point: dict, log_path: str | None = None) -> dict:
    """One sweep point: the case ``point["case"]`` of :func:`blowup_cases` run without stops and analysed.

    Parameters
    ----------
    spec : dict
        The sweep's scenario as data (unused: the case builds its own controller).
    point : dict
        The point: ``{"case": name}``.
    log_path : str or None
        Unused (the point writes no log).

    Returns
    -------
    dict
        ``outcome`` (``singularity`` when ``|u|`` blew up), ``blowup`` [s], ``longitudinal_at_blowup``,
        ``lead_<threshold>`` [s] for each of :data:`CANDIDATES` (NaN when never crossed), ``fires_<margin>``
        (whether that margin crossed its threshold before the blow-up) and the sweep's margin columns.
    """
    ctrl, q0, dur = blowup_cases()[point["case"]]
    run = simulate_through(ctrl, q0, dur, 0.001)
    a = analyse_run(ctrl, run.t, run.q, run.u, samples=600)
    blowup = a.blowup_time
    k = min(np.searchsorted(run.t, blowup), len(run.t) - 1) if blowup is not None else -1
    row = {**point, "outcome": (Outcome.SINGULARITY if blowup is not None else Outcome.COMPLETED).value, "message": "",
           "stop_time": float(run.t[-1]), "min_link_margin": float(np.min(run.link_margins)),
           "min_longitudinal": float(np.min(run.longitudinal)), "final_max_e": float(np.max(np.abs(run.e[-1]))),
           "peak_u": float(np.max(np.abs(run.u))), "blowup": np.nan if blowup is None else float(blowup),
           "longitudinal_at_blowup": float(run.longitudinal[k])}
    for thr in CANDIDATES:
        hit = np.flatnonzero(~(run.longitudinal >= thr))
        row[f"lead_{thr}"] = float(blowup - run.t[hit[0]]) if (len(hit) and blowup is not None) else np.nan
    row.update({f"fires_{name}": bool(v) for name, v in a.predicted().items()})
    return row


def study(client: Any = "serial", workers: int | None = None) -> pd.DataFrame:
    """Every case of :func:`blowup_cases` as one point of a sweep (see :func:`threshold_point`).

    Parameters
    ----------
    client : None, str or distributed.Client
        Where to run (see :func:`coordarm.simulation.sweep.sweep`); ``"serial"``: here, without Dask.
    workers : int or None
        Worker processes of a new local cluster (``client`` None).

    Returns
    -------
    pandas.DataFrame
        One row per case (column ``case``).
    """
    from coordarm.simulation.scenario import load_scenario
    from coordarm.simulation.sweep import sweep

    return sweep(load_scenario("line"), {"case": list(blowup_cases())}, client=client, workers=workers,
                 batch=1, point_fn=threshold_point)


def main(argv: list[str] | None = None) -> None:
    """Print the study as a Markdown table (``--workers N``: on a local Dask cluster).

    Parameters
    ----------
    argv : list of str or None
        Command-line arguments (None: ``sys.argv[1:]``).
    """
    import argparse

    p = argparse.ArgumentParser(prog="python -m coordarm.analysis.threshold_study", description=__doc__.splitlines()[0])
    p.add_argument("--workers", type=int, help="run the cases on a local Dask cluster of N workers (default: here)")
    args = p.parse_args(argv)
    df = study(client=None if args.workers else "serial", workers=args.workers)
    print("| run | blow-up [s] | longitudinal at blow-up | " +
          " | ".join(f"lead of {t} [s]" for t in CANDIDATES) + " | sigma_min / 1/cond fire first? |")
    print("|---|---|---|" + "---|" * (len(CANDIDATES) + 1))
    for r in df.to_dict("records"):
        fired = ["yes" if r[f"fires_{n}"] else "no" for n in ("sigma_min", "inverse_cond", "inverse_cond_scaled")]
        leads = " | ".join("—" if np.isnan(r[f"lead_{t}"]) else f"{r[f'lead_{t}']:+.3f}" for t in CANDIDATES)
        print(f"| {r['case']} | {r['blowup']:.3f} | {r['longitudinal_at_blowup']:.4f} | {leads} | "
              f"{' / '.join(fired)} |")


if __name__ == "__main__":
    main()
