"""How a run ended, in words a user can act on, and the exit status of ``coordarm run``."""
from __future__ import annotations

from typing import Any

from coordarm.symbolic import CollisionError, SingularityError
from coordarm.symbolic.errors import BaseOffPathError, JointRateError
from coordarm.symbolic.interrupts import interruption

from .choices import Outcome


#: Exit status of ``coordarm run`` per outcome (bad input is 2, Ctrl-C 130: see ``coordarm.cli``).
EXIT_CODES = {Outcome.COMPLETED: 0, Outcome.SINGULARITY: 3, Outcome.BASE_OFF_PATH: 3, Outcome.COLLISION: 4,
              Outcome.RATE_LIMIT: 5}


def outcome_of(error: BaseException | None, last_t: float | None,
               contacts: list[dict] | None = None, governed: float = 0.0) -> dict[str, Any]:
    """The ``outcome`` record for a run that ended normally (``error`` None) or with ``error``.

    Parameters
    ----------
    error : BaseException or None
        Why the run ended: None (completed), a SingularityError, a CollisionError, an
        interruption (Ctrl-C or a termination signal) or any other error.
    last_t : float or None
        Time of the last simulated step [s] (None: no step).
    contacts : list of dict, optional
        The contact records of an ``--allow-contact`` run, added when there are any.
    governed : float
        Simulated time during which the speed governor slowed ``v*`` [s].

    Returns
    -------
    dict
        ``status`` (an :class:`Outcome` value), ``t_end``, the details of the singularity, the
        collision or the error (``message`` among them), ``contacts`` when any, and ``governed``.
    """
    if error is None:
        out = {"status": Outcome.COMPLETED.value, "t_end": last_t}
    elif isinstance(error, BaseOffPathError):
        out = {"status": Outcome.BASE_OFF_PATH.value, "t_end": last_t, "time": error.time, "link": 1,
               "margin": error.margin, "kind": error.kind, "threshold": error.threshold, "d": error.d,
               "offset": error.offset, "message": str(error)}
    elif isinstance(error, SingularityError):
        out = {"status": Outcome.SINGULARITY.value, "t_end": last_t, "time": error.time, "link": error.link,
               "margin": error.margin, "kind": error.kind, "threshold": error.threshold, "message": str(error)}
    elif isinstance(error, CollisionError):
        c = error.contact
        out = {"status": Outcome.COLLISION.value, "t_end": last_t, "time": c.time, "kind": c.kind, "links": list(c.links),
               "value": c.value, "threshold": c.threshold, "obstacle": c.obstacle, "message": str(error)}
    elif isinstance(error, JointRateError):
        out = {"status": Outcome.RATE_LIMIT.value, "t_end": last_t, "time": error.time, "joint": error.joint,
               "value": error.value, "limit": error.limit, "kind": error.kind, "message": str(error)}
    else:
        status = (Outcome.INTERRUPTED if interruption(error) is not None else Outcome.ERROR).value
        out = {"status": status, "t_end": last_t, "error": type(error).__name__, "message": str(error)}
    if contacts:
        out["contacts"] = contacts
    out["governed"] = governed
    return out


def explain(error: SingularityError | CollisionError) -> list[str]:
    """What happened (margin or contact, link, time, value against threshold, geometric meaning) and one line of advice.

    Parameters
    ----------
    error : SingularityError or CollisionError
        The error that stopped the run (a BaseOffPathError names the base and the rail); a SingularityError whose ``kind`` is not ``"longitudinal"``,
        ``"end"`` or ``"joint"`` (a spatial chain's) is explained as a link margin.

    Returns
    -------
    list of str
        Two lines: what happened, then one line of advice (starting ``advice:``).
    """
    if isinstance(error, CollisionError):
        return [error.contact.describe(), error.contact.advice()]
    if isinstance(error, JointRateError):
        return [str(error).removesuffix("; run stopped"),
                "advice: lower the speed v*, use longer path transitions (curve.transition), or raise "
                f"chain.{error.kind}_limit if the hardware allows"]
    t, v, thr = f"t = {error.time:.3f} s", f"{error.margin:.3g}", f"{error.threshold:.3g}"
    if isinstance(error, BaseOffPathError):
        return [f"the base left the path at {t}: at d = {error.d:.4f} m on the rail the base is {error.offset:.3g} m "
                f"off the path (the path leaves the rail's line) and {error.what()} "
                f"(base margin {error.margin_text()}, threshold {thr}): the body can no longer follow (|u| would blow up)",
                "advice: end the rail's feed before the path leaves its line (chain.base.limits), put the first "
                "bend further along the path, or grow the span (control.span) so the base stays on the straight part"]
    if error.kind == "longitudinal":
        return [f"singularity ahead at {t}: the longitudinal margin fell to {v} (threshold {thr}): the body is "
                f"stretched along the curve and the end point can hardly be pushed further (|u| would blow up)",
                "advice: lower the speed v*, use more links, a shorter duration, or a more compact start "
                "(larger start.beta)" + ("; or turn on the speed governor ([control] governor = true, "
                                         "--governor), which slows v* down instead of stopping" if error.hint else "")]
    if error.kind == "end":
        return [f"singularity ahead at {t}: the end margin fell to {v} (threshold {thr}): the body is stretched "
                "along the curve or its fold plane is lost, so the end point's advance and the roll can hardly be set",
                "advice: lower the speed v* or the roll rate, use more links, or a more compact start (larger start.beta)"]
    if error.kind == "joint":
        return [f"singularity ahead at {t}: the joint margin |cos b| of joint {error.link} fell to {v} (threshold "
                f"{thr}): its second angle nears ±90°, where the two angles cannot express the link's turn",
                "advice: roll the fold plane more slowly or less, or start with smaller bends (smaller start.beta)"]
    return [f"singularity ahead at {t}: the link margin of link {error.link} fell to {v} (threshold {thr}): "
            f"link {error.link} stands almost across the curve",
            "advice: move the curve more slowly (angle, radius), raise the gain K, or start with links more "
            "aligned with the curve (smaller start.beta)"]
