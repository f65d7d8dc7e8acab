"""A lean MCAP writer that takes whole chunks of pre-encoded message records.

``mcap.writer.Writer.add_message`` costs a few microseconds of Python per message (a
``Message`` object, statistics, a message-index entry, five ``struct.pack`` calls); at
30,000 steps and three channels that is more than a fast simulation itself. Here the caller
hands over the message records of a whole chunk, built with numpy, as one buffer or a few parts
(compressed one after the other, never joined: :func:`parts_compressor`), plus the (log time,
offset) pairs of each channel, and this class frames the chunk, its message indexes, and at the
end the summary section exactly as the MCAP specification (and ``mcap.writer.Writer``) does. The
records are encoded by :mod:`.mcap_records` (``mcap.records`` costs ~7 ms to import).
"""
from __future__ import annotations

import errno
import fcntl
import functools
import os
import queue
import struct
import threading
import zlib
from collections import defaultdict
from pathlib import Path
from typing import Any, BinaryIO, Callable, Sequence

import mcap
import numpy as np

from . import mcap_records as rec
from .choices import COMPRESSIONS, DEFAULT_COMPRESSION, Compression, lz4_frame
from .file_replace import replace
from .log_layout import DIGEST_KEY, metadata_digest


#: The magic bytes that open and close an MCAP file (the MCAP specification: 0x89, "MCAP0", CR, LF); as
#: ``mcap.writer.MCAP0_MAGIC``, which is not imported: ``mcap.writer`` loads ``importlib.metadata``
#: (~25 ms at every start-up; ``tests/test_mcap_file_constants.py`` checks the two agree).
MCAP0_MAGIC = b"\x89MCAP0\r\n"
#: The header's ``library`` field: mcap-python's, as ``mcap.writer.LIBRARY_IDENTIFIER`` (whose records we write).
LIBRARY_IDENTIFIER = f"mcap-python/{mcap.__version__}"

#: Bytes of a Message record before its data: opcode, length, channel id, sequence, log and publish time.
MESSAGE_HEADER_SIZE = 1 + 8 + 2 + 4 + 8 + 8


#: Packed numpy dtype of a Message record header (the data follows it).
MESSAGE_HEADER_DTYPE = np.dtype([("opcode", "u1"), ("length", "<u8"), ("channel", "<u2"), ("sequence", "<u4"),
                                 ("log_time", "<u8"), ("publish_time", "<u8")])


#: A Message record's header, as :data:`MESSAGE_HEADER_DTYPE` (opcode, length, channel, sequence, log time,
#: publish time), packed one at a time for the few records of the low-rate channels.
_MESSAGE_HEADER = struct.Struct("<BQHIQQ")


def message_records(channels: Sequence[int], sequences: Sequence[int], log_times: Sequence[int],
                    data: Sequence[Any], offset: int = 0) -> tuple[bytes, np.ndarray]:
    """Message records of a few messages of any channels and sizes, back to back (for the low-rate channels).

    Parameters
    ----------
    channels, sequences, log_times : sequence of int, length n
        Each message's channel id, sequence number (< 2^32) and log (and publish) time [ns].
    data : sequence of bytes-like, length n
        The message bodies.
    offset : int
        Where the first record will sit in its chunk [bytes].

    Returns
    -------
    records : bytes
        The n records.
    offsets : uint64 ndarray, shape (n,)
        Where each record sits in the chunk: ``offset`` plus its position in ``records`` [bytes].
    """
    n = len(data)
    lengths = [len(d) if type(d) is bytes else memoryview(d).nbytes for d in data]
    pieces: list[Any] = [b""] * (2 * n)          # header, body, header, body, ...
    pieces[1::2] = data
    pieces[0::2] = map(_MESSAGE_HEADER.pack, [rec.MESSAGE] * n, [size + MESSAGE_HEADER_SIZE - 9 for size in lengths],
                       np.asarray(channels, "<u2").tolist(), np.asarray(sequences, "<u4").tolist(),
                       *[np.asarray(log_times, "<u8").tolist()] * 2)
    sizes = np.array(lengths, np.uint64) + np.uint64(MESSAGE_HEADER_SIZE)
    return b"".join(pieces), np.cumsum(sizes) - sizes + np.uint64(offset)


