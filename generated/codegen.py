"""Emit the C source of a controller: CasADi-generated Functions plus the glue of :mod:`.templates`.

The structured law is emitted as four small Functions (time features, first carry, one
link step without trigonometry, tail) and C loops over links (angles, all cosines and sines
in one vectorised loop, the recursion), so the code size and the compile time do not
grow with the number of links. The dense law (eq. 27) is emitted as one Function.
"""
from __future__ import annotations

from dataclasses import dataclass

import casadi as ca
import numpy as np

import coordarm.symbolic.controller as controller_module
from coordarm.symbolic import LAWS, BuildError, CoordinatingController
from coordarm.symbolic.laws import Law
from coordarm.symbolic.outputs import offsets, packed_width
from coordarm.symbolic.paths import Path

from . import templates
from .path_search import search_source

#: Options of CasADi's CodeGenerator (part of the cache key).
CODEGEN_OPTIONS = {"with_header": False, "casadi_real": "double", "casadi_int": "long long int"}


@dataclass(frozen=True)
class Source:
    """Generated C source of one controller.

    Attributes
    ----------
    text : str
        The complete C translation unit.
    form : str
        ``"structured"`` or ``"dense"``.
    m : int
        Number of links.
    """

    text: str
    form: str
    m: int


def _split(ctrl: CoordinatingController, form: str) -> bool:
    """Whether the law is emitted as per-link Functions and a C loop (structured, undamped)."""
    return form == Law.STRUCTURED and not ctrl.damping


def structured_law(ctrl: CoordinatingController, path_search: bool = True) -> str:
    """The C of the structured law (:data:`.templates.STRUCTURED_LAW`) with its re-pivoting macros.

    Parameters
    ----------
    ctrl : CoordinatingController
        The controller (its time terms of the re-pivoting step set ``CA_NW_REPIVOT``).
    path_search : bool
        On a path, search the closest piece in C (see :mod:`.path_search`); False: select it
        inside the generated link step, over every piece (the reference form, slower).

    Returns
    -------
    str
        ``CA_REPIVOT`` and ``CA_NW_REPIVOT`` definitions followed by the law's C.

    Notes
    -----
    With the governor on a rail (``CA_GOVERNED`` defined by :func:`rail_macros`) the C's
    ``#ifdef CA_GOVERNED`` blocks run the recursion twice, first with ``v_scale`` = 1 for the
    longitudinal margin (it does not depend on the rail rate), then with the head's governed rail
    rate, as the interpreted law does; for every other law the preprocessor drops them.
    """
    law = templates.STRUCTURED_LAW
    return (f"#define CA_REPIVOT {controller_module.REPIVOT!r}\n"
            f"#define CA_NW_REPIVOT {int(ctrl.time_features_repivot().numel_out(0))}\n"
            + rail_macros(ctrl) + (path_macros(ctrl) if path_search else "") + law)


def _governed_rail(ctrl: CoordinatingController) -> bool:
    """Whether the law is the governor on a rail (its C runs the recursion twice: ``CA_GOVERNED``)."""
    return bool(ctrl.chain.rail and ctrl.governor)


def path_macros(ctrl: CoordinatingController) -> str:
    """The C of the closest-piece search on a path (tables and :data:`.templates.PATH_SEARCH`), else "".

    Parameters
    ----------
    ctrl : CoordinatingController
        The controller.

    Returns
    -------
    str
        ``CA_PATH`` macros, the piece tables and the search, or an empty string for other curves.
    """
    if not _searched(ctrl):
        return ""
    return ("#define CA_PATH_SCRATCH (6 * CA_M)\n"
            + search_source(ctrl.curve)
            + templates.PATH_SEARCH)


def functions(ctrl: CoordinatingController, form: str, path_search: bool = True) -> list[ca.Function]:
    """The CasADi Functions the C of ``form`` calls (the structured form's time features first).

    The structured form adds the re-pivoting step and its time terms (called only at a state
    with a small link pivot); with damping, the whole law is one Function. With the governor
    on a rail, the head takes ``v_scale`` (the C calls it twice, see :func:`structured_law`).
    """
    if _split(ctrl, form):
        if path_search and _searched(ctrl):
            tf, geometry, step = ctrl.piece_steps()
            return [tf, _head(ctrl), step, ctrl.tail(), geometry["line"], ctrl.time_features_repivot(),
                    ctrl.link_step_repivot(), ctrl.curve.frame_function(), geometry["arc"],
                    ctrl.tail_piece("line"), ctrl.tail_piece("arc")]
        return [ctrl.time_features(True), _head(ctrl), ctrl.link_step_trig(), ctrl.tail(),
                ctrl.link_pivot(), ctrl.time_features_repivot(), ctrl.link_step_repivot()]
    return [ctrl.law(form)]


def _searched(ctrl: CoordinatingController) -> bool:
    """Whether the C glue searches the closest piece of a path itself (see :mod:`.path_search`)."""
    return isinstance(ctrl.curve, Path)


def _head(ctrl: CoordinatingController) -> ca.Function:
    """The Function that starts the recursion: the first carry, or on a rail the rail head (with the
    span computed from the end's centre when it is commanded)."""
    if not ctrl.chain.rail:
        return ctrl.first_carry()
    governed = _governed_rail(ctrl)
    return ctrl.rail_head_from_end(governed) if ctrl.span is not None else ctrl.rail_head(governed)


