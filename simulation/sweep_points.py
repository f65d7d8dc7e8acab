"""The points of a parameter sweep and the run of one point (one row of the results table).

A point is a mapping ``{name: value}`` over the varied names exactly as the user gave them
(``"control.gain"``, ``"links"``, ...). A name is a dotted path into the scenario's TOML
tables (``chain.links``, ``control.gain``, ``curve.radius``, ``start.beta``, ``run.duration``)
or one of the short :data:`ALIASES`. Nothing here imports Dask: :mod:`coordarm.simulation.sweep` ships these
functions to the workers, which run them on plain data (a scenario as a dict and the point),
so the compiled controller is never pickled: each worker builds or loads it from its own
content-addressed cache (:func:`coordarm.generated.build.build_root`).
"""
from __future__ import annotations

import copy
import itertools
import math
import os
import socket
import time
from pathlib import Path
from typing import Any, Callable

import numpy as np

from coordarm.symbolic import CollisionError, ConfigError, CoordarmError, SingularityError
from coordarm.symbolic.checks import is_integer, is_real
from coordarm.symbolic.errors import shown

from .choices import SWEEP_ALIASES, Backend, Outcome
from .result import deviation_norms
from .run import check_stride, even_indices, simulate
from .scenario import Scenario

#: Short names accepted by ``--vary`` (the results column keeps the name as given).
ALIASES = SWEEP_ALIASES
#: How a point can end, from best to worst.
OUTCOMES = tuple(o.value for o in (Outcome.COMPLETED, Outcome.SINGULARITY, Outcome.COLLISION, Outcome.ERROR))
#: Result columns after the varied names, in order.
RESULT_COLUMNS = ("outcome", "message", "stop_time", "min_link_margin", "min_longitudinal", "final_max_e",
                  "peak_u", "min_clearance", "wall_time", "worker")

#: The most points of one sweep (each is validated and becomes a row of the results table).
MOST_POINTS = 100_000

#: Controllers built in this process, by their (chain, curve, control) spec: a sweep over the start,
#: the duration or the thresholds builds each controller (and loads its library) once per worker.
_CONTROLLERS: dict[str, Any] = {}
_MAX_CONTROLLERS = 8


def field_path(name: str) -> tuple[str, ...]:
    """The TOML path of a varied ``name`` (an alias or a dotted name), as a tuple of keys.

    Parameters
    ----------
    name : str
        A dotted name such as ``control.gain``, or an alias of :data:`ALIASES`.

    Returns
    -------
    tuple of str
        The keys.

    Raises
    ------
    ConfigError
        An empty name or an empty path component.
    """
    path = tuple(ALIASES.get(name, name).split("."))
    if not name or any(not p for p in path):
        raise ConfigError(f"--vary: bad parameter name {name!r} (expected a dotted TOML name like control.gain)")
    return path


def _number(text: str, name: str) -> Any:
    """``text`` as an int, a float, a TOML boolean (``true``/``false``) or else the string itself."""
    text = text.strip()
    if text in ("true", "false"):
        return text == "true"
    for kind in (int, float):
        try:
            return kind(text)
        except ValueError:
            pass
    if not text:
        raise ConfigError(f"--vary {name}: empty value")
    return text


def parse_vary(text: str) -> tuple[str, list]:
    """Parse ``NAME=v1,v2,...`` (a list) or ``NAME=a:b:n`` (``n`` values from ``a`` to ``b``).

    Parameters
    ----------
    text : str
        One ``--vary`` argument.

    Returns
    -------
    (str, list)
        The name as given and its values (int, float, bool for ``true``/``false``, or str).

    Raises
    ------
    ConfigError
        No ``=``, a malformed range, ``n < 1`` or ``n >`` :data:`MOST_POINTS`.
    """
    name, sep, rest = text.partition("=")
    name = name.strip()
    if not sep or not name or not rest.strip():
        raise ConfigError(f"--vary {text!r}: expected NAME=v1,v2,... or NAME=start:stop:count")
    field_path(name)
    if ":" in rest:
        parts = rest.split(":")
        vals = [_number(p, name) for p in parts]
        if len(parts) != 3 or isinstance(vals[2], str) or isinstance(vals[2], float) or \
                any(isinstance(v, str) for v in vals[:2]):
            raise ConfigError(f"--vary {text!r}: a range is start:stop:count with an integer count")
        if vals[2] < 1:
            raise ConfigError(f"--vary {text!r}: count must be >= 1")
        if vals[2] > MOST_POINTS:
            raise ConfigError(f"--vary {shown(text)}: a range of {vals[2]:,} values; a sweep has at most "
                              f"{MOST_POINTS:,} points")
        return name, [float(v) for v in np.linspace(vals[0], vals[1], vals[2])]
    return name, [_number(p, name) for p in rest.split(",")]


