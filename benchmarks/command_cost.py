"""Where the time of ``coordarm run line --links 64 --duration 30`` goes, in one benchmark run.

Each round, interleaved: a bare interpreter (``python -c pass``), fresh interpreters that only
import numpy, CasADi, matplotlib.pyplot (Agg) and the modules ``coordarm run`` loads, the bare
simulation (in this process, compiled, library cached), and the command itself with and without
figures in a new process, instrumented from inside: it reports the wall time of the import of
its modules, building the controller, loading the compiled law from the cache, the simulation
with the log (the writer threads overlap it), closing the log, and each figure. Medians over the
rounds; the command's wall time is measured from outside (interpreter start included).

Run: ``python benchmarks/command_cost.py [--rounds 5]``; :func:`decomposition` is what
``benchmarks/performance.py`` records in ``RESULTS.md``.
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent

#: Runs inside the command's process: wraps the phases with timers, runs the CLI, writes the timings.
PROBE = r"""
import json, sys, time
T = {}
def timed(module, name, label):
    f = getattr(module, name)
    def g(*a, **k):
        t = time.perf_counter()
        try:
            return f(*a, **k)
        finally:
            T[label] = T.get(label, 0.0) + time.perf_counter() - t
    setattr(module, name, g)
t = time.perf_counter()
import coordarm.cli, coordarm.commands.run
from coordarm.simulation import mcap_writer, run as run_mod, scenario as sc_mod
T["import coordarm, numpy, CasADi (simulation, log)"] = time.perf_counter() - t
timed(sc_mod.Scenario, "controller", "build the controller")
timed(run_mod, "select_backend", "load the compiled law (cache)")
timed(run_mod, "simulate", "simulate + log (writer threads overlapping)")
timed(mcap_writer.RunLogger, "finish", "close the log (wait for the writer)")
if "--no-figures" not in sys.argv:
    t = time.perf_counter()
    from coordarm.simulation import figures
    T["import matplotlib (figures)"] = time.perf_counter() - t
    timed(figures, "plot_stages", "figure: stages")
    timed(figures, "plot_tracking", "figure: tracking")
    from coordarm.simulation import figure_files
    timed(figure_files, "write_figures", "figures (total)")
t = time.perf_counter()
code = coordarm.cli.main(sys.argv[2:])
T["command inside the process"] = time.perf_counter() - t
with open(sys.argv[1], "w") as f:
    json.dump(T, f)
sys.exit(code)
"""


def fresh(code: str) -> float:
    """Wall time of a new interpreter running ``code`` [s]."""
    start = time.perf_counter()
    subprocess.run([sys.executable, "-c", code], check=True, capture_output=True)
    return time.perf_counter() - start


def command(tmp: Path, *extra: str) -> tuple[float, dict[str, float]]:
    """The instrumented command: its wall time from outside [s] and its phases [s]."""
    report = tmp / "phases.json"
    args = ["run", "line", "--links", "64", "--duration", "30", "--quiet", "--overwrite", "--out",
            str(tmp / "c.mcap"), *extra]
    for png in tmp.glob("*.png"):
        png.unlink()
    (tmp / "c.mcap").unlink(missing_ok=True)
    start = time.perf_counter()
    subprocess.run([sys.executable, "-c", PROBE, str(report), *args], check=True, capture_output=True,
                   env=dict(os.environ, MPLBACKEND="Agg"))
    wall = time.perf_counter() - start
    return wall, json.loads(report.read_text())


def decomposition(rounds: int = 5) -> list[str]:
    """Markdown lines: the decomposition table (medians of ``rounds`` interleaved rounds)."""
    sys.path.insert(0, str(ROOT))
    from coordarm.simulation.run import CHECK_RATE, select_backend, simulate
    from coordarm.simulation.scenario import load_scenario
    scenario = load_scenario("line").with_overrides(64, 30.0, None)
    ctrl = scenario.controller()
    q0 = scenario.start(ctrl)
    select_backend(ctrl, "compiled")
    tmp = Path(tempfile.mkdtemp(prefix="coordarm-cmd-"))
    command(tmp)                                            # the cache holds the library from here on
    rows: dict[str, list[float]] = {}
    load = [os.getloadavg()[0]]

    def add(label: str, value: float) -> None:
        rows.setdefault(label, []).append(value)

    for _ in range(rounds):
        add("interpreter start (`python -c pass`)", fresh("pass"))
        add("new interpreter + `import numpy`", fresh("import numpy"))
        add("new interpreter + `import casadi`", fresh("import casadi"))
        add("new interpreter + `import matplotlib.pyplot` (Agg)",
            fresh("import matplotlib; matplotlib.use('Agg'); import matplotlib.pyplot"))
        start = time.perf_counter()
        simulate(ctrl, q0, scenario.duration, scenario.step, scenario.t0, backend="compiled", progress=False)
        add("bare simulation (this process)", time.perf_counter() - start)
        start = time.perf_counter()
        simulate(ctrl, q0, scenario.duration, scenario.step, scenario.t0, backend="compiled", progress=False,
                 physical=scenario.physical(ctrl.chain), check_every=round(1.0 / (CHECK_RATE * scenario.step)))
        add("bare simulation with the physical checks `coordarm run` makes (200 Hz)", time.perf_counter() - start)
        for label, extra in (("--no-figures", ("--no-figures",)), ("with figures", ())):
            wall, phases = command(tmp, *extra)
            add(f"`coordarm run` {label}: wall time (new process)", wall)
            for key, value in phases.items():
                add(f"`coordarm run` {label}: {key}", value)
        load.append(os.getloadavg()[0])
    bare = float(np.median(rows["bare simulation (this process)"]))
    out = ["| | median [s] | / bare simulation |", "|---|---|---|"]
    for label, values in rows.items():
        med = float(np.median(values))
        out.append(f"| {label} | {med:.3f} | {med / bare:.2f}× |")
    out += ["", f"{rounds} interleaved rounds; load average {min(load):.2f}–{max(load):.2f}."]
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rounds", type=int, default=5)
    print("\n".join(decomposition(ap.parse_args().rounds)))


if __name__ == "__main__":
    main()
