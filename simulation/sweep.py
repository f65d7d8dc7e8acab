"""Parameter sweeps on Dask distributed: one row per point, resumable, written as the rows arrive.

:func:`sweep` turns a scenario and the varied names into points (a grid, or a Latin
hypercube), packs them into batches (one Dask task each, so the scheduler's ~1 ms per task
stays far below 1 % of the work), runs them on a ``LocalCluster`` (one single-threaded
worker process per core), on an existing cluster by address or in this process, and
gathers the rows with ``as_completed``. The workers receive the scenario as plain data and
build (or load from their own content-addressed cache) the compiled controller themselves:
nothing compiled is ever pickled, so a cluster of fresh machines works.

Robustness: a point that raises is a row with outcome ``error`` and its message; a task
lost with a killed worker is rescheduled by Dask on another worker; rows are written to
``results.parquet`` and ``results.csv`` every few seconds, at the end and on Ctrl-C, and
running the same sweep again skips the points already there.
"""
from __future__ import annotations

import logging
import math
import os
import re
import time
import warnings
from pathlib import Path
from typing import TYPE_CHECKING, Any, Callable, TextIO

import numpy as np

from coordarm.symbolic import ConfigError
from coordarm.symbolic.errors import shown

from .progress import Progress
from .sweep_checks import check_size, check_sweep
from .scenario import Scenario, load_scenario
from .sweep_points import (RESULT_COLUMNS, check_names, grid_points, integer_fields, latin_hypercube_points,
                           run_batch)

if TYPE_CHECKING:
    import pandas as pd

RESULTS = "results.parquet"
RESULTS_CSV = "results.csv"
#: Key of the scenario JSON in the parquet file's metadata (a re-run must sweep the same scenario).
SCENARIO_KEY = b"coordarm.scenario"
#: Run in this process, without Dask (tests, debugging, tiny sweeps).
SERIAL = "serial"
#: Seconds to wait for a scheduler given by address.
CONNECT_TIMEOUT = 20.0
#: Seconds between rewrites of the results files while the sweep runs.
WRITE_INTERVAL = 5.0


class SweepProgress(Progress):
    """Progress bar of a sweep: points done / total and the estimated time left.

    Parameters
    ----------
    total : int
        Points of the sweep.
    already : int
        Points done before this call (from an earlier sweep into the same directory); the
        time left is estimated from the others.
    stream : file-like or None
        Where the bar is written (None: ``sys.stderr``).
    """

    def __init__(self, total: int, already: int = 0, stream: TextIO | None = None) -> None:
        super().__init__(total, "sweep", stream)
        self.already = already

    def status(self, done: float, elapsed: float) -> str:
        """Points done of all, wall time spent and the estimated time left.

        Parameters
        ----------
        done : float
            Points done, ``already`` included.
        elapsed : float
            Wall time since the start [s].

        Returns
        -------
        str
            The text after the bar.
        """
        new = done - self.already
        left = (self.total - done) * elapsed / new if new > 0 else math.nan
        eta = f"{left:.0f} s" if math.isfinite(left) else "?"
        return f"{int(done)}/{int(self.total)} points  {elapsed:.0f} s  ETA {eta}"


def as_scenario(scenario: Scenario | str | os.PathLike | dict) -> Scenario:
    """A :class:`Scenario` from a scenario, a preset name, a TOML path or a dict.

    Parameters
    ----------
    scenario : Scenario, str, os.PathLike or dict
        The scenario, a preset name or TOML path, or the scenario as data.

    Returns
    -------
    Scenario
        The scenario (validated).

    Raises
    ------
    ConfigError
        An invalid scenario, or no such preset or file.
    """
    if isinstance(scenario, Scenario):
        return scenario
    if isinstance(scenario, dict):
        return Scenario.from_dict(scenario)
    return load_scenario(scenario)


def sweep_points(spec: dict, vary: dict[str, list], samples: int | None = None, seed: int = 0,
                 check: bool = True) -> list[dict]:
    """The points of a sweep: the grid of ``vary``, or ``samples`` Latin-hypercube points.

    Parameters
    ----------
    spec : dict
        The scenario as data.
    vary : dict of str to list
        Values of each varied name.
    samples : int or None
        Number of Latin-hypercube points over each name's range of values (see
        :func:`latin_hypercube_points`; None: the full grid).
    seed : int
        Seed of the Latin hypercube.
    check : bool
        Every name must be a field of the scenario (off for a custom ``point_fn``, which may
        read names of its own).

    Returns
    -------
    list of dict
        One ``{name: value}`` per point.

    Raises
    ------
    ConfigError
        No varied name, an empty value list, more than
        :data:`~.sweep_points.MOST_POINTS` points, or a name that is not a field of the scenario.
    """
    if not vary:
        raise ConfigError("sweep: nothing to vary (give at least one --vary NAME=VALUES)")
    for name, vals in vary.items():
        if not isinstance(vals, (list, tuple, np.ndarray)) or len(vals) == 0:
            raise ConfigError(f"--vary {name}: need a non-empty list of values")
    check_size(vary, samples)
    vary = {n: [v.item() if isinstance(v, np.generic) else v for v in vals] for n, vals in vary.items()}
    if check:
        check_names(spec, list(vary))
    if samples is None:
        return grid_points(vary)
    return latin_hypercube_points(vary, samples, seed, integer_fields(spec, list(vary)) if check else None)


