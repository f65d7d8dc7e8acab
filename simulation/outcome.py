"""How a run ended, in words a user can act on, and the exit status of ``coordarm run``."""
from __future__ import annotations

from coordarm.symbolic import CollisionError, SingularityError

from .choices import Outcome

#: Exit status of ``coordarm run`` per outcome (bad input is 2, Ctrl-C 130: see ``coordarm.cli``).
EXIT_CODES = {Outcome.COMPLETED: 0, Outcome.SINGULARITY: 3, Outcome.COLLISION: 4}


def explain(error: SingularityError | CollisionError) -> list[str]:
    """What happened (margin or contact, link, time, value against threshold, geometric meaning) and one line of advice.

    Parameters
    ----------
    error : SingularityError or CollisionError
        The error that stopped the run; a SingularityError whose ``kind`` is not ``"longitudinal"``
        is explained as a link margin.

    Returns
    -------
    list of str
        Two lines: what happened, then one line of advice (starting ``advice:``).
    """
    if isinstance(error, CollisionError):
        return [error.contact.describe(), error.contact.advice()]
    t, v, thr = f"t = {error.time:.3f} s", f"{error.margin:.3g}", f"{error.threshold:.3g}"
    if error.kind == "longitudinal":
        return [f"singularity ahead at {t}: the longitudinal margin fell to {v} (threshold {thr}): the body is "
                f"stretched along the curve and the end point can hardly be pushed further (|u| would blow up)",
                "advice: lower the speed v*, use more links, a shorter duration, or a more compact start "
                "(larger start.beta)" + ("; or turn on the speed governor ([control] governor = true, "
                                         "--governor), which slows v* down instead of stopping" if error.hint else "")]
    return [f"singularity ahead at {t}: the link margin of link {error.link} fell to {v} (threshold {thr}): "
            f"link {error.link} stands almost across the curve",
            "advice: move the curve more slowly (angle, radius), raise the gain K, or start with links more "
            "aligned with the curve (smaller start.beta)"]