def rail_macros(ctrl: CoordinatingController) -> str:
    """C macros of a chain on a rail: the rail's direction, half a link and the head's name.

    Parameters
    ----------
    ctrl : CoordinatingController
        The controller (on a rail; a fixed base gives an empty string).

    Returns
    -------
    str
        ``CA_RAIL_C``, ``CA_RAIL_S``, ``CA_RAIL_HEAD`` and, for a commanded span,
        ``CA_SPAN``, with the governor ``CA_GOVERNED`` definitions.
    """
    if not ctrl.chain.rail:
        return ""
    c, s = (float(v) for v in ctrl.chain.rail_direction)
    return (f"#define CA_RAIL_C {c!r}\n#define CA_RAIL_S {s!r}\n"
            f"#define CA_RAIL_HEAD {_head(ctrl).name()}\n" + ("#define CA_SPAN 1\n" if ctrl.span is not None else "")
            + ("#define CA_GOVERNED 1\n" if _governed_rail(ctrl) else ""))


def _b_macros(ctrl: CoordinatingController) -> str:
    bd = ctrl.chain.b_diagonal
    if bd is None:
        raise BuildError("B: the compiled backend needs a diagonal input matrix B; "
                         "use backend='interpreted' for a full B")
    if np.all(bd == 1):
        return templates.B_IDENTITY
    if ctrl.chain.rail:
        bd = np.r_[1.0, bd]                           # qdot_d = u_d on a rail
    return templates.B_DIAGONAL.format(values=", ".join(repr(float(v)) for v in bd))


def layout_macros(m: int, rail: bool = False) -> str:
    """C macros of the packed output vector for ``m`` links: ``CA_NOUT`` and ``CA_OUT_<NAME>`` offsets.

    Parameters
    ----------
    m : int
        Number of links.
    rail : bool
        A chain on a rail (``u`` one wider, then ``sigma`` and ``rail_margin``).

    Returns
    -------
    str
        One ``#define`` per line, from :data:`coordarm.symbolic.outputs.LAW_OUTPUTS`.
    """
    lines = [f"#define CA_NOUT {packed_width(m, rail)}"]
    lines += [f"#define CA_OUT_{name.upper()} {start}" for name, (start, _) in offsets(m, rail).items()]
    return "\n".join(lines) + "\n"


def generate_source(ctrl: CoordinatingController, form: str = "structured", path_search: bool = True) -> Source:
    """The C source of ``ctrl``'s law (``form``), RK4 step and chunk loop.

    Parameters
    ----------
    ctrl : CoordinatingController
        Chain (with a diagonal B), curve, gain and speed.
    form : {"structured", "dense"}
        Law form.
    path_search : bool
        See :func:`structured_law`.

    Returns
    -------
    Source

    Raises
    ------
    BuildError
        A non-diagonal B, or an unknown form.

    Notes
    -----
    A chain on a rail compiles too: ``q`` and ``u`` have ``d`` and ``d_dot`` first, and the packed
    outputs end with ``sigma`` and ``rail_margin`` (:func:`coordarm.symbolic.outputs.offsets`).
    """
    if form not in LAWS:
        raise BuildError(f"law: expected one of {LAWS}, got {form!r}")
    funcs = functions(ctrl, form, path_search)
    if _split(ctrl, form):
        law = structured_law(ctrl, path_search)
    else:
        results = "\n".join(f"  res[{i}] = {'u' if name == 'u' else 'out + CA_OUT_' + name.upper()};"
                            for i, name in enumerate(ctrl.outputs))
        law = templates.DENSE_LAW.replace("{law_name}", funcs[0].name()).replace("{results}", results)
    return assemble_source(ctrl, funcs, law, form)


def assemble_source(ctrl: CoordinatingController, funcs: list[ca.Function], law: str, form: str, *,
                    name: str = "coordarm", api: str = templates.LOOP) -> Source:
    """One translation unit: the generated ``funcs``, the glue header, the C ``law`` and the ``api``.

    ``law`` defines ``ca_law`` and ``CA_LAW_SCRATCH`` (see :mod:`.templates`); for the
    structured form, ``funcs[0]`` is the time-features Function (its size sets ``CA_NW``).
    ``name`` prefixes CasADi's helper symbols.
    """
    b_macros = _b_macros(ctrl)
    cg = ca.CodeGenerator(name, dict(CODEGEN_OPTIONS))
    for f in funcs:
        cg.add(f)
    sizes = {k: max(int(getattr(f, "sz_" + k)()) for f in funcs) + 1
             for k in ("arg", "res", "iw", "w")}
    m, rail = ctrl.chain.m, ctrl.chain.rail
    parts = [templates.CASADI_BEGIN, cg.dump(), templates.CASADI_END,
             templates.HEADER.format(m=m, nq=ctrl.chain.dof, half_xi=repr(0.5 * ctrl.chain.xi), rail=int(rail),
                                     layout=layout_macros(m, rail), b_diagonal=b_macros,
                                     **{f"sz_{k}": v for k, v in sizes.items()})]
    if _split(ctrl, form):
        parts.append(f"#define CA_NW {int(funcs[0].numel_out(0))}\n"
                     f"#define CA_NC {len(CoordinatingController.CARRY)}\n")
    parts += [law, api]
    return Source("\n".join(parts), form, m)