def parts_compressor(compression: str) -> Callable[[Sequence[Any], int], list]:
    """What compresses a chunk's records given in parts: ``compress(parts, size)`` -> the data, in parts.

    lz4 compresses the parts one after the other into one frame with ``lz4.frame.compress``'s settings (for
    one part its very bytes; for several, blocks may fall elsewhere: the frame decompresses to the whole);
    zstd (level 1) compresses them joined (its streaming interface is ~10 % slower than a join and one
    call); none returns them as they are. Nothing is copied but for zstd's join.

    Parameters
    ----------
    compression : {"lz4", "zstd", "none"}
        The chunk compression.

    Returns
    -------
    callable
        ``compress(parts, size)``: ``parts`` a sequence of bytes-like objects of ``size`` bytes in all;
        returns a list of bytes-like objects whose concatenation is the chunk's data. Not for two threads at once.

    Raises
    ------
    ConfigError
        ``compression="lz4"`` without the lz4 package installed.
    """
    if compression == Compression.ZSTD:
        from zstandard import ZstdCompressor     # here: only a zstd log loads it
        one_call = ZstdCompressor(level=1).compress
        return lambda parts, size: [one_call(parts[0] if len(parts) == 1 else b"".join(parts))]
    if compression == Compression.LZ4:
        frames = lz4_frame().LZ4FrameCompressor()   # lz4.frame.compress's defaults; the size stored in the frame

        def lz4_parts(parts: Sequence[Any], size: int) -> list:
            return [frames.begin(size), *(frames.compress(p) for p in parts), frames.flush()]
        return lz4_parts
    return lambda parts, size: list(parts)


@functools.cache
def crc32_function() -> Callable[..., int]:
    """The CRC-32 of the chunks: zlib-ng's (carry-less multiplication, ~4x faster than zlib 1.2's) where the
    ``zlib-ng`` package is installed, else :func:`zlib.crc32`; the same values (the MCAP and zlib CRC-32).
    Loaded on the first chunk (the chunk thread's), not at start-up.

    Returns
    -------
    callable
        ``crc32(data, value=0)`` -> int, releasing the GIL on large buffers.
    """
    try:
        from zlib_ng.zlib_ng import crc32
    except ImportError:
        return zlib.crc32
    return crc32


def open_locked(path: Path) -> BinaryIO:
    """Open ``path`` for writing, emptied, holding an exclusive lock (``flock``) until it is closed.

    The lock goes with the process: a killed writer leaves no stale lock behind. Only a file that is not
    empty is truncated: ext4 (its ``auto_da_alloc``) writes a truncated file out as it is closed, which made
    the close of a 41 MB log take 18-30 ms (``strace -T``) at the end of ``coordarm run``, against 0-3 ms.

    Parameters
    ----------
    path : Path
        The file.

    Returns
    -------
    BinaryIO
        The file opened ``"wb"``, empty.

    Raises
    ------
    OSError
        It cannot be created, or another process holds its lock (``EBUSY``).
    """
    fd = os.open(path, os.O_WRONLY | os.O_CREAT, 0o644)
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except BlockingIOError:
        os.close(fd)
        raise OSError(errno.EBUSY, "another process is writing this file", str(path)) from None
    except BaseException:
        os.close(fd)
        raise
    if os.fstat(fd).st_size:
        os.ftruncate(fd, 0)
    return os.fdopen(fd, "wb")


class Worker:
    """One background thread that applies ``handle`` to queued jobs, in order.

    The first failure is kept in :attr:`error` and the jobs after it are skipped; the owner
    re-raises it on its next call. With ``idle``, that is called whenever no job came for
    ``idle_interval`` seconds (e.g. to flush what was written so far).

    Parameters
    ----------
    handle : callable
        ``handle(job)``, applied to each job.
    name : str
        The thread's name.
    maxsize : int
        Most jobs queued (0: no limit).
    idle : callable or None
        ``idle()``, called after ``idle_interval`` without a job.
    idle_interval : float
        Wait before ``idle`` is called [s].
    """

    def __init__(self, handle: Callable[[Any], None], name: str, maxsize: int,
                 idle: Callable[[], None] | None = None, idle_interval: float = 0.25) -> None:
        self.error: BaseException | None = None
        self._handle, self._idle, self._idle_interval = handle, idle, idle_interval
        self._queue: queue.Queue = queue.Queue(maxsize=maxsize)
        self._thread = threading.Thread(target=self._run, name=name, daemon=True)
        self._thread.start()

    def _run(self) -> None:
        while True:
            try:
                job = self._queue.get(timeout=self._idle_interval if self._idle else None)
            except queue.Empty:
                try:
                    if self.error is None:
                        self._idle()
                except BaseException as exc:  # re-raised by the owner
                    self.error = exc
                continue
            try:
                if job is None:
                    return
                if self.error is None:
                    self._handle(job)
            except BaseException as exc:  # re-raised by the owner
                self.error = exc
            finally:
                self._queue.task_done()

    def put(self, job: Any) -> None:
        """Queue ``job`` (blocks while the queue is full; never with ``maxsize=0``).

        Parameters
        ----------
        job : Any
            Passed to ``handle``; None stops the thread.
        """
        self._queue.put(job)

    def join(self) -> None:
        """Wait until every queued job is done."""
        self._queue.join()

    def stop(self) -> None:
        """Finish the queued jobs and end the thread."""
        self._queue.put(None)
        self._thread.join()


