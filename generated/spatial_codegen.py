"""Emit the C source of a :class:`~coordarm.symbolic.spatial_controller.SpatialController`'s law.

The structured form is four small generated Functions (the time features and the per-link step of
:mod:`.spatial_variants`, the head and the end solve of
:class:`~coordarm.symbolic.spatial_recursion.SpatialRecursion`) and the joint step, called by the C
loops of ``templates/spatial_law.c``: the code size does not grow with the number of links. The
dense form is the whole law as one Function (``templates/dense_law.c``). Both end with the
library's API of ``templates/library_api.c`` (law, control, RK4 step, chunk, sizes), the same entry
points as the planar library; the packed outputs follow
:func:`coordarm.symbolic.outputs.spatial_offsets` (``CA_OUT_<NAME>`` macros).

On a rail (``CA_RAIL`` = 1) the structured form's head is the rail head (:func:`spatial_rail_head`,
``CA_RAIL_HEAD``): ``d_dot``, the rail margin and ``psi(y^1)`` with link 1's carry; the rail direction is
``CA_RAIL_X/Y/Z`` and a commanded span (``CA_SPAN``) reads the end's centre ``y^m``, summed in the C.
"""
from __future__ import annotations

import casadi as ca
import numpy as np

from coordarm.symbolic import LAWS, BuildError, SpatialController
from coordarm.symbolic.laws import Law
from coordarm.symbolic.outputs import spatial_offsets, spatial_packed_width
from coordarm.symbolic.spatial_recursion import SPATIAL_CARRY

from .codegen import Source, casadi_code, dense_law
from .render import render
from .spatial_variants import (JOINT_CARRY, spatial_joint_step_trig, spatial_link_inv_det, spatial_link_step_trig,
                               spatial_time_features)


def spatial_layout_macros(m: int, rail: bool = False) -> str:
    """C macros of the spatial packed output vector: ``CA_NOUT`` and ``CA_OUT_<NAME>`` offsets.

    Parameters
    ----------
    m : int
        Number of links.
    rail : bool
        A chain on a rail (``u`` one wider, then ``sigma`` and ``rail_margin``).

    Returns
    -------
    str
        One ``#define`` per line, from :func:`coordarm.symbolic.outputs.spatial_outputs_of`.
    """
    lines = [f"#define CA_NOUT {spatial_packed_width(m, rail)}"]
    lines += [f"#define CA_OUT_{name.upper()} {start}" for name, (start, _) in spatial_offsets(m, rail).items()]
    return "\n".join(lines) + "\n"


def spatial_rail_head(ctrl: SpatialController) -> ca.Function:
    """The head of the generated C on a rail: the interpreted rail head, or with a commanded span its
    variant that takes the end's centre ``y^m`` [m] instead of ``sigma`` (``sigma = psi(y^m) - psi(y^1)``).

    Parameters
    ----------
    ctrl : SpatialController
        The controller (its chain on a rail).

    Returns
    -------
    casadi.Function
        ``(d, ab_1, t, sigma or y_m) -> (carry, roll, roll_row, roll_rhs, roll_scale, d_dot, rail_margin, psi_1)``.
    """
    head = ctrl.recursion.rail_head()
    if ctrl.span is None:
        return head
    d, ab, t, y_m = ca.SX.sym("d"), ca.SX.sym("ab", 2), ca.SX.sym("t"), ca.SX.sym("y_m", 3)
    geometry = ctrl.task.geometry
    sigma = geometry(y_m, t)[3] - geometry(d * ca.DM(ctrl.chain.rail_direction), t)[3]
    outs = head(d, ab, t, sigma)
    both = ca.cse(ca.vertcat(*[ca.vec(o) for o in outs]))
    sizes = np.cumsum([0] + [o.numel() for o in outs])
    parts = [ca.reshape(both[a:b], o.size1(), o.size2()) for a, b, o in zip(sizes[:-1], sizes[1:], outs)]
    return ca.Function("spatial_rail_head_from_end", [d, ab, t, y_m], parts, ["d", "ab", "t", "y_m"],
                       head.name_out())


