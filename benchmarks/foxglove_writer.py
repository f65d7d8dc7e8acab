"""coordarm's own MCAP/CDR writer (``RunLogger``) against foxglove-sdk's MCAP writer, on the same log.

1. Throughput: the same synthetic 64-link run (30,000 steps in blocks of 500, as ``simulate``
   hands them over; ``benchmarks/log_cost.py`` makes the signals) written by ``RunLogger`` and
   by foxglove-sdk (``foxglove.open_mcap`` + one ``Channel.log`` per message), each on one
   thread with zstd level 1 and 256 KiB chunks, both pushing the file to the OS once a second.
   Without scenes (the three per-step channels) and with ``/scene``, ``/tf``, ``/tracking`` at
   20 Hz (built by the same :class:`SceneBuilder` for both, so the difference is the writer).
   Medians of interleaved repeats, time per message.
2. Crash safety: a child process writes a run paced to real time and is SIGKILLed; the log is
   read back with the ``mcap`` package's streaming reader; reported is how much simulated time
   was handed to the writer but lost.

Usage: ``python benchmarks/foxglove_writer.py [--repeats 5] [--links 64] [--duration 30] [--kill-after 4]``
"""
from __future__ import annotations

import argparse
from importlib import metadata
import os
import platform
import signal
import statistics
import struct
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

import foxglove  # noqa: E402
from foxglove.mcap import MCAPCompression, MCAPWriteOptions  # noqa: E402
from mcap.records import Channel, Message  # noqa: E402
from mcap.stream_reader import StreamReader  # noqa: E402

from coordarm.analysis.replay import load  # noqa: E402
from coordarm.simulation.live import sdk_channels  # noqa: E402
from coordarm.simulation.log_schemas import CDR_HEADER, PER_STEP, numeric_channels  # noqa: E402
from coordarm.simulation.mcap_writer import SCENE_RATE, RunLogger, log_time_ns, steps_between  # noqa: E402
from coordarm.simulation.scenario import load_scenario  # noqa: E402
from coordarm.simulation.scene import SceneBuilder  # noqa: E402

sys.path.insert(0, str(ROOT / "benchmarks"))
from log_cost import STEP, synthetic_blocks, timed  # noqa: E402


class FoxgloveLogger:
    """The log of :class:`RunLogger` (same channels, schemas, bytes) written through foxglove-sdk."""

    def __init__(self, path: Path, scenario, ctrl, scene_rate: float = SCENE_RATE, flush_interval: float = 1.0):
        self.context = foxglove.Context()
        options = MCAPWriteOptions(compression=MCAPCompression.Zstd, compression_level=1, compression_threads=0,
                                   chunk_size=256 * 1024, profile="ros2")
        self.writer = foxglove.open_mcap(path, allow_overwrite=True, context=self.context, writer_options=options)
        self.writer.write_metadata("scenario", {"json": scenario.to_json(), "source": scenario.source})
        self.numeric = numeric_channels(ctrl.chain.m)
        self.channels = sdk_channels(self.context, ctrl.chain.m, scenes=bool(scene_rate))
        self.scene = SceneBuilder(ctrl, scenario.obstacles)
        self.scene_every = steps_between(scene_rate, scenario.step, "scene_rate") if scene_rate else 0
        self.origin = min(0.0, scenario.t0)
        self.flush_interval, self._flushed, self._seen = flush_interval, time.monotonic(), 0

    def on_chunk(self, part) -> None:
        n = len(part.t)
        g = self._seen + np.arange(n)
        self._seen += n
        ns = log_time_ns(part.t, self.origin).tolist()
        rows = np.arange(n)
        data = {}
        for key in PER_STEP:
            ch = self.numeric[key]
            data[key] = np.empty((n, ch.width), "<f8")
            ch.fill(data[key], part, rows)
        for k in range(n):
            for key in PER_STEP:
                self.channels[key].log(CDR_HEADER + data[key][k].tobytes(), log_time=ns[k])
        if self.scene_every:
            self.scene.advance(part)
            ks = np.flatnonzero(g % self.scene_every == 0)
            for key, lt, msg in self.scene.messages(part, ks, log_time_ns(part.t[ks], self.origin)):
                self.channels[key].log(msg, log_time=lt)
        if time.monotonic() - self._flushed >= self.flush_interval:
            self.writer.flush()
            self._flushed = time.monotonic()

    def close(self) -> None:
        self.writer.close()


def _writer(kind: str, path: Path, sc, ctrl, scenes: bool):
    if kind == "coordarm":
        return RunLogger(path, sc, ctrl, command=["bench"], scene_rate=SCENE_RATE if scenes else 0, cond_rate=0)
    return FoxgloveLogger(path, sc, ctrl, scene_rate=SCENE_RATE if scenes else 0)


def _finish(w) -> None:
    w.finish() if isinstance(w, RunLogger) else w.close()


