"""Cost of the kill-loss bound in the threaded logger: the bounded writer (at most two blocks
queued, idle flushes, pushed every 0.5 s) against the previous one (eight blocks queued, pushed
every second), interleaved with an unlogged run.

The 64-link ``line`` run, 30 s at 1 ms, compiled backend, full-rate threaded log.

Usage: ``python benchmarks/logging_bounds.py [--repeats 9]``
"""
from __future__ import annotations

import argparse
import platform
import statistics
import tempfile
import time
from pathlib import Path

from coordarm.simulation import mcap_writer
from coordarm.simulation.mcap_file import Worker
from coordarm.simulation.run import simulate
from coordarm.simulation.scenario import load_scenario


class PreviousWorker(Worker):
    """The writer thread as it was: eight blocks queued, no idle flush."""

    def __init__(self, handle, name, maxsize, idle=None, idle_interval=0.25):
        super().__init__(handle, name, 8)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=9)
    args = parser.parse_args()
    sc = load_scenario("line").with_overrides(duration=30.0)
    ctrl = sc.controller()
    q0 = sc.start(ctrl)
    simulate(ctrl, q0, 0.01, sc.step, backend="compiled", progress=False)   # build or load the library
    tmp = Path(tempfile.mkdtemp())

    def logged(variant: str) -> None:
        mcap_writer.Worker = PreviousWorker if variant == "previous" else Worker
        kw = {"flush_interval": 1.0} if variant == "previous" else {}
        with mcap_writer.RunLogger(tmp / f"{variant}.mcap", sc, ctrl, threaded=True, **kw) as log:
            simulate(ctrl, q0, sc.duration, sc.step, backend="compiled", progress=False, on_chunk=log.on_chunk)
        mcap_writer.Worker = Worker

    runs = {"without log": lambda: simulate(ctrl, q0, sc.duration, sc.step, backend="compiled", progress=False),
            "previous writer": lambda: logged("previous"), "bounded writer": lambda: logged("bounded")}
    times: dict[str, list[float]] = {k: [] for k in runs}
    for _ in range(args.repeats):
        for name, fn in runs.items():   # interleaved
            start = time.perf_counter()
            fn()
            times[name].append(time.perf_counter() - start)
    print(f"python {platform.python_version()}, {platform.machine()}, repeats {args.repeats}")
    med = {k: statistics.median(v) for k, v in times.items()}
    for name, v in times.items():
        print(f"  {name:16s} median {med[name]:.3f} s  ratio {med[name] / med['without log']:.2f}  "
              f"({', '.join(f'{t:.3f}' for t in v)})")
    print(f"  bounded / previous: {med['bounded writer'] / med['previous writer']:.3f}")


if __name__ == "__main__":
    main()
