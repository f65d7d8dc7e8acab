"""Parallel efficiency of ``coordarm.sweep`` on a local Dask cluster, per-task overhead, projection.

1. A 32-point sweep (``control.gain`` 1..4 x ``control.speed`` 0.02..0.08) of 64-link, 10 s
   ``line`` runs on a LocalCluster of 1 worker and one of 2 workers (both started first and
   warmed up, so cluster start and compilation are not timed), ``--repeats`` times each,
   interleaved; efficiency = median T1 / (2 x median T2). Also printed: how busy the workers
   were (time inside points / elapsed) and how much CPU they got while inside a point
   (process CPU time / wall time), which separates the sweep's own losses from other load.
2. Per-task overhead: ``--tasks`` no-op tasks through ``client.submit`` on one worker, and the
   same number of no-op points through ``sweep`` with one point per task (our machinery too).
3. Projection for 1,000 machines from the measured per-point cost (``wall_time`` column).

Usage: ``python benchmarks/sweep.py [--repeats 3] [--tasks 500]``. Results: RESULTS.md, "Sweeps".
"""
from __future__ import annotations

import argparse
import logging
import os
import platform
import statistics
import time

import numpy as np

from coordarm.simulation.sweep import sweep

VARY = {"control.gain": [1.0, 1.5, 2.0, 2.5, 3.0, 3.5, 4.0, 4.5], "control.speed": [0.02, 0.04, 0.06, 0.08],
        "chain.links": [64], "run.duration": [10.0]}


def noop_point(spec, point, log_path=None):
    """A point that does nothing (measures the per-task cost of the sweep machinery)."""
    return {**point, "outcome": "completed"}


def timed_point(spec, point, log_path=None):
    """:func:`run_point` plus the CPU time the worker process got for it (``cpu`` [s])."""
    from coordarm.simulation.sweep_points import run_point

    c = time.process_time()
    row = run_point(spec, point, log_path)
    return {**row, "cpu": time.process_time() - c}


def noop(x):
    return x


def load() -> str:
    return " / ".join(f"{v:.1f}" for v in os.getloadavg())


def main() -> None:
    from distributed import Client, LocalCluster

    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--repeats", type=int, default=3)
    p.add_argument("--tasks", type=int, default=500)
    args = p.parse_args()
    print(f"machine: {platform.processor() or platform.machine()}, {os.cpu_count()} cores, "
          f"Python {platform.python_version()}; load (1/5/15 min) at start {load()}")
    clients = {}
    for n in (1, 2):
        t = time.perf_counter()
        clients[n] = Client(LocalCluster(n_workers=n, threads_per_worker=1, processes=True,
                                         dashboard_address=None, silence_logs=logging.ERROR))
        sweep("line", VARY, client=clients[n])                   # warm up: compile, import, build controllers
        print(f"LocalCluster({n}) start + warm-up sweep: {time.perf_counter() - t:.1f} s")
    times, busy, cpu = {1: [], 2: []}, {1: [], 2: []}, {1: [], 2: []}
    per_point = []
    for r in range(args.repeats):
        for n in (1, 2):
            t = time.perf_counter()
            df = sweep("line", VARY, client=clients[n], point_fn=timed_point)
            cpu[n].append(df["cpu"].sum() / df["wall_time"].sum())
            times[n].append(time.perf_counter() - t)
            busy[n].append(df["wall_time"].sum() / (n * times[n][-1]))
            per_point.extend(df["wall_time"])
            assert set(df["outcome"]) == {"completed"}, df["outcome"].value_counts()
            print(f"  repeat {r}: {n} worker(s) {times[n][-1]:.2f} s (load {load()})")
    t1, t2 = statistics.median(times[1]), statistics.median(times[2])
    eff = t1 / (2 * t2)
    print(f"32 points, 64 links, 10 s: 1 worker {t1:.2f} s, 2 workers {t2:.2f} s (medians of {args.repeats}); "
          f"speed-up {t1 / t2:.2f}, parallel efficiency {100 * eff:.0f} %")
    pairs = [a / (2 * b) for a, b in zip(times[1], times[2])]
    print(f"efficiency of each interleaved pair: {', '.join(f'{100 * e:.0f} %' for e in pairs)}")
    print(f"workers busy (sum of point wall times / (workers x elapsed)), median: 1 worker "
          f"{100 * statistics.median(busy[1]):.0f} %, 2 workers {100 * statistics.median(busy[2]):.0f} %")
    print(f"CPU the workers got while in a point (process CPU time / wall time), median: 1 worker "
          f"{100 * statistics.median(cpu[1]):.0f} %, 2 workers {100 * statistics.median(cpu[2]):.0f} %; "
          f"efficiency with the CPU each got: {100 * eff * statistics.median(cpu[1]) / statistics.median(cpu[2]):.0f} %")
    c = clients[1]
    c.gather(c.map(noop, range(50), pure=False))
    t = time.perf_counter()
    c.gather(c.map(noop, range(args.tasks), pure=False))
    raw = (time.perf_counter() - t) / args.tasks
    t = time.perf_counter()
    sweep("line", {"control.gain": list(np.linspace(1, 2, args.tasks))}, client=c, batch=1, point_fn=noop_point)
    ours = (time.perf_counter() - t) / args.tasks
    pt = statistics.median(per_point)
    print(f"per-task overhead on 1 worker: {1e3 * raw:.2f} ms (client.map of no-ops), "
          f"{1e3 * ours:.2f} ms (sweep, one no-op point per task)")
    print(f"median cost of a point (64 links, 10 s, wall_time): {pt:.3f} s; one point per task: overhead "
          f"{100 * ours / pt:.1f} %; default batching (4 tasks per worker, <= 64 points): below "
          f"{100 * ours / (pt * min(64, 8)):.2f} %")
    for cores in (2, 16):
        work = 1e6 * pt / (1000 * cores * min(eff, 1.0))
        print(f"projection: 10^6 points on 1,000 machines x {cores} cores at this efficiency: {work / 60:.1f} min "
              f"(+ scheduler: {1e6 / 64:.0f} tasks of 64 points x {1e3 * ours:.1f} ms = "
              f"{1e6 / 64 * ours:.0f} s of scheduler time, spread over the run)")
    for c in clients.values():
        cluster = c.cluster
        c.close()
        cluster.close()


if __name__ == "__main__":
    main()