def child(kind: str, path: Path, links: int) -> None:
    """Write a run paced to real time (blocks of 0.1 s), printing the simulated time handed over."""
    sc = load_scenario("line").with_overrides(links=links, duration=60.0, step=STEP)
    ctrl = sc.controller()
    blocks = synthetic_blocks(links, 60_000, 100)
    w = _writer(kind, path, sc, ctrl, scenes=True)
    start = time.monotonic()
    for part in blocks:
        w.on_chunk(part)
        print(f"{part.t[-1]:.3f}", flush=True)
        due = start + part.t[-1] + STEP
        time.sleep(max(0.0, due - time.monotonic()))


def crash(kind: str, tmp: Path, links: int, kill_after: float) -> tuple[float, float]:
    """(simulated time handed over, simulated time recovered) of a run SIGKILLed after ``kill_after`` s."""
    path = tmp / f"killed_{kind}.mcap"
    proc = subprocess.Popen([sys.executable, __file__, "--child", kind, str(path), "--links", str(links)],
                            stdout=subprocess.PIPE, text=True)
    handed = 0.0
    for line in proc.stdout:
        handed = float(line)
        if handed >= kill_after:
            break
    os.kill(proc.pid, signal.SIGKILL)
    proc.wait()
    return handed, recovered_time(path)


def recovered_time(path: Path) -> float:
    """Last simulated time on ``/joint_state`` that a streaming read of ``path`` reaches (mcap's StreamReader).

    foxglove-sdk writes its channel records inside chunks, which ``replay.load`` skips, so the
    plain reader of the ``mcap`` package is the common yardstick here.
    """
    topics, last = {}, 0.0
    with open(path, "rb") as f:
        try:
            for record in StreamReader(f, skip_magic=False).records:
                if isinstance(record, Channel):
                    topics[record.id] = record.topic
                elif isinstance(record, Message) and topics.get(record.channel_id) == "/joint_state":
                    last = max(last, struct.unpack_from("<d", record.data, 4)[0])
        except Exception:  # the killed writer's last record is cut off
            pass
    return last


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--links", type=int, default=64)
    ap.add_argument("--duration", type=float, default=30.0, help="simulated seconds of the synthetic log")
    ap.add_argument("--kill-after", type=float, default=4.0, help="simulated (= wall) seconds before SIGKILL")
    ap.add_argument("--child", nargs=2, metavar=("WRITER", "PATH"), help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.child:
        child(args.child[0], Path(args.child[1]), args.links)
        return
    sc = load_scenario("line").with_overrides(links=args.links, duration=args.duration, step=STEP)
    ctrl = sc.controller()
    tmp = Path(tempfile.mkdtemp(prefix="coordarm-bench-fox-"))
    print(f"python {platform.python_version()}, {platform.machine()}, foxglove-sdk {metadata.version('foxglove-sdk')}, "
          f"repeats {args.repeats}, load {os.getloadavg()[0]:.2f}")
    blocks = synthetic_blocks(args.links, int(args.duration / STEP), 500)

    def write(kind: str, scenes: bool) -> Path:
        path = tmp / f"{kind}_{'scenes' if scenes else 'steps'}.mcap"
        w = _writer(kind, path, sc, ctrl, scenes)
        for part in blocks:
            w.on_chunk(part)
        _finish(w)
        return path

    variants = [(kind, scenes) for scenes in (False, True) for kind in ("coordarm", "foxglove")]
    for v in variants:
        write(*v)  # warm up
    times = {v: [] for v in variants}
    for _ in range(args.repeats):
        for v in variants:
            times[v].append(timed(lambda: write(*v)))
    for v in variants:
        path = tmp / f"{v[0]}_{'scenes' if v[1] else 'steps'}.mcap"
        rep = load(path)
        n = len(rep.t) * 3 + (3 * len(range(0, len(rep.t), steps_between(SCENE_RATE, STEP, 'x'))) if v[1] else 0)
        med = statistics.median(times[v])
        print(f"  {v[0]:9s} {'with scenes' if v[1] else 'per-step  '}  median {med:7.3f} s  {med / n * 1e6:6.2f} us/msg"
              f"  ({n} msgs, {path.stat().st_size / 2**20:6.2f} MiB)  runs {', '.join(f'{t:.3f}' for t in times[v])}")
    for scenes in (False, True):
        ratios = [f / c for c, f in zip(times[("coordarm", scenes)], times[("foxglove", scenes)])]
        print(f"  foxglove / coordarm {'with scenes' if scenes else 'per-step'}: median of per-repeat ratios "
              f"{statistics.median(ratios):.2f} (min {min(ratios):.2f}, max {max(ratios):.2f})")
    for kind in ("coordarm", "foxglove"):
        handed, recovered = crash(kind, tmp, args.links, args.kill_after)
        print(f"  SIGKILL {kind:9s} handed over {handed:.3f} s, recovered {recovered:.3f} s, lost {handed - recovered:.3f} s")


if __name__ == "__main__":
    main()
