"""Physical validity of the chain: joint limits, self-collision and obstacles, vectorised over samples.

:func:`check_configuration` returns every contact of a block of configurations;
:class:`Physical` holds what a run checks (limits, clearance, obstacles) and is what
:func:`coordarm.simulation.run.simulate` takes as ``physical=``.
"""
from __future__ import annotations

from dataclasses import asdict, field
from typing import TYPE_CHECKING, Sequence

import numpy as np

from coordarm.generated.chain_geometry import chain_joints, self_distances
from coordarm.symbolic import PlanarChain
from coordarm.symbolic.geometry import touching
from coordarm.symbolic.records import record

from .obstacles import Obstacle, link_distances

if TYPE_CHECKING:
    from numpy.typing import ArrayLike

#: Contact kinds, in the order they are reported within one sample.
KINDS = ("joint_limit", "self", "wall", "rail_limit")


@record(frozen=True)
class Contact:
    """One violation at one sample.

    Attributes
    ----------
    kind : str
        ``"joint_limit"`` (``links`` = the two links the joint joins), ``"self"`` (two
        non-adjacent links) or ``"wall"`` (one link and ``obstacle``).
    time : float
        Simulated time [s].
    links : tuple of int
        1-based links.
    value : float
        The joint angle [rad] or the distance [m].
    threshold : float
        The joint limit [rad] or the clearance [m].
    obstacle : str or None
        Name of the obstacle (``"wall"`` only).
    """

    kind: str
    time: float
    links: tuple[int, ...]
    value: float
    threshold: float
    obstacle: str | None = None

    def describe(self) -> str:
        """What happened, in words (time, links, value against threshold, geometric meaning).

        Returns
        -------
        str
            One sentence.
        """
        t = f"t = {self.time:.3f} s"
        if self.kind == "rail_limit":
            return (f"rail limit at {t}: the rail position d = {self.value:+.4{'f' if abs(self.value) < 1e6 else 'g'}} m "
                    f"is beyond its limit "
                    f"{self.threshold:+.4f} m: the introduction axis cannot feed the body further")
        if self.kind == "joint_limit":
            j = self.links[1]
            return (f"joint limit at {t}: joint {j} (between links {j - 1} and {j}) is at "
                    f"{self.value:+.4{'f' if abs(self.value) < 1e6 else 'g'}} rad, "
                    f"beyond its limit ±{self.threshold:.4f} rad: the two links fold too far onto each other")
        if self.kind == "self":
            a, b = self.links
            what = "cross each other" if self.value <= 0 else f"come {self.value:.4f} m apart"
            return (f"self-collision at {t}: links {a} and {b} {what} (clearance {self.threshold:g} m): "
                    f"the body runs into itself")
        what = "touches or crosses" if self.value <= 0 else f"comes {self.value:.4f} m close to"
        return f"collision at {t}: link {self.links[0]} {what} {self.obstacle!r} (clearance {self.threshold:g} m)"

    def advice(self) -> str:
        """One line of advice.

        Returns
        -------
        str
            The advice, starting with ``advice:``.
        """
        if self.kind == "joint_limit":
            return ("advice: start more compact only up to the limit (smaller start.beta), lower the curve's "
                    "curvature or speed, or raise chain.joint_limit if the hardware allows")
        if self.kind == "self":
            return ("advice: a shorter duration or lower speed (the body is pushed back onto itself), a larger "
                    "curve radius, or fewer links")
        return ("advice: move the obstacle or the curve away from the body, narrow the body (smaller start.beta) "
                "to pass an opening, or add --allow-contact to record contacts and keep going")

    def to_dict(self) -> dict:
        """JSON-ready record (the MCAP ``outcome`` and ``report.json``).

        Returns
        -------
        dict
            The fields, ``links`` as a list.
        """
        d = asdict(self)
        d["links"] = list(self.links)
        return d


def joint_limits(links: int, joint_limit: float | Sequence[float]) -> np.ndarray:
    """Limits [rad] of the relative joints 2..m, shape (m-1,), from one number or a list of m-1.

    Parameters
    ----------
    links : int
        Number of links m.
    joint_limit : float or sequence of float
        One limit for every joint, or m-1 limits [rad].

    Returns
    -------
    ndarray
        The limits [rad], shape (m-1,) for one number (a sequence is converted to floats as it
        is, its length not checked here).
    """
    lim = np.asarray(joint_limit, dtype=float)
    if lim.ndim == 0:
        lim = np.full(links - 1, float(lim))
    return lim