class McapFile:
    """Write an MCAP file: header, schemas, channels and metadata, then chunks, then the summary.

    Parameters
    ----------
    path : str or Path
        File to create (emptied if it exists), locked against a second writer until closed.
    profile : str
        MCAP profile written in the header (``"ros2"`` for ``cdr`` channels).
    compression : {"lz4", "zstd", "none"}
        Chunk compression: lz4 (frame format, fast mode; the default) compresses 2-3x faster than
        zstd (level 1), which makes files about 1.4x smaller; none stores the records as they are
        (MCAP's empty compression string; benchmarks/RESULTS.md, issue 24).
    background : bool
        Compress and write chunks on a thread of their own (zstd, lz4 and zlib release the
        GIL), so that the caller can build the next chunk meanwhile; :meth:`flush` and
        :meth:`close` wait.

    Raises
    ------
    ValueError
        Unknown compression.
    ConfigError
        ``compression="lz4"`` without the lz4 package installed.
    """

    def __init__(self, path: str | Path, profile: str = "", compression: str = DEFAULT_COMPRESSION,
                 background: bool = False) -> None:
        if compression not in COMPRESSIONS:
            raise ValueError(f"compression: expected one of {COMPRESSIONS}, got {compression!r}")
        self.path = Path(path)
        self.compression = "" if compression == Compression.NONE else compression   # as the Chunk record names it
        self._compress = parts_compressor(compression)
        self._stream: BinaryIO = open_locked(self.path)
        self._schemas: list[bytes] = []          # the summary's records, encoded (mcap_records)
        self._channels: list[bytes] = []
        self._chunk_indexes: list[bytes] = []
        self._metadata_indexes: list[bytes] = []
        self._counts: dict[int, int] = defaultdict(int)
        self._time = [None, 0]
        self._metadata_count = 0
        self._closed = False
        self._stream.write(MCAP0_MAGIC)
        self._write(rec.header_record(profile, LIBRARY_IDENTIFIER))
        self._worker = Worker(lambda job: self._write_chunk_now(*job), "mcap-chunks", 4) if background else None

    def _wait(self) -> None:
        """Wait until every queued chunk is written; re-raise a failure of the chunk thread."""
        if self._worker is not None:
            self._worker.join()
            if self._worker.error is not None:
                raise self._worker.error

    @property
    def closed(self) -> bool:
        """Whether :meth:`close` has run."""
        return self._closed

    def _write(self, raw: bytes) -> int:
        """Write an encoded record; return its offset."""
        offset = self._stream.tell()
        self._stream.write(raw)
        return offset

    def add_schema(self, name: str, encoding: str, data: bytes) -> int:
        """Register a schema; returns its id (1, 2, ...).

        Parameters
        ----------
        name : str
            Schema name, e.g. ``coordarm_msgs/msg/JointState``.
        encoding : str
            Schema encoding, e.g. ``ros2msg`` or ``jsonschema``.
        data : bytes
            The schema definition.

        Returns
        -------
        int
            The schema id.
        """
        schema_id = len(self._schemas) + 1
        self._schemas.append(rec.schema_record(schema_id, name, encoding, data))
        self._write(self._schemas[-1])
        return schema_id

    def add_channel(self, topic: str, message_encoding: str, schema_id: int,
                    metadata: dict[str, str] | None = None) -> int:
        """Register a channel; returns its id (1, 2, ...).

        Parameters
        ----------
        topic : str
            Channel topic, e.g. ``/joint_state``.
        message_encoding : str
            ``cdr`` or ``json``.
        schema_id : int
            Id from :meth:`add_schema`.
        metadata : dict of str to str or None
            Channel metadata.

        Returns
        -------
        int
            The channel id.
        """
        channel_id = len(self._channels) + 1
        self._channels.append(rec.channel_record(channel_id, schema_id, topic, message_encoding, dict(metadata or {})))
        self._write(self._channels[-1])
        return channel_id

    def add_metadata(self, name: str, data: dict[str, str]) -> None:
        """Write a Metadata record (string values only) with its checksum (:func:`metadata_digest`) and index it.

        Parameters
        ----------
        name : str
            The record's name, e.g. ``scenario``.
        data : dict of str to str
            Its entries.
        """
        self._wait()
        raw = rec.metadata_record(name, {**data, DIGEST_KEY: metadata_digest(data)})
        self._metadata_indexes.append(rec.metadata_index_record(self._write(raw), len(raw), name))
        self._metadata_count += 1

    def write_chunk(self, records: Any, index: dict[int, tuple[np.ndarray, np.ndarray]]) -> None:
        """Compress and write one chunk and its message indexes.

        Parameters
        ----------
        records : bytes-like or list of bytes-like
            Concatenated Message records (see :data:`MESSAGE_HEADER_DTYPE`), or parts to be concatenated
            (they are compressed one after the other, never joined): ``bytes`` or contiguous uint8 arrays,
            which must not change afterwards (they may be compressed later, on the chunk thread).
        index : dict
            Channel id -> ``(log_times, offsets)`` (uint64 arrays) of that channel's messages
            inside the records; empty: nothing is written.

        Raises
        ------
        Exception
            The error with which the chunk thread failed on an earlier chunk, raised again.
        """
        if not index:
            return
        parts = records if isinstance(records, (list, tuple)) else [records]
        if self._worker is not None:
            if self._worker.error is not None:
                raise self._worker.error
            self._worker.put((parts, index))
        else:
            self._write_chunk_now(parts, index)

    def _write_chunk_now(self, parts: Sequence[Any], index: dict[int, tuple[np.ndarray, np.ndarray]]) -> None:
        times = np.concatenate([lt for lt, _ in index.values()])
        start, end = int(times.min()), int(times.max())
        size, crc, crc32 = 0, 0, crc32_function()
        for part in parts:                  # the CRC-32 of the whole, part by part
            crc = crc32(part, crc)
            size += memoryview(part).nbytes
        data = self._compress(parts, size)
        compressed = sum(memoryview(d).nbytes for d in data)
        head = rec.chunk_head(start, end, size, crc, self.compression, compressed)
        chunk_offset = self._write(head)
        for d in data:
            self._stream.write(d)
        index_offset = pos = chunk_offset + len(head) + compressed
        indexes, offsets = [], {}
        for channel_id, (lt, off) in index.items():
            indexes.append(rec.message_index_record(channel_id, lt, off))
            offsets[channel_id] = pos
            pos += len(indexes[-1])
            self._counts[channel_id] += len(lt)
        self._stream.write(b"".join(indexes))
        self._chunk_indexes.append(rec.chunk_index_record(
            start, end, chunk_offset, index_offset - chunk_offset, offsets, pos - index_offset, self.compression,
            compressed, size))
        self._time = [start if self._time[0] is None else min(self._time[0], start), max(self._time[1], end)]

    def flush(self) -> None:
        """Push everything written so far to the operating system (survives a kill of this process)."""
        self._wait()
        self._stream.flush()

    def close(self, rename_to: str | Path | None = None, *, free_replaced_later: bool = False) -> None:
        """Write the data end, the summary section (schemas, channels, statistics, indexes), footer.

        With ``rename_to``, the finished file is renamed to it (replacing it) while still locked.

        Parameters
        ----------
        rename_to : str, Path or None
            Final name of the file.
        free_replaced_later : bool
            Free the storage of the file that ``rename_to`` replaces on a background thread
            (:func:`.file_replace.replace` with ``free_later``; :func:`.file_replace.wait_released` waits for it)
            instead of before returning.
        """
        if self._closed:
            return
        self._wait()
        self._stop()
        self._closed = True
        self._write(rec.data_end_record(0))
        summary_start = self._stream.tell()
        groups, pos, statistics = [], summary_start, [self._statistics()]
        for opcode, records in ((rec.SCHEMA, self._schemas), (rec.CHANNEL, self._channels),
                                (rec.STATISTICS, statistics), (rec.CHUNK_INDEX, self._chunk_indexes),
                                (rec.METADATA_INDEX, self._metadata_indexes)):
            length = sum(map(len, records))
            groups.append(rec.summary_offset_record(opcode, pos, length))
            pos += length
        summary = b"".join([*self._schemas, *self._channels, *statistics, *self._chunk_indexes,
                            *self._metadata_indexes, *groups])
        crc = zlib.crc32(summary)
        crc = zlib.crc32(struct.pack("<BQQQ", rec.FOOTER, 20, summary_start, pos), crc)
        self._stream.write(summary)
        self._write(rec.footer_record(summary_start, pos, crc))
        self._stream.write(MCAP0_MAGIC)
        self._stream.flush()
        if rename_to is not None:
            replace(self.path, rename_to, free_later=free_replaced_later)
            self.path = Path(rename_to)
        self._stream.close()

    def abandon(self) -> None:
        """Close the file as it is, without a summary (what a crash leaves behind)."""
        if not self._closed:
            self._stop()
            self._closed = True
            self._stream.close()

    def _stop(self) -> None:
        if self._worker is not None:
            self._worker.stop()
            self._worker = None

    def _statistics(self) -> bytes:
        return rec.statistics_record(sum(self._counts.values()), len(self._schemas), len(self._channels),
                                     self._metadata_count, len(self._chunk_indexes), self._time[0] or 0,
                                     self._time[1], dict(self._counts))
