"""Exports shared machinery and the training formats: staging, CLI, roborefer, bench, parquet.

Each format is checked by loading its output the way its consumer does (json + image
files for RoboRefer and RefSpatial-Bench, pyarrow and `datasets` for Parquet).
"""

from __future__ import annotations

import argparse
import hashlib
import json
from pathlib import Path

import cv2
import numpy as np
import pytest

from refspatial.data import RefSpatialDataset
from refspatial.export import FORMATS, ExportError, add_cli, export
from refspatial.export.bench import decode_rle, score, to_pixels
from refspatial.export.common import FAR_FRACTION, FAR_PLANE_M, backproject, depth_to_png8, project, valid_depth
from refspatial.recipe import load_recipe
from refspatial.shards import generate

MULTIVIEW = Path(__file__).parent / "data" / "tiny_multiview.yaml"
SUFFIX = ("Your answer should be formatted as a list of tuples, i.e. [(x1, y1)], where each tuple contains "
          "the x and y coordinates of a point satisfying the conditions above. The coordinates should be "
          "between 0 and 1, indicating the normalized pixel locations of the points in the image.")


@pytest.fixture(scope="module")
def multiview_dataset(tmp_path_factory, catalogue):
    """Four two-view scenes in two shards, made once per session: a second module calling
    generate() on the same folder finds the shards complete and only rewrites the manifest."""
    out = tmp_path_factory.getbasetemp() / "export-multiview"
    generate(out, load_recipe(str(MULTIVIEW)), catalogue, n_scenes=4, base_seed=5, workers=1, scenes_per_shard=2)
    return out


def _records(root: Path, fields=("rgb", "depth", "seg")) -> dict[str, dict]:
    ds = RefSpatialDataset(root, fields=fields)
    return {s["key"]: s for s in (ds[i] for i in range(len(ds)))}


def _tree_digest(root: Path) -> dict[str, str]:
    return {str(p.relative_to(root)): hashlib.sha256(p.read_bytes()).hexdigest()
            for p in sorted(root.rglob("*")) if p.is_file()}


def _imread(path: Path) -> np.ndarray:
    image = cv2.imread(str(path), cv2.IMREAD_UNCHANGED)
    assert image is not None, path
    return image


# --- shared machinery ----------------------------------------------------------------------


def test_depth_png_is_near_bright_and_min_max_normalised():
    depth = np.array([[1.0, 2.0], [3.0, 100.0]], dtype=np.float32)  # 100 m = sky
    png = depth_to_png8(depth)
    assert png.shape == (2, 2, 3) and png.dtype == np.uint8
    assert (png[..., 0] == png[..., 2]).all()
    assert png[0, 0, 0] == 255 and png[1, 0, 0] == 0 and png[0, 1, 0] == 128 and png[1, 1, 0] == 0
    assert valid_depth(depth).tolist() == [[True, True], [True, False]]


def test_backproject_then_project_returns_pixel_centres():
    K = np.array([[100.0, 0, 32], [0, 100.0, 24], [0, 0, 1]])
    T = np.eye(4)
    T[:3, :3] = cv2.Rodrigues(np.array([0.3, -0.2, 0.1]))[0]
    T[:3, 3] = [0.1, -0.4, 1.2]
    depth = np.random.default_rng(0).uniform(0.5, 2.0, (48, 64)).astype(np.float32)
    world, rc = backproject(depth, K, T, np.ones(depth.shape, bool))
    uv, z = project(world, K, T)
    assert np.allclose(uv, rc[:, ::-1] + 0.5, atol=1e-9) and np.allclose(z, depth.ravel(), atol=1e-6)


def test_non_empty_out_is_refused_and_overwrite_replaces(multiview_dataset, tmp_path):
    out = tmp_path / "bench"
    out.mkdir()
    (out / "keep.txt").write_text("mine")
    with pytest.raises(ExportError) as err:
        export("bench", multiview_dataset, out)
    assert "--overwrite" in str(err.value) and "\n" not in str(err.value)
    assert (out / "keep.txt").read_text() == "mine"
    export("bench", multiview_dataset, out, overwrite=True)
    assert not (out / "keep.txt").exists() and (out / "Location" / "question.json").is_file()
    assert [p.name for p in tmp_path.iterdir()] == ["bench"]  # no staging or old folder left


def test_out_may_not_hold_the_dataset(multiview_dataset):
    for out in (multiview_dataset, multiview_dataset.parent):
        with pytest.raises(ExportError, match="outside the dataset"):
            export("bench", multiview_dataset, out, overwrite=True)
    assert (multiview_dataset / "manifest.json").is_file()


