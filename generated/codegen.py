"""Emit the C source of a controller: CasADi-generated Functions plus the hand-written C glue of the
templates (``templates/*.c``, filled by :func:`.render.render`).

The structured law is emitted as four small Functions (time features, first carry, one
link step without trigonometry, tail) and C loops over links (angles, all cosines and sines
in one vectorised loop, the recursion), so the code size and the compile time do not
grow with the number of links. The dense law (eq. 27) is emitted as one Function.

The glue defines the library's whole API (every other symbol is hidden):

* ``coordarm_law(q, t, out, iw, w)``: the law at ``(q, t)``; ``out`` is the packed output
  vector of :data:`coordarm.symbolic.outputs.LAW_OUTPUTS` (``CA_NOUT`` doubles, each output
  at its offset ``CA_OUT_<NAME>``, macros emitted by :func:`layout_macros` from that table);
* ``coordarm_control(q, t, u, out, iw, w)``: the same with ``u`` written to an array of its own
  (``out`` receives the other outputs at their offsets; its ``u`` part is left alone), so a
  caller's arrays are written without copies;
* ``coordarm_rk4(q, t, h, q_next, out, iw, w)``: one closed-loop RK4 step, ``out`` being
  the law at the step's start;
* ``coordarm_chunk(q0, times, h, n, Q, D, iw, w)``: ``n`` RK4 steps in one call;
* ``coordarm_sizes(sizes)``: ``m``, ``len(out)``, ``len(iw)``, ``len(w)``.

On a chain on a rail (``CA_RAIL`` = 1) the state has ``CA_NQ = CA_M + 1`` joints, ``d`` first:
``q``, ``u`` and the RK4 and chunk states are ``CA_NQ`` long, the recursion starts from the
generated rail head (``d_dot``, the rail margin, ``psi(y^1)``) and the packed outputs end with
``sigma`` and ``rail_margin``; with a fixed base ``CA_NQ = CA_M``.

A law or step call returns 1 when ``q`` or ``t`` is not finite (nothing is computed), 2 when
a generated Function failed, 3 when it produced a non-finite output, 0 otherwise. All
finiteness checks test the IEEE bits, so they hold under ``-ffast-math`` too.
"""
from __future__ import annotations

from typing import Sequence

import casadi as ca
import numpy as np

import coordarm.symbolic.recursion as recursion_module
from coordarm.symbolic import LAWS, BuildError, CoordinatingController
from coordarm.symbolic.carry import CARRY
from coordarm.symbolic.laws import Law
from coordarm.symbolic.outputs import offsets, packed_width
from coordarm.symbolic.paths import Path

from . import link_variants
from .path_search import search_source
from .render import render
from .source import CODEGEN_OPTIONS, Source  # noqa: F401 (re-exported)

def _split(ctrl: CoordinatingController, form: str) -> bool:
    """Whether the law is emitted as per-link Functions and a C loop (structured, undamped)."""
    return form == Law.STRUCTURED and not ctrl.damping


def structured_law(ctrl: CoordinatingController, path_search: bool = True) -> str:
    """The C of the structured law (``trig_passes.c``, ``structured_law.c``) with its re-pivoting macros.

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
    The law takes the angles and all their cosines and sines in loops without loop-carried
    dependence (``trig_passes.c``: glibc's vector ``cos``/``sin`` of libmvec are declared there on
    x86-64, so the loops vectorise under ``-O3 -fno-math-errno`` without ``-ffast-math``, which would
    break the non-finite checks; elsewhere, or with ``-DCOORDARM_SCALAR_TRIG``, they stay scalar), then runs
    the O(m) recursion calling the generated per-link step (which has no trigonometry), then the
    tail and the rates. If some link's pivot is small (margin below ``CA_REPIVOT`` or NaN) the
    recursion only raises a flag and the whole law is evaluated again, out of line, with the
    re-pivoting step (``ca_law_repivot``).

    With the governor on a rail (``CA_GOVERNED`` defined by :func:`rail_macros`) the C's
    ``#ifdef CA_GOVERNED`` blocks run the recursion twice, first with ``v_scale`` = 1 for the
    longitudinal margin (it does not depend on the rail rate), then with the head's governed rail
    rate, as the interpreted law does; for every other law the preprocessor drops them.
    """
    law = render("trig_passes.c") + render("structured_law.c")
    return (f"#define CA_REPIVOT {recursion_module.REPIVOT!r}\n"
            f"#define CA_NW_REPIVOT {int(ctrl.recursion.time_features_repivot().numel_out(0))}\n"
            + rail_macros(ctrl) + (path_macros(ctrl) if path_search else "") + law)


