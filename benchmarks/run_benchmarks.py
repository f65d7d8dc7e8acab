"""Speed and scale of the coordinating law: compiled C vs interpreted CasADi vs numpy.

Run: ``python benchmarks/run_benchmarks.py [--quick] [--out FILE]`` (``make bench``).
Prints Markdown tables (medians over repeats; ratios from the same run) for a 64-link
style line whose angle swings as ``0.6 sin(0.2 t)``, at m = 8, 64, 256, 1024:

* one law evaluation and one RK4 step, timed from C (``bench_driver.c`` calls the
  generated library in a loop) and from Python (``CompiledController.control``, and per
  step of ``CompiledController.chunk``);
* the compiled dense law (eq. 27) up to the m where generate + compile still takes
  less than a minute;
* the interpreted CasADi law and RK4 step (the expanded SX Function);
* the vectorised numpy dense law of ``numpy_dense.py`` (same law, tested against ours);
* cold generate + compile time per m, and a 64-link, 30 s run at 1 ms steps.

numpy runs with a single BLAS thread (``OPENBLAS_NUM_THREADS=1`` unless set): on a
shared 2-core machine a threaded BLAS fighting other jobs was up to 3x slower and far
noisier, which would flatter the compiled code.
"""
from __future__ import annotations

import argparse
import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")   # before numpy is imported (see the docstring)
import platform
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import casadi as ca
import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))
sys.path.insert(0, str(HERE))

from coordarm.generated.build import build, find_compiler  # noqa: E402
from coordarm.generated.codegen import generate_source  # noqa: E402
from numpy_dense import dense_law_line  # noqa: E402
from timing import c_driver, c_interleaved  # noqa: E402
from coordarm.simulation.run import DEFAULT_CHUNK, chunk_function, simulate  # noqa: E402
from coordarm.simulation.scenario import load_scenario  # noqa: E402
from coordarm.symbolic import BuildError, CoordinatingController, Line, PlanarChain  # noqa: E402
from coordarm.generated import compile as compile_controller  # noqa: E402
from coordarm.symbolic.integrator import rk4  # noqa: E402

SIZES = (8, 64, 256, 1024)
DENSE_LIMIT_SECONDS = 60.0


def time_from_c(driver: Path, comp, q: np.ndarray, reps: int, t: float = 1.0) -> tuple[float, float]:
    """Median ns per ``coordarm_law`` and per ``coordarm_rk4`` call, timed in C (``reps`` rounds)."""
    law, rk4 = c_interleaved([comp.library.path], q, rounds=max(3, reps), batch_ms=2.0, t=t)
    return float(np.median(law)), float(np.median(rk4))


def median_time(fn, target: float = 0.001, repeat: int = 61) -> float:
    """Median seconds per call of ``fn`` over ``repeat`` batches of about ``target`` seconds each."""
    fn()
    start = time.perf_counter()
    fn()
    once = max(time.perf_counter() - start, 1e-7)
    number = max(1, int(target / once))
    samples = []
    for _ in range(repeat):
        start = time.perf_counter()
        for _ in range(number):
            fn()
        samples.append((time.perf_counter() - start) / number)
    return statistics.median(samples)


def paired_ratio(slow, fast, pairs: int = 31) -> float:
    """Median over interleaved pairs of ``time(slow) / time(fast)``: both see the same machine load."""
    def once(fn, number):
        start = time.perf_counter()
        for _ in range(number):
            fn()
        return (time.perf_counter() - start) / number
    n_slow = max(1, int(0.001 / once(slow, 1)))
    n_fast = max(1, int(0.001 / once(fast, 1)))
    return statistics.median(once(slow, n_slow) / once(fast, n_fast) for _ in range(pairs))


def line_controller(m: int, law: str = "structured") -> CoordinatingController:
    """The benchmark case: m links of 0.1 m, line through the base swinging as 0.6 sin(0.2 t)."""
    return CoordinatingController(PlanarChain(m, 0.1), Line(angle=lambda t: 0.6 * ca.sin(0.2 * t)), 2.0, 0.1,
                                  law=law)


