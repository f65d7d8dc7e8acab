"""A lean MCAP writer that takes whole chunks of pre-encoded message records.

``mcap.writer.Writer.add_message`` costs a few microseconds of Python per message (a
``Message`` object, statistics, a message-index entry, five ``struct.pack`` calls); at
30,000 steps and three channels that is more than a fast simulation itself. Here the caller
hands over the message records of a whole chunk as one ``bytes`` object built with numpy,
plus the (log time, offset) pairs of each channel, and this class frames the chunk, its
message indexes, and at the end the summary section exactly as the MCAP specification (and
``mcap.writer.Writer``) does. Every record other than messages is written by the record
classes of the ``mcap`` library itself.
"""
from __future__ import annotations

import errno
import fcntl
import os
import queue
import struct
import threading
import zlib
from collections import defaultdict
from pathlib import Path
from typing import Any, BinaryIO, Callable

import mcap
import numpy as np
import zstandard

from mcap.data_stream import RecordBuilder
from mcap.opcode import Opcode
from mcap.records import (Channel, Chunk, ChunkIndex, DataEnd, Footer, Header, Metadata, MetadataIndex, Schema,
                          Statistics, SummaryOffset)

from .choices import COMPRESSIONS, DEFAULT_COMPRESSION, Compression, lz4_frame
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


def message_records(channel_id: int, log_times: np.ndarray, data: list[bytes], sequence0: int = 0) -> bytes:
    """Message records for a few messages of variable size (the slow path, for low-rate channels).

    Parameters
    ----------
    channel_id : int
        The channel's id.
    log_times : ndarray of int, shape (n,)
        Log (and publish) time of each message [ns].
    data : list of bytes
        The n message bodies.
    sequence0 : int
        Sequence number of the first message (wraps at 2^32).

    Returns
    -------
    bytes
        The encoded records, back to back.
    """
    out = bytearray()
    for i, (lt, d) in enumerate(zip(log_times, data)):
        out += struct.pack("<BQHIQQ", Opcode.MESSAGE, MESSAGE_HEADER_SIZE - 9 + len(d), channel_id,
                           (sequence0 + i) & 0xFFFFFFFF, int(lt), int(lt))
        out += d
    return bytes(out)


