"""Start-up cost of two source trees, interleaved: a cache-hit ``coordarm run`` and its imports.

Each round runs, for each tree in turn (``PYTHONPATH`` = the tree, a neutral working directory),
``python -m coordarm run line --duration 0.1 --no-figures`` (the compiled law from the cache)
timed from outside, then the same command under ``python -X importtime``: the sum of every
module's own import time, and the cumulative time of the modules named with ``--module``.
Medians over the rounds. Used for issue 21 (the cache directory from platformdirs).

Run: ``python benchmarks/startup_trees.py BEFORE_TREE AFTER_TREE [--rounds 7] [--module platformdirs]``
(a tree: a checkout, e.g. ``git archive <commit> | tar -x -C /tmp/before``).
"""
from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path


def import_times(stderr: str, modules: list[str]) -> dict[str, float]:
    """``total`` (sum of the modules' own times) and each of ``modules``' cumulative time [ms]."""
    out = {"total": 0.0, **{m: 0.0 for m in modules}}
    for line in stderr.splitlines():
        if not line.startswith("import time:") or "self [us]" in line:
            continue
        own, cumulative, name = (x.strip() for x in line[len("import time:"):].split("|"))
        out["total"] += int(own) / 1000
        if name in modules:
            out[name] = int(cumulative) / 1000
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("trees", nargs="+", type=Path)
    parser.add_argument("--rounds", type=int, default=7)
    parser.add_argument("--module", action="append", default=[])
    args = parser.parse_args()
    work = Path(tempfile.mkdtemp(prefix="coordarm-startup-"))
    cmd = ["-m", "coordarm", "run", "line", "--duration", "0.1", "--no-figures", "--out", str(work / "x.mcap"),
           "--overwrite"]
    samples = {str(t): {"wall [s]": [], "imports [ms]": [], **{m: [] for m in args.module}} for t in args.trees}
    for tree in args.trees:                      # warm the cache and the byte code
        subprocess.run([sys.executable, *cmd], cwd=work, env=dict(os.environ, PYTHONPATH=str(tree)), check=True,
                       capture_output=True)
    for _ in range(args.rounds):
        for tree in args.trees:
            env = dict(os.environ, PYTHONPATH=str(tree))
            start = time.perf_counter()
            subprocess.run([sys.executable, *cmd], cwd=work, env=env, check=True, capture_output=True)
            samples[str(tree)]["wall [s]"].append(time.perf_counter() - start)
            res = subprocess.run([sys.executable, "-X", "importtime", *cmd], cwd=work, env=env, check=True,
                                 capture_output=True, text=True)
            times = import_times(res.stderr, args.module)
            samples[str(tree)]["imports [ms]"].append(times["total"])
            for m in args.module:
                samples[str(tree)][m].append(times[m])
    for tree, values in samples.items():
        print(tree, {k: round(statistics.median(v), 3) for k, v in values.items()})


if __name__ == "__main__":
    main()
