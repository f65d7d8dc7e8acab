"""Emit the C source of a :class:`~coordarm.symbolic.spatial_controller.SpatialController`'s law.

The structured form is small generated Functions of :mod:`.spatial_variants` and :mod:`.spatial_joints`
(the time features, the head, the per-link kinematics, pivot and rates steps, the end solve, the
joint rates), called by the C loops
of ``templates/spatial_law.c``: the code size does not grow with the number of links. The
dense form is the whole law as one Function (``templates/dense_law.c``). Both end with the
library's API of ``templates/library_api.c`` (law, control, RK4 step, chunk, sizes), the same entry
points as the planar library; the packed outputs follow
:func:`coordarm.symbolic.outputs.spatial_offsets` (``CA_OUT_<NAME>`` macros).

On a rail (``CA_RAIL`` = 1) the heads are the rail's (:func:`~.spatial_variants.spatial_rates_head`:
``d_dot``, the rail margin and ``psi(y^1)``; a commanded span reads the end's centre ``y^m`` from the
kinematics loop).
"""
from __future__ import annotations

import casadi as ca

from coordarm.symbolic import LAWS, BuildError, SpatialController
from coordarm.symbolic.laws import Law
from coordarm.symbolic.outputs import spatial_offsets, spatial_packed_width

from .codegen import Source, casadi_code, dense_law
from .render import render
from .spatial_joints import spatial_joint_prep, spatial_joint_rates
from .spatial_path import path_functions, path_source, searched
from .spatial_variants import (KIN_CARRY, LINK_GEOMETRY, RATE_CARRY, spatial_end_margin, spatial_frame_tail,
                               spatial_kinematics_head, spatial_kinematics_step, spatial_link_inv_det,
                               spatial_link_pivot, spatial_link_pivot_rates, spatial_rate_norm, spatial_rates_head,
                               spatial_rates_step, spatial_time_features)


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
        Structured: time features, the two heads (on a rail the rail's), kinematics step, link pivot's 1/det,
        link pivot, link pivot without e^j and margin, rates step, end solve, rate norm, end margin, joint prep,
        joint rates (on a 3-D path without the three pivot Functions, followed by the piece selector and each
        piece kind's pivots, :mod:`.spatial_path`); dense: the whole law.
    """
    if form != Law.STRUCTURED:
        return [ctrl.law(form)]
    pivots = ([spatial_link_inv_det(ctrl), spatial_link_pivot(ctrl), spatial_link_pivot_rates(ctrl)]
              if not searched(ctrl) else [])
    funcs = [spatial_time_features(ctrl), spatial_kinematics_head(ctrl), spatial_rates_head(ctrl),
             spatial_kinematics_step(ctrl), *pivots, spatial_rates_step(ctrl), spatial_frame_tail(ctrl),
             spatial_rate_norm(ctrl), spatial_end_margin(ctrl), spatial_joint_prep(), spatial_joint_rates()]
    return funcs + (path_functions(ctrl) if searched(ctrl) else [])


def spatial_law(ctrl: SpatialController) -> str:
    """The C of the structured spatial law: its size macros and ``templates/spatial_law.c``.

    Parameters
    ----------
    ctrl : SpatialController
        The controller (its time features set ``CA_NW``).

    Returns
    -------
    str
        ``CA_NW``, ``CA_NKC``, ``CA_NRC``, ``CA_NG``, ``CA_NPV`` definitions (on a 3-D path the pieces' tables and
        the pivot wrappers of :func:`~.spatial_path.path_source`) followed by the law's C (``ca_law``,
        ``CA_LAW_SCRATCH``).
    """
    return (f"#define CA_NW {int(spatial_time_features(ctrl).numel_out(0))}\n#define CA_NKC {KIN_CARRY}\n"
            f"#define CA_NRC {RATE_CARRY}\n#define CA_NG {LINK_GEOMETRY}\n"
            f"#define CA_NPV {spatial_rates_step(ctrl).n_in() - 1}\n"
            + (path_source(ctrl) if searched(ctrl) else "") + render("spatial_law.c"))


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
