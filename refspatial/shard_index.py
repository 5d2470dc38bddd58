"""Reading a shard's MCAP summary into a compact index, and the low-level record reads it
points to: chunks, metadata, and the data-section CRC.

ShardReader (records.py) keeps one ``ShardIndex`` per shard, so random access finds a
record's chunks without scanning the file. Every function here raises plain exceptions on
damaged bytes; the reader turns them into one ShardError naming the file.
"""

from __future__ import annotations

import io
import os
import struct
from dataclasses import dataclass
from typing import BinaryIO

import numpy as np
from mcap.data_stream import ReadDataStream
from mcap.opcode import Opcode
from mcap.records import Channel, Chunk, ChunkIndex, Message, Metadata, MetadataIndex, Statistics
from mcap.stream_reader import StreamReader, breakup_chunk

from .crc import crc32
from .record_schemas import JSON_SCHEMAS, PROTO_TOPICS

NS_PER_RECORD = 1_000_000_000  # record i is logged at (i + 1) s
MAGIC = b"\x89MCAP0\r\n"
_FOOTER_LEN = 1 + 8 + 8 + 8 + 4  # opcode, length, summary_start, summary_offset_start, crc


@dataclass(frozen=True, eq=False)
class ShardIndex:
    """The summary boiled down to small arrays: a dataset keeps one per shard alive."""

    size: int
    summary_start: int
    channels: dict[str, int]  # topic -> channel id
    n_records: int
    chunk_record: np.ndarray  # (C,) int64, sorted
    chunk_offset: np.ndarray  # (C,) int64
    chunk_length: np.ndarray  # (C,) int64
    chunk_mask: np.ndarray  # (C,) int64, bit c set when the chunk holds channel c
    metadata: tuple[tuple[str, int, int], ...]  # (name, offset, length)


def read_index(f: BinaryIO) -> ShardIndex:
    """Footer, then the summary it points to, checked against the footer's CRC."""
    size = os.fstat(f.fileno()).st_size
    if size < 2 * len(MAGIC) + _FOOTER_LEN:
        raise ValueError(f"only {size} bytes, too short for a complete MCAP file (truncated?)")
    head = f.read(len(MAGIC))
    f.seek(size - len(MAGIC) - _FOOTER_LEN)
    tail = f.read(len(MAGIC) + _FOOTER_LEN)
    if head != MAGIC or tail[-len(MAGIC):] != MAGIC:
        raise ValueError("no MCAP magic at the start or end (truncated or still being written)")
    opcode, length, start, _, crc = struct.unpack("<BQQQI", tail[:_FOOTER_LEN])
    if opcode != Opcode.FOOTER or length != _FOOTER_LEN - 9 or not 8 < start < size - _FOOTER_LEN:
        raise ValueError("bad MCAP footer (truncated or damaged)")
    f.seek(start)
    summary = f.read(size - len(MAGIC) - _FOOTER_LEN - start)
    if crc32(tail[:25], crc32(summary)) != crc:
        raise ValueError("summary CRC mismatch (damaged index)")
    stream = StreamReader(io.BytesIO(summary + tail), skip_magic=True, record_size_limit=size)
    return _index_from_summary(size, start, list(stream.records))


def _index_from_summary(size: int, start: int, records: list) -> ShardIndex:
    channels = {r.topic: r.id for r in records if isinstance(r, Channel)}
    if set(channels) != set(JSON_SCHEMAS) | set(PROTO_TOPICS):
        raise ValueError(f"not a refspatial shard: topics {sorted(channels)}")
    stats = next(r for r in records if isinstance(r, Statistics))
    counts = [stats.channel_message_counts.get(c, 0) for c in channels.values()]
    n = counts[0]
    if any(c != n for c in counts):
        raise ValueError(f"message counts differ between topics: {counts}")
    chunks = [r for r in records if isinstance(r, ChunkIndex)]
    rec = np.array([c.message_start_time // NS_PER_RECORD - 1 for c in chunks], dtype=np.int64)
    mask = np.array([sum(1 << k for k in c.message_index_offsets) for c in chunks], dtype=np.int64)
    if len(rec) and (rec.min() < 0 or rec.max() >= n or np.any(np.diff(rec) < 0)):
        raise ValueError("chunk index times do not match the record count")
    covered, full = np.zeros(n, dtype=np.int64), sum(1 << c for c in channels.values())
    np.bitwise_or.at(covered, rec, mask)
    if np.any(covered != full):
        raise ValueError(f"record {int(np.argmax(covered != full))} is missing chunks")
    return ShardIndex(
        size=size, summary_start=start, channels=channels, n_records=n, chunk_record=rec,
        chunk_offset=np.array([c.chunk_start_offset for c in chunks], dtype=np.int64),
        chunk_length=np.array([c.chunk_length for c in chunks], dtype=np.int64), chunk_mask=mask,
        metadata=tuple((m.name, m.offset, m.length) for m in records
                       if isinstance(m, MetadataIndex)),
    )


def _record_body(f: BinaryIO, offset: int, length: int, opcode: Opcode) -> ReadDataStream:
    f.seek(offset)
    buf = f.read(length)
    if len(buf) != length or buf[0] != opcode:
        raise ValueError(f"no {opcode.name} record at byte {offset}")
    return ReadDataStream(io.BytesIO(buf[9:]))


def chunk_messages(f: BinaryIO, offset: int, length: int) -> list[Message]:
    chunk = Chunk.read(_record_body(f, offset, length, Opcode.CHUNK))
    if chunk.compression != "zstd":
        raise ValueError(f"chunk compression {chunk.compression!r}, expected zstd")
    return [r for r in breakup_chunk(chunk, validate_crc=True) if isinstance(r, Message)]


def read_metadata(f: BinaryIO, name: str, offset: int, length: int) -> tuple[str, dict]:
    return name, dict(Metadata.read(_record_body(f, offset, length, Opcode.METADATA)).metadata)


def verify_data_crc(f: BinaryIO, summary_start: int) -> None:
    data_end = summary_start - 13  # the DataEnd record: opcode, length 4, crc32
    f.seek(data_end)
    opcode, length, expected = struct.unpack("<BQI", f.read(13))
    if opcode != Opcode.DATA_END or length != 4:
        raise ValueError("no DataEnd record before the summary")
    f.seek(0)
    crc, left = 0, data_end
    while left:
        block = f.read(min(left, 1 << 22))
        crc, left = crc32(block, crc), left - len(block)
    if crc != expected:
        raise ValueError("data section CRC mismatch (damaged bytes)")
