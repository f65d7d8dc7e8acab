"""``coordarm init``: write a preset scenario out as a TOML file to start a scenario of one's own from."""
from __future__ import annotations

import argparse
from pathlib import Path

from coordarm.symbolic import ConfigError


def register(sub: argparse._SubParsersAction) -> None:
    """Add the ``init`` sub-command.

    Parameters
    ----------
    sub : argparse._SubParsersAction
        The sub-parsers of the ``coordarm`` parser; the added parser sets ``func`` to :func:`main`.
    """
    p = sub.add_parser("init", help="write a preset scenario to a TOML file, to edit and run",
                       description="Write the TOML of a preset scenario (with its comments) to FILE, to edit "
                                   "and run with coordarm run FILE.")
    p.add_argument("preset", metavar="PRESET", help="a preset name, e.g. hole (an unknown name is answered with the list)")
    p.add_argument("file", type=Path, metavar="FILE.toml", help="the file to write")
    p.add_argument("--overwrite", action="store_true", help="replace FILE if it exists")
    p.set_defaults(func=main)


def main(args: argparse.Namespace) -> int:
    """Write the preset ``args.preset`` to ``args.file``; print the file's path; return 0.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed options of the ``init`` sub-command.

    Returns
    -------
    int
        The exit status: 0.

    Raises
    ------
    ConfigError
        Not a preset name, ``FILE`` exists without ``--overwrite``, or it cannot be written.
    """
    from importlib import resources

    from coordarm.simulation.choices import presets

    if args.preset not in presets():
        raise ConfigError(f"{args.preset}: not a preset (one of {', '.join(presets())})")
    if args.file.suffix != ".toml":
        raise ConfigError(f"{args.file}: the scenario file must end in .toml")
    if args.file.exists() and not args.overwrite:
        raise ConfigError(f"{args.file}: exists (use --overwrite to replace it)")
    text = (resources.files("coordarm.simulation") / "presets" / f"{args.preset}.toml").read_text()
    try:
        args.file.write_text(text)
    except OSError as exc:
        raise ConfigError(f"{args.file}: cannot write the scenario: {exc.strerror or exc}") from None
    print(args.file)
    return 0
