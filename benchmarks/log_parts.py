"""What each part of a logged run costs (64 links, 30 s, in this process, interleaved rounds).

Variants: bare simulation; checked at 200 Hz and at 100 Hz (the physical checks ``coordarm run``
makes); logged at 100 Hz and at full rate (threaded writer, as the command), each with the scene
(20 Hz) and ``cond`` (5 Hz) and without them. Prints medians and per-round ratios to the bare and
to the checked (200 Hz) run. Run: ``python benchmarks/log_parts.py [--rounds 3]``; results in
RESULTS.md, issue 24 section.
"""
import argparse
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))
import tempfile
import time

import numpy as np

from coordarm.simulation.mcap_writer import RunLogger
from coordarm.simulation.run import CHECK_RATE, simulate
from coordarm.simulation.scenario import load_scenario
ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
ap.add_argument("--rounds", type=int, default=3)
rounds = ap.parse_args().rounds
OUT = Path(tempfile.mkdtemp()) / "parts.mcap"
sc = load_scenario("line").with_overrides(64, 30.0, None)
ctrl = sc.controller(); q0 = sc.start(ctrl)
simulate(ctrl, q0, 0.1, sc.step, backend="compiled", progress=False)
def checked(every):
    simulate(ctrl, q0, sc.duration, sc.step, sc.t0, backend="compiled", progress=False, thresholds=sc.thresholds,
             physical=sc.physical(ctrl.chain), check_every=every)
def logged(rate, **kw):
    with RunLogger(OUT, sc, ctrl, log_rate=rate, command=["b"], threaded=True, **kw) as log:
        simulate(ctrl, q0, sc.duration, sc.step, sc.t0, backend="compiled", progress=False, thresholds=sc.thresholds,
                 physical=sc.physical(ctrl.chain), check_every=max(log.every, 5), on_chunk=log.on_chunk)
V = {"bare": lambda: simulate(ctrl, q0, sc.duration, sc.step, backend="compiled", progress=False),
     "checked200": lambda: checked(5), "checked100": lambda: checked(10),
     "log100": lambda: logged(100.0), "log100 noscene": lambda: logged(100.0, scene_rate=0),
     "log100 noscene nocond": lambda: logged(100.0, scene_rate=0, cond_rate=0),
     "logfull": lambda: logged(None), "logfull noscene nocond": lambda: logged(None, scene_rate=0, cond_rate=0)}
T = {k: [] for k in V}
for r in range(rounds):
    for k, f in V.items():
        t = time.perf_counter(); f(); T[k].append(time.perf_counter() - t)
b = np.array(T["bare"]); c = np.array(T["checked200"])
for k, v in T.items():
    v = np.array(v)
    print(f"| {k} | {np.median(v):.3f} | {np.median(v / b):.2f}× | {np.median(v / c):.2f}× |")
