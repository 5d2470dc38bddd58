"""Writing and reading one shard: an MCAP file of rendered views and their referring QA.

A shard describes itself: each topic has a schema (foxglove protobuf for images and
calibration, JSON schema for scene, relations and QA), recipe and versions travel as MCAP
metadata, and Foxglove opens it as is. Record ``i`` is every message logged at ``i + 1``
seconds, so the bytes depend on the records only, never on the wall clock. A record is
written as four chunks (JSON + calibration, rgb, depth, seg): a reader that wants QA only,
or rgb only, decompresses just those, found through the CRC-checked summary's chunk index.

The topics and their schemas are in ``record_schemas`` (the JSON schemas are files in
``schemas/``); reading the summary, chunks and CRCs is ``shard_index``'s.
"""

from __future__ import annotations

import hashlib
import json
import operator
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any, BinaryIO, Callable, Iterator, Sequence

import cv2
import numpy as np
from foxglove_schemas_protobuf.CameraCalibration_pb2 import CameraCalibration
from foxglove_schemas_protobuf.CompressedImage_pb2 import CompressedImage
from foxglove_schemas_protobuf.RawImage_pb2 import RawImage
from google.protobuf.timestamp_pb2 import Timestamp
import mcap.writer
import zstandard
from mcap.writer import LIBRARY_IDENTIFIER, CompressionType, Writer

from refspatial import __version__

from .crc import crc32
from .png import encode_rgb
from .record_schemas import GROUPS as _GROUPS
from .record_schemas import IMAGE_TOPICS as _IMAGE_TOPICS
from .record_schemas import JSON_TOPICS as _JSON_TOPICS
from .record_schemas import register_channels as _register_channels
from .shard_index import NS_PER_RECORD, ShardIndex
from .shard_index import chunk_messages as _chunk_messages  # a module name, so tests can count calls
from .shard_index import read_index as _read_index
from .shard_index import read_metadata as _read_metadata
from .shard_index import verify_data_crc as _verify_data_crc

FIELDS = ("rgb", "depth", "seg")  # image fields a reader decodes only on request
# The RGB PNG: stored deflate blocks after the "sub" row filter (``png.encode_rgb``); the shard's
# zstd chunk compression then does the squeezing. On 960x540 textured renders this costs 7 ms a
# record (the PNG 0.7 ms, 3 through libpng; zstd 6 ms) where zlib level 3 with no filter cost 17 ms
# (PNG 16.5 ms, then zstd finding nothing to gain), and the stored chunk is 8 % smaller (291 kB
# against 316 kB). Pixels are lossless either way; a PNG copied out of a message is as large as
# the raw image.
ZSTD_LEVEL = 1


class _ChunkZstd:
    """What mcap's writer calls to compress a chunk (``zstandard.compress``), at ZSTD_LEVEL. The
    writer (mcap 1.6) uses zstd's default, level 3, and offers no setting; on our chunks level 1
    is 1.5x quicker (896 against 593 MB/s of raw chunk, one core) for the same size (0.149 of
    raw either way), and a chunk decompresses to the same bytes at any level."""

    def __init__(self) -> None:
        self._compressor = zstandard.ZstdCompressor(level=ZSTD_LEVEL)

    def compress(self, data: bytes) -> bytes:
        return self._compressor.compress(data)


class _WriterCrc:
    """What mcap's writer calls for its checksums (``zlib.crc32``, the only zlib function it uses):
    the same CRC-32, quicker (``refspatial.crc``)."""

    crc32 = staticmethod(crc32)


mcap.writer.zstandard = _ChunkZstd()
mcap.writer.zlib = _WriterCrc
_FIX = "delete it and re-run `refspatial generate` (rewrites missing shards, skips complete ones)"


class ShardError(RuntimeError):
    """A shard is truncated, damaged or not a refspatial shard. Takes one message argument
    so that it survives pickling back from DataLoader workers."""


def _shard_error(path: Path, problem: str, index: int | None = None) -> ShardError:
    where = "" if index is None else f" (record {index})"
    return ShardError(f"{path}{where}: {' '.join(problem.split())}; {_FIX}")


