"""Issue 24, the command's cost: two source trees side by side, in interleaved rounds.

For each tree (``PYTHONPATH`` = the tree, child processes with bytecode caching on) and each round:

* ``coordarm run line --links m --duration T --no-figures`` (new process, library cached) for the
  cases given (default 64 links 30 s, and 16, 1024, 4096 links 1 s), timed from outside, with the
  process's CPU time (both threads, ``wait4``);
* the physical checks of a 64-link, 30 s run as ``coordarm run`` makes them (200 Hz, the run's own
  6001 checked samples, in blocks of 400 as the chunk loop hands them): the fastest of 5 calls of
  ``check_configuration``, in a child process;
* the cache-hit lookup of the compiled law (``generated.compile`` of a new controller, the
  library cached), fastest of 5, in a child process.

And, in this process, the bare simulation (compiled, unlogged, no checks) of every case, so that
each round gives the command / bare ratio of both trees under the same load. Medians over rounds,
ratios as median (min-max) of the per-round ratios.

Run: ``python benchmarks/startup_checks.py BEFORE_TREE AFTER_TREE [--rounds 5] [--case 64:30 ...]``
(a tree: a checkout, e.g. ``git archive <commit> | tar -x -C /tmp/before``).
"""
from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))
sys.path.insert(0, str(HERE))

from scale import bare_seconds  # noqa: E402
from timing import fmt_ratio  # noqa: E402

ENV = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}

PROBE = r"""
import json, sys, time
import numpy as np
from coordarm.simulation.scenario import load_scenario
from coordarm.simulation.physical import check_configuration
from coordarm.simulation.run import simulate
import coordarm.generated as generated

sc = load_scenario("line").with_overrides(64, 30.0, None)
ctrl = sc.controller()
run = simulate(ctrl, sc.start(ctrl), sc.duration, sc.step, sc.t0, backend="compiled", progress=False)
q, t = run.q[::5], run.t[::5]                                       # 200 Hz: 6001 samples
blocks = [slice(i, i + 400) for i in range(0, len(q), 400)]
def fastest(f, n=5):
    best = float("inf")
    for _ in range(n):
        start = time.perf_counter(); f(); best = min(best, time.perf_counter() - start)
    return best
checks = fastest(lambda: [check_configuration(ctrl.chain, q[b], [], t[b]) for b in blocks])
from coordarm.generated import build
def lookup():                                   # as in a new process: no compiled law, no version asked yet
    generated._compiled.clear()
    build._compiler_version.cache_clear()
    generated.compile(sc.controller())
lookup_s = fastest(lookup)
print(json.dumps({"checks": checks, "samples": len(q), "lookup": lookup_s}))
"""


def ratio(a: list[float], b: list[float]) -> tuple[float, float, float]:
    r = [x / y for x, y in zip(a, b)]
    return statistics.median(r), min(r), max(r)


def command(tree: Path, work: Path, m: int, duration: float) -> tuple[float, float]:
    """Wall and CPU time [s] of one ``coordarm run`` from ``tree``."""
    argv = [sys.executable, "-m", "coordarm", "run", "line", "--links", str(m), "--duration", str(duration),
            "--no-figures", "--quiet", "--overwrite", "--out", str(work / f"{tree.name}.mcap")]
    start = time.perf_counter()
    proc = subprocess.Popen(argv, cwd=work, env=dict(ENV, PYTHONPATH=str(tree)), stdout=subprocess.DEVNULL)
    _, status, usage = os.wait4(proc.pid, 0)
    wall = time.perf_counter() - start
    proc.returncode = os.waitstatus_to_exitcode(status)
    if proc.returncode:
        raise RuntimeError(f"{' '.join(argv)} (tree {tree}): exit {proc.returncode}")
    return wall, usage.ru_utime + usage.ru_stime


def probe(tree: Path, work: Path) -> dict:
    res = subprocess.run([sys.executable, "-c", PROBE], cwd=work, env=dict(ENV, PYTHONPATH=str(tree)),
                         capture_output=True, text=True, check=True)
    return json.loads(res.stdout.strip().splitlines()[-1])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("trees", nargs=2, type=Path, metavar="TREE")
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--case", action="append", help="LINKS:SECONDS (repeatable; default 64:30 16:1 1024:1 4096:1)")
    args = ap.parse_args()
    cases = [(int(c.split(":")[0]), float(c.split(":")[1])) for c in args.case or ["64:30", "16:1", "1024:1", "4096:1"]]
    work = Path(tempfile.mkdtemp(prefix="coordarm-startup-checks-"))
    trees = [t.resolve() for t in args.trees]
    names = ["before", "after"]
    for m, d in cases:                                   # build and cache the libraries, warm the bytecode
        bare_seconds(m, 0.01)
        for tree in trees:
            command(tree, work, m, 0.01)
    data: dict = {"loads": [os.getloadavg()[0]]}
    for _ in range(args.rounds):
        for m, d in cases:
            data.setdefault(f"bare {m}:{d:g}", []).append(bare_seconds(m, d))
            for name, tree in zip(names, trees):
                wall, cpu = command(tree, work, m, d)
                data.setdefault(f"{name} {m}:{d:g}", []).append(wall)
                data.setdefault(f"{name} cpu {m}:{d:g}", []).append(cpu)
        for name, tree in zip(names, trees):
            for key, value in probe(tree, work).items():
                data.setdefault(f"{name} {key}", []).append(value)
        data["loads"].append(os.getloadavg()[0])
    med = statistics.median
    print(f"load average {min(data['loads']):.2f}-{max(data['loads']):.2f}, {args.rounds} interleaved rounds")
    print("| run | bare [s] | before [s] | / bare | after [s] | / bare | after / before | CPU before [s] | CPU after [s] |")
    print("|---|---|---|---|---|---|---|---|---|")
    for m, d in cases:
        k = f"{m}:{d:g}"
        b, x, y = data[f"bare {k}"], data[f"before {k}"], data[f"after {k}"]
        print(f"| {m} links, {d:g} s | {med(b):.3f} | {med(x):.3f} | {fmt_ratio(ratio(x, b))} | {med(y):.3f} | "
              f"{fmt_ratio(ratio(y, b))} | {fmt_ratio(ratio(y, x))} | {med(data[f'before cpu {k}']):.3f} | "
              f"{med(data[f'after cpu {k}']):.3f} |")
    if any(m == 1024 for m, _ in cases) and any(m == 4096 for m, _ in cases):
        d = next(d for m, d in cases if m == 1024)
        for name in names:
            print(f"{name}: 1024 / 4096 links ({d:g} s): {fmt_ratio(ratio(data[f'{name} 1024:{d:g}'], data[f'{name} 4096:{d:g}']))}")
    n = data["after samples"][0]
    for name in names:
        c = med(data[f"{name} checks"])
        print(f"{name}: checks {c * 1e3:.1f} ms for {n:.0f} samples ({c / n * 1e6:.1f} µs per sample), "
              f"cache-hit lookup {med(data[f'{name} lookup']) * 1e3:.1f} ms")
    print(f"checks after / before: {fmt_ratio(ratio(data['after checks'], data['before checks']))}; "
          f"lookup after / before: {fmt_ratio(ratio(data['after lookup'], data['before lookup']))}")


if __name__ == "__main__":
    main()
