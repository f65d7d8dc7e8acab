"""Arrays handed out again once nothing else refers to them: a log's sample records without fresh memory per block.

A log builds the records of every block of steps in a new array of a few MB; the kernel gives a new array
fresh pages, and touching them (a page fault and a zeroed page per 4 KiB) cost about as much as writing
the records. :class:`RecycledArrays` keeps the last few arrays and hands one out again when no view of it
is alive any more (the chunks cut from it are written: the chunk thread dropped them), which CPython's
reference count tells.
"""
from __future__ import annotations

import sys
from typing import Callable

import numpy as np


class RecycledArrays:
    """A few 1-D arrays of one dtype, each handed out (as a view of its first n items) again when free.

    Parameters
    ----------
    dtype : numpy.dtype
        The items' dtype.
    prepare : callable or None
        ``prepare(array)``, applied to each new array, whole (e.g. to write what every item holds alike;
        the caller keeps it true of what it writes, since the array comes back as it was left).
    keep : int
        Most arrays kept (the smallest is let go first).
    """

    def __init__(self, dtype: np.dtype, prepare: Callable[[np.ndarray], None] | None = None, keep: int = 4) -> None:
        self.dtype = np.dtype(dtype)
        self.prepare, self.keep = prepare, keep
        self._arrays: list[np.ndarray] = []

    def take(self, n: int, spare: int = 0) -> np.ndarray:
        """An array of ``n`` items (uninitialised), a view of a kept array that nothing else refers to, or new.

        Parameters
        ----------
        n : int
            Items needed.
        spare : int
            Items more to allocate when a new array is made (so that later, larger requests fit it).

        Returns
        -------
        ndarray, shape (n,)
            Not shared with any live array (the caller's until it drops every view of it); a new array's
            items as ``prepare`` left them, a recycled one's as the caller did.
        """
        for i in range(len(self._arrays)):
            # references: the list's and getrefcount's argument; a live view (its .base) adds one
            if len(self._arrays[i]) >= n and sys.getrefcount(self._arrays[i]) == 2:
                return self._arrays[i][:n]
        array = np.empty(n + spare, self.dtype)
        if self.prepare is not None:
            self.prepare(array)
        self._arrays.append(array)
        if len(self._arrays) > self.keep:
            del self._arrays[min(range(len(self._arrays)), key=lambda i: len(self._arrays[i]))]
        return array[:n]