def _governed_rail(ctrl: CoordinatingController) -> bool:
    """Whether the law is the governor on a rail (its C runs the recursion twice: ``CA_GOVERNED``)."""
    return bool(ctrl.chain.rail and ctrl.governor)


def path_macros(ctrl: CoordinatingController) -> str:
    """The C of the closest-piece search on a path (tables and ``path_search.c``), else "".

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
            + render("path_search.c"))


def functions(ctrl: CoordinatingController, form: str, path_search: bool = True) -> list[ca.Function]:
    """The CasADi Functions the C of ``form`` calls (the structured form's time features first).

    The structured form adds the re-pivoting step and its time terms (called only at a state
    with a small link pivot); with damping, the whole law is one Function. With the governor
    on a rail, the head takes ``v_scale`` (the C calls it twice, see :func:`structured_law`).

    Parameters
    ----------
    ctrl : CoordinatingController
        The controller.
    form : {"structured", "dense"}
        Form of the law; only the undamped structured form is split into per-link Functions.
    path_search : bool
        On a path, the C searches the closest piece itself (the piece step Functions of
        :mod:`.link_variants`); False: the piece is selected inside the generated link step,
        over every piece (the reference form, slower).

    Returns
    -------
    list of casadi.Function
        In the order the C glue calls them; the whole law alone when it is not split.
    """
    if _split(ctrl, form):
        rec = ctrl.recursion
        if path_search and _searched(ctrl):
            tf, geometry, step = link_variants.piece_steps(ctrl)
            spiral = ([geometry["spiral"], link_variants.tail_piece(ctrl, "spiral")]
                      if "spiral" in geometry else [])
            return [tf, _head(ctrl), step, rec.tail(), geometry["line"], rec.time_features_repivot(),
                    rec.link_step_repivot(), ctrl.curve.frame_function(), geometry["arc"],
                    link_variants.tail_piece(ctrl, "line"), link_variants.tail_piece(ctrl, "arc")] + spiral
        return [link_variants.time_features_trig(ctrl), _head(ctrl), link_variants.link_step_trig(ctrl), rec.tail(),
                link_variants.link_pivot(ctrl), rec.time_features_repivot(), rec.link_step_repivot()]
    return [ctrl.law(form)]


def _searched(ctrl: CoordinatingController) -> bool:
    """Whether the C glue searches the closest piece of a path itself (see :mod:`.path_search`)."""
    return isinstance(ctrl.curve, Path)


def _head(ctrl: CoordinatingController) -> ca.Function:
    """The Function that starts the recursion: the first carry, or on a rail the rail head (with the
    span computed from the end's centre when it is commanded)."""
    if not ctrl.chain.rail:
        return ctrl.recursion.first_carry()
    governed = _governed_rail(ctrl)
    return (link_variants.rail_head_from_end(ctrl, governed) if ctrl.span is not None
            else ctrl.recursion.rail_head(governed))


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
    """``CA_U_FROM_QDOT`` and ``CA_K_FROM_U`` (``u = qdot / diag(B)``, ``k = diag(B) u`` over all ``CA_NQ``
    joints: on a rail ``d`` first, with ``qdot_d = u_d``), plain copies for B = I."""
    bd = ctrl.chain.b_diagonal
    if bd is None:
        raise BuildError("B: the compiled backend needs a diagonal input matrix B; "
                         "use backend='interpreted' for a full B")
    if np.all(bd == 1):
        return render("b_identity.h")
    if ctrl.chain.rail:
        bd = np.r_[1.0, bd]                           # qdot_d = u_d on a rail
    return render("b_diagonal.h", values=", ".join(repr(float(v)) for v in bd))


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


def dense_law(law: ca.Function, outputs: Sequence[str]) -> str:
    """C of ``ca_law`` for the dense form: one call of the generated ``law``, its results packed.

    Parameters
    ----------
    law : casadi.Function
        The generated law ``(q, t) -> outputs``.
    outputs : sequence of str
        Its output names, in order (``u`` first, the others packed at ``CA_OUT_<NAME>``).

    Returns
    -------
    str
        ``dense_law.c`` rendered.
    """
    results = "\n".join(f"  res[{i}] = {'u' if name == 'u' else 'out + CA_OUT_' + name.upper()};"
                        for i, name in enumerate(outputs))
    return render("dense_law.c", law_name=law.name(), results=results)


def casadi_code(funcs: list[ca.Function], name: str) -> tuple[str, dict[str, int]]:
    """CasADi's C of ``funcs`` (wrapped in ``casadi.c``) and the work sizes the glue needs.

    Parameters
    ----------
    funcs : list of casadi.Function
        The Functions the C calls.
    name : str
        Prefix of CasADi's helper symbols.

    Returns
    -------
    code : str
        ``casadi.c`` rendered around the generated Functions.
    sizes : dict
        ``arg``, ``res``, ``iw``, ``w``: the largest of each over ``funcs``, plus one.
    """
    cg = ca.CodeGenerator(name, dict(CODEGEN_OPTIONS))
    for f in funcs:
        cg.add(f)
    sizes = {k: max(int(getattr(f, "sz_" + k)()) for f in funcs) + 1
             for k in ("arg", "res", "iw", "w")}
    return render("casadi.c", functions=cg.dump()), sizes


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
        The C text, with the form and the link count.

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
        law = dense_law(funcs[0], ctrl.outputs)
    return assemble_source(ctrl, funcs, law, form)


def assemble_source(ctrl: CoordinatingController, funcs: list[ca.Function], law: str, form: str, *,
                    name: str = "coordarm", api: str | None = None) -> Source:
    """One translation unit: the generated ``funcs``, the glue's prelude, the C ``law`` and the ``api``.

    Parameters
    ----------
    ctrl : CoordinatingController
        The controller (its chain sets the sizes and the B macros).
    funcs : list of casadi.Function
        The Functions the C calls; for the structured form ``funcs[0]`` is the time-features
        Function (its size sets ``CA_NW``).
    law : str
        C defining ``ca_law`` and ``CA_LAW_SCRATCH`` (:func:`structured_law` or ``dense_law.c``).
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

    Raises
    ------
    BuildError
        A non-diagonal B.

    Notes
    -----
    ``casadi.c`` silences ``-Wunused-parameter`` around CasADi's code only (it declares every
    Function with the full signature ``(arg, res, iw, w, mem)``); the glue compiles with every warning.
    """
    b_macros = _b_macros(ctrl)
    code, sizes = casadi_code(funcs, name)
    m, rail = ctrl.chain.m, ctrl.chain.rail
    parts = [code,
             render("prelude.c", m=m, nq=ctrl.chain.dof, half_xi=repr(0.5 * ctrl.chain.xi), rail=int(rail),
                    layout=layout_macros(m, rail), b_macros=b_macros, **{f"sz_{k}": v for k, v in sizes.items()})]
    if _split(ctrl, form):
        parts.append(f"#define CA_NW {int(funcs[0].numel_out(0))}\n"
                     f"#define CA_NC {CARRY.size}\n")
    parts += [law, render("library_api.c") if api is None else api]
    return Source("\n".join(parts), form, m)
