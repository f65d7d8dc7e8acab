"""Ctrl-C and SIGTERM that are never lost: a handler that raises *and* remembers.

CasADi's C++ calls can swallow the ``KeyboardInterrupt`` raised by Python's default SIGINT
handler (the call then returns normally and the run carries on). The handler installed by
:func:`handled` raises :class:`Interrupted` like the default one but also records the signal,
so the next :func:`check` (called between chunks of a run, after building, before the end)
raises it again. SIGTERM is treated the same way, and a SIGINT inherited as "ignored" (a
shell's background job) is replaced too, so that ``kill -INT`` works there as well.
"""
from __future__ import annotations

import signal
import threading
from contextlib import contextmanager
from typing import Iterator

#: Signals turned into :class:`Interrupted`.
SIGNALS = (signal.SIGINT, signal.SIGTERM)

_received: list[int] = []


class Interrupted(KeyboardInterrupt):
    """The run was stopped by a signal (Ctrl-C = SIGINT, or SIGTERM).

    Parameters
    ----------
    signum : int
        The signal number (default SIGINT).

    Attributes
    ----------
    signum : int
        The signal number.
    """

    def __init__(self, signum: int = signal.SIGINT) -> None:
        self.signum = int(signum)
        super().__init__(f"interrupted by {signal.Signals(self.signum).name}")


def _handler(signum: int, frame) -> None:
    _received.append(signum)
    raise Interrupted(signum)


def received() -> int | None:
    """The first signal received since :func:`handled` began, or None.

    Returns
    -------
    int or None
        Its signal number, or None if none arrived.
    """
    return _received[0] if _received else None


def interruption(exc: BaseException) -> int | None:
    """The signal behind ``exc`` if it ends the run as an interruption, else None.

    An interruption is a :class:`Interrupted`, a ``KeyboardInterrupt`` (SIGINT, also chained as
    the cause), or *any* error raised after a signal was received: CasADi's C++ calls can turn
    the ``KeyboardInterrupt`` raised inside them into a ``SystemError`` (65 of 44,000 mapped
    Function calls hit by a SIGINT every 0.7 ms) and, when SWIG then tries the next overload of a
    Function call (the symbolic one), into a ``TypeError`` far from the signal (1 of 200 Ctrl-Cs
    at random moments of ``coordarm run``).

    Parameters
    ----------
    exc : BaseException
        The exception that ended the run.

    Returns
    -------
    int or None
        The signal number (SIGINT when a bare ``KeyboardInterrupt`` has none on record).
    """
    if isinstance(exc, Interrupted):
        return exc.signum
    if _received:
        return _received[0]
    if isinstance(exc, KeyboardInterrupt) or isinstance(exc.__cause__, KeyboardInterrupt):
        return int(signal.SIGINT)
    return None


def check() -> None:
    """Raise :class:`Interrupted` if a signal arrived (even one whose exception was swallowed).

    Raises
    ------
    Interrupted
        A signal arrived since :func:`handled` began (carrying the first one received).
    """
    if _received:
        raise Interrupted(_received[0])


@contextmanager
def handled() -> Iterator[None]:
    """Install the remembering handler for SIGINT and SIGTERM inside the block (main thread only).

    The previous handlers come back afterwards and the record of received signals is cleared.
    Outside the main thread (where signal handlers cannot be set) the block runs unchanged.

    Yields
    ------
    None
        Control to the block, with the handlers installed.
    """
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    _received.clear()
    previous = {s: signal.signal(s, _handler) for s in SIGNALS}
    try:
        yield
    finally:
        for s, h in previous.items():
            signal.signal(s, h if h is not None else signal.SIG_DFL)
        _received.clear()
