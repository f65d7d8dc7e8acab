"""Composite paths of straight lines and circular arcs, exact and in closed form (docs/guide/curves.md).

A :class:`Path` is a start point, a start heading and segments, each a straight line of
given length or a circular arc of given turning angle (+ = left, counter-clockwise) and
radius, joined with a continuous tangent (G1). Before its start and after its end the path
continues as straight rays along its end tangents.

Definitions
-----------
``s = psi(y)`` is the arc length (0 at ``start``) of the closest point of the path to
``y``; ``phi(y)`` the signed distance to it, positive to the left of the direction of
travel. Both are closed forms per segment, the segment chosen by CasADi ``if_else`` (no
iterative projection), so they compile to C like the other curves. They are exact and
``phi`` is C1 in the tube ``|phi| < min R`` (the smallest arc radius): outside it the closest
point may jump between segments, and the run stops (see ``tube_radius``).

Selection: every segment's distance to ``y`` is computed cheaply (clamped to the segment);
the closest segment's parameters are selected, and one line and one arc formula are
evaluated with them (one square root and one ``atan2`` per point, whatever the number of
segments). The generated C finds the same piece by a search near the previous link's piece
(:mod:`coordarm.generated.path_search`) and evaluates that piece's formula only
(:func:`piece_formulas` with its ``kind``).
"""
from __future__ import annotations

import math
from typing import Any, Sequence

import casadi as ca
import numpy as np

from .curves import Curve
from .errors import ConfigError
from .motions import motion_to_spec
from .params import as_param, as_point, evaluate
from .path_pieces import build_pieces, closest_piece_formulas, finite_number, parse_segment, piece_formulas
from .transitions import junction_transitions, segment_transition, transition_length


def _rot(th, v):
    c, s = ca.cos(th), ca.sin(th)
    return ca.vertcat(c * v[0] - s * v[1], s * v[0] + c * v[1])


