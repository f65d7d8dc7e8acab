"""Composite 3-D paths of lines and banked circular arcs, exact and in closed form (docs/guide/spatial.md).

A :class:`Path3D` is a start point, a start direction, a first normal ``n_1`` and segments:
straight lines of given length and circular arcs turning by ``A > 0`` with radius ``R``
towards ``cos(bank) n_1 + sin(bank) n_2`` (the frame ``(t, n_1, n_2)`` at the arc's start).
Junctions are G1 and the frame is transported along the path without twist: along a line it
stays, along an arc it turns with the tangent about the arc's plane normal. Before its start
and after its end the path continues as straight rays.

Per piece, closed form (no iteration): a line from ``p0`` gives ``psi = s0 + t.(y - p0)``,
``Phi = (n_1.(y - p0), n_2.(y - p0))``; an arc of centre ``C = p0 + R u`` (``u`` the turn
direction), plane normal ``w = t_0 x u`` and in-plane part ``r`` of ``y - C`` gives
``psi = s0 + R a`` with ``a = atan2(((-u) x r).w, (-u).r)`` and ``Phi`` = the deviation
``(rho - R) r/rho + ((y - C).w) w`` in the fixed components of ``(n_1, n_2)`` in the basis
``(w x t, w)``. Among the pieces whose closest-point range holds ``y`` the one with the
smallest ``|Phi|`` is selected with CasADi ``if_else``; in the tube ``|Phi| < min R`` the
choice is unique and ``Phi``, ``psi`` are continuous across junctions.
"""
from __future__ import annotations

import math
from typing import Any, Sequence

import casadi as ca
import numpy as np

from .curves3d import SpatialCurve, as_column
from .path_pieces import all_hold
from .piece_formulas3d import piece_formulas3d
from .errors import ConfigError, shown
from .records import record
from .vectors3d import finite, finite_vector, orthogonal_normal, rotate, unit_vector
from .transitions import segment_transition, spiral_local, transition_length
from .transitions3d import curvature_vectors, junction_transitions3d, local_piece, ramps, segment_lengths3d, spiral_constants
from .waypoints3d import waypoint_segments3d

#: Arcs turning more than this are split into equal pieces (each piece's ``atan2`` stays
#: away from its branch cut).
MAX_PIECE = 2.0 * math.pi / 3.0
#: Length of a piece's constants (:func:`piece_constants`).
PIECE3D_CONSTANTS = 28