def grid_points(vary: dict[str, list]) -> list[dict]:
    """Every combination of the varied values (cartesian product, last name fastest).

    Parameters
    ----------
    vary : dict of str to list
        Values of each varied name.

    Returns
    -------
    list of dict
        One ``{name: value}`` per combination.
    """
    names = list(vary)
    return [dict(zip(names, combo)) for combo in itertools.product(*(vary[n] for n in names))]


def latin_hypercube_points(vary: dict[str, list], samples: int, seed: int,
                           integers: set[str] | None = None) -> list[dict]:
    """``samples`` Latin-hypercube points over the range (smallest to largest value) of each name.

    Names whose values are not numbers are drawn from their list (uniform, seeded). The names
    in ``integers`` (default: those whose values are all ints) are rounded.

    Parameters
    ----------
    vary : dict
        Name -> values; a numeric name's range is its smallest to its largest value.
    samples : int
        Number of points.
    seed : int
        Seed of the generator (the same seed gives the same points).
    integers : set of str, optional
        Names to round to integers.

    Returns
    -------
    list of dict
        ``samples`` points, each name -> value.

    Raises
    ------
    ConfigError
        ``samples < 1``.
    """
    from scipy.stats import qmc

    if not is_integer(samples) or samples < 1:
        raise ConfigError(f"--samples: need a positive integer, got {samples!r}")
    names = list(vary)
    u = qmc.LatinHypercube(d=len(names), seed=np.random.default_rng(seed)).random(samples)
    cols = {}
    for i, n in enumerate(names):
        vals = vary[n]
        if all(is_real(v) for v in vals):
            lo, hi = min(vals), max(vals)
            x = lo + u[:, i] * (hi - lo)
            whole = n in integers if integers is not None else all(isinstance(v, int) for v in vals)
            cols[n] = [int(round(v)) for v in x] if whole else [float(v) for v in x]
        else:
            cols[n] = [vals[min(int(v * len(vals)), len(vals) - 1)] for v in u[:, i]]
    return [{n: cols[n][k] for n in names} for k in range(samples)]


def apply_point(spec: dict, point: dict) -> Scenario:
    """The scenario ``spec`` with every varied field of ``point`` set (validated again).

    A value replaces the field whole (a motion table becomes a constant); an integer field
    (``chain.links``) takes integral floats as ints.

    Parameters
    ----------
    spec : dict
        The scenario as data (not modified).
    point : dict
        ``{name: value}`` of the varied fields.

    Returns
    -------
    Scenario
        The scenario of the point.

    Raises
    ------
    ConfigError
        A name that is not a field of the scenario, or an invalid value (named).
    """
    spec = copy.deepcopy(spec)
    for name, value in point.items():
        path = field_path(name)
        table = spec
        for key in path[:-1]:
            if not isinstance(table.get(key), dict):
                raise ConfigError(f"--vary {name}: the scenario has no table {'.'.join(path[:-1])!r}")
            table = table[key]
        if isinstance(value, (float, np.floating)):
            value = float(value)
            if is_integer(table.get(path[-1])) and value.is_integer():
                value = int(value)
        elif isinstance(value, np.integer):
            value = int(value)
        table[path[-1]] = value
    return Scenario.from_dict(spec, "sweep point")