@dataclass(frozen=True, eq=False)
class Record:
    """One rendered view with its annotations, as written to a shard."""

    key: str  # unique within a dataset, e.g. "tabletop-1a2b3c4d-123/view0"
    scene: dict  # JSON-able scene description (objects, camera, seed ...)
    rgb: np.ndarray  # (H, W, 3) uint8, RGB order
    depth_m: np.ndarray  # (H, W) float32, metres along the optical axis
    seg: np.ndarray  # (H, W) int32, object id per pixel, -1 background
    K: np.ndarray  # (3, 3) float64, pixels
    T_world_cam: np.ndarray  # (4, 4) float64, world <- OpenCV camera (+z forward, +y down)
    relations: list[dict]
    qa: list[dict]

    def __post_init__(self) -> None:
        """Fail at construction, where the caller still sees which value is wrong."""
        if not isinstance(self.key, str) or not self.key:
            raise ValueError(f"Record.key must be a non-empty str; got {self.key!r}")
        h, w = getattr(self.rgb, "shape", (0, 0))[:2]
        for name, shape, dtype in (("rgb", (h, w, 3), "uint8"), ("depth_m", (h, w), "float32"),
                                   ("seg", (h, w), "int32"), ("K", (3, 3), "float64"),
                                   ("T_world_cam", (4, 4), "float64")):
            a = getattr(self, name)
            if not isinstance(a, np.ndarray) or a.shape != shape or a.dtype != dtype:
                got = f"{a.dtype} {a.shape}" if isinstance(a, np.ndarray) else type(a).__name__
                raise ValueError(f"Record {self.key!r}: {name} must be {dtype} {shape}; got {got} "
                                 f"(convert with np.asarray(..., dtype=np.{dtype}))")
        if self.seg.size and (self.seg.min() < -1 or self.seg.max() > 65534):
            raise ValueError(f"Record {self.key!r}: seg ids must lie in [-1, 65534] to fit 16UC1")
        for name, kind in (("scene", dict), ("relations", list), ("qa", list)):
            if not isinstance(getattr(self, name), kind):
                raise ValueError(f"Record {self.key!r}: {name} must be a {kind.__name__}")
        if {"key", "K", "T_world_cam"} & set(self.scene):
            raise ValueError(f"Record {self.key!r}: scene must not hold 'key', 'K' or "
                             "'T_world_cam'; they are stored from the Record's own fields")


class ShardWriter:
    """Writes records to ``path`` atomically: the partial file is renamed on a clean close
    only, so a file at ``path`` always is a complete shard to whoever resumes a run."""

    def __init__(self, path: Path | str, metadata: dict[str, dict[str, str]]) -> None:
        self.path = Path(path)
        self.partial_path = self.path.with_name(f".{self.path.name}.partial")
        _check_metadata(self.path, metadata)
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self._file: BinaryIO = open(self.partial_path, "wb")
        # Data CRCs let ShardReader.verify() check every byte of the data section.
        self._mcap = Writer(self._file, compression=CompressionType.ZSTD, enable_data_crcs=True)
        self._mcap.start(profile="", library=f"refspatial/{__version__}; {LIBRARY_IDENTIFIER}")
        for name, data in metadata.items():
            self._mcap.add_metadata(name, dict(data))
        self._channels = _register_channels(self._mcap)
        self._keys: set[str] = set()
        self._done = False
        self.sha256: str | None = None  # of the finished file, set by close()

    def __enter__(self) -> ShardWriter:
        return self

    def __exit__(self, exc_type: type | None, exc: BaseException | None, tb: Any) -> None:
        self.close() if exc_type is None else self.abort()

    def __len__(self) -> int:
        return len(self._keys)

    def write(self, record: Record) -> int:
        """Append one record and return its index. Encodes it fully before touching the
        file, so a record that fails to encode leaves the shard consistent."""
        if self._done:
            raise ValueError(f"{self.path}: writer is closed; open a new ShardWriter")
        if record.key in self._keys:
            raise ValueError(f"{self.path}: key {record.key!r} written twice; keys must be unique")
        index = len(self._keys)
        t = (index + 1) * NS_PER_RECORD
        messages = _encode(record, t)
        for group in _GROUPS:
            for topic in group:
                self._mcap.add_message(self._channels[topic], log_time=t, data=messages[topic],
                                       publish_time=t, sequence=index)
            self._mcap.flush()  # ends the chunk: one group per chunk
        self._keys.add(record.key)
        return index

    def close(self) -> None:
        """Write the summary, fsync, and rename the partial file to ``path``."""
        if self._done:
            return
        try:
            self._mcap.finish()
            self._file.flush()
            os.fsync(self._file.fileno())
            self._file.close()
            # Hashed before the rename, so the shard's sidecar follows it in milliseconds: an
            # interrupt while a finished shard was being hashed left it without one (a Ctrl-C test
            # caught it once in a fresh clone).
            self.sha256 = sha256_file(self.partial_path)
            os.replace(self.partial_path, self.path)
        except BaseException:
            self.abort()
            raise
        self._done = True

    def abort(self) -> None:
        """Drop the partial file; whatever is at ``path`` stays untouched."""
        self._done = True
        try:
            self._file.close()  # may raise itself on a full disk: the partial file must still go
        finally:
            self.partial_path.unlink(missing_ok=True)