def point_key(point: dict, names: list[str]) -> tuple:
    """A hashable key of a point: its values in ``names`` order, numbers as floats.

    Parameters
    ----------
    point : dict
        ``{name: value}``.
    names : list of str
        The varied names.

    Returns
    -------
    tuple
        Floats for numbers, strings for the rest.
    """
    return tuple(float(point[n]) if isinstance(point[n], (int, float, np.number)) and not isinstance(point[n], bool)
                 else str(point[n]) for n in names)


def batch_size(points: int, workers: int) -> int:
    """Points per task: about four tasks per worker (load balance), at most 64 points a task.

    A 64-link, 10 s point takes ~0.2 s, so even one point a task keeps the scheduler's
    ~1 ms per task under 1 % of the work; batching matters for fast points.

    Parameters
    ----------
    points : int
        Points to run.
    workers : int
        Worker processes.

    Returns
    -------
    int
        Points per task, 1 to 64.
    """
    return max(1, min(64, math.ceil(points / max(1, 4 * workers))))


def log_name(point: dict) -> str:
    """File name of a point's MCAP log, made of its values (``chain.links=32_control.gain=2.mcap``).

    Parameters
    ----------
    point : dict
        ``{name: value}``.

    Returns
    -------
    str
        The name, characters other than letters, digits and ``_.=+-`` replaced by ``-``.
    """
    text = "_".join(f"{n}={v}" for n, v in point.items())
    return re.sub(r"[^A-Za-z0-9_.=+-]", "-", text) + ".mcap"


class ResultsTable:
    """The rows of a sweep and their files ``results.parquet`` / ``results.csv`` in ``out`` (if given).

    Rows are kept in the order of ``points`` (rows of earlier sweeps into the same ``out`` that
    are not among them come last), whatever order they finish in.

    Parameters
    ----------
    out : Path or None
        Output directory; rows already in its ``results.parquet`` are loaded (None: no files).
    names : list of str
        The varied names (the first columns).
    scenario_json : str
        The scenario as JSON (stored with the table; a table of another scenario is refused).
    points : list of dict
        The sweep's points, in order.

    Raises
    ------
    ConfigError
        ``out`` holds the results of a different sweep.
    """

    def __init__(self, out: Path | None, names: list[str], scenario_json: str, points: list[dict]) -> None:
        self.out, self.names, self.scenario_json = out, names, scenario_json
        self.order = {point_key(p, names): i for i, p in enumerate(points)}
        self.rows: list[dict] = []
        self.last_write, self.dirty = time.monotonic(), False
        if out is not None and (out / RESULTS).is_file():
            self._load()

    def _load(self) -> None:
        import pyarrow.parquet as pq

        try:
            table = pq.read_table(self.out / RESULTS)
        except Exception as exc:   # noqa: BLE001 - pyarrow raises ArrowInvalid, OSError, ... on a damaged file
            raise ConfigError(f"{self.out / RESULTS}: cannot be read ({type(exc).__name__}: "
                              f"{shown(str(exc))}); delete it or choose another --out") from None
        old = (table.schema.metadata or {}).get(SCENARIO_KEY, b"").decode()
        cols = list(table.column_names)
        if cols[:len(self.names)] != self.names or old != self.scenario_json:
            raise ConfigError(f"{self.out / RESULTS}: holds a different sweep (columns {cols[:-len(RESULT_COLUMNS)]}"
                              f"{'' if old == self.scenario_json else ', another scenario'}); "
                              "choose another --out or delete it")
        self.rows = table.to_pandas().to_dict("records")

    def done(self) -> set[tuple]:
        """Keys (:func:`point_key`) of the points that already have a row.

        Returns
        -------
        set of tuple
            The keys.
        """
        return {point_key(r, self.names) for r in self.rows}

    def add(self, rows: list[dict]) -> None:
        """Append finished rows; the files are rewritten when the last write is older than
        :data:`WRITE_INTERVAL`.

        Parameters
        ----------
        rows : list of dict
            One row per point (the varied names and :data:`RESULT_COLUMNS`).
        """
        self.rows.extend(rows)
        self.dirty = True
        if self.out is not None and time.monotonic() - self.last_write > WRITE_INTERVAL:
            self.write()

    def frame(self, rank: bool = True) -> pd.DataFrame:
        """All rows as a DataFrame: the varied names, :data:`RESULT_COLUMNS`, extra columns, in point order.

        Parameters
        ----------
        rank : bool
            Keep the column ``_rank`` (index of the point, ``len(points)`` for other rows).

        Returns
        -------
        pandas.DataFrame
            One row per finished point.
        """
        import pandas as pd

        cols = self.names + [c for c in RESULT_COLUMNS]
        extra = sorted({k for r in self.rows for k in r} - set(cols))
        df = pd.DataFrame(self.rows, columns=cols + extra)
        for c in ("outcome", "message", "worker"):
            df[c] = df[c].fillna("").astype(str)
        order = [self.order.get(point_key(r, self.names), len(self.order)) for r in self.rows]
        df = df.assign(_rank=order).sort_values("_rank", kind="stable").reset_index(drop=True)
        return df if rank else df.drop(columns="_rank")

    def write(self) -> None:
        """Rewrite both files atomically (temporary name, then rename), if rows came since the last write."""
        if self.out is None or not self.dirty:
            return
        from .figure_files import writing

        with writing(self.out / RESULTS):      # a full disk names the table
            self._write_files()

    def _write_files(self) -> None:
        import pyarrow as pa
        import pyarrow.parquet as pq

        self.out.mkdir(parents=True, exist_ok=True)
        df = self.frame(rank=False)
        table = pa.Table.from_pandas(df, preserve_index=False)
        table = table.replace_schema_metadata({**(table.schema.metadata or {}),
                                               SCENARIO_KEY: self.scenario_json.encode()})
        tmp = self.out / (RESULTS + ".tmp")
        pq.write_table(table, tmp)
        os.replace(tmp, self.out / RESULTS)
        tmp = self.out / (RESULTS_CSV + ".tmp")
        df.to_csv(tmp, index=False)
        os.replace(tmp, self.out / RESULTS_CSV)
        self.last_write, self.dirty = time.monotonic(), False


