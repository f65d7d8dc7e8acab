"""The pieces of a composite path (docs/guide/curves.md): per-segment closed forms in the path frame.

A :class:`Piece` is one line or arc (long arcs split into pieces of at most :data:`MAX_PIECE`);
:func:`build_pieces` lays them from a start, a heading and segments; :func:`closest_piece_formulas`
selects the closest piece with CasADi ``if_else`` and :func:`piece_formulas` evaluates one line and
one arc formula with its constants (:func:`piece_parameters`), as :class:`~.paths.Path` and the
generated C (:mod:`coordarm.generated.path_search`) do.
"""
from __future__ import annotations

import math
from typing import Any, Sequence

import casadi as ca
import numpy as np

from .checks import is_real
from .errors import ConfigError
from .records import record
from .transitions import spiral_formulas, spiral_local, split_ramp, transition_runs

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


@record(frozen=True)
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
    c : float
        Curvature rate [1/m^2]: non-zero for a clothoid piece of a transition
        (:mod:`.transitions`), whose curvature is ``k + c sigma`` at ``sigma`` along it.
    """

    p0: np.ndarray
    d0: np.ndarray
    k: float
    s0: float
    length: float
    ray_before: bool = False
    c: float = 0.0

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
        if self.c != 0:
            return self.point(self.length)
        if self.k == 0:
            return self.p0 + self.length * self.d0, self.d0.copy()
        a = self.k * self.length
        c, s = math.cos(a), math.sin(a)
        rot = np.array([[c, -s], [s, c]])
        return self.centre + rot @ (self.p0 - self.centre), rot @ self.d0


    def point(self, x: float) -> tuple[np.ndarray, np.ndarray]:
        """Point and unit tangent at ``x`` along the piece (0 <= x <= length).

        Parameters
        ----------
        x : float
            Arc length from the piece's start [m].

        Returns
        -------
        point : (2,) ndarray
            The point [m].
        tangent : (2,) ndarray
            The unit tangent there.
        """
        if self.c == 0:
            return Piece(self.p0, self.d0, self.k, self.s0, x).end()
        X, Y, th = spiral_local(self.k, self.c, x)
        n0 = self.n0
        c, s = math.cos(th), math.sin(th)
        return self.p0 + X * self.d0 + Y * n0, c * self.d0 + s * n0

    def wedge(self) -> tuple[np.ndarray, float, np.ndarray]:
        """Centre, radius and the direction towards the middle of the arc that selects the piece.

        An arc's own centre and radius; a clothoid's approximating arc: centre at the crossing of
        its end normals, radius the mean distance of its end points from there.

        Returns
        -------
        centre : (2,) ndarray
            [m].
        radius : float
            [m].
        mid : (2,) ndarray
            From the centre towards the piece's middle (not normalised) [m].
        """
        end, d1 = self.end()
        if self.c == 0:
            c = self.centre
            return c, 1.0 / abs(self.k), self.p0 + end - 2 * c
        n0, n1 = self.n0, np.array([-d1[1], d1[0]])
        det = n0[0] * (-n1[1]) + n1[0] * n0[1]                   # p0 + a n0 = end + b n1
        r = end - self.p0
        a = (r[0] * (-n1[1]) + n1[0] * r[1]) / det
        c = self.p0 + a * n0
        radius = 0.5 * (float(np.linalg.norm(self.p0 - c)) + float(np.linalg.norm(end - c)))
        return c, radius, self.p0 + end - 2 * c

    def selection_error(self) -> float:
        """Bound of the error of :meth:`wedge`'s ``| |p - centre| - radius |`` as ``|phi|`` on the piece [m].

        Returns
        -------
        float
            0 for a line or an arc; for a clothoid the largest deviation of its points (sampled
            finely) from the approximating arc, doubled.
        """
        if self.c == 0:
            return 0.0
        c, radius, _ = self.wedge()
        dev = max(abs(float(np.linalg.norm(self.point(x)[0] - c)) - radius)
                  for x in np.linspace(0.0, self.length, 33))
        return 2.0 * dev


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


def build_pieces(start: Sequence[float], heading: float, segments: Sequence[tuple[str, float, float]],
                 transitions: Sequence[float] | None = None) -> list[Piece]:
    """The path's pieces (arcs over :data:`MAX_PIECE` split), with rays at both ends.

    A line at either end becomes the ray there; an arc at an end gets a ray added (before the
    first arc: a piece of length 0 marked ``ray_before``; after the last: one of length ``inf``).
    With transitions, each junction's curvature jump becomes a clothoid ramp
    (:func:`~.transitions.transition_runs`, split by :func:`~.transitions.split_ramp`).

    Parameters
    ----------
    start : (2,) sequence of float
        Start point [m].
    heading : float
        Tangent direction at the start [rad].
    segments : sequence of (str, float, float)
        Parsed segments (:func:`parse_segment`), at least one.
    transitions : sequence of float, optional
        Transition length at each junction [m] (``len(segments) - 1`` values); None or all 0: G1.

    Returns
    -------
    list of Piece
        In order along the path.
    """
    p = np.asarray(start, float)
    d = np.array([math.cos(heading), math.sin(heading)])
    s, pieces = 0.0, []
    for parts in _segment_parts(segments, transitions):
        for k, length, c in parts:
            piece = Piece(p, d, k, s, length, c=c)
            pieces.append(piece)
            p, d = piece.end()
            s += length
    first, last = pieces[0], pieces[-1]
    if first.k == 0 and first.c == 0:
        pieces[0] = Piece(first.p0, first.d0, 0.0, first.s0, first.length, ray_before=True)
    else:
        pieces.insert(0, Piece(first.p0, first.d0, 0.0, 0.0, 0.0, ray_before=True))
    if last.k == 0 and last.c == 0:
        pieces[-1] = Piece(pieces[-1].p0, pieces[-1].d0, 0.0, pieces[-1].s0, math.inf, pieces[-1].ray_before)
    else:
        pieces.append(Piece(p, d, 0.0, s, math.inf))
    return pieces


def _arc_parts(a: float, r: float) -> list[tuple[float, float, float]]:
    """An arc of turning angle ``a`` and radius ``r`` as pieces ``(k, length, 0)`` of at most :data:`MAX_PIECE`."""
    n = max(1, math.ceil(abs(a) / MAX_PIECE - 1e-12))
    return [(math.copysign(1.0 / r, a), abs(a) * r / n, 0.0)] * n


def _segment_parts(segments, transitions) -> list[list[tuple[float, float, float]]]:
    """Per segment, its pieces ``(k [1/m], length [m], c [1/m^2])``: G1 as before, or with the transitions' ramps."""
    if not transitions or not any(transitions):
        return [[(0.0, a, 0.0)] if kind == "line" else _arc_parts(a, r) for kind, a, r in segments]
    curv = [0.0 if kind == "line" else math.copysign(1.0 / r, a) for kind, a, r in segments]
    lengths = [a if kind == "line" else abs(a) * r for kind, a, r in segments]
    out = []
    for i, ((kind, a, r), run) in enumerate(zip(segments, transition_runs(curv, lengths, transitions))):
        core, ramps = run[0][2], run[1:]
        if core <= 1e-12:                   # used up by its transitions
            parts = []
        elif core == lengths[i]:            # no transition at either end: the segment as in G1
            parts = [(0.0, a, 0.0)] if kind == "line" else _arc_parts(a, r)
        elif kind == "line":
            parts = [(0.0, core, 0.0)]
        else:
            parts = _arc_parts(math.copysign(core / r, a), r)
        for k0, c, length in ramps:
            parts += [(ks, h, c) for ks, h in split_ramp(k0, c, length)]
        out.append(parts)
    return out