def test_sky_reads_the_far_plane(multiview_dataset):
    """FAR_PLANE_M must follow mjcf.py's clipping: sky pixels sit at it, surfaces well short."""
    for s in _records(multiview_dataset, fields=("depth", "seg")).values():
        d = s["depth_m"]
        sky = d >= FAR_FRACTION * FAR_PLANE_M
        assert np.allclose(d[sky], FAR_PLANE_M, rtol=1e-3) and (s["seg"][sky] == -1).all()
        assert d[~sky].max() < 20


def test_a_failing_export_leaves_nothing(multiview_dataset, tmp_path, monkeypatch):
    import refspatial.export.roborefer as rr

    calls = {"n": 0}
    real = rr.write_png

    def flaky(path, image):
        calls["n"] += 1
        if calls["n"] > 3:
            raise OSError(28, "No space left on device")
        real(path, image)

    monkeypatch.setattr(rr, "write_png", flaky)
    with pytest.raises(OSError):
        export("roborefer", multiview_dataset, tmp_path / "out")
    assert list(tmp_path.iterdir()) == []


def test_missing_dataset_is_a_one_line_error(tmp_path):
    with pytest.raises(ExportError) as err:
        export("roborefer", tmp_path / "nothing", tmp_path / "out")
    assert "manifest.json" in str(err.value) and "\n" not in str(err.value)
    with pytest.raises(ExportError, match="unknown export format"):
        export("tfrecord", tmp_path, tmp_path / "out")


def test_cli_registers_every_format_and_runs(multiview_dataset, tmp_path, capsys):
    parser = argparse.ArgumentParser(prog="refspatial")
    add_cli(parser.add_subparsers(dest="command"))
    for name in FORMATS:
        assert parser.parse_args(["export", name, "d", "o"]).format == name
    args = parser.parse_args(["export", "roborefer", str(multiview_dataset), str(tmp_path / "rr"), "--max-turns", "4"])
    assert args.func(args) == 0
    n = len(RefSpatialDataset(multiview_dataset, fields=()))
    assert f"exported {n} records as roborefer" in capsys.readouterr().out
    args = parser.parse_args(["export", "colmap", "d", "o", "--stride", "2", "--text"])
    assert (args.stride, args.text, args.depth_tolerance_m) == (2, True, 0.01)
    with pytest.raises(SystemExit):
        parser.parse_args(["export", "roborefer", "d", "o", "--stride", "2"])
    with pytest.raises(ExportError, match="--max-turns"):
        export("roborefer", multiview_dataset, tmp_path / "x", max_turns=16)


# --- roborefer -------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def roborefer(multiview_dataset, tmp_path_factory):
    out = tmp_path_factory.mktemp("roborefer") / "out"
    export("roborefer", multiview_dataset, out)
    return out


def _subsets(out: Path) -> dict[str, list[dict]]:
    return {p.stem: json.loads(p.read_text()) for p in sorted(out.glob("*_qa.json"))}


