"""What the law builder needs from a chain: the interface a chain kind implements.

:class:`~coordarm.symbolic.chain.PlanarChain` implements it; a second kind of chain (a spatial chain
with two-axis joints, DESIGN.md section 10) implements the same members, so the task outputs, the
law's assembly, the numeric API and the code generator need no copy of their own.

Shapes: ``m`` links, ``dof`` joints (``m``, plus the rail's prismatic joint first on a rail).
"""
from __future__ import annotations

from typing import Any, Protocol, runtime_checkable

import numpy as np


@runtime_checkable
class ChainModel(Protocol):
    """A chain of ``m`` equal links driven by ``qdot = B u``: kinematics, joint layout, base and the
    chain-specific pieces of the law (the link frames, the first carry, link rates to controls).

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
        """The revolute joint angles of ``q`` (``d`` dropped on a rail), shape (..., m) [rad]."""

    def check_q(self, q: Any, field: str = "q") -> np.ndarray:
        """``q`` as a float array of shape (dof,), or a ConfigError naming ``field``."""

    # ---------------------------------------------------------------------------- kinematics
    def centres(self, q: Any) -> Any:
        """Link centres as a CasADi expression of shape (2, m) [m] for symbolic ``q`` of shape (dof,)."""

    def centres_np(self, q: Any) -> np.ndarray:
        """Link centres of shape (..., m, 2) [m] for ``q`` of shape (..., dof)."""

    # ----------------------------------------------------------------- pieces of the law
    def link_direction(self, alpha: Any) -> Any:
        """The direction ``d_j`` of a link at absolute angle ``alpha`` (CasADi)."""

    def link_normal(self, direction: Any) -> Any:
        """The normal ``n_j`` of a link whose direction is ``direction`` (CasADi)."""

    def centre_step(self, d_prev: Any, d_j: Any) -> Any:
        """``y^j - y^{j-1}`` [m] from the directions of links ``j-1`` and ``j``."""

    def first_carry(self, q1: Any) -> Any:
        """The carry of link 1 (layout :data:`~coordarm.symbolic.carry.CARRY`) for joint angle ``q1``."""

    def controls_from_link_rates(self, w: Any) -> Any:
        """The controls ``u = B^-1 qdot`` of the revolute joints from the link rates ``w`` [rad/s]."""