def _junction_tests(pieces: list[Piece], p) -> list:
    """``g_i = t_i . (p - J_i)`` at the start of every piece (``J_i`` its start point, ``t_i`` the tangent there).

    A piece's closest-point range is ``g_k >= 0`` and ``g_{k+1} <= 0`` (for an arc: its wedge,
    and the opposite one): neighbours share one test, so the ranges tile the tube.
    """
    return [pc.d0[0] * p[0] + pc.d0[1] * p[1] - float(pc.d0 @ pc.p0) for pc in pieces]


def _abs_phi(piece: Piece, p):
    """``|phi|`` of the piece's own formula at ``p`` and, for an arc, the test excluding the opposite wedge.

    A clothoid piece is selected like an arc, by its approximating arc (:meth:`Piece.wedge`).
    """
    if piece.k == 0 and piece.c == 0:
        n0 = piece.n0
        return ca.fabs(n0[0] * p[0] + n0[1] * p[1] - float(n0 @ piece.p0)), None
    if piece.c == 0:
        c = piece.centre
        rx, ry = p[0] - c[0], p[1] - c[1]
        mid = piece.p0 + piece.end()[0] - 2 * c                # towards the arc's middle from its centre
        return ca.fabs(ca.sqrt(rx * rx + ry * ry) - 1.0 / abs(piece.k)), mid[0] * rx + mid[1] * ry > 0
    c, radius, mid = piece.wedge()
    rx, ry = p[0] - c[0], p[1] - c[1]
    return ca.fabs(ca.sqrt(rx * rx + ry * ry) - radius), mid[0] * rx + mid[1] * ry > 0



