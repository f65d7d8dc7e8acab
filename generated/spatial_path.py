"""The link pivots of the compiled spatial law on a 3-D path: one piece's formulas per link, not every piece's.

The interpreted geometry of a :class:`~coordarm.symbolic.paths3d.Path3D` selects the closest piece's
constants over every piece and evaluates the line, the arc and (with transitions) the clothoid formulas,
keeping one (:func:`~coordarm.symbolic.paths3d.closest_piece3d`): per link, the clothoid's Newton steps and
their derivatives cost most of the law, and the geometry was evaluated twice (for ``1 / det P_j`` and for the
pivot). The generated C instead finds the piece first (``ca_path3d_piece``: every piece's tests,
``spatial_path_valid``, then the distance ``spatial_path_dist_<i>`` of the pieces whose tests hold, keeping
the first of the smallest: the selection's own tests and comparisons, so the same piece as
:func:`piece_selector`), evaluates ``Phi`` and ``dPhi/dy`` by that piece's kind only
(``spatial_path_geometry_<kind>``, :func:`~coordarm.symbolic.piece_formulas3d.kind_formulas3d`, with the
piece's row of the constants' table) and the pivot after it (``spatial_path_inv_det``, ``spatial_path_pivot``
or ``spatial_path_pivot_rates``): the same operations as the selected branch, once per link. The wrappers
``spatial_link_inv_det`` (a placeholder), ``spatial_link_pivot`` and ``spatial_link_pivot_rates``
(:func:`path_source`) have the names and signatures of the Functions they stand for, so the law's C
(``templates/spatial_law.c``) is the same.
"""
from __future__ import annotations

import casadi as ca

from coordarm.symbolic import SpatialController
from coordarm.symbolic.path_pieces import all_hold
from coordarm.symbolic.paths3d import (PIECE3D_CONSTANTS, PIECE_KINDS, Path3D, closest_piece_index3d, piece_candidates3d,
                                       piece_constants, piece_kind)
from coordarm.symbolic.piece_formulas3d import kind_formulas3d

from .spatial_variants import LINK_GEOMETRY, link_pivot_expressions, spatial_time_features


def searched(ctrl: SpatialController) -> bool:
    """Whether the compiled law finds each link's piece first (the curve is a :class:`~coordarm.symbolic.paths3d.Path3D`).

    Parameters
    ----------
    ctrl : SpatialController
        The controller.

    Returns
    -------
    bool
    """
    return isinstance(ctrl.task.curve, Path3D)


def path_kinds(ctrl: SpatialController) -> list[str]:
    """The kinds of piece the path has (:data:`~coordarm.symbolic.paths3d.PIECE_KINDS` order).

    Parameters
    ----------
    ctrl : SpatialController
        The controller (on a :class:`~coordarm.symbolic.paths3d.Path3D`).

    Returns
    -------
    list of str
        Some of ``"line"``, ``"arc"``, ``"spiral"``.
    """
    present = {piece_kind(pc) for pc in ctrl.task.curve.pieces}
    return [k for k in PIECE_KINDS if k in present]


def piece_geometry(kind: str) -> ca.Function:
    """``spatial_path_geometry_<kind>``: ``(y, sel) -> (Phi, dPhi/dy)`` on one ``kind`` of piece with constants ``sel``.

    As the task's geometry function builds them (``Phi`` of :func:`~coordarm.symbolic.piece_formulas3d.kind_formulas3d`,
    its Jacobian by AD); a path does not move, so ``dPhi/dt = 0``.

    Parameters
    ----------
    kind : {"line", "arc", "spiral"}
        The kind of piece.

    Returns
    -------
    casadi.Function
        Inputs ``y`` (3,) [m], ``sel`` (28,); outputs ``Phi`` (2,) [m], ``JPhi`` (2, 3) [-], dense.
    """
    y, sel = ca.SX.sym("y", 3), ca.SX.sym("sel", PIECE3D_CONSTANTS)
    Phi = ca.reshape(ca.SX(kind_formulas3d(sel, y, kind)[1]), 2, 1)
    return ca.Function(f"spatial_path_geometry_{kind}", [y, sel], [Phi, ca.densify(ca.jacobian(Phi, y))],
                       ["y", "sel"], ["Phi", "JPhi"])


