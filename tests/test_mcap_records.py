"""The MCAP records coordarm encodes itself (mcap_records, mcap_file) against the ``mcap`` library's own record
classes and readers: the same bytes, and chunks given in parts that read back as the whole."""
from __future__ import annotations

import io
import zlib

import lz4.frame
import numpy as np
import pytest
import zstandard
from mcap.data_stream import RecordBuilder
from mcap.reader import make_reader
from mcap.records import (Channel, Chunk, ChunkIndex, DataEnd, Footer, Header, Message, MessageIndex, Metadata,
                          MetadataIndex, Schema, Statistics, SummaryOffset)
from mcap.stream_reader import StreamReader

from coordarm.simulation import mcap_records as rec
from coordarm.simulation.mcap_file import McapFile, message_records, parts_compressor


def _mcap(record) -> bytes:
    builder = RecordBuilder()
    record.write(builder)
    return builder.end()


def test_every_record_is_the_bytes_mcaps_record_classes_write():
    meta = {"json": "{\"a\": 1}", "ключ": "значение", "": ""}
    assert rec.header_record("ros2", "mcap-python/1.2.3") == _mcap(Header("ros2", "mcap-python/1.2.3"))
    assert rec.schema_record(3, "a/msg/B", "ros2msg", b"float64 x\n") == _mcap(
        Schema(id=3, name="a/msg/B", encoding="ros2msg", data=b"float64 x\n"))
    assert rec.channel_record(2, 3, "/joint_state", "cdr", meta) == _mcap(
        Channel(id=2, schema_id=3, topic="/joint_state", message_encoding="cdr", metadata=meta))
    assert rec.channel_record(1, 0, "/x", "json", {}) == _mcap(
        Channel(id=1, schema_id=0, topic="/x", message_encoding="json", metadata={}))
    assert rec.metadata_record("run", meta) == _mcap(Metadata(name="run", metadata=meta))
    assert rec.metadata_index_record(123, 45, "run") == _mcap(MetadataIndex(offset=123, length=45, name="run"))
    lt, off = np.array([5, 2**63 + 7], np.uint64), np.array([0, 1033], np.uint64)
    assert rec.message_index_record(4, lt, off) == _mcap(MessageIndex(channel_id=4, records=list(zip(lt.tolist(),
                                                                                                  off.tolist()))))
    offsets = {1: 1000, 7: 2**40, 3: 12}
    assert rec.chunk_index_record(1, 2, 3, 4, offsets, 5, "lz4", 6, 7) == _mcap(ChunkIndex(
        message_start_time=1, message_end_time=2, chunk_start_offset=3, chunk_length=4,
        message_index_offsets=offsets, message_index_length=5, compression="lz4", compressed_size=6,
        uncompressed_size=7))
    assert rec.statistics_record(10, 2, 3, 4, 5, 6, 7, {1: 8, 2: 2}) == _mcap(Statistics(
        message_count=10, schema_count=2, channel_count=3, attachment_count=0, metadata_count=4, chunk_count=5,
        message_start_time=6, message_end_time=7, channel_message_counts={1: 8, 2: 2}))
    assert rec.summary_offset_record(rec.CHUNK_INDEX, 99, 88) == _mcap(
        SummaryOffset(group_opcode=0x08, group_start=99, group_length=88))
    assert rec.data_end_record(0) == _mcap(DataEnd(0))
    assert rec.footer_record(1, 2, 3) == _mcap(Footer(summary_start=1, summary_offset_start=2, summary_crc=3))


@pytest.mark.parametrize("compression", ["lz4", "zstd", ""])
def test_a_chunk_head_followed_by_its_data_is_mcaps_chunk_record(compression):
    data = bytes(range(256)) * 3
    whole = _mcap(Chunk(compression=compression, data=data, message_start_time=11, message_end_time=22,
                        uncompressed_crc=0xDEADBEEF, uncompressed_size=4096))
    assert rec.chunk_head(11, 22, 4096, 0xDEADBEEF, compression, len(data)) + data == whole


def test_message_records_of_mixed_channels_are_mcaps_messages_back_to_back():
    bodies = [b"{}", b"x" * 1000, np.frombuffer(b"abc", np.uint8), b""]
    channels, sequences, times = [5, 6, 5, 7], [0, 3, 1, 2**32 - 1], [10, 10, 20, 2**63]
    records, offsets = message_records(channels, sequences, times, bodies, offset=77)
    expected = [_mcap(Message(channel_id=c, sequence=s, log_time=t, publish_time=t, data=bytes(b)))
                for c, s, t, b in zip(channels, sequences, times, bodies)]
    assert records == b"".join(expected)
    assert offsets.tolist() == (77 + np.cumsum([0] + [len(e) for e in expected[:-1]])).tolist()


