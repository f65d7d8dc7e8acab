"""What the law builders need from a chain: the interfaces a chain kind implements.

:class:`KinematicChain` is the kinematic part every kind implements (the planar
:class:`~coordarm.symbolic.chain.PlanarChain` and the spatial
:class:`~coordarm.symbolic.spatial_chain.SpatialChain`, docs/guide/spatial.md): joint layout, the
check of ``q`` and the link centres. :class:`ChainModel` adds the pieces of the planar law (the link
frames, the first carry, link rates to controls), so the planar task outputs, the law's assembly,
the numeric API and the code generator need no copy of their own.

Shapes: ``m`` links, ``dof`` joints (``m`` for revolute joints, ``2 m`` for universal ones, plus the
rail's prismatic joint first on a rail), ``dim`` = 2 (planar) or 3 (spatial).
"""
from __future__ import annotations

from typing import Any, Protocol, runtime_checkable

import numpy as np

from .errors import ConfigError


def check_joint_vector(q: Any, dof: int, field: str, layout: str = "") -> np.ndarray:
    """Return ``q`` as a float array of shape (dof,), or raise a ConfigError naming ``field``.

    Parameters
    ----------
    q : array_like, shape (dof,)
        Joint coordinates.
    dof : int
        Number of joint coordinates.
    field : str
        Name used in the error message.
    layout : str
        What the coordinates are, appended to the shape in the error message (e.g. ``" (d, ...)"``).

    Returns
    -------
    ndarray, shape (dof,)
        ``q`` as floats.

    Raises
    ------
    ConfigError
        Wrong shape, NaN or inf.
    """
    q = np.asarray(q, dtype=float)
    if q.shape != (dof,):
        raise ConfigError(f"{field}: need shape ({dof},){layout}, got {q.shape}")
    if not np.all(np.isfinite(q)):
        raise ConfigError(f"{field}: contains NaN or inf at index {int(np.flatnonzero(~np.isfinite(q))[0])}")
    return q


@runtime_checkable
class KinematicChain(Protocol):
    """A chain of ``m`` equal links: its joint layout, the check of ``q`` and the link centres.

    Attributes
    ----------
    m : int
        Number of links.
    xi : float
        Link length [m].
    dof : int
        Number of joint coordinates (length of ``q`` and ``u``).
    rail : bool
        Whether the base slides on a rail (``q`` then holds ``d`` [m] first).
    """

    m: int
    xi: float
    dof: int
    rail: bool

    def check_q(self, q: Any, field: str = "q") -> np.ndarray:
        """``q`` as floats, or a ConfigError naming ``field``.

        Parameters
        ----------
        q : array_like, shape (dof,)
            Joint coordinates.
        field : str
            Name used in the error message.

        Returns
        -------
        ndarray, shape (dof,)
        """

    # ---------------------------------------------------------------------------- kinematics
    def centres(self, q: Any) -> Any:
        """Link centres of symbolic joint coordinates.

        Parameters
        ----------
        q : casadi.SX or casadi.MX, shape (dof,)
            Joint coordinates.

        Returns
        -------
        casadi expression, shape (dim, m)
            Column j is the centre of link j+1 [m].
        """

    def centres_np(self, q: Any) -> np.ndarray:
        """Link centres, vectorised over leading axes.

        Parameters
        ----------
        q : array_like, shape (..., dof)
            Joint coordinates.

        Returns
        -------
        ndarray, shape (..., m, dim)
            Link centres [m].
        """


@runtime_checkable
class ChainModel(KinematicChain, Protocol):
    """A planar chain of ``m`` equal links driven by ``qdot = B u``: the :class:`KinematicChain` members,
    the base and the chain-specific pieces of the planar law (the link frames, the first carry, link
    rates to controls).

    Attributes
    ----------
    m : int
        Number of links.
    xi : float
        Link length [m].
    dof : int
        Number of joints (length of ``q`` and ``u``).
    rail : bool
        Whether the base slides on a rail (``q`` then holds ``d`` [m] first).
    """

    m: int
    xi: float
    dof: int
    rail: bool

    # ----------------------------------------------------------------- joint layout and base
    @property
    def rail_direction(self) -> np.ndarray:
        """Unit vector of the rail, shape (2,) (meaningful on a rail only)."""

    @property
    def B(self) -> np.ndarray:
        """The input matrix over the revolute joints, shape (m, m)."""

    @property
    def b_diagonal(self) -> np.ndarray | None:
        """The diagonal of ``B``, shape (m,), or None when ``B`` is not diagonal."""

    @property
    def B_joints(self) -> np.ndarray:
        """``B`` over all joints, shape (dof, dof) (``diag(1, B)`` on a rail)."""

    def revolute(self, q: Any) -> Any:
        """The revolute joint angles of ``q`` (``d`` dropped on a rail).

        Parameters
        ----------
        q : ndarray or casadi expression, shape (..., dof)
            Joint coordinates.

        Returns
        -------
        same type, shape (..., m)
            Revolute joint angles [rad].
        """

    # ----------------------------------------------------------------- pieces of the law
    def link_direction(self, alpha: Any) -> Any:
        """The direction ``d_j`` of a link at absolute orientation ``alpha``.

        Parameters
        ----------
        alpha : casadi.SX
            The link's absolute orientation (the planar chain: ``alpha_j = q_1 + ... + q_j`` [rad]).

        Returns
        -------
        casadi.SX
            Unit vector along the link.
        """

    def link_normal(self, d: Any) -> Any:
        """The normal(s) ``n_j`` of a link of direction ``d``: where the link's rate moves its centres.

        Parameters
        ----------
        d : casadi.SX
            Link direction.

        Returns
        -------
        casadi.SX
            ``d`` turned by +90 degrees.
        """

    def centre_step(self, d_prev: Any, d_j: Any) -> Any:
        """``y^j - y^{j-1}`` from the directions of links ``j-1`` and ``j``.

        Parameters
        ----------
        d_prev, d_j : casadi.SX
            Directions of links ``j-1`` and ``j``.

        Returns
        -------
        casadi.SX
            Step between the centres [m].
        """

    def first_carry(self, q1: Any) -> Any:
        """The carry of link 1 (layout :data:`~coordarm.symbolic.carry.CARRY`).

        Parameters
        ----------
        q1 : casadi.SX
            Joint angle(s) of the first joint [rad].

        Returns
        -------
        casadi.SX, shape (CARRY.size, 1)
            The packed carry.
        """

    def controls_from_link_rates(self, w: Any) -> Any:
        """The controls ``u = B^-1 qdot`` of the revolute joints from the link rates ``w``.

        Parameters
        ----------
        w : casadi.MX
            Link rates [rad/s].

        Returns
        -------
        casadi.MX
            Controls ``u`` [rad/s for B = I].
        """
