"""The pieces of a composite path (DESIGN.md section 6): per-segment closed forms in the path frame.

A :class:`Piece` is one line or arc (long arcs split into pieces of at most :data:`MAX_PIECE`);
:func:`build_pieces` lays them from a start, a heading and segments; :func:`closest_piece_formulas`
selects the closest piece with CasADi ``if_else`` and :func:`piece_formulas` evaluates one line and
one arc formula with its constants (:func:`piece_parameters`), as :class:`~.paths.Path` and the
generated C (:mod:`coordarm.generated.path_search`) do.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Sequence

import casadi as ca
import numpy as np

from .checks import is_real
from .errors import ConfigError

#: Length of a piece's constants with the derived ones (:func:`piece_parameters`), as the
#: generated per-piece link steps take them.
PIECE_CONSTANTS = 10
#: Arcs turning more than this are split into equal pieces, so each piece's angle
#: measured with ``atan2`` from its start stays away from the branch cut.
MAX_PIECE = 2.0 * math.pi / 3.0


def finite_number(value: Any, field: str) -> float:
    """``value`` as a float, checked to be a finite real number.

    Parameters
    ----------
    value : object
        The value read from a scenario or an argument.
    field : str
        Its name in error messages (e.g. ``"curve.start[0]"``).

    Returns
    -------
    float
        ``float(value)``.

    Raises
    ------
    ConfigError
        ``value`` is not a real number (a bool is not) or not finite.
    """
    if not is_real(value, numpy=True) or not math.isfinite(value):
        raise ConfigError(f"{field}: need a finite number, got {value!r}")
    return float(value)


@dataclass(frozen=True)
class Piece:
    """One segment in the path frame: start ``p0``, unit tangent ``d0`` there, curvature ``k``.

    Attributes
    ----------
    p0 : (2,) ndarray
        Start point [m].
    d0 : (2,) ndarray
        Unit tangent at ``p0``.
    k : float
        Curvature [1/m]: 0 for a line; an arc has ``k = sign(A) / R``.
    s0 : float
        Arc length at ``p0`` [m].
    length : float
        The piece's length [m] (``inf`` for the ray after the last segment).
    ray_before : bool
        The piece's line extends backwards without limit (the ray before the first segment).
    """

    p0: np.ndarray
    d0: np.ndarray
    k: float
    s0: float
    length: float
    ray_before: bool = False

    @property
    def n0(self) -> np.ndarray:
        return np.array([-self.d0[1], self.d0[0]])

    @property
    def centre(self) -> np.ndarray:
        return self.p0 + self.n0 / self.k

    def end(self) -> tuple[np.ndarray, np.ndarray]:
        """End point and end tangent.

        Returns
        -------
        point : (2,) ndarray
            End point [m] (non-finite for the final ray).
        tangent : (2,) ndarray
            Unit tangent there.
        """
        if self.k == 0:
            return self.p0 + self.length * self.d0, self.d0.copy()
        a = self.k * self.length
        c, s = math.cos(a), math.sin(a)
        rot = np.array([[c, -s], [s, c]])
        return self.centre + rot @ (self.p0 - self.centre), rot @ self.d0


def parse_segment(seg: Any, field: str) -> tuple[str, float, float]:
    """``{line = L}`` or ``{arc = A, radius = R}`` (a dict, or a tuple ``("line", L)``, ``("arc", A, R)``).

    Parameters
    ----------
    seg : dict or tuple
        One segment of a path's ``segments``.
    field : str
        Its name in error messages (e.g. ``"curve.segments[0]"``).

    Returns
    -------
    tuple of (str, float, float)
        ``("line", L, 0.0)`` with the length L [m], or ``("arc", A, R)`` with the turning angle
        A [rad] (+ = left) and the radius R [m].

    Raises
    ------
    ConfigError
        Not a segment of either form, a value that is not a finite number, a length or radius
        that is not > 0, or a turning angle that is 0 or at least 2 pi in size.
    """
    if isinstance(seg, (tuple, list)) and seg and seg[0] in ("line", "arc"):
        seg = {"line": seg[1]} if seg[0] == "line" else {"arc": seg[1], "radius": seg[2] if len(seg) > 2 else None}
    if not isinstance(seg, dict):
        raise ConfigError(f"{field}: expected {{line = L}} or {{arc = A, radius = R}}, got {seg!r}")
    if set(seg) == {"line"}:
        length = finite_number(seg["line"], f"{field}.line")
        if not length > 0:
            raise ConfigError(f"{field}.line: length must be > 0, got {length}")
        return "line", length, 0.0
    if set(seg) == {"arc", "radius"}:
        angle = finite_number(seg["arc"], f"{field}.arc")
        radius = finite_number(seg["radius"], f"{field}.radius")
        if angle == 0 or abs(angle) >= 2 * math.pi:
            raise ConfigError(f"{field}.arc: turning angle must be non-zero and below 2 pi in size, got {angle}")
        if not radius > 0:
            raise ConfigError(f"{field}.radius: must be > 0, got {radius}")
        return "arc", angle, radius
    raise ConfigError(f"{field}: expected {{line = L}} or {{arc = A, radius = R}}, got keys {sorted(seg)}")


def build_pieces(start: Sequence[float], heading: float, segments: Sequence[tuple[str, float, float]]
                 ) -> list[Piece]:
    """The path's pieces (arcs over :data:`MAX_PIECE` split), with rays at both ends.

    A line at either end becomes the ray there; an arc at an end gets a ray added (before the
    first arc: a piece of length 0 marked ``ray_before``; after the last: one of length ``inf``).

    Parameters
    ----------
    start : (2,) sequence of float
        Start point [m].
    heading : float
        Tangent direction at the start [rad].
    segments : sequence of (str, float, float)
        Parsed segments (:func:`parse_segment`), at least one.

    Returns
    -------
    list of Piece
        In order along the path.
    """
    p = np.asarray(start, float)
    d = np.array([math.cos(heading), math.sin(heading)])
    s, pieces = 0.0, []
    for kind, a, r in segments:
        if kind == "line":
            parts = [(0.0, a)]
        else:
            n = max(1, math.ceil(abs(a) / MAX_PIECE - 1e-12))
            parts = [(math.copysign(1.0 / r, a), abs(a) * r / n)] * n
        for k, length in parts:
            piece = Piece(p, d, k, s, length)
            pieces.append(piece)
            p, d = piece.end()
            s += length
    first, last = pieces[0], pieces[-1]
    if first.k == 0:
        pieces[0] = Piece(first.p0, first.d0, 0.0, first.s0, first.length, ray_before=True)
    else:
        pieces.insert(0, Piece(first.p0, first.d0, 0.0, 0.0, 0.0, ray_before=True))
    if last.k == 0:
        pieces[-1] = Piece(pieces[-1].p0, pieces[-1].d0, 0.0, pieces[-1].s0, math.inf, pieces[-1].ray_before)
    else:
        pieces.append(Piece(p, d, 0.0, s, math.inf))
    return pieces


def _junction_tests(pieces: list[Piece], p) -> list:
    """``g_i = t_i . (p - J_i)`` at the start of every piece (``J_i`` its start point, ``t_i`` the tangent there).

    A piece's closest-point range is ``g_k >= 0`` and ``g_{k+1} <= 0`` (for an arc: its wedge,
    and the opposite one): neighbours share one test, so the ranges tile the tube.
    """
    return [pc.d0[0] * p[0] + pc.d0[1] * p[1] - float(pc.d0 @ pc.p0) for pc in pieces]


def _abs_phi(piece: Piece, p):
    """``|phi|`` of the piece's own formula at ``p`` and, for an arc, the test excluding the opposite wedge."""
    if piece.k == 0:
        n0 = piece.n0
        return ca.fabs(n0[0] * p[0] + n0[1] * p[1] - float(n0 @ piece.p0)), None
    c = piece.centre
    rx, ry = p[0] - c[0], p[1] - c[1]
    mid = piece.p0 + piece.end()[0] - 2 * c                    # towards the arc's middle from its centre
    return ca.fabs(ca.sqrt(rx * rx + ry * ry) - 1.0 / abs(piece.k)), mid[0] * rx + mid[1] * ry > 0