@record(frozen=True)
class Piece3D:
    """One piece of a 3-D path: a line (``radius = 0``) or a banked arc, with its frame at the start.

    Attributes
    ----------
    p0 : ndarray, shape (3,)
        Start point [m].
    tangent, n1, n2 : ndarray, shape (3,)
        The transported frame at ``p0``.
    s0 : float
        Arc length at ``p0`` [m].
    length : float
        Length of the piece [m] (``inf`` for the final ray).
    radius : float
        Arc radius [m]; 0 for a line.
    bank : float
        Turn direction ``cos(bank) n1 + sin(bank) n2`` of an arc [rad].
    ray_before : bool
        The line extends backwards without limit (the first piece).
    k0, c : float
        A clothoid piece of a transition (``c != 0``, :mod:`.transitions3d`): curvature ``k0 + c sigma``
        [1/m] towards the ``bank`` direction (``radius`` 0).
    """

    p0: np.ndarray
    tangent: np.ndarray
    n1: np.ndarray
    n2: np.ndarray
    s0: float
    length: float
    radius: float = 0.0
    bank: float = 0.0
    ray_before: bool = False
    k0: float = 0.0
    c: float = 0.0

    @property
    def toward(self) -> np.ndarray:
        """Unit turn direction ``u`` of an arc (from ``p0`` to the centre)."""
        return math.cos(self.bank) * self.n1 + math.sin(self.bank) * self.n2

    @property
    def centre(self) -> np.ndarray:
        """Centre ``p0 + R u`` of an arc [m]."""
        return self.p0 + self.radius * self.toward

    @property
    def axis(self) -> np.ndarray:
        """Plane normal ``w = t x u`` of an arc (it turns counter-clockwise about it)."""
        return np.cross(self.tangent, self.toward)

    def point_at(self, x: float) -> np.ndarray:
        """The point at distance ``x`` along the piece from its start.

        Parameters
        ----------
        x : float
            Arc length from ``p0`` [m] (negative on the ray before a first line).

        Returns
        -------
        ndarray, shape (3,)
            The point [m].
        """
        if self.c != 0:
            X, Y, _ = spiral_local(self.k0, self.c, x)
            return self.p0 + X * self.tangent + Y * self.toward
        if self.radius == 0:
            return self.p0 + x * self.tangent
        c = self.centre
        return c + rotate(self.axis, x / self.radius, self.p0 - c)

    def frame_at(self, x: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The transported frame at distance ``x`` along the piece.

        Parameters
        ----------
        x : float
            Arc length from ``p0`` [m].

        Returns
        -------
        tuple of 3 ndarray, shape (3,)
            Tangent, ``n_1``, ``n_2``.
        """
        if self.c != 0:
            w, a = self.axis, spiral_local(self.k0, self.c, x)[2]
            return tuple(rotate(w, a, v) for v in (self.tangent, self.n1, self.n2))
        if self.radius == 0:
            return self.tangent, self.n1, self.n2
        w, a = self.axis, x / self.radius
        return tuple(rotate(w, a, v) for v in (self.tangent, self.n1, self.n2))


def parse_segment3d(seg: Any, field: str) -> tuple[str, float, float, float]:
    """A segment ``{line = L}`` or ``{arc = A, radius = R, bank = beta}``, validated.

    Parameters
    ----------
    seg : dict or tuple
        ``{"line": L}`` or ``{"arc": A, "radius": R, "bank": beta}`` (``bank`` optional, default 0),
        or a tuple ``("line", L)``, ``("arc", A, R)``, ``("arc", A, R, beta)``.
    field : str
        Name of the segment in error messages (``"curve.segments[2]"``).

    Returns
    -------
    tuple (str, float, float, float)
        ``("line", L, 0, 0)`` or ``("arc", A, R, beta)``: length [m], turning angle [rad], radius [m],
        bank [rad].

    Raises
    ------
    ConfigError
        Unknown keys, a length or radius not > 0, a turning angle not in ``(0, 2 pi)``.
    """
    if isinstance(seg, (tuple, list)) and seg and seg[0] in ("line", "arc"):
        keys = ("line",) if seg[0] == "line" else ("arc", "radius", "bank")
        seg = dict(zip(keys, seg[1:]))
    if not isinstance(seg, dict):
        raise ConfigError(f"{field}: expected {{line = L}} or {{arc = A, radius = R, bank = beta}}, got {shown(seg)}")
    seg, _ = segment_transition(seg, field)                 # read by Path3D (its junction's transition)
    if set(seg) == {"line"}:
        length = finite(seg["line"], f"{field}.line")
        if not length > 0:
            raise ConfigError(f"{field}.line: length must be > 0, got {length}")
        return "line", length, 0.0, 0.0
    if "arc" in seg and "radius" in seg and set(seg) <= {"arc", "radius", "bank"}:
        angle = finite(seg["arc"], f"{field}.arc")
        radius = finite(seg["radius"], f"{field}.radius")
        bank = finite(seg.get("bank", 0.0), f"{field}.bank")
        if not 0 < angle < 2 * math.pi:
            raise ConfigError(f"{field}.arc: turning angle must be > 0 and below 2 pi, got {angle} "
                              "(turn the other way with bank = pi)")
        if not radius > 0:
            raise ConfigError(f"{field}.radius: must be > 0, got {radius}")
        return "arc", angle, radius, bank
    raise ConfigError(f"{field}: expected {{line = L}} or {{arc = A, radius = R, bank = beta}}, "
                      f"got keys {sorted(seg)}")


def build_pieces3d(start: np.ndarray, direction: np.ndarray, normal: np.ndarray,
                   segments: Sequence[tuple[str, float, float, float]],
                   transitions: Sequence[float] | None = None) -> list[Piece3D]:
    """The path's pieces (arcs over :data:`MAX_PIECE` split), with rays at both ends.

    Parameters
    ----------
    start : ndarray, shape (3,)
        Start point [m].
    direction, normal : ndarray, shape (3,)
        Unit tangent and unit ``n_1`` (perpendicular) at the start.
    segments : sequence of tuple
        Parsed segments (:func:`parse_segment3d`).
    transitions : sequence of float, optional
        Transition length at each junction [m] (:mod:`.transitions3d`); None or all 0: G1.

    Returns
    -------
    list of Piece3D
        The pieces in order; the first extends backwards, the last has infinite length.
    """
    p, frame, s, pieces = np.asarray(start, float), (direction, normal, np.cross(direction, normal)), 0.0, []
    for length, radius, bank, k0, c in _parts3d(segments, transitions):
        piece = Piece3D(p, *frame, s, length, radius, bank, k0=k0, c=c)
        pieces.append(piece)
        p, frame, s = piece.point_at(length), piece.frame_at(length), s + length
    first, last = pieces[0], pieces[-1]
    if first.radius == 0 and first.c == 0:
        pieces[0] = Piece3D(first.p0, first.tangent, first.n1, first.n2, 0.0, first.length, ray_before=True)
    else:
        pieces.insert(0, Piece3D(first.p0, first.tangent, first.n1, first.n2, 0.0, 0.0, ray_before=True))
    if last.radius == 0 and last.c == 0:
        last = pieces[-1]
        pieces[-1] = Piece3D(last.p0, last.tangent, last.n1, last.n2, last.s0, math.inf, ray_before=last.ray_before)
    else:
        pieces.append(Piece3D(p, *frame, s, math.inf))
    return pieces


def _parts3d(segments, transitions) -> list[tuple[float, float, float, float, float]]:
    """The pieces ``(length, radius, bank, k0, c)`` of the segments: G1 as before, or with the transitions' clothoids."""
    out = []
    if not transitions or not any(transitions):
        for kind, a, r, bank in segments:
            count = 1 if kind == "line" else max(1, math.ceil(a / MAX_PIECE - 1e-12))
            parts = [(a, 0.0)] if kind == "line" else [(a * r / count, r)] * count
            out += [(length, radius, bank, 0.0, 0.0) for length, radius in parts]
        return out
    K, ls = curvature_vectors(segments), segment_lengths3d(segments)
    n = len(segments)
    for i, (kind, a, r, bank) in enumerate(segments):
        before = transitions[i - 1] if i > 0 else 0.0
        after = transitions[i] if i < n - 1 else 0.0
        core = ls[i] - 0.5 * (before + after)
        if core < -1e-12 * max(1.0, ls[i]):
            raise ConfigError(f"curve.segments[{i}]: {ls[i]:.6g} m is too short for its transitions "
                              f"({before:.6g} m before, {after:.6g} m after; each takes half its length "
                              f"from the segment): shorten curve.transition")
        if core > 1e-12:
            count = 1 if kind == "line" else max(1, math.ceil(core / r / MAX_PIECE - 1e-12))
            out += [(core / count, 0.0 if kind == "line" else r, bank, 0.0, 0.0)] * count
        if after > 0:
            out += [(h, 0.0, b, k0, c) for b, k0, c, h in ramps(K[i], K[i + 1], after)]
    return out


def piece_constants(piece: Piece3D) -> np.ndarray:
    """The constants of a piece that :func:`piece_formulas3d` takes.

    Parameters
    ----------
    piece : Piece3D
        One piece of a path.

    Returns
    -------
    ndarray, shape (28,)
        ``p0, t, n1, n2`` (3 each), ``s0``, arc flag (1 or 0), ``R``, centre, plane normal ``w``, turn
        direction ``u`` (3 each) and the components ``(n1.u, n1.w, n2.u, n2.w)``. A line gets
        the finite stand-ins ``R = 1``, ``u = n1`` (its arc formula is never selected).
    """
    if piece.c != 0:
        return spiral_constants(piece.p0, piece.tangent, piece.n1, piece.n2, piece.s0, piece.bank, piece.k0,
                                piece.c, piece.length)
    arc = piece.radius > 0
    u = piece.toward if arc else piece.n1
    radius = piece.radius if arc else 1.0
    w = np.cross(piece.tangent, u)
    comps = [piece.n1 @ u, piece.n1 @ w, piece.n2 @ u, piece.n2 @ w]
    return np.r_[piece.p0, piece.tangent, piece.n1, piece.n2, piece.s0, float(arc), radius,
                 piece.p0 + radius * u, w, u, comps]


#: The kinds of piece (:func:`piece_kind`), in the order of their index in the generated C's table.
PIECE_KINDS = ("line", "arc", "spiral")


def piece_kind(piece: Piece3D) -> str:
    """``"line"``, ``"arc"`` or ``"spiral"`` (a transition's clothoid): which formulas hold on ``piece``.

    Parameters
    ----------
    piece : Piece3D
        One piece of a path.

    Returns
    -------
    str
        One of :data:`PIECE_KINDS`.
    """
    return "spiral" if piece.c != 0 else ("arc" if piece.radius > 0 else "line")


def closest_piece3d(pieces: list[Piece3D], y):
    """``(psi, Phi, frame)`` of the path at ``y``: select the closest valid piece, evaluate its formulas.

    A piece is valid when ``y`` lies between the normal planes at its ends
    (``t_i.(y - p_i) >= 0`` and ``t_{i+1}.(y - p_{i+1}) <= 0``, the rays unbounded outwards; an
    arc also excludes the opposite wedge); among those, the smallest ``|Phi|`` wins.

    Parameters
    ----------
    pieces : list of Piece3D
        The path's pieces (:func:`build_pieces3d`).
    y : casadi.SX or casadi.MX, shape (3, 1)
        A point [m].

    Returns
    -------
    tuple
        As :func:`piece_formulas3d`.
    """
    y = as_column(y)
    sel = ca.DM(piece_constants(pieces[0]))
    for i, closer in _closer_pieces(pieces, y):
        sel = ca.if_else(closer, ca.DM(piece_constants(pieces[i])), sel)
    return piece_formulas3d(sel, y, any(pc.c != 0 for pc in pieces))


def closest_piece_index3d(pieces: list[Piece3D], y):
    """Index of the piece :func:`closest_piece3d` selects at ``y`` (the same tests and comparisons).

    Parameters
    ----------
    pieces : list of Piece3D
        The path's pieces (:func:`build_pieces3d`).
    y : casadi.SX, shape (3, 1)
        A point [m].

    Returns
    -------
    casadi.SX
        The index into ``pieces`` (a whole number; 0 when no piece is valid, as the selection).
    """
    index = ca.SX(0)
    for i, closer in _closer_pieces(pieces, as_column(y)):
        index = ca.if_else(closer, i, index)
    return index


def _closer_pieces(pieces: list[Piece3D], y):
    """``(i, closer)`` for each piece in order: ``closer`` is true where piece ``i`` is valid and closer than
    every piece before it (approximate squared distances: a clothoid by its approximating arc)."""
    best = ca.inf
    for i, (dist, tests) in enumerate(piece_candidates3d(pieces, y)):
        closer = all_hold(dist < best, tests)
        best = ca.if_else(closer, dist, best)
        yield i, closer


def piece_candidates3d(pieces: list[Piece3D], y) -> list[tuple[Any, list]]:
    """Each piece's approximate squared distance to ``y`` and the tests that ``y`` is in its closest-point range.

    The selection (:func:`closest_piece3d`) takes, among the pieces whose tests all hold, the first of the
    smallest distance. A clothoid is measured by its approximating arc in its plane.

    Parameters
    ----------
    pieces : list of Piece3D
        The path's pieces (:func:`build_pieces3d`).
    y : casadi.SX, shape (3, 1)
        A point [m].

    Returns
    -------
    list of (casadi.SX, list of casadi.SX)
        Per piece, in order: the distance [m^2] and its tests (the junction planes at its ends, an arc's wedge).
    """
    g = [ca.dot(ca.DM(pc.tangent), y) - float(pc.tangent @ pc.p0) for pc in pieces]
    last, out = len(pieces) - 1, []
    for i, pc in enumerate(pieces):
        tests = ([] if pc.ray_before or i == 0 else [g[i] >= 0]) + ([] if i == last else [g[i + 1] <= 0])
        if pc.c != 0:                       # a clothoid: by its approximating arc in its plane
            c, radius, mid = local_piece(pc.k0, pc.c, pc.length).wedge()
            u, w = pc.toward, pc.axis
            full = y - ca.DM(pc.p0 + c[0] * pc.tangent + c[1] * u)
            z = ca.dot(ca.DM(w), full)
            dist = (ca.norm_2(full - z * ca.DM(w)) - radius) ** 2 + z ** 2
            tests.append(ca.dot(ca.DM(mid[0] * pc.tangent + mid[1] * u), full) > 0)
        elif pc.radius == 0:
            v = y - ca.DM(pc.p0)
            dist = ca.sumsqr(v) - ca.dot(ca.DM(pc.tangent), v) ** 2
        else:
            c, w = pc.centre, pc.axis
            full = y - ca.DM(c)
            z = ca.dot(ca.DM(w), full)
            dist = (ca.norm_2(full - z * ca.DM(w)) - pc.radius) ** 2 + z ** 2
            tests.append(ca.dot(ca.DM(pc.p0 + pc.point_at(pc.length) - 2 * c), full) > 0)
        out.append((dist, tests))
    return out


class Path3D(SpatialCurve):
    """A composite 3-D path of lines and banked arcs (G1), its frame transported without twist.

    Parameters
    ----------
    start : sequence of 3 float
        Start point [m]; ``psi = 0`` there.
    direction : sequence of 3 float
        Tangent at the start (any non-zero length).
    normal : sequence of 3 float
        ``n_1`` at the start (orthogonalised against the direction); ``n_2 = t x n_1``.
    segments : sequence
        Each ``{"line": L}`` (length L [m]) or ``{"arc": A, "radius": R, "bank": beta}`` (turn by
        ``0 < A < 2 pi`` [rad] with radius R [m] towards ``cos(beta) n_1 + sin(beta) n_2`` of the frame
        at the arc's start; ``bank`` defaults to 0); tuples ``("line", L)``, ``("arc", A, R, beta)`` work too.
        A segment's ``transition`` sets the one at its start junction.
    transition : float, optional
        Length of the clothoid transitions at the junctions [m] (:mod:`.transitions3d`); None: the
        default (a quarter of the smaller radius joined, at most either segment's length); 0: G1.

    Notes
    -----
    The path does not move: ``t`` is accepted for the curve interface. Valid in the tube
    ``|Phi| < tube_radius`` (the smallest radius); straight rays continue both ends.

    Raises
    ------
    ConfigError
        A bad start, direction or normal, an empty segment list or a malformed segment.
    """

    kind = "path"

    def __init__(self, start: Any, direction: Any, normal: Any, segments: Sequence[Any],
                 transition: float | None = None) -> None:
        self.start = finite_vector(start, "curve.start")
        self.direction = unit_vector(direction, "curve.direction")
        self.normal = orthogonal_normal(self.direction, normal, "curve.normal")
        if not isinstance(segments, (list, tuple)) or not segments:
            raise ConfigError(f"curve.segments: need a non-empty list of segments, got {shown(segments)}")
        self.segments = [parse_segment3d(sg, f"curve.segments[{i}]") for i, sg in enumerate(segments)]
        own = [segment_transition(sg, f"curve.segments[{i}]")[1] for i, sg in enumerate(segments)]
        if own[0] is not None:
            raise ConfigError("curve.segments[0].transition: the first segment has no junction before it")
        #: The ``transition`` given for the path (None: the default) and per segment [m].
        self.transition = None if transition is None else transition_length(transition, "curve.transition")
        self.segment_transitions = own
        #: Transition length at each junction [m] (:mod:`.transitions3d`).
        self.transitions = junction_transitions3d(self.segments, self.transition, own[1:])
        self.pieces = build_pieces3d(self.start, self.direction, self.normal, self.segments, self.transitions)
        radii = [r for kind, _, r, _ in self.segments if kind == "arc"]
        #: Half-width of the tube in which ``Phi``, ``psi`` are valid [m] (inf for lines only).
        self.tube_radius = min(radii) if radii else math.inf
        #: Length of the path between its start and its end [m].
        self.length = sum(a if kind == "line" else a * r for kind, a, r, _ in self.segments)
        self.waypoints = None

    @classmethod
    def from_waypoints(cls, points: Sequence[Sequence[float]], radius: float, normal: Any = None,
                       transition: float | None = None) -> "Path3D":
        """The polyline through 3-D ``points`` with a circular fillet of ``radius`` at each corner.

        Parameters
        ----------
        points : sequence of (x, y, z)
            At least two waypoints [m]; the path starts at the first and ends at the last.
        radius : float
            Fillet radius [m].
        normal : sequence of 3 float, optional
            ``n_1`` at the start (default: ``e_z x direction``, the left normal of a planar path).
        transition : float, optional
            Transition length at every junction [m], as for :class:`Path3D`.

        Returns
        -------
        Path3D
            The filleted path (see :func:`waypoint_segments3d`).

        Raises
        ------
        ConfigError
            Fewer than two points, coinciding points, a 180 degree corner or a fillet that does not fit.
        """
        segments, start, direction, n1 = waypoint_segments3d(points, radius, normal)
        path = cls(start, direction, n1, segments, transition)
        path.waypoints = (np.asarray(points, float).tolist(), float(radius))
        return path

    def coordinates(self, y, t):
        return closest_piece3d(self.pieces, y)

    def piece_at(self, s: float) -> Piece3D:
        """The piece holding arc length ``s`` (the rays beyond the ends included).

        Parameters
        ----------
        s : float
            Arc length [m].

        Returns
        -------
        Piece3D
            The first piece whose end lies at or beyond ``s`` (the last one for any larger ``s``).
        """
        return next(pc for pc in self.pieces if s <= pc.s0 + pc.length or pc is self.pieces[-1])

    def point_at(self, s: float, t: float = 0.0) -> np.ndarray:
        """The point of arc length ``s`` (rays beyond the ends).

        Parameters
        ----------
        s : float
            Arc length [m].
        t : float
            Time [s] (the path does not move).

        Returns
        -------
        ndarray, shape (3,)
            The point [m].
        """
        piece = self.piece_at(s)
        return piece.point_at(s - piece.s0)

    def frame_at(self, s: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The transported frame at arc length ``s``.

        Parameters
        ----------
        s : float
            Arc length [m].

        Returns
        -------
        tuple of 3 ndarray, shape (3,)
            Tangent, ``n_1``, ``n_2``.
        """
        piece = self.piece_at(s)
        return piece.frame_at(s - piece.s0)

    def sample(self, t: float, n: int = 200, extent: float | None = None) -> np.ndarray:
        ray = 0.0 if extent is None else float(extent)
        return np.array([self.point_at(s) for s in np.linspace(-ray, self.length + ray, n)])

    def to_spec(self) -> dict:
        """The path as data (``kind = "path"``, or ``"waypoints"`` when built from waypoints).

        Returns
        -------
        dict
            Accepted by :func:`~.curve3d_specs.curve3d_from_spec`.
        """
        extra = {} if self.transition is None else {"transition": self.transition}
        if self.waypoints:
            return {"kind": "waypoints", "points": self.waypoints[0], "radius": self.waypoints[1],
                    "normal": self.normal.tolist(), **extra}
        segs = [{"line": a} if kind == "line" else {"arc": a, "radius": r, "bank": b}
                for kind, a, r, b in self.segments]
        for seg, L in zip(segs, self.segment_transitions):
            if L is not None:
                seg["transition"] = L
        return {"kind": "path", "start": self.start.tolist(), "direction": self.direction.tolist(),
                "normal": self.normal.tolist(), "segments": segs, **extra}


Path3D.coordinates.__doc__ = SpatialCurve.coordinates.__doc__
Path3D.sample.__doc__ = SpatialCurve.sample.__doc__
