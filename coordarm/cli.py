"""``coordarm`` command line: one sub-command per module, imported only when used."""
from __future__ import annotations

import argparse
import errno
import importlib
import os
import signal
import sys
import threading
from typing import NoReturn

#: Sub-command name -> module defining ``register(subparsers)``; the parser it adds sets ``func``.
COMMANDS = {
    "run": "coordarm.commands.run",
    "regen": "coordarm.commands.regen",
    "replay": "coordarm.commands.replay",
    "report": "coordarm.commands.report",
    "compare": "coordarm.commands.compare",
    "sweep": "coordarm.commands.sweep",
    "layout": "coordarm.commands.layout",
    "export": "coordarm.commands.export",
    "init": "coordarm.commands.init",
}

#: OpenBLAS threads of a command unless ``OPENBLAS_NUM_THREADS`` is set: the command's matrices are small
#: (``cond`` of the decoupling matrix, at most a few hundred joints by default), where a second BLAS thread
#: gains nothing on an idle machine and, on a loaded one, made one ``cond`` value 50x dearer (80-90 ms of CPU
#: instead of 1.2-1.7 ms at 160-192 joints); its Dask workers inherit it.
BLAS_THREADS = "1"


class _Version(argparse.Action):
    """``--version``: the version (``coordarm.version``), printed only when asked."""

    def __init__(self, option_strings: list[str], dest: str, **kwargs) -> None:
        super().__init__(option_strings, dest, nargs=0, default=argparse.SUPPRESS, **kwargs)

    def __call__(self, parser, namespace, values, option_string=None) -> None:
        import coordarm

        print(f"{parser.prog} {coordarm.__version__}")
        parser.exit()


