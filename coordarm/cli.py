"""``coordarm`` command line: one sub-command per module, imported only when used."""
from __future__ import annotations

import argparse
import importlib
import os
import sys

from coordarm.symbolic.errors import CoordarmError

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
}


class _Version(argparse.Action):
    """``--version``: the installed version, looked up only when asked (importlib.metadata is slow)."""

    def __init__(self, option_strings: list[str], dest: str, **kwargs) -> None:
        super().__init__(option_strings, dest, nargs=0, default=argparse.SUPPRESS, **kwargs)

    def __call__(self, parser, namespace, values, option_string=None) -> None:
        import coordarm

        print(f"{parser.prog} {coordarm.__version__}")
        parser.exit()


def build_parser() -> argparse.ArgumentParser:
    """The full ``coordarm`` argument parser."""
    parser = argparse.ArgumentParser(prog="coordarm", description=(
        "Coordinating control of hyper-redundant planar manipulators: run scenarios, "
        "regenerate the compiled controller, replay logs, write singularity reports, "
        "find the Foxglove layout."))
    parser.add_argument("--version", action=_Version, help="print the installed version and exit")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for name, module in COMMANDS.items():
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
    """
    args = build_parser().parse_args(argv)
    if "matplotlib" not in sys.modules:
        os.environ["MPLBACKEND"] = "Agg"
    try:
        return int(args.func(args) or 0)
    except CoordarmError as exc:
        print(f"coordarm {args.command}: error: {exc}", file=sys.stderr)
        return 2
    except (KeyboardInterrupt, SystemError) as exc:
        # CasADi's C++ calls can surface a Ctrl-C as "SystemError: ... returned a result with an
        # exception set", chained from the KeyboardInterrupt.
        if isinstance(exc, SystemError) and not isinstance(exc.__cause__, KeyboardInterrupt):
            raise
        print(f"coordarm {args.command}: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
