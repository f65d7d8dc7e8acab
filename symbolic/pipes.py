"""Standard output closed by the reader (``coordarm run ... | head -3``): go on quietly, as a filter does."""
from __future__ import annotations

import os
import sys

#: Exit status of a command whose standard output was closed by its reader (128 + SIGPIPE, as a shell
#: reports a filter ended by SIGPIPE).
BROKEN_PIPE_STATUS = 141


def quiet_stdout() -> None:
    """Point standard output at ``/dev/null`` after its reader went away.

    The lines still to come (and Python's flush at exit) then vanish silently instead of raising
    ``BrokenPipeError`` again.
    """
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        os.close(devnull)
    except (OSError, ValueError):   # no file descriptor (a captured stream in tests): nothing to redirect
        pass


def say(line: str) -> None:
    """Print ``line`` on standard output at once; once the reader has gone, print nothing more.

    Parameters
    ----------
    line : str
        One line of a command's output.
    """
    try:
        print(line, flush=True)
    except BrokenPipeError:
        quiet_stdout()
