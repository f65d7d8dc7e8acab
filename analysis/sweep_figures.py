"""Figures of a sweep's results table: a line plot for one varied name, heat maps for each pair.

Each heat map figure has two panels over a pair of varied names: the outcome (the worst
one over the other names: completed < singularity < collision < error) and the smallest
margin ``min(min_link_margin, min_longitudinal)`` (the smallest over the other names).
A Latin-hypercube sweep (values not on a grid) is drawn as coloured points instead.
"""
from __future__ import annotations

import itertools
import re
from pathlib import Path
from typing import TYPE_CHECKING

import matplotlib.pyplot as plt
import numpy as np
from matplotlib.colors import BoundaryNorm, ListedColormap

from coordarm.simulation.choices import SWEEP_ALIASES
from coordarm.simulation.figures import legend_beside, save_figure
from coordarm.simulation.sweep_points import OUTCOMES

if TYPE_CHECKING:
    import pandas as pd

#: Colour of each outcome (same order as OUTCOMES).
OUTCOME_COLOURS = ("#2ca02c", "#ff7f0e", "#9467bd", "#d62728")
#: Units of the scenario keys a sweep varies most (dotted names; aliases are mapped by :func:`axis_label`).
UNITS = {"chain.links": "-", "chain.link_length": "m", "chain.clearance": "m", "chain.joint_limit": "rad",
         "chain.radius": "m", "chain.rate_limit": "rad/s", "chain.accel_limit": "rad/s²", "control.gain": "1/s",
         "control.speed": "m/s", "control.span": "m", "start.beta": "rad", "start.heading": "rad",
         "start.fold": "rad", "start.roll": "rad", "run.duration": "s", "run.step": "s", "run.t0": "s",
         "curve.radius": "m", "curve.angle": "rad", "curve.amplitude": "m", "curve.omega": "rad/s",
         "thresholds.link": "-", "thresholds.longitudinal": "-"}


def axis_label(name: str) -> str:
    """``name`` with its unit, ``"gain [1/s]"``, when :data:`UNITS` knows it (by dotted name or alias).

    Parameters
    ----------
    name : str
        A varied name (dotted, or an alias of :data:`~coordarm.simulation.choices.SWEEP_ALIASES`).

    Returns
    -------
    str
        The label; ``name`` alone for a key of unknown unit.
    """
    unit = UNITS.get(SWEEP_ALIASES.get(name, name))
    return f"{name} [{unit}]" if unit else name


def smallest_margin(df: pd.DataFrame) -> np.ndarray:
    """``min(min_link_margin, min_longitudinal)`` per row (NaN where the point did not run).

    Parameters
    ----------
    df : pandas.DataFrame
        The sweep's results table (one row per point).

    Returns
    -------
    ndarray, shape (len(df),)
        Smallest margins [-].
    """
    return np.fmin(df["min_link_margin"].to_numpy(float), df["min_longitudinal"].to_numpy(float))


def _file(name: str) -> str:
    return re.sub(r"[^A-Za-z0-9_.=+-]", "-", name)


def _numeric(values) -> bool:
    return all(isinstance(v, (int, float, np.number)) and not isinstance(v, bool) for v in values)


def plot_line(df: pd.DataFrame, name: str, path: str | Path) -> Path:
    """Smallest link and longitudinal margins against one varied ``name``, markers coloured by outcome.

    Parameters
    ----------
    df : pandas.DataFrame
        The sweep's results table (one row per point).
    name : str
        The varied name (a column of ``df``).
    path : str or Path
        The PNG to write.

    Returns
    -------
    Path
        The file written.
    """
    fig, ax = plt.subplots(figsize=(8.5, 4.2))      # the legend right of the axes
    d = df.sort_values(name) if _numeric(df[name]) else df
    x = d[name].to_numpy() if _numeric(d[name]) else np.arange(len(d))
    ax.plot(x, d["min_link_margin"], "-", color="0.5", label="smallest link margin")
    ax.plot(x, d["min_longitudinal"], "--", color="0.3", label="smallest longitudinal margin")
    for outcome, colour in zip(OUTCOMES, OUTCOME_COLOURS):
        sel = (d["outcome"] == outcome).to_numpy()
        if sel.any():
            y = np.nan_to_num(smallest_margin(d)[sel], nan=0.0)
            ax.scatter(x[sel], y, color=colour, zorder=3, label=outcome)
    if not _numeric(d[name]):
        ax.set_xticks(x, [str(v) for v in d[name]], rotation=30, ha="right")
    ax.set_xlabel(axis_label(name))
    ax.set_ylabel("margin [-] (0 = singular)")
    ax.set_title(f"sweep over {name}: smallest margins (points: smallest of both, by outcome)", fontsize=10)
    legend_beside(ax)
    ax.grid(alpha=0.3)
    return save_figure(fig, path)


