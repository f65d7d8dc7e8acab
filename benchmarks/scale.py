"""Issue 24: every size, the cost of the command, the exported law and its real-time loop, in one run.

Run: ``python benchmarks/scale.py [--rounds 5] [--no-write] [--parts links,command,export,rt]
[--label TEXT] [--also-python PATH --also-label TEXT]``. It
writes the section between the ``scale.py`` markers of ``benchmarks/RESULTS.md`` and every raw number
into ``benchmarks/scale.json``. Every comparison is interleaved in rounds inside this process (each
variant once per round, so all see the same machine load); ratios are medians of per-round ratios
(min-max). Child processes run with bytecode caching on (``PYTHONDONTWRITEBYTECODE`` removed), as in
a normal installation. Each timed item starts once the page cache holds nothing unwritten (:func:`settled`).

* **links**: ``coordarm run line --links m --duration 1 --no-figures`` (new process, library cached)
  at m = 16 .. 16384: wall time, peak memory (``wait4``) against :func:`~coordarm.simulation.limits.estimate`,
  the bare simulation (in this process, unlogged) and both exponents; the 1024 / 4096 cost ratio
  with the default (estimated) ``cond`` and with ``--cond-rate 0``.
* **command**: 64 links, 30 s: the bare simulation, the same with the threaded full-rate log and
  with a 100 Hz log (as ``coordarm run`` writes them, physical checks included), and the command with
  ``--no-figures`` and with figures (new process). With ``--also-python PATH`` (an interpreter with
  coordarm and its dependencies installed, e.g. a venv of the distribution's Python: ``/usr/bin/python3
  -m venv /tmp/v && /tmp/v/bin/pip install -c constraints.txt -e .``) each round also times the bare
  simulation (in a process of that interpreter) and the ``--no-figures`` command under it: the command's
  cost depends on how the interpreter was built (profile-guided and link-time optimised or not).
* **export**: ``coordarm export line`` at m = 64 and 1024, the law per call from a C driver linked
  with the static library (the Makefile's flags), the shared library (``-fvisibility=hidden``), a
  plain ``-fPIC -shared`` build and a static build in ISO ``-std=c99``.
* **rt**: ``./example_rt 2000 1000`` at m = 64, 256, 1024, 4096 with and without real-time priority.
"""
from __future__ import annotations

import argparse
import json
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

from coordarm.simulation.limits import estimate  # noqa: E402
from coordarm.simulation.scenario import load_scenario  # noqa: E402
from run_benchmarks import machine  # noqa: E402
from timing import fmt_ratio  # noqa: E402

SIZES = (16, 64, 256, 1024, 4096, 16384)
RT_SIZES = (64, 256, 1024, 4096)
START, END = "<!-- scale.py: start -->", "<!-- scale.py: end -->"
README_START, README_END = "<!-- speed: start (written by benchmarks/scale.py) -->", "<!-- speed: end -->"
DOCS_START, DOCS_END = "<!-- targets: start (written by benchmarks/scale.py) -->", "<!-- targets: end -->"
DOCS_PAGE = HERE.parent / "docs" / "guide" / "performance.md"
ENV = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}
COORDARM = [sys.executable, "-m", "coordarm"]

DRIVER = r"""
#include <stdio.h>
#include <stdlib.h>
#include <time.h>
#include "coordarm_law.h"
static double now(void) { struct timespec t; clock_gettime(CLOCK_MONOTONIC, &t); return t.tv_sec + 1e-9 * t.tv_nsec; }
int main(int argc, char** argv) {
  long n_q, n_u, n_out, n_work, j, k, b, calls = atol(argv[1]);
  double *q, *u, *o, *w, best = 1e30, sink = 0;
  coordarm_law_sizes(&n_q, &n_u, &n_out, &n_work);
  q = calloc(n_q, sizeof *q); u = calloc(n_u, sizeof *u); o = calloc(n_out, sizeof *o); w = calloc(n_work, sizeof *w);
  for (j = 0; j < n_q; ++j) q[j] = j == 0 ? 1.0 : (j % 2 ? -2.0 : 2.0);   /* zig-zag, beta = 1 */
  for (b = 0; b < 7; ++b) {                                             /* fastest of 7 batches */
    double t = now();
    for (k = 0; k < calls; ++k) { coordarm_law(q, 1e-3 * k, u, o, w); sink += u[0]; }
    t = (now() - t) / calls;
    if (t < best) best = t;
  }
  printf("%.6g %g\n", best * 1e9, sink);
  return 0;
}
"""