def build_parser(only: str | None = None) -> argparse.ArgumentParser:
    """The ``coordarm`` argument parser: the full one, or the one that parses a single command.

    Parameters
    ----------
    only : str, optional
        A name of :data:`COMMANDS`: register only that command (its module alone is imported; the
        command's own parsing, help and errors are the same as with the full parser).

    Returns
    -------
    argparse.ArgumentParser
        With ``--version`` and one sub-parser per entry of :data:`COMMANDS` that is installed (or ``only``).

    Raises
    ------
    ModuleNotFoundError
        A command's module is there but something it imports is not (a missing command module
        itself is left out).
    """
    parser = argparse.ArgumentParser(prog="coordarm", description=(
        "Coordinating control of hyper-redundant planar manipulators: run scenarios, "
        "regenerate the compiled controller, replay logs, write singularity reports, "
        "find the Foxglove layout."))
    parser.add_argument("--version", action=_Version, help="print the installed version and exit")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for name, module in COMMANDS.items():
        if only is not None and name != only:
            continue
        try:
            importlib.import_module(module).register(sub)
        except ModuleNotFoundError as exc:
            if exc.name != module:
                raise
    return parser


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``coordarm`` console script; returns the exit status.

    The sub-commands write figures to files, so matplotlib (imported later, if at all) gets the
    non-interactive Agg backend; library users keep their own backend.

    Parameters
    ----------
    argv : list of str, optional
        The arguments (default: ``sys.argv[1:]``).

    Returns
    -------
    int
        0 done, 2 bad input or an unwritable/unreadable file (one line on stderr, no traceback),
        3 stopped ahead of a singularity, 4 stopped at a collision, 130 interrupted (Ctrl-C or
        SIGTERM, at any moment, also while the first modules are imported). ``--help``,
        ``--version`` and an argparse usage error exit through :class:`SystemExit` (0 or 2).
    """
    previous = _early_handlers()
    try:
        try:
            from coordarm.symbolic.errors import CoordarmError  # noqa: F401 (the first coordarm modules)
            from coordarm.symbolic.interrupts import handled
        except KeyboardInterrupt:
            print("coordarm: interrupted", file=sys.stderr)
            return 130
        with handled():  # Ctrl-C and SIGTERM raise Interrupted, also when inherited as ignored
            return _main(argv)
    finally:
        for signum, handler in previous.items():
            signal.signal(signum, handler)


def console(argv: list[str] | None = None) -> NoReturn:
    """Entry point of the ``coordarm`` console script and of ``python -m coordarm``: :func:`main`, then exit.

    When nothing is left to clean up (no ``atexit`` callback registered, no thread but this one,
    no profiler or tracer), the process ends with ``os._exit`` once standard output and error are flushed: the
    interpreter's teardown of some 400 modules (numpy, CasADi, ...) changes nothing on disk and
    costs 40-130 ms, a quarter of a small run. Otherwise it exits the usual way.

    Parameters
    ----------
    argv : list of str, optional
        The arguments (default: ``sys.argv[1:]``).

    Raises
    ------
    SystemExit
        With :func:`main`'s status (or argparse's, for ``--help``, ``--version`` and usage errors).

    Notes
    -----
    Sets ``OPENBLAS_NUM_THREADS=1`` unless the environment sets it (:data:`BLAS_THREADS`), before numpy loads.
    """
    os.environ.setdefault("OPENBLAS_NUM_THREADS", BLAS_THREADS)
    status = main(argv)
    if _nothing_to_clean_up():
        try:
            sys.stdout.flush()
            sys.stderr.flush()
        except (OSError, ValueError):       # a stream gone or closed: let the interpreter deal with it
            sys.exit(status)
        os._exit(status)
    sys.exit(status)


def _nothing_to_clean_up() -> bool:
    """No ``atexit`` callback (a temporary directory's finalizer, matplotlib, dask, logging with a handler)
    but an idle logging's (:func:`_idle_logging_callbacks`), no other thread, and no profiler or tracer
    (``python -m cProfile``, coverage, a debugger) that writes after."""
    import atexit

    count = getattr(atexit, "_ncallbacks", None)       # CPython's count of registered callbacks
    return (count is not None and count() == _idle_logging_callbacks() and threading.active_count() == 1
            and sys.getprofile() is None and sys.gettrace() is None)


def _idle_logging_callbacks() -> int:
    """1 when :mod:`logging` is imported and no logger has a handler, else 0.

    ``import logging`` registers one ``atexit`` callback, ``logging.shutdown`` (a caller or a
    library may import logging); with no handler it would only flush logging's last-resort handler,
    standard error, which :func:`console` flushes itself.
    """
    logging = sys.modules.get("logging")
    if logging is None:
        return 0
    loggers = [logging.getLogger(), *(v for v in logging.Logger.manager.loggerDict.values()
                                      if isinstance(v, logging.Logger))]
    return 0 if any(logger.handlers for logger in loggers) else 1


def _early_handlers() -> dict:
    """Until :func:`~coordarm.symbolic.interrupts.handled` takes over: SIGINT and SIGTERM raise
    KeyboardInterrupt (stdlib only, installed before anything heavy is imported)."""
    if threading.current_thread() is not threading.main_thread():
        return {}

    def interrupt(signum, frame):
        raise KeyboardInterrupt

    return {s: signal.signal(s, interrupt) for s in (signal.SIGINT, signal.SIGTERM)}


def _main(argv: list[str] | None) -> int:
    from coordarm.symbolic.errors import CoordarmError
    from coordarm.symbolic.interrupts import interruption

    command = "coordarm"
    try:
        words = sys.argv[1:] if argv is None else argv
        first = words[0] if words else None       # a command's line is parsed by its parser alone
        args = build_parser(first if first in COMMANDS else None).parse_args(argv)
        command = f"coordarm {args.command}"
        if "matplotlib" not in sys.modules:
            os.environ["MPLBACKEND"] = "Agg"
        return int(args.func(args) or 0)
    except BaseException as exc:
        # First the signal: CasADi's C++ calls can turn a Ctrl-C into another error (a SystemError,
        # or a TypeError of the next overload SWIG tries); a signal on record decides (`interruption`).
        signum = interruption(exc)
        if signum is not None:
            print(f"{command}: interrupted by {signal.Signals(signum).name}", file=sys.stderr)
            return 130
        if isinstance(exc, BrokenPipeError):   # the reader of standard output went away: end quietly
            from coordarm.symbolic.pipes import BROKEN_PIPE_STATUS, quiet_stdout

            quiet_stdout()
            return BROKEN_PIPE_STATUS
        if isinstance(exc, CoordarmError):
            print(f"{command}: error: {exc}", file=sys.stderr)
            return 2
        if isinstance(exc, (OSError, MemoryError, RecursionError)):  # a full disk, a file in the way, a huge input
            print(f"{command}: error: {_describe(exc)}", file=sys.stderr)
            return 2
        raise


def _describe(exc: BaseException) -> str:
    """One line for an operating-system or resource error."""
    if isinstance(exc, MemoryError):
        return "out of memory (reduce --links, --duration or the log rate)"
    if isinstance(exc, RecursionError):
        return "input nested too deeply"
    text = exc.strerror or str(exc) if isinstance(exc, OSError) else str(exc)
    where = getattr(exc, "filename", None)
    if not where and isinstance(exc, OSError) and exc.errno == errno.ENOSPC:
        return f"{text} (while writing this command's outputs: its --out, logs/ or the build cache)"
    return f"{where}: {text}" if where else text

if __name__ == "__main__":
    sys.exit(main())