def _open_client(client: Any, workers: int | None):
    """``(client, owned)``: a Client for ``client`` (None: a new LocalCluster; str: an address)."""
    from distributed import Client, LocalCluster

    if client is None:
        n = workers or os.cpu_count() or 1
        with warnings.catch_warnings():   # the scheduler's HTTP server (health checks, no dashboard) on
            # another port when 8787 is taken: nothing for the user to act on
            warnings.filterwarnings("ignore", message=r"Port \d+ is already in use", category=UserWarning)
            cluster = LocalCluster(n_workers=n, threads_per_worker=1, processes=True, dashboard_address=None,
                                   silence_logs=logging.ERROR)
        local = Client(cluster)
        from .sweep_plugin import QuietLocalWorker

        local.register_plugin(QuietLocalWorker(), name="coordarm-quiet-local-worker")
        return local, True
    if isinstance(client, str):
        try:
            return Client(client, timeout=CONNECT_TIMEOUT), True
        except (OSError, TimeoutError, ValueError) as exc:
            raise ConfigError(f"--scheduler {client}: cannot connect ({type(exc).__name__}: {exc})") from None
    return client, False


def _close(client: Any) -> None:
    cluster = getattr(client, "cluster", None)
    client.close()
    if cluster is not None:
        cluster.close()


def _error_rows(points: list[dict], exc: BaseException) -> list[dict]:
    return [{**p, "outcome": "error", "message": f"{type(exc).__name__}: {exc}", "worker": ""} for p in points]


