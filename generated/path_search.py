"""The closest piece of a composite path, searched by the generated C near the previous link's piece.

Consecutive central points are one link apart, so the C glue carries the piece found for link
``j - 1`` and starts link ``j``'s search there (``templates/path_search.c``): the first piece
whose closest-point range holds the point (its ``|phi| = delta``) bounds every other candidate,
because a piece ``k`` can only be closer if the two pieces come within ``2 delta`` of each other.
Each piece lists the others by a lower bound of that distance (discs around finite pieces,
half-lines for the rays), sorted, so the search tests only the pieces that may be closer and
returns the same piece as the full selection of :func:`coordarm.symbolic.path_pieces.closest_piece_formulas`
(the first, in order, of the candidates with the smallest ``|phi|``; pieces that tie to rounding give
the same law, ``phi`` being C1 across a junction). The link step then takes that piece's constants
(:func:`coordarm.generated.link_variants.piece_steps`).
"""
from __future__ import annotations

import math

import numpy as np

from coordarm.symbolic.path_pieces import PIECE_CONSTANTS, Piece, piece_parameters
from coordarm.symbolic.paths import Path

#: Relative slack on the lower bounds (rounding of the tables and of ``|phi|`` in the search).
SLACK = 1e-9


def _shape(piece: Piece, first: bool) -> tuple[str, np.ndarray, np.ndarray | float]:
    """A set containing the piece: ``("disc", centre, radius)``, ``("ray", start, direction)`` or ``("all", ...)``."""
    before = piece.ray_before or first
    after = not math.isfinite(piece.length)
    if before and after:
        return "all", piece.p0, 0.0
    if before:                              # the piece and the ray before it: back from its end
        return "ray", piece.end()[0] if piece.length > 0 else piece.p0, -piece.d0
    if after:
        return "ray", piece.p0, piece.d0
    end = piece.end()[0]                    # an arc piece turns at most 2 pi / 3: its chord's disc holds it
    return "disc", 0.5 * (piece.p0 + end), 0.5 * float(np.linalg.norm(end - piece.p0))


def _point_ray(x: np.ndarray, start: np.ndarray, u: np.ndarray) -> float:
    return float(np.linalg.norm(x - (start + max(0.0, float((x - start) @ u)) * u)))


def _rays_cross(p: np.ndarray, u: np.ndarray, q: np.ndarray, v: np.ndarray) -> bool:
    det = u[0] * (-v[1]) + v[0] * u[1]
    if abs(det) < 1e-15:
        return False                         # parallel: the end-point distances below decide
    r = q - p
    a = (r[0] * (-v[1]) + v[0] * r[1]) / det
    b = (u[0] * r[1] - u[1] * r[0]) / det
    return a >= 0 and b >= 0


def lower_bound(a: tuple, b: tuple) -> float:
    """A lower bound of the distance between two shapes of :func:`_shape` [m].

    Parameters
    ----------
    a, b : tuple
        Sets containing a path piece: ``("disc", centre, radius)``, ``("ray", start, unit direction)``
        or ``("all", point, 0.0)``; points and directions shape (2,) [m], radius [m].

    Returns
    -------
    float
        A distance [m] no larger than the distance between the two sets (0 when either is ``"all"``).
    """
    if a[0] == "all" or b[0] == "all":
        return 0.0
    if a[0] == "disc" and b[0] == "disc":
        return max(0.0, float(np.linalg.norm(a[1] - b[1])) - a[2] - b[2])
    if a[0] == "ray" and b[0] == "ray":
        if _rays_cross(a[1], a[2], b[1], b[2]):
            return 0.0
        return min(_point_ray(a[1], *b[1:]), _point_ray(b[1], *a[1:]))
    disc, ray = (a, b) if a[0] == "disc" else (b, a)
    return max(0.0, _point_ray(disc[1], ray[1], ray[2]) - disc[2])