def test_roborefer_layout_and_records(roborefer, multiview_dataset):
    subsets = _subsets(roborefer)
    families = {qa["family"] for s in _records(multiview_dataset, fields=()).values() for qa in s["qa"]}
    assert {"choice_qa", "reasoning_template_qa"} <= set(subsets)
    assert ("vacant_qa" in subsets) == ("placement" in families)  # no empty subset files
    assert ("multi_view_qa" in subsets) == ("multiview" in families)
    ids = [r["id"] for rows in subsets.values() for r in rows]
    assert len(ids) == len(set(ids))
    folders = {"visual_choice_qa": ("image_visual_choice", "depth"), "multi_view_qa": ("image_multi_view", "depth_multi_view")}
    for name, rows in subsets.items():
        image_dir, depth_dir = (roborefer / f for f in folders.get(name, ("image", "depth")))
        for r in rows:
            assert set(r) == {"id", "image", "depth", "conversations"}
            images = r["image"] if isinstance(r["image"], list) else [r["image"]]
            depths = r["depth"] if isinstance(r["depth"], list) else [r["depth"]]
            assert len(images) == len(depths) == (2 if name == "multi_view_qa" else 1)
            for image, depth in zip(images, depths):
                assert _imread(image_dir / image).shape[2] == 3 and _imread(depth_dir / depth).shape[2] == 3
            turns = r["conversations"]
            assert 2 <= len(turns) <= 30 and len(turns) % 2 == 0
            assert [t["from"] for t in turns] == ["human", "gpt"] * (len(turns) // 2)
            assert turns[0]["value"].startswith("<image>\n" * len(images))
            assert sum(t["value"].count("<image>") for t in turns) == len(images)
    metadata = json.loads((roborefer / "reasoning_metadata.json").read_text())
    assert set(metadata) == set(ids)


def test_roborefer_keeps_every_qa_text_byte_exact(roborefer, multiview_dataset):
    want = []
    for s in _records(multiview_dataset, fields=()).values():
        for qa in s["qa"]:
            gpt = qa["reasoning"] if qa["family"] == "location" else qa["answer"]
            want.append((qa["question"], gpt))
            if qa["kind"] == "point":
                assert qa["question"] == f"{qa['prompt']} {SUFFIX}"
            if qa["family"] == "location":
                assert gpt.endswith(f"<answer>{qa['answer']}</answer>")
    got = []
    for rows in _subsets(roborefer).values():
        for r in rows:
            values = [t["value"].replace("<image>\n", "") for t in r["conversations"]]
            got += list(zip(values[::2], values[1::2]))
    assert sorted(got) == sorted(want)


def test_roborefer_depth_images(roborefer, multiview_dataset):
    for key, s in _records(multiview_dataset).items():
        stem = key.replace("/", "_")
        png = _imread(roborefer / "depth" / f"{stem}_depth.png")
        assert png.shape == (*s["depth_m"].shape, 3) and png.dtype == np.uint8
        valid = valid_depth(s["depth_m"])
        d = np.where(valid, s["depth_m"], np.inf)
        nearest = np.unravel_index(np.argmin(d), d.shape)
        assert png[nearest][0] == 255 and png[..., 0][valid].min() == 0
        assert (png[..., 0][~valid] == 0).all()


def test_roborefer_multi_view_and_visual_choice_records(roborefer, multiview_dataset):
    records = _records(multiview_dataset, fields=("rgb", "seg"))
    by_id = {qa["qa_id"]: qa for s in records.values() for qa in s["qa"]}
    metadata = json.loads((roborefer / "reasoning_metadata.json").read_text())
    subsets = _subsets(roborefer)
    for r in subsets.get("multi_view_qa", []):
        for turn, trace in zip(r["conversations"][1::2], metadata[r["id"]], strict=True):
            qa = by_id[trace["qa_id"]]
            assert r["image"] == [k.replace("/", "_") + ".png" for k in qa["images"]]
            if qa["kind"] == "point":  # the answer lies on the target in the second image
                assert score(turn["value"], records[qa["images"][1]]["seg"] == qa["target_id"]) == 1.0
    for r in subsets.get("visual_choice_qa", []):
        qa = by_id[metadata[r["id"]][0]["qa_id"]]
        drawn = cv2.cvtColor(_imread(roborefer / "image_visual_choice" / r["image"]), cv2.COLOR_BGR2RGB)
        clean = records[qa["qa_id"].split("#")[0]]["rgb"]
        assert drawn.shape == clean.shape and not np.array_equal(drawn, clean)  # the marks are drawn


def test_roborefer_splits_at_max_turns(multiview_dataset, roborefer, tmp_path):
    export("roborefer", multiview_dataset, tmp_path / "two", max_turns=2)
    short, full = _subsets(tmp_path / "two"), _subsets(roborefer)
    assert all(len(r["conversations"]) <= 4 for rows in short.values() for r in rows)
    for name in full:
        pairs = [t["value"].replace("<image>\n", "") for r in full[name] for t in r["conversations"]]
        again = [t["value"].replace("<image>\n", "") for r in short[name] for t in r["conversations"]]
        assert again == pairs


def test_roborefer_is_deterministic(multiview_dataset, roborefer, tmp_path):
    export("roborefer", multiview_dataset, tmp_path / "again")
    assert _tree_digest(tmp_path / "again") == _tree_digest(roborefer)


# --- bench -----------------------------------------------------------------------------------


def test_bench_layout_masks_and_scores(multiview_dataset, tmp_path):
    summary = export("bench", multiview_dataset, tmp_path / "bench")
    by_id = {qa["qa_id"]: qa for s in _records(multiview_dataset, fields=()).values() for qa in s["qa"]}
    want = {"Location": [q for q in by_id.values() if q["family"] == "location" and q["kind"] == "point"],
            "Placement": [q for q in by_id.values() if q["family"] == "placement" and q.get("free_mask")]}
    assert want["Location"]
    for split, category in (("Location", "location"), ("Placement", "placement")):
        folder = tmp_path / "bench" / split
        assert folder.is_dir() == bool(want[split])
        if not want[split]:
            continue
        questions = json.loads((folder / "question.json").read_text())
        assert summary.counts[split] == len(questions) == len(want[split])
        assert [q["id"] for q in questions] == list(range(len(questions)))
        for q in questions:
            assert {"id", "object", "prompt", "suffix", "rgb_path", "mask_path", "category", "step"} <= set(q)
            qa = by_id[q["qa_id"]]
            assert f"{q['prompt']} {q['suffix']}" == qa["question"] and q["suffix"] == SUFFIX
            assert (q["object"], q["category"], q["step"]) == (qa["ref"], category, qa["num_steps"])
            mask = _imread(folder / q["mask_path"])
            assert mask.ndim == 2 and set(np.unique(mask)) <= {0, 255}
            assert _imread(folder / q["rgb_path"]).shape[:2] == mask.shape
            assert score(qa["answer"], mask) == 1.0  # the stored answer scores full marks


def test_score_follows_roboRefer_rule():
    mask = np.zeros((10, 20), np.uint8)
    mask[:, :10] = 255  # left half
    assert score("[(0.25, 0.5)]", mask) == 1.0
    assert score("[(0.25, 0.5), (0.75, 0.5)]", mask) == 0.5
    assert score([[0.25, 0.5], [1.5, 0.5]], mask) == 0.5  # off the image: a miss
    assert score("no idea", mask) == 0.0
    assert score("[(3, 4)]", mask) == 1.0  # integers are pixels
    assert to_pixels("[(0.999, 0.05)]", 20, 10).tolist() == [[19, 0]]
    assert score([[0.2, 0.2]], np.dstack([mask] * 3)) == 1.0


def test_free_masks_decode_as_annotate_encodes_them():
    from refspatial.annotate import rle_encode

    mask = np.zeros((3, 4), bool)
    mask[1, 1:3] = True
    mask[2, 0] = True
    assert np.array_equal(decode_rle(rle_encode(mask), (3, 4)), mask)
    with pytest.raises(ExportError, match="free_mask"):
        decode_rle({"size": [3, 4], "counts": [5]}, (3, 4))
    with pytest.raises(ExportError, match="free_mask size"):
        decode_rle(rle_encode(mask), (4, 3))


# --- parquet --------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def parquet(multiview_dataset, tmp_path_factory):
    out = tmp_path_factory.mktemp("parquet") / "out"
    export("parquet", multiview_dataset, out)
    return out


def test_parquet_reads_with_pyarrow(parquet, multiview_dataset):
    pq = pytest.importorskip("pyarrow.parquet")
    files = sorted((parquet / "data").glob("*.parquet"))
    n = len(json.loads((multiview_dataset / "manifest.json").read_text())["shards"])
    assert [f.name for f in files] == [f"train-{i:05d}-of-{n:05d}.parquet" for i in range(n)]
    table = pq.read_table(files)
    records = _records(multiview_dataset, fields=("rgb",))
    assert table.num_rows == len(records)
    assert b"huggingface" in table.schema.metadata
    for row in table.to_pylist():
        s = records[row["key"]]
        rgb = cv2.cvtColor(cv2.imdecode(np.frombuffer(row["image"]["bytes"], np.uint8), cv2.IMREAD_COLOR), cv2.COLOR_BGR2RGB)
        assert np.array_equal(rgb, s["rgb"])
        assert [q["question"] for q in row["qa"]] == [q["question"] for q in s["qa"]]
        assert [json.loads(q["json"]) for q in row["qa"]] == s["qa"]
        assert row["K"] == s["K"].tolist()


def test_parquet_loads_with_huggingface_datasets(parquet, multiview_dataset, tmp_path):
    datasets = pytest.importorskip("datasets")
    files = [str(p) for p in sorted((parquet / "data").glob("*.parquet"))]
    ds = datasets.load_dataset("parquet", data_files=files, split="train", cache_dir=str(tmp_path / "cache"))
    assert isinstance(ds.features["image"], datasets.Image) and isinstance(ds.features["depth"], datasets.Image)
    records = _records(multiview_dataset, fields=("rgb",))
    row = ds[0]
    s = records[row["key"]]
    assert np.array_equal(np.asarray(row["image"].convert("RGB")), s["rgb"])
    assert row["depth"].size == (s["scene"]["width"], s["scene"]["height"])
    assert row["qa"][0]["question"] == s["qa"][0]["question"]
    card = datasets.load_dataset(str(parquet), split="train", cache_dir=str(tmp_path / "cache2"))
    assert card.num_rows == len(records)