def check_names(spec: dict, names: list[str]) -> None:
    """Raise a ConfigError unless each name is an existing field of the scenario or of its section.

    Fields of the fixed sections (``[chain]``, ``[control]``, ``[start]``, ``[run]``,
    ``[thresholds]``) may be absent (their default is used); curve fields must be present.

    Parameters
    ----------
    spec : dict
        The scenario as data.
    names : list of str
        Varied names (dotted or aliases).

    Raises
    ------
    ConfigError
        The first name that is not a field (or is malformed).
    """
    from .scenario_tables import KEYS

    for name in names:
        path = field_path(name)
        table = spec
        for key in path[:-1]:
            table = table.get(key) if isinstance(table, dict) else None
        ok = isinstance(table, dict) and (path[-1] in table or (len(path) == 2 and path[-1] in KEYS.get(path[0], ())))
        if not ok:
            raise ConfigError(f"--vary {name}: {'.'.join(path)} is not a field of the scenario")


def integer_fields(spec: dict, names: list[str]) -> set[str]:
    """The names whose field in the scenario holds an integer (e.g. ``chain.links``).

    Parameters
    ----------
    spec : dict
        The scenario as data.
    names : list of str
        Varied names (dotted or aliases).

    Returns
    -------
    set of str
        Those of ``names`` whose field is an int (not a bool).
    """
    out = set()
    for name in names:
        value: Any = spec
        for key in field_path(name):
            value = value.get(key) if isinstance(value, dict) else None
        if is_integer(value):
            out.add(name)
    return out


def _controller(sc: Scenario):
    # a spatial controller whose roll is held holds the roll of its start: the start is part of its key
    held = sc.config.chain.universal and sc.config.control.roll_motion is None
    key = repr((sc.config.chain, sc.config.curve, sc.config.control,
                (sc.config.start, sc.config.run.t0) if held else None))
    ctrl = _CONTROLLERS.get(key)
    if ctrl is None:
        if len(_CONTROLLERS) >= _MAX_CONTROLLERS:
            _CONTROLLERS.pop(next(iter(_CONTROLLERS)))
        ctrl = _CONTROLLERS[key] = sc.controller()
    return ctrl


def worker_name() -> str:
    """The Dask worker's address when called on one, else ``host:pid``.

    Returns
    -------
    str
        The name of the process running a point.
    """
    try:
        from distributed import get_worker

        return get_worker().address
    except (ImportError, ValueError):
        return f"{socket.gethostname()}:{os.getpid()}"


def _walls(sc: Scenario, ctrl, t: np.ndarray, q: np.ndarray) -> float:
    """Smallest clearance between the chain and any obstacle over the run [m] (NaN without obstacles)."""
    if not len(sc.obstacles) or not len(q):
        return math.nan
    rows = np.union1d(even_indices(len(t), 2000), [len(t) - 1])     # the stop row included
    return min(d for d, _, _ in sc.physical(ctrl.chain).clearances(q[rows], t[rows]).values())


def run_columns(run: Any) -> dict[str, float]:
    """The margin and tracking columns of a row from its run (planar or spatial).

    A spatial run (universal joints) has no longitudinal margin: ``min_longitudinal`` holds its end
    margin (the 2x2 end solve of ``s`` and roll, checked against the same threshold), ``final_max_e``
    the largest distance ``|(e^j_1, e^j_2)|``, and three columns of its own follow the others:
    ``min_end_margin``, ``min_joint_margin`` (``|cos b_j|``) [-] and ``max_roll_error`` [rad].

    Parameters
    ----------
    run : Run
        The simulated run (up to its stop), at least one row.

    Returns
    -------
    dict
        ``min_link_margin``, ``min_longitudinal`` [-], ``final_max_e`` [m], ``peak_u`` [rad/s], and for a
        spatial run the three columns above.
    """
    cols = {"min_link_margin": float(np.min(run.link_margins)), "peak_u": float(np.max(np.abs(run.u)))}
    if run.layout.kind == "revolute":
        return {**cols, "min_longitudinal": float(np.min(run.longitudinal)),
                "final_max_e": float(np.max(np.abs(run.e[-1])))}
    end = float(np.min(run.end_margin))
    roll_error = np.angle(np.exp(1j * (run.roll - run.roll_star)))
    return {**cols, "min_longitudinal": end, "final_max_e": float(np.max(deviation_norms(run.e[-1:], 2))),
            "min_end_margin": end, "min_joint_margin": float(np.min(run.joint_margins)),
            "max_roll_error": float(np.max(np.abs(roll_error)))}


