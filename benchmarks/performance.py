"""Performance at every scale (issue 15), written into benchmarks/RESULTS.md by ``make bench``.

Run: ``python benchmarks/performance.py [--quick] [--no-write]``. Every comparison is
interleaved in rounds inside one process (each variant timed once per round, so all see the
same machine load; a round of the law and of the wrapper keeps each variant's fastest of 5
interleaved batches, so a batch preempted by another process does not count) and reported as
the median of the per-round ratios with their min-max:

* the law from C (``bench_driver.c``) at m = 16 .. 16384: today's vectorised law vs the law
  as generated before it (``scalar_law.py``, default flags of then: ``-O3``) and vs the
  cos/sin-only floor (``timing.FLOOR``), and the scaling exponent of the law;
* a 1 s run (1000 RK4 steps, compiled, unlogged) at m = 16 .. 16384 and its exponent;
* generate + compile + load of the law, cold, at m = 64 and 16384;
* the Python wrapper at m = 8: ``control(q, t, out=u)`` vs the C law;
* the command at 64 links: bare simulation, simulation with the full-rate log, and
  ``coordarm run line --duration 30`` with and without figures (in a fresh process).
"""
from __future__ import annotations

import argparse
import os
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
import numpy as np  # noqa: E402

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))
sys.path.insert(0, str(HERE))

from coordarm.generated.build import DEFAULT_FLAGS, build  # noqa: E402
from coordarm.generated.codegen import generate_source  # noqa: E402
from coordarm.simulation.mcap_writer import RunLogger  # noqa: E402
from coordarm.simulation.run import select_backend, simulate  # noqa: E402
from coordarm.simulation.scenario import load_scenario  # noqa: E402
from coordarm.generated import compile as compile_controller  # noqa: E402
from command_cost import decomposition  # noqa: E402
from run_benchmarks import line_controller, machine  # noqa: E402
from scalar_law import scalar_source  # noqa: E402
from timing import c_interleaved, floor_library, fmt_ratio, py_interleaved, ratio  # noqa: E402

SIZES = (16, 64, 256, 1024, 4096, 16384)
START, END = "<!-- performance.py: start -->", "<!-- performance.py: end -->"


def exponent(ms, times) -> float:
    """Least-squares slope of log(time) against log(m)."""
    return float(np.polyfit(np.log(ms), np.log(times), 1)[0])


def law_table(rounds: int) -> tuple[list[str], dict]:
    rows = ["| m | today's law [µs] | before [µs] | floor [µs] | before / today (law) | before / today (RK4 step) "
            "| today / floor |", "|---|---|---|---|---|---|---|"]
    law_us = {}
    for m in SIZES:
        ctrl = line_controller(m)
        libs = [build(generate_source(ctrl)).path, build(scalar_source(ctrl), flags=("-O3",)).path,
                floor_library(m)]
        law, rk4 = c_interleaved(libs, ctrl.chain.zigzag(1.0), rounds=rounds, batch_ms=2.0)
        med = np.median(law, axis=0) / 1e3
        law_us[m] = med[0]
        rows.append(f"| {m} | {med[0]:.3g} | {med[1]:.3g} | {med[2]:.3g} | {fmt_ratio(ratio(law, 1, 0))} | "
                    f"{fmt_ratio(ratio(rk4, 1, 0))} | {fmt_ratio(ratio(law, 0, 2))} |")
    return rows, law_us


def run_seconds(m: int) -> float:
    ctrl = line_controller(m)
    q0 = ctrl.chain.zigzag(1.0)
    start = time.perf_counter()
    simulate(ctrl, q0, 1.0, 1e-3, backend="compiled", progress=False)
    return time.perf_counter() - start


def build_seconds(m: int) -> float:
    ctrl = line_controller(m)
    with tempfile.TemporaryDirectory() as tmp:
        start = time.perf_counter()
        compile_controller(ctrl, build_dir=tmp)
        return time.perf_counter() - start


def scaling(rounds: int) -> list[str]:
    runs = py_interleaved([lambda m=m: run_seconds(m) for m in SIZES], rounds=rounds, batch_s=0)
    med = np.median(runs, axis=0)
    builds = py_interleaved([lambda: build_seconds(64), lambda: build_seconds(16384)], rounds=rounds, batch_s=0)
    rows = ["| m | " + " | ".join(map(str, SIZES)) + " |", "|---" * (len(SIZES) + 1) + "|",
            "| 1 s run (1000 RK4 steps, compiled, unlogged) [s] | " + " | ".join(f"{v:.3g}" for v in med) + " |",
            "", f"Scaling exponent of the 1 s run from m = 16 to 16384: **{exponent(SIZES, med):.2f}** "
            f"(from m = 256: {exponent(SIZES[2:], med[2:]):.2f}).", "",
            f"Generate + compile + load, cold: m = 64 {np.median(builds[:, 0]):.2f} s, m = 16384 "
            f"{np.median(builds[:, 1]):.2f} s; ratio 16384 / 64 per round {fmt_ratio(ratio(builds, 1, 0))}."]
    return rows


def wrapper(rounds: int) -> list[str]:
    ctrl = line_controller(8)
    comp = compile_controller(ctrl)
    q, u, packed = ctrl.chain.zigzag(1.0), np.empty(8), np.empty(comp.n_out)
    py = py_interleaved([lambda: comp.control(q, 1.0, out=u), lambda: comp.evaluate(q, 1.0, out=packed),
                         lambda: comp.control(q, 1.0)], rounds=rounds, sub=5)
    law, _ = c_interleaved([comp.library.path], q, rounds=rounds)
    c_us = float(np.median(law)) / 1e3
    med = np.median(py, axis=0) * 1e6
    return [f"m = 8: the C law {c_us:.3f} µs; from Python `control(q, t, out=u)` {med[0]:.3f} µs, "
            f"`evaluate(q, t, out=row)` {med[1]:.3f} µs, `control(q, t)` (new array) {med[2]:.3f} µs: "
            f"wrapper overhead (ctypes call included) **{med[0] - c_us:.2f} µs** with `out=`."]


