"""Emit the C source of a controller: CasADi-generated Functions plus the glue of :mod:`.templates`.

The structured law is emitted as four small Functions (time features, first carry, one
link step, tail) and a C loop over links, so the code size and the compile time do not
grow with the number of links. The dense law (eq. 27) is emitted as one Function.
"""
from __future__ import annotations

from dataclasses import dataclass

import casadi as ca
import numpy as np

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


def _functions(ctrl: CoordinatingController, form: str) -> list[ca.Function]:
    if form == "structured" and ctrl.chain.rail:
        extra = [_psi_at(ctrl)] if ctrl.span is not None else []
        return [ctrl.time_features(), ctrl.rail_head(), ctrl.link_step(), ctrl.tail()] + extra
    if form == "structured":
        return [ctrl.time_features(), ctrl.first_carry(), ctrl.link_step(), ctrl.tail()]
    return [ctrl.law("dense")]


def _psi_at(ctrl: CoordinatingController) -> ca.Function:
    """``(y, t) -> psi``: the arc length at a point, for the span of a commanded rail run."""
    y, t = ca.SX.sym("y", 2), ca.SX.sym("t")
    return ca.Function("psi_at", [y, t], [ctrl._geometry(y, t)[3]], ["y", "t"], ["psi"])


def _b_macros(ctrl: CoordinatingController) -> str:
    bd = ctrl.chain.b_diagonal
    if bd is None:
        raise BuildError("B: the compiled backend needs a diagonal input matrix B; "
                         "use backend='interpreted' for a full B")
    if np.all(bd == 1):
        return templates.B_IDENTITY
    bd = np.r_[1.0, bd] if ctrl.chain.rail else bd          # qdot_d = u_d on a rail
    return templates.B_DIAGONAL.format(values=", ".join(repr(float(v)) for v in bd))


def layout_macros(m: int, rail: bool = False) -> str:
    """C macros of the packed output vector for ``m`` links: ``CA_NOUT`` and ``CA_OUT_<NAME>`` offsets.

    Parameters
    ----------
    m : int
        Number of links.
    rail : bool
        A chain on a rail (``u`` one wider, ``sigma`` and ``rail_margin`` added).

    Returns
    -------
    str
        One ``#define`` per line, from :data:`coordarm.symbolic.outputs.LAW_OUTPUTS`.
    """
    lines = [f"#define CA_NOUT {packed_width(m, rail)}"]
    lines += [f"#define CA_OUT_{name.upper()} {start}" for name, (start, _) in offsets(m, rail).items()]
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
        A non-diagonal B, the dense law of a chain on a rail, or an unknown form.
    """
    if form not in LAWS:
        raise BuildError(f"law: expected one of {LAWS}, got {form!r}")
    if ctrl.chain.rail and form != "structured":
        raise BuildError("law: a chain on a rail compiles the structured law only; use law 'structured' "
                         "or backend 'interpreted'")
    b_macros = _b_macros(ctrl)
    funcs = _functions(ctrl, form)
    cg = ca.CodeGenerator("coordarm", dict(CODEGEN_OPTIONS))
    for f in funcs:
        cg.add(f)
    sizes = {k: max(int(getattr(f, "sz_" + k)()) for f in funcs) + 1
             for k in ("arg", "res", "iw", "w")}
    m, n = ctrl.chain.m, ctrl.chain.dof
    parts = [templates.CASADI_BEGIN, cg.dump(), templates.CASADI_END,
             templates.HEADER.format(m=m, n=n, layout=layout_macros(m, ctrl.chain.rail), b_diagonal=b_macros,
                                     **{f"sz_{k}": v for k, v in sizes.items()})]
    if form == "structured":
        parts.append(f"#define CA_NW {int(funcs[0].numel_out(0))}\n"
                     f"#define CA_NC {len(CoordinatingController.CARRY)}\n")
        if ctrl.chain.rail:
            c, s_ = (float(v) for v in ctrl.chain.rail_direction)
            parts.append(f"#define CA_RAIL_C {c!r}\n#define CA_RAIL_S {s_!r}\n#define CA_HALF_XI {0.5 * ctrl.chain.xi!r}\n"
                         + ("#define CA_SPAN 1\n" if ctrl.span is not None else ""))
        parts.append(templates.RAIL_LAW if ctrl.chain.rail else templates.STRUCTURED_LAW)
    else:
        results = "\n".join(f"  res[{i}] = out + CA_OUT_{name.upper()};" for i, name in enumerate(OUTPUTS))
        parts.append(templates.DENSE_LAW.replace("{law_name}", funcs[0].name()).replace("{results}", results))
    parts.append(templates.LOOP)
    return Source("\n".join(parts), form, m)
