"""The coordinating law as one CasADi Function: the structured recursion, or the dense reference.

``(q, t) -> outputs`` named and ordered as :data:`~coordarm.symbolic.outputs.OUTPUTS` (the rail's
:data:`~coordarm.symbolic.outputs.RAIL_OUTPUTS` after them). Both forms take their margins from the
O(m) recursion (:mod:`.recursion`); the dense form and damping solve the decoupling matrix of
:mod:`.dense`.
"""
from __future__ import annotations

from typing import Sequence

import casadi as ca

from .laws import Law
from .recursion import StructuredRecursion


def law_function(recursion: StructuredRecursion, form: str, damping: dict | None,
                 names: Sequence[str]) -> ca.Function:
    """The control law ``(q, t) -> outputs`` as an MX Function.

    Parameters
    ----------
    recursion : StructuredRecursion
        The chain's recursion (its ``chain`` and ``task`` serve the dense solve too).
    form : {"structured", "dense"}
        ``"structured"``: ``u`` from the recursion (a loop over links); ``"dense"``: ``u`` from a
        QR solve of the dense eq. 27.
    damping : dict or None
        Damped least squares inside the band of small margins (see :func:`.dense.dense_controls`).
    names : sequence of str
        The outputs, in order (:data:`~coordarm.symbolic.outputs.OUTPUTS`, plus the rail's).

    Returns
    -------
    casadi.Function
        ``coordinating_law_<form>``: inputs ``q`` (dof,) and ``t`` [s], outputs ``names``.
    """
    chain = recursion.chain
    q, t = ca.MX.sym("q", chain.dof), ca.MX.sym("t")
    outs = recursion.outputs(q, t)
    if form == Law.DENSE or damping:
        from .dense import dense_controls          # here: the structured law without damping does not load it

        outs["u"] = dense_controls(chain, recursion.task, outs, q, t, form == Law.DENSE, damping)
    return ca.Function(f"coordinating_law_{form}", [q, t], [outs[n] for n in names], ["q", "t"], list(names))
