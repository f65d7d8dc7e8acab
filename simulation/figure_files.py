"""A run's figures as PNG files beside its log: the stages (or the scenario's panels) and the tracking."""
from __future__ import annotations

from contextlib import contextmanager
from pathlib import Path
from typing import TYPE_CHECKING, Iterator, Sequence

from coordarm.symbolic.errors import LogError

if TYPE_CHECKING:   # matplotlib, numpy and CasADi load only when figures are drawn
    from coordarm.simulation.run import Run
    from coordarm.simulation.scenario import Scenario
    from coordarm.symbolic.controller import CoordinatingController


def write_figures(run: Run, scenario: Scenario, ctrl: CoordinatingController, stem: Path,
                  stages: Sequence[float] | None = None, outcome: str = "") -> list[Path]:
    """Stage and tracking figures as ``<stem>_stages.png`` and ``<stem>_tracking.png``.

    ``stages`` (times [s]) overrides the scenario's ``[figures] stages``; a scenario with
    ``[figures] panels`` draws one labelled panel per phase instead (paper Fig. 4). The
    figures are drawn with whatever matplotlib backend is selected (none is chosen here). A spatial
    chain's figures are :func:`coordarm.simulation.figures3d.spatial_figures` (3-D stages, tracking).

    Parameters
    ----------
    run : Run
        The run to draw.
    scenario : Scenario
        Its scenario (name, obstacles, thresholds, ``[figures]``).
    ctrl : CoordinatingController or SpatialController
        Its controller (chain, curve, gain).
    stem : Path
        Path of the figures without suffix, e.g. ``logs/line`` for ``logs/line_stages.png``.
    stages : sequence of float, optional
        Times [s] of the stage figure (default: the scenario's).
    outcome : str, optional
        How the run ended, shown in the title when given (``"singularity"``, ...).

    Returns
    -------
    list of Path
        The stage (or panel) figure, then the tracking figure.

    Raises
    ------
    LogError
        A figure cannot be written (a full disk, a directory in the way), naming the file.
    """
    from coordarm.simulation.contact_marks import ended_note, recorded_contacts
    from coordarm.simulation.log_layout import PLANAR, layout_of_chain

    if layout_of_chain(ctrl.chain) is not PLANAR:    # a spatial chain: 3-D figures (matplotlib loads there)
        from coordarm.simulation.figures3d import spatial_figures
        return spatial_figures(run, scenario, ctrl, stem, stages, outcome)
    from coordarm.simulation.figures import plot_panels, plot_stages, plot_tracking

    ended = ended_note(outcome, len(recorded_contacts(run)))
    title = f"{scenario.name}: {ctrl.chain.m} links" + (f" ({ended})" if ended else "")
    stopped = outcome not in ("", "completed")
    stages_png = stem.with_name(stem.name + "_stages.png")
    panels = scenario.spec["figures"].get("panels")
    tracking_png = stem.with_name(stem.name + "_tracking.png")
    with writing(stages_png):
        if panels and stages is None:
            first = plot_panels(run, ctrl, stages_png, panels, obstacles=scenario.obstacles, title=title,
                                stopped=stopped)
        else:
            first = plot_stages(run, ctrl, stages_png, obstacles=scenario.obstacles, times=stages or scenario.stages,
                                title=f"{title}, stages of the motion", stopped=stopped)
    with writing(tracking_png):
        return [first, plot_tracking(run, ctrl.gain, tracking_png, thresholds=scenario.thresholds, title=title,
                                    speeds=getattr(ctrl, "speeds", None))]


@contextmanager
def writing(path: Path) -> Iterator[None]:
    """Turn an OSError while writing ``path`` (a full disk, a read-only file system) into a LogError naming it.

    Parameters
    ----------
    path : Path
        The file the body writes.

    Raises
    ------
    LogError
        The body raised an OSError.
    """
    try:
        yield
    except OSError as exc:
        raise LogError(f"{path}: cannot write it: {exc.strerror or exc}") from None
