"""A CasADi Function of time evaluated at many times at once through a reused buffer (the scene's straight line).

The scene of a straight-line curve needs the line's angle and point at every drawn time of a block. The
Function mapped over those times gives them in one evaluation, but calling it from Python costs
~70 us a block (a ``DM`` of the times, the call, three ``.full()``), ten times its arithmetic.
:class:`MappedBuffer` evaluates the very same mapped Function through a CasADi ``FunctionBuffer`` bound
to numpy arrays kept for each number of times (~6 us): the same evaluation, so the same bits.
"""
from __future__ import annotations

from typing import Any

import casadi as ca
import numpy as np

#: Most block lengths whose mapped Function and buffers are kept (block lengths vary little).
KEPT_SIZES = 8


class MappedBuffer:
    """``function`` (one scalar input, scalar outputs) at a row of times, mapped, evaluated in place.

    Parameters
    ----------
    function : casadi.Function
        One input of shape (1, 1) (a time [s]), any number of outputs of shape (1, 1).
    """

    def __init__(self, function: ca.Function) -> None:
        self.function = function
        self._sizes: dict[int, tuple[Any, ...]] = {}

    def __call__(self, times: np.ndarray) -> tuple[np.ndarray, ...]:
        """The outputs at each of ``times``: what ``function.map(k)`` returns, as new float arrays.

        Parameters
        ----------
        times : ndarray, shape (k,)
            Times [s].

        Returns
        -------
        tuple of ndarray, each shape (k,)
            One array per output of the Function.
        """
        k = len(times)
        kept = self._sizes.get(k)
        if kept is None:
            if len(self._sizes) >= KEPT_SIZES:
                self._sizes.clear()
            kept = self._sizes[k] = self._bind(k)
        evaluate, arg, res = kept[-3:]
        arg[:] = times
        evaluate()
        return tuple(r.copy() for r in res)

    def _bind(self, k: int) -> tuple[Any, ...]:
        """The Function mapped over ``k`` times, its buffer bound to an input array and one array per output."""
        mapped = self.function.map(k)
        arg = np.zeros(k)
        res = [np.zeros(k) for _ in range(mapped.n_out())]
        if not hasattr(mapped, "buffer"):          # an older CasADi: the plain mapped call
            def evaluate() -> None:
                for r, v in zip(res, mapped(ca.DM(arg[None, :]))):
                    r[:] = v.full().ravel()
            return mapped, evaluate, arg, res
        buffer, evaluate = mapped.buffer()
        buffer.set_arg(0, memoryview(arg))
        for i, r in enumerate(res):
            buffer.set_res(i, memoryview(r))
        return mapped, buffer, evaluate, arg, res
