"""Generate tiny scenes, read them back through the loader, and check every answer."""

import json

import numpy as np
import pytest
from mcap.reader import make_reader

import shutil

from refspatial.annotate import rle_decode
from refspatial.data import RefSpatialDataset
from refspatial.questions.phrases import Phrasebook
from refspatial.records import Record, ShardReader, ShardWriter, sha256_file
from refspatial.shard_index import NS_PER_RECORD
from refspatial.shards import generate
from refspatial.verify import verify


def test_manifest_accounts_for_every_scene(tiny_dataset):
    m = json.loads((tiny_dataset / "manifest.json").read_text())
    assert m["scenes"] == 8 and [s["scenes"] for s in m["shards"]] == [[0, 3], [3, 6], [6, 8]]
    assert m["records"] == 2 * (8 - m["rejected"]["count"])  # two views per scene
    assert m["records"] >= 4, "most tiny scenes should survive"
    assert sum(s["qa"] for s in m["shards"]) == m["qa"]
    assert len(m["recipe_hash"]) == 64 and "name: tiny" in m["recipe_yaml"]
    assert not list(tiny_dataset.rglob("*.partial"))


def test_loader_yields_documented_samples(tiny_dataset, tiny):
    ds = RefSpatialDataset(tiny_dataset)
    samples = list(ds)
    assert len(samples) == len(ds) > 0
    h, w = tiny["camera"]["height"], tiny["camera"]["width"]
    for s in samples:
        assert s["rgb"].shape == (h, w, 3) and s["rgb"].dtype == np.uint8
        assert s["depth_m"].shape == (h, w) and s["depth_m"].dtype == np.float32
        assert s["seg"].shape == (h, w) and s["seg"].dtype == np.int32
        assert s["K"].shape == (3, 3) and s["T_world_cam"].shape == (4, 4)
        ids = {o["id"] for o in s["objects"]}
        assert set(np.unique(s["seg"])) - {-1} <= ids
        for o in s["objects"]:
            assert {"id", "category", "color", "box_world"} <= set(o)
        for qa in s["qa"]:
            assert {"question", "answer", "answer_points", "target_id", "steps", "num_steps"} <= set(qa)
            assert 1 <= qa["num_steps"] <= 5


def test_verify_finds_every_answer_correct(tiny_dataset):
    report = verify(tiny_dataset)
    assert report.failures == []
    assert report.qa >= 40 and report.checks == report.qa


def test_every_point_answer_lies_on_its_target(tiny_dataset):
    """Independent of verify: read through the loader and look at the masks directly."""
    suffix = Phrasebook.get().point_suffix
    checked = 0
    samples = {s["key"]: s for s in RefSpatialDataset(tiny_dataset)}
    for s in samples.values():
        h, w = s["seg"].shape
        for qa in s["qa"]:
            if qa["kind"] != "point":
                continue
            assert qa["question"] == f"{qa['prompt']} {suffix}"
            mask = rle_decode(qa["free_mask"]) if qa["family"] == "placement" else s["seg"] == qa["target_id"]
            for x, y in qa["answer_points"]:
                assert 0 <= x < 1 and 0 <= y < 1 and round(x, 3) == x
                assert mask[int(y * h), int(x * w)], qa["question"]
            for step in qa["reasoning_steps"]:
                if step["kind"] != "Position" or step["object_id"] is None:
                    continue
                seg = samples[qa["images"][0]]["seg"] if step.get("view") == "other" else s["seg"]
                px, py = step["point"]
                assert seg[int(py * h), int(px * w)] == step["object_id"]
            assert qa["reasoning"].startswith("<think>") and qa["reasoning"].endswith(f"<answer>{qa['answer']}</answer>")
            checked += 1
    assert checked >= 10


def test_verify_catches_a_wrong_answer(tiny_dataset, tmp_path):
    """Rewrite one shard with a point moved off its target; verify must name it."""
    broken = tmp_path / "broken"
    shutil.copytree(tiny_dataset, broken)
    manifest = json.loads((broken / "manifest.json").read_text())
    entry = manifest["shards"][0]
    path = broken / entry["file"]
    reader = ShardReader(path)
    records = [reader.read(i) for i in range(len(reader))]
    meta = reader.metadata()
    victim = next((r, q) for r in records for q in r["qa"] if q["kind"] == "point" and q["family"] == "location")
    record, qa = victim
    rows, cols = np.nonzero(record["seg"] != qa["target_id"])
    qa["answer_points"] = [[round((cols[0] + 0.5) / record["seg"].shape[1], 3), round((rows[0] + 0.5) / record["seg"].shape[0], 3)]]
    path.unlink()
    with ShardWriter(path, meta) as writer:
        for r in records:
            writer.write(Record(r["key"], r["scene"], r["rgb"], r["depth_m"], r["seg"], r["K"], r["T_world_cam"],
                                r["relations"], r["qa"]))
    report = verify(broken)
    assert any("sha256" in f for f in report.failures)  # the manifest no longer matches
    entry["sha256"] = sha256_file(path)
    (broken / "manifest.json").write_text(json.dumps(manifest))
    report = verify(broken)
    assert len(report.failures) == 1 and "not on the target's mask" in report.failures[0]
    assert record["key"] in report.failures[0]


