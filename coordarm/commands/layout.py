"""``coordarm layout``: where the shipped Foxglove layout is, or a copy of it."""
from __future__ import annotations

import argparse
import json
from importlib import resources
from pathlib import Path

from coordarm.symbolic import ConfigError


def layout_path() -> Path:
    """Path of the Foxglove layout shipped with coordarm (3D view of ``/scene`` and five plots).

    Returns
    -------
    Path
        ``coordarm/data/foxglove_layout.json`` in the installed package.
    """
    return Path(str(resources.files("coordarm") / "data" / "foxglove_layout.json"))


def register(sub: argparse._SubParsersAction) -> None:
    """Add the ``layout`` sub-command.

    Parameters
    ----------
    sub : argparse._SubParsersAction
        The sub-parsers of the ``coordarm`` parser; the added parser sets ``func`` to :func:`main`.
    """
    p = sub.add_parser("layout", help="print the path of the Foxglove layout, or write a copy of it",
                       description="The Foxglove layout for coordarm logs and the live view, planar or spatial: "
                                   "a 3D panel (perspective view of frame world with /scene and the frames base "
                                   "and tip) and plots of log10 max|e| and log10 |s - target|, s and its target, "
                                   "the link margins with the longitudinal (planar) or end (spatial) margin, |u| "
                                   "and the roll (spatial). In Foxglove or Lichtblick: open the log (Open local "
                                   "file), then Layouts > Import layout and pick this file.")
    p.add_argument("--out", type=Path, metavar="FILE", help="write a copy of the layout to FILE")
    p.add_argument("--for", dest="fit", metavar="SCENARIO|LOG",
                   help="fit the layout to this scene: a preset name, a scenario TOML or a run log (.mcap: "
                        "every logged pose); the 3D panel's camera aimed at it, frame labels sized to it, and "
                        "no plot or series the chain kind never draws (the roll on a planar chain); needs --out")
    p.set_defaults(func=main)


def main(args: argparse.Namespace) -> int:
    """Print the layout's path (or write it, or with ``args.fit`` a copy whose camera frames that scene, to
    ``args.out`` and print that); return 0.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed options of the ``layout`` sub-command.

    Returns
    -------
    int
        The exit status: 0.

    Raises
    ------
    ConfigError
        ``--out`` cannot be written, ``--for`` without ``--out``, or a ``--for`` scenario or log that cannot
        be read.
    """
    source = layout_path()
    if args.fit is not None:
        if args.out is None:
            raise ConfigError("--for: give --out FILE for the fitted layout")
        from coordarm.simulation.scene_view import fitted_layout

        points, spatial = _scene_points(args.fit)
        text = json.dumps(fitted_layout(json.loads(source.read_text()), points, spatial), indent=2) + "\n"
        data = text.encode()
    elif args.out is None:
        print(source)
        return 0
    else:
        data = source.read_bytes()
    try:
        args.out.write_bytes(data)
    except OSError as exc:
        raise ConfigError(f"--out {args.out}: cannot write the layout: {exc.strerror or exc}") from None
    print(args.out)
    return 0


def _scene_points(name: str):
    """The points of the scene of a preset, scenario file or log (every logged pose) [m], shape (k, 3), and
    whether its chain is spatial."""
    from coordarm.simulation.scenario import load_scenario
    from coordarm.simulation.scene_view import scene_points

    if name.endswith(".mcap"):
        from coordarm.analysis.replay import load

        try:
            run = load(name)
        except OSError as exc:
            raise ConfigError(f"--for {name}: cannot read the log: {exc.strerror or exc}") from None
        return (scene_points(run.scenario, run.q[:: max(1, len(run.q) // 200)] if len(run.q) else None),
                run.scenario.universal)
    scenario = load_scenario(name)
    return scene_points(scenario), scenario.universal