def path_pivots(ctrl: SpatialController) -> tuple[ca.Function, ca.Function, ca.Function]:
    """The link pivot's 1/det, the pivot and the pivot for the rates, given the link's ``Phi`` and ``dPhi/dy``.

    As :func:`~.spatial_variants.spatial_link_inv_det`, :func:`~.spatial_variants.spatial_link_pivot` and
    :func:`~.spatial_variants.spatial_link_pivot_rates`, the curve's geometry replaced by the inputs ``Phi``,
    ``JPhi`` (:func:`piece_geometry` of the link's piece): the same operations after it.

    Parameters
    ----------
    ctrl : SpatialController
        The controller (on a :class:`~coordarm.symbolic.paths3d.Path3D`).

    Returns
    -------
    (casadi.Function, casadi.Function, casadi.Function)
        ``spatial_path_inv_det``: ``(g_0, ..., g_8, JPhi) -> inv_det``; ``spatial_path_pivot``:
        ``(g_0, ..., g_8, w, inv_det, Phi, JPhi) -> (pivot_0, ..., pivot_n-1, e_1, e_2, margin)``;
        ``spatial_path_pivot_rates``: the same inputs, ``(pivot_0, ..., pivot_n-1)``.

    Raises
    ------
    AssertionError
        The pivot depends on time (a path does not move; its time features would be missing).
    """
    t, Phi, J = ca.SX.sym("t"), ca.SX.sym("Phi", 2), ca.SX.sym("JPhi", 2, 3)
    (geo, inv), (piv, out, inv_expr), _ = link_pivot_expressions(ctrl, t, lambda y, t: (Phi, J, ca.SX(2, 1)))
    if ca.depends_on(ca.vertcat(piv, out), t):
        raise AssertionError("the link pivot on a 3-D path depends on time")
    w = ca.SX.sym("w", int(spatial_time_features(ctrl).numel_out(0)))
    n = piv.numel()
    names = [f"g{k}" for k in range(LINK_GEOMETRY)]
    body, rates = ca.cse(ca.vertcat(piv, out)), ca.cse(piv)
    inputs, in_names = [*geo, w, inv, Phi, J], names + ["w", "inv_det", "Phi", "JPhi"]
    inv_det = ca.Function("spatial_path_inv_det", [*geo, J], [ca.cse(inv_expr)], names + ["JPhi"], ["inv_det"])
    pivot = ca.Function("spatial_path_pivot", inputs, [body[k] for k in range(n + 3)], in_names,
                        [f"pivot_{k}" for k in range(n)] + ["e_1", "e_2", "margin"])
    pivot_rates = ca.Function("spatial_path_pivot_rates", inputs, [rates[k] for k in range(n)], in_names,
                              [f"pivot_{k}" for k in range(n)])
    return inv_det, pivot, pivot_rates


def centre_symbols() -> tuple[list[ca.SX], list[str]]:
    """The three scalar inputs ``y_1, y_2, y_3`` of the per-link path Functions (a link's centre [m]) and their names.

    Returns
    -------
    symbols : list of casadi.SX
        ``y_1``, ``y_2``, ``y_3``.
    names : list of str
        ``["y_1", "y_2", "y_3"]``.
    """
    names = [f"y_{k}" for k in (1, 2, 3)]
    return [ca.SX.sym(n) for n in names], names


