"""What each part of a logged run costs (64 links, 30 s, in this process, interleaved rounds).

Variants: bare simulation; checked at 200 Hz and at 100 Hz (the physical checks ``coordarm run``
makes); logged at 100 Hz and at full rate (threaded writer, as the command), with today's defaults
(lz4, ``cond`` at :data:`~coordarm.simulation.cond_channel.COND_RATE`), with the former ones (zstd,
``cond`` at 5 Hz) and without the scene and ``cond``. Prints, per variant, the median wall time,
the median per-round ratios to the bare and to the checked (200 Hz) run, and the median CPU time of
the process (all threads; on a loaded machine the wall time follows it). Then the parts alone, in
one thread: the 20 Hz scene messages, ``cond`` at 1 and 5 Hz, and the compression of the full-rate
log's chunks with lz4 and zstd. Run: ``python benchmarks/log_parts.py [--rounds 5]``; results in
RESULTS.md ("Where a logged run's time goes").
"""
import argparse
import os
import sys
import tempfile
import time
import zlib
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

import numpy as np  # noqa: E402
import zstandard  # noqa: E402

from coordarm.simulation import mcap_file  # noqa: E402
from coordarm.simulation.choices import lz4_frame  # noqa: E402
from coordarm.simulation.cond_channel import cond_values  # noqa: E402
from coordarm.simulation.mcap_writer import RunLogger, log_time_ns  # noqa: E402
from coordarm.simulation.run import simulate  # noqa: E402
from coordarm.simulation.scenario import load_scenario  # noqa: E402
from coordarm.simulation.scene_kind import scene_builder  # noqa: E402

ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
ap.add_argument("--rounds", type=int, default=3)
rounds = ap.parse_args().rounds
OUT = Path(tempfile.mkdtemp()) / "parts.mcap"
sc = load_scenario("line").with_overrides(64, 30.0, None)
ctrl = sc.controller()
q0 = sc.start(ctrl)
simulate(ctrl, q0, 0.1, sc.step, backend="compiled", progress=False)


def checked(every):
    simulate(ctrl, q0, sc.duration, sc.step, sc.t0, backend="compiled", progress=False, thresholds=sc.thresholds,
             physical=sc.physical(ctrl.chain), check_every=every)


def logged(rate, **kw):
    with RunLogger(OUT, sc, ctrl, log_rate=rate, command=["b"], threaded=True, **kw) as log:
        simulate(ctrl, q0, sc.duration, sc.step, sc.t0, backend="compiled", progress=False, thresholds=sc.thresholds,
                 physical=sc.physical(ctrl.chain), check_every=max(log.every, 5), on_chunk=log.on_chunk)
    return OUT.stat().st_size


OLD = {"compression": "zstd", "cond_rate": 5.0}
V = {"bare simulation": lambda: simulate(ctrl, q0, sc.duration, sc.step, backend="compiled", progress=False),
     "checked, 200 Hz": lambda: checked(5), "checked, 100 Hz": lambda: checked(10),
     "100 Hz log (defaults: lz4, cond 1 Hz)": lambda: logged(100.0),
     "100 Hz log, former defaults (zstd, cond 5 Hz)": lambda: logged(100.0, **OLD),
     "100 Hz log, no scene": lambda: logged(100.0, scene_rate=0),
     "100 Hz log, no scene, no cond": lambda: logged(100.0, scene_rate=0, cond_rate=0),
     "full-rate log (defaults: lz4, cond 1 Hz)": lambda: logged(None),
     "full-rate log, former defaults (zstd, cond 5 Hz)": lambda: logged(None, **OLD),
     "full-rate log, no scene, no cond": lambda: logged(None, scene_rate=0, cond_rate=0)}
T = {k: [] for k in V}
C = {k: [] for k in V}
size = {}
load = [os.getloadavg()[0]]
for r in range(rounds):
    for k, f in V.items():
        t, c = time.perf_counter(), time.process_time()
        out = f()
        T[k].append(time.perf_counter() - t)
        C[k].append(time.process_time() - c)
        if isinstance(out, int):
            size[k] = out
    load.append(os.getloadavg()[0])