def open_locked(path: Path) -> BinaryIO:
    """Open ``path`` for writing, emptied, holding an exclusive lock (``flock``) until it is closed.

    The lock goes with the process: a killed writer leaves no stale lock behind.

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
    os.ftruncate(fd, 0)
    return os.fdopen(fd, "wb")


#: Threads freeing the storage of files replaced by :func:`replace_in_background` (see :func:`wait_released`).
_releasing: list[threading.Thread] = []


def replace_in_background(src: str | os.PathLike, dst: str | os.PathLike) -> None:
    """``os.replace(src, dst)``, with the storage of the file it replaces freed on a thread of its own.

    The rename is the same atomic step; only the kernel's freeing of the old file's blocks and cached
    pages, which holding it open defers to the last close (20-30 ms for a 40 MB log on ext4), runs on a
    daemon thread, so the caller goes on (e.g. with the run's summary) meanwhile.
    :func:`wait_released` waits for it; a process that ends first frees the file as it exits.

    Parameters
    ----------
    src, dst : str or path-like
        As for :func:`os.replace`.

    Raises
    ------
    OSError
        As :func:`os.replace` raises it.
    """
    try:
        old = os.open(dst, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0))
    except OSError:                 # nothing there (or not readable): a plain rename
        old = None
    try:
        os.replace(src, dst)
    except BaseException:
        if old is not None:
            os.close(old)
        raise
    if old is not None:
        thread = threading.Thread(target=os.close, args=(old,), name="coordarm-release", daemon=True)
        thread.start()
        _releasing.append(thread)


def wait_released() -> None:
    """Wait until the files replaced by :func:`replace_in_background` so far are freed (from any thread)."""
    while True:
        try:
            thread = _releasing.pop()
        except IndexError:       # none left (another thread may have taken the last one)
            return
        thread.join()


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
        self._compress: Callable[[bytes], bytes] = bytes          # none: the records as they are
        if compression == Compression.ZSTD:
            self._compress = zstandard.ZstdCompressor(level=1).compress
        elif compression == Compression.LZ4:
            self._compress = lz4_frame().compress
        self._stream: BinaryIO = open_locked(self.path)
        self._schemas: list[Schema] = []
        self._channels: list[Channel] = []
        self._chunk_indexes: list[ChunkIndex] = []
        self._metadata_indexes: list[MetadataIndex] = []
        self._counts: dict[int, int] = defaultdict(int)
        self._time = [None, 0]
        self._metadata_count = 0
        self._closed = False
        self._stream.write(MCAP0_MAGIC)
        self._write(Header(profile, LIBRARY_IDENTIFIER))
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

    def _write(self, *records) -> int:
        """Write records; return the offset of the first."""
        builder = RecordBuilder()
        for r in records:
            r.write(builder)
        offset = self._stream.tell()
        self._stream.write(builder.end())
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
        schema = Schema(id=len(self._schemas) + 1, name=name, encoding=encoding, data=data)
        self._schemas.append(schema)
        self._write(schema)
        return schema.id

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
        channel = Channel(id=len(self._channels) + 1, topic=topic, message_encoding=message_encoding,
                          schema_id=schema_id, metadata=dict(metadata or {}))
        self._channels.append(channel)
        self._write(channel)
        return channel.id

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
        builder = RecordBuilder()
        Metadata(name=name, metadata={**data, DIGEST_KEY: metadata_digest(data)}).write(builder)
        raw = builder.end()
        offset = self._stream.tell()
        self._stream.write(raw)
        self._metadata_indexes.append(MetadataIndex(offset=offset, length=len(raw), name=name))
        self._metadata_count += 1

    def write_chunk(self, records: bytes, index: dict[int, tuple[np.ndarray, np.ndarray]]) -> None:
        """Compress and write one chunk and its message indexes.

        Parameters
        ----------
        records : bytes-like
            Concatenated Message records (see :data:`MESSAGE_HEADER_DTYPE`); ``bytes`` or a contiguous
            uint8 array, which must not change afterwards (it may be compressed later, on the chunk thread).
        index : dict
            Channel id -> ``(log_times, offsets)`` (uint64 arrays) of that channel's messages
            inside ``records``; empty: nothing is written.

        Raises
        ------
        Exception
            The error with which the chunk thread failed on an earlier chunk, raised again.
        """
        if not index:
            return
        if self._worker is not None:
            if self._worker.error is not None:
                raise self._worker.error
            self._worker.put((records, index))
        else:
            self._write_chunk_now(records, index)

    def _write_chunk_now(self, records: bytes, index: dict[int, tuple[np.ndarray, np.ndarray]]) -> None:
        times = np.concatenate([lt for lt, _ in index.values()])
        start, end = int(times.min()), int(times.max())
        data = self._compress(records)
        chunk = Chunk(compression=self.compression, data=data, message_start_time=start, message_end_time=end,
                      uncompressed_crc=zlib.crc32(records), uncompressed_size=len(records))
        builder = RecordBuilder()
        chunk.write(builder)
        chunk_raw = builder.end()
        chunk_offset = self._stream.tell()
        self._stream.write(chunk_raw)
        index_offset = self._stream.tell()
        parts, offsets, pos = [], {}, index_offset
        for channel_id, (lt, off) in index.items():
            pairs = np.empty((len(lt), 2), "<u8")
            pairs[:, 0], pairs[:, 1] = lt, off
            body = struct.pack("<HI", channel_id, pairs.nbytes) + pairs.tobytes()
            parts.append(struct.pack("<BQ", Opcode.MESSAGE_INDEX, len(body)) + body)
            offsets[channel_id] = pos
            pos += len(parts[-1])
            self._counts[channel_id] += len(lt)
        self._stream.write(b"".join(parts))
        self._chunk_indexes.append(ChunkIndex(
            message_start_time=start, message_end_time=end, chunk_start_offset=chunk_offset,
            chunk_length=len(chunk_raw), message_index_offsets=offsets, message_index_length=pos - index_offset,
            compression=self.compression, compressed_size=len(data), uncompressed_size=len(records)))
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
            (:func:`replace_in_background`; :func:`wait_released` waits for it) instead of before returning.
        """
        if self._closed:
            return
        self._wait()
        self._stop()
        self._closed = True
        self._write(DataEnd(0))
        summary_start = self._stream.tell()
        builder = RecordBuilder()
        groups = []
        for opcode, records in ((Opcode.SCHEMA, self._schemas), (Opcode.CHANNEL, self._channels),
                                (Opcode.STATISTICS, [self._statistics()]),
                                (Opcode.CHUNK_INDEX, self._chunk_indexes),
                                (Opcode.METADATA_INDEX, self._metadata_indexes)):
            group_start = builder.count
            for r in records:
                r.write(builder)
            groups.append(SummaryOffset(group_opcode=opcode, group_start=summary_start + group_start,
                                        group_length=builder.count - group_start))
        offset_start = summary_start + builder.count
        for g in groups:
            g.write(builder)
        summary = builder.end()
        crc = zlib.crc32(summary)
        crc = zlib.crc32(struct.pack("<BQQQ", Opcode.FOOTER, 20, summary_start, offset_start), crc)
        self._stream.write(summary)
        self._write(Footer(summary_start=summary_start, summary_offset_start=offset_start, summary_crc=crc))
        self._stream.write(MCAP0_MAGIC)
        self._stream.flush()
        if rename_to is not None:
            (replace_in_background if free_replaced_later else os.replace)(self.path, rename_to)
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

    def _statistics(self) -> Statistics:
        return Statistics(attachment_count=0, channel_count=len(self._channels),
                          channel_message_counts=dict(self._counts), chunk_count=len(self._chunk_indexes),
                          message_count=sum(self._counts.values()), metadata_count=self._metadata_count,
                          message_start_time=self._time[0] or 0, message_end_time=self._time[1],
                          schema_count=len(self._schemas))
