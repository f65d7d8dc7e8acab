"""``coordarm run``: simulate a scenario, print a summary, write the log and figures."""
from __future__ import annotations

import argparse
import math
import os
import sys
import warnings
from contextlib import ExitStack, contextmanager
from pathlib import Path
from typing import TYPE_CHECKING, Callable, Iterator, TextIO

from coordarm.simulation.choices import BACKENDS, COMPRESSIONS, DENSE_LINKS, presets
from coordarm.symbolic.errors import LogError
from coordarm.symbolic.laws import LAWS

if TYPE_CHECKING:   # the simulation modules load numpy, CasADi, matplotlib: only when the command runs
    from coordarm.simulation.run import Run
    from coordarm.simulation.scenario import Scenario


def register(sub: argparse._SubParsersAction) -> None:
    """Add the ``run`` sub-command."""
    p = sub.add_parser("run", help="simulate a scenario (preset or TOML file)",
                       description=f"Simulate a scenario: a preset ({', '.join(presets())}) or a TOML file. "
                                   "Prints a summary and writes the log and PNG figures next to it.")
    p.add_argument("scenario", metavar="SCENARIO_OR_TOML")
    p.add_argument("--links", type=int, help="override the number of links")
    p.add_argument("--duration", type=float, help="override the simulated duration [s]")
    p.add_argument("--step", type=float, help="override the RK4 step [s]")
    p.add_argument("--law", choices=LAWS, help="form of the control law")
    p.add_argument("--governor", action="store_true",
                   help="slow the commanded speed smoothly near the longitudinal singularity instead of stopping "
                        "(same as [control] governor = true)")
    p.add_argument("--backend", choices=BACKENDS, default="auto",
                   help="compiled C (built or taken from the cache), interpreted CasADi, or auto (default: "
                        "compiled when a C compiler is found, else interpreted with a warning)")
    p.add_argument("--out", type=Path, help="log file (default: logs/<scenario>.mcap); figures go beside it; "
                                            "an existing file is refused unless --overwrite")
    p.add_argument("--overwrite", action="store_true", help="replace an existing --out log")
    p.add_argument("--yes", action="store_true",
                   help="run even when the estimate (steps, log size, memory) is above the limits, or the dense "
                        f"law has more than {DENSE_LINKS} links")
    p.add_argument("--log-rate", type=float, metavar="HZ",
                   help="samples per simulated second in the log (default: every step)")
    p.add_argument("--cond-rate", type=float, metavar="HZ",
                   help="samples per simulated second of cond (an SVD each; default 5 Hz up to 64 links, "
                        "then falling as 1/m^2, off above 1024 links; 0 = off)")
    p.add_argument("--compression", choices=COMPRESSIONS, default="zstd",
                   help="chunk compression of the log: zstd (default, smallest), lz4 (faster) "
                        "or none (the cheapest to write, ~2.6x larger)")
    p.add_argument("--live", action="store_true",
                   help="serve the run over the Foxglove WebSocket protocol while it is simulated (paced to "
                        "real time, see --live-speed), writing the log too; in Foxglove: Open connection, "
                        "Foxglove WebSocket, ws://127.0.0.1:PORT")
    p.add_argument("--port", type=int, default=8765, help="port of the live server (default 8765; 0 = any free port)")
    p.add_argument("--live-speed", type=float, default=1.0, metavar="X",
                   help="simulated seconds per wall-clock second on the live view (default 1)")
    p.add_argument("--live-wait", action="store_true",
                   help="with --live: start simulating only once a client has subscribed")
    p.add_argument("--no-figures", action="store_true", help="do not draw figures")
    p.add_argument("--stages", type=stage_list, metavar="T1,T2,...",
                   help="times [s] of the stage figure, e.g. 0,4,8,12 (default: [figures] stages, else 5 evenly)")
    p.add_argument("--allow-contact", action="store_true",
                   help="keep going after a collision, self-collision or joint limit and record every contact")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=main)


def stage_list(text: str) -> list[float]:
    """``"0,4,8,12"`` -> ``[0.0, 4.0, 8.0, 12.0]`` (argparse type of ``--stages``: finite times >= 0, sorted)."""
    try:
        times = [float(v) for v in text.split(",")]
    except ValueError:
        times = []
    if not times or not all(math.isfinite(t) and t >= 0 for t in times):
        raise argparse.ArgumentTypeError(f"expected times in seconds >= 0 like 0,4,8,12, got {text!r}")
    return sorted(times)


