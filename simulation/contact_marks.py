"""Where and when links touched: the one description of contact marks on every figure and GIF frame.

A run with ``--allow-contact`` records the first contact of every (kind, links, obstacle) in
``run.info["contacts"]`` (a replayed log: its ``outcome`` metadata). Each is marked by a red ring
(:data:`CONTACT_STYLE`) on the centre of every touching link, where the link was at the contact's
time; the obstacle (or the kind) is named once, beside its first ring; the legend says
:func:`contact_note` and the title :func:`ended_note`. The stage figures (planar and spatial) and the
GIFs (planar and spatial) all draw them with :func:`draw_contact_marks`.
"""
from __future__ import annotations

from typing import Any, Sequence

import numpy as np

from coordarm.symbolic.records import record

#: Colour of the contact marks (and of the stage at which a run stopped).
CONTACT_COLOUR = "#d62728"
#: Line2D keywords of a contact ring (no line; a hollow red circle).
CONTACT_STYLE = dict(ls="", marker="o", mfc="none", mec=CONTACT_COLOUR, ms=11, mew=1.8)
#: Most contacts marked on one axes (the first ones on a stage figure, the latest ones on a GIF frame).
MOST_MARKED = 10


@record(frozen=True)
class ContactMark:
    """One recorded contact, placed.

    Attributes
    ----------
    time : float
        When it happened [s].
    points : ndarray, shape (k, 2) or (k, 3)
        The centres of the touching links at that time [m].
    what : str
        The obstacle's name, or the kind (``"self"``, ``"joint limit"``, ...).
    """

    time: float
    points: np.ndarray
    what: str


def recorded_contacts(run: Any) -> list[dict]:
    """The contact records of ``run`` (``run.info["contacts"]``), in time order; empty when there are none.

    Parameters
    ----------
    run : Run or namespace
        A run, with or without ``info``.

    Returns
    -------
    list of dict
        ``kind``, ``time`` [s], ``links`` (1-based) and ``obstacle`` (when an obstacle was touched) each.
    """
    return list((getattr(run, "info", None) or {}).get("contacts") or [])


def contact_marks(run: Any, chain: Any, contacts: Sequence[Any] | None = None) -> list[ContactMark]:
    """Contacts placed on ``chain``: the touching links' centres at the sample of ``run`` nearest each one's time.

    Parameters
    ----------
    run : Run or namespace
        ``t`` (N,) [s], ``q`` (N, dof) and (without ``contacts``) ``info["contacts"]``.
    chain : PlanarChain or SpatialChain
        The chain (its ``centres_np``).
    contacts : sequence of dict or Contact, optional
        The contacts to place (default: :func:`recorded_contacts` of ``run``), records or
        :class:`~.physical.Contact` objects (a run's check at given samples).

    Returns
    -------
    list of ContactMark
        One per contact, in the given order (links outside ``1..m`` are left out).
    """
    out = []
    for c in recorded_contacts(run) if contacts is None else contacts:
        c = c if isinstance(c, dict) else c.to_dict()
        k = int(np.argmin(np.abs(np.asarray(run.t) - float(c["time"]))))
        centres = chain.centres_np(run.q[k])
        links = [j - 1 for j in c.get("links", ()) if 1 <= j <= len(centres)]
        out.append(ContactMark(float(c["time"]), centres[links], c.get("obstacle") or c["kind"].replace("_", " ")))
    return out


def contact_note(count: int, first: float) -> str:
    """The legend label of the rings: ``"contacts: 6, first 2.32 s"``.

    Parameters
    ----------
    count : int
        Contacts recorded.
    first : float
        Time of the first [s].

    Returns
    -------
    str
    """
    return f"contacts: {count}, first {first:.2f} s"


def ended_note(outcome: str | None, contacts: int) -> str:
    """How a run ended, for a title: ``"completed, 6 contacts"``, ``"singularity"``, ``""``.

    Parameters
    ----------
    outcome : str or None
        The outcome's status (empty or None: not shown).
    contacts : int
        Contacts recorded.

    Returns
    -------
    str
        The parts that apply, joined by commas.
    """
    return ", ".join([outcome] * bool(outcome) + [f"{contacts} contact{'s' * (contacts != 1)}"] * bool(contacts))


def draw_contact_marks(ax: Any, marks: Sequence[ContactMark], axes: Sequence[int] = (0, 1), count: int | None = None,
                       names: bool = True, note: str | None = None, **artist: Any) -> list[Any]:
    """Rings on the links of ``marks`` (:data:`CONTACT_STYLE`), the first labelled :func:`contact_note`.

    Parameters
    ----------
    ax : matplotlib Axes or Axes3D
        Where to draw.
    marks : sequence of ContactMark
        The contacts to mark (at most :data:`MOST_MARKED` of them are drawn: pick them before).
    axes : sequence of int
        The coordinates drawn: ``(0, 1)`` on a plane, ``(0, 1, 2)`` on a 3-D axes, ``(0, 2)`` on a side view.
    count : int, optional
        Contacts in the legend label (default: ``len(marks)``).
    names : bool
        Name each obstacle (or kind) once, beside its first ring, below left of it (off a wall's label); 2-D only.
    note : str, optional
        The legend label of the rings instead of :func:`contact_note`.
    **artist
        Further Line2D keywords (``animated=True`` for a GIF).

    Returns
    -------
    list of Artist
        The rings and names drawn.
    """
    drawn, named = [], set()
    for i, mark in enumerate(marks[:MOST_MARKED]):
        label = (note or contact_note(len(marks) if count is None else count, marks[0].time)) if i == 0 else None
        drawn += ax.plot(*(mark.points[:, a] for a in axes), **CONTACT_STYLE, zorder=31, label=label, gid="contact",
                         **artist)
        if names and len(axes) == 2 and mark.what not in named and len(mark.points):
            named.add(mark.what)
            drawn.append(ax.annotate(mark.what, mark.points[0, list(axes)], xytext=(-8, -8), textcoords="offset points",
                                     ha="right", va="top", fontsize=7, color=CONTACT_COLOUR, zorder=31, **artist))
    return drawn