def spatial_rail_macros(ctrl: SpatialController) -> str:
    """C macros of a spatial chain on a rail: the rail's unit direction, the head's name, a commanded span.

    Parameters
    ----------
    ctrl : SpatialController
        The controller (a fixed base gives an empty string).

    Returns
    -------
    str
        ``CA_RAIL_X/Y/Z``, ``CA_RAIL_HEAD`` and (a commanded span) ``CA_SPAN``, one ``#define`` per line.
    """
    if not ctrl.chain.rail:
        return ""
    x, y, z = (repr(float(v)) for v in ctrl.chain.rail_direction)
    return (f"#define CA_RAIL_X {x}\n#define CA_RAIL_Y {y}\n#define CA_RAIL_Z {z}\n"
            f"#define CA_RAIL_HEAD {spatial_rail_head(ctrl).name()}\n"
            + ("#define CA_SPAN 1\n" if ctrl.span is not None else ""))


def spatial_functions(ctrl: SpatialController, form: str) -> list[ca.Function]:
    """The CasADi Functions the C of ``form`` calls (the structured form's time features first).

    Parameters
    ----------
    ctrl : SpatialController
        The controller.
    form : {"structured", "dense"}
        Form of the law.

    Returns
    -------
    list of casadi.Function
        Structured: time features, head (on a rail the rail head), link step, end solve, joint step, link pivot's
        1/det; dense: the whole law.
    """
    if form == Law.STRUCTURED:
        rec = ctrl.recursion
        head = spatial_rail_head(ctrl) if ctrl.chain.rail else rec.head()
        return [spatial_time_features(ctrl), head, spatial_link_step_trig(ctrl), rec.tail(),
                spatial_joint_step_trig(), spatial_link_inv_det(ctrl)]
    return [ctrl.law(form)]


def spatial_law(ctrl: SpatialController) -> str:
    """The C of the structured spatial law: its size macros and ``templates/spatial_law.c``.

    Parameters
    ----------
    ctrl : SpatialController
        The controller (its time features set ``CA_NW``).

    Returns
    -------
    str
        ``CA_NW``, ``CA_NC``, ``CA_NJC`` definitions followed by the law's C (``ca_law``, ``CA_LAW_SCRATCH``).
    """
    return (f"#define CA_NW {int(spatial_time_features(ctrl).numel_out(0))}\n#define CA_NC {SPATIAL_CARRY}\n"
            f"#define CA_NJC {JOINT_CARRY}\n" + spatial_rail_macros(ctrl) + render("spatial_law.c"))


def generate_spatial_source(ctrl: SpatialController, form: str = "structured") -> Source:
    """The C source of a spatial controller's law (``form``), RK4 step and chunk loop.

    Parameters
    ----------
    ctrl : SpatialController
        Spatial chain (``B = I``), 3-D curve, gain, speed and roll command.
    form : {"structured", "dense"}
        Law form.

    Returns
    -------
    Source
        The C text, with the form and the link count.

    Raises
    ------
    BuildError
        An unknown form.
    """
    if form not in LAWS:
        raise BuildError(f"law: expected one of {LAWS}, got {form!r}")
    funcs = spatial_functions(ctrl, form)
    if form == Law.STRUCTURED:
        law = spatial_law(ctrl)
    else:
        law = dense_law(funcs[0], ctrl.outputs)
    return assemble_spatial_source(ctrl, funcs, law, form)


def assemble_spatial_source(ctrl: SpatialController, funcs: list[ca.Function], law: str, form: str, *,
                            name: str = "coordarm", api: str | None = None) -> Source:
    """One translation unit: the generated ``funcs``, the prelude (spatial layout, ``B = I``), ``law`` and ``api``.

    Parameters
    ----------
    ctrl : SpatialController
        The controller (its chain sets the sizes).
    funcs : list of casadi.Function
        The Functions the C calls.
    law : str
        C defining ``ca_law`` and ``CA_LAW_SCRATCH``.
    form : str
        ``"structured"`` or ``"dense"``.
    name : str
        Prefix of CasADi's helper symbols.
    api : str, optional
        C of the entry points (default: the library's, ``library_api.c``).

    Returns
    -------
    Source
        The C text, with the form and the link count.
    """
    code, sizes = casadi_code(funcs, name)
    m, rail = ctrl.chain.m, ctrl.chain.rail
    prelude = render("prelude.c", m=m, nq=ctrl.chain.dof, half_xi=repr(0.5 * ctrl.chain.xi), rail=int(rail),
                     layout=spatial_layout_macros(m, rail), b_macros=render("b_identity.h"),
                     **{f"sz_{k}": v for k, v in sizes.items()})
    parts = [code, prelude, law, render("library_api.c") if api is None else api]
    return Source("\n".join(parts), form, m)
