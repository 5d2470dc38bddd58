"""The shards' own PNG writer: valid files (checksums, zlib stream) that decode to the same pixels."""

from __future__ import annotations

import io
import struct
import zlib

import cv2
import numpy as np
import pytest
from PIL import Image

from refspatial.png import encode_rgb

# (height, width): one pixel; one row; the scanlines filling exactly one and two stored blocks
# (771 and 1542 rows of 1 + 3 * 28 = 85 bytes: 65,535 and 131,070); a render's size.
SHAPES = [(1, 1), (1, 7), (5, 1), (771, 28), (1542, 28), (33, 651), (540, 960)]


def _image(shape: tuple[int, int], seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    img = rng.integers(0, 256, (*shape, 3), dtype=np.uint8)
    img[: shape[0] // 2] = img[: shape[0] // 2].mean(axis=1, keepdims=True).astype(np.uint8)  # flat runs too
    return img


def _chunks(png: bytes) -> list[tuple[bytes, bytes]]:
    """(type, data) of every chunk, each CRC checked against zlib's."""
    assert png[:8] == b"\x89PNG\r\n\x1a\n"
    out, at = [], 8
    while at < len(png):
        (length,), kind = struct.unpack(">I", png[at:at + 4]), png[at + 4:at + 8]
        data = png[at + 8:at + 8 + length]
        (crc,) = struct.unpack(">I", png[at + 8 + length:at + 12 + length])
        assert crc == zlib.crc32(kind + data), kind
        out.append((kind, data))
        at += 12 + length
    assert at == len(png)
    return out


@pytest.mark.parametrize("shape", SHAPES)
def test_pixels_read_back_unchanged(shape):
    img = _image(shape, seed=sum(shape))
    png = encode_rgb(img)
    bgr = cv2.imdecode(np.frombuffer(png, np.uint8), cv2.IMREAD_UNCHANGED)
    np.testing.assert_array_equal(bgr[..., ::-1], img)
    with Image.open(io.BytesIO(png)) as pil:
        assert pil.mode == "RGB"
        np.testing.assert_array_equal(np.asarray(pil), img)


@pytest.mark.parametrize("shape", SHAPES)
def test_file_structure(shape):
    img = _image(shape, seed=1)
    chunks = _chunks(encode_rgb(img))
    assert [k for k, _ in chunks] == [b"IHDR", b"IDAT", b"IEND"]
    assert chunks[0][1] == struct.pack(">IIBBBBB", shape[1], shape[0], 8, 2, 0, 0, 0)
    rows = np.frombuffer(zlib.decompress(chunks[1][1]), np.uint8).reshape(shape[0], 1 + 3 * shape[1])
    assert np.all(rows[:, 0] == 1)  # every scanline "sub" filtered
    # Undo the filter by hand: running sums per channel along the row, modulo 256.
    filtered = rows[:, 1:].reshape(shape[0], shape[1], 3).astype(np.int64)
    np.testing.assert_array_equal(np.cumsum(filtered, axis=1) % 256, img)


def test_a_non_contiguous_view_is_written_as_its_pixels():
    img = _image((40, 60), seed=3)[:, ::2]
    bgr = cv2.imdecode(np.frombuffer(encode_rgb(img), np.uint8), cv2.IMREAD_UNCHANGED)
    np.testing.assert_array_equal(bgr[..., ::-1], img)


@pytest.mark.parametrize("bad", [np.zeros((4, 4), np.uint8), np.zeros((4, 4, 4), np.uint8),
                                 np.zeros((4, 4, 3), np.float32), np.zeros((0, 4, 3), np.uint8)])
def test_rejects_what_is_not_an_rgb_image(bad):
    with pytest.raises(ValueError, match="uint8 image"):
        encode_rgb(bad)
