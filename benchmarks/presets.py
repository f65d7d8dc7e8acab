"""Every preset's whole command against another revision: ``coordarm run PRESET --no-figures``, interleaved.

For each round and preset the command runs once in this checkout and once in a temporary ``git worktree`` of
``--against`` (the order alternating between rounds), each a new process with bytecode caching on, each after
``os.sync`` (the page cache of the log before is written out, untimed). Reported per preset: the median wall
time of each, the median of the per-round ratios (min-max), and whether the two logs hold the same messages
(the topics that differ, if any). The libraries and memos are built once, untimed, before the rounds.

Run: ``python benchmarks/presets.py --against REV [--rounds 5] [--presets pipe thread] [--no-write]``; writes
the section between the ``presets.py`` markers of ``benchmarks/RESULTS.md``.
"""
from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
sys.path.insert(0, str(HERE))

from run_benchmarks import machine  # noqa: E402

START, END = "<!-- presets.py: start -->", "<!-- presets.py: end -->"
ENV = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}


def presets() -> list[str]:
    """The shipped presets, by name."""
    from coordarm.simulation.choices import presets as shipped
    return sorted(shipped())


def command(checkout: Path, preset: str, log: Path) -> float:
    """Wall time [s] of ``coordarm run PRESET --no-figures`` with ``checkout``'s package (fails loudly)."""
    os.sync()
    start = time.perf_counter()
    proc = subprocess.run([sys.executable, "-m", "coordarm", "run", preset, "--no-figures", "--quiet", "--overwrite",
                           "--out", str(log)], cwd=checkout, env={**ENV, "PYTHONPATH": str(checkout)},
                          stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    seconds = time.perf_counter() - start
    if proc.returncode:
        raise RuntimeError(f"{checkout}: coordarm run {preset}: exit {proc.returncode}: {proc.stderr[-400:]}")
    return seconds


def differing_topics(a: Path, b: Path) -> list[str]:
    """The topics whose messages (log time, bytes) differ between two logs."""
    from mcap.reader import make_reader

    def messages(path: Path) -> dict[str, list]:
        out: dict[str, list] = {}
        with open(path, "rb") as f:
            for _, channel, message in make_reader(f).iter_messages(log_time_order=True):
                out.setdefault(channel.topic, []).append((message.log_time, message.data))
        return out
    ma, mb = messages(a), messages(b)
    return sorted(t for t in set(ma) | set(mb) if ma.get(t) != mb.get(t))


def measure(against: str, rounds: int, names: list[str], tmp: Path) -> list[str]:
    """The report's lines: one table row per preset."""
    base = tmp / "base"
    subprocess.run(["git", "-C", str(ROOT), "worktree", "add", "--detach", "-q", str(base), against], check=True)
    try:
        sides = {"this": ROOT, "base": base}
        for name in names:                               # libraries built, memos written (untimed)
            for side, checkout in sides.items():
                command(checkout, name, tmp / f"{side}_{name}.mcap")
        times = {(side, name): [] for side in sides for name in names}
        for k in range(rounds):
            for name in names:
                for side in (("this", "base") if k % 2 == 0 else ("base", "this")):
                    times[side, name].append(command(sides[side], name, tmp / f"{side}_{name}.mcap"))
        rev = subprocess.run(["git", "-C", str(ROOT), "rev-parse", "--short", against], capture_output=True,
                             text=True, check=True).stdout.strip()
        lines = [f"| preset | {rev} [s] | this checkout [s] | speed-up (per round, min–max) | logs |", "|---|---|---|---|---|"]
        for name in names:
            a, b = np.array(times["base", name]), np.array(times["this", name])
            r = a / b
            topics = differing_topics(tmp / f"base_{name}.mcap", tmp / f"this_{name}.mcap")
            logs = "the same messages" if not topics else "differ in " + ", ".join(f"`{t}`" for t in topics)
            lines.append(f"| `{name}` | {np.median(a):.3f} | {np.median(b):.3f} | {np.median(r):.2f}× "
                         f"({r.min():.2f}–{r.max():.2f}) | {logs} |")
        return lines
    finally:
        subprocess.run(["git", "-C", str(ROOT), "worktree", "remove", "--force", str(base)], check=False)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--against", required=True, help="the git revision to compare with (e.g. HEAD~5)")
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--presets", nargs="*", help="the presets (default: all)")
    ap.add_argument("--no-write", action="store_true", help="print only; leave RESULTS.md alone")
    args = ap.parse_args()
    names = args.presets or presets()
    stamp = time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime())
    with tempfile.TemporaryDirectory() as tmp:
        rows = measure(args.against, args.rounds, names, Path(tmp))
    report = [START, f"Measured by `benchmarks/presets.py --against {args.against} --rounds {args.rounds}` ({stamp}; "
              f"load at the end {os.getloadavg()[0]:.1f}):", "", *machine(), "", *rows, END]
    print("\n".join(report))
    if not args.no_write:
        path = HERE / "RESULTS.md"
        text = path.read_text()
        if START in text:
            text = text[:text.index(START)] + "\n".join(report) + text[text.index(END) + len(END):]
        else:
            text = text.rstrip() + "\n\n## Every preset's command against an earlier revision (`benchmarks/presets.py`)\n\n" \
                + "\n".join(report) + "\n"
        path.write_text(text)


if __name__ == "__main__":
    main()
