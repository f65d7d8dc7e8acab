"""The carry of the planar O(m) recursion: one layout table, read by the law builder and the C glue.

Link ``j`` of the recursion (:mod:`.recursion`) takes the carry of link ``j-1`` and returns its own.
The carry is one CasADi column; :data:`CARRY` names its fields, so the code reads ``c.P`` (after
:meth:`CarryLayout.unpack`) instead of ``carry[5:7]``, and the generated C sizes its buffers by
:attr:`CarryLayout.size` (``CA_NC``).
"""
from __future__ import annotations

from typing import Any, NamedTuple

import casadi as ca


class Carry(NamedTuple):
    """The fields of the carry after link ``j-1`` (values, or their widths in :data:`CARRY_WIDTHS`).

    Parameters
    ----------
    y : (2,)
        Centre ``y^{j-1}`` [m].
    alpha : scalar
        Absolute angle ``alpha_{j-1}`` [rad].
    direction : (2,)
        ``(cos, sin)(alpha_{j-1})``, so that each link evaluates one sine/cosine pair.
    P, Q : (2,)
        ``P + Q p = ydot^{j-1} + xi/2 n(alpha_{j-1}) w_{j-1}``, affine in the free rate ``p``:
        the part of ``ydot^j`` known before ``w_j`` ([m/s] and [m/rad]).
    a, b : scalar
        ``w_{j-1} = a + b p`` ([rad/s] and dimensionless).
    sum_abs_b : scalar
        The running ``sum |b|`` (scale of the longitudinal margin).
    """

    y: Any
    alpha: Any
    direction: Any
    P: Any
    Q: Any
    a: Any
    b: Any
    sum_abs_b: Any


#: Width of each field of the carry, in order.
CARRY_WIDTHS = Carry(y=2, alpha=1, direction=2, P=2, Q=2, a=1, b=1, sum_abs_b=1)


class CarryLayout:
    """Positions of the fields of :class:`Carry` in the carry column.

    Parameters
    ----------
    widths : Carry
        Width of each field (a scalar field has width 1 and is read as one element).

    Attributes
    ----------
    size : int
        Length of the carry column (12 for the planar chain).
    """

    def __init__(self, widths: Carry) -> None:
        self._index: dict[str, int | slice] = {}
        start = 0
        for name, width in zip(Carry._fields, widths):
            self._index[name] = start if width == 1 else slice(start, start + width)
            start += width
        self.size = start

    def index(self, name: str) -> int | slice:
        """The position of field ``name``: an index for a scalar, a slice for a vector.

        Parameters
        ----------
        name : str
            A field of :class:`Carry`.

        Returns
        -------
        int or slice
            Row(s) of the field in the carry column.
        """
        return self._index[name]

    def symbol(self) -> ca.SX:
        """A symbolic carry column ``carry`` of :attr:`size` elements.

        Returns
        -------
        casadi.SX, shape (size, 1)
            A fresh symbol named ``carry``.
        """
        return ca.SX.sym("carry", self.size)

    def unpack(self, carry: Any) -> Carry:
        """The fields of a carry column.

        Parameters
        ----------
        carry : casadi.SX or casadi.MX, shape (size, 1)
            A carry column.

        Returns
        -------
        Carry
            Each field as an element or a slice of ``carry``.
        """
        return Carry(*(carry[self._index[name]] for name in Carry._fields))

    @staticmethod
    def pack(fields: Carry) -> Any:
        """The carry column of ``fields``, in layout order.

        Parameters
        ----------
        fields : Carry
            Each field as a CasADi expression or number; a tuple is spliced element by element.

        Returns
        -------
        casadi.SX or casadi.MX, shape (size, 1)
            The fields stacked in order.
        """
        parts: list = []
        for value in fields:
            parts.extend(value) if isinstance(value, tuple) else parts.append(value)
        return ca.vertcat(*parts)


#: The layout of the planar recursion's carry.
CARRY = CarryLayout(CARRY_WIDTHS)
