"""Write-then-read tests for refspatial.records: one shard, its bytes and its failure modes."""

from __future__ import annotations

import hashlib
import json
import pickle
import platform
import sys
import zlib
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from mcap.reader import NonSeekingReader, make_reader
from mcap_protobuf.decoder import DecoderFactory

import refspatial.records as records
from refspatial.crc import adler32, crc32
from refspatial.record_schemas import schema_bytes
from refspatial.records import Record, ShardError, ShardReader, ShardWriter, sha256_file

META = {"refspatial": {"version": "0.1.0", "recipe_hash": "1a2b3c4d"},
        "recipe": {"name": "tabletop", "yaml": "name: tabletop\nobjects: [3, 6]\n"}}
H, W = 48, 64


def make_record(i: int, seed: int = 0, h: int = H, w: int = W) -> Record:
    """A small synthetic view: random image, smooth depth, a few object ids and two QA."""
    rng = np.random.default_rng([seed, i])
    yy, xx = np.mgrid[0:h, 0:w]
    K = np.array([[50.0 + i, 0.0, w / 2], [0.0, 50.0 + i, h / 2], [0.0, 0.0, 1.0]])
    T = np.eye(4)
    T[:3, 3] = rng.normal(size=3)
    return Record(
        key=f"tabletop-1a2b3c4d-{seed}-{i}/view0",
        scene={"seed": i, "objects": [{"object_id": k, "name": "mug", "pos_world_m": [0.1 * k, 0.0, 0.8]}
                                      for k in range(3)]},
        rgb=rng.integers(0, 256, (h, w, 3), dtype=np.uint8),
        depth_m=(1.0 + 0.01 * yy + rng.random((h, w)) * 1e-3).astype(np.float32),
        seg=(xx * 4 // w - 1).astype(np.int32),
        K=K,
        T_world_cam=T,
        relations=[{"subject": 0, "predicate": "left_of", "object": 1}],
        qa=[{"question": "Point to the mug left of the cup.", "answer_px": [[12.5, 30.0]]},
            {"question": f"How many mugs? {i}", "answer": 3}],
    )


def write_shard(path: Path, recs: list[Record], metadata: dict = META) -> Path:
    with ShardWriter(path, metadata) as w:
        for r in recs:
            w.write(r)
    return path


@pytest.fixture
def shard(tmp_path: Path) -> tuple[Path, list[Record]]:
    recs = [make_record(i) for i in range(3)]
    return write_shard(tmp_path / "shard-00000.mcap", recs), recs


def assert_sample_equals(sample: dict, r: Record, fields=("rgb", "depth", "seg")) -> None:
    assert sample["key"] == r.key
    assert sample["scene"] == r.scene and sample["relations"] == r.relations and sample["qa"] == r.qa
    for name in ("K", "T_world_cam"):
        assert sample[name].dtype == np.float64 and np.array_equal(sample[name], getattr(r, name))
    for field, name, dtype in (("rgb", "rgb", np.uint8), ("depth", "depth_m", np.float32),
                               ("seg", "seg", np.int32)):
        if field in fields:
            assert sample[name].dtype == dtype
            np.testing.assert_array_equal(sample[name], getattr(r, name))  # lossless, NaN-aware
        else:
            assert name not in sample


def test_round_trip(shard):
    path, recs = shard
    reader = ShardReader(path)
    assert len(reader) == 3 and reader.keys() == [r.key for r in recs]
    for i, r in enumerate(recs):
        sample = reader.read(i)
        assert sample["shard"] == path.name and sample["index"] == i
        assert_sample_equals(sample, r)
    assert reader.metadata() == META
    reader.verify()


def test_rewrite_is_byte_identical(tmp_path, shard):
    path, recs = shard
    again = write_shard(tmp_path / "again.mcap", [make_record(i) for i in range(3)])
    assert path.read_bytes() == again.read_bytes()
    assert sha256_file(path) == hashlib.sha256(path.read_bytes()).hexdigest()


def test_random_access_equals_streaming(shard):
    path, recs = shard
    reader = ShardReader(path)
    streamed = list(reader)
    for i in (2, 0, 1):
        sample = reader.read(i)
        assert sample.keys() == streamed[i].keys()
        assert_sample_equals(sample, recs[i])
        assert_sample_equals(streamed[i], recs[i])


@pytest.mark.parametrize("fields", [(), ("rgb",), ("depth",), ("seg", "rgb")])
def test_fields_selection(shard, fields):
    path, recs = shard
    reader = ShardReader(path)
    assert_sample_equals(reader.read(1, fields=fields), recs[1], fields)
    assert [s["key"] for s in reader.iter(fields=fields)] == [r.key for r in recs]


def test_bad_fields_and_index(shard):
    reader = ShardReader(shard[0])
    with pytest.raises(ValueError, match="fields must be a subset"):
        reader.read(0, fields=("depth_m",))
    with pytest.raises(IndexError, match="out of range"):
        reader.read(3)


def test_random_access_decompresses_only_needed_chunks(shard, monkeypatch):
    """One record, one chunk per requested group: no scan of the file."""
    calls = []
    original = records._chunk_messages
    monkeypatch.setattr(records, "_chunk_messages", lambda f, o, n: calls.append(o) or original(f, o, n))
    reader = ShardReader(shard[0])
    for fields, expected in (((), 1), (("rgb",), 2), (("rgb", "depth", "seg"), 4)):
        calls.clear()
        reader.read(2, fields=fields)
        assert len(calls) == expected


def test_standard_mcap_readers_decode_every_topic(shard):
    """The shard describes itself: a generic MCAP reader decodes it with its schemas."""
    path, recs = shard
    with open(path, "rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        summary = reader.get_summary()
        encodings = {c.topic: (summary.schemas[c.schema_id].encoding, c.message_encoding)
                     for c in summary.channels.values()}
        assert encodings["/qa"] == ("jsonschema", "json")
        assert encodings["/camera/rgb"] == ("protobuf", "protobuf")
        seen = {}
        for schema, channel, message, proto in reader.iter_decoded_messages(
                topics=["/camera/rgb", "/camera/depth", "/camera/seg", "/camera/calibration"]):
            assert message.log_time == message.publish_time and message.log_time % 10**9 == 0
            seen[(channel.topic, message.log_time)] = proto
        for schema, channel, message in reader.iter_messages(topics=["/scene", "/relations", "/qa"]):
            assert schema.data == schema_bytes(channel.topic)  # the schema file, verbatim
            assert json.loads(message.data)["key"].endswith("/view0")
    assert len(seen) == 4 * len(recs)
    assert seen[("/camera/rgb", 10**9)].format == "png"
    assert seen[("/camera/depth", 10**9)].encoding == "32FC1"
    seg = seen[("/camera/seg", 2 * 10**9)]
    assert seg.encoding == "16UC1" and seg.frame_id == "camera"
    assert np.array_equal(np.frombuffer(seg.data, "<u2").reshape(H, W), recs[1].seg + 1)
    calib = seen[("/camera/calibration", 10**9)]
    assert calib.distortion_model == "plumb_bob" and list(calib.D) == [0.0] * 5
    assert np.array_equal(np.reshape(calib.P, (3, 4))[:, :3], recs[0].K)
    with open(path, "rb") as f:  # the data-section CRC written by the shard holds
        assert sum(1 for _ in NonSeekingReader(f, validate_crcs=True).iter_messages()) == 7 * 3


@pytest.mark.skipif(sys.platform == "darwin" and platform.machine() == "x86_64", reason="isal has no wheel there")
def test_crc32_comes_from_isal():
    """The install brings the quicker checksums (a missing dependency would only show as a slower write)."""
    assert crc32.__module__ == adler32.__module__ == "isal.isal_zlib"


@settings(max_examples=60, deadline=None)
@given(st.binary(max_size=5000), st.integers(0, 2**32 - 1), st.integers(0, 5000))
def test_crc32_is_zlibs(data, start, cut):
    """The quicker CRC the shards are checked with is zlib's, whole and continued from any value,
    so every MCAP reader's check agrees with ours; so is the Adler-32 closing each RGB PNG's
    zlib stream, which decoders check."""
    assert crc32(data) == zlib.crc32(data)
    assert crc32(data, start) == zlib.crc32(data, start)
    assert crc32(data[cut:], crc32(data[:cut])) == zlib.crc32(data)
    assert adler32(data) == zlib.adler32(data)
    assert adler32(data, start) == zlib.adler32(data, start)
    assert adler32(data[cut:], adler32(data[:cut])) == zlib.adler32(data)


def test_truncated_file_raises_shard_error(shard, tmp_path):
    path = shard[0]
    data = path.read_bytes()
    for cut in (0, 5, 8, 100, len(data) // 3, len(data) // 2, len(data) - 40, len(data) - 8,
                len(data) - 1):
        bad = tmp_path / f"cut-{cut}.mcap"
        bad.write_bytes(data[:cut])
        with pytest.raises(ShardError, match=rf"{bad}.*refspatial generate") as e:
            ShardReader(bad)
        assert "\n" not in str(e.value)


def _flipped(data: bytes, at: int) -> bytes:
    return data[:at] + bytes([data[at] ^ 0xFF]) + data[at + 1:]


def test_flip_inside_a_chunk_names_the_record(shard, tmp_path):
    path, recs = shard
    with open(path, "rb") as f:
        summary = make_reader(f).get_summary()
    chunk = max((c for c in summary.chunk_indexes if c.message_start_time == 2 * 10**9),
                key=lambda c: c.chunk_length)  # record 1's largest chunk
    bad = tmp_path / "flip.mcap"
    bad.write_bytes(_flipped(path.read_bytes(), chunk.chunk_start_offset + chunk.chunk_length // 2))
    reader = ShardReader(bad)  # the summary is intact
    with pytest.raises(ShardError, match=r"\(record 1\).*refspatial generate"):
        reader.read(1)
    assert_sample_equals(reader.read(0), recs[0])  # damage stays local
    with pytest.raises(ShardError, match="CRC"):
        reader.verify()


def test_any_flipped_byte_is_caught_or_harmless(shard, tmp_path):
    """verify() catches every flip; plain reads raise ShardError or return the true data."""
    path, recs = shard
    data = path.read_bytes()
    offsets = np.random.default_rng(7).choice(len(data), size=80, replace=False)
    bad = tmp_path / "flip.mcap"
    for at in sorted(set(offsets.tolist()) | {0, len(data) - 1, len(data) - 20}):
        bad.write_bytes(_flipped(data, at))
        try:
            reader = ShardReader(bad)
            for i, sample in enumerate(reader):
                assert_sample_equals(sample, recs[i])
        except ShardError:
            pass
        with pytest.raises(ShardError):
            ShardReader(bad).verify()


def test_writer_exception_leaves_no_file(tmp_path):
    path = tmp_path / "shard-00001.mcap"
    with pytest.raises(RuntimeError, match="boom"):
        with ShardWriter(path, META) as w:
            w.write(make_record(0))
            assert w.partial_path.exists() and not path.exists()
            raise RuntimeError("boom")
    assert list(tmp_path.iterdir()) == []


def test_exception_keeps_an_existing_shard(shard):
    path = shard[0]
    before = path.read_bytes()
    with pytest.raises(KeyboardInterrupt):
        with ShardWriter(path, META) as w:
            w.write(make_record(5))
            raise KeyboardInterrupt
    assert path.read_bytes() == before and not w.partial_path.exists()


def test_failed_write_keeps_the_shard_consistent(tmp_path):
    r = make_record(1)
    bad = Record(**{**r.__dict__, "key": "bad", "qa": [{"score": float("nan")}]})
    with ShardWriter(tmp_path / "s.mcap", META) as w:
        w.write(make_record(0))
        with pytest.raises(ValueError, match="'bad': qa is not strict JSON"):
            w.write(bad)
        with pytest.raises(ValueError, match="written twice"):
            w.write(make_record(0))
        w.write(r)
    assert ShardReader(tmp_path / "s.mcap").keys() == [make_record(0).key, r.key]


@pytest.mark.parametrize(
    "change, match",
    [({"depth_m": np.zeros((H, W))}, "depth_m must be float32"),
     ({"rgb": np.zeros((H, W, 4), np.uint8)}, "rgb must be uint8"),
     ({"seg": np.full((H, W), 70000, np.int32)}, r"\[-1, 65534\]"),
     ({"K": np.eye(3, dtype=np.float32)}, "K must be float64"),
     ({"scene": {"K": 1}}, "scene must not hold"),
     ({"key": ""}, "non-empty")],
)
def test_record_validation(change, match):
    with pytest.raises(ValueError, match=match):
        Record(**{**make_record(0).__dict__, **change})


def test_metadata_must_be_text(tmp_path):
    with pytest.raises(ValueError, match=r"metadata\['refspatial'\]\['version'\] must be a str"):
        ShardWriter(tmp_path / "s.mcap", {"refspatial": {"version": 1}})
    assert list(tmp_path.iterdir()) == []


def test_empty_shard(tmp_path):
    reader = ShardReader(write_shard(tmp_path / "empty.mcap", []))
    assert len(reader) == 0 and reader.keys() == [] and list(reader) == []
    assert reader.metadata() == META


def test_shard_error_survives_pickling():
    e = ShardError("x.mcap (record 3): bad; fix")
    assert str(pickle.loads(pickle.dumps(e))) == str(e)


@settings(max_examples=15, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(h=st.integers(1, 9), w=st.integers(1, 9), seed=st.integers(0, 2**32 - 1))
def test_arrays_are_lossless(tmp_path, h, w, seed):
    """Any float32 bit pattern (NaN, inf, -0.0, denormals) and any id survive a round trip."""
    rng = np.random.default_rng(seed)
    base = make_record(0, h=h, w=w)
    r = Record(**{**base.__dict__,
                  "depth_m": rng.integers(0, 2**32, (h, w), dtype=np.uint32).view(np.float32),
                  "seg": rng.integers(-1, 65535, (h, w)).astype(np.int32)})
    sample = ShardReader(write_shard(tmp_path / "h.mcap", [r])).read(0)
    assert np.array_equal(sample["depth_m"].view(np.uint32), r.depth_m.view(np.uint32))
    assert np.array_equal(sample["seg"], r.seg) and np.array_equal(sample["rgb"], r.rgb)
