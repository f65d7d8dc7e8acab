"""Error hierarchy shared by every layer of coordarm.

Every message names the field, file, time or link it is about.
"""
from __future__ import annotations

import math


class CoordarmError(Exception):
    """Base class of all coordarm errors."""


class ConfigError(CoordarmError, ValueError):
    """Invalid input: a parameter, a scenario field or a start configuration."""


class BuildError(CoordarmError):
    """Code generation, compilation or loading of a generated library failed."""


class LogError(CoordarmError):
    """A run log cannot be written or read."""


class NonFiniteError(CoordarmError, ArithmeticError):
    """The compiled law produced a non-finite value (NaN or inf) from finite inputs."""


class SingularityError(CoordarmError):
    """A singularity margin fell below its threshold during a run.

    Parameters
    ----------
    time : float
        Simulated time [s] of the first state whose margin is below threshold.
    link : int or None
        1-based index of the offending link (of the joint for ``"joint"``), or None for the
        longitudinal or end margin.
    margin : float
        The margin (dimensionless) at that time.
    kind : str
        ``"link"`` or ``"longitudinal"``; for a spatial chain also ``"end"`` (the 2x2 end solve) and
        ``"joint"`` (``|cos b_j|``).
    threshold : float
        The threshold it fell below.
    run : object, optional
        The run up to (and including) the offending state.
    hint : str, optional
        What the user can do about it (appended to the message).

    Attributes
    ----------
    time : float
        Simulated time [s] of the first state whose margin is below threshold.
    link : int or None
        1-based index of the offending link, or None for the longitudinal margin.
    margin : float
        The margin value (dimensionless) at that time.
    kind : str
        ``"link"`` or ``"longitudinal"``.
    threshold : float
        The threshold it fell below.
    run : object or None
        The run up to (and including) the offending state, if available.
    hint : str or None
        What the user can do about it (appended to the message).
    """

    def __init__(self, time: float, link: int | None, margin: float, kind: str,
                 threshold: float, run: object | None = None, hint: str | None = None) -> None:
        self.time, self.link, self.margin = float(time), link, float(margin)
        self.kind, self.threshold, self.run, self.hint = kind, float(threshold), run, hint
        where = (f"{'joint' if kind == 'joint' else 'link'} {link}" if link is not None
                 else "the end point (longitudinal)" if kind == "longitudinal" else "the end point")
        value = (f"is {self.margin:.3g} < threshold {self.threshold:.3g}" if math.isfinite(self.margin) else
                 f"is {self.margin} (the state is no longer finite: the run diverged)")
        super().__init__(
            f"singularity ahead at t = {self.time:.4f} s: {kind} margin of {where} {value}; run stopped"
            + (f" (hint: {hint})" if hint else ""))

    def __reduce__(self):
        return (SingularityError, (self.time, self.link, self.margin, self.kind,
                                   self.threshold, None, self.hint))


class TubeError(SingularityError):
    """A central point left a path's tube ``|phi| < smallest radius`` (the closest point is no longer unique).

    Parameters
    ----------
    time : float
        Simulated time [s].
    link : int or None
        1-based index of the link whose central point left the tube.
    margin : float
        Its ``|phi|`` [m].
    kind : str
        ``"tube"``.
    threshold : float
        The tube radius (the path's smallest arc radius) [m].
    run : object, optional
        The run up to (and including) that state.

    Notes
    -----
    Attributes as :class:`SingularityError`.
    """

    def __init__(self, time: float, link: int | None, margin: float, kind: str = "tube",
                 threshold: float = 0.0, run: object | None = None) -> None:
        super().__init__(time, link, margin, kind, threshold, run)
        self.args = (f"left the path's tube at t = {self.time:.4f} s: the central point of link {link} is "
                     f"{self.margin:.4g} m from the path, not less than its smallest radius "
                     f"{self.threshold:.4g} m (its closest point is no longer unique); run stopped",)

    def __reduce__(self):
        return (TubeError, (self.time, self.link, self.margin, self.kind, self.threshold, None))