def exponent(ms, times) -> float:
    """Least-squares slope of log(time) against log(m)."""
    return float(np.polyfit(np.log(ms), np.log(times), 1)[0])


def settled() -> None:
    """Write out what earlier measurements left to the disk (``os.sync``, untimed) before the next one.

    A log is written to the page cache; the kernel writes it out later, on any core. Without this,
    the write-out of one measurement's 38 MB log lands in whichever measurement follows it (seen: the
    bare simulation right after the figures command took 0.176 s instead of 0.14 s)."""
    os.sync()


def child(argv: list[str]) -> tuple[float, int]:
    """Wall time [s] and peak resident memory [bytes] of a child process (fails loudly).

    The memory comes from ``/usr/bin/time -f %M``: a child forked from this (large) process would
    report this process's high-water mark as its own (Linux keeps it across exec). Starts
    :func:`settled`."""
    settled()
    start = time.perf_counter()
    proc = subprocess.run(["/usr/bin/time", "-f", "%M", *argv], env=ENV, stdout=subprocess.DEVNULL,
                          stderr=subprocess.PIPE, text=True)
    wall = time.perf_counter() - start
    if proc.returncode:
        raise RuntimeError(f"{' '.join(argv)}: exit {proc.returncode}: {proc.stderr[-400:]}")
    return wall, int(proc.stderr.split()[-1]) * 1024


def run_argv(tmp: Path, m: int, duration: float, *extra: str) -> list[str]:
    """The command as a user types it (summary on stdout, progress bar on stderr: not ``--quiet``), into
    ``tmp``, replacing the log of the round before."""
    return [*COORDARM, "run", "line", "--links", str(m), "--duration", str(duration), "--overwrite",
            "--out", str(tmp / f"r{m}.mcap"), *extra]


def bare_seconds(m: int, duration: float) -> float:
    """The bare simulation (compiled, unlogged, no physical checks) of the ``line`` preset [s]: the faster
    of two runs in a row.

    One run alone came out slower than the checked run (the bare one plus the checks) in 7 of 9 rounds
    at 09:42 UTC on 2026-11-26 (0.176 s against 0.162 s): the bare simulation is the denominator of
    the command's ratio, and a slow outlier there flatters the command."""
    from coordarm.simulation.run import simulate
    sc = load_scenario("line").with_overrides(m, duration, None)
    ctrl = sc.controller()
    q0 = sc.start(ctrl)
    best = float("inf")
    for _ in range(2):
        settled()
        start = time.perf_counter()
        simulate(ctrl, q0, sc.duration, sc.step, sc.t0, backend="compiled", progress=False)
        best = min(best, time.perf_counter() - start)
    return best


def links_part(rounds: int, tmp: Path) -> dict:
    """CLI and bare 1 s runs at every size; cond's share at 1024 and 4096 links."""
    for m in SIZES:                                      # build and cache every library first
        child(run_argv(tmp, m, 0.01, "--no-figures"))
        bare_seconds(m, 0.01)
    wall = {str(m): [] for m in SIZES}
    rss = {str(m): [] for m in SIZES}
    bare = {str(m): [] for m in SIZES}
    cond = {key: [] for key in ("1024", "4096", "1024 off", "4096 off")}
    for r in range(rounds):
        for m in SIZES:
            w, mem = child(run_argv(tmp, m, 1.0, "--no-figures"))
            wall[str(m)].append(w)
            rss[str(m)].append(mem)
            bare[str(m)].append(bare_seconds(m, 1.0))
        for m in (1024, 4096):
            cond[f"{m}"].append(wall[str(m)][-1])
            cond[f"{m} off"].append(child(run_argv(tmp, m, 1.0, "--no-figures", "--cond-rate", "0"))[0])
    est = {str(m): estimate(m, 1e-3, 1.0).memory_bytes for m in SIZES}
    return {"wall": wall, "rss": rss, "bare": bare, "cond": cond, "estimate_bytes": est}