def test_verify_names_the_damaged_records_of_a_changed_shard(tiny_dataset, tmp_path):
    damaged = tmp_path / "damaged"
    shutil.copytree(tiny_dataset, damaged)
    path = damaged / "shards" / "shard-00001.mcap"
    keys = ShardReader(path).keys()
    with path.open("rb") as f:
        summary = make_reader(f).get_summary()
    topics = {c.id: c.topic for c in summary.channels.values()}
    # One byte flipped midway through the compressed messages of two chunks: the first record's
    # RGB and the second record's JSON (its key with it). A fixed share of the file could land
    # on a chunk's time fields instead, which no record reads.
    raw = bytearray(path.read_bytes())
    hit = {}
    for chunk in summary.chunk_indexes:
        record = chunk.message_start_time // NS_PER_RECORD - 1
        kind = "rgb" if list(map(topics.get, chunk.message_index_offsets)) == ["/camera/rgb"] else (
            "json" if "/scene" in map(topics.get, chunk.message_index_offsets) else None)
        if (record, kind) in ((0, "rgb"), (1, "json")):
            data_start = chunk.chunk_start_offset + chunk.chunk_length - chunk.compressed_size
            raw[data_start + chunk.compressed_size // 2] ^= 0xFF
            hit[record] = kind
    assert hit == {0: "rgb", 1: "json"}
    path.write_bytes(bytes(raw))
    failures = verify(damaged).failures
    assert failures[0] == "shards/shard-00001.mcap: sha256 differs from manifest.json"
    named = failures[1:]
    assert [f.split()[2] for f in named] == ["0", "1"], failures
    assert f"record 0 ({keys[0]})" in named[0] and "record 1 (its key unreadable)" in named[1]
    # Whether the CRC check or the decoder catches the byte first, the record is named as damaged.
    assert all("CRC" in f.upper() or "DAMAGED" in f.upper() for f in named), named


def test_same_command_gives_identical_bytes_whatever_the_worker_count(tiny_dataset, tiny, catalogue, tmp_path):
    again = tmp_path / "again"
    generate(again, tiny, catalogue, n_scenes=8, base_seed=7, workers=1, scenes_per_shard=3)
    for name in ("manifest.json", "shards/shard-00000.mcap", "shards/shard-00001.mcap", "shards/shard-00002.mcap"):
        assert (again / name).read_bytes() == (tiny_dataset / name).read_bytes(), name


def test_rerun_skips_complete_shards_and_redoes_broken_ones(tiny, catalogue, tmp_path):
    out = tmp_path / "ds"
    generate(out, tiny, catalogue, n_scenes=4, base_seed=1, workers=1, scenes_per_shard=2)
    first = (out / "shards/shard-00001.mcap").read_bytes()
    (out / "shards/shard-00001.mcap").write_bytes(first[: len(first) // 2])  # a torn file
    before = (out / "shards/shard-00000.mcap").stat().st_mtime_ns
    generate(out, tiny, catalogue, n_scenes=4, base_seed=1, workers=1, scenes_per_shard=2)
    assert (out / "shards/shard-00000.mcap").stat().st_mtime_ns == before
    assert (out / "shards/shard-00001.mcap").read_bytes() == first


def test_a_different_run_into_the_same_folder_is_refused(tiny, catalogue, tmp_path):
    from refspatial.shards import RunError

    out = tmp_path / "ds"
    generate(out, tiny, catalogue, n_scenes=1, base_seed=1, workers=1, scenes_per_shard=2)
    with pytest.raises(RunError, match="manifest.json says its dataset was made with --seed 1, not --seed 2; "):
        generate(out, tiny, catalogue, n_scenes=1, base_seed=2, workers=1, scenes_per_shard=2)


@pytest.mark.parametrize("family", ["tabletop", "kitchen_counter", "shelf", "room"])
def test_every_scene_family_generates_and_verifies(family, catalogue, tmp_path):
    from refspatial.recipe import load_recipe

    small = tmp_path / f"{family}_small.yaml"
    small.write_text(f"extends: {family}\nname: {family}_small\ncamera: {{width: 192, height: 108}}\n"
                     "questions: {per_view: 6}\n")
    out = tmp_path / "ds"
    manifest = generate(out, load_recipe(str(small)), catalogue, n_scenes=2, base_seed=3, workers=1,
                        scenes_per_shard=2)
    assert manifest["records"] >= 2 and manifest["qa"] >= 12
    report = verify(out)
    assert report.failures == [] and report.qa == manifest["qa"]


def test_stage_memory_is_measured_only_while_tracing(tiny, catalogue):
    import tracemalloc

    from refspatial.pipeline import STAGES, generate_scene

    plain = generate_scene(tiny, catalogue, 5)
    assert plain.rejected is None and plain.peak_bytes == {}
    tracemalloc.start()
    try:
        traced = generate_scene(tiny, catalogue, 5)
    finally:
        tracemalloc.stop()
    assert set(traced.peak_bytes) == set(STAGES)
    assert traced.peak_bytes["render"] >= 3 * 192 * 108  # at least the RGB frames it returns
    assert [r.qa for r in traced.records] == [r.qa for r in plain.records]  # tracing changes no output
