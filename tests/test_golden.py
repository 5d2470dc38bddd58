"""The committed golden shard must still read, and re-encode, exactly as it did.

tests/golden/dataset was written by tests/golden/make_golden.py; expected.json is what the
reader made of it then. Pixels are left out of the byte checks (PNG encoders and renderers
change between versions); the JSON messages, schemas, metadata, calibration and raw
depth/seg encodings are pinned to the byte. A failure here means the format drifted: bump
shards.FORMAT_VERSION, describe the change in docs/FORMAT.md, then regenerate the golden.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from mcap.reader import make_reader

from refspatial.data import RefSpatialDataset
from refspatial.records import Record, ShardReader, ShardWriter

GOLDEN = Path(__file__).parent / "golden"
SHARD = GOLDEN / "dataset" / "shards" / "shard-00000.mcap"
EXPECTED = json.loads((GOLDEN / "expected.json").read_text(encoding="utf-8"))
SUFFIX = ("Your answer should be formatted as a list of tuples, i.e. [(x1, y1)], where each tuple contains "
          "the x and y coordinates of a point satisfying the conditions above. The coordinates should be "
          "between 0 and 1, indicating the normalized pixel locations of the points in the image.")
TOPICS = {  # topic -> (message encoding, schema name, schema encoding)
    "/scene": ("json", "refspatial.Scene", "jsonschema"),
    "/relations": ("json", "refspatial.Relations", "jsonschema"),
    "/qa": ("json", "refspatial.QA", "jsonschema"),
    "/camera/calibration": ("protobuf", "foxglove.CameraCalibration", "protobuf"),
    "/camera/rgb": ("protobuf", "foxglove.CompressedImage", "protobuf"),
    "/camera/depth": ("protobuf", "foxglove.RawImage", "protobuf"),
    "/camera/seg": ("protobuf", "foxglove.RawImage", "protobuf"),
}
QA_KEYS = {"qa_id", "family", "kind", "prompt", "question", "answer", "answer_points", "target_id", "ref",
           "steps", "num_steps", "predicates", "reasoning_steps", "reasoning"}


def _raw_messages(path: Path) -> list[tuple[str, int, int, bytes]]:
    """(topic, log_time, sequence, data) of every message, in file order."""
    with open(path, "rb") as f:
        return [(c.topic, m.log_time, m.sequence, m.data) for _, c, m in make_reader(f).iter_messages()]


@pytest.fixture(scope="module")
def reader() -> ShardReader:
    return ShardReader(SHARD)


def test_golden_is_small():
    size = sum(p.stat().st_size for p in (GOLDEN / "dataset").rglob("*") if p.is_file())
    assert size < 300_000


def test_topics_schemas_and_channel_metadata():
    with open(SHARD, "rb") as f:
        summary = make_reader(f).get_summary()
    schemas = summary.schemas
    got = {c.topic: (c.message_encoding, schemas[c.schema_id].name, schemas[c.schema_id].encoding)
           for c in summary.channels.values()}
    assert got == TOPICS
    channels = sorted(({"topic": c.topic, "message_encoding": c.message_encoding, "metadata": dict(c.metadata),
                        "schema_name": schemas[c.schema_id].name, "schema_encoding": schemas[c.schema_id].encoding}
                       for c in summary.channels.values()), key=lambda c: c["topic"])
    assert channels == EXPECTED["channels"]
    scene_schema = json.loads(next(s for s in schemas.values() if s.name == "refspatial.Scene").data)
    assert scene_schema["required"] == ["key", "K", "T_world_cam"]


def test_metadata(reader):
    meta = reader.metadata()
    assert meta == EXPECTED["metadata"]
    assert set(meta) == {"refspatial", "recipe"}
    assert meta["refspatial"]["format"] == "refspatial-shards"
    assert meta["refspatial"]["format_version"] == "1"
    assert {"version", "recipe", "recipe_hash", "catalogue_sha256", "base_seed", "scenes"} <= set(meta["refspatial"])
    assert set(meta["recipe"]) == {"name", "yaml", "resolved_json"}


def test_records_read_exactly_as_recorded(reader):
    assert len(reader) == len(EXPECTED["records"]) == 2
    assert reader.keys() == [r["key"] for r in EXPECTED["records"]]
    for sample, want in zip(reader, EXPECTED["records"]):
        for k in ("key", "index", "scene", "relations", "qa"):
            assert sample[k] == want[k], k
        assert sample["K"].tolist() == want["K"] and sample["T_world_cam"].tolist() == want["T_world_cam"]
        for k, (shape, dtype) in want["shapes"].items():
            assert list(sample[k].shape) == shape and str(sample[k].dtype) == dtype


def test_pinned_content(reader):
    first = reader.read(0, fields=())
    assert first["key"].endswith("/view0") and first["scene"]["view"] == "view0"
    assert {"scene_id", "recipe", "recipe_hash", "seed", "view", "view_index", "views", "width", "height",
            "camera", "table", "light", "objects"} <= set(first["scene"])
    assert {"id", "category", "name", "color", "rgba", "pose", "box_world", "aabb_world_m", "front_world",
            "visibility"} <= set(first["scene"]["objects"][0])
    keys = [r["key"] for r in EXPECTED["records"]]
    qas = [q for r in EXPECTED["records"] for q in r["qa"]]
    assert {"location", "choice", "placement", "multiview"} <= {q["family"] for q in qas}
    for q in qas:
        assert QA_KEYS <= set(q)
        if q["kind"] == "point":
            assert q["question"] == f"{q['prompt']} {SUFFIX}"
            assert q["reasoning"].endswith(f"<answer>{q['answer']}</answer>")
        if q["family"] == "multiview":
            assert len(q["images"]) == 2 and set(q["images"]) == set(keys) and q["qa_id"].startswith(q["images"][1])
        if q["family"] == "placement":
            assert q["free_mask"]["size"] == [first["scene"]["height"], first["scene"]["width"]]


def test_log_times_and_json_bytes():
    messages = _raw_messages(SHARD)
    assert len(messages) == 7 * 2
    for topic, log_time, sequence, data in messages:
        assert log_time == (sequence + 1) * 1_000_000_000
        if TOPICS[topic][0] == "json":  # compact UTF-8 JSON, key order as written
            decoded = json.loads(data)
            assert data == json.dumps(decoded, ensure_ascii=False, separators=(",", ":")).encode("utf-8")


def test_todays_writer_reencodes_the_same_bytes(reader, tmp_path):
    """Everything but the PNG: JSON, calibration and the raw depth / seg images."""
    out = tmp_path / "again.mcap"
    with ShardWriter(out, reader.metadata()) as writer:
        for s in reader:
            writer.write(Record(key=s["key"], scene=s["scene"], rgb=s["rgb"], depth_m=s["depth_m"], seg=s["seg"],
                                K=s["K"], T_world_cam=s["T_world_cam"], relations=s["relations"], qa=s["qa"]))
    old = [m for m in _raw_messages(SHARD) if m[0] != "/camera/rgb"]
    new = [m for m in _raw_messages(out) if m[0] != "/camera/rgb"]
    assert new == old
    again = ShardReader(out)
    assert np.array_equal(again.read(0)["rgb"], reader.read(0)["rgb"])


def test_dataset_loader_reads_the_golden_folder():
    ds = RefSpatialDataset(GOLDEN / "dataset", fields=("seg",), verify=True)
    assert len(ds) == 2
    sample = ds[1]
    assert sample["objects"] == sample["scene"]["objects"] and sample["seg"].dtype == np.int32
