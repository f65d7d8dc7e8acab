"""The per-step message records of a log block, packed in one pass of C where possible.

A log keeps one packed record per logged step: for each per-step channel (:data:`~.log_schemas.PER_STEP`) a
Message record header, the CDR header and the channel's doubles (:attr:`RunLogger.sample_dtype`). Filling a
block of them with numpy takes a strided pass per header field and per message field (some 18 a block),
holding the GIL between them; :class:`RecordPacker` writes each record whole in one pass of a small C kernel
(``generated/templates/log_records.c``, a :mod:`~coordarm.generated.kernels` library) called through ctypes,
which releases the GIL meanwhile. The bytes are the numpy path's, which runs where the kernel cannot: no C
compiler, a big-endian machine, thinned rows, a field that is not float64 with adjacent columns.
"""
from __future__ import annotations

import ctypes
import functools
import sys
from typing import Any, Sequence

import numpy as np

from .mcap_file import MESSAGE_HEADER_DTYPE


@functools.cache
def packing_kernel() -> Any:
    """The C kernel's ``coordarm_pack_records``, typed (built or loaded on the first call), or None where it
    cannot serve: no working C compiler, or a big-endian machine (MCAP and CDR are little-endian; the kernel
    copies bytes as they are).

    Returns
    -------
    ctypes function or None
        ``(out, n, size, copies, src, src_step, dst, bytes, headers, hdr_at, seq0, times, seq_at, log_at, pub_at)``.
    """
    if sys.byteorder != "little":
        return None
    from coordarm.generated.kernels import kernel_library    # here: the build machinery loads on first use
    lib = kernel_library("log_records.c")
    if lib is None:
        return None
    p, i = ctypes.c_void_p, ctypes.c_longlong
    lib.coordarm_pack_records.argtypes = [p, i, i, i, p, p, p, p, i, p, p, p, i, i, i]
    lib.coordarm_pack_records.restype = None
    return lib.coordarm_pack_records


class RecordPacker:
    """Writes the records of a block of steps: each message's sequence number and times, and its fields.

    Parameters
    ----------
    dtype : numpy.dtype
        The packed record: for each key, fields ``key + "_hdr"`` (:data:`~.mcap_file.MESSAGE_HEADER_DTYPE`)
        and ``key`` (the channel's doubles).
    channels : dict of str to NumericChannel
        The channel of each key (its :meth:`~.log_schemas.NumericChannel.slices` and ``fill``).
    keys : sequence of str
        The keys, in the order of the record.
    """

    def __init__(self, dtype: np.dtype, channels: dict, keys: Sequence[str]) -> None:
        self.dtype, self.channels, self.keys = np.dtype(dtype), channels, tuple(keys)
        header = MESSAGE_HEADER_DTYPE.fields
        self._at = [header[name][1] for name in ("sequence", "log_time", "publish_time")]
        self._hdr_at = np.array([self.dtype.fields[key + "_hdr"][1] for key in self.keys], np.int64)
        # each field: (its Run array's name, where it starts in the record [bytes], its columns)
        self._field_copies = []
        for key in self.keys:
            start = self.dtype.fields[key][1]
            for name, cols in channels[key].slices().items():
                first, width = (cols.start, cols.stop - cols.start) if isinstance(cols, slice) else (cols, 1)
                self._field_copies.append((name, start + 8 * first, width))

    def pack(self, records: np.ndarray, part: Any, rows: slice | np.ndarray, sequences: Sequence[int],
             log_times: np.ndarray) -> None:
        """Fill ``records`` (one per row of ``part`` at ``rows``) but for the fields every record has alike.

        Parameters
        ----------
        records : ndarray of ``dtype``, shape (n,)
            The records to write.
        part : Run
            The block (an array attribute per field).
        rows : slice or ndarray of int
            Its n rows to write.
        sequences : sequence of int
            The sequence number of each key's first message (the next ones count up, modulo 2^32).
        log_times : ndarray of uint64, shape (n,)
            Log (and publish) time of each row [ns].
        """
        n = len(records)
        if not n:
            return
        kernel = packing_kernel() if isinstance(rows, slice) else None
        sources = [getattr(part, name)[rows] for name, _, _ in self._field_copies] if kernel is not None else []
        if kernel is not None and all(_packable(a, n, width) for a, (_, _, width) in zip(sources, self._field_copies)):
            times = np.ascontiguousarray(log_times, np.uint64)
            copies = np.array([[a.ctypes.data, a.strides[0], at, 8 * width]
                               for a, (_, at, width) in zip(sources, self._field_copies)], np.int64).T.copy()
            seq0 = np.array(sequences, np.int64)
            kernel(records.ctypes.data, n, self.dtype.itemsize, len(sources), copies[0].ctypes.data,
                   copies[1].ctypes.data, copies[2].ctypes.data, copies[3].ctypes.data, len(self.keys),
                   self._hdr_at.ctypes.data, seq0.ctypes.data, times.ctypes.data, *self._at)
            return
        for key, first in zip(self.keys, sequences):
            hdr = records[key + "_hdr"]
            hdr["sequence"] = (first + np.arange(n)) & 0xFFFFFFFF
            hdr["log_time"] = hdr["publish_time"] = log_times
            self.channels[key].fill(records[key], part, rows)


def _packable(array: np.ndarray, n: int, width: int) -> bool:
    """Whether the kernel can copy ``array``'s rows as they are: float64 (native), n rows, ``width`` adjacent columns."""
    if array.dtype != np.float64 or len(array) != n:
        return False
    if array.ndim == 1:
        return width == 1
    return array.ndim == 2 and array.shape[1] == width and array.strides[1] == 8