def closest_piece_formulas(pieces: list[Piece], p):
    """``(phi, psi)`` of the path at ``p`` (path frame): select the closest piece, evaluate its formula.

    Among the pieces whose closest-point range holds ``p`` (shared junction tests), the one
    with the smallest ``|phi|``; its constants are selected and one line and one arc formula
    evaluated with them.

    Parameters
    ----------
    pieces : list of Piece
        The path's pieces (:func:`build_pieces`).
    p : casadi.SX, shape (2,)
        A point in the path's frame [m].

    Returns
    -------
    tuple of casadi.SX
        Signed distance ``phi`` and arc length ``psi`` [m].
    """
    g = _junction_tests(pieces, p)
    params = [ca.DM(piece_parameters(pc)) for pc in pieces]
    best, sel = ca.inf, params[0]
    last = len(pieces) - 1
    for i, (pc, par) in enumerate(zip(pieces, params)):
        dist, extra = _abs_phi(pc, p)
        tests = ([] if pc.ray_before or i == 0 else [g[i] >= 0]) + ([] if i == last else [g[i + 1] <= 0])
        tests += [extra] if extra is not None else []
        closer = dist < best
        for tst in tests:
            closer = ca.logic_and(closer, tst)
        best = ca.if_else(closer, dist, best)
        sel = ca.if_else(closer, par, sel)
    return piece_formulas(sel, p)


