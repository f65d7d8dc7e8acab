"""The C kernels of the physical checks and of the scene's JSON against their numpy references, in one run.

64 links, 30 s of the ``line`` preset, interleaved rounds in one process: the bare simulation; the checked
run (physical checks at 200 Hz, as ``coordarm run`` checks a full-rate log); the 100 Hz and the full-rate
log (threaded writer, checks as the command makes them), each with the kernels
(:mod:`coordarm.generated.kernels`) and with the numpy references (the kernels switched off: the code
before issue 24's simulation-loop round); and ``coordarm run line --duration 30 --no-figures`` in a new
process, both ways. Prints per variant the median wall time, the median per-round ratios to the bare
simulation and to the checked run of the same kind, and the median CPU time (all threads). Also checks
that both ways write the same log records. Run: ``python benchmarks/check_kernels.py [--rounds 5]``;
results in RESULTS.md (issue 24, "The simulation loop's own time").
"""
import argparse
import hashlib
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

import numpy as np  # noqa: E402

import coordarm.generated.chain_geometry as chain_geometry  # noqa: E402
import coordarm.simulation.json_fill as json_fill  # noqa: E402
from coordarm.simulation.mcap_writer import RunLogger  # noqa: E402
from coordarm.simulation.run import CHECK_RATE, simulate  # noqa: E402
from coordarm.simulation.scenario import load_scenario  # noqa: E402

ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
ap.add_argument("--rounds", type=int, default=5)
rounds = ap.parse_args().rounds
TMP = Path(tempfile.mkdtemp())
sc = load_scenario("line").with_overrides(64, 30.0, None)
ctrl = sc.controller()
q0 = sc.start(ctrl)
KERNELS = {"geometry_library": chain_geometry.geometry_library, "digits_kernel": json_fill.digits_kernel}
#: The child process of the command, with the kernels switched off when asked.
CHILD = ("import sys, coordarm.generated.chain_geometry as g, coordarm.simulation.json_fill as j\n"
         "if sys.argv.pop(1) == 'numpy':\n    g.geometry_library = j.digits_kernel = lambda: None\n"
         "from coordarm.cli import main\nsys.exit(main(sys.argv[1:]))")


def use(kind: str) -> None:
    """Switch the kernels on (``"C"``) or off (``"numpy"``)."""
    chain_geometry.geometry_library = KERNELS["geometry_library"] if kind == "C" else (lambda: None)
    json_fill.digits_kernel = KERNELS["digits_kernel"] if kind == "C" else (lambda: None)


def checked():
    simulate(ctrl, q0, sc.duration, sc.step, sc.t0, backend="compiled", progress=False, thresholds=sc.thresholds,
             physical=sc.physical(ctrl.chain), check_every=round(1.0 / (CHECK_RATE * sc.step)))


def logged(rate, out=TMP / "l.mcap"):
    with RunLogger(out, sc, ctrl, log_rate=rate, command=["bench"], threaded=True) as log:
        simulate(ctrl, q0, sc.duration, sc.step, sc.t0, backend="compiled", progress=False, thresholds=sc.thresholds,
                 physical=sc.physical(ctrl.chain), check_every=max(log.every, round(1.0 / (CHECK_RATE * sc.step))),
                 on_chunk=log.on_chunk)


def command(kind):
    subprocess.run([sys.executable, "-c", CHILD, kind, "run", "line", "--duration", "30", "--no-figures", "--quiet",
                    "--overwrite", "--out", str(TMP / "c.mcap")], check=True, stdout=subprocess.DEVNULL)


def records(path: Path) -> str:
    """SHA-256 of every message of a log (channel, log time, data), in file order, and its outcome."""
    from mcap.reader import make_reader
    digest = hashlib.sha256()
    with open(path, "rb") as f:
        reader = make_reader(f)
        for _, channel, message in reader.iter_messages(log_time_order=False):
            digest.update(f"{channel.topic} {message.log_time} {message.sequence}".encode() + message.data)
        for meta in reader.iter_metadata():
            if meta.name == "outcome":
                digest.update(repr(sorted(meta.metadata.items())).encode())
    return digest.hexdigest()


simulate(ctrl, q0, 0.1, sc.step, backend="compiled", progress=False)
same = {}
for rate in (None, 100.0):
    for kind in ("numpy", "C"):
        use(kind)
        logged(rate, TMP / f"{kind}.mcap")
    same[rate] = records(TMP / "numpy.mcap") == records(TMP / "C.mcap")
V = {"bare simulation": lambda: simulate(ctrl, q0, sc.duration, sc.step, backend="compiled", progress=False)}
for kind in ("numpy", "C"):
    V.update({f"checked, 200 Hz ({kind})": (kind, checked), f"100 Hz log ({kind})": (kind, lambda: logged(100.0)),
              f"full-rate log ({kind})": (kind, lambda: logged(None)),
              f"coordarm run --no-figures ({kind})": (kind, lambda k=kind: command(k))})
for kind in ("numpy", "C"):
    command(kind)                                        # the libraries built and cached
T = {k: [] for k in V}
C = {k: [] for k in V}
load = [os.getloadavg()[0]]
for r in range(rounds):
    for k, f in V.items():
        if isinstance(f, tuple):
            use(f[0])
            f = f[1]
        t, c = time.perf_counter(), time.process_time()
        f()
        T[k].append(time.perf_counter() - t)
        C[k].append(time.process_time() - c)
    load.append(os.getloadavg()[0])
use("C")
bare = np.array(T["bare simulation"])
print(f"load average (1 min) during the rounds: {min(load):.2f}-{max(load):.2f}; {rounds} rounds")
print(f"same log records and outcome with the kernels and with numpy: full rate {same[None]}, 100 Hz {same[100.0]}")
print("| variant | median [s] | / bare (per round, min–max) | / checked run of the same kind | C / numpy (per round) "
      "| CPU [s] | CPU / checked CPU |")
print("|---|---|---|---|---|---|---|")
for k, v in T.items():
    v = np.array(v)
    kind = k[k.rfind("(") + 1:-1] if "(" in k else None
    ref = np.array(T[f"checked, 200 Hz ({kind})"]) if kind else None
    vs_checked = (f"{np.median(v / ref):.2f}× ({np.min(v / ref):.2f}–{np.max(v / ref):.2f})"
                  if kind and "command" not in k and "coordarm" not in k else "")
    cpu = "" if "coordarm" in k else f"{np.median(C[k]):.3f}"
    cpu_ratio = (f"{np.median(C[k]) / np.median(C[f'checked, 200 Hz ({kind})']):.2f}×"
                 if kind and "coordarm" not in k else "")
    twin = np.array(T[k.replace("(C)", "(numpy)")]) if kind == "C" else None
    vs_numpy = f"{np.median(v / twin):.2f}× ({np.min(v / twin):.2f}–{np.max(v / twin):.2f})" if kind == "C" else ""
    print(f"| {k} | {np.median(v):.3f} | {np.median(v / bare):.2f}× ({np.min(v / bare):.2f}–{np.max(v / bare):.2f}) | "
          f"{vs_checked} | {vs_numpy} | {cpu} | {cpu_ratio} |")