def other_bare_seconds(python: str) -> float:
    """:func:`bare_seconds` (64 links, 30 s) in a new process of the interpreter ``python`` [s]."""
    out = subprocess.run([python, str(Path(__file__).resolve()), "--bare-only"], env=ENV, check=True,
                         capture_output=True, text=True).stdout
    return float(out.split()[-1])


def command_part(rounds: int, tmp: Path, also: str | None = None) -> dict:
    """64 links, 30 s: bare, logged at full rate and at 100 Hz (as the command logs), the command (and,
    with ``also``, the bare simulation and the ``--no-figures`` command under that interpreter)."""
    from coordarm.simulation.mcap_writer import RunLogger
    from coordarm.simulation.run import check_stride, simulate
    sc = load_scenario("line").with_overrides(64, 30.0, None)
    ctrl = sc.controller()
    q0 = sc.start(ctrl)

    def logged(rate):
        with RunLogger(tmp / "l.mcap", sc, ctrl, log_rate=rate, command=["bench"], threaded=True) as log:
            every = check_stride(sc.step)           # as coordarm run checks, whatever the log's rate
            simulate(ctrl, q0, sc.duration, sc.step, sc.t0, backend="compiled", progress=False,
                     thresholds=sc.thresholds, physical=sc.physical(ctrl.chain), check_every=every,
                     on_chunk=log.on_chunk)

    child(run_argv(tmp, 64, 30.0, "--no-figures"))
    keys = ("bare", "checked", "full-rate log", "100 Hz log", "--no-figures", "figures")
    out = {k: [] for k in keys + (("other bare", "other --no-figures") if also else ())}
    if also:
        child([also, *run_argv(tmp, 64, 30.0, "--no-figures")[1:]])     # its bytecode cached, as for this one
    for _ in range(rounds):
        out["bare"].append(bare_seconds(64, 30.0))
        settled()
        start = time.perf_counter()
        simulate(ctrl, q0, sc.duration, sc.step, sc.t0, backend="compiled", progress=False, thresholds=sc.thresholds,
                 physical=sc.physical(ctrl.chain), check_every=check_stride(sc.step))
        out["checked"].append(time.perf_counter() - start)
        for key, rate in (("full-rate log", None), ("100 Hz log", 100.0)):
            settled()
            start = time.perf_counter()
            logged(rate)
            out[key].append(time.perf_counter() - start)
        out["--no-figures"].append(child(run_argv(tmp, 64, 30.0, "--no-figures"))[0])
        out["figures"].append(child([*run_argv(tmp, 64, 30.0)])[0])
        if also:
            out["other bare"].append(other_bare_seconds(also))
            out["other --no-figures"].append(child([also, *run_argv(tmp, 64, 30.0, "--no-figures")[1:]])[0])
    return out


