"""Everything a sweep can refuse, checked before its first point runs.

The size of the grid (at most :data:`~.sweep_points.MOST_POINTS` points), every value of every
varied name (each is set alone in the scenario and validated: a value the scenario refuses is
refused here, naming ``--vary NAME=VALUE``), the cost of the whole sweep (RK4 steps summed
over the points; above :data:`SWEEP_STEPS` only with ``yes``), a ``results.parquet`` that
cannot be read and an output directory that cannot be written.
"""
from __future__ import annotations

import math
import os
from pathlib import Path

from coordarm.symbolic import ConfigError, LogError
from coordarm.symbolic.errors import shown

from .scenario_tables import DEFAULTS
from .sweep_points import MOST_POINTS, apply_point, field_path

#: RK4 steps of a whole sweep (summed over its points) above which ``--yes`` is needed.
SWEEP_STEPS = 2_000_000_000


def check_size(vary: dict[str, list], samples: int | None) -> int:
    """The number of points of the sweep, or a ConfigError above :data:`MOST_POINTS`.

    Parameters
    ----------
    vary : dict of str to list
        Values of each varied name.
    samples : int or None
        Latin-hypercube points (None: the full grid).

    Returns
    -------
    int
        Points of the sweep.

    Raises
    ------
    ConfigError
        More than :data:`MOST_POINTS` points (named ``--vary`` or ``--samples``).
    """
    if samples is not None:
        if isinstance(samples, int) and samples > MOST_POINTS:
            raise ConfigError(f"--samples: {samples:,} points; a sweep has at most {MOST_POINTS:,}")
        return int(samples) if isinstance(samples, int) else 0
    total = math.prod(len(v) for v in vary.values())
    if total > MOST_POINTS:
        grid = " x ".join(f"{len(v):,}" for v in vary.values())
        raise ConfigError(f"--vary: a grid of {grid} = {total:,} points; a sweep has at most {MOST_POINTS:,} "
                          "(use fewer values, or --samples N for a Latin hypercube)")
    return total


def check_values(spec: dict, vary: dict[str, list]) -> None:
    """Set each value of each varied name alone in the scenario and validate it.

    A value the scenario refuses on its own fails every point it is in; combinations
    (e.g. ``control.gain`` x ``run.step``) are checked when their point runs (a row with
    outcome ``error``).

    Parameters
    ----------
    spec : dict
        The scenario as data.
    vary : dict of str to list
        Values of each varied name.

    Raises
    ------
    ConfigError
        ``--vary NAME=VALUE: why`` for the first value the scenario refuses.
    """
    for name, values in vary.items():
        seen: set = set()
        for value in values:
            key = (type(value).__name__, repr(value))
            if key in seen:
                continue
            seen.add(key)
            try:
                apply_point(spec, {name: value})
            except ConfigError as exc:
                why = str(exc).removeprefix("sweep point: ")
                raise ConfigError(f"--vary {name}={shown(value)}: {why}") from None


def sweep_steps(spec: dict, points: list[dict]) -> int:
    """RK4 steps of the whole sweep: ``ceil(duration / step)`` of each point, summed.

    Parameters
    ----------
    spec : dict
        The scenario as data (its ``run.duration`` and ``run.step``, or the defaults).
    points : list of dict
        The points (a varied ``run.duration`` or ``run.step`` replaces the scenario's).

    Returns
    -------
    int
        Steps.
    """
    run = {**DEFAULTS["run"], **(spec.get("run") or {})}
    names = {field_path(n): n for n in (points[0] if points else {})}
    d_name, h_name = names.get(("run", "duration")), names.get(("run", "step"))
    total = 0
    for p in points:
        duration = float(p[d_name]) if d_name else float(run["duration"])
        step = float(p[h_name]) if h_name else float(run["step"])
        total += math.ceil(duration / step)
    return total


def check_cost(spec: dict, points: list[dict], yes: bool) -> None:
    """Refuse a sweep of more than :data:`SWEEP_STEPS` RK4 steps unless ``yes``.

    Parameters
    ----------
    spec : dict
        The scenario as data.
    points : list of dict
        The points.
    yes : bool
        The user accepted the cost (``--yes``).

    Raises
    ------
    ConfigError
        The estimate and the limit, naming ``--yes``.
    """
    steps = sweep_steps(spec, points)
    if steps > SWEEP_STEPS and not yes:
        raise ConfigError(f"this sweep needs {steps:,} RK4 steps over {len(points):,} points (> {SWEEP_STEPS:,}); "
                          "pass --yes to run it anyway, or use fewer points, a shorter run.duration or a longer run.step")


def check_out(out: Path | None) -> None:
    """Make sure ``out`` is (or can become) a directory this process can write to; nothing is created.

    Parameters
    ----------
    out : Path or None
        The results directory (None: nothing written).

    Raises
    ------
    LogError
        ``--out`` is a file, cannot be created or is not writable (named).
    """
    if out is None:
        return
    there = out
    while not there.exists() and there.parent != there:     # created only when the first rows are written
        there = there.parent
    if not there.is_dir():
        raise LogError(f"--out {out}: {there} is a file, not a directory")
    if not os.access(there, os.W_OK | os.X_OK):
        raise LogError(f"--out {out}: cannot write in {there} (permission denied)")


def check_sweep(spec: dict, vary: dict[str, list], points: list[dict], *, yes: bool, logs: bool,
                out: str | os.PathLike | None, simulated: bool = True) -> Path | None:
    """The checks of a sweep's points and output before any work (:func:`check_values`, :func:`check_cost`,
    :func:`check_out`).

    Parameters
    ----------
    spec : dict
        The scenario as data.
    vary : dict of str to list
        Values of each varied name.
    points : list of dict
        The points.
    yes : bool
        Accept a cost above :data:`SWEEP_STEPS`.
    logs : bool
        Each point's log is kept (needs ``out``).
    out : path-like or None
        The results directory.
    simulated : bool
        The points are simulated (False for a custom point function: the values and cost are its own).

    Returns
    -------
    Path or None
        ``out`` as a Path.

    Raises
    ------
    ConfigError
        A value the scenario refuses, a cost above the limit without ``yes``, ``logs`` without ``out``.
    LogError
        ``out`` cannot be written.
    """
    if simulated:
        check_values(spec, vary)
        check_cost(spec, points, yes)
    if logs and out is None:
        raise ConfigError("--logs needs --out (the logs go to OUT/logs/)")
    out = Path(out) if out is not None else None
    check_out(out)
    return out