def print_summary(run: Run, scenario: Scenario, out: TextIO | None = None) -> None:
    """Human-readable summary of a run (to ``out``, standard output by default)."""
    import numpy as np

    out = sys.stdout if out is None else out
    s = run.summary()
    lines = [f"scenario      {scenario.name} ({scenario.source}), {run.q.shape[1] - int(scenario.chain().rail)} links"
             + (" on a rail" if scenario.chain().rail else ""),
             f"simulated     {s['duration']:.3f} s in {s['steps']} steps ({run.info.get('stopped', '?')}, "
             f"backend {run.info.get('backend', '?')})",
             f"final max|e|  {s['final_max_abs_e']:.3e} m",
             f"s tracking    max |s - (s0 + ∫v*)| = {s['max_s_tracking_error']:.3e} m",
             f"link margin   min {s['min_link_margin']:.4f} (link {s['min_link_margin_link']}, "
             f"t = {s['min_link_margin_time']:.2f} s)",
             f"longitudinal  min {s['min_longitudinal_margin']:.4f} (t = {s['min_longitudinal_margin_time']:.2f} s)",
             f"max|u|        {s['max_abs_u']:.4g}"]
    if scenario.spec["control"].get("governor"):
        lines.append(f"governor      v* slowed during {run.governed_time():.3f} s (final v_scale {run.speed_factor()[-1]:.3g})")
    if run.sigma is not None:
        lines.append(f"rail          d from {run.q[0, 0]:.4f} to {run.q[-1, 0]:.4f} m, span sigma {run.sigma[0]:.4f} -> "
                     f"{run.sigma[-1]:.4f} m, min rail margin {np.min(run.rail_margin):.4f}")
    if run.q.shape[1] == scenario.chain().dof:
        lines += physical_lines(run, scenario)
    print("\n".join(lines), file=out)


def physical_lines(run: Run, scenario: Scenario) -> list[str]:
    """Summary lines: largest joint angle against its limit, contacts, clearance per obstacle."""
    import numpy as np

    from coordarm.simulation.run import even_indices

    chain = scenario.chain()
    qr = chain.revolute(run.q)
    rel = np.abs(qr[:, 1:]) / chain.joint_limits
    k, j = np.unravel_index(int(np.argmax(rel)), rel.shape)
    lines = [f"joints        max |q_j|/limit = {rel[k, j]:.3f} (joint {j + 2}: {qr[k, j + 1]:+.3f} rad of "
             f"±{chain.joint_limits[j]:.3f}, t = {run.t[k]:.2f} s)"]
    contacts = run.info.get("contacts") or []
    if contacts:
        lines.append(f"contacts      {len(contacts)} distinct (allowed), first: {contacts[0]['kind']} at "
                     f"t = {contacts[0]['time']:.3f} s, links {contacts[0]['links']}")
    rows = even_indices(len(run.t), 2000)
    for name, (d, t, link) in scenario.physical(chain).clearances(run.q[rows], run.t[rows]).items():
        lines.append(f"clearance     {name!r}: min {d:.4f} m (link {link}, t = {t:.2f} s)")
    return lines


def write_figures(run: Run, scenario: Scenario, ctrl, stem: Path, stages: list[float] | None = None,
                  outcome: str = "") -> list[Path]:
    """Stage and tracking figures as ``<stem>_stages.png`` and ``<stem>_tracking.png``.

    ``stages`` (times [s]) overrides the scenario's ``[figures] stages``; a scenario with
    ``[figures] panels`` draws one labelled panel per phase instead (paper Fig. 4).
    """
    from coordarm.simulation.figures import plot_panels, plot_stages, plot_tracking

    title = f"{scenario.name}: {ctrl.chain.m} links" + (f" ({outcome})" if outcome else "")
    stages_png = stem.with_name(stem.name + "_stages.png")
    panels = scenario.spec["figures"].get("panels")
    tracking_png = stem.with_name(stem.name + "_tracking.png")
    with writing(stages_png):
        if panels and stages is None:
            first = plot_panels(run, ctrl, stages_png, panels, obstacles=scenario.obstacles, title=title)
        else:
            first = plot_stages(run, ctrl, stages_png, obstacles=scenario.obstacles, times=stages or scenario.stages,
                                title=f"{title}, stages of the motion")
    with writing(tracking_png):
        return [first, plot_tracking(run, ctrl.gain, tracking_png, thresholds=scenario.thresholds, title=title)]


@contextmanager
def writing(path: Path) -> Iterator[None]:
    """Turn an OSError while writing ``path`` (a full disk, a read-only file system) into a LogError naming it."""
    try:
        yield
    except OSError as exc:
        raise LogError(f"{path}: cannot write it: {exc.strerror or exc}") from None


def _both(first: Callable[[Run], None], second: Callable[[Run], None]) -> Callable[[Run], None]:
    """One ``on_chunk`` that hands each block to ``first`` then ``second``."""
    def on_chunk(part: Run) -> None:
        first(part)
        second(part)
    return on_chunk


