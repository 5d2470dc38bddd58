"""CRC-32 with zlib's polynomial and conventions, as MCAP specifies for its chunk, data-section and
summary checksums, from ISA-L (``isal``): the same values as ``zlib.crc32`` (tests compare them),
about five times quicker (0.18 against 0.94 ms for a record's 4.7 MB of chunks, one core here),
which is a millisecond of every record's shard write."""

from __future__ import annotations

from isal.isal_zlib import crc32

__all__ = ["crc32"]
