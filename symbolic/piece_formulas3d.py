"""The closed-form formulas of one piece of a 3-D path (:class:`~.paths3d.Path3D`): a line, a banked arc or a clothoid.

Each takes the piece's 28 constants (:func:`~.paths3d.piece_constants`) and a point ``y`` and gives
``(psi, Phi, frame)`` at ``y``'s closest point on the piece. :func:`piece_formulas3d` evaluates every kind
and selects by the constants' flag (the interpreted law, after the selection of the closest piece);
:func:`kind_formulas3d` evaluates one kind only (the generated C, which finds the piece and its kind
first, :mod:`coordarm.generated.spatial_path`).
"""
from __future__ import annotations

import casadi as ca

from .curves3d import as_column
from .transitions3d import spiral_formulas3d


def piece_formulas3d(sel, y, spirals: bool = False):
    """``(psi, Phi, frame)`` at ``y`` by the formulas of the piece whose constants are ``sel``.

    Parameters
    ----------
    sel : casadi.SX, casadi.MX or casadi.DM, shape (28,)
        The piece's :func:`piece_constants`.
    y : casadi.SX or casadi.MX, shape (3, 1)
        A point [m].
    spirals : bool
        The path has clothoid pieces (flag 2, :func:`~.transitions3d.spiral_formulas3d`): their
        formulas are selected for them too.

    Returns
    -------
    psi : casadi.SX
        Arc length [m].
    Phi : casadi.SX, shape (2, 1)
        Normal coordinates [m].
    frame : tuple of 3 casadi.SX, shape (3, 1)
        Tangent, ``n_1``, ``n_2`` at the closest point.
    """
    y = as_column(y)
    is_arc = sel[13] != 0
    psi_line, phi_line, frame_line = _line_formulas(sel, y)
    psi_arc, phi_arc, frame_arc = _arc_formulas(sel, y)
    frame = tuple(ca.if_else(is_arc, fa, fl) for fa, fl in zip(frame_arc, frame_line))
    psi, phi = ca.if_else(is_arc, psi_arc, psi_line), ca.if_else(is_arc, phi_arc, phi_line)
    if not spirals:
        return psi, phi, frame
    spiral = sel[13] == 2
    psi_s, phi_s, frame_s = spiral_formulas3d(sel, y)
    return (ca.if_else(spiral, psi_s, psi), ca.if_else(spiral, phi_s, phi),
            tuple(ca.if_else(spiral, a, b) for a, b in zip(frame_s, frame)))


def _line_formulas(sel, y):
    """``(psi, Phi, frame)`` of a line piece (:func:`piece_formulas3d`'s line branch)."""
    p0, t0, n1, n2, s0 = sel[0:3], sel[3:6], sel[6:9], sel[9:12], sel[12]
    v = y - p0
    return s0 + ca.dot(t0, v), ca.vertcat(ca.dot(n1, v), ca.dot(n2, v)), (t0, n1, n2)


def _arc_formulas(sel, y):
    """``(psi, Phi, frame)`` of an arc piece (:func:`piece_formulas3d`'s arc branch)."""
    s0, R, C, w, u0 = sel[12], sel[14], sel[15:18], sel[18:21], sel[21:24]
    c11, c12, c21, c22 = sel[24], sel[25], sel[26], sel[27]
    full = y - C
    z = ca.dot(full, w)
    r = full - z * w
    rho = ca.norm_2(r)
    u = r / rho
    a = ca.atan2(ca.dot(ca.cross(-u0, r), w), ca.dot(-u0, r))
    dev = R - rho
    psi_arc, phi_arc = s0 + R * a, ca.vertcat(c11 * dev + c12 * z, c21 * dev + c22 * z)
    return psi_arc, phi_arc, (ca.cross(w, u), -c11 * u + c12 * w, -c21 * u + c22 * w)


def kind_formulas3d(sel, y, kind: str):
    """``(psi, Phi, frame)`` at ``y`` by the formulas of one ``kind`` of piece only (constants ``sel``).

    Equal to :func:`piece_formulas3d` (with ``spirals`` set) for a piece of that kind, up to the sign
    of a zero: the same operations, without the other kinds' formulas and the selection between them.

    Parameters
    ----------
    sel : casadi.SX, shape (28,)
        The piece's :func:`piece_constants`.
    y : casadi.SX, shape (3, 1)
        A point [m].
    kind : {"line", "arc", "spiral"}
        The piece's :func:`piece_kind`.

    Returns
    -------
    tuple
        As :func:`piece_formulas3d`.
    """
    y = as_column(y)
    return {"line": _line_formulas, "arc": _arc_formulas, "spiral": spiral_formulas3d}[kind](sel, y)