@pytest.mark.parametrize("compression", ["lz4", "zstd", "none"])
def test_records_given_in_parts_compress_to_the_whole(compression):
    rng = np.random.default_rng(3)
    whole = np.concatenate([rng.integers(0, 4, 300_000, dtype=np.uint8), np.zeros(70_000, np.uint8)])
    parts = [whole[:1], whole[1:200_000], b"", bytes(whole[200_000:])]     # arrays and bytes, odd sizes
    data = b"".join(bytes(d) for d in parts_compressor(compression)(parts, whole.nbytes))
    decompress = {"lz4": lz4.frame.decompress, "none": bytes,
                  "zstd": lambda b: zstandard.ZstdDecompressor().decompress(b)}[compression]
    assert decompress(data) == whole.tobytes()
    if compression == "lz4":   # one frame, as lz4.frame.compress makes it (the size in its header)
        assert lz4.frame.get_frame_info(data)["content_size"] == whole.nbytes
        one = parts_compressor(compression)
        assert b"".join(one([whole], whole.nbytes)) == lz4.frame.compress(whole.tobytes())


@pytest.mark.parametrize("compression", ["lz4", "zstd", "none"])
def test_a_file_of_chunks_in_parts_reads_back_with_mcaps_readers_and_crc_checks(tmp_path, compression):
    path = tmp_path / "parts.mcap"
    f = McapFile(path, profile="ros2", compression=compression, background=True)
    sid = f.add_schema("a/msg/B", "ros2msg", b"float64 x\n")
    a, b = f.add_channel("/a", "cdr", sid), f.add_channel("/b", "cdr", sid, {"k": "v"})
    f.add_metadata("run", {"x": "1"})
    sent = []
    for chunk in range(3):
        times = [100 * chunk + i for i in range(4)]
        bodies = [bytes([chunk, i]) * (i * 5000 + 1) for i in range(4)]
        first, offs1 = message_records([a, a], [2 * chunk, 2 * chunk + 1], times[:2], bodies[:2])
        second, offs2 = message_records([b, b], [2 * chunk, 2 * chunk + 1], times[2:], bodies[2:], len(first))
        f.write_chunk([np.frombuffer(first, np.uint8), second],
                      {a: (np.array(times[:2], np.uint64), offs1), b: (np.array(times[2:], np.uint64), offs2)})
        sent += [("/a", t, s, d) for t, s, d in zip(times[:2], (2 * chunk, 2 * chunk + 1), bodies[:2])]
        sent += [("/b", t, s, d) for t, s, d in zip(times[2:], (2 * chunk, 2 * chunk + 1), bodies[2:])]
    f.close()
    raw = path.read_bytes()
    records = list(StreamReader(io.BytesIO(raw), validate_crcs=True, emit_chunks=True).records)
    chunks = [r for r in records if isinstance(r, Chunk)]
    assert len(chunks) == 3 and all(c.compression == ("" if compression == "none" else compression) for c in chunks)
    reader = make_reader(io.BytesIO(raw))
    got = [(c.topic, m.log_time, m.sequence, m.data) for _, c, m in reader.iter_messages()]
    assert got == sorted(sent, key=lambda x: x[1])
    summary = reader.get_summary()
    assert summary.statistics.message_count == 12 and summary.statistics.chunk_count == 3
    assert summary.statistics.channel_message_counts == {a: 6, b: 6}
    assert [c.uncompressed_size for c in summary.chunk_indexes] == [c.uncompressed_size for c in chunks]
    decompress = {"lz4": lz4.frame.decompress, "none": bytes,
                  "zstd": lambda x: zstandard.ZstdDecompressor().decompress(x)}[compression]
    for c in chunks:      # the CRC of the whole, computed part by part
        assert c.uncompressed_crc == zlib.crc32(decompress(c.data)) != 0
    # the message indexes point at the records (the indexed read of the file uses them)
    for ci in summary.chunk_indexes:
        for cid, offset in ci.message_index_offsets.items():
            index = next(StreamReader(io.BytesIO(raw[offset:]), skip_magic=True).records)
            assert isinstance(index, MessageIndex) and index.channel_id == cid and len(index.records) == 2


def test_the_chunks_crc32_is_zlibs_whole_and_part_by_part(rng):
    from coordarm.simulation.mcap_file import crc32_function
    crc32 = crc32_function()
    data = rng.integers(0, 256, 3_000_001, dtype=np.uint8)
    assert crc32(data) == zlib.crc32(data) and crc32(b"") == 0
    assert crc32(data[1_000_000:], crc32(data[:1_000_000])) == zlib.crc32(data.tobytes())


def test_a_logged_run_loads_none_of_mcaps_record_classes(tmp_path):
    """mcap.records (~7 ms to import) and its RecordBuilder are the readers' business, not a run's."""
    import subprocess
    import sys
    code = ("import sys; from coordarm.cli import main; "
            "main(['run', 'line', '--links', '4', '--duration', '0.05', '--no-figures', '--quiet', '--overwrite', "
            "'--out', sys.argv[1]]); "
            "print(sorted(m for m in ('mcap.records', 'mcap.data_stream', 'mcap.opcode') if m in sys.modules))")
    res = subprocess.run([sys.executable, "-c", code, str(tmp_path / "x.mcap")], capture_output=True, text=True,
                         timeout=300)
    assert res.returncode == 0, res.stderr
    assert res.stdout.strip().splitlines()[-1] == "[]"
    with open(tmp_path / "x.mcap", "rb") as f:
        assert make_reader(f).get_summary().statistics.message_count > 50