@record
class Physical:
    """What a run checks at every logged sample.

    Attributes
    ----------
    chain : PlanarChain
        The chain (its ``joint_limits`` and ``clearance``).
    obstacles : list of Obstacle
        Walls, discs and polygons.
    rate_limits : (float or None, float or None)
        ``[chain] rate_limit`` [rad/s] and ``accel_limit`` [rad/s^2], checked at every step
        (:mod:`.joint_rates`); None: unchecked.
    """

    chain: PlanarChain
    obstacles: list[Obstacle] = field(default_factory=list)
    rate_limits: tuple = (None, None)

    def check(self, t: np.ndarray, q: np.ndarray) -> list[Contact]:
        """Every contact at the samples ``(t[k], q[k])``, sorted by time (then kind, links).

        Parameters
        ----------
        t : ndarray, shape (N,)
            Times of the samples [s].
        q : ndarray, shape (N, dof)
            Configurations [rad] (on a rail ``d`` [m] first).

        Returns
        -------
        list of Contact
            The contacts.
        """
        return check_configuration(self.chain, q, self.obstacles, t)

    def clearances(self, q: np.ndarray, t: np.ndarray) -> dict[str, tuple[float, float, int]]:
        """Per obstacle: (smallest distance [m], its time [s], its 1-based link) over the samples.

        Parameters
        ----------
        q : ndarray, shape (N, dof)
            Configurations [rad] (on a rail ``d`` [m] first).
        t : ndarray, shape (N,)
            Times of the samples [s].

        Returns
        -------
        dict of str to (float, float, int)
            By obstacle name.
        """
        if not self.obstacles:                      # nothing to measure: skip the O(N m) joints
            return {}
        joints = self.chain.joints_np(np.asarray(q, float))
        out = {}
        for ob in self.obstacles:
            d = link_distances(joints, ob)
            k, j = np.unravel_index(int(np.argmin(d)), d.shape)
            out[ob.name] = (float(d[k, j]), float(t[k]), int(j) + 1)
        return out


def check_configuration(chain: PlanarChain, q: ArrayLike, obstacles: Sequence[Obstacle] = (),
                        t: ArrayLike | None = None) -> list[Contact]:
    """Joint limits, self-collision and obstacle contacts of configurations ``q``.

    Parameters
    ----------
    chain : PlanarChain
        Its ``joint_limits`` (m-1,) [rad] bound ``|q_j|``, j = 2..m; its ``clearance`` [m]
        is the smallest allowed distance between non-adjacent links and from a link to an
        obstacle (0: touching counts as contact).
    q : (N, dof) or (dof,) array
        Configurations [rad] (on a rail ``d`` [m] first, checked against ``chain.rail_limits``).
    obstacles : sequence of Obstacle
        Obstacles each link must keep ``chain.clearance`` from.
    t : (N,) array, optional
        Times of the samples [s] (default: the sample index).

    Returns
    -------
    list of Contact
        Sorted by time; empty when every sample is valid.
    """
    q = np.atleast_2d(np.asarray(q, dtype=float))
    t = np.arange(len(q), dtype=float) if t is None else np.atleast_1d(np.asarray(t, dtype=float))
    lim, c = chain.joint_limits, chain.clearance
    found: list[tuple[int, int, Contact]] = []
    rev = chain.revolute(q)                                # the rail position d is checked apart
    ks, js = np.nonzero(~(np.abs(rev[:, 1:]) <= lim))      # NaN counts as beyond
    for k, j in zip(ks.tolist(), js.tolist()):
        found.append((k, 0, Contact("joint_limit", float(t[k]), (j + 1, j + 2), float(rev[k, j + 1]), float(lim[j]))))
    if chain.rail:
        lo, hi = chain.rail_limits
        for k in np.flatnonzero(~((q[:, 0] >= lo) & (q[:, 0] <= hi))).tolist():
            found.append((k, 0, Contact("rail_limit", float(t[k]), (1,), float(q[k, 0]),
                                        lo if q[k, 0] < lo else hi)))
    joints = chain_joints(chain, q)                        # compiled (numpy's to the last bit), or numpy
    s, la, lb, d = self_distances(joints, c)
    hit = touching(d, c)
    for k, a, b, dist in zip(s[hit].tolist(), la[hit].tolist(), lb[hit].tolist(), d[hit].tolist()):
        found.append((k, 1, Contact("self", float(t[k]), (a, b), dist, c)))
    for ob in obstacles:
        dist = link_distances(joints, ob)
        for k, j in zip(*np.nonzero(touching(dist, c))):
            found.append((int(k), 2, Contact("wall", float(t[k]), (int(j) + 1,), float(dist[k, j]), c, ob.name)))
    found.sort(key=lambda x: (x[0], x[1], x[2].links))
    return [x[2] for x in found]


def distinct(contacts: Sequence[Contact]) -> list[Contact]:
    """The first contact of every (kind, links, obstacle), in time order (for ``--allow-contact`` records).

    Parameters
    ----------
    contacts : sequence of Contact
        Contacts in time order.

    Returns
    -------
    list of Contact
        The first of each kind, links and obstacle.
    """
    seen, out = set(), []
    for c in contacts:
        key = (c.kind, c.links, c.obstacle)
        if key not in seen:
            seen.add(key)
            out.append(c)
    return out