def sweep(scenario: Scenario | str | os.PathLike | dict, vary: dict[str, list], client: Any = None, *,
          samples: int | None = None, seed: int = 0, out: str | os.PathLike | None = None, logs: bool = False,
          workers: int | None = None, batch: int | None = None, progress: bool = False,
          point_fn: Callable[..., dict] | None = None, yes: bool = False) -> pd.DataFrame:
    """Run ``scenario`` at every point of ``vary`` on Dask and return one row per point.

    Parameters
    ----------
    scenario : Scenario, str, path or dict
        A scenario, a preset name, a TOML file or a scenario table.
    vary : dict
        Varied name (dotted TOML name such as ``"control.gain"``, or an alias such as
        ``"links"``) -> list of values. The result columns keep the names as given.
    client : None, str, distributed.Client or "serial"
        None: a new ``LocalCluster`` with ``workers`` single-threaded worker processes (default:
        one per core), closed at the end; ``"tcp://host:8786"``: the cluster of that scheduler;
        a Client: used as is (not closed); ``"serial"``: run here, without Dask.
    samples, seed : int, optional
        Latin-hypercube sampling of ``samples`` points over each name's range (smallest to
        largest value) instead of the grid (cartesian product).
    out : path, optional
        Directory of ``results.parquet`` and ``results.csv`` (and ``logs/`` with ``logs``).
        Points already in its ``results.parquet`` are skipped (resuming a sweep).
    logs : bool
        Keep each point's MCAP log in ``out/logs/`` (needs ``out``).
    workers : int, optional
        Worker processes of the new LocalCluster when ``client`` is None (default: one per core).
    batch : int, optional
        Points per task (default :func:`batch_size`).
    progress : bool
        Progress bar on stderr (points done / total and the time left).
    point_fn : callable, optional
        ``point_fn(spec, point, log_path) -> dict`` replacing the simulation of a point (module-level,
        importable on the workers); e.g. the static margin maps of :mod:`coordarm.analysis.workspace`.
    yes : bool
        Run a sweep of more than :data:`~.sweep_checks.SWEEP_STEPS` RK4 steps (``--yes``).

    Returns
    -------
    pandas.DataFrame
        One row per point of this sweep (in point order): the varied names, then ``outcome``
        (completed / singularity / collision / error), ``message``, ``stop_time`` [s],
        ``min_link_margin``, ``min_longitudinal`` [-], ``final_max_e`` [m], ``peak_u`` [rad/s],
        ``min_clearance`` [m] (NaN without walls), ``wall_time`` [s], ``worker``.

    Raises
    ------
    ConfigError
        Nothing to vary, a name that is not a field of the scenario, a value it refuses, more
        than :data:`~.sweep_points.MOST_POINTS` points, a cost above
        :data:`~.sweep_checks.SWEEP_STEPS` steps without ``yes``, ``logs`` without ``out``, an
        ``out`` holding another sweep or an unreadable ``results.parquet``, or a scheduler
        address that does not answer; all before any work.
    LogError
        ``out`` cannot be written (before any work).
    KeyboardInterrupt
        Ctrl-C; every finished row is written first.
    """
    sc = as_scenario(scenario)
    names = list(vary)
    points = sweep_points(sc.spec, vary, samples, seed, check=point_fn is None)
    out = check_sweep(sc.spec, vary, points, yes=yes, logs=logs, out=out, simulated=point_fn is None)
    table = ResultsTable(out, names, sc.to_json(), points)
    done = table.done()
    todo = [p for p in points if point_key(p, names) not in done]
    bar = SweepProgress(len(points), len(points) - len(todo)) if progress and points else None
    owned = None
    try:
        if todo:
            owned = _run(sc.spec, todo, client, workers, batch, point_fn, out if logs else None, table, bar)
    finally:
        if bar:
            bar.close()
        table.write()
        if owned is not None:
            _close(owned)
    df = table.frame()
    return df[df["_rank"] < len(points)].drop(columns="_rank").drop_duplicates(
        subset=names, keep="last").reset_index(drop=True)


def _run(spec, todo, client, workers, batch, point_fn, log_dir, table, bar):
    """Run ``todo`` and add the rows to ``table``; returns the client to close (None if not ours)."""
    def paths(pts):
        return [str(log_dir / "logs" / log_name(p)) for p in pts] if log_dir is not None else None

    n_done = bar.already if bar else 0
    if client == SERIAL:
        size = batch or 1
        for i in range(0, len(todo), size):
            pts = todo[i:i + size]
            table.add(run_batch(spec, pts, point_fn, paths(pts)))
            n_done += len(pts)
            if bar:
                bar.update(n_done)
        return None
    from distributed import as_completed

    from .sweep_plugin import drop_sync_cancel_race

    drop_sync_cancel_race()
    from .progress import Phase
    with Phase("sweep: starting the Dask workers" if client is None else f"sweep: connecting to {client}",
               enabled=bar is not None):
        dask_client, owned = _open_client(client, workers)
    try:
        n_workers = sum(dask_client.nthreads().values()) or (workers or 1)
        size = batch or batch_size(len(todo), n_workers)
        batches = [todo[i:i + size] for i in range(0, len(todo), size)]
        futures = {dask_client.submit(run_batch, spec, pts, point_fn, paths(pts), pure=False): pts
                   for pts in batches}
        try:
            for fut in as_completed(list(futures)):
                pts = futures[fut]
                try:
                    rows = fut.result()
                except Exception as exc:   # noqa: BLE001 - e.g. KilledWorker after repeated worker deaths
                    rows = _error_rows(pts, exc)
                table.add(rows)
                n_done += len(pts)
                if bar:
                    bar.update(n_done)
        finally:
            dask_client.cancel(list(futures))
    except BaseException:
        if owned:
            _close(dask_client)
        raise
    return dask_client if owned else None
