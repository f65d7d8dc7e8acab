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
from coordarm.symbolic.outputs import OUTPUTS, offsets, packed_width

from . import templates

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
    return form == "structured" and not ctrl.damping


def structured_law(ctrl: CoordinatingController) -> str:
    """The C of the structured law (:data:`.templates.STRUCTURED_LAW`) with its re-pivoting macros.

    Parameters
    ----------
    ctrl : CoordinatingController
        The controller (its time terms of the re-pivoting step set ``CA_NW_REPIVOT``).

    Returns
    -------
    str
        ``CA_REPIVOT`` and ``CA_NW_REPIVOT`` definitions followed by the law's C.
    """
    return (f"#define CA_REPIVOT {controller_module.REPIVOT!r}\n"
            f"#define CA_NW_REPIVOT {int(ctrl.time_features_repivot().numel_out(0))}\n"
            + templates.STRUCTURED_LAW)


def functions(ctrl: CoordinatingController, form: str) -> list[ca.Function]:
    """The CasADi Functions the C of ``form`` calls (the structured form's time features first).

    The structured form adds the re-pivoting step and its time terms (called only at a state
    with a small link pivot); with damping, the whole law is one Function.
    """
    if _split(ctrl, form):
        return [ctrl.time_features(True), ctrl.first_carry(), ctrl.link_step_trig(), ctrl.tail(),
                ctrl.link_pivot(), ctrl.time_features_repivot(), ctrl.link_step_repivot()]
    return [ctrl.law(form)]


def _b_macros(ctrl: CoordinatingController) -> str:
    bd = ctrl.chain.b_diagonal
    if bd is None:
        raise BuildError("B: the compiled backend needs a diagonal input matrix B; "
                         "use backend='interpreted' for a full B")
    if np.all(bd == 1):
        return templates.B_IDENTITY
    return templates.B_DIAGONAL.format(values=", ".join(repr(float(v)) for v in bd))


def layout_macros(m: int) -> str:
    """C macros of the packed output vector for ``m`` links: ``CA_NOUT`` and ``CA_OUT_<NAME>`` offsets.

    Parameters
    ----------
    m : int
        Number of links.

    Returns
    -------
    str
        One ``#define`` per line, from :data:`coordarm.symbolic.outputs.LAW_OUTPUTS`.
    """
    lines = [f"#define CA_NOUT {packed_width(m)}"]
    lines += [f"#define CA_OUT_{name.upper()} {start}" for name, (start, _) in offsets(m).items()]
    return "\n".join(lines) + "\n"


def generate_source(ctrl: CoordinatingController, form: str = "structured") -> Source:
    """The C source of ``ctrl``'s law (``form``), RK4 step and chunk loop.

    Parameters
    ----------
    ctrl : CoordinatingController
        Chain (with a diagonal B), curve, gain and speed.
    form : {"structured", "dense"}
        Law form.

    Returns
    -------
    Source

    Raises
    ------
    BuildError
        A non-diagonal B, or an unknown form.
    """
    if form not in LAWS:
        raise BuildError(f"law: expected one of {LAWS}, got {form!r}")
    if ctrl.chain.rail and ctrl.governor:
        raise BuildError("governor: the governed rail law (two passes of the recursion) runs on the interpreted "
                         "backend; use backend 'interpreted' ('auto' falls back by itself)")
    if ctrl.chain.rail:
        raise BuildError("base: a chain on a rail runs on the interpreted backend for now (the compiled rail "
                         "glue was written for the glue before issue 15's vectorisation and is not ported yet); "
                         "use backend 'interpreted' ('auto' falls back by itself)")
    funcs = functions(ctrl, form)
    if _split(ctrl, form):
        law = structured_law(ctrl)
    else:
        results = "\n".join(f"  res[{i}] = {'u' if name == 'u' else 'out + CA_OUT_' + name.upper()};"
                            for i, name in enumerate(OUTPUTS))
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
    m = ctrl.chain.m
    parts = [templates.CASADI_BEGIN, cg.dump(), templates.CASADI_END,
             templates.HEADER.format(m=m, layout=layout_macros(m), b_diagonal=b_macros,
                                     **{f"sz_{k}": v for k, v in sizes.items()})]
    if _split(ctrl, form):
        parts.append(f"#define CA_NW {int(funcs[0].numel_out(0))}\n"
                     f"#define CA_NC {len(CoordinatingController.CARRY)}\n")
    parts += [law, api]
    return Source("\n".join(parts), form, m)
