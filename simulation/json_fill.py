"""JSON messages of one shape filled with integers for many messages at once, with numpy.

The scene and frame-transform messages of a run all have the same text around their numbers.
A :class:`JsonTemplate` holds that text once, with a fixed-width slot per number; filling it
for n messages writes the digits of every number with array operations (no per-number Python
string formatting). A number is right-aligned in its slot and padded with spaces, which JSON
allows between tokens, so the text parses to exactly the integers given (``"x":  -1234e-9``
is the number -1.234e-6). Each slot's *kind* shares one width, the digits (and sign) of the
widest value of that kind in the batch, so the messages stay about as short as formatted ones.

The digits are written by a small C kernel (``generated/templates/json_digits.c``, a
:mod:`~coordarm.generated.kernels` library) when a C compiler works, else by :func:`int_text` (the
same bytes).
"""
from __future__ import annotations

import ctypes
import functools
from typing import Any

import numpy as np

#: Largest magnitude a slot takes (int64 powers of ten stop at 10**18).
LIMIT = 10 ** 18


#: 10**0 .. 10**18: the number of these <= |v| is the number of digits of v (v != 0).
_POWERS = 10 ** np.arange(19, dtype=np.int64)


@functools.cache
def _digit_groups() -> np.ndarray:
    """ASCII of "0000" .. "9999", four bytes each as one little-endian uint32 (one gather per group of
    digits), read-only; built with array operations on the first need (~1 ms: the C kernel, when it is
    built, needs none; formatting 10,000 strings took ~3 ms)."""
    groups = (np.arange(10000)[:, None] // np.array([1000, 100, 10, 1]) % 10 + ord("0")).astype(np.uint8).view("<u4")[:, 0]
    groups.flags.writeable = False
    return groups


@functools.lru_cache(maxsize=None)
def _padding(width: int) -> np.ndarray:
    """What to subtract from the ``width`` ASCII digits (right-aligned in whole groups of four bytes, as
    uint32 words) to blank ``b`` leading zeros (``'0' - ' '``) and, if negative, turn the last of them
    into ``'-'``: row ``2 b + negative``. No byte borrows from its neighbour (each digit >= ``'0'``)."""
    groups = -(-width // 4)
    table = np.zeros((width + 1, 2, 4 * groups), np.uint8)
    lead = 4 * groups - width                     # bytes before the text (cut off by the caller)
    for b in range(width + 1):
        table[b, :, lead:lead + b] = ord("0") - ord(" ")
        if b:
            table[b, 1, lead + b - 1] = ord("0") - ord("-")
    return table.reshape(-1, 4 * groups).view("<u4")


def int_text(values: np.ndarray, width: int) -> np.ndarray:
    """ASCII of integers right-aligned in ``width`` characters, spaces before, minus sign if negative.

    Parameters
    ----------
    values : int64 array, any shape
        The integers, ``|v| < LIMIT`` and short enough for ``width`` (digits plus sign).
    width : int
        Characters per value.

    Returns
    -------
    uint8 array, shape ``values.shape + (width,)``
        ASCII codes, one row of ``width`` characters per value (a view of a wider buffer).
    """
    v = np.asarray(values, np.int64)
    rest = np.abs(v)
    blanks = np.zeros(v.shape, np.intp)          # leading blanks: width - digits (at least one digit)
    for k in range(1, width):
        blanks += rest < _POWERS[k]
    groups, digit_groups = -(-width // 4), _digit_groups()
    buf = np.empty(v.shape + (groups,), "<u4")
    for j in range(groups - 1, 0, -1):           # four digits per integer division
        buf[..., j] = digit_groups[rest % 10000]
        rest //= 10000
    buf[..., 0] = digit_groups[rest]
    blanks *= 2
    blanks += v < 0
    buf -= np.take(_padding(width), blanks, axis=0)
    return buf.view(np.uint8).reshape(v.shape + (4 * groups,))[..., 4 * groups - width:]


def text_width(values: np.ndarray) -> int:
    """Characters the widest of ``values`` needs (digits, and a sign if any is negative).

    Parameters
    ----------
    values : ndarray of int
        The integers, any shape.

    Returns
    -------
    int
        The width (1 for no values).

    Raises
    ------
    ValueError
        A value of magnitude :data:`LIMIT` or more.
    """
    v = np.asarray(values, np.int64)
    if not v.size:
        return 1
    top = int(np.max(np.abs(v)))
    if top >= LIMIT:
        raise ValueError(f"integer {top} too large for a JSON slot (limit 1e18)")
    return len(str(top)) + int(bool(np.any(v < 0)))


def _width(lo: int, hi: int) -> int:
    """:func:`text_width` of values from ``lo`` to ``hi`` (``lo <= hi``), on Python integers."""
    top = max(-lo, hi)
    if top >= LIMIT:
        raise ValueError(f"integer {top} too large for a JSON slot (limit 1e18)")
    return len(str(top)) + (lo < 0)


class JsonTemplate:
    """Literal JSON text with integer slots, built by :meth:`text` and :meth:`number` calls in order.

    Parameters
    ----------
    kinds : int
        Number of slot kinds (a kind's slots share one width per batch).
    """

    def __init__(self, kinds: int = 1) -> None:
        self.kinds = kinds
        self._literals: list[str] = [""]
        self._slot_kinds: list[int] = []
        self._slot_columns: list[int] = []              # the column of ``values`` each slot shows
        self._column_kinds: list[int] = []              # the kind of each column
        self._kind_columns: list[np.ndarray] = []       # the columns of each kind (made again when columns are added)
        self._layouts: dict[tuple[int, ...], tuple[np.ndarray, ...]] = {}
        self._kind_order, self._kind_starts = np.zeros(0, int), np.zeros(0, int)
        self._encoded: tuple[list[bytes], np.ndarray] | None = None   # the literals as bytes, where each ends

    @property
    def slots(self) -> int:
        """Number of integer slots."""
        return len(self._slot_kinds)

    @property
    def columns(self) -> int:
        """Number of integers a message takes (columns of :meth:`fill`'s values; slots may show one twice)."""
        return len(self._column_kinds)

    def text(self, literal: str) -> "JsonTemplate":
        """Append literal text.

        Parameters
        ----------
        literal : str
            JSON text.

        Returns
        -------
        JsonTemplate
            This template (calls chain).
        """
        self._literals[-1] += literal
        self._forget_layouts()
        return self

    def number(self, kind: int = 0, column: int | None = None) -> "JsonTemplate":
        """Append an integer slot of ``kind``, showing a new column of the values or an earlier one.

        Parameters
        ----------
        kind : int
            Slot kind, ``0 <= kind < kinds``.
        column : int, optional
            The column of :meth:`fill`'s values the slot shows: an earlier slot's (of the same kind), so
            that a number written twice is given once; default a new column (the next).

        Returns
        -------
        JsonTemplate
            This template (calls chain).

        Raises
        ------
        ValueError
            ``kind`` out of range, or ``column`` not an existing column of that kind.
        """
        if not 0 <= kind < self.kinds:
            raise ValueError(f"slot kind {kind} outside 0..{self.kinds - 1}")
        if column is None:
            column = len(self._column_kinds)
            self._column_kinds.append(kind)
        elif not 0 <= column < len(self._column_kinds) or self._column_kinds[column] != kind:
            raise ValueError(f"column {column}: not an existing column of kind {kind}")
        self._slot_kinds.append(kind)
        self._slot_columns.append(column)
        self._literals.append("")
        self._forget_layouts()
        return self

    def _forget_layouts(self) -> None:
        """The text changed: the blank messages made so far no longer hold."""
        if self._encoded is not None or self._layouts:
            self._encoded = None
            self._layouts = {}

    def _widths(self, values: np.ndarray) -> tuple[int, ...]:
        """Each kind's width in this batch: :func:`text_width` of the kind's smallest and largest value
        (what decides the width of all its values: the largest magnitude and whether one is negative)."""
        if len(self._kind_columns) != self.kinds or sum(map(len, self._kind_columns)) != self.columns:
            kinds = np.array(self._column_kinds, int)
            self._kind_columns = [np.flatnonzero(kinds == k) for k in range(self.kinds)]
            used = [c for c in self._kind_columns if len(c)]
            self._kind_order = np.concatenate(used) if used else np.zeros(0, int)    # the slots, kind by kind
            self._kind_starts = np.cumsum([0] + [len(c) for c in used])[:-1]
        if not len(values) or not self.columns:
            return (1,) * self.kinds
        lo = iter(np.minimum.reduceat(values.min(axis=0)[self._kind_order], self._kind_starts).tolist())
        hi = iter(np.maximum.reduceat(values.max(axis=0)[self._kind_order], self._kind_starts).tolist())
        return tuple(_width(next(lo), next(hi)) if len(c) else 1 for c in self._kind_columns)

    def _layout(self, widths: tuple[int, ...]):
        """The blank message (spaces in the slots), each slot's start, width and column (int64, for the C kernel)."""
        if widths not in self._layouts:
            if self._encoded is None:                                   # once per template (and change)
                lit = [x.encode() for x in self._literals]
                self._encoded = lit, np.cumsum([len(x) for x in lit[:-1]], dtype=np.int64)
            lit, before = self._encoded
            w = np.array(widths, np.int64)[self._slot_kinds] if self.slots else np.zeros(0, np.int64)
            starts = before + np.concatenate([[0], np.cumsum(w[:-1])]).astype(np.int64)
            spaces = [b" " * k for k in widths]
            pieces = [b""] * (2 * self.slots + 1)
            pieces[0::2] = lit
            pieces[1::2] = [spaces[k] for k in self._slot_kinds]
            columns = np.array(self._slot_columns, np.int64)
            self._layouts[widths] = np.frombuffer(b"".join(pieces), np.uint8), starts, w, columns
        return self._layouts[widths]

    def fill(self, values: np.ndarray, views: bool = False) -> list[bytes] | list[memoryview]:
        """The messages, one per row of ``values``.

        Parameters
        ----------
        values : int array, shape (n, columns)
            The integers of each message, in the order of their columns (of the slots, when no slot shows
            an earlier slot's column: see :meth:`number`).
        views : bool
            Give the messages as read-only memoryviews of one array instead of ``bytes`` (no copy of each:
            for a writer that copies them into its records anyway).

        Returns
        -------
        list of bytes or list of memoryview
            n UTF-8 JSON texts.

        Raises
        ------
        ValueError
            ``values`` of the wrong shape, or a value of magnitude 1e18 or more.
        """
        values = np.asarray(values, np.int64)
        n = len(values)
        if values.shape != (n, self.columns):
            raise ValueError(f"values: expected shape (n, {self.columns}), got {values.shape}")
        blank, starts, slot_widths, columns = self._layout(self._widths(values))
        out = np.empty((n, len(blank)), np.uint8)
        fill = digits_kernel()
        if fill is not None and n:
            values = np.ascontiguousarray(values)
            fill(blank.ctypes.data, len(blank), starts.ctypes.data, slot_widths.ctypes.data, columns.ctypes.data,
                 self.slots, values.ctypes.data, self.columns, n, out.ctypes.data)
        else:
            out[:] = blank
            values = values[:, columns]
            for width in sorted(set(slot_widths.tolist())):
                idx = np.flatnonzero(slot_widths == width)
                out[:, starts[idx, None] + np.arange(width)] = int_text(values[:, idx], width)
        if views and n:
            out.flags.writeable = False
            whole, size = memoryview(out).cast("B"), out.shape[1]
            return [whole[i:i + size] for i in range(0, n * size, size)]
        return [row.tobytes() for row in out]


@functools.cache
def digits_kernel() -> Any:
    """The C kernel's ``coordarm_json_fill``, typed: built or loaded on the first call (from the main thread
    where possible, see :func:`~coordarm.generated.kernels.kernel_library`).

    Returns
    -------
    ctypes function or None
        ``(blank, size, starts, widths, columns, slots, values, value_columns, n, out)``; None without a working
        C compiler (the numpy path then writes the digits).
    """
    from coordarm.generated.kernels import kernel_library    # here: the build machinery loads on first use
    lib = kernel_library("json_digits.c")
    if lib is None:
        return None
    p, i = ctypes.c_void_p, ctypes.c_longlong
    lib.coordarm_json_fill.argtypes = [p, i, p, p, p, i, p, i, i, p]
    lib.coordarm_json_fill.restype = None
    return lib.coordarm_json_fill
