"""Issue 24, item 5: the fixed cost of ``coordarm run`` (all but the ``simulate`` call), two trees interleaved.

Each round, for each tree in turn (``PYTHONPATH`` = the tree, child processes with bytecode caching on,
library cached) and each variant (``--quiet``; the progress bar, on a pipe; ``--duration 0.01 --quiet``,
the fixed cost alone):
``python -m coordarm run line --links 64 --duration 30 --no-figures --overwrite`` timed from outside
(interpreter start to process end), with the wall time of its ``simulation.run.simulate`` call measured
inside the process (the per-chunk log work overlaps it; the writer's tail after it does not). The fixed
cost is the difference: interpreter, imports, preparation, the log's opening and closing, the summary and
the exit. Medians over the rounds; ratios: median (min-max) of the per-round ratios.

Run: ``python benchmarks/fixed_cost.py BEFORE_TREE AFTER_TREE [--rounds 15]``
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

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

from timing import fmt_ratio  # noqa: E402

ENV = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}

#: The command, with its ``simulate`` call timed (written to the file named by argv[1]).
PROBE = r"""
import sys, time
import coordarm.simulation.run as run
simulate = run.simulate
def timed(*a, **k):
    start = time.perf_counter()
    try:
        return simulate(*a, **k)
    finally:
        with open(sys.argv[1], "w") as f:
            f.write(repr(time.perf_counter() - start))
run.simulate = timed
from coordarm.cli import console
console(sys.argv[2:])
"""

VARIANTS = {"--quiet": ["--quiet"], "progress bar": [],
            # the fixed cost alone: the same command simulating 0.01 s (10 steps)
            "--duration 0.01 --quiet": ["--quiet", "--duration", "0.01"]}


def one(tree: Path, work: Path, extra: list[str]) -> tuple[float, float]:
    """Wall time of the command and of its ``simulate`` call [s]."""
    stamp = work / "simulate.txt"
    argv = [sys.executable, "-c", PROBE, str(stamp), "run", "line", "--links", "64", "--duration", "30",
            "--no-figures", "--overwrite", "--out", str(work / f"{tree.name}.mcap"), *extra]
    start = time.perf_counter()
    subprocess.run(argv, cwd=work, env=dict(ENV, PYTHONPATH=str(tree)), stdout=subprocess.DEVNULL,
                   stderr=subprocess.DEVNULL, check=True)
    return time.perf_counter() - start, float(stamp.read_text())


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("trees", nargs=2, type=Path, metavar="TREE")
    ap.add_argument("--rounds", type=int, default=15)
    args = ap.parse_args()
    trees = [t.resolve() for t in args.trees]
    work = Path(tempfile.mkdtemp(prefix="coordarm-fixed-cost-"))
    for tree in trees:                                   # warm the bytecode and the build cache
        one(tree, work, ["--quiet"])
    data: dict[str, list[float]] = {}
    loads = [os.getloadavg()[0]]
    for _ in range(args.rounds):
        for variant, extra in VARIANTS.items():
            for name, tree in zip(("before", "after"), trees):
                wall, sim = one(tree, work, extra)
                data.setdefault(f"{name} {variant} wall", []).append(wall)
                data.setdefault(f"{name} {variant} simulate", []).append(sim)
                data.setdefault(f"{name} {variant} fixed", []).append(wall - sim)
        loads.append(os.getloadavg()[0])
    med = statistics.median
    print(f"load average {min(loads):.2f}-{max(loads):.2f}, {args.rounds} interleaved rounds")
    print("| command | before: wall [s] | simulate [s] | fixed [s] | after: wall [s] | simulate [s] | fixed [s] "
          "| fixed after / before |")
    print("|---|---|---|---|---|---|---|---|")
    for variant in VARIANTS:
        b = {k: data[f"before {variant} {k}"] for k in ("wall", "simulate", "fixed")}
        a = {k: data[f"after {variant} {k}"] for k in ("wall", "simulate", "fixed")}
        r = [x / y for x, y in zip(a["fixed"], b["fixed"])]
        print(f"| {variant} | {med(b['wall']):.3f} | {med(b['simulate']):.3f} | {med(b['fixed']):.3f} | "
              f"{med(a['wall']):.3f} | {med(a['simulate']):.3f} | {med(a['fixed']):.3f} | "
              f"{fmt_ratio((med(r), min(r), max(r)))} |")


if __name__ == "__main__":
    main()
