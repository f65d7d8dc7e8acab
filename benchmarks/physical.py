"""Cost of the physical checks (joint limits + self-collision) per sample, 64 to 1024 links.

Compares the sort-and-sweep self-collision search (``symbolic.geometry.self_distances``, numpy; and
its compiled twin ``generated.chain_geometry.self_distances``, which ``check_configuration`` runs) with
the vectorised all-pairs O(m^2) check, interleaved, on blocks of samples of two shapes:
the compact zig-zag along a line (beta = 1.3) and the zig-zag wrapped along a circle of
radius m xi cos(beta) / (2 pi) (the body closes on itself: the worst case for a sweep along
one axis). Prints a Markdown table of medians (µs per sample) and their ratio.

Run: ``python benchmarks/physical.py [--quick]``; results in ``benchmarks/RESULTS.md``.
"""
from __future__ import annotations

import argparse
import math
import os
import platform
import time

import numpy as np

from coordarm.generated.chain_geometry import self_distances as compiled_self_distances
from coordarm.simulation.physical import check_configuration
from coordarm.symbolic import Arc, CoordinatingController, PlanarChain, project_onto_curve
from coordarm.symbolic.geometry import segment_distance, self_distances, touching


def all_pairs(joints: np.ndarray, clearance: float = 0.0) -> int:
    """Contacts by the plain vectorised O(m^2) check (every non-adjacent pair of every sample)."""
    a, b = joints[:, :-1], joints[:, 1:]
    i, j = np.triu_indices(a.shape[1], k=2)
    hits = 0
    for k in range(len(joints)):             # one sample at a time: m^2/2 pairs already fill memory
        hits += int(np.count_nonzero(touching(segment_distance(a[k, i], b[k, i], a[k, j], b[k, j]), clearance)))
    return hits


def shapes(m: int, samples: int) -> dict[str, np.ndarray]:
    chain = PlanarChain(m, 0.1)
    line = np.repeat(chain.zigzag(1.3)[None], samples, axis=0)
    R = m * 0.1 * math.cos(1.3) / (2 * math.pi) * 1.05
    ctrl = CoordinatingController(chain, Arc(radius=R), 2.0, 0.0)
    ring = np.repeat(project_onto_curve(ctrl, chain.zigzag(1.3))[None], samples, axis=0)
    return {"line": line, "circle": ring}


def median_time(f, repeats: int) -> float:
    times = []
    for _ in range(repeats):
        t = time.perf_counter()
        f()
        times.append(time.perf_counter() - t)
    return float(np.median(times))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--quick", action="store_true")
    args = ap.parse_args()
    links = (64, 256) if args.quick else (64, 256, 1024)
    print(f"machine: {platform.processor() or platform.machine()}, {os.cpu_count()} CPUs, "
          f"load {os.getloadavg()[0]:.1f}, numpy {np.__version__}")
    print("| links | shape | check_configuration [µs/sample] | sort and sweep, numpy [µs/sample] | "
          "the same in C [µs/sample] | all pairs O(m^2) [µs/sample] | all pairs / sweep (numpy) |")
    print("|---|---|---|---|---|---|---|")
    for m in links:
        n = max(4, 4096 // m)
        chain = PlanarChain(m, 0.1)
        for name, q in shapes(m, n).items():
            J = chain.joints_np(q)
            sweep, brute, full, compiled = [], [], [], []
            for _ in range(7):                 # interleaved: load changes hit both alike
                sweep.append(median_time(lambda: self_distances(J), 1) / n)
                compiled.append(median_time(lambda: compiled_self_distances(J), 1) / n)
                brute.append(median_time(lambda: all_pairs(J), 1) / n)
                full.append(median_time(lambda: check_configuration(chain, q), 1) / n)
            ratio = np.median(np.array(brute) / np.array(sweep))
            print(f"| {m} | {name} | {1e6 * np.median(full):.1f} | {1e6 * np.median(sweep):.1f} | "
                  f"{1e6 * np.median(compiled):.1f} | {1e6 * np.median(brute):.0f} | {ratio:.1f}x |")
    print("\n| links | simulated | physical checks | wall time (median) | / no checks (median of ratios) |")
    print("|---|---|---|---|---|")
    run_overhead(64, 20.0 if not args.quick else 5.0)
    run_overhead(1024, 2.0 if not args.quick else 0.5, repeats=3)


def run_overhead(m: int, duration: float, repeats: int = 5) -> None:
    """Wall time of a compiled run without and with the physical checks (every step, and at CHECK_RATE)."""
    from coordarm.simulation.run import CHECK_RATE, simulate
    from coordarm.simulation.scenario import load_scenario

    sc = load_scenario("line").with_overrides(links=m)
    ctrl = sc.controller()
    q0 = sc.start(ctrl)
    simulate(ctrl, q0, 0.01, 0.001)                   # build / load the library first
    stride = round(1 / (CHECK_RATE * 0.001))
    cases = {"no checks": {}, f"checks at {CHECK_RATE:g} Hz": {"physical": sc.physical(), "check_every": stride},
             "checks every step": {"physical": sc.physical(), "check_every": 1}}
    times = {k: [] for k in cases}
    for _ in range(repeats):                          # interleaved
        for name, kw in cases.items():
            times[name].append(median_time(lambda: simulate(ctrl, q0, duration, 0.001, progress=False, **kw), 1))
    base = np.array(times["no checks"])
    for name in cases:
        ratio = np.median(np.array(times[name]) / base)
        print(f"| {m} | {duration:g} s | {name} | {np.median(times[name]):.2f} s | {ratio:.2f}x |")


if __name__ == "__main__":
    main()
