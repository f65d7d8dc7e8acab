"""Compiled law on a composite path vs on a line (issue: within 3x at m = 64, 10 segments).

Times the compiled closed-loop chunk (RK4 steps inside C, 4 law calls each, so the Python call
overhead is spread over 2000 steps) for a line and for paths of 2, 5 and 10 segments
(alternating lines and arcs), interleaved: every repetition times each case once, and the
ratios are medians of the per-repetition ratios.

Run: ``python benchmarks/path_law.py [--reps N] [--links M]``.
"""
from __future__ import annotations

import argparse
import os
import platform
import time

import numpy as np

from coordarm import CoordinatingController, Line, Path, PlanarChain


def path_of(n_segments: int) -> Path:
    """A path through the base of ``n_segments`` alternating 0.3 m lines and 0.8 rad arcs of 0.5 m."""
    segs = []
    for i in range(n_segments):
        segs.append({"line": 0.3} if i % 2 == 0 else {"arc": 0.8 * (-1) ** (i // 2), "radius": 0.5})
    return Path((-0.5, 0.0), 0.0, segs)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--reps", type=int, default=15)
    ap.add_argument("--links", type=int, default=64)
    ap.add_argument("--steps", type=int, default=2000)
    args = ap.parse_args()
    chain = PlanarChain(args.links, 0.1)
    cases = {"line": Line()} | {f"path, {k} segments": path_of(k) for k in (2, 5, 10)}
    compiled = {name: CoordinatingController(chain, c, 2.0, 0.1).compile() for name, c in cases.items()}
    q, T = chain.zigzag(1.3), np.arange(args.steps) * 1e-4
    times: dict[str, list[float]] = {name: [] for name in cases}
    for _ in range(args.reps):
        for name, fast in compiled.items():
            t0 = time.perf_counter()
            fast.chunk(q, T, 1e-4)
            times[name].append((time.perf_counter() - t0) / (4 * args.steps))
    base = np.array(times["line"])
    print(f"{platform.processor() or platform.machine()}, {os.cpu_count()} CPUs, load {os.getloadavg()[0]:.1f}; "
          f"m = {args.links}, {args.reps} interleaved repetitions of {args.steps} RK4 steps")
    print("| curve | law call [µs] (median) | per link [ns] | ratio to the line (median of pairs) |")
    print("|---|---|---|---|")
    for name, ts in times.items():
        ts = np.array(ts)
        print(f"| {name} | {np.median(ts) * 1e6:.2f} | {np.median(ts) * 1e9 / args.links:.1f} | "
              f"{np.median(ts / base):.2f} |")


if __name__ == "__main__":
    main()
