"""A/B of generated law sources: the C chunk of two or more versions of the spatial law, interleaved.

``gen DIR`` writes, with the code of this checkout, the generated C of the ``spatial_law.py`` cases
(``spatial_M.c``, ``planar_M.c``) and their start states (``q_spatial_M.npy``, ``q_planar_M.npy``) to
``DIR`` for each ``--m``; run it once per version (e.g. before a change, from a checkout of the base commit
put first on ``PYTHONPATH``, and after it). ``time DIR [DIR ...]`` builds every ``spatial_M.c`` with the
default flags (``gcc``, cached next to the source), checks each chunk against the first's (largest
relative difference of the states and of the outputs), then times ``coordarm_chunk`` of every version
(and with ``--planar`` the first directory's planar law) in interleaved rounds: thread CPU time per law call
per link, output arrays allocated once, ratios as medians (min-max) of the per-round ratios to the first
version (and to the planar law).

Run: ``python benchmarks/chunk_ab.py gen DIR [--m 64 256 1024] [--curve line|circle|path]``, then
``python benchmarks/chunk_ab.py time DIR_A DIR_B [--planar] [--m ...] [--reps 31] [--steps S]``.
"""
from __future__ import annotations

import argparse
import ctypes
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from spatial_law import cases  # noqa: E402


def generate(folder: Path, links: list[int], curve: str) -> None:
    """Write the planar and spatial sources and start states of ``spatial_law.cases`` for each link count."""
    from coordarm.generated.compiled import controller_source

    folder.mkdir(parents=True, exist_ok=True)
    for m in links:
        for name, (comp, q0) in cases(m, False, curve).items():
            (folder / f"{name}_{m}.c").write_text(controller_source(comp.ctrl, "structured").text)
            np.save(folder / f"q_{name}_{m}.npy", q0)


def library(source: Path) -> ctypes.CDLL:
    """``source`` built with the default flags into ``source.so`` (rebuilt when the source is newer), loaded."""
    from coordarm.generated.build import DEFAULT_FLAGS, REQUIRED_FLAGS

    lib = source.with_suffix(".so")
    if not lib.exists() or lib.stat().st_mtime < source.stat().st_mtime:
        subprocess.run(["gcc", *REQUIRED_FLAGS, *DEFAULT_FLAGS, "-o", str(lib), str(source), "-lm"], check=True)
    return ctypes.CDLL(str(lib))


class Chunk:
    """One library's RK4 chunk of ``steps`` steps from ``q0``, its arrays allocated once."""

    def __init__(self, source: Path, q0: np.ndarray, steps: int) -> None:
        self.lib = library(source)
        p, d, i = ctypes.c_void_p, ctypes.c_double, ctypes.c_longlong
        self.lib.coordarm_chunk.argtypes, self.lib.coordarm_chunk.restype = [p, p, d, i, p, p, p, p], ctypes.c_int
        self.lib.coordarm_sizes.argtypes = [p]
        sizes = np.zeros(4, dtype=np.int64)
        self.lib.coordarm_sizes(sizes.ctypes.data)
        self.m, n_out, n_iw, n_w = (int(v) for v in sizes)
        self.q0, self.steps = np.ascontiguousarray(q0, dtype=float), steps
        self.times = np.arange(steps) * 1e-4
        self.Q, self.D = np.zeros((steps, len(q0))), np.zeros((steps, n_out))
        self.iw, self.w = np.zeros(n_iw, dtype=np.int64), np.zeros(n_w)

    def run(self) -> None:
        """One chunk (h = 0.1 ms)."""
        rc = self.lib.coordarm_chunk(self.q0.ctypes.data, self.times.ctypes.data, 1e-4, self.steps,
                                     self.Q.ctypes.data, self.D.ctypes.data, self.iw.ctypes.data, self.w.ctypes.data)
        if rc:
            raise RuntimeError(f"chunk returned {rc}")

    def per_link_ns(self) -> float:
        """Thread CPU time of one chunk per law call per link [ns]."""
        start = time.thread_time()
        self.run()
        return (time.thread_time() - start) / (4 * self.steps * self.m) * 1e9


def relative(a: np.ndarray, b: np.ndarray) -> float:
    """Largest ``|a - b| / (1 + |b|)``."""
    return float(np.max(np.abs(a - b) / (1 + np.abs(b))))


def compare(folders: list[Path], m: int, reps: int, steps: int, planar: bool) -> None:
    """Check and time the versions in ``folders`` at ``m`` links; print one line per version."""
    steps = steps or max(8, 131072 // (4 * m))
    runs = {}
    if planar:
        runs["planar"] = Chunk(folders[0] / f"planar_{m}.c", np.load(folders[0] / f"q_planar_{m}.npy"), steps)
    for folder in folders:
        runs[str(folder)] = Chunk(folder / f"spatial_{m}.c", np.load(folder / f"q_spatial_{m}.npy"), steps)
    first = runs[str(folders[0])]
    first.run()
    for folder in folders[1:]:
        run = runs[str(folder)]
        run.run()
        print(f"  {folder}: states {relative(run.Q, first.Q):.2e}, outputs {relative(run.D, first.D):.2e} "
              f"(largest relative difference to {folders[0]})")
    times = {name: [] for name in runs}
    for _ in range(reps):
        for name, run in runs.items():
            times[name].append(run.per_link_ns())
    base = np.array(times[str(folders[0])])
    for name, values in times.items():
        t = np.array(values)
        row = f"m = {m} {name}: {np.median(t):.2f} ns/link, / first {np.median(t / base):.3f} " \
              f"({np.min(t / base):.3f}-{np.max(t / base):.3f})"
        if planar and name != "planar":
            r = t / np.array(times["planar"])
            row += f", / planar {np.median(r):.3f} ({r.min():.2f}-{r.max():.2f})"
        print(row, flush=True)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("command", choices=["gen", "time"])
    ap.add_argument("folders", nargs="+", type=Path)
    ap.add_argument("--m", type=int, nargs="+", default=[64, 256, 1024])
    ap.add_argument("--curve", choices=["line", "circle", "path"], default="line")
    ap.add_argument("--reps", type=int, default=31)
    ap.add_argument("--steps", type=int, default=0, help="RK4 steps per chunk (default: about 131,000 links)")
    ap.add_argument("--planar", action="store_true", help="time the first folder's planar law too")
    args = ap.parse_args()
    if args.command == "gen":
        generate(args.folders[0], args.m, args.curve)
        return
    print(f"# load {os.getloadavg()}")
    for m in args.m:
        compare(args.folders, m, args.reps, args.steps, args.planar)
    print(f"# load after: {os.getloadavg()}")


if __name__ == "__main__":
    main()