def piece_selector(ctrl: SpatialController) -> ca.Function:
    """``spatial_path_piece``: ``(y_1, y_2, y_3) -> piece``, the index of the piece the geometry selects at ``y``.

    The selection over every piece in one Function (:func:`~coordarm.symbolic.paths3d.closest_piece_index3d`);
    the C computes the same index with :func:`piece_tests` and :func:`piece_distances`, a piece's distance only
    where its tests hold.

    Parameters
    ----------
    ctrl : SpatialController
        The controller (on a :class:`~coordarm.symbolic.paths3d.Path3D`).

    Returns
    -------
    casadi.Function
        Three scalars, a link's centre [m]; output the piece's index (a whole number).
    """
    y, names = centre_symbols()
    index = closest_piece_index3d(ctrl.task.curve.pieces, ca.vertcat(*y))
    return ca.Function("spatial_path_piece", y, [index], names, ["piece"])


def piece_tests(ctrl: SpatialController) -> ca.Function:
    """``spatial_path_valid``: ``(y_1, y_2, y_3) -> valid``, 1 for each piece whose closest-point range holds ``y``.

    Parameters
    ----------
    ctrl : SpatialController
        The controller (on a :class:`~coordarm.symbolic.paths3d.Path3D`).

    Returns
    -------
    casadi.Function
        Three scalars, a point [m]; output ``valid`` (n,), 1 or 0 (the tests of
        :func:`~coordarm.symbolic.paths3d.piece_candidates3d`, all of them).
    """
    y, names = centre_symbols()
    valid = [all_hold(ca.SX(1), tests) for _, tests in piece_candidates3d(ctrl.task.curve.pieces, ca.vertcat(*y))]
    return ca.Function("spatial_path_valid", y, [ca.vertcat(*valid)], names, ["valid"])


def piece_distances(ctrl: SpatialController) -> list[ca.Function]:
    """``spatial_path_dist_<i>``: ``(y_1, y_2, y_3) -> dist``, piece ``i``'s distance of the selection.

    Parameters
    ----------
    ctrl : SpatialController
        The controller (on a :class:`~coordarm.symbolic.paths3d.Path3D`).

    Returns
    -------
    list of casadi.Function
        One per piece: three scalars, a point [m]; output the approximate squared distance [m^2] of
        :func:`~coordarm.symbolic.paths3d.piece_candidates3d`.
    """
    y, names = centre_symbols()
    return [ca.Function(f"spatial_path_dist_{i}", y, [dist], names, ["dist"])
            for i, (dist, _) in enumerate(piece_candidates3d(ctrl.task.curve.pieces, ca.vertcat(*y)))]


def path_functions(ctrl: SpatialController) -> list[ca.Function]:
    """The Functions the wrappers of :func:`path_source` call: the pieces' tests and distances, each kind's
    geometry, the pivots.

    Parameters
    ----------
    ctrl : SpatialController
        The controller (on a :class:`~coordarm.symbolic.paths3d.Path3D`).

    Returns
    -------
    list of casadi.Function
    """
    return ([piece_tests(ctrl), *piece_distances(ctrl)] + [piece_geometry(kind) for kind in path_kinds(ctrl)]
            + list(path_pivots(ctrl)))


def _rows(rows) -> str:
    return ", ".join("{" + ", ".join(repr(float(v)) for v in row) + "}" for row in rows)


