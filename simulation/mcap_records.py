"""The MCAP records a log writes, encoded with :mod:`struct` (no ``mcap.records``: its dataclasses cost ~7 ms of
every start-up).

Each function returns the whole record, opcode and length first, laid out as the MCAP specification
(https://mcap.dev/spec) and ``mcap.records`` write it: little-endian integers, a string as its uint32 byte
length and UTF-8 bytes, a map as its uint32 byte length and its entries. ``tests/test_mcap_records.py``
checks every one against ``mcap.records`` byte for byte. A Chunk is written as :func:`chunk_head`
followed by its compressed data (not copied into the record).
"""
from __future__ import annotations

import struct

import numpy as np

#: The opcodes of the MCAP records (the MCAP specification; as ``mcap.opcode.Opcode``).
HEADER, FOOTER, SCHEMA, CHANNEL, MESSAGE, CHUNK, MESSAGE_INDEX, CHUNK_INDEX = 0x01, 0x02, 0x03, 0x04, 0x05, 0x06, 0x07, 0x08
STATISTICS, METADATA, METADATA_INDEX, SUMMARY_OFFSET, DATA_END = 0x0B, 0x0C, 0x0D, 0x0E, 0x0F

_PREFIX = struct.Struct("<BQ")           # opcode, record length
_CHUNK_HEAD = struct.Struct("<BQQQQI")   # opcode, length, start, end, uncompressed size, uncompressed CRC
_U32, _U64 = struct.Struct("<I"), struct.Struct("<Q")
#: One (channel id, uint64) entry of a Chunk Index's offsets or of the Statistics' message counts.
_ID_U64 = np.dtype([("id", "<u2"), ("value", "<u8")])


def record(opcode: int, body: bytes) -> bytes:
    """A record: ``opcode``, the body's length (uint64), the body.

    Parameters
    ----------
    opcode : int
        The record's opcode (e.g. :data:`SCHEMA`).
    body : bytes
        Its fields, encoded.

    Returns
    -------
    bytes
        The record.
    """
    return _PREFIX.pack(opcode, len(body)) + body


def string(value: str) -> bytes:
    """An MCAP string: uint32 byte length, then the UTF-8 bytes.

    Parameters
    ----------
    value : str
        The text.

    Returns
    -------
    bytes
        The encoded field.
    """
    raw = value.encode()
    return _U32.pack(len(raw)) + raw


def string_map(entries: dict[str, str]) -> bytes:
    """An MCAP ``Map<string, string>``: uint32 byte length, then each key and value as :func:`string`, in order.

    Parameters
    ----------
    entries : dict of str to str
        The map.

    Returns
    -------
    bytes
        The encoded field.
    """
    body = b"".join(string(k) + string(v) for k, v in entries.items())
    return _U32.pack(len(body)) + body


def _id_map(entries: dict[int, int]) -> bytes:
    """A ``Map<uint16, uint64>``: uint32 byte length, then 10 bytes per entry, in order."""
    pairs = np.empty(len(entries), _ID_U64)
    pairs["id"], pairs["value"] = list(entries), list(entries.values())
    return _U32.pack(pairs.nbytes) + pairs.tobytes()


def header_record(profile: str, library: str) -> bytes:
    """The Header record (the file's first).

    Parameters
    ----------
    profile : str
        The MCAP profile (e.g. ``"ros2"``).
    library : str
        The writing library's name.

    Returns
    -------
    bytes
        The record.
    """
    return record(HEADER, string(profile) + string(library))


def schema_record(schema_id: int, name: str, encoding: str, data: bytes) -> bytes:
    """A Schema record.

    Parameters
    ----------
    schema_id : int
        Its id (uint16, > 0).
    name, encoding : str
        Its name and encoding (e.g. ``"ros2msg"``).
    data : bytes
        The schema text.

    Returns
    -------
    bytes
        The record.
    """
    return record(SCHEMA, struct.pack("<H", schema_id) + string(name) + string(encoding) + _U32.pack(len(data)) + data)


def channel_record(channel_id: int, schema_id: int, topic: str, message_encoding: str,
                   metadata: dict[str, str]) -> bytes:
    """A Channel record.

    Parameters
    ----------
    channel_id, schema_id : int
        The channel's id and its schema's (uint16).
    topic, message_encoding : str
        E.g. ``"/joint_state"`` and ``"cdr"``.
    metadata : dict of str to str
        The channel's metadata.

    Returns
    -------
    bytes
        The record.
    """
    return record(CHANNEL, struct.pack("<HH", channel_id, schema_id) + string(topic) + string(message_encoding)
                  + string_map(metadata))


def metadata_record(name: str, metadata: dict[str, str]) -> bytes:
    """A Metadata record.

    Parameters
    ----------
    name : str
        Its name.
    metadata : dict of str to str
        Its entries, in order.

    Returns
    -------
    bytes
        The record.
    """
    return record(METADATA, string(name) + string_map(metadata))