def numpy_law(q: np.ndarray, t: float) -> np.ndarray:
    """:func:`dense_law_line` for the benchmark line at time ``t``."""
    return dense_law_line(q, 0.1, 2.0, 0.1, 0.6 * np.sin(0.2 * t), 0.12 * np.cos(0.2 * t))


def numpy_rk4(q: np.ndarray, t: float, h: float) -> np.ndarray:
    """One RK4 step of the numpy law."""
    return rk4(numpy_law, q, t, h)


def cold_build(ctrl: CoordinatingController, form: str, timeout: float | None = None) -> float:
    """Seconds to generate and compile ``ctrl``'s library into an empty cache directory."""
    with tempfile.TemporaryDirectory() as tmp:
        start = time.perf_counter()
        build(generate_source(ctrl, form), build_dir=tmp, timeout=timeout)
        return time.perf_counter() - start


def machine() -> list[str]:
    """Lines describing the machine, the tool versions and the current load."""
    lines = []
    try:
        info = subprocess.run(["lscpu"], capture_output=True, text=True).stdout
        for key in ("Model name", "CPU(s)", "Thread(s) per core", "L2 cache", "L3 cache"):
            for line in info.splitlines():
                if line.startswith(key + ":"):
                    lines.append(f"* {key}: {line.split(':', 1)[1].strip()}")
    except OSError:
        lines.append(f"* CPU: {platform.processor()}")
    cc = find_compiler()
    version = subprocess.run([cc, "--version"], capture_output=True, text=True).stdout.splitlines()[0]
    lines += [f"* compiler: {version}", f"* casadi {ca.__version__}, numpy {np.__version__}, "
              f"Python {platform.python_version()}, {platform.system()} {platform.release()}",
              f"* load average at start: {os.getloadavg()[0]:.2f} (machine shared with other jobs)"]
    return lines


