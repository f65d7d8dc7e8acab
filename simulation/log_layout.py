"""What a run's log holds, described once for its writer (:mod:`.mcap_writer`, :mod:`.mcap_file`)
and its readers (:mod:`coordarm.analysis.replay`): the per-sample arrays, the checksum of the
metadata records, the name of a log that is still being written.
"""
from __future__ import annotations

import json
import sys
from pathlib import Path

from coordarm.symbolic.digests import sha256
from coordarm.symbolic.outputs import (LAW_OUTPUTS, RAIL_OUTPUTS, RUN_OUTPUTS, SCALAR_OUTPUTS, SPATIAL_LAW_OUTPUTS,
                                       SPATIAL_RUN_OUTPUTS, SPATIAL_SCALAR_OUTPUTS, Output)
from coordarm.symbolic.records import record

#: The per-sample arrays of a run and of its log: time, state, the law's run outputs, commanded speed.
ARRAYS = ("t", "q", *RUN_OUTPUTS, "v_star")
#: Arrays present only on some runs (a chain on a rail).
OPTIONAL = RAIL_OUTPUTS


@record(frozen=True)
class MarginCheck:
    """A margin that stops a run when it falls below its threshold.

    Attributes
    ----------
    kind : str
        The :class:`~coordarm.symbolic.SingularityError` kind (``"link"``, ``"longitudinal"``, ``"end"``, ``"joint"``).
    array : str
        The run array holding it (``(N,)`` or ``(N, n)``).
    threshold : str
        The key of its threshold in ``simulate(thresholds=...)`` (``"link"`` or ``"longitudinal"``).
    first : int or None
        The link or joint number of the array's column 0 (None for a scalar margin).
    """

    kind: str
    array: str
    threshold: str
    first: int | None


@record(frozen=True)
class ChainLayout:
    """What a run of one kind of chain holds: its arrays, their widths, its stops and its log fields.

    Attributes
    ----------
    kind : str
        ``"revolute"`` (planar) or ``"universal"`` (spatial, two angles per joint).
    outputs : tuple of Output
        The law's output rows (:data:`~coordarm.symbolic.outputs.LAW_OUTPUTS` or ``SPATIAL_LAW_OUTPUTS``).
    run_outputs : tuple of str
        The outputs kept at every sample (returned by the RK4 step after ``q_next``).
    scalars : tuple of str
        The outputs that are scalars.
    commands : tuple of str
        Commanded values kept beside them (``v_star`` [m/s]; ``roll_star`` [rad] for a spatial chain).
    joints_per_link : int
        Columns of ``q`` per link (1 or 2).
    deviations_per_link : int
        Columns of ``e`` per link (1: ``e^j``; 2: ``(e^j_1, e^j_2)``).
    margins : tuple of MarginCheck
        The stops, checked in this order at the first row where any is below threshold.
    """

    kind: str
    outputs: tuple[Output, ...]
    run_outputs: tuple[str, ...]
    scalars: tuple[str, ...]
    commands: tuple[str, ...]
    joints_per_link: int
    deviations_per_link: int
    margins: tuple[MarginCheck, ...]

    def threshold_key(self, kind: str) -> str:
        """The key in ``simulate(thresholds=...)`` of the margin check ``kind`` (``"link"`` or ``"longitudinal"``).

        Parameters
        ----------
        kind : str
            A :attr:`MarginCheck.kind` of :attr:`margins`.

        Returns
        -------
        str

        Raises
        ------
        StopIteration
            No margin check of that kind.
        """
        return next(c.threshold for c in self.margins if c.kind == kind)

    @property
    def arrays(self) -> tuple[str, ...]:
        """The per-sample arrays of a run and of its log: ``t``, ``q``, the run outputs, the commands."""
        return ("t", "q", *self.run_outputs, *self.commands)


#: The planar chain (revolute joints): :data:`ARRAYS`.
PLANAR = ChainLayout("revolute", LAW_OUTPUTS, RUN_OUTPUTS, SCALAR_OUTPUTS, ("v_star",), 1, 1,
                     (MarginCheck("link", "link_margins", "link", 2),
                      MarginCheck("longitudinal", "longitudinal", "longitudinal", None)))
#: The spatial chain (universal joints): ``q = (a_1, b_1, ...)``, ``e = (e^2_1, e^2_2, e^3_1, ...)``.
SPATIAL = ChainLayout("universal", SPATIAL_LAW_OUTPUTS, SPATIAL_RUN_OUTPUTS, SPATIAL_SCALAR_OUTPUTS,
                      ("v_star", "roll_star"), 2, 2,
                      (MarginCheck("link", "link_margins", "link", 2),
                       MarginCheck("end", "end_margin", "longitudinal", None),
                       MarginCheck("joint", "joint_margins", "link", 1)))
#: The layouts by chain kind (the ``chain_kind`` of a log's ``run`` metadata; planar logs have none).
LAYOUTS = {layout.kind: layout for layout in (PLANAR, SPATIAL)}


def layout_of(kind: str | None) -> ChainLayout:
    """The layout of a chain kind (None: planar, as in logs written before spatial chains).

    Parameters
    ----------
    kind : str or None
        ``"revolute"``, ``"universal"`` or None.

    Returns
    -------
    ChainLayout

    Raises
    ------
    KeyError
        An unknown kind.
    """
    if kind is None:
        return PLANAR
    if kind not in LAYOUTS:
        raise KeyError(f"unknown chain kind {kind!r} (known: {', '.join(LAYOUTS)})")
    return LAYOUTS[kind]


def layout_of_chain(chain: object) -> ChainLayout:
    """The layout of a chain model: spatial for a :class:`~coordarm.symbolic.SpatialChain`, else planar.

    Parameters
    ----------
    chain : KinematicChain
        A planar chain or a spatial one.

    Returns
    -------
    ChainLayout
    """
    # No SpatialChain exists before its module is loaded: a planar run neither loads it nor CasADi here.
    spatial = sys.modules.get("coordarm.symbolic.spatial_chain")
    return SPATIAL if spatial is not None and isinstance(chain, spatial.SpatialChain) else PLANAR


def layout_of_arrays(names: object) -> ChainLayout:
    """The layout whose arrays are all among ``names`` (spatial if every spatial array is there, else planar).

    Parameters
    ----------
    names : iterable of str
        Array names (the keys of a dict of arrays).

    Returns
    -------
    ChainLayout
    """
    return SPATIAL if set(SPATIAL.arrays) <= set(names) else PLANAR

#: Key of the checksum in every Metadata record of a log.
DIGEST_KEY = "sha256"


def metadata_digest(data: dict[str, str]) -> str:
    """SHA-256 of a metadata record's entries (all but :data:`DIGEST_KEY`), as canonical JSON.

    Parameters
    ----------
    data : dict of str to str
        The record's entries (a :data:`DIGEST_KEY` entry among them is left out).

    Returns
    -------
    str
        The hexadecimal digest.
    """
    body = {k: v for k, v in data.items() if k != DIGEST_KEY}
    return sha256(json.dumps(body, sort_keys=True, ensure_ascii=True).encode()).hexdigest()


def partial_path(path: str | Path) -> Path:
    """Where the log of ``path`` is written until it is closed: ``<stem>.partial<suffix>`` beside it.

    Parameters
    ----------
    path : str or Path
        The log's final name.

    Returns
    -------
    Path
        The name it has while it is written (and after a kill).
    """
    path = Path(path)
    return path.with_name(f"{path.stem}.partial{path.suffix}")