def export_part(rounds: int, tmp: Path) -> dict:
    """Law per call [ns] of the exported law: static, shared hidden, shared plain, ISO c99."""
    res = {}
    for m in (64, 1024):
        d = tmp / f"export{m}"
        subprocess.run([*COORDARM, "export", "line", "--links", str(m), "--out", str(d)], check=True,
                       capture_output=True, env=ENV)
        subprocess.run(["make", "-C", str(d), "libcoordarm_law.a", "libcoordarm_law.so"], check=True,
                       capture_output=True)
        make = (d / "Makefile").read_text()
        flags = re.search(r"^CFLAGS \?= (.*)$", make, re.M).group(1).split()
        (d / "driver.c").write_text(DRIVER)
        cc = ["cc", "-std=gnu99", *flags, f"-I{d}"]
        subprocess.run([*cc, "-fPIC", "-shared", "-o", str(d / "libplain.so"), str(d / "coordarm_law.c"), "-lm"],
                       check=True)
        subprocess.run(["cc", "-std=c99", *flags, "-c", "-o", str(d / "iso.o"), str(d / "coordarm_law.c")], check=True)
        variants = {"static (Makefile flags)": [str(d / "libcoordarm_law.a")],
                    "shared, -fvisibility=hidden (Makefile)": [str(d / "libcoordarm_law.so"), f"-Wl,-rpath,{d}"],
                    "shared, plain -fPIC -shared": [str(d / "libplain.so"), f"-Wl,-rpath,{d}"],
                    "static, ISO -std=c99 (no contraction)": [str(d / "iso.o")]}
        exes = {}
        for i, (name, libs) in enumerate(variants.items()):
            exe = d / f"drv{i}"
            subprocess.run([*cc, "-o", str(exe), str(d / "driver.c"), *libs, "-lm"], check=True)
            exes[name] = exe
        calls = str(max(200, 400_000 // m))
        times = {name: [] for name in exes}
        for _ in range(rounds):
            for name, exe in exes.items():
                times[name].append(float(subprocess.run([str(exe), calls], capture_output=True, text=True,
                                                        check=True).stdout.split()[0]))
        res[str(m)] = times
    return res


def rt_part(tmp: Path) -> dict:
    """``example_rt 2000 1000`` at every size, with and without real-time priority."""
    res = {}
    for m in RT_SIZES:
        d = tmp / f"rt{m}"
        subprocess.run([*COORDARM, "export", "line", "--links", str(m), "--out", str(d)], check=True,
                       capture_output=True, env=ENV)
        subprocess.run(["make", "-C", str(d), "example_rt"], check=True, capture_output=True)
        for label, env in (("real-time", {}), ("normal", {"COORDARM_RT": "0"})):
            run = subprocess.run([str(d / "example_rt"), "2000", "1000"], capture_output=True, text=True,
                                 check=True, env={**ENV, **env})
            lines = run.stdout.splitlines()
            res[f"{m} {label}"] = {"head": lines[0], **{
                what: [float(v) for v in re.findall(r"(?:p50|p99|p99\.9|max) +([0-9.]+)", ln)]
                for ln in lines for what in ("law", "wake-up") if ln.startswith(what + " ")},
                "late": int(re.search(r"late cycles +(\d+)", run.stdout).group(1))}
    return res


def interpreter(python: str, label: str = "") -> dict[str, str]:
    """What an interpreter is: ``{"short": "Python 3.11.7, libpython shared", "long": ... its path too}``.

    ``label`` (how it was built, e.g. "Debian's, PGO + LTO") replaces the libpython note in ``short``."""
    version = subprocess.run([python, "-c", "import platform; print(platform.python_version())"],
                             capture_output=True, text=True, check=True).stdout.strip()
    linked = subprocess.run(["ldd", os.path.realpath(python)], capture_output=True, text=True).stdout
    lib = "libpython shared" if "libpython" in linked else "libpython linked in"
    return {"short": f"Python {version}, {label or lib}",
            "long": f"Python {version} ({python}; {lib}{'; ' + label if label else ''})"}


def link_medians(links: dict, key: str) -> dict[int, float]:
    """Median over rounds of one quantity of the links part (``"wall"``, ``"bare"`` or ``"rss"``) per link count."""
    return {int(m): float(np.median(v)) for m, v in links[key].items()}


def per_round(a: list[float], b: list[float]) -> str:
    r = np.asarray(a) / np.asarray(b)
    return fmt_ratio((float(np.median(r)), float(r.min()), float(r.max())))


def beyond_start(links: dict, m: str) -> np.ndarray:
    """Per round, the 1 s command at ``m`` links minus the 16-link one (the fixed start-up and close) [s]."""
    return np.asarray(links["wall"][m]) - np.asarray(links["wall"]["16"])


def report(data: dict, load: list[float], rounds: int) -> list[str]:
    when = data.get("when", {})
    out = [f"Report written {time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}; parts measured "
           + ", ".join(f"{k} at {v}" for k, v in when.items()) + "; machine:",
           *(line for line in machine() if "load average at start" not in line),
           f"* load average during the run: {min(load):.2f}–{max(load):.2f} (2 cores shared with "
           "other jobs; ratios are per round, so both sides of each saw the same load)",
           "* interleaved rounds: " + ", ".join(f"{k} {v}" for k, v in data.get("rounds", {}).items())
           + " (rt: one run of 2000 cycles per case); raw numbers in `benchmarks/scale.json`", ""]
    if "links" in data:
        d = data["links"]
        med = {k: link_medians(d, k) for k in ("wall", "bare", "rss")}
        out += ["### Link counts: `coordarm run line --links m --duration 1 --no-figures` (1000 RK4 steps)", "",
                "| m | " + " | ".join(str(m) for m in SIZES) + " |", "|---|" + "---|" * len(SIZES),
                "| command, new process [s] | " + " | ".join(f"{med['wall'][m]:.3g}" for m in SIZES) + " |",
                "| bare simulation (unlogged, in process, the faster of two runs) [s] | " + " | ".join(f"{med['bare'][m]:.3g}" for m in SIZES)
                + " |",
                "| peak memory of the command [MiB] | " + " | ".join(f"{med['rss'][m] / 2**20:.0f}" for m in SIZES) + " |",
                "| `estimate()` memory [MiB] | " + " | ".join(f"{d['estimate_bytes'][str(m)] / 2**20:.0f}" for m in SIZES)
                + " |", ""]
        ms = np.array(SIZES)
        big = ms >= 256
        out += [f"Exponent of the command's time from m = 16 to 16384: **{exponent(ms, [med['wall'][m] for m in ms]):.2f}**"
                f" (from m = 256: {exponent(ms[big], [med['wall'][m] for m in ms[big]]):.2f}); of the bare "
                f"simulation: {exponent(ms, [med['bare'][m] for m in ms]):.2f} (from 256: "
                f"{exponent(ms[big], [med['bare'][m] for m in ms[big]]):.2f}).", ""]
        c = d["cond"]
        out += [f"`cond` in the log (default above 256 links: the O(m) 1-norm estimate at 0.5 Hz): the 1024-link run costs "
                f"{per_round(c['1024'], c['4096'])} of the 4096-link one; with `--cond-rate 0` "
                f"{per_round(c['1024 off'], c['4096 off'])}; beyond the 16-link run's time (the fixed start-up "
                f"and close of the command) {per_round(beyond_start(d, '1024'), beyond_start(d, '4096'))}; the "
                f"estimate's share at 4096 links: {per_round(c['4096'], c['4096 off'])} of the run without it.", ""]
    if "command" in data:
        d = data["command"]
        out += ["### What the command costs (64 links, 30 s simulated, 30,000 RK4 steps)", "",
                "| | median [s] | / bare simulation (per round, min–max) | / checked run | target (issue 24) |",
                "|---|---|---|---|---|"]
        targets = {"full-rate log": "≤ 2.5× the checked run", "100 Hz log": "≤ 1.3× the checked run",
                   "--no-figures": "≤ 3× the bare simulation", "figures": ""}
        labels = {"bare": "bare simulation (compiled, unlogged, no checks; the faster of two runs in a row)",
                  "checked": "checked run: bare + the physical checks `coordarm run` makes (200 Hz), unlogged",
                  "full-rate log": "simulation + full-rate log (threaded writer) + physical checks at 200 Hz",
                  "100 Hz log": "simulation + 100 Hz log + physical checks at 200 Hz",
                  "--no-figures": "`coordarm run line --duration 30 --no-figures` (new process)",
                  "figures": "`coordarm run line --duration 30` with figures (new process)"}
        for key, label in labels.items():
            ratio = "1" if key == "bare" else per_round(d[key], d["bare"])
            checked = "" if key == "bare" else "1" if key == "checked" else per_round(d[key], d["checked"])
            out.append(f"| {label} | {np.median(d[key]):.3f} | {ratio} | {checked} | {targets.get(key, '')} |")
        runs = data["interpreters"]
        if "other bare" in d:
            other = runs["other"]["short"]
            out += [f"| bare simulation, in a process of {other} | {np.median(d['other bare']):.3f} | "
                    f"1 (its own) | | |",
                    f"| `coordarm run line --duration 30 --no-figures` under {other} (new process) | "
                    f"{np.median(d['other --no-figures']):.3f} | {per_round(d['other --no-figures'], d['other bare'])} "
                    f"(to its own bare simulation) | | ≤ 3× the bare simulation |"]
        out += ["", f"The rows above the last two: {runs['this']['long']}."
                + (f" The last two: {runs['other']['long']}." if "other bare" in d else "")]
        out.append("")
    if "export" in data:
        out += ["### The exported law: static, shared and ISO C builds (ns per call, C driver, fastest of 7 "
                "batches, zig-zag β = 1)", "", "| build | m = 64 [µs] | / static | m = 1024 [µs] | / static |",
                "|---|---|---|---|---|"]
        d = data["export"]
        for name in d["64"]:
            cells = []
            for m in ("64", "1024"):
                t = d[m][name]
                cells += [f"{np.median(t) / 1e3:.3g}", per_round(t, d[m]["static (Makefile flags)"])]
            out.append(f"| {name} | " + " | ".join(cells) + " |")
        out.append("")
    if "rt" in data:
        out += ["### `example_rt 2000 1000` (2000 cycles at 1 kHz) [µs]", "",
                "| m | scheduling | law p50 | p99 | p99.9 | max | wake-up p50 | p99 | p99.9 | max | late cycles |",
                "|---|---|---|---|---|---|---|---|---|---|---|"]
        for key, v in data["rt"].items():
            m, label = key.split()
            sched = re.search(r"; (SCHED[^;]*);", v["head"]).group(1)
            out.append(f"| {m} | {sched} | " + " | ".join(f"{x:.3g}" for x in v["law"]) + " | "
                       + " | ".join(f"{x:.3g}" for x in v["wake-up"]) + f" | {v['late']} |")
        out.append("")
    return out


def readme_block(data: dict) -> list[str]:
    """The README's speed lines, from the numbers of ``scale.json`` (the same medians as :func:`report`).

    Parameters
    ----------
    data : dict
        The contents of ``benchmarks/scale.json`` (every part measured).

    Returns
    -------
    list of str
        Markdown lines: the law, the command, the sizes and the real-time loop.
    """
    cpu = next((ln.split(": ", 1)[1] for ln in data.get("machine", []) if ln.startswith("* Model name")), "")
    loads = [x for v in data["loads"].values() for x in v]
    law = {m: np.median(data["export"][m]["static (Makefile flags)"]) / 1e3 for m in ("64", "1024")}
    cmd = data["command"]
    links = data["links"]
    ms = np.array(SIZES)
    wall = [link_medians(links, "wall")[m] for m in SIZES]
    rt = {m: data["rt"][f"{m} real-time"] for m in ("64", "1024")}
    return [f"Measured by `benchmarks/scale.py` ({data['when']['command']}, 2-vCPU {cpu or 'machine'} shared with "
            f"other jobs, load {min(loads):.1f}–{max(loads):.1f}; medians of interleaved rounds; all of it in "
            "`benchmarks/RESULTS.md`):", "",
            f"* **The law** (exported C, static build): {law['64']:.3g} µs per call at 64 links, "
            f"{law['1024']:.3g} µs at 1024.",
            f"* **A run** of 64 links for 30 s (30,000 RK4 steps): the bare simulation {np.median(cmd['bare']):.3g} s; "
            f"`coordarm run --no-figures` (start-up, physical checks, full-rate log) {per_round(cmd['--no-figures'], cmd['bare'])} "
            f"of it with {data['interpreters']['this']['short']}"
            + (f", {per_round(cmd['other --no-figures'], cmd['other bare'])} with {data['interpreters']['other']['short']}"
               if "other bare" in cmd else "") + f"; the 100 Hz log {per_round(cmd['100 Hz log'], cmd['checked'])} and the full-rate log "
            f"{per_round(cmd['full-rate log'], cmd['checked'])} the checked, unlogged run.",
            f"* **Any size**: a 1 s run of 16 to 16384 links takes {wall[0]:.3g} to {wall[-1]:.3g} s "
            f"(time ∝ m^{exponent(ms, wall):.2f}); 1024 links cost "
            f"{per_round(links['cond']['1024'], links['cond']['4096'])} of 4096 "
            f"({per_round(beyond_start(links, '1024'), beyond_start(links, '4096'))} beyond the fixed start-up).",
            f"* **Real time** (`example_rt`, 1 kHz, SCHED_FIFO): the law's p99 {rt['64']['law'][1]:.3g} µs at 64 "
            f"links, {rt['1024']['law'][1]:.3g} µs at 1024; wake-up p99 {rt['64']['wake-up'][1]:.3g} µs."]


def targets_block(data: dict) -> list[str]:
    """Issue 24's targets against the last run, for the performance page (the medians of :func:`report`).

    Parameters
    ----------
    data : dict
        The contents of ``benchmarks/scale.json`` (the links and command parts measured).

    Returns
    -------
    list of str
        A Markdown paragraph and table.
    """
    loads = [x for k in ("links", "command") for x in data["loads"].get(k, [])]
    cmd, links = data["command"], data["links"]
    ms = np.array(SIZES)
    wall = [link_medians(links, "wall")[m] for m in SIZES]
    bare = [link_medians(links, "bare")[m] for m in SIZES]
    big = ms >= 256
    c = links["cond"]
    return [f"The last run of `benchmarks/scale.py` (command part {data['when']['command']}, links part "
            f"{data['when']['links']}; load {min(loads):.1f}–{max(loads):.1f} on 2 cores; "
            f"interleaved rounds: command {data['rounds']['command']}, links {data['rounds']['links']}):", "",
            "| | measured | target (issue 24) |", "| --- | --- | --- |",
            f"| full-rate log / checked run | {per_round(cmd['full-rate log'], cmd['checked'])} | ≤ 2.5× |",
            f"| 100 Hz log / checked run | {per_round(cmd['100 Hz log'], cmd['checked'])} | ≤ 1.3× |",
            f"| `coordarm run --no-figures` / bare simulation ({data['interpreters']['this']['short']}) | "
            f"{per_round(cmd['--no-figures'], cmd['bare'])} | ≤ 3× |",
            *([f"| the same under {data['interpreters']['other']['short']} | "
               f"{per_round(cmd['other --no-figures'], cmd['other bare'])} | ≤ 3× |"] if "other bare" in cmd else []),
            f"| `coordarm run` with figures / bare simulation | {per_round(cmd['figures'], cmd['bare'])} | — |",
            f"| 1 s run: 1024 / 4096 links | {per_round(c['1024'], c['4096'])} | about 0.25× |",
            f"| the same, each beyond the 16-link run (the fixed start-up) | "
            f"{per_round(beyond_start(links, '1024'), beyond_start(links, '4096'))} | |",
            f"| 1 s run: 1024 / 4096 links, `--cond-rate 0` | {per_round(c['1024 off'], c['4096 off'])} | |",
            f"| `coordarm run line --links 16384 --duration 1 --no-figures` | {wall[-1]:.3g} s | < 60 s |",
            f"| exponent of a 1 s run's time, m = 16–16384 (256–16384): command | {exponent(ms, wall):.2f} "
            f"({exponent(ms[big], np.array(wall)[big]):.2f}) | ≤ 1.1 |",
            f"| the same, bare simulation | {exponent(ms, bare):.2f} ({exponent(ms[big], np.array(bare)[big]):.2f}) | |"]


def replace_block(path: Path, start: str, end: str, lines: list[str]) -> bool:
    """Replace the text between two marker lines of a file; False when the markers are missing."""
    text = path.read_text()
    if start not in text:
        return False
    block = "\n".join([start, *lines, end])
    path.write_text(re.sub(re.escape(start) + ".*?" + re.escape(end), lambda _: block, text, flags=re.S))
    return True


def write(lines: list[str], data: dict) -> None:
    """Write the report into RESULTS.md and the speed lines into the README."""
    path = HERE / "RESULTS.md"
    if not replace_block(path, START, END, lines):
        path.write_text(path.read_text().rstrip() + "\n\n## Every size, the command's cost, the export (issue 24; "
                        "`benchmarks/scale.py`)\n\n" + "\n".join([START, *lines, END]) + "\n")
    if all(part in data for part in ("links", "command", "export", "rt")):
        replace_block(HERE.parent / "README.md", README_START, README_END, readme_block(data))
        replace_block(DOCS_PAGE, DOCS_START, DOCS_END, targets_block(data))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--parts", default="links,command,export,rt",
                    help="comma-separated parts to measure; `none` rewrites the report from scale.json")
    ap.add_argument("--no-write", action="store_true")
    ap.add_argument("--label", default="", metavar="TEXT",
                    help="how this interpreter was built, for the report (e.g. \"pyenv's build, no PGO\")")
    ap.add_argument("--also-python", metavar="PATH",
                    help="command part: also time the bare simulation and the --no-figures command under this interpreter")
    ap.add_argument("--also-label", default="", metavar="TEXT",
                    help="how that interpreter was built, for the report (e.g. \"Debian's, PGO + LTO\")")
    ap.add_argument("--bare-only", action="store_true", help=argparse.SUPPRESS)   # other_bare_seconds' child
    args = ap.parse_args()
    if args.bare_only:
        print(bare_seconds(64, 30.0))
        return
    parts = args.parts.split(",")
    tmp = Path(tempfile.mkdtemp(prefix="coordarm-scale-"))
    load = [os.getloadavg()[0]]
    data: dict = {}
    stamps: dict[str, str] = {}
    started = time.perf_counter()
    for name, fn in (("links", lambda: links_part(args.rounds, tmp)), ("command", lambda: command_part(args.rounds, tmp, args.also_python)),
                     ("export", lambda: export_part(args.rounds, tmp)), ("rt", lambda: rt_part(tmp))):
        if name in parts:
            data[name] = fn()
            stamps[name] = time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime())
            load.append(os.getloadavg()[0])
            print(f"{name}: done after {time.perf_counter() - started:.0f} s", file=sys.stderr)
    saved = json.loads((HERE / "scale.json").read_text()) if (HERE / "scale.json").exists() else {}
    merged = {**saved, **data}        # parts not run this time keep their last numbers
    merged["rounds"] = {**saved.get("rounds", {}), **{name: args.rounds for name in data if name != "rt"}}
    loads = {**saved.get("loads", {}), **{name: load for name in data}}
    merged["when"] = {**saved.get("when", {}), **stamps}     # when each part finished
    if "command" in data:
        merged["interpreters"] = {"this": interpreter(sys.executable, args.label)}
        if args.also_python:
            merged["interpreters"]["other"] = interpreter(args.also_python, args.also_label)
    lines = report(merged, [x for v in loads.values() for x in v], args.rounds)
    print("\n".join(lines))
    if not args.no_write:
        merged["loads"] = loads
        merged["machine"] = [line for line in machine() if "load average at start" not in line]
        (HERE / "scale.json").write_text(json.dumps(merged, indent=1, default=str))
        write(lines, merged)


if __name__ == "__main__":
    main()