class Path(Curve):
    """A composite path of lines and arcs (G1), optionally in rigid motion.

    Parameters
    ----------
    start : (float, float)
        Start point [m]; ``s = 0`` there.
    heading : float
        Tangent direction at the start [rad].
    segments : sequence
        Each ``{"line": L}`` (length L [m]) or ``{"arc": A, "radius": R}`` (turning angle A
        [rad], + = left; radius R [m]); tuples ``("line", L)``, ``("arc", A, R)`` work too.
    offset : (float | motion, float | motion), optional
        Translation ``o(t)`` of the whole path [m].
    rotation : float or motion, optional
        Rotation ``th(t)`` of the whole path about ``start`` [rad].
    transition : float, optional
        Length of the clothoid transition at every junction [m] (:mod:`.transitions`); a segment's
        own ``transition`` key sets the one at its start junction. None: the default,
        :data:`~.transitions.DEFAULT_FRACTION` of the smaller radius joined, at most the length of
        either segment; 0: the G1 path (curvature jumps at the junctions).

    Notes
    -----
    ``psi`` is the arc length of the closest point and ``phi`` the signed distance to it
    (+ = left of the direction of travel), straight rays continuing both ends; closed form
    per segment, selected with ``if_else``. Valid in the tube ``|phi| < tube_radius`` (the
    smallest radius). The motion maps ``y`` to the path frame by
    ``p = start + R(-th) (y - o - start)``.

    Raises
    ------
    ConfigError
        A malformed segment, a non-positive length or radius, a zero turning angle.
    """

    kind = "path"

    def __init__(self, start: Sequence[float], heading: float, segments: Sequence[Any],
                 offset: Any = (0.0, 0.0), rotation: Any = 0.0, transition: float | None = None) -> None:
        if not isinstance(start, (tuple, list, np.ndarray)) or len(start) != 2:
            raise ConfigError(f"curve.start: expected a pair (x, y), got {start!r}")
        self.start = np.array([finite_number(v, f"curve.start[{i}]") for i, v in enumerate(start)])
        self.heading = finite_number(heading, "curve.heading")
        if not isinstance(segments, (list, tuple)) or not segments:
            raise ConfigError("curve.segments: need a non-empty list of segments")
        own = [segment_transition(sg, f"curve.segments[{i}]") for i, sg in enumerate(segments)]
        self.segments = [parse_segment(sg, f"curve.segments[{i}]") for i, (sg, _) in enumerate(own)]
        #: The ``transition`` given for the path (None: the default) and per segment [m].
        self.transition = None if transition is None else transition_length(transition, "curve.transition")
        self.segment_transitions = [L for _, L in own]
        if self.segment_transitions[0] is not None:
            raise ConfigError("curve.segments[0].transition: the first segment has no junction before it")
        #: Transition length at each junction [m] (junction i before segment i + 1).
        self.transitions = junction_transitions(self.segments, self.transition, self.segment_transitions[1:])
        self.offset, self.rotation = as_point(offset, "curve.offset"), as_param(rotation, "curve.rotation")
        self.pieces = build_pieces(self.start, self.heading, self.segments, self.transitions)
        radii = [r for kind, _, r in self.segments if kind == "arc"]
        #: Half-width of the tube in which ``phi``, ``psi`` are valid [m] (inf for lines only).
        self.tube_radius = min(radii) if radii else math.inf
        self.length = sum(a if kind == "line" else abs(a) * r for kind, a, r in self.segments)

    @classmethod
    def from_waypoints(cls, points: Sequence[Sequence[float]], radius: float, offset: Any = (0.0, 0.0),
                       rotation: Any = 0.0, transition: float | None = None) -> "Path":
        """The polyline through ``points`` with a circular fillet of ``radius`` at each interior corner.

        Parameters
        ----------
        points : sequence of (x, y)
            At least two waypoints [m]; the path starts at the first and ends at the last.
        radius : float
            Fillet radius [m].
        offset : (float | motion, float | motion), optional
            Translation ``o(t)`` of the whole path [m], as for :class:`Path`.
        rotation : float or motion, optional
            Rotation ``th(t)`` of the whole path about the first point [rad].
        transition : float, optional
            Transition length at every junction of the filleted path [m], as for :class:`Path`.

        Returns
        -------
        Path
            The path, with ``waypoints`` set to ``(points, radius)``.

        Raises
        ------
        ConfigError
            Fewer than two points, a value that is not a finite number, a radius that is not > 0,
            two consecutive points that coincide, a corner that turns back (180 degrees), or a
            fillet that does not fit between its neighbours (the trims ``r tan(|a|/2)`` of two
            corners exceed the line between them).
        """
        segments, start, heading = waypoint_segments(points, radius)
        path = cls(start, heading, segments, offset=offset, rotation=rotation, transition=transition)
        path.waypoints = (np.asarray(points, float).tolist(), float(radius))
        return path

    # ------------------------------------------------------------------ symbolic
    def path_point(self, y, t):
        """``p = start + R(-th(t)) (y - o(t) - start)``: ``y`` in the path's own frame.

        Parameters
        ----------
        y : casadi.SX, shape (2,)
            A point [m].
        t : casadi.SX
            Time [s].

        Returns
        -------
        casadi.SX, shape (2,)
            The point in the path's frame [m].
        """
        st = ca.DM(self.start)
        w = ca.vertcat(y[0] - self.offset[0](t), y[1] - self.offset[1](t)) - st
        return st + _rot(-self.rotation(t), w)

    def phi_psi(self, y, t):
        """``(phi, psi)`` at ``y``, time ``t`` (one selection of the closest piece for both).

        Parameters
        ----------
        y : casadi.SX, shape (2,)
            A point [m].
        t : casadi.SX
            Time [s].

        Returns
        -------
        tuple of casadi.SX
            Signed distance and arc length [m].
        """
        return closest_piece_formulas(self.pieces, self.path_point(y, t))

    def phi_psi_piece(self, y, t, sel, kind: str | None = None):
        """``(phi, psi)`` at ``y``, time ``t``, by the formulas of the piece with constants ``sel``.

        Equal to :meth:`phi_psi` when ``sel`` is the closest piece's :func:`piece_parameters`
        (the generated C finds that piece itself and passes it in).

        Parameters
        ----------
        y : casadi.SX, shape (2,)
            A point [m].
        t : casadi.SX
            Time [s].
        sel : casadi.SX, shape (6,) or (10,)
            The piece's constants (see :func:`piece_parameters`).
        kind : {None, "line", "arc", "spiral"}
            The piece's kind, when known (see :func:`piece_formulas`).

        Returns
        -------
        tuple of casadi.SX
            Signed distance and arc length [m].
        """
        return piece_formulas(sel, self.path_point(y, t), kind)

    def frame_function(self) -> ca.Function:
        """``t -> (A, b)``: the path frame as an affine map, ``p = A y + b`` (see :meth:`path_point`).

        Returns
        -------
        casadi.Function
            ``A`` as a 2 x 2 matrix (column-major in C), ``b`` [m].
        """
        y, t = ca.SX.sym("y", 2), ca.SX.sym("t")
        p = self.path_point(y, t)
        A = ca.densify(ca.jacobian(p, y))                 # dense: the C reads four and two numbers
        b = ca.densify(ca.substitute(p, y, ca.DM.zeros(2)))
        return ca.Function("path_frame", [t], [A, b], ["t"], ["A", "b"])

    def phi(self, y, t):
        """Signed distance to the closest point of the path, + to the left.

        Parameters
        ----------
        y : casadi.SX, shape (2,)
            A point [m].
        t : casadi.SX
            Time [s].

        Returns
        -------
        casadi.SX
            ``phi`` [m].
        """
        return self.phi_psi(y, t)[0]

    def psi(self, y, t):
        """Arc length of the closest point of the path.

        Parameters
        ----------
        y : casadi.SX, shape (2,)
            A point [m].
        t : casadi.SX
            Time [s].

        Returns
        -------
        casadi.SX
            ``psi`` [m].
        """
        return self.phi_psi(y, t)[1]

    def functions(self) -> ca.Function:
        """CasADi Function ``(y, t) -> (phi, psi)`` (one selection for both).

        Returns
        -------
        casadi.Function
            ``path_curve``: ``(y [m], t [s]) -> (phi [m], psi [m])``.
        """
        y, t = ca.SX.sym("y", 2), ca.SX.sym("t")
        phi, psi = self.phi_psi(y, t)
        return ca.Function("path_curve", [y, t], [phi, psi], ["y", "t"], ["phi", "psi"])

    # ------------------------------------------------------------------- numeric
    def frame_points(self, n: int = 400, ray: float = 0.0) -> np.ndarray:
        """Points along the whole path in its own frame (plus rays of length ``ray``).

        Parameters
        ----------
        n : int
            About how many points the arcs get in all (lines: their end points).
        ray : float
            Length of the rays drawn beyond both ends [m].

        Returns
        -------
        ndarray, shape (N, 2)
            The points [m].
        """
        inner = [pc for pc in self.pieces if pc.length > 0 and math.isfinite(pc.length)]
        pts = []
        if ray > 0:
            pts.append(inner[0].p0 - ray * inner[0].d0)
        for pc in inner:
            k = max(2, int(n * pc.length / max(self.length, 1e-12)) + 2 if pc.k or pc.c else 2)
            for x in np.linspace(0.0, pc.length, k):
                if pc.c != 0:
                    pts.append(pc.point(x)[0])
                elif pc.k == 0:
                    pts.append(pc.p0 + x * pc.d0)
                else:
                    a = pc.k * x
                    c, s = math.cos(a), math.sin(a)
                    pts.append(pc.centre + np.array([[c, -s], [s, c]]) @ (pc.p0 - pc.centre))
        if ray > 0:
            end, d = inner[-1].end()
            pts.append(end + ray * d)
        return np.array(pts)

    def to_world(self, pts: np.ndarray, t: float) -> np.ndarray:
        """Map path-frame points to the world at time ``t`` (the inverse of :meth:`path_point`).

        Parameters
        ----------
        pts : ndarray, shape (N, 2)
            Points in the path's frame [m].
        t : float
            Time [s].

        Returns
        -------
        ndarray, shape (N, 2)
            The points in the world [m].
        """
        th = evaluate(self.rotation, t)
        o = np.array([evaluate(c, t) for c in self.offset])
        c, s = math.cos(th), math.sin(th)
        return self.start + o + (pts - self.start) @ np.array([[c, s], [-s, c]])

    def sample(self, t: float, n: int = 400, extent: float = 10.0) -> np.ndarray:
        """The whole path at time ``t`` (with short rays at both ends).

        Parameters
        ----------
        t : float
            Time [s].
        n : int
            About how many points the arcs get.
        extent : float
            The rays drawn are ``min(extent / 10, 0.5)`` long [m].

        Returns
        -------
        ndarray, shape (N, 2)
            Points [m].
        """
        return self.to_world(self.frame_points(n, ray=min(extent * 0.1, 0.5)), t)

    def point_at(self, s: float, t: float = 0.0) -> np.ndarray:
        """World point of arc length ``s`` at time ``t`` (rays beyond the ends).

        Parameters
        ----------
        s : float
            Arc length [m].
        t : float
            Time [s].

        Returns
        -------
        ndarray, shape (2,)
            The point [m].
        """
        for pc in self.pieces:
            if s <= pc.s0 + pc.length or pc is self.pieces[-1]:
                x = s - pc.s0
                if pc.c != 0:
                    p = pc.point(x)[0]
                elif pc.k == 0:
                    p = pc.p0 + x * pc.d0
                else:
                    a = pc.k * x
                    c, sn = math.cos(a), math.sin(a)
                    p = pc.centre + np.array([[c, -sn], [sn, c]]) @ (pc.p0 - pc.centre)
                return self.to_world(p[None], t)[0]
        raise AssertionError("unreachable")

    def curvature_at(self, s: np.ndarray) -> np.ndarray:
        """Curvature of the path at arc lengths ``s`` (0 on the rays), + = turning left.

        Parameters
        ----------
        s : array_like, shape (N,)
            Arc lengths [m].

        Returns
        -------
        ndarray, shape (N,)
            Curvature [1/m].
        """
        s = np.asarray(s, float)
        out = np.zeros_like(s)
        for pc in self.pieces:
            if math.isfinite(pc.length) and pc.length > 0:
                x = s - pc.s0
                inside = (x >= 0) & (x <= pc.length)
                out[inside] = pc.k + pc.c * x[inside]
        return out

    def to_spec(self) -> dict:
        """The path as data (``kind = "path"``, or ``"waypoints"`` when built from waypoints).

        Returns
        -------
        dict
            Plain data that :func:`~symbolic.curve_specs.curve_from_spec` builds the same path from.
        """
        motion = {"offset": [motion_to_spec(c) for c in self.offset], "rotation": motion_to_spec(self.rotation)}
        if self.transition is not None:
            motion["transition"] = self.transition
        if getattr(self, "waypoints", None):
            return {"kind": "waypoints", "points": self.waypoints[0], "radius": self.waypoints[1], **motion}
        segs = [{"line": a} if kind == "line" else {"arc": a, "radius": r} for kind, a, r in self.segments]
        for seg, L in zip(segs, self.segment_transitions):
            if L is not None:
                seg["transition"] = L
        return {"kind": "path", "start": self.start.tolist(), "heading": self.heading, "segments": segs, **motion}