def search_tables(path: Path) -> dict:
    """The tables of the C search for ``path`` (numbers only; formatted by :func:`search_source`).

    Parameters
    ----------
    path : Path
        The path (its pieces, in its own frame).

    Returns
    -------
    dict
        ``params`` (n, PIECE_CONSTANTS) piece constants (with the derived ones), ``junction`` (n, 3) ``(d0, d0 . p0)``, ``formula`` (n, 5)
        (line: ``n0, n0 . p0``; arc: centre, radius, towards the middle; clothoid: those of its
        approximating arc, :meth:`~coordarm.symbolic.path_pieces.Piece.wedge`), ``flags`` (n,) (1: arc or
        clothoid, 2: no start test, 4: no end test, 8: clothoid), ``start`` (n + 1,), ``others`` and ``bounds``: piece
        ``i``'s list of the other pieces and their lower bounds, ascending, at
        ``start[i]:start[i + 1]``; ``eps`` [m], the slack of the comparison ``bound <= 2 delta + eps``.
    """
    pieces = path.pieces
    n = len(pieces)
    params = np.array([piece_parameters(pc, derived=True) for pc in pieces])
    junction = np.array([[pc.d0[0], pc.d0[1], float(pc.d0 @ pc.p0)] for pc in pieces])
    formula, flags = np.zeros((n, 5)), np.zeros(n, dtype=int)
    for i, pc in enumerate(pieces):
        if pc.k == 0 and pc.c == 0:
            n0 = pc.n0
            formula[i, :3] = (n0[0], n0[1], float(n0 @ pc.p0))
        elif pc.c == 0:
            c = pc.centre
            mid = pc.p0 + pc.end()[0] - 2 * c
            formula[i] = (c[0], c[1], 1.0 / abs(pc.k), mid[0], mid[1])
            flags[i] |= 1
        else:                               # a clothoid: selected by its approximating arc
            c, radius, mid = pc.wedge()
            formula[i] = (c[0], c[1], radius, mid[0], mid[1])
            flags[i] |= 1 | 8
        flags[i] |= 2 if (pc.ray_before or i == 0) else 0
        flags[i] |= 4 if i == n - 1 else 0
    shapes = [_shape(pc, i == 0) for i, pc in enumerate(pieces)]
    scale = 1.0 + max(float(np.max(np.abs(params[:, :2]))),
                      max((pc.length for pc in pieces if math.isfinite(pc.length)), default=0.0))
    start, others, bounds = [0], [], []
    loose = 2.0 * max(pc.selection_error() for pc in pieces)   # the clothoids' approximate |phi| (0 on G1 paths)
    for i in range(n):
        row = sorted((max(0.0, lower_bound(shapes[i], shapes[k]) * (1 - SLACK) - SLACK * scale - loose), k)
                     for k in range(n) if k != i)
        others += [k for _, k in row]
        bounds += [b for b, _ in row]
        start.append(len(others))
    return {"params": params, "junction": junction, "formula": formula, "flags": flags, "start": np.array(start),
            "others": np.array(others, dtype=int), "bounds": np.array(bounds), "eps": 4 * SLACK * scale}


def _rows(a: np.ndarray) -> str:
    return ", ".join("{" + ", ".join(repr(float(v)) for v in row) + "}" for row in a)


def _values(a, cast=float) -> str:
    return ", ".join(repr(cast(v)) for v in a) if len(a) else "0"


def search_source(path: Path) -> str:
    """C tables of :func:`search_tables` and the ``CA_PATH`` macros that switch the glue's search on.

    Parameters
    ----------
    path : Path
        The path.

    Returns
    -------
    str
        ``#define CA_PATH``, ``CA_NP`` (the number of pieces), ``CA_PATH_EPS`` and the static
        tables (and :data:`SPIRAL_WRAPPERS` on a path with clothoids).
    """
    tb = search_tables(path)
    n = len(tb["flags"])
    return (f"#define CA_PATH 1\n#define CA_NP {n}\n#define CA_PATH_EPS {tb['eps']!r}\n"
            f"static const casadi_real ca_pp[CA_NP][{PIECE_CONSTANTS}] = {{{_rows(tb['params'])}}};\n"
            f"static const casadi_real ca_pj[CA_NP][3] = {{{_rows(tb['junction'])}}};\n"
            f"static const casadi_real ca_pf[CA_NP][5] = {{{_rows(tb['formula'])}}};\n"
            f"static const int ca_pk[CA_NP] = {{{_values(tb['flags'], int)}}};\n"
            f"static const int ca_nb_start[CA_NP + 1] = {{{_values(tb['start'], int)}}};\n"
            f"static const int ca_nb_j[{max(1, len(tb['others']))}] = {{{_values(tb['others'], int)}}};\n"
            f"static const casadi_real ca_nb_lb[{max(1, len(tb['bounds']))}] = {{{_values(tb['bounds'])}}};\n"
            + (SPIRAL_WRAPPERS if np.any(tb["flags"] & 8) else ""))


#: On a path with clothoids: ``link_geometry_arc`` and ``tail_arc``, which the glue calls for every
#: arc-like piece (flag 1), call the clothoid's Function for a piece flagged 8, else the arc's
#: (``*_arc_only``, :func:`~coordarm.generated.link_variants.function_kind`); the piece is found from
#: its constants' row of ``ca_pp``, the argument at ``slot``.
SPIRAL_WRAPPERS = "".join(
    f"static int {name}_arc(const casadi_real** arg, casadi_real** res, casadi_int* iw, casadi_real* w, int mem) {{\n"
    f"  casadi_int k = (casadi_int)((arg[{slot}] - ca_pp[0]) / {PIECE_CONSTANTS});\n"
    f"  return ca_pk[k] & 8 ? {name}_spiral(arg, res, iw, w, mem) : {name}_arc_only(arg, res, iw, w, mem);\n}}\n"
    for name, slot in (("link_geometry", 5), ("tail", 2)))
