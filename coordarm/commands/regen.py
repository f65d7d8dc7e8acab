"""``coordarm regen``: regenerate and recompile the C controller of scenarios."""
from __future__ import annotations

import argparse
import sys
import time

from coordarm.simulation.choices import presets
from coordarm.symbolic.laws import LAWS


def register(sub: argparse._SubParsersAction) -> None:
    """Add the ``regen`` sub-command.

    Parameters
    ----------
    sub : argparse._SubParsersAction
        The sub-parsers of the ``coordarm`` parser; the added parser sets ``func`` to :func:`main`.
    """
    p = sub.add_parser("regen", help="regenerate and recompile the C controller of scenarios",
                       description="Generate the C code of each scenario's control law, RK4 step and chunk "
                                   "loop, compile it and store it in the build cache (default: every preset). "
                                   "The cache directory is $COORDARM_BUILD_DIR, else $XDG_CACHE_HOME/coordarm, "
                                   "else ~/.cache/coordarm (see --print-cache-dir).")
    p.add_argument("scenarios", nargs="*", metavar="SCENARIO_OR_TOML",
                   help="preset names or TOML files (default: all presets)")
    p.add_argument("--clean", action="store_true", help="delete every cached library first")
    p.add_argument("--law", choices=LAWS, help="form of the control law (default: the scenario's)")
    p.add_argument("--links", type=int, help="override the number of links")
    p.add_argument("--print-cache-dir", action="store_true", help="print the build cache directory and exit")
    p.set_defaults(func=main)


def main(args: argparse.Namespace) -> int:
    """Regenerate and recompile the libraries of ``args.scenarios``; print where each went; return 0.

    With ``--print-cache-dir``, print the build cache directory only. Every scenario is loaded (and
    checked) before anything is removed or built.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed options of the ``regen`` sub-command.

    Returns
    -------
    int
        The exit status: 0.

    Raises
    ------
    ConfigError
        A bad scenario or override.
    BuildError
        A library cannot be built.
    """
    from coordarm.generated.build import build, build_root, clean
    from coordarm.generated.compiled import controller_source
    from coordarm.simulation.scenario import load_scenario

    if args.print_cache_dir:
        print(build_root())
        return 0

    names = args.scenarios or presets()
    scenarios = [load_scenario(n, links=args.links, law=args.law) for n in names]  # validate all first
    if args.clean:
        print(f"removed {clean()} cached libraries from {build_root()}")
    for scenario in scenarios:
        ctrl = scenario.controller()
        start = time.perf_counter()
        source = controller_source(ctrl, ctrl.law_form)     # planar or spatial
        gen = time.perf_counter() - start
        lib = build(source, force=True)
        print(f"{scenario.name}: {ctrl.law_form} law, {ctrl.chain.m} links, {len(source.text) / 1e3:.0f} kB of C "
              f"generated in {gen:.2f} s, compiled in {lib.compile_seconds:.2f} s -> {lib.path}")
        sys.stdout.flush()
    return 0