def metadata_index_record(offset: int, length: int, name: str) -> bytes:
    """A Metadata Index record (summary section).

    Parameters
    ----------
    offset, length : int
        Where the Metadata record starts in the file and its whole length [bytes].
    name : str
        Its name.

    Returns
    -------
    bytes
        The record.
    """
    return record(METADATA_INDEX, struct.pack("<QQ", offset, length) + string(name))


def chunk_head(start: int, end: int, uncompressed_size: int, uncompressed_crc: int, compression: str,
               compressed_size: int) -> bytes:
    """A Chunk record up to its data: the ``compressed_size`` bytes of data follow it in the file.

    Parameters
    ----------
    start, end : int
        Log times of the chunk's first and last message [ns].
    uncompressed_size : int
        Bytes of the records before compression.
    uncompressed_crc : int
        Their CRC-32 (:func:`zlib.crc32`).
    compression : str
        ``"lz4"``, ``"zstd"`` or ``""`` (none).
    compressed_size : int
        Bytes of the data that follows.

    Returns
    -------
    bytes
        Opcode, length (counting the data), the fields and the data's uint64 length.
    """
    tail = string(compression) + _U64.pack(compressed_size)
    return _CHUNK_HEAD.pack(CHUNK, 28 + len(tail) + compressed_size, start, end, uncompressed_size,
                            uncompressed_crc) + tail


def message_index_record(channel_id: int, log_times: np.ndarray, offsets: np.ndarray) -> bytes:
    """A Message Index record: each message of a channel in a chunk as (log time, offset in the chunk).

    Parameters
    ----------
    channel_id : int
        The channel.
    log_times, offsets : ndarray of int, shape (n,)
        Its messages' log times [ns] and offsets in the uncompressed chunk [bytes], in that order.

    Returns
    -------
    bytes
        The record.
    """
    pairs = np.empty((len(log_times), 2), "<u8")
    pairs[:, 0], pairs[:, 1] = log_times, offsets
    return record(MESSAGE_INDEX, struct.pack("<HI", channel_id, pairs.nbytes) + pairs.tobytes())


def chunk_index_record(start: int, end: int, chunk_offset: int, chunk_length: int, index_offsets: dict[int, int],
                       index_length: int, compression: str, compressed_size: int, uncompressed_size: int) -> bytes:
    """A Chunk Index record (summary section).

    Parameters
    ----------
    start, end : int
        Log times of the chunk's first and last message [ns].
    chunk_offset, chunk_length : int
        Where the Chunk record starts in the file and its whole length [bytes].
    index_offsets : dict of int to int
        Channel id -> file offset of its Message Index record.
    index_length : int
        Bytes of the chunk's Message Index records.
    compression : str
        The chunk's compression.
    compressed_size, uncompressed_size : int
        Bytes of its data, and of its records before compression.

    Returns
    -------
    bytes
        The record.
    """
    return record(CHUNK_INDEX, struct.pack("<QQQQ", start, end, chunk_offset, chunk_length) + _id_map(index_offsets)
                  + _U64.pack(index_length) + string(compression) + struct.pack("<QQ", compressed_size, uncompressed_size))


def statistics_record(message_count: int, schema_count: int, channel_count: int, metadata_count: int,
                      chunk_count: int, start: int, end: int, channel_message_counts: dict[int, int]) -> bytes:
    """The Statistics record (summary section; no attachments).

    Parameters
    ----------
    message_count, schema_count, channel_count, metadata_count, chunk_count : int
        The file's totals.
    start, end : int
        Log times of its first and last message [ns].
    channel_message_counts : dict of int to int
        Channel id -> its messages.

    Returns
    -------
    bytes
        The record.
    """
    return record(STATISTICS, struct.pack("<QHIIIIQQ", message_count, schema_count, channel_count, 0, metadata_count,
                                          chunk_count, start, end) + _id_map(channel_message_counts))


def summary_offset_record(group_opcode: int, group_start: int, group_length: int) -> bytes:
    """A Summary Offset record: where the summary's records of one opcode are.

    Parameters
    ----------
    group_opcode : int
        Their opcode.
    group_start, group_length : int
        File offset of the first and the group's length [bytes].

    Returns
    -------
    bytes
        The record.
    """
    return record(SUMMARY_OFFSET, struct.pack("<BQQ", group_opcode, group_start, group_length))


def data_end_record(data_section_crc: int = 0) -> bytes:
    """The Data End record (0: the data section's CRC is not computed).

    Parameters
    ----------
    data_section_crc : int
        CRC-32 of the data section, or 0.

    Returns
    -------
    bytes
        The record.
    """
    return record(DATA_END, _U32.pack(data_section_crc))


def footer_record(summary_start: int, summary_offset_start: int, summary_crc: int) -> bytes:
    """The Footer record (before the closing magic).

    Parameters
    ----------
    summary_start, summary_offset_start : int
        File offsets of the summary section and of its Summary Offset records.
    summary_crc : int
        CRC-32 from the summary's start through the footer's ``summary_offset_start`` field.

    Returns
    -------
    bytes
        The record.
    """
    return record(FOOTER, struct.pack("<QQI", summary_start, summary_offset_start, summary_crc))