def main() -> None:
    """Run every benchmark and print the Markdown report."""
    ap = argparse.ArgumentParser(description="coordarm speed benchmarks")
    ap.add_argument("--quick", action="store_true", help="fewer repeats, no dense build above m = 8")
    ap.add_argument("--out", type=Path, help="also write the report to this file")
    args = ap.parse_args()
    reps = 5 if args.quick else 41
    report = ["# coordarm benchmark run", "", f"{time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}", ""]
    report += machine() + [f"* numpy BLAS threads: OPENBLAS_NUM_THREADS={os.environ['OPENBLAS_NUM_THREADS']}", ""]
    driver = c_driver()
    rows, dense_stop = {}, None
    with tempfile.TemporaryDirectory() as cache:
        for m in SIZES:
            ctrl = line_controller(m)
            q, t, h = ctrl.chain.zigzag(1.0), 1.0, 1e-3
            r = rows[m] = {}
            r["build"] = statistics.median(cold_build(ctrl, "structured") for _ in range(1 if args.quick else 3))
            comp = compile_controller(ctrl, build_dir=cache)
            r["c_law"], r["c_rk4"] = (v / 1e3 for v in time_from_c(driver, comp, q, reps))
            r["py_law"] = median_time(lambda: comp.control(q, t), repeat=reps) * 1e6
            times = t + h * np.arange(1000)
            r["py_step"] = median_time(lambda: comp.chunk(q, times, h), repeat=max(3, reps // 3)) / 1000 * 1e6
            law = ctrl.fast_law()
            r["interp_law"] = median_time(lambda: law(q, t), repeat=reps) * 1e6
            n_int = 20
            chunk = chunk_function(ctrl, h, n_int)
            times_i = t + h * np.arange(n_int)
            r["interp_step"] = median_time(lambda: chunk(q, times_i), repeat=max(3, reps // 3)) / n_int * 1e6
            r["np_law"] = median_time(lambda: numpy_law(q, t), repeat=reps) * 1e6
            r["np_step"] = median_time(lambda: numpy_rk4(q, t, h), repeat=max(3, reps // 3)) * 1e6
            r["np_ratio"] = paired_ratio(lambda: numpy_law(q, t), lambda: comp.control(q, t),
                                         pairs=5 if args.quick else 31)
            if dense_stop is None and not (args.quick and m > 8):
                dctrl = line_controller(m, "dense")
                try:
                    r["dense_build"] = cold_build(dctrl, "dense", timeout=DENSE_LIMIT_SECONDS)
                    dcomp = compile_controller(dctrl, build_dir=cache)
                    r["dense_c_law"], r["dense_c_rk4"] = (v / 1e3 for v in time_from_c(driver, dcomp, q, reps))
                    r["dense_py_law"] = median_time(lambda: dcomp.control(q, t), repeat=reps) * 1e6
                except BuildError as exc:
                    dense_stop = (m, str(exc).splitlines()[0])
            print(f"m = {m} done", file=sys.stderr)

        scenario = load_scenario("line").with_overrides(64, 30.0, 0.001)
        ctrl = scenario.controller()
        q0 = scenario.start(ctrl)
        simulate(ctrl, q0, 0.01, backend="compiled")          # build outside the timing
        walls = []
        for _ in range(1 if args.quick else 3):
            start = time.perf_counter()
            run = simulate(ctrl, q0, 30.0, 0.001, backend="compiled", progress=False)
            walls.append(time.perf_counter() - start)
        long_run = statistics.median(walls)

    def cell(r, key, fmt="{:.2f}"):
        return fmt.format(r[key]) if key in r else "—"

    report += ["## One control-law evaluation [µs] (median)", "",
               "| m | compiled, from C | compiled, from Python `control()` | compiled dense, from C | "
               "compiled dense, from Python | interpreted CasADi | numpy dense | numpy / compiled (Python) | "
               "same, interleaved pairs | interpreted / compiled (Python) |",
               "|---|---|---|---|---|---|---|---|---|---|"]
    for m, r in rows.items():
        report.append(f"| {m} | {r['c_law']:.3f} | {r['py_law']:.2f} | {cell(r, 'dense_c_law')} | "
                      f"{cell(r, 'dense_py_law')} | {r['interp_law']:.1f} | {r['np_law']:.1f} | "
                      f"{r['np_law'] / r['py_law']:.0f}× | {r['np_ratio']:.0f}× | {r['interp_law'] / r['py_law']:.0f}× |")
    report += ["", "## One closed-loop RK4 step [µs] (median)", "",
               "| m | compiled, from C | compiled, per step of a 1000-step `chunk()` from Python | "
               "compiled dense, from C | interpreted CasADi (chunk of 20) | numpy dense | numpy / compiled chunk |",
               "|---|---|---|---|---|---|---|"]
    for m, r in rows.items():
        report.append(f"| {m} | {r['c_rk4']:.3f} | {r['py_step']:.2f} | {cell(r, 'dense_c_rk4')} | "
                      f"{r['interp_step']:.1f} | {r['np_step']:.1f} | {r['np_step'] / r['py_step']:.0f}× |")
    report += ["", "## Cold generate + compile [s]", "", "| m | structured | dense |", "|---|---|---|"]
    for m, r in rows.items():
        report.append(f"| {m} | {r['build']:.2f} | {cell(r, 'dense_build')} |")
    if dense_stop:
        report += ["", f"Compiled dense stops at m = {dense_stop[0]}: {dense_stop[1]}"]
    lin = rows[1024]["c_law"] / rows[64]["c_law"]
    report += ["", "## Scale and the long run", "",
               f"* compiled law from C: m = 1024 costs {lin:.1f}× m = 64 "
               f"({1e3 * rows[64]['c_law'] / 64:.1f} and {1e3 * rows[1024]['c_law'] / 1024:.1f} ns per link)",
               f"* 64-link line, 30 s at 1 ms (30,000 RK4 steps, chunks of {DEFAULT_CHUNK} through Python): "
               f"{long_run:.3f} s wall (median of {len(walls)}; stopped: {run.info['stopped']})",
               f"* load average at end: {os.getloadavg()[0]:.2f}"]
    text = "\n".join(report) + "\n"
    print(text)
    if args.out:
        args.out.write_text(text)


if __name__ == "__main__":
    main()
