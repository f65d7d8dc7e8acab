"""Wall time of ``coordarm replay``'s GIF for a 64-link, 15 s run (the line preset): 200 frames.

Run: ``python benchmarks/animation.py``; results in ``benchmarks/RESULTS.md``.
"""
from __future__ import annotations

import os
import tempfile
import time
from pathlib import Path

import numpy as np

from coordarm.analysis.animation import animate
from coordarm.analysis.replay import load
from coordarm.cli import main as cli


def main(repeats: int = 3) -> None:
    with tempfile.TemporaryDirectory() as tmp:
        log = Path(tmp) / "line.mcap"
        assert cli(["run", "line", "--duration", "15", "--quiet", "--no-figures", "--out", str(log)]) == 0
        rep = load(log)
        ctrl = rep.controller()
        times = []
        for _ in range(repeats):
            t = time.perf_counter()
            animate(rep, Path(tmp) / "line.gif", ctrl=ctrl, progress=False)
            times.append(time.perf_counter() - t)
    print(f"64 links, 15 s, 200 frames: median {np.median(times):.1f} s over {repeats} "
          f"(all: {', '.join(f'{x:.1f}' for x in times)}), load {os.getloadavg()[0]:.1f}")


if __name__ == "__main__":
    main()
