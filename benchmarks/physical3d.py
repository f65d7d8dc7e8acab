"""Cost of a spatial run's physical checks and 3-D scene: the C capsule distances against numpy, the scene's
template against ``json.dumps``, and whole ``coordarm run`` commands of the spatial presets.

Parts, each interleaved (A, B, A, B, ...) in one process, medians and the median of the per-round ratios:

* ``checks``: ``Physical3D.check`` on a block of a real run's samples (the preset run for its duration,
  every ``--every`` step), with the distances from ``coordarm.generated.segment_distance`` and with the
  numpy reference (``distance_library`` switched off): the same contacts are asserted.
* ``scene``: ``SpatialSceneBuilder.messages`` for every 20 Hz row of the same run (one template filled per
  block), against ``json.dumps`` of each scene's whole entity: the same items are asserted. (The walls were
  literal text in the template; since ``/scene/fixed`` they are in none of the ``/scene`` messages.)
* ``command``: ``coordarm run PRESET --no-figures`` in new processes (the whole command, wall time).

Run: ``python benchmarks/physical3d.py [--rounds N] [--presets pipe3d path3d]``; results in
``benchmarks/RESULTS.md``.
"""
from __future__ import annotations

import argparse
import json
import os
import platform
import subprocess
import sys
import tempfile
import time

import numpy as np

from coordarm.generated import segment_distance
from coordarm.simulation.physical3d import Physical3D
from coordarm.simulation.scene3d import SpatialSceneBuilder
from coordarm.simulation.session import run_scenario


def ratios(a: list[float], b: list[float]) -> str:
    r = np.array(b) / np.array(a)
    return f"{np.median(r):.1f}x ({r.min():.1f}-{r.max():.1f})"


def interleaved(first, second, rounds: int) -> tuple[list[float], list[float]]:
    """Times [s] of ``first()`` and ``second()``, alternating which goes first."""
    a, b = [], []
    for k in range(rounds):
        for f, out in ((first, a), (second, b)) if k % 2 == 0 else ((second, b), (first, a)):
            t = time.perf_counter()
            f()
            out.append(time.perf_counter() - t)
    return a, b


def checks(result, rounds: int, every: int) -> str:
    sc, run = result.scenario, result.run
    phys = sc.physical()
    assert isinstance(phys, Physical3D), type(phys)
    t, q = run.t[::every], run.q[::every]
    library = segment_distance.distance_library

    def compiled():
        return phys.check(t, q)

    def reference():
        segment_distance.distance_library = lambda: None
        try:
            return phys.check(t, q)
        finally:
            segment_distance.distance_library = library

    assert compiled() == reference()
    a, b = interleaved(compiled, reference, rounds)
    return (f"| `{sc.name}` checks | {len(t)} samples x {phys.chain.m} links, {len(phys.obstacles)} obstacles | "
            f"{np.median(a) * 1e3:.1f} ms | {np.median(b) * 1e3:.1f} ms | {ratios(a, b)} |")


def scene(result, rounds: int) -> str:
    sc, run = result.scenario, result.run
    ctrl = sc.controller()
    builder = SpatialSceneBuilder(ctrl, sc.obstacles, radius=sc.physical(ctrl.chain).radius)
    builder.advance(run)
    ks = np.flatnonzero(np.arange(len(run.t)) % max(1, round(0.05 / (run.t[1] - run.t[0]))) == 0)
    ns = (run.t[ks] * 1e9).round().astype(np.int64)
    from coordarm.simulation.scene import margin_colours

    def once():
        return [d for k, _, d in builder.messages(run, ks, ns) if k == "scene"]

    def every_message():     # the whole entity encoded for each message
        poses, curves, targets = builder.poses(run.q[ks]), builder.curves(run.t[ks]), builder.targets(run, ks)
        for pose, rgb in zip(poses, margin_colours(run.link_margins[ks])):
            pose["colours"] = rgb
        builder.frame_transforms(run.q[ks], ns)
        return [json.dumps({"deletions": [], "entities": [builder.scene_entity(p, c, x, n)]},
                           separators=(",", ":")).encode() for p, c, x, n in zip(poses, curves, targets, ns.tolist())]

    fast, dicts = once(), every_message()
    for x, y in zip(fast, dicts):
        x, y = json.loads(x)["entities"][0], json.loads(y)["entities"][0]
        assert [(k, len(v) if isinstance(v, list) else v) for k, v in x.items() if k != "timestamp"] == \
            [(k, len(v) if isinstance(v, list) else v) for k, v in y.items() if k != "timestamp"]
    a, b = interleaved(once, every_message, rounds)
    size = np.mean([len(x) for x in once()]) / 1e3
    return (f"| `{sc.name}` scene | {len(ks)} messages of {size:.0f} kB | "
            f"{np.median(a) * 1e3:.0f} ms | {np.median(b) * 1e3:.0f} ms | {ratios(a, b)} |")


def command(preset: str, rounds: int) -> str:
    with tempfile.TemporaryDirectory() as d:
        cmd = [sys.executable, "-m", "coordarm", "run", preset, "--no-figures", "--out", os.path.join(d, "x.mcap"),
               "--overwrite"]
        times = []
        for _ in range(rounds):
            t = time.perf_counter()
            subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
            times.append(time.perf_counter() - t)
    return f"| `coordarm run {preset} --no-figures` | {np.median(times):.2f} s (min {min(times):.2f}, max {max(times):.2f}) |"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rounds", type=int, default=7, help="interleaved rounds per part (default 7)")
    ap.add_argument("--presets", nargs="+", default=["pipe3d", "path3d"], help="spatial presets (default pipe3d path3d)")
    ap.add_argument("--every", type=int, default=2, help="check every n-th step of the run (default 2)")
    args = ap.parse_args()
    print(f"{time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}, {platform.processor() or platform.machine()}, "
          f"{os.cpu_count()} cores, load {os.getloadavg()[0]:.1f}, Python {platform.python_version()}, "
          f"kernel {'built' if segment_distance.distance_library() is not None else 'MISSING'}\n")
    print("| part | size | C kernel / template | numpy / json.dumps per message | ratio (median, min-max) |")
    print("|---|---|---|---|---|")
    for preset in args.presets:
        with tempfile.TemporaryDirectory() as d:
            result = run_scenario(preset, log=os.path.join(d, "x.mcap"))     # every step kept (figures drawn)
        print(checks(result, args.rounds, args.every), flush=True)
        print(scene(result, args.rounds), flush=True)
    print("\n| command | wall time |\n|---|---|")
    for preset in args.presets:
        print(command(preset, args.rounds), flush=True)


if __name__ == "__main__":
    main()
