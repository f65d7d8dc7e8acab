"""A CasADi Function called on numpy arrays through a reused ``FunctionBuffer``: the same evaluation without
the ``DM`` conversions around it.

Calling a small Function from Python costs mostly its arguments and results: a ``DM`` made of each numpy
input and ``np.asarray`` of each output (the 64-link geometry mapped over two states: ~300 us a call, of
which ~50 us evaluate). :class:`BufferedFunction` binds numpy arrays to the Function's ``FunctionBuffer``
once (per thread: a buffer holds one evaluation's memory) and copies the inputs in and the outputs out:
the Function's own evaluation of the same numbers, so the same bits.
"""
from __future__ import annotations

import threading
from typing import Any

import casadi as ca
import numpy as np


class BufferedFunction:
    """``function`` called on dense numeric inputs, its dense outputs as numpy arrays, through a buffer.

    Parameters
    ----------
    function : casadi.Function
        Any Function; one whose inputs or outputs are not all dense, or a CasADi without
        ``Function.buffer``, is called as usual (the same results, at the usual cost).
    """

    def __init__(self, function: ca.Function) -> None:
        self.function = function
        self._shapes_in = [function.size_in(i) for i in range(function.n_in())]
        self._shapes_out = [function.size_out(i) for i in range(function.n_out())]
        self.buffered = hasattr(function, "buffer") and all(rows * cols for rows, cols in self._shapes_in) and all(
            sp.is_dense() for sp in [*map(function.sparsity_in, range(function.n_in())),
                                     *map(function.sparsity_out, range(function.n_out()))])
        self._local = threading.local()

    def __call__(self, *inputs: Any) -> list[np.ndarray]:
        """The outputs at ``inputs``: ``[np.asarray(v) for v in function.call(inputs)]``, as new arrays.

        Parameters
        ----------
        *inputs : array_like
            One per input of the Function, each of its shape ``size_in(i)`` (another shape, e.g. a
            scalar for a 1 x 1 input, is passed to the plain call).

        Returns
        -------
        list of ndarray
            One C-contiguous float array per output, of shape ``size_out(i)``.
        """
        arrays = [np.asarray(x, float) for x in inputs]
        if not self.buffered or [a.shape for a in arrays] != self._shapes_in:
            return [np.asarray(v) for v in self.function.call([ca.DM(a) for a in arrays])]
        evaluate, args, results = self._bound()
        for arg, x in zip(args, arrays):
            arg.reshape(x.shape[1], x.shape[0])[...] = x.T         # CasADi stores column by column
        evaluate()
        return [r.reshape(cols, rows).T.copy() for r, (rows, cols) in zip(results, self._shapes_out)]

    def __getstate__(self) -> dict[str, Any]:
        """Pickled without this thread's buffers (made again on the first call)."""
        return {k: v for k, v in self.__dict__.items() if k != "_local"}

    def __setstate__(self, state: dict[str, Any]) -> None:
        self.__dict__.update(state, _local=threading.local())

    def _bound(self) -> tuple[Any, list[np.ndarray], list[np.ndarray]]:
        """This thread's buffer: its evaluation and the arrays bound to its inputs and outputs."""
        bound = getattr(self._local, "bound", None)
        if bound is None:
            buffer, evaluate = self.function.buffer()
            args = [np.zeros(rows * cols) for rows, cols in self._shapes_in]
            results = [np.zeros(rows * cols) for rows, cols in self._shapes_out]
            for i, a in enumerate(args):
                buffer.set_arg(i, memoryview(a))
            for i, r in enumerate(results):
                buffer.set_res(i, memoryview(r))
            bound = self._local.bound = (evaluate, args, results, buffer)
        return bound[:3]


#: Operations of a :class:`PointwiseFunction`'s expanded map: its points per evaluation are this many over the
#: Function's operations, from 256 to 2048 (a constant speed: 2048 points, one call for a 2000-step chunk; a
#: speed profile of 20 operations: 256). Larger maps of such a profile were slower a point (862 points:
#: 0.18 ms for 2000 points against 0.12 ms) and took longer to build (5.6 ms against 1.2 ms).
POINTWISE_OPERATIONS = 4096


#: Most operations of an expanded map (a block's points times the Function's operations): a Function of more
#: operations a point than this over 256 is mapped as it is (its own work dwarfs the map's overhead, and an
#: expanded map of it would take long to build).
POINTWISE_EXPANDED = 65536


