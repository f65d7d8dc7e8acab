"""What a run's log holds, described once for its writer (:mod:`.mcap_writer`, :mod:`.mcap_file`)
and its readers (:mod:`coordarm.analysis.replay`): the per-sample arrays, the checksum of the
metadata records, the name of a log that is still being written.
"""
from __future__ import annotations

import hashlib
import json
from pathlib import Path

from coordarm.symbolic.outputs import RAIL_OUTPUTS, RUN_OUTPUTS

#: The per-sample arrays of a run and of its log: time, state, the law's run outputs, commanded speed.
ARRAYS = ("t", "q", *RUN_OUTPUTS, "v_star")
#: Arrays present only on some runs (a chain on a rail).
OPTIONAL = RAIL_OUTPUTS

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
    return hashlib.sha256(json.dumps(body, sort_keys=True, ensure_ascii=True).encode()).hexdigest()


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
