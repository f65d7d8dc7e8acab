"""Compiled spatial law (universal joints) vs the compiled planar law, per link (issue 22: within 2x).

Times the compiled closed-loop chunk (RK4 steps inside C, 4 law calls each, so the Python call
overhead is spread over the steps) of the planar law (a line swinging as ``0.6 sin(0.2 t)``,
the RESULTS.md case) and of the spatial law (a 3-D line through the base turning about a tilted
axis, roll command ``0.2 sin(1.3 t)``), both with links of 0.1 m, K = 2, v* = 0.1 m/s, from a
zig-zag (beta = 1.0). Interleaved: every repetition times each case once; the ratio is the
median (with min-max) of the per-repetition ratios spatial / planar of the time per link.

Also times the spatial chunk with ``-DCOORDARM_SCALAR_TRIG`` (the trig passes not vectorised)
with ``--scalar-trig``, to see what the vector passes give.

``--curve circle`` / ``--curve path`` time the spatial law on a tilted circle or a banked 3-D path
instead (their geometry is evaluated at every link; only a line has the frame where it is free).

Run: ``python benchmarks/spatial_law.py [--reps N] [--links 64 256 1024] [--steps S] [--scalar-trig]
[--curve line|circle|path]``.
"""
from __future__ import annotations

import argparse
import os
import platform
import time

import numpy as np

from coordarm import CoordinatingController, Line, PlanarChain
from coordarm.generated.build import DEFAULT_FLAGS
from coordarm.generated.compiled import CompiledController
from coordarm.symbolic.curves3d import Circle3D, Line3D
from coordarm.symbolic.motions import Sinusoid
from coordarm.symbolic.paths3d import Path3D
from coordarm.symbolic.spatial_chain import SpatialChain
from coordarm.symbolic.spatial_controller import SpatialController

AXIS = np.array([1.0, 0.2, 0.1]) / np.linalg.norm([1.0, 0.2, 0.1])


def spatial_curve(kind: str):
    """The spatial case's curve: the turning line (default), or a tilted circle or a banked path through the base."""
    if kind == "circle":
        w = np.array([0.1, -0.4, 1.0]) / np.linalg.norm([0.1, -0.4, 1.0])
        inward = np.cross(w, AXIS) / np.linalg.norm(np.cross(w, AXIS))
        return Circle3D(1.5 * inward, 1.5, w, -inward)
    if kind == "path":
        return Path3D((0.0, 0.0, 0.0), AXIS, (0.0, 1.0, 0.0),
                      [("line", 0.6), ("arc", 0.9, 1.2, 0.7), ("line", 0.8), ("arc", 1.1, 1.0, -1.4), ("line", 300.0)])
    return Line3D((0.0, 0.0, 0.0), AXIS, (0.0, 1.0, 0.0), rotation=((0.0, 0.3, 1.0), Sinusoid(0.3, 0.7)))


def cases(m: int, scalar_trig: bool, kind: str = "line") -> dict[str, tuple[CompiledController, np.ndarray]]:
    """``name -> (compiled controller, start state)`` of the planar and the spatial law at ``m`` links."""
    planar = CoordinatingController(PlanarChain(m, 0.1), Line(angle=Sinusoid(0.6, 0.2)), 2.0, 0.1)
    chain = SpatialChain(m, 0.1)
    curve = spatial_curve(kind)
    spatial = SpatialController(chain, curve, 2.0, 0.1, roll=Sinusoid(0.2, 1.3))
    q3 = chain.zigzag(1.0, axis=AXIS, fold=(0.0, 1.0, 0.0))
    out = {"planar": (CompiledController(planar), planar.chain.zigzag(1.0)),
           "spatial": (CompiledController(spatial), q3)}
    if scalar_trig:
        scalar = CompiledController(spatial, flags=list(DEFAULT_FLAGS) + ["-DCOORDARM_SCALAR_TRIG"])
        out["spatial, scalar trig"] = (scalar, q3)
    return out


def per_link_ns(comp: CompiledController, q0: np.ndarray, steps: int, m: int) -> float:
    """Time of one law call per link [ns], from a chunk of ``steps`` RK4 steps (4 law calls each).

    CPU time of the calling thread (``time.thread_time``: the chunk runs in it), so that the time the
    thread waits while other jobs run on the shared cores is not counted.
    """
    T = np.arange(steps) * 1e-4
    start = time.thread_time()
    comp.chunk(q0, T, 1e-4)
    return (time.thread_time() - start) / (4 * steps * m) * 1e9


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--reps", type=int, default=15)
    ap.add_argument("--links", type=int, nargs="+", default=[64, 256, 1024])
    ap.add_argument("--steps", type=int, default=0, help="RK4 steps per chunk (default: about 130,000 links)")
    ap.add_argument("--scalar-trig", action="store_true")
    ap.add_argument("--curve", choices=["line", "circle", "path"], default="line",
                    help="the spatial case's curve (default: the turning line)")
    args = ap.parse_args()
    print(f"# {platform.processor() or platform.machine()}, {os.cpu_count()} CPUs, load {os.getloadavg()}")
    print("| m | planar [ns/link] | spatial [ns/link] | spatial / planar: median (min-max) |"
          + (" scalar trig / vector trig |" if args.scalar_trig else ""))
    for m in args.links:
        runs = cases(m, args.scalar_trig, args.curve)
        steps = args.steps or max(8, 131072 // (4 * m))
        times: dict[str, list[float]] = {name: [] for name in runs}
        for _ in range(args.reps):
            for name, (comp, q0) in runs.items():
                times[name].append(per_link_ns(comp, q0, steps, m))
        ratios = np.array(times["spatial"]) / np.array(times["planar"])
        row = (f"| {m} | {np.median(times['planar']):.1f} | {np.median(times['spatial']):.1f} | "
               f"{np.median(ratios):.2f} ({ratios.min():.2f}-{ratios.max():.2f}) |")
        if args.scalar_trig:
            scal = np.array(times["spatial, scalar trig"]) / np.array(times["spatial"])
            row += f" {np.median(scal):.2f} |"
        print(row, flush=True)
    print(f"# load after: {os.getloadavg()}")


if __name__ == "__main__":
    main()
