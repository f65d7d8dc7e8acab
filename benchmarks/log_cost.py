"""How much MCAP logging adds to a run, and how big the log is.

1. The 64-link ``line`` run, 30 s at 1 ms (30,000 steps), without a logger and with the
   full-rate :class:`~simulation.mcap_writer.RunLogger` (``--backend`` is passed to
   ``simulate`` when it has that option); median wall times of ``--repeats`` runs each,
   interleaved, and their ratio.
2. The pure logging cost of 30,000 synthetic 64-link samples handed over in blocks of 500
   (as ``simulate`` does), so the number stands whatever the simulation backend; for
   comparison the same per-step messages written one by one with ``mcap.writer.Writer``.

Usage: ``python benchmarks/log_cost.py [--repeats 3] [--backend compiled] [--skip-run] [--links 64] [--duration 30]``
"""
from __future__ import annotations

import argparse
import inspect
import platform
import statistics
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from mcap.writer import CompressionType, Writer  # noqa: E402

from coordarm.simulation.log_schemas import CDR_HEADER, PER_STEP, numeric_channels  # noqa: E402
from coordarm.simulation.mcap_writer import RunLogger  # noqa: E402
from coordarm.simulation.run import Run, simulate  # noqa: E402
from coordarm.simulation.scenario import load_scenario  # noqa: E402

STEP, BLOCK = 0.001, 500


def timed(fn) -> float:
    start = time.perf_counter()
    fn()
    return time.perf_counter() - start


def synthetic_blocks(m: int, n: int, block: int, seed: int = 1) -> list[Run]:
    """Smooth made-up signals (they compress about like a real run's) in blocks of ``block`` rows."""
    rng = np.random.default_rng(seed)
    t = STEP * np.arange(n)
    phase = rng.uniform(0, 2 * np.pi, m)
    q = 0.3 * np.sin(0.2 * t[:, None] + phase) + 1e-9 * rng.standard_normal((n, m))
    u = 0.06 * np.cos(0.2 * t[:, None] + phase)
    e = 1e-3 * np.exp(-2 * t)[:, None] * np.cos(phase[1:])
    margins = 0.5 + 0.4 * np.sin(0.1 * t[:, None] + phase[1:])
    return [Run(t[i:i + block], q[i:i + block], u[i:i + block], e[i:i + block], 0.1 * t[i:i + block],
                margins[i:i + block], 0.5 + 0.1 * np.cos(t[i:i + block]), np.full(len(t[i:i + block]), 0.1))
            for i in range(0, n, block)]


