"""RGB images as PNG files whose deflate stream is stored, not compressed, after the "sub" filter.

A shard compresses every chunk with zstd, which squeezes a stored PNG of a render better than
deflate would (records.py): the PNG's own job is only to be a valid PNG of the right pixels.
libpng (through OpenCV) spent 2.4-2.7 ms a 960x540 image on that, most of it copying the rows
through its filter and zlib's stored blocks in 8 kB pieces; this writes the same kind of file
in 0.7 ms with numpy, and zstd makes it slightly smaller (one IDAT chunk, fewer headers:
384 against 386 kB a record). Decoders read the pixels back unchanged (tests compare them
through OpenCV and Pillow).
"""

from __future__ import annotations

import struct

import numpy as np

from .crc import adler32, crc32

SIGNATURE = b"\x89PNG\r\n\x1a\n"
STORED_BLOCK = 0xFFFF  # the most bytes one stored deflate block holds
SUB = 1  # PNG filter type: each byte minus the byte one pixel to its left


def encode_rgb(rgb: np.ndarray) -> bytes:
    """An 8-bit RGB PNG of ``rgb`` (H, W, 3 uint8): one IDAT chunk, a zlib stream of stored blocks."""
    if rgb.dtype != np.uint8 or rgb.ndim != 3 or rgb.shape[2] != 3 or 0 in rgb.shape:
        raise ValueError(f"encode_rgb takes an (H, W, 3) uint8 image; got {rgb.dtype} {rgb.shape}")
    h, w, _ = rgb.shape
    flat = rgb.reshape(h, 3 * w)
    rows = np.empty((h, 1 + 3 * w), np.uint8)  # each scanline: its filter byte, then the filtered bytes
    rows[:, 0] = SUB
    rows[:, 1:4] = flat[:, :3]
    np.subtract(flat[:, 3:], flat[:, :-3], out=rows[:, 4:])  # uint8 arithmetic wraps modulo 256, as PNG's does
    raw = memoryview(rows).cast("B")
    stream = [b"\x78\x01"]  # zlib header: deflate, 32 kB window, no dictionary, "fastest" level
    for start in range(0, len(raw), STORED_BLOCK):
        block = raw[start:start + STORED_BLOCK]
        last = start + STORED_BLOCK >= len(raw)
        stream += (struct.pack("<BHH", last, len(block), len(block) ^ 0xFFFF), block)
    stream.append(struct.pack(">I", adler32(raw)))
    header = struct.pack(">IIBBBBB", w, h, 8, 2, 0, 0, 0)  # 8 bits a sample, truecolour, no interlace
    return b"".join((SIGNATURE, *_chunk(b"IHDR", [header]), *_chunk(b"IDAT", stream), *_chunk(b"IEND", [])))


def _chunk(kind: bytes, pieces: list) -> list:
    """A PNG chunk holding ``pieces`` one after another, as pieces: the image is copied once, by
    the caller's final join."""
    crc = crc32(kind)
    for piece in pieces:
        crc = crc32(piece, crc)
    return [struct.pack(">I", sum(len(p) for p in pieces)), kind, *pieces, struct.pack(">I", crc)]
