"""Compiled law on a composite path vs on a line (issue: within 3x at m = 64, 10 segments).

Times the compiled closed-loop chunk (RK4 steps inside C, 4 law calls each, so the Python call
overhead is spread over 2000 steps) for a line and for paths of 2, 5 and 10 segments
(alternating lines and arcs), each with the closest piece searched by the C glue near the
previous link's (the default) and, for comparison, selected over every piece inside the
generated link step (``path_search=False``, the form before). Interleaved: every repetition
times each case once; the ratios are medians (with min-max) of the per-repetition ratios.

The chain starts laid along its curve (``follow_curve``, zig-zag beta = 1.3): the law is only
valid in the path's tube, where a run stays (``--off-path`` times the zig-zag along x
instead, which leaves a path of 10 segments by up to 0.7 m, outside its 0.5 m tube).

G1 paths (``transition = 0``: lines and arcs) and G2 paths (the default clothoid transitions,
issue 28: 0.125 m at every junction of these 0.3 m lines and 0.5 m arcs, a clothoid link takes a
fixed 3 Newton steps of an 8-node quadrature) are timed side by side; ``--full`` adds the full
selection inside the link step.

Run: ``python benchmarks/path_law.py [--reps N] [--links M] [--off-path] [--full]``.
"""
from __future__ import annotations

import argparse
import os
import platform
import time

import numpy as np

from coordarm import CoordinatingController, Line, Path, PlanarChain
from coordarm.generated.compiled import CompiledController
from coordarm.symbolic import follow_curve


def path_of(n_segments: int, transition: float | None = 0.0) -> Path:
    """A path through the base of ``n_segments`` alternating 0.3 m lines and 0.8 rad arcs of 0.5 m
    (``transition``: 0 the G1 path, None the default clothoid transitions)."""
    segs = []
    for i in range(n_segments):
        segs.append({"line": 0.3} if i % 2 == 0 else {"arc": 0.8 * (-1) ** (i // 2), "radius": 0.5})
    return Path((-0.5, 0.0), 0.0, segs, transition=transition)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--reps", type=int, default=15)
    ap.add_argument("--links", type=int, default=64)
    ap.add_argument("--steps", type=int, default=2000)
    ap.add_argument("--off-path", action="store_true", help="start from the zig-zag along x, not on the path")
    ap.add_argument("--full", action="store_true", help="also time the full selection inside the link step")
    args = ap.parse_args()
    chain = PlanarChain(args.links, 0.1)
    cases, states = {}, {}
    curves = ({"line": Line()} | {f"path, {k} segments": path_of(k) for k in (2, 5, 10)}
              | {f"G2 path, {k} segments": path_of(k, None) for k in (2, 5, 10)})
    for name, curve in curves.items():
        ctrl = CoordinatingController(chain, curve, 2.0, 0.1)
        q = chain.zigzag(1.3) if args.off_path else follow_curve(ctrl, 1.3)
        variants = [("", True)] + ([(" (full selection)", False)] if name != "line" and args.full else [])
        for suffix, search in variants:
            cases[name + suffix] = CompiledController(ctrl, path_search=search)
            states[name + suffix] = q
    T = np.arange(args.steps) * 1e-4
    times: dict[str, list[float]] = {name: [] for name in cases}
    for _ in range(args.reps):
        for name, fast in cases.items():
            t0 = time.perf_counter()
            fast.chunk(states[name], T, 1e-4)
            times[name].append((time.perf_counter() - t0) / (4 * args.steps))
    base = np.array(times["line"])
    print(f"{platform.processor() or platform.machine()}, {os.cpu_count()} CPUs, load {os.getloadavg()[0]:.1f}; "
          f"m = {args.links}, {args.reps} interleaved repetitions of {args.steps} RK4 steps, "
          f"{'off the path' if args.off_path else 'on the path'}")
    print("| curve | law call [µs] (median) | per link [ns] | ratio to the line: median (min-max) |")
    print("|---|---|---|---|")
    for name, ts in times.items():
        ts = np.array(ts)
        r = ts / base
        print(f"| {name} | {np.median(ts) * 1e6:.2f} | {np.median(ts) * 1e9 / args.links:.1f} | "
              f"{np.median(r):.2f} ({np.min(r):.2f}-{np.max(r):.2f}) |")


if __name__ == "__main__":
    main()