def main(args: argparse.Namespace) -> int:
    """Run the scenario named in ``args``; return 0 (completed), 3 (singularity) or 4 (collision).

    The log is opened as soon as the controller exists, so that however the run ends (an
    interrupt while compiling, a build error, a singularity, a collision) it is closed with its outcome.
    """
    from coordarm.simulation.limits import GainStepWarning, check_cost, check_gain_step, estimate
    from coordarm.simulation.live import LiveView
    from coordarm.simulation.mcap_writer import RunLogger
    from coordarm.simulation.outcome import EXIT_CODES, explain
    from coordarm.simulation.run import CHECK_RATE, BackendFallbackWarning, select_backend, simulate
    from coordarm.simulation.scenario import load_scenario
    from coordarm.symbolic.errors import CollisionError, ConfigError, SingularityError

    scenario = load_scenario(args.scenario).with_overrides(args.links, args.duration, args.step, law=args.law,
                                                           governor=True if args.governor else None)
    check_cost(estimate(scenario.chain().m, scenario.step, scenario.duration, args.log_rate), args.yes)
    m = scenario.spec["chain"]["links"]
    if scenario.spec["control"]["law"] == "dense" and m > DENSE_LINKS and not args.yes:
        raise ConfigError(f"--law dense with {m} links: generating and compiling it takes many minutes "
                          f"(its size grows as m^2); use the structured law, or pass --yes")
    out = args.out or Path("logs") / f"{scenario.name}.mcap"
    overwrite = args.overwrite or args.out is None   # the default log is a scratch file
    if out.exists() and not out.is_file():
        raise LogError(f"--out {out}: not a regular file; choose a log file name")
    if not overwrite and out.exists():
        raise LogError(f"--out {out}: exists; choose another file or pass --overwrite")
    try:
        out.parent.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise LogError(f"--out {out}: cannot create its directory: {exc.strerror or exc}") from None
    ctrl = scenario.controller()
    stopped: SingularityError | CollisionError | None = None
    with ExitStack() as stack:
        live = None
        if args.live:
            live = stack.enter_context(LiveView(scenario, ctrl, port=args.port, speed=args.live_speed))
            print(f"live          {live.url} (Foxglove: Open connection, Foxglove WebSocket)", flush=True)
            if args.live_wait:
                live.wait_for_client()
        try:
            # The log is closed with its outcome however the run ends (singularity, collision, error, Ctrl-C).
            # With a second core, encoding and compression overlap the simulation (RESULTS_logging.md).
            with RunLogger(out, scenario, ctrl, log_rate=args.log_rate, cond_rate=args.cond_rate,
                           compression=args.compression, overwrite=overwrite,
                           threaded=(os.cpu_count() or 1) > 1) as log:
                q0 = scenario.start(ctrl)
                with warnings.catch_warnings(record=True) as caught:   # builds or loads the library
                    warnings.simplefilter("always", BackendFallbackWarning)
                    check_gain_step(ctrl.gain, scenario.step)
                    backend, compiled, _ = select_backend(ctrl, args.backend)
                for w in caught:
                    print(f"coordarm run: warning: {w.message}", file=sys.stderr)
                log.set_backend(backend, compiled.library.key if compiled else None)
                on_chunk = log.on_chunk if live is None else _both(log.on_chunk, live.on_chunk)
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore", GainStepWarning)   # said above already
                    run = simulate(ctrl, q0, scenario.duration, scenario.step, scenario.t0, backend=backend,
                                   thresholds=scenario.thresholds, progress=not args.quiet, on_chunk=on_chunk,
                                   physical=scenario.physical(ctrl.chain),
                                   check_every=max(log.every, round(1.0 / (CHECK_RATE * scenario.step))),
                                   allow_contact=args.allow_contact)
                log.contacts = run.info["contacts"]
        except (SingularityError, CollisionError) as err:
            run, stopped = err.run, err
    status = "completed" if stopped is None else ("collision" if isinstance(stopped, CollisionError) else "singularity")
    print_summary(run, scenario)
    if compiled:
        print(f"library       {compiled.library.path} ({'cache hit' if compiled.cache_hit else 'built now'})")
    print(f"log           {out}")
    figures = [] if args.no_figures else write_figures(run, scenario, ctrl, out.with_suffix(""), args.stages,
                                                       outcome=status)
    for p in figures:
        print(f"figure        {p}")
    if stopped is not None:
        what, advice = explain(stopped)
        print(f"coordarm run: {status}: {what}; run stopped\n{advice}\nlog: {out}"
              + "".join(f"\nfigure: {p}" for p in figures), file=sys.stderr)
    return EXIT_CODES[status]