def pointwise_block(function: ca.Function) -> int:
    """Points per evaluation of ``function``'s :class:`PointwiseFunction` (:data:`POINTWISE_OPERATIONS`).

    Parameters
    ----------
    function : casadi.Function
        The Function of one point.

    Returns
    -------
    int
        From 256 to 2048.
    """
    return max(256, min(2048, POINTWISE_OPERATIONS // max(1, function.n_instructions())))


class PointwiseFunction:
    """A Function of one point (one column per input) evaluated at any number of points, a block at a time.

    ``function.map(n)`` costs a new Function for each ``n`` and about 0.1 us of overhead a point (the
    speed at a 2000-step chunk's times: 0.27 ms, on a spatial chain 0.7-1.1 ms with the map made anew). Here
    one map of ``block`` points (:func:`pointwise_block`), expanded into one SX Function, is built once and
    called through a :class:`BufferedFunction` on the points in blocks (the last block padded with copies
    of the last point): the same operations on each point, the same bits as ``function.map(n)``
    (``tests/test_function_buffer.py``), 4-9x faster (0.04-0.12 ms).

    Parameters
    ----------
    function : casadi.Function
        Dense inputs of one column each (``size_in(i) == (rows_i, 1)``) and dense outputs of one column.
    block : int, optional
        Points per evaluation (default :func:`pointwise_block`).
    """

    def __init__(self, function: ca.Function, block: int | None = None) -> None:
        self.function, self.block = function, int(pointwise_block(function) if block is None else block)
        mapped = function.map(self.block)
        if function.n_instructions() * self.block <= POINTWISE_EXPANDED:
            # expanded: one SX Function, no per-point call inside the map (what SX cannot hold, e.g. a Python
            # callback, stays a call node in it)
            mapped = mapped.expand()
        self._evaluate = BufferedFunction(mapped)
        self._rows_in = [function.size1_in(i) for i in range(function.n_in())]

    def __call__(self, *inputs: Any) -> list[np.ndarray]:
        """The outputs at ``n`` points: ``[np.asarray(v) for v in function.map(n).call(inputs)]``.

        Parameters
        ----------
        *inputs : array_like
            One per input of the Function, of shape ``(rows_i, n)`` (a 1-D array: one row).

        Returns
        -------
        list of ndarray
            One float array per output, of shape ``(rows_j, n)``.
        """
        arrays = [np.asarray(x, float).reshape(rows, -1) for x, rows in zip(inputs, self._rows_in)]
        n, block = arrays[0].shape[1], self.block
        if n == 0:
            return [np.empty((self.function.size1_out(j), 0)) for j in range(self.function.n_out())]
        padded = []
        for a in arrays:
            p = np.empty((a.shape[0], -(-n // block) * block))
            p[:, :n], p[:, n:] = a, a[:, -1:]
            padded.append(p)
        pieces = [self._evaluate(*(p[:, i:i + block] for p in padded)) for i in range(0, padded[0].shape[1], block)]
        return [np.concatenate([piece[j] for piece in pieces], axis=1)[:, :n] for j in range(len(pieces[0]))]


def two_point_function(function: ca.Function, first: int, second: int) -> ca.Function:
    """``(y_a, y_b, t) -> (function(y_a, t)[first], function(y_b, t)[second])``: two outputs of a Function of a
    point and a time at two points, with only the operations they need.

    The Function's graph called on new symbols keeps its operations in their order; the new Function drops
    those no output uses, so its values are the Function's own, bit for bit (``tests/test_function_buffer.py``).

    Parameters
    ----------
    function : casadi.Function
        Inputs: a point and a time; an SX Function gives an SX Function.
    first, second : int
        The outputs taken at ``y_a`` and at ``y_b``.

    Returns
    -------
    casadi.Function
        Inputs ``y_a``, ``y_b`` (the point's shape) and ``t``; outputs the two outputs.
    """
    sym = ca.SX if function.is_a("SXFunction") else ca.MX
    y_a, y_b = sym.sym("y_a", function.sparsity_in(0)), sym.sym("y_b", function.sparsity_in(0))
    t = sym.sym("t", function.sparsity_in(1))
    return ca.Function(f"{function.name()}_at_two_points", [y_a, y_b, t],
                       [function(y_a, t)[first], function(y_b, t)[second]])
