"""Workspace map: margins over fold angle ``beta`` x curve curvature x link count, as heat maps.

The configurations are *zig-zags on the curve*: the first link at angle ``beta`` to the
tangent at the base, and every next centre the other intersection of the curve with the
circle of radius ``xi/2`` about the free joint, so that every centre lies exactly on the
curve (for a line this is the uniform zig-zag of docs/model.md). The curves are arcs
through the base, tangent to the x axis there, of curvature ``kappa`` (``kappa = 0``: the
line). Each (link count, curvature, fold angle) is one point of a :func:`coordarm.simulation.sweep.sweep`
(in this process, on a local Dask cluster with ``--workers N`` or a cluster with ``--scheduler``),
and the maps are drawn from its results table. ``python -m coordarm.analysis.workspace OUT.png``
draws the default map.
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any, Sequence

import numpy as np
from numpy.typing import ArrayLike

from coordarm.simulation.choices import Outcome
from coordarm.symbolic import Arc, ConfigError, CoordinatingController, Line, PlanarChain

from .singularity import run_margins

#: Quantities mapped, with their colour-bar labels.
MAPPED = {"longitudinal": "longitudinal margin [-]", "smallest_link": "smallest link margin [-]",
          "log10_cond": "log$_{10}$ cond(M) [-]"}


def curve_zigzag(m: int, xi: float, beta: float, curvature: float) -> np.ndarray | None:
    """Joint angles of the zig-zag on the arc of ``curvature`` [1/m] (None if it does not fit).

    Parameters
    ----------
    m : int
        Links.
    xi : float
        Link length [m].
    beta : float
        Angle of the first link to the curve's tangent at the base [rad].
    curvature : float
        ``1/R`` of the arc through the base with centre ``(0, R)``; 0 for the x axis.

    Returns
    -------
    ndarray, shape (m,) or None
        Joint coordinates [rad] (the angle of link 1, then each link's angle relative to the
        previous), or None if a link cannot reach the curve again.
    """
    y, a = np.zeros(2), float(beta)
    alphas = [a]
    centre = np.array([0.0, 1.0 / curvature]) if curvature else None
    for _ in range(1, m):
        P = y + 0.5 * xi * np.array([np.cos(a), np.sin(a)])
        w = np.array([0.0, 1.0]) if centre is None else P - centre   # reflect across the normal through P
        nw = np.linalg.norm(w)
        if not nw > 1e-12:
            return None
        w = w / nw
        y_new = P + (2 * np.outer(w, w) - np.eye(2)) @ (y - P)
        if np.linalg.norm(y_new - y) < 1e-9 * xi:                     # tangent: no second intersection
            return None
        a_new = np.arctan2(*(y_new - P)[::-1])
        a = a + (a_new - a + np.pi) % (2 * np.pi) - np.pi                 # keep alpha continuous
        alphas.append(a)
        y = y_new
    return np.diff(np.concatenate([[0.0], alphas]))


#: The scenario a workspace sweep starts from (its chain and curve are replaced point by point).
BASE = {"chain": {"links": 8, "link_length": 0.1}, "curve": {"kind": "line", "point": [0.0, 0.0], "angle": 0.0},
        "control": {"gain": 1.0, "speed": 0.1}}
#: Varied names of a workspace sweep (the results table's first columns).
NAMES = ("chain.links", "curvature", "start.beta")
#: Mapped quantity -> column of the results table.
COLUMNS = {"longitudinal": "min_longitudinal", "smallest_link": "min_link_margin", "log10_cond": "log10_cond"}
_CONTROLLERS: dict[tuple, CoordinatingController] = {}


def workspace_point(spec: dict, point: dict, log_path: str | None = None) -> dict:
    """One sweep point of the map: margins of the on-curve zig-zag ``(chain.links, curvature, start.beta)``.

    Parameters
    ----------
    spec : dict
        The sweep's scenario as data (its ``chain.link_length`` [m] is read).
    point : dict
        The point: ``{"chain.links": m, "curvature": 1/R [1/m], "start.beta": beta [rad]}``.
    log_path : str or None
        Unused (the point writes no log).

    Returns
    -------
    dict
        ``outcome`` completed (``error`` when no zig-zag fits), ``min_link_margin`` (smallest link
        margin), ``min_longitudinal`` and ``log10_cond`` of the decoupling matrix [-].

    Raises
    ------
    ConfigError
        The curvature is negative or not finite.
    """
    m, kappa, beta = int(point["chain.links"]), float(point["curvature"]), float(point["start.beta"])
    xi = float(spec["chain"]["link_length"])
    if kappa < 0 or not np.isfinite(kappa):
        raise ConfigError(f"curvature: need a finite value >= 0, got {kappa}")
    q = curve_zigzag(m, xi, beta, kappa)
    if q is None:
        return {**point, "outcome": "error", "message": "no zig-zag fits this curve"}
    key = (m, xi, kappa)
    if key not in _CONTROLLERS:
        _CONTROLLERS[key] = CoordinatingController(PlanarChain(m, xi), Line() if kappa == 0 else Arc(radius=1.0 / kappa),
                                                   1.0, 0.1)
    mg = run_margins(_CONTROLLERS[key], np.zeros(1), q[None])
    return {**point, "outcome": Outcome.COMPLETED.value, "message": "", "min_longitudinal": float(mg["longitudinal"][0]),
            "min_link_margin": float(np.min(mg["links"])), "log10_cond": float(np.log10(mg["cond"][0]))}


def workspace_map(links: Sequence[int] = (8, 16, 32, 64), betas: ArrayLike | None = None,
                  curvatures: ArrayLike | None = None, xi: float = 0.1, client: Any = "serial",
                  workers: int | None = None) -> dict:
    """Margins of on-curve zig-zags over ``betas`` x ``curvatures`` for each link count, as a sweep.

    Parameters
    ----------
    links : sequence of int
        Link counts.
    betas : array_like, optional
        Fold angles [rad] (default 30 in [0.02, 1.56]).
    curvatures : array_like, optional
        Curvatures [1/m] (default 13 in [0, 1.5]).
    xi : float
        Link length [m].
    client : None, str or distributed.Client
        Where the sweep runs (see :func:`coordarm.simulation.sweep.sweep`; default here: this process).
    workers : int, optional
        Worker processes of the local cluster when ``client`` is None.

    Returns
    -------
    dict
        ``link_counts``, ``betas`` [rad], ``curvatures`` [1/m], ``table`` (the sweep's results
        DataFrame) and for each key of :data:`MAPPED` an array of shape
        (len(links), len(curvatures), len(betas)) (NaN where no zig-zag fits).

    Raises
    ------
    ConfigError
        A negative or non-finite curvature.
    """
    from coordarm.simulation.sweep import sweep

    betas = np.linspace(0.02, 1.56, 30) if betas is None else np.asarray(betas, dtype=float)
    curvatures = np.linspace(0.0, 1.5, 13) if curvatures is None else np.asarray(curvatures, dtype=float)
    if np.any(curvatures < 0) or not np.all(np.isfinite(curvatures)):
        raise ConfigError("curvatures: need finite values >= 0")
    base = dict(BASE, chain={"links": 8, "link_length": xi})
    table = sweep(base, dict(zip(NAMES, (list(links), list(curvatures), list(betas)))), client=client,
                  workers=workers, point_fn=workspace_point)
    shape = (len(links), len(curvatures), len(betas))
    out = {k: table[col].to_numpy(float).reshape(shape) for k, col in COLUMNS.items()}
    return {"link_counts": list(links), "betas": betas, "curvatures": curvatures, "table": table, **out}


def plot_workspace(result: dict, path: str | Path, thresholds: dict | None = None) -> Path:
    """Heat maps: one row per link count, one column per mapped quantity; threshold contours dashed.

    Parameters
    ----------
    result : dict
        What :func:`workspace_map` returns.
    path : str or Path
        The PNG to write.
    thresholds : dict of str to float or None
        Contour levels by mapped key (``longitudinal``, ``smallest_link``) [-], overriding the
        default stop thresholds.

    Returns
    -------
    Path
        The file written.
    """
    import matplotlib.pyplot as plt

    from coordarm.simulation.figures import save_figure
    from coordarm.simulation.run import DEFAULT_THRESHOLDS

    thr = {"longitudinal": DEFAULT_THRESHOLDS["longitudinal"], "smallest_link": DEFAULT_THRESHOLDS["link"],
           **(thresholds or {})}
    L = result["link_counts"]
    fig, axes = plt.subplots(len(L), len(MAPPED), figsize=(4.6 * len(MAPPED), 3.2 * len(L) + 0.6),
                             squeeze=False, layout="constrained")
    b, k = result["betas"], result["curvatures"]
    for col, (key, label) in enumerate(MAPPED.items()):
        data = result[key]
        lo, hi = (0.0, 1.0) if key != "log10_cond" else (np.nanmin(data), np.nanmax(data))
        for row, m in enumerate(L):
            ax = axes[row, col]
            im = ax.pcolormesh(b, k, data[row], shading="nearest", cmap="viridis", vmin=lo, vmax=hi)
            if key in thr and np.isfinite(data[row]).sum() > 3:
                ax.contour(b, k, data[row], levels=[thr[key]], colors="red", linestyles="--", linewidths=1.2)
            ax.set_title(f"{m} links: {label.split(' [')[0]}", fontsize=9)
            ax.set_xlabel("fold angle beta [rad]")
            ax.set_ylabel("curvature [1/m]")
            fig.colorbar(im, ax=ax, label=label)
    fig.suptitle("Workspace map of on-curve zig-zags (red dashed: stop threshold; white: no zig-zag fits)")
    return save_figure(fig, path, dpi=100)


def main(argv: list[str] | None = None) -> int:
    """``python -m coordarm.analysis.workspace OUT.png [--links 8 16 ...]``: compute and draw the map.

    Parameters
    ----------
    argv : list of str or None
        Command-line arguments (None: ``sys.argv[1:]``).

    Returns
    -------
    int
        Exit status 0.
    """
    p = argparse.ArgumentParser(prog="python -m coordarm.analysis.workspace", description=__doc__.splitlines()[0])
    p.add_argument("out", type=Path, help="PNG file to write")
    p.add_argument("--links", type=int, nargs="+", default=[8, 16, 32, 64], help="link counts")
    p.add_argument("--betas", type=int, default=30, help="number of fold angles in [0.02, 1.56] rad")
    p.add_argument("--curvatures", type=int, default=13, help="number of curvatures in [0, 1.5] 1/m")
    p.add_argument("--workers", type=int, help="run the sweep on a local Dask cluster of N workers (default: here)")
    p.add_argument("--scheduler", help="run the sweep on the Dask cluster of this scheduler address")
    args = p.parse_args(argv)
    import matplotlib
    matplotlib.use("Agg")   # a command line writing files: no window (library calls keep the user's backend)
    client = args.scheduler or (None if args.workers else "serial")
    res = workspace_map(args.links, np.linspace(0.02, 1.56, args.betas), np.linspace(0.0, 1.5, args.curvatures),
                        client=client, workers=args.workers)
    print(f"workspace map  {plot_workspace(res, args.out)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