def _wrapper(name: str, kinds: list[str]) -> str:
    """C of ``spatial_link_<name>`` (a pivot Function's signature): the link's piece, its geometry, then ``spatial_path_<name>``."""
    cases = "".join(f"    case {PIECE_KINDS.index(k)}: rc = spatial_path_geometry_{k}(a, r, iw, w, 0); break;\n"
                    for k in kinds)
    return (f"static int spatial_link_{name}(const casadi_real** arg, casadi_real** res, casadi_int* iw, casadi_real* w,"
            " int mem) {\n"
            "  const casadi_real* a[CA_SZ_ARG];\n  casadi_real* r[CA_SZ_RES];\n"
            "  casadi_real y[3], phi[2], jac[6], inv;\n"
            "  casadi_int k = ca_path3d_piece(arg, iw, w), i;\n  int rc = 1;\n"
            "  (void)mem;\n"
            "  if (k < 0 || k >= CA_NP3) return 1;\n"
            "  for (i = 0; i < 3; ++i) y[i] = *arg[6 + i];\n"
            "  a[0] = y; a[1] = ca_pp3[k]; r[0] = phi; r[1] = jac;\n"
            f"  switch (ca_pk3[k]) {{\n{cases}  }}\n"
            "  if (rc) return rc;\n"
            "  for (i = 0; i < CA_NG; ++i) a[i] = arg[i];\n"
            "  a[CA_NG] = jac; r[0] = &inv;\n"
            "  if (spatial_path_inv_det(a, r, iw, w, 0)) return 1;\n"
            "  a[CA_NG] = arg[CA_NG]; a[CA_NG + 1] = &inv; a[CA_NG + 2] = phi; a[CA_NG + 3] = jac;\n"
            f"  return spatial_path_{name}(a, res, iw, w, 0);\n}}\n")


def path_source(ctrl: SpatialController) -> str:
    """C of the pieces' tables and the wrappers that stand for the link pivot Functions on a 3-D path.

    Parameters
    ----------
    ctrl : SpatialController
        The controller (on a :class:`~coordarm.symbolic.paths3d.Path3D`).

    Returns
    -------
    str
        ``CA_NP3`` (the number of pieces), ``ca_pp3`` (their constants), ``ca_pk3`` (their kinds' index in
        :data:`~coordarm.symbolic.paths3d.PIECE_KINDS`), ``ca_path3d_piece`` and the wrappers
        ``spatial_link_inv_det``, ``spatial_link_pivot``, ``spatial_link_pivot_rates``; after ``CA_NG``.
    """
    pieces = ctrl.task.curve.pieces
    kinds = path_kinds(ctrl)
    table = (f"#define CA_NP3 {len(pieces)}\n"
             f"static const casadi_real ca_pp3[CA_NP3][{PIECE3D_CONSTANTS}] = "
             f"{{{_rows(piece_constants(pc) for pc in pieces)}}};\n"
             f"static const int ca_pk3[CA_NP3] = {{{', '.join(str(PIECE_KINDS.index(piece_kind(pc))) for pc in pieces)}}};\n")
    tested = "".join(f"  if (ok[{i}] != 0) {{\n    if (spatial_path_dist_{i}(a, r, iw, w, 0)) return -1;\n"
                     f"    if (d < best) {{\n      best = d;\n      k = {i};\n    }}\n  }}\n" for i in range(len(pieces)))
    search = ("/* The piece of the path the geometry selects at the link's centre y^j (the pivot's arguments 6-8): the\n"
              "   first valid piece of the smallest distance, as spatial_path_piece, a distance computed only where\n"
              "   the piece's tests hold. */\n"
              "static casadi_int ca_path3d_piece(const casadi_real** arg, casadi_int* iw, casadi_real* w) {\n"
              "  const casadi_real* a[3];\n  casadi_real ok[CA_NP3], d, best = INFINITY;\n  casadi_real* r[1];\n"
              "  casadi_int k = 0;\n"
              "  a[0] = arg[6]; a[1] = arg[7]; a[2] = arg[8]; r[0] = ok;\n"
              "  if (spatial_path_valid(a, r, iw, w, 0)) return -1;\n"
              "  r[0] = &d;\n" + tested + "  return k;\n}\n"
              "/* Each kind's pivot computes 1 / det P_j itself: nothing to do here. */\n"
              "static int spatial_link_inv_det(const casadi_real** arg, casadi_real** res, casadi_int* iw, "
              "casadi_real* w, int mem) {\n"
              "  (void)arg; (void)iw; (void)w; (void)mem;\n  res[0][0] = 1;\n  return 0;\n}\n")
    return table + search + _wrapper("pivot", kinds) + _wrapper("pivot_rates", kinds)