def piece_parameters(piece: Piece, derived: bool = False) -> np.ndarray:
    """The six constants ``(p0, d0, k, s0)`` of a piece that :func:`piece_formulas` takes.

    Parameters
    ----------
    piece : Piece
        One piece of a path.
    derived : bool
        Append four constants that the arc formula would compute from those six, computed here
        by the same floating-point operations: the centre ``p0 + n0 / k``, ``1 / k`` and
        ``sign(k)`` (zeros for a line).

    Returns
    -------
    ndarray, shape (6,) or (10,)
        Start point [m], unit tangent there, curvature [1/m] (0 for a line), arc length at the
        start [m]; with ``derived``, then centre [m], ``1 / k`` [m] and the turning sign.
    """
    base = np.r_[piece.p0, piece.d0, piece.k, piece.s0]
    if not derived:
        return base
    if piece.k == 0:
        return np.r_[base, 0.0, 0.0, 0.0, 0.0]
    n0 = np.array([-piece.d0[1], piece.d0[0]])
    return np.r_[base, piece.p0 + n0 / piece.k, 1.0 / piece.k, math.copysign(1.0, piece.k)]


def piece_formulas(sel, p, kind: str | None = None):
    """``(phi, psi)`` at ``p`` (path frame) by the formulas of the piece whose constants are ``sel``.

    Parameters
    ----------
    sel : casadi.SX or casadi.DM, shape (6,) or (10,)
        The piece's :func:`piece_parameters` (selected by :func:`closest_piece_formulas`, or by
        the generated C's own search, which finds the same piece); with its ``derived`` constants
        the arc formula takes them instead of computing them (the same values).
    p : casadi.SX, shape (2,)
        A point in the path's frame [m].
    kind : {None, "line", "arc"}
        None: one line and one arc formula, chosen by ``k != 0``; ``"line"`` or ``"arc"``: that
        formula only (for a piece known to be of that kind; the same operations).

    Returns
    -------
    tuple of casadi.SX
        Signed distance and arc length [m].
    """
    p0, d0, k, s0 = sel[0:2], sel[2:4], sel[4], sel[5]
    is_arc = k != 0
    n0 = ca.vertcat(-d0[1], d0[0])
    v = p - p0
    # line: tau along d0, phi along n0
    phi_line, psi_line = ca.dot(n0, v), s0 + ca.dot(d0, v)
    if kind == "line":
        return phi_line, psi_line
    # arc: centre p0 + n0 / k; phi = 1/k - sign(k) rho; psi = s0 + R a
    kk = k if kind == "arc" else ca.if_else(is_arc, k, 1.0)  # keep the arc formula finite on lines
    if kind == "arc" and sel.numel() == 10:
        c, inv_k, sg = sel[6:8], sel[8], sel[9]
    else:
        sg, c, inv_k = ca.sign(kk), p0 + n0 / kk, 1 / kk
    r = p - c
    u0 = -sg * n0                                            # radial unit vector at p0
    a = sg * ca.atan2(u0[0] * r[1] - u0[1] * r[0], ca.dot(u0, r))
    phi_arc = inv_k - sg * ca.norm_2(r)
    psi_arc = s0 + a / (sg * kk)
    if kind == "arc":
        return phi_arc, psi_arc
    return ca.if_else(is_arc, phi_arc, phi_line), ca.if_else(is_arc, psi_arc, psi_line)
