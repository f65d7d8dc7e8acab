"""The log-encoding thread's CPU, part by part, inside whole logged runs (64 links, 30 s, full rate, threaded).

Each round logs the ``line`` run as ``coordarm run`` does (``RunLogger(threaded=True)``, lz4, the 20 Hz scene,
``cond`` at 1 Hz) while the compiled simulation runs on the main thread, and adds up ``time.thread_time()``
around the writer's parts on the thread that runs them (the ``coordarm-log`` thread): the whole
``RunLogger._process``, the per-step records (``_add_samples``, of which ``RecordPacker.pack``), the scene
(``SceneBuilder.advance`` and ``messages``, of which the JSON templates' ``fill``, ``/tf``, the targets and
the ``/tracking`` records), ``cond`` and the chunks' framing (``_write_chunk``, of which ``message_records``).
Prints the median of each over the rounds (after one warm-up round) and the wall time of a round.

It imports the ``coordarm`` its interpreter finds: to compare checkouts, run it alternately with each one's
venv interpreter, or with one interpreter and ``PYTHONPATH`` set to a worktree of each (the parts are looked
up by name, so a part that a checkout does not have reads 0). Run:
``python benchmarks/log_thread_cpu.py [--rounds 5]``; results in RESULTS.md ("The log thread's CPU, part by
part").
"""
import argparse
import collections
import functools
import statistics
import tempfile
import time
from pathlib import Path

from coordarm.simulation import json_fill, mcap_writer, scene
from coordarm.simulation.mcap_writer import RunLogger
from coordarm.simulation.run import simulate
from coordarm.simulation.scenario import load_scenario

try:
    from coordarm.simulation.record_packing import RecordPacker
except ImportError:     # a checkout from before the records' kernel (its part reads 0)
    RecordPacker = None

PARTS = [(RunLogger, "_process", "RunLogger._process (all)"), (RunLogger, "_add_samples", "records: _add_samples"),
         (RecordPacker, "pack", "  RecordPacker.pack"),
         (scene.SceneBuilder, "advance", "scene: SceneBuilder.advance"),
         (scene.SceneBuilder, "messages", "scene: SceneBuilder.messages"),
         (json_fill.JsonTemplate, "fill", "  JsonTemplate.fill"), (scene, "end_frames_json", "  end_frames_json"),
         (scene, "_targets", "  _targets"), (scene, "tracking_records", "  tracking_records"),
         (mcap_writer, "cond_values", "cond: cond_values"), (RunLogger, "_write_chunk", "chunks: _write_chunk"),
         (mcap_writer, "message_records", "  message_records")]
spent: dict[str, float] = collections.defaultdict(float)


def timed(owner, name, label):
    """Replace ``owner.name`` by a wrapper adding its thread CPU time to ``spent[label]``."""
    f = getattr(owner, name, None)
    if f is None:
        return

    @functools.wraps(f)
    def wrapper(*args, **kwargs):
        t = time.thread_time()
        try:
            return f(*args, **kwargs)
        finally:
            spent[label] += time.thread_time() - t
    setattr(owner, name, wrapper)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rounds", type=int, default=5)
    rounds = ap.parse_args().rounds
    for owner, name, label in PARTS:
        timed(owner, name, label)
    out = Path(tempfile.mkdtemp()) / "log_thread_cpu.mcap"
    sc = load_scenario("line").with_overrides(64, 30.0, None)
    ctrl = sc.controller()
    q0 = sc.start(ctrl)
    results, walls = collections.defaultdict(list), []
    for r in range(rounds + 1):
        spent.clear()
        t0 = time.perf_counter()
        with RunLogger(out, sc, ctrl, command=["log_thread_cpu"], threaded=True) as log:
            simulate(ctrl, q0, sc.duration, sc.step, sc.t0, backend="compiled", progress=False,
                     thresholds=sc.thresholds, physical=sc.physical(ctrl.chain), check_every=max(log.every, 5),
                     on_chunk=log.on_chunk)
        if r:                                   # the first round warms the caches and builds the law
            walls.append(time.perf_counter() - t0)
            for _, _, label in PARTS:
                results[label].append(spent.get(label, 0.0))
    print(f"round wall (median of {rounds}): {statistics.median(walls) * 1e3:.1f} ms")
    print("| part | thread CPU [ms] (median) |\n|---|---|")
    for _, _, label in PARTS:
        print(f"| {label} | {statistics.median(results[label]) * 1e3:.2f} |")


if __name__ == "__main__":
    main()