class BaseOffPathError(SingularityError):
    """The base of a robot on a rail left the path, and the law can no longer drive the body from it.

    Where the path leaves the rail's line, the base (``y^1``, on the rail) can no longer be on
    the path. In the plane, link 1 then turns towards the path's normal at link 2's centre; once it
    stands across it, the free rate (link 1's) no longer moves the body and every rate blows up, while
    the link, longitudinal and rail margins stay healthy (the longitudinal margin is scaled by
    the same vanishing factor). The base margin is ``|n_1 . grad phi(y^2)| / |n_2 . grad phi(y^2)|``
    (at most 1; 1 on a zig-zag along the path). In space, link 1 turns towards the path's tangent and
    the roll held from it spins the body; the base margin is ``1 - |Phi(y^1)| / (xi/2 |d_2 across|)``
    (``coordarm.simulation.base_margin``).

    Parameters
    ----------
    time : float
        Simulated time [s].
    margin : float
        The base margin [-].
    threshold : float
        The threshold it fell below [-].
    d : float
        The rail position [m].
    offset : float
        The base's distance from the path, ``|phi(y^1)|`` (spatial: ``|Phi(y^1)|``) [m].
    run : object, optional
        The run up to (and including) that state.
    spatial : bool
        A spatial chain (the message says what its base margin measures).

    Notes
    -----
    Attributes as :class:`SingularityError` (``kind`` is ``"base"``, ``link`` 1), plus ``d``, ``offset`` and
    ``spatial``.
    """

    def __init__(self, time: float, margin: float, threshold: float, d: float, offset: float,
                 run: object | None = None, spatial: bool = False) -> None:
        super().__init__(time, 1, margin, "base", threshold, run)
        self.d, self.offset, self.spatial = float(d), float(offset), bool(spatial)
        self.args = (f"the base left the path at t = {self.time:.4f} s: at d = {self.d:.4f} m on the rail the base is "
                     f"{self.offset:.3g} m off the path and {self.what()} (base margin "
                     f"{self.margin_text()} < {self.threshold:.3g}); run stopped",)

    def what(self) -> str:
        """What the base margin saw: link 1 across the path (planar), the offset eating link 2's reach (spatial).

        Returns
        -------
        str
        """
        return ("the offset takes more than half of link 2's reach across the path" if self.spatial
                else "link 1 stands almost across the path")

    def margin_text(self) -> str:
        """The margin with the digits that show it below the threshold (3 significant digits when they do).

        Returns
        -------
        str
        """
        for digits in (3, 4, 6):
            text = f"{self.margin:.{digits}g}"
            if float(text) < self.threshold:
                return text
        return repr(self.margin)

    def __reduce__(self):
        return (BaseOffPathError, (self.time, self.margin, self.threshold, self.d, self.offset, None, self.spatial))


class CollisionError(CoordarmError):
    """The chain hit an obstacle, itself or a joint limit during a run.

    Attributes
    ----------
    contact : object
        The first contact (a :class:`coordarm.simulation.physical.Contact`: ``kind``,
        ``time``, ``links``, ``value``, ``threshold``, ``obstacle``).
    run : object or None
        The run up to (and including) the offending state, if available.

    Parameters
    ----------
    contact : object
        The first contact (see Attributes).
    run : object, optional
        The run so far.
    """

    def __init__(self, contact: object, run: object | None = None) -> None:
        self.contact, self.run = contact, run
        self.time = float(contact.time)
        super().__init__(f"{contact.describe()}; run stopped")

    def __reduce__(self):
        return (CollisionError, (self.contact, None))


#: Longest echo of an input value in a message [characters].
SHOWN_LENGTH = 80


def shown(value: object) -> str:
    """``repr(value)`` cut to :data:`SHOWN_LENGTH` characters (with ``...``) for an error message.

    Parameters
    ----------
    value : object
        Any value.

    Returns
    -------
    str
        Its ``repr``, at most :data:`SHOWN_LENGTH` characters.
    """
    text = repr(value)
    return text if len(text) <= SHOWN_LENGTH else text[:SHOWN_LENGTH - 3] + "..."


class JointRateError(CoordarmError):
    """A joint moved faster (``kind = "rate"``) or turned its rate faster (``"accel"``) than its limit.

    Parameters
    ----------
    time : float
        Simulated time [s].
    joint : int
        1-based joint index (``q_j``; on a rail joint 0 is the rail).
    value : float
        ``|u_j|`` [rad/s] or ``|du_j/dt|`` [rad/s^2].
    limit : float
        The limit it exceeded.
    kind : {"rate", "accel"}
        Which limit.
    run : object, optional
        The run up to that state.
    """

    def __init__(self, time: float, joint: int, value: float, limit: float, kind: str,
                 run: object | None = None) -> None:
        self.time, self.joint, self.value, self.limit, self.kind, self.run = time, joint, value, limit, kind, run
        what = (f"moves at |u| = {value:.4g} rad/s, above chain.rate_limit = {limit:.4g} rad/s" if kind == "rate" else
                f"accelerates at |du/dt| = {value:.4g} rad/s^2, above chain.accel_limit = {limit:.4g} rad/s^2")
        super().__init__(f"joint {kind} limit at t = {time:.4f} s: joint {joint} {what}; run stopped")

    def __reduce__(self):
        return (JointRateError, (self.time, self.joint, self.value, self.limit, self.kind, None))
