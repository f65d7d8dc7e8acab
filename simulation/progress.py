"""The one-line progress bar of long runs, sweeps and animations, rendered by tqdm.

``run [###############               ]  50.0%  t = 0.25/0.50 s  0.1 s wall`` on stderr: redrawn in
place on a terminal, and a new line every tenth of the way elsewhere (a pipe, a log file,
CI). tqdm formats the line (:meth:`tqdm.tqdm.format_meter`: the bar, the percentage and the
text after them); a tqdm bar object is not used because it always redraws with a carriage
return (one ever-growing line in a log file, no line per tenth), draws itself when created and
starts a monitor thread. tqdm is imported when the first bar is made, not with this module.
"""
from __future__ import annotations

import sys
import time
from typing import TextIO

#: The line: label, a 30-character bar of ``#``, the percentage and :meth:`Progress.status`.
LINE = "{desc} [{bar:30}] {percentage:5.1f}%  {status}"


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
        from tqdm.std import tqdm    # here: about 50 ms of imports, only when a bar is shown

        self.total, self.label, self.stream, self.unit = total, label, stream or sys.stderr, unit
        self.tty = hasattr(self.stream, "isatty") and self.stream.isatty()
        self.start, self.last = time.perf_counter(), -1
        self.format_meter = tqdm.format_meter

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
        shown = min(max(done, 0.0), self.total)         # the bar's fraction: frac, to the last bit
        msg = self.format_meter(shown, self.total, elapsed, prefix=self.label, ascii=" #",
                                bar_format=LINE, status=self.status(done, elapsed))
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