def plot_pair(df: pd.DataFrame, a: str, b: str, path: str | Path) -> Path:
    """Heat maps of the worst outcome and the smallest margin over the varied names ``a`` x ``b``.

    Parameters
    ----------
    df : pandas.DataFrame
        The sweep's results table (one row per point).
    a, b : str
        The varied names on the x and y axes (columns of ``df``).
    path : str or Path
        The PNG to write.

    Returns
    -------
    Path
        The file written.
    """
    code = df["outcome"].map({o: i for i, o in enumerate(OUTCOMES)}).fillna(len(OUTCOMES) - 1).to_numpy(float)
    data = df.assign(_code=code, _margin=smallest_margin(df))
    cmap = ListedColormap(OUTCOME_COLOURS)
    norm = BoundaryNorm(np.arange(len(OUTCOMES) + 1) - 0.5, len(OUTCOMES))
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.4), layout="constrained")
    grid = len(data[[a, b]].drop_duplicates()) == data[a].nunique() * data[b].nunique()
    panels = (("_code", "max", "outcome (worst over the other names)", cmap, norm),
              ("_margin", "min", "smallest margin [-]", "viridis", None))
    for ax, (col, how, label, cm, nm) in zip(axes, panels):
        if grid and _numeric(data[a]) and _numeric(data[b]):
            table = data.pivot_table(index=b, columns=a, values=col, aggfunc=how, dropna=False)
            im = ax.pcolormesh(table.columns.to_numpy(float), table.index.to_numpy(float), table.to_numpy(float),
                               shading="nearest", cmap=cm, norm=nm, **({} if nm else {"vmin": 0.0}))
        else:
            xa = data[a].to_numpy() if _numeric(data[a]) else data[a].astype("category").cat.codes
            xb = data[b].to_numpy() if _numeric(data[b]) else data[b].astype("category").cat.codes
            im = ax.scatter(xa, xb, c=data[col], cmap=cm, norm=nm, s=40, **({} if nm else {"vmin": 0.0}))
        bar = fig.colorbar(im, ax=ax, label=None if nm is not None else label)   # outcomes: named by the ticks
        if nm is not None:
            bar.set_ticks(range(len(OUTCOMES)), labels=list(OUTCOMES))
        ax.set_xlabel(axis_label(a))
        ax.set_ylabel(axis_label(b))
        ax.set_title(label.split(" [")[0], fontsize=10)
    fig.suptitle(f"sweep: {b} x {a} ({len(data)} points)")
    return save_figure(fig, path, dpi=100)


def plot_sweep(df: pd.DataFrame, names: list[str], out: str | Path) -> list[Path]:
    """All figures of a sweep into ``out``: ``sweep_<name>.png`` for one name, else ``sweep_<a>__<b>.png`` per pair.

    Names held at a single value are left out (they add no axis).

    Parameters
    ----------
    df : pandas.DataFrame
        The sweep's results table (one row per point).
    names : list of str
        The varied names (columns of ``df``).
    out : str or Path
        Output directory (created if missing).

    Returns
    -------
    list of Path
        The files written (none for an empty table).
    """
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    if len(df) == 0:
        return []
    names = [n for n in names if df[n].nunique() > 1] or names[:1]   # a name held at one value adds no axis
    if len(names) == 1:
        return [plot_line(df, names[0], out / f"sweep_{_file(names[0])}.png")]
    return [plot_pair(df, a, b, out / f"sweep_{_file(a)}__{_file(b)}.png")
            for a, b in itertools.combinations(names, 2)]