def run_point(spec: dict, point: dict, log_path: str | None = None) -> dict:
    """Simulate one sweep point and summarise it as a row (never raises on a failed point).

    Parameters
    ----------
    spec : dict
        The base scenario (:attr:`Scenario.spec`).
    point : dict
        Varied name -> value.
    log_path : str, optional
        Write the point's MCAP log there.

    Returns
    -------
    dict
        The point's values and :data:`RESULT_COLUMNS`: ``outcome`` (one of :data:`OUTCOMES`),
        ``message``, ``stop_time`` [s] (simulated time at which the run ended), the smallest
        link and longitudinal margins [-], ``final_max_e`` [m], ``peak_u`` [rad/s],
        ``min_clearance`` [m] (NaN without walls); :func:`run_batch` adds ``wall_time`` and ``worker``.
    """
    row = {**point, "outcome": "error", "message": "", "stop_time": math.nan, "min_link_margin": math.nan,
           "min_longitudinal": math.nan, "final_max_e": math.nan, "peak_u": math.nan,
           "min_clearance": math.nan}
    run = None
    try:
        sc = apply_point(spec, point)
        ctrl = _controller(sc)
        q0 = sc.start(ctrl)
        kw = dict(backend=Backend.AUTO.value, thresholds=sc.thresholds, progress=False, physical=sc.physical(ctrl.chain),
                  check_every=check_stride(sc.step))
        try:
            if log_path:
                from .mcap_writer import RunLogger

                Path(log_path).parent.mkdir(parents=True, exist_ok=True)
                with RunLogger(log_path, sc, ctrl, command=["coordarm", "sweep", repr(point)]) as log:
                    # every row kept (not thinned as with a log by default): the wall check below needs them
                    run = simulate(ctrl, q0, sc.duration, sc.step, sc.t0, on_chunk=log.on_chunk,
                                   keep=int(round(sc.duration / sc.step)) + 1, **kw)
            else:
                run = simulate(ctrl, q0, sc.duration, sc.step, sc.t0, **kw)
            row["outcome"] = Outcome.COMPLETED.value
        except SingularityError as err:
            run, row["outcome"], row["message"] = err.run, Outcome.SINGULARITY.value, str(err)
        except CollisionError as err:
            run, row["outcome"], row["message"] = err.run, Outcome.COLLISION.value, str(err)
        if run is not None:
            row.update(stop_time=float(run.t[-1]), **run_columns(run))
            row["min_clearance"] = _walls(sc, ctrl, run.t, run.q)
    except CoordarmError as exc:
        row["message"] = f"{type(exc).__name__}: {exc}"
    except Exception as exc:   # noqa: BLE001 - a failing point is a row, the sweep goes on
        row["message"] = f"{type(exc).__name__}: {exc}"
    return row


def run_batch(spec: dict, points: list[dict], point_fn: Callable[..., dict] | None = None,
              log_paths: list[str | None] | None = None) -> list[dict]:
    """Run ``points`` one after the other here (one Dask task): one row each, with ``wall_time`` and ``worker``.

    Parameters
    ----------
    spec : dict
        The base scenario (plain data: what a worker receives instead of a compiled controller).
    points : list of dict
        Varied name -> value, one dict per point.
    point_fn : callable, optional
        ``point_fn(spec, point, log_path) -> dict`` (default :func:`run_point`), importable on
        the workers; an exception it raises becomes a row with outcome ``error``.
    log_paths : list of str or None, optional
        One MCAP log path per point (None: no logs).

    Returns
    -------
    list of dict
        One row per point, in order, with ``wall_time`` [s] and ``worker`` added.
    """
    fn = point_fn or run_point
    rows = []
    for p, lp in zip(points, log_paths or [None] * len(points)):
        t0 = time.perf_counter()
        try:
            row = fn(spec, p, lp)
        except Exception as exc:   # noqa: BLE001 - a failing point is a row, the sweep goes on
            row = {**p, "outcome": "error", "message": f"{type(exc).__name__}: {exc}"}
        row["wall_time"] = time.perf_counter() - t0
        row["worker"] = worker_name()
        rows.append(row)
    return rows
