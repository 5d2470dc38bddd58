"""Generate tiny scenes, read them back through the loader, and check every answer."""

import json

import numpy as np
import pytest

from refspatial.data import RefSpatialDataset
from refspatial.questions import execute
from refspatial.questions.phrases import Phrasebook
from refspatial.relations import ObjectFacts, ViewFacts
from refspatial.shards import generate


def test_manifest_accounts_for_every_scene(tiny_dataset):
    m = json.loads((tiny_dataset / "manifest.json").read_text())
    assert m["scenes"] == 8 and [s["scenes"] for s in m["shards"]] == [[0, 3], [3, 6], [6, 8]]
    assert m["records"] + m["rejected"]["count"] == 8  # one view per scene in the tiny recipe
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


def _facts_from_record(sample) -> ViewFacts:
    """Rebuild view facts from what the record stores, so answers are checked from the data alone."""
    from refspatial.relations.facts import _horizontal

    R = sample["T_world_cam"][:3, :3]
    right, forward = _horizontal(R[:, 0]), _horizontal(R[:, 2])
    seg, depth = sample["seg"], sample["depth_m"]
    objs = []
    for o in sample["objects"]:
        aabb = np.array(o["aabb_world_m"])
        c = aabb.mean(0)
        px = int((seg == o["id"]).sum())
        d = float(np.median(depth[seg == o["id"]])) if px else float("inf")
        objs.append(ObjectFacts(o["id"], o["category"], o["name"], o["color"], aabb, float(c @ right),
                                float(c @ forward), d, px, o["visibility"]))
    return ViewFacts(tuple(objs), right, forward, seg, depth)


def test_every_answer_is_verified_against_the_stored_data(tiny_dataset):
    checked = 0
    suffix = Phrasebook.get().point_suffix
    for s in RefSpatialDataset(tiny_dataset):
        facts = _facts_from_record(s)
        h, w = s["seg"].shape
        for qa in s["qa"]:
            program = [{k: v for k, v in n.items() if k != "result"} for n in qa["steps"]]
            assert execute(program, facts) == [n["result"] for n in qa["steps"]], qa["question"]
            if qa["kind"] == "point":
                assert qa["question"] == f"{qa['prompt']} {suffix}"
                assert qa["answer_points"]
                for x, y in qa["answer_points"]:
                    assert 0 <= x <= 1 and 0 <= y <= 1 and round(x, 3) == x
                    assert s["seg"][int(y * h), int(x * w)] == qa["target_id"], qa["question"]
                for step in qa["reasoning_steps"]:
                    px, py = step["point"]
                    assert s["seg"][int(py * h), int(px * w)] == step["object_id"]
                assert qa["reasoning"].startswith("<think>") and qa["reasoning"].endswith(f"<answer>{qa['answer']}</answer>")
            else:
                assert qa["answer"] in ("(A)", "(B)")
            checked += 1
    assert checked >= 20


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
    with pytest.raises(RunError, match="already holds a dataset"):
        generate(out, tiny, catalogue, n_scenes=1, base_seed=2, workers=1, scenes_per_shard=2)