def command(rounds: int) -> list[str]:
    scenario = load_scenario("line").with_overrides(64, 30.0, None)
    ctrl = scenario.controller()
    q0 = scenario.start(ctrl)
    select_backend(ctrl, "compiled")          # build once, outside the timings
    tmp = Path(tempfile.mkdtemp())

    def bare():
        simulate(ctrl, q0, scenario.duration, scenario.step, scenario.t0, backend="compiled", progress=False)

    def logger(name: str, **options) -> RunLogger:
        (tmp / name).unlink(missing_ok=True)   # a new file each time (replacing one frees its blocks: not logging)
        return RunLogger(tmp / name, scenario, ctrl, backend="compiled", threaded=True, **options)

    def logged():
        with logger("b.mcap") as log:
            simulate(ctrl, q0, scenario.duration, scenario.step, scenario.t0, backend="compiled", progress=False,
                     on_chunk=log.on_chunk)

    def logged_lz4():
        with logger("b4.mcap", compression="lz4") as log:
            simulate(ctrl, q0, scenario.duration, scenario.step, scenario.t0, backend="compiled", progress=False,
                     on_chunk=log.on_chunk)

    def cmd(*extra):
        subprocess.run([sys.executable, "-m", "coordarm", "run", "line", "--links", "64", "--duration", "30",
                        "--quiet", "--overwrite", "--out", str(tmp / "c.mcap"), *extra], check=True,
                       capture_output=True)

    try:
        import lz4.frame  # noqa: F401   optional (coordarm[lz4])
        variants = [bare, logged, lambda: cmd("--no-figures"), lambda: cmd(), logged_lz4]
    except ImportError:
        variants = [bare, logged, lambda: cmd("--no-figures"), lambda: cmd()]
    T = py_interleaved(variants, rounds=rounds, batch_s=0)
    med = np.median(T, axis=0)
    return ["| | seconds (median) | / bare simulation (median of rounds, min–max) |", "|---|---|---|",
            f"| bare simulation (64 links, 30 s, 30,000 RK4 steps, compiled) | {med[0]:.3f} | 1 |",
            f"| the same with the full-rate MCAP log (threaded writer) | {med[1]:.3f} | {fmt_ratio(ratio(T, 1, 0))} |",
            *([f"| the same with `--compression lz4` | {med[4]:.3f} | {fmt_ratio(ratio(T, 4, 0))} |"]
              if T.shape[1] > 4 else []),
            f"| `coordarm run line --duration 30 --no-figures` (new process) | {med[2]:.3f} | "
            f"{fmt_ratio(ratio(T, 2, 0))} |",
            f"| `coordarm run line --duration 30` with figures (new process) | {med[3]:.3f} | "
            f"{fmt_ratio(ratio(T, 3, 0))} |"]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="fewer rounds")
    ap.add_argument("--no-write", action="store_true", help="print only; leave RESULTS.md alone")
    args = ap.parse_args()
    rounds = 5 if args.quick else 15
    load0 = os.getloadavg()[0]
    started = time.time()
    law_rows, law_us = law_table(rounds)
    parts = [START, "## Performance at every scale (generated by `make bench`, benchmarks/performance.py)", "",
             f"Run {time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}, default flags `{' '.join(DEFAULT_FLAGS)}`. "
             f"Machine:", *machine(), "",
             "Every comparison is interleaved in rounds in one process; ratios are medians of per-round "
             f"ratios (min–max), {rounds} rounds; a round of the law (and of the wrapper) keeps each "
             "variant's fastest of 5 interleaved batches.", "",
             "### The law from C: vectorised trigonometry vs the law before it and vs the cos/sin floor", "",
             "*before*: the law as generated before the vectorised trigonometry (one scalar `sincos` per link "
             "inside the recursion, `-O3`); *floor*: only the prefix sum of the angles and their cosines and "
             "sines (the same vector loops); state a zig-zag (β = 1).", "", *law_rows, "",
             f"Scaling exponent of the law from m = 16 to 16384: **{exponent(SIZES, list(law_us.values())):.2f}**.",
             "", "### Scaling of a run and of the set-up", "", *scaling(max(3, rounds // 3)), "",
             "### Python wrapper", "", *wrapper(rounds), "",
             "### What the command costs (64 links, 30 s simulated)", "", *command(max(3, rounds // 3)), "",
             "Where the command's time goes (`benchmarks/command_cost.py`: phases timed inside the command's "
             "process; the log's writer threads run during *simulate + log*):", "",
             *decomposition(max(3, rounds // 3)), "",
             f"Load average at start {load0:.2f}, at end {os.getloadavg()[0]:.2f}; the benchmark took "
             f"{time.time() - started:.0f} s.", END]
    text = "\n".join(parts) + "\n"
    print(text)
    if not args.no_write:
        path = HERE / "RESULTS.md"
        old = path.read_text()
        pattern = re.compile(re.escape(START) + ".*?" + re.escape(END) + "\n?", re.S)
        new = pattern.sub(lambda _: text, old) if pattern.search(old) else old.rstrip("\n") + "\n\n" + text
        path.write_text(new)


if __name__ == "__main__":
    main()