def all_hold(first: Any, tests: Sequence[Any]) -> Any:
    """``first and tests[0] and tests[1] ...``, folded left with :func:`casadi.logic_and` (the piece
    selections of planar and spatial paths and the C's per-piece tests build their conditions so).

    Parameters
    ----------
    first : casadi.SX
        The first condition (e.g. ``dist < best``, or ``SX(1)``).
    tests : sequence of casadi.SX
        The further conditions, in order.

    Returns
    -------
    casadi.SX
        Their conjunction (1 or 0).
    """
    for test in tests:
        first = ca.logic_and(first, test)
    return first

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
    spirals = any(pc.c != 0 for pc in pieces)
    params = [ca.DM(_padded(piece_parameters(pc)) if spirals else piece_parameters(pc)) for pc in pieces]
    best, sel = ca.inf, params[0]
    last = len(pieces) - 1
    for i, (pc, par) in enumerate(zip(pieces, params)):
        dist, extra = _abs_phi(pc, p)
        tests = ([] if pc.ray_before or i == 0 else [g[i] >= 0]) + ([] if i == last else [g[i + 1] <= 0])
        tests += [extra] if extra is not None else []
        closer = all_hold(dist < best, tests)
        best = ca.if_else(closer, dist, best)
        sel = ca.if_else(closer, par, sel)
    if spirals:
        phi, psi = piece_formulas(sel[:6], p)
        phi_s, psi_s = spiral_formulas(sel, p)
        return ca.if_else(sel[6] != 0, phi_s, phi), ca.if_else(sel[6] != 0, psi_s, psi)
    return piece_formulas(sel, p)


def _padded(params: np.ndarray) -> np.ndarray:
    """A piece's constants filled with zeros to :data:`PIECE_CONSTANTS` (a line's or an arc's ``c = 0``)."""
    return np.r_[params, np.zeros(PIECE_CONSTANTS - len(params))]


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
        A clothoid piece always has ten: those four, then its curvature rate ``c`` [1/m^2],
        its length [m] and the chord projection ``h`` of :func:`~.transitions.spiral_formulas`.
    """
    if piece.c != 0:
        end = piece.end()[0]
        chord = end - piece.p0
        return np.r_[piece.p0, piece.d0, piece.k, piece.s0, piece.c, piece.length,
                     piece.length * chord / float(chord @ chord)]
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
    kind : {None, "line", "arc", "spiral"}
        None: one line and one arc formula, chosen by ``k != 0``; ``"line"`` or ``"arc"``: that
        formula only (for a piece known to be of that kind; the same operations); ``"spiral"``:
        the clothoid's (:func:`~.transitions.spiral_formulas`).

    Returns
    -------
    tuple of casadi.SX
        Signed distance and arc length [m].
    """
    if kind == "spiral":
        return spiral_formulas(sel, p)
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
