"""The one-line progress bar of long runs, sweeps and animations.

``run [###############               ]  50.0%  t = 0.25/0.50 s  0.1 s wall`` on stderr: redrawn in
place on a terminal, and a new line every tenth of the way elsewhere (a pipe, a log file,
CI). :func:`bar_line` formats the line; it writes what tqdm's ``format_meter`` writes for
:data:`LINE` (``tests/test_simulation.py`` compares the two), without tqdm's 30 ms of imports
(importlib.metadata, logging), a tenth of a 64-link, 30 s command (benchmarks/RESULTS.md, issue 24).
"""
from __future__ import annotations

import sys
import time
from typing import TextIO

#: Characters in the bar.
WIDTH = 30

#: The line: label, a :data:`WIDTH`-character bar of ``#``, the percentage and :meth:`Progress.status`
#: (a format string that tqdm's ``bar_format`` reads the same way).
LINE = "{desc} [{bar:%d}] {percentage:5.1f}%%  {status}" % WIDTH


def bar_line(label: str, done: float, total: float, status: str) -> str:
    """The progress line: ``label``, a bar of ``#`` filled to ``done / total``, the percentage, ``status``.

    Parameters
    ----------
    label : str
        Text before the bar.
    done, total : float
        Work done and work at 100 % (same unit; the fraction is clipped to [0, 1]).
    status : str
        Text after the percentage.

    Returns
    -------
    str
        E.g. ``"run [###############               ]  50.0%  t = 0.25/0.50 s  0.1 s wall"``:
        ``floor(30 * fraction)`` characters ``#``, the percentage to one decimal.
    """
    frac = min(max(0.0, done / total), 1.0)     # (0.0 first: a fraction of -0.0, e.g. -5e-324 / 2, shows as 0.0 %)
    return LINE.format(desc=label, bar="#" * int(frac * WIDTH), percentage=frac * 100, status=status)


class Progress:
    """A one-line progress bar on stderr (redrawn in place on a terminal, every 10% otherwise).

    Parameters
    ----------
    total : float
        Amount of work at 100 % (in the unit of ``update``'s ``done``, e.g. simulated seconds).
    label : str
        Text before the bar.
    stream : text file, optional
        Where to draw (default: ``sys.stderr``); a terminal if its ``isatty()`` says so.
    unit : str
        Format of the progress after the bar, with fields ``done`` and ``total``.
    """

    def __init__(self, total: float, label: str = "run", stream: TextIO | None = None,
                 unit: str = "t = {done:.2f}/{total:.2f} s") -> None:
        self.total, self.label, self.stream, self.unit = total, label, stream or sys.stderr, unit
        self.tty = hasattr(self.stream, "isatty") and self.stream.isatty()
        self.start, self.last = time.perf_counter(), -1

    def update(self, done: float) -> None:
        """Show the progress ``done`` of ``total`` (on a pipe only when it reaches a new tenth).

        Parameters
        ----------
        done : float
            Work done so far (the bar and percentage stop at 0 and 100 %).
        """
        frac = min(max(done / self.total, 0.0), 1.0)
        decile = int(frac * 10)
        if not self.tty and decile == self.last:
            return
        self.last = decile
        elapsed = time.perf_counter() - self.start
        msg = bar_line(self.label, done, self.total, self.status(done, elapsed))
        self.stream.write(("\r" + msg) if self.tty else msg + "\n")
        self.stream.flush()

    def status(self, done: float, elapsed: float) -> str:
        """The text after the bar: the progress in ``unit`` (simulated time by default) and wall time spent.

        Parameters
        ----------
        done : float
            Work done so far.
        elapsed : float
            Wall time since the bar was made [s].

        Returns
        -------
        str
        """
        return f"{self.unit.format(done=done, total=self.total)}  {elapsed:.1f} s wall"

    def close(self) -> None:
        """End the bar's line on a terminal (nothing to do elsewhere)."""
        if self.tty:
            self.stream.write("\n")
            self.stream.flush()


class Phase:
    """A line on stderr for a step that may take a while without a bar of its own (a build, a start-up).

    Used as a context manager: nothing is written if the step ends within ``delay`` seconds;
    after that, ``"<label> ..."`` appears (on a terminal followed by the seconds spent, updated
    every second), and at the end ``"<label>: done in X s"`` (or ``"<label>: failed after X s"``).

    Parameters
    ----------
    label : str
        What is being done, e.g. ``"law: building the compiled library"``.
    enabled : bool
        Write anything at all (False: a quiet run).
    stream : text file, optional
        Where to write (default: ``sys.stderr``).
    delay : float
        Seconds before the line appears [s].
    """

    def __init__(self, label: str, enabled: bool = True, stream: TextIO | None = None, delay: float = 1.0) -> None:
        import threading

        self.label, self.enabled, self.stream, self.delay = label, enabled, stream or sys.stderr, delay
        self.tty = hasattr(self.stream, "isatty") and self.stream.isatty()
        self.shown = False
        self._done = threading.Event()
        self._lock = threading.Lock()
        self._thread = threading.Thread(target=self._watch, name="coordarm-phase", daemon=True)

    def _watch(self) -> None:
        if self._done.wait(self.delay):
            return
        while True:
            with self._lock:
                if self._done.is_set():
                    return
                elapsed = time.perf_counter() - self.start
                if self.tty:
                    self.stream.write(f"\r{self.label} ... {elapsed:.0f} s")
                elif not self.shown:
                    self.stream.write(f"{self.label} ...\n")
                self.stream.flush()
                self.shown = True
            if self._done.wait(1.0):
                return

    def __enter__(self) -> "Phase":
        self.start = time.perf_counter()
        if self.enabled:
            self._thread.start()
        return self

    def __exit__(self, exc_type, exc, tb) -> bool:
        with self._lock:
            self._done.set()
            if self.shown:
                how = "done in" if exc_type is None else "failed after"
                self.stream.write(f"{chr(13) if self.tty else ''}{self.label}: {how} "
                                  f"{time.perf_counter() - self.start:.1f} s\n")
                self.stream.flush()
        return False
