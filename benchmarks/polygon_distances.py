"""Link-to-polygon distances of the `pipe` preset: every edge measured vs bounding-box pruning.

`link_distances` (simulation/obstacles.py) measures, per link, the edge whose bounding box is
nearest and then only the edges whose boxes are nearer than that distance; the same numbers as
measuring every edge (tests/test_physical.py). Interleaved repetitions on the same samples (the
pipe's chain slid along its rail and shaken); ratios are medians of per-repetition pairs.

Run: ``python benchmarks/polygon_distances.py [--reps N] [--samples N]``.
"""
from __future__ import annotations

import argparse
import os
import platform
import time

import numpy as np

from coordarm.simulation.obstacles import edges, inside_polygon, link_distances
from coordarm.simulation.scenario import load_scenario
from coordarm.symbolic.geometry import segment_distance


def every_edge(joints, obstacle):
    """The previous form: the minimum of the distances to every edge."""
    a, b = joints[:, :-1], joints[:, 1:]
    d = np.full(a.shape[:-1], np.inf)
    for e0, e1 in edges(obstacle):
        d = np.minimum(d, segment_distance(a, b, e0, e1))
    return np.where(inside_polygon(a, obstacle.points), 0.0, d)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--reps", type=int, default=15)
    ap.add_argument("--samples", type=int, default=200)
    args = ap.parse_args()
    sc = load_scenario("pipe")
    ctrl = sc.controller()
    rng = np.random.default_rng(0)
    Q = sc.start(ctrl)[None] + rng.normal(scale=0.02, size=(args.samples, ctrl.chain.dof))
    Q[:, 0] += np.linspace(0.0, 2.5, args.samples)
    J = ctrl.chain.joints_np(Q)
    times = {"every edge": [], "pruned": []}
    for _ in range(args.reps):
        for name, f in (("every edge", every_edge), ("pruned", link_distances)):
            t0 = time.perf_counter()
            for ob in sc.obstacles:
                f(J, ob)
            times[name].append(time.perf_counter() - t0)
    r = np.array(times["every edge"]) / np.array(times["pruned"])
    print(f"{platform.processor() or platform.machine()}, {os.cpu_count()} CPUs, load {os.getloadavg()[0]:.1f}; "
          f"{args.samples} samples x {ctrl.chain.m} links x 2 polygons of 28 edges, {args.reps} interleaved repetitions")
    for name, ts in times.items():
        print(f"{name}: median {np.median(ts) * 1e3:.1f} ms ({np.median(ts) * 1e6 / args.samples:.0f} µs a sample)")
    print(f"speed-up: median {np.median(r):.2f} (min {np.min(r):.2f}, max {np.max(r):.2f})")


if __name__ == "__main__":
    main()