def _check_metadata(path: Path, metadata: dict[str, dict[str, str]]) -> None:
    for name, data in metadata.items():
        if not isinstance(name, str) or not isinstance(data, dict):
            raise ValueError(f"{path}: metadata must map str -> dict[str, str]; got {name!r}")
        for k, v in data.items():
            if not (isinstance(k, str) and isinstance(v, str)):
                raise ValueError(f"{path}: metadata[{name!r}][{k!r}] must be a str (MCAP metadata "
                                 f"is text); got {type(v).__name__}, convert it with json.dumps")


def _encode(r: Record, t: int) -> dict[str, bytes]:
    """Every message of one record, serialised; pure, so failures happen before any write."""
    stamp = Timestamp(seconds=t // NS_PER_RECORD, nanos=t % NS_PER_RECORD)
    scene = {"key": r.key, **r.scene, "K": r.K.tolist(), "T_world_cam": r.T_world_cam.tolist()}
    what = f"Record {r.key!r}:"
    return {
        "/scene": _json(f"{what} scene", scene),
        "/relations": _json(f"{what} relations", {"key": r.key, "relations": r.relations}),
        "/qa": _json(f"{what} qa", {"key": r.key, "qa": r.qa}),
        "/camera/calibration": _calibration(r, stamp),
        "/camera/rgb": _png_message(r.rgb, stamp),
        "/camera/depth": _raw_message(r.depth_m.astype("<f4", copy=False), "32FC1", stamp),
        "/camera/seg": _raw_message(_seg_u16(r.seg), "16UC1", stamp),
    }


def _seg_u16(seg: np.ndarray) -> np.ndarray:
    """Segmentation ids + 1 as little-endian uint16 (background -1 -> 0), without an int32
    temporary: the cast wraps -1 to 65535, and adding 1 in uint16 wraps it on to 0."""
    out = seg.astype("<u2")
    out += 1
    return out


def _jsonable(o: Any) -> Any:
    """numpy scalars and arrays sneak into scene dicts; store them as plain JSON."""
    if isinstance(o, (np.generic, np.ndarray)):
        return o.tolist()
    raise TypeError(f"{type(o).__name__} is not JSON-able")


def _json(what: str, obj: Any) -> bytes:
    # Without the encoder's bookkeeping of every container against cycles (a tenth of the time):
    # a record is trees of dicts and lists built afresh, and a cycle would still end in an error.
    try:
        return json.dumps(obj, ensure_ascii=False, allow_nan=False, separators=(",", ":"), check_circular=False,
                          default=_jsonable).encode("utf-8")
    except (TypeError, ValueError, RecursionError) as e:
        raise ValueError(f"{what} is not strict JSON ({e}); use dicts, lists, strings and "
                         "finite numbers") from None


def _calibration(r: Record, stamp: Timestamp) -> bytes:
    h, w = r.depth_m.shape
    P = np.hstack([r.K, np.zeros((3, 1))])
    msg = CameraCalibration(timestamp=stamp, frame_id="camera", width=w, height=h,
                            distortion_model="plumb_bob", D=[0.0] * 5, K=r.K.ravel().tolist(),
                            R=np.eye(3).ravel().tolist(), P=P.ravel().tolist())
    return msg.SerializeToString(deterministic=True)


def _png_message(rgb: np.ndarray, stamp: Timestamp) -> bytes:
    png = np.frombuffer(encode_rgb(rgb), np.uint8)
    return _with_data(CompressedImage(timestamp=stamp), 2, png, CompressedImage(format="png", frame_id="camera"))


def _raw_message(a: np.ndarray, encoding: str, stamp: Timestamp) -> bytes:
    h, w = a.shape
    head = RawImage(timestamp=stamp, width=w, height=h, encoding=encoding, step=w * a.itemsize)
    return _with_data(head, 6, a, RawImage(frame_id="camera"))


def _with_data(head: Any, number: int, data: np.ndarray, tail: Any) -> bytes:
    """One image message serialised: the fields numbered below `number` (head), the bytes field
    `number` holding the image, then the fields above it (tail). Protobuf's wire format is the
    fields one after another, in number order when deterministic, so these are the bytes
    SerializeToString gives for the whole message; the image is copied once here, where
    tobytes, the message and its serialisation copied it three times (4.6 MB a record)."""
    view = memoryview(np.ascontiguousarray(data)).cast("B")
    key = (number << 3) | 2  # wire type 2: length-delimited
    field = (_varint(key), _varint(len(view)), view) if len(view) else ()  # proto3 leaves empty bytes out
    return b"".join((head.SerializeToString(deterministic=True), *field, tail.SerializeToString(deterministic=True)))


def _varint(n: int) -> bytes:
    out = bytearray()
    while n > 0x7F:
        out.append((n & 0x7F) | 0x80)
        n >>= 7
    out.append(n)
    return bytes(out)


class ShardReader:
    """Random and streaming access to one shard. Opens the file per call, so it holds no
    descriptor between calls, pickles cheaply and is safe in forked DataLoader workers."""

    def __init__(self, path: Path | str) -> None:
        self.path = Path(path)
        if not self.path.is_file():
            raise FileNotFoundError(f"{self.path}: no such shard; check the path or regenerate it")
        with open(self.path, "rb") as f:
            self._index: ShardIndex = self._guard(lambda: _read_index(f), None)
        self._keys: list[str] | None = None

    def __len__(self) -> int:
        return self._index.n_records

    def __iter__(self) -> Iterator[dict]:
        return self.iter()

    def keys(self) -> list[str]:
        """Record keys in order (decompresses the small JSON chunks only)."""
        if self._keys is None:
            self._keys = [s["key"] for s in self.iter(fields=())]
        return list(self._keys)

    def read(self, i: int, fields: Sequence[str] = FIELDS) -> dict:
        """The i-th record as a sample dict; only the requested image fields are decoded."""
        i = operator.index(i)  # numpy integers too, but never floats
        if not 0 <= i < len(self):
            raise IndexError(f"{self.path}: record {i} out of range; the shard has {len(self)}")
        with self._open() as f:
            return self._read(f, i, _check_fields(fields))

    def iter(self, fields: Sequence[str] = FIELDS) -> Iterator[dict]:
        """All records in order, as read() returns them, through one open file."""
        return self._iter(_check_fields(fields))  # a bad ``fields`` fails here, not at next()

    def _iter(self, fields: tuple[str, ...]) -> Iterator[dict]:
        with self._open() as f:
            for i in range(len(self)):
                yield self._read(f, i, fields)

    def metadata(self) -> dict[str, dict[str, str]]:
        """The MCAP metadata records (recipe, versions ...) as written."""
        with self._open() as f:
            return self._guard(lambda: dict(_read_metadata(f, *m) for m in self._index.metadata))

    def verify(self) -> None:
        """Check the data-section CRC. Reads the whole file, but catches any damaged byte,
        including those that reading records never touches."""
        with self._open() as f:
            self._guard(lambda: _verify_data_crc(f, self._index.summary_start))

    def _guard(self, fn: Callable[[], Any], index: int | None = None) -> Any:
        """Whatever damaged bytes make the parsers raise becomes one ShardError naming the file."""
        try:
            return fn()
        except ShardError:
            raise
        except Exception as e:  # noqa: BLE001 - damaged bytes can raise anything
            raise _shard_error(self.path, f"damaged or truncated ({type(e).__name__}: {e})",
                               index) from e

    def _open(self) -> BinaryIO:
        f = open(self.path, "rb")
        if os.fstat(f.fileno()).st_size != self._index.size:
            f.close()
            raise _shard_error(self.path, "the file changed size since this reader opened it")
        return f

    def _read(self, f: BinaryIO, i: int, fields: tuple[str, ...]) -> dict:
        wanted = set(_JSON_TOPICS) | {_IMAGE_TOPICS[name] for name in fields}
        messages = self._guard(lambda: self._messages(f, i, wanted), i)
        if wanted - set(messages):
            raise _shard_error(self.path, f"no message on {sorted(wanted - set(messages))}", i)
        return self._guard(lambda: self._decode(i, messages, fields), i)

    def _messages(self, f: BinaryIO, i: int, wanted: set[str]) -> dict[str, bytes]:
        ix = self._index
        mask = sum(1 << ix.channels[t] for t in wanted)
        topics = {c: t for t, c in ix.channels.items() if t in wanted}
        lo, hi = np.searchsorted(ix.chunk_record, [i, i + 1])
        out = {}
        for j in np.flatnonzero(ix.chunk_mask[lo:hi] & mask) + lo:
            for m in _chunk_messages(f, int(ix.chunk_offset[j]), int(ix.chunk_length[j])):
                if m.channel_id in topics and m.log_time == (i + 1) * NS_PER_RECORD:
                    out[topics[m.channel_id]] = m.data
        return out

    def _decode(self, i: int, messages: dict[str, bytes], fields: tuple[str, ...]) -> dict:
        scene = json.loads(messages["/scene"])
        key = scene.pop("key")
        K, T = np.array(scene.pop("K"), np.float64), np.array(scene.pop("T_world_cam"), np.float64)
        rel, qa = json.loads(messages["/relations"]), json.loads(messages["/qa"])
        if K.shape != (3, 3) or T.shape != (4, 4) or rel["key"] != key or qa["key"] != key:
            raise ValueError(f"inconsistent JSON messages for {key!r}")
        sample = {"key": key, "shard": self.path.name, "index": i, "scene": scene,
                  "relations": rel["relations"], "qa": qa["qa"], "K": K, "T_world_cam": T}
        if "rgb" in fields:
            sample["rgb"] = _decode_png(messages["/camera/rgb"])
        if "depth" in fields:
            sample["depth_m"] = _decode_raw(messages["/camera/depth"], "32FC1", "<f4")
        if "seg" in fields:
            seg = _decode_raw(messages["/camera/seg"], "16UC1", "<u2")
            sample["seg"] = seg.astype(np.int32) - 1
        return sample


def _check_fields(fields: Sequence[str]) -> tuple[str, ...]:
    if isinstance(fields, str) or not set(fields) <= set(FIELDS):
        raise ValueError(f"fields must be a subset of {FIELDS}; got {fields!r}")
    return tuple(fields)


def _decode_png(data: bytes) -> np.ndarray:
    msg = CompressedImage.FromString(data)
    bgr = cv2.imdecode(np.frombuffer(msg.data, np.uint8), cv2.IMREAD_UNCHANGED)
    if msg.format != "png" or bgr is None or bgr.ndim != 3 or bgr.shape[2] != 3:
        raise ValueError("rgb is not a 3-channel PNG")
    return cv2.cvtColor(bgr, cv2.COLOR_BGR2RGB)


def _decode_raw(data: bytes, encoding: str, dtype: str) -> np.ndarray:
    """A writable native-endian copy (frombuffer alone would be read-only)."""
    msg = RawImage.FromString(data)
    step = msg.width * np.dtype(dtype).itemsize
    if msg.encoding != encoding or msg.step != step or len(msg.data) != step * msg.height:
        raise ValueError(f"{encoding} image has inconsistent encoding, step or size")
    return np.frombuffer(msg.data, dtype=dtype).reshape(msg.height, msg.width).astype(dtype[1:])


def sha256_file(path: Path | str) -> str:
    """Hex sha256 of a file, read in blocks so shards of any size fit in memory."""
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 22), b""):
            h.update(block)
    return h.hexdigest()