b, c = np.array(T["bare simulation"]), np.array(T["checked, 200 Hz"])
print(f"load average (1 min) during the rounds: {min(load):.2f}-{max(load):.2f}")
print("| variant | median [s] | / bare | / checked (200 Hz) | CPU [s] | CPU / checked CPU | file [MiB] |")
print("|---|---|---|---|---|---|---|")
cc = np.median(C["checked, 200 Hz"])
for k, v in T.items():
    v = np.array(v)
    mib = f"{size[k] / 2**20:.1f}" if k in size else ""
    print(f"| {k} | {np.median(v):.3f} | {np.median(v / b):.2f}× | {np.median(v / c):.2f}× "
          f"({np.min(v / c):.2f}–{np.max(v / c):.2f}) | {np.median(C[k]):.3f} | {np.median(C[k]) / cc:.2f}× | {mib} |")

# ---- the parts alone, in one thread
blocks, chunks = [], []
simulate(ctrl, q0, sc.duration, sc.step, sc.t0, backend="compiled", progress=False, on_chunk=blocks.append)
grab = mcap_file.McapFile._write_chunk_now
mcap_file.McapFile._write_chunk_now = lambda self, rec, idx: (chunks.append(b"".join(rec)), grab(self, rec, idx))[1]
with RunLogger(OUT, sc, ctrl, command=["b"], threaded=False) as log:
    for part in blocks:
        log.on_chunk(part)
mcap_file.McapFile._write_chunk_now = grab


def scenes():
    builder, seen = scene_builder(ctrl, sc.obstacles, getattr(sc.physical(ctrl.chain), "radius", None), "ends"), 0
    for part in blocks:
        builder.advance(part)
        ks = np.flatnonzero((seen + np.arange(len(part.t))) % 50 == 0)
        seen += len(part.t)
        builder.messages(part, ks, log_time_ns(part.t[ks], 0.0))


def conds(every):
    seen = 0
    for part in blocks:
        ks = np.flatnonzero((seen + np.arange(len(part.t))) % every == 0)
        seen += len(part.t)
        cond_values(ctrl, False, part.q[ks], part.t[ks])


zstd = zstandard.ZstdCompressor(level=1).compress
lz4 = lz4_frame().compress
lz4_fast = lz4_frame().compress
crc_ng = mcap_file.crc32_function()
raw = sum(map(len, chunks))
P = {"scene, /tf, /tracking at 20 Hz (601 each)": scenes, "cond at 1 Hz (31 exact 1-norm values)": lambda: conds(1000),
     "cond at 5 Hz (151 values)": lambda: conds(200),
     f"lz4 of the full-rate chunks ({raw / 2**20:.0f} MiB)": lambda: [lz4(x) for x in chunks],
     "zstd level 1 of the same": lambda: [zstd(x) for x in chunks],
     **{f"zstd level {lv} (fast) of the same": (lambda c: lambda: [c(x) for x in chunks])(
         zstandard.ZstdCompressor(level=lv).compress) for lv in (-5, -10)},
     "lz4 acceleration 8 (level -8) of the same": lambda: [lz4_fast(x, compression_level=-8) for x in chunks],
     "CRC-32 of the same (zlib)": lambda: [zlib.crc32(x) for x in chunks],
     "CRC-32 of the same (zlib-ng, as the log)": lambda: [crc_ng(x) for x in chunks]}
PT = {k: [] for k in P}
size = {}
for r in range(rounds):
    for k, f in P.items():
        t = time.process_time()
        out = f()
        PT[k].append(time.process_time() - t)
        if isinstance(out, list) and out and isinstance(out[0], bytes):
            size[k] = sum(map(len, out)) / raw
print("\n| part (alone, one thread) | median CPU [s] | compressed / raw |")
print("|---|---|---|")
for k, v in PT.items():
    print(f"| {k} | {np.median(v):.3f} | {f'{size[k]:.3f}' if k in size else ''} |")