def waypoint_segments(points: Sequence[Sequence[float]], radius: float
                      ) -> tuple[list[dict], tuple[float, float], float]:
    """Segments, start and heading of the filleted polyline through ``points`` (see :meth:`Path.from_waypoints`).

    Parameters
    ----------
    points : (N, 2) sequence of float
        At least two waypoints [m].
    radius : float
        Fillet radius [m] (> 0).

    Returns
    -------
    segments : list of dict
        ``{"line": L}`` [m] and ``{"arc": A, "radius": R}`` ([rad], [m]); a leg used up by its
        fillets and a straight corner (turn 0) give no segment.
    start : (float, float)
        The first point [m].
    heading : float
        Direction of the first leg [rad].

    Raises
    ------
    ConfigError
        As :meth:`Path.from_waypoints` (named ``curve.points`` and ``curve.radius``), or a path of
        no length.
    """
    if not isinstance(points, (list, tuple, np.ndarray)) or len(points) < 2:
        raise ConfigError(f"curve.points: need at least two points [x, y], got {points!r}")
    pts = []
    for i, pt in enumerate(points):
        if not isinstance(pt, (list, tuple, np.ndarray)) or len(pt) != 2:
            raise ConfigError(f"curve.points[{i}]: expected [x, y], got {pt!r}")
        pts.append([finite_number(v, f"curve.points[{i}][{k}]") for k, v in enumerate(pt)])
    P = np.array(pts)
    r = finite_number(radius, "curve.radius")
    if not r > 0:
        raise ConfigError(f"curve.radius: must be > 0, got {r}")
    legs = np.diff(P, axis=0)
    lengths = np.linalg.norm(legs, axis=1)
    for i, L in enumerate(lengths):
        if not L > 1e-12:
            raise ConfigError(f"curve.points[{i}] and curve.points[{i + 1}] coincide")
    head = np.arctan2(legs[:, 1], legs[:, 0])
    turns = (np.diff(head) + math.pi) % (2 * math.pi) - math.pi      # signed corner angles
    for i, a in enumerate(turns):
        if abs(abs(a) - math.pi) < 1e-9:
            raise ConfigError(f"curve.points[{i + 1}]: the path turns back on itself (180 degree corner)")
    trim = r * np.tan(np.abs(turns) / 2)
    before = np.r_[0.0, trim]          # trimmed at the start of each leg
    after = np.r_[trim, 0.0]           # trimmed at its end
    segments: list[dict] = []
    for i, L in enumerate(lengths):
        rest = L - before[i] - after[i]
        if rest < -1e-12:
            raise ConfigError(f"curve.radius: a fillet of radius {r} does not fit between curve.points[{i}] and "
                              f"curve.points[{i + 1}] (needs {before[i] + after[i]:.4g} m of the {L:.4g} m leg)")
        if rest > 1e-12:
            segments.append({"line": float(rest)})
        if i < len(turns) and abs(turns[i]) > 1e-12:
            segments.append({"arc": float(turns[i]), "radius": r})
    if not segments:
        raise ConfigError("curve.points: the filleted path has no length")
    return segments, (float(P[0, 0]), float(P[0, 1])), float(head[0])