def per_message_writer(path: Path, blocks: list[Run], m: int) -> None:
    """The same per-step messages through ``mcap.writer.Writer.add_message``, one call each."""
    chans = numeric_channels(m)
    with open(path, "wb") as f:
        w = Writer(f, chunk_size=256 * 1024, compression=CompressionType.ZSTD)
        w.start(profile="ros2")
        ids = {}
        for key in PER_STEP:
            sid = w.register_schema(chans[key].schema_name, "ros2msg", chans[key].schema_text().encode())
            ids[key] = w.register_channel(chans[key].topic, "cdr", sid)
        for part in blocks:
            rows = {"joint_state": np.column_stack([part.t, part.q, part.u]),
                    "task_state": np.column_stack([part.t, part.s, part.v_star, part.e]),
                    "margins": np.column_stack([part.t, part.link_margins, part.longitudinal])}
            ns = np.round(part.t * 1e9).astype(np.uint64)
            for k in range(len(part.t)):
                lt = int(ns[k])
                for key in PER_STEP:
                    w.add_message(ids[key], lt, CDR_HEADER + rows[key][k].tobytes(), lt)
        w.finish()


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--backend", help="simulation backend (if simulate() has that option)")
    ap.add_argument("--skip-run", action="store_true", help="only the synthetic logging benchmark")
    ap.add_argument("--links", type=int, default=64)
    ap.add_argument("--duration", type=float, default=30.0, help="simulated seconds")
    args = ap.parse_args()
    links, duration = args.links, args.duration
    sc = load_scenario("line").with_overrides(links=links, duration=duration, step=STEP)
    ctrl = sc.controller()
    tmp = Path(tempfile.mkdtemp(prefix="coordarm-bench-"))
    print(f"python {platform.python_version()}, {platform.machine()}, repeats {args.repeats}")

    blocks = synthetic_blocks(links, int(duration / STEP), BLOCK)

    def log_synthetic(path: Path, **kw) -> None:
        with RunLogger(path, sc, ctrl, command=["bench"], **kw) as log:
            for part in blocks:
                log.on_chunk(part)

    log_synthetic(tmp / "warm.mcap")
    rows = []
    for label, fn, path in (
            ("RunLogger, all channels", lambda p: log_synthetic(p), tmp / "syn_all.mcap"),
            ("RunLogger, per-step channels only", lambda p: log_synthetic(p, scene_rate=0, cond_rate=0),
             tmp / "syn_step.mcap"),
            ("mcap Writer.add_message, per-step channels", lambda p: per_message_writer(p, blocks, links),
             tmp / "syn_writer.mcap")):
        times = [timed(lambda: fn(path)) for _ in range(args.repeats)]
        rows.append((label, statistics.median(times), path.stat().st_size))
    print(f"\nsynthetic: {len(blocks) * BLOCK} samples of {links} links in blocks of {BLOCK}")
    for label, t, size in rows:
        print(f"  {label:45s} {t:7.3f} s   {size / 2**20:6.2f} MiB")

    if args.skip_run:
        return
    kw = {}
    if args.backend:
        if "backend" not in inspect.signature(simulate).parameters:
            sys.exit("simulate() has no backend option in this checkout")
        kw["backend"] = args.backend
    q0 = sc.start(ctrl)

    def plain():
        simulate(ctrl, q0, duration, STEP, progress=False, **kw)

    def logged(name: str, **options):
        def go():
            (tmp / name).unlink(missing_ok=True)   # a new file (replacing one frees its blocks: not logging)
            with RunLogger(tmp / name, sc, ctrl, command=["bench"], **options) as log:
                simulate(ctrl, q0, duration, STEP, progress=False, on_chunk=log.on_chunk, **kw)
        return go

    variants = {"without log": plain, "full-rate log": logged("run.mcap"),
                "full-rate log, threaded": logged("run_threaded.mcap", threaded=True),
                "full-rate zstd, threaded": logged("run_zstd.mcap", threaded=True, compression="zstd"),
                "full-rate uncompressed, threaded": logged("run_none.mcap", threaded=True, compression="none"),
                "log at 100 Hz, threaded": logged("run100.mcap", threaded=True, log_rate=100.0)}
    plain()  # build and cache the chunk Function
    times: dict[str, list[float]] = {k: [] for k in variants}
    for _ in range(args.repeats):  # interleaved, so that load changes hit every variant alike
        for k, fn in variants.items():
            times[k].append(timed(fn))
    files = {"full-rate log": "run.mcap", "full-rate log, threaded": "run_threaded.mcap",
             "full-rate zstd, threaded": "run_zstd.mcap", "full-rate uncompressed, threaded": "run_none.mcap",
             "log at 100 Hz, threaded": "run100.mcap"}
    ratios = {k: statistics.median(t / b for t, b in zip(ts, times["without log"])) for k, ts in times.items()}
    base = statistics.median(times["without log"])
    print(f"\n{links}-link line run, {duration:g} s at {STEP * 1e3:g} ms, backend {args.backend or 'default'}")
    for k, ts in times.items():
        med = statistics.median(ts)
        size = f"   log {(tmp / files[k]).stat().st_size / duration / 2**20:.3f} MiB per simulated s" if k in files else ""
        print(f"  {k:26s} median {med:7.3f} s  ratio {med / base:5.2f} (median per round {ratios[k]:5.2f})  "
              f"({', '.join(f'{t:.3f}' for t in ts)}){size}")


if __name__ == "__main__":
    main()
