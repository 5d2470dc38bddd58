"""Exports as their consumers read them: RoboRefer's registration and depth, the Unseen
split, the benchmark and the records as Hugging Face Parquet batched by torch."""

from __future__ import annotations

import ast
import json
import warnings
from dataclasses import dataclass, field
from pathlib import Path

import cv2
import numpy as np
import pytest

from refspatial.data import RefSpatialDataset
from refspatial.export import ExportError, export
from refspatial.export.cards import PROCEDURAL, licence
from refspatial.export.common import depth_to_png8, valid_depth
from refspatial.export.unseen import HoldOut, combination, combination_fraction
from refspatial.recipe import load_recipe
from refspatial.shards import generate

MULTIVIEW = Path(__file__).parent / "data" / "tiny_multiview.yaml"
SHARE = 0.5  # on the fixture's 64 QA this holds out location and placement questions


@pytest.fixture(scope="module")
def dataset(tmp_path_factory, catalogue):
    out = tmp_path_factory.getbasetemp() / "export-multiview"  # shared with test_export.py
    generate(out, load_recipe(str(MULTIVIEW)), catalogue, n_scenes=4, base_seed=5, workers=1, scenes_per_shard=2)
    return out


def _qas(root: Path) -> list[dict]:
    ds = RefSpatialDataset(root, fields=())
    return [qa for i in range(len(ds)) for qa in ds[i]["qa"]]


# --- roborefer: registration, multi-view folders, depth encodings ---------------------------


@dataclass
class Dataset:  # the fields of RoboRefer's llava/data/datasets_mixture.py Dataset that we use
    dataset_name: str
    dataset_type: str = "torch"
    data_path: str | None = None
    image_path: str | None = None
    depth_path: str | None = None
    meta: dict = field(default_factory=dict)


@pytest.fixture(scope="module")
def roborefer(dataset, tmp_path_factory):
    out = tmp_path_factory.mktemp("rr") / "out"
    export("roborefer", dataset, out, unseen_share=SHARE, depth_encoding="inverse")
    return out


def test_registration_is_python_that_registers_every_subset(roborefer):
    source = (roborefer / "roborefer_mixture.py").read_text()
    tree = ast.parse(source)  # valid Python
    registered: dict[str, Dataset] = {}

    def add_dataset(d: Dataset) -> None:  # RoboRefer's rules: unique names without '+'
        assert "+" not in d.dataset_name and d.dataset_name not in registered
        registered[d.dataset_name] = d

    namespace = {"Dataset": Dataset, "add_dataset": add_dataset}
    exec(compile(tree, "roborefer_mixture.py", "exec"), namespace)
    register = [v for k, v in namespace.items() if k.startswith("register_refspatial_")]
    mixture = [v for k, v in namespace.items() if k.endswith("_MIXTURE")]
    assert len(register) == len(mixture) == 1
    register[0](str(roborefer))
    assert mixture[0].split("+") == list(registered)
    subsets = {p.stem for p in roborefer.glob("*_qa.json")}
    assert {n.removesuffix("_RGB") for n in registered} == {f"refspatial_tiny_multiview_{s}" for s in subsets}
    for name, d in registered.items():
        assert name.isidentifier() and d.dataset_type == "spatialdataset"
        assert (d.depth_path is None) == name.endswith("_RGB")
        for row in json.loads(Path(d.data_path).read_text()):
            images = row["image"] if isinstance(row["image"], list) else [row["image"]]
            depths = row["depth"] if isinstance(row["depth"], list) else [row["depth"]]
            assert all((Path(d.image_path) / i).is_file() for i in images)
            if d.depth_path:
                assert all((Path(d.depth_path) / i).is_file() for i in depths)
    multi = registered.get("refspatial_tiny_multiview_multi_view_qa")
    assert multi and multi.image_path.endswith("/image_multi_view") and multi.depth_path.endswith("/depth_multi_view")


def test_inverse_depth_is_normalised_inverse_depth_near_bright():
    depth = np.array([[1.0, 2.0], [4.0, 100.0]], dtype=np.float32)  # 100 m = sky
    png = depth_to_png8(depth, "inverse")[..., 0]
    # 1/d = 1, 0.5, 0.25 -> (1/d - 0.25) / 0.75 * 255, truncated as RoboRefer's API does
    assert png.tolist() == [[255, 85], [0, 0]]
    assert depth_to_png8(depth, "linear")[..., 0].tolist() == [[255, 170], [0, 0]]
    with pytest.raises(ExportError, match="linear, inverse"):
        depth_to_png8(depth, "log")


def test_roborefer_depth_pngs_follow_the_chosen_encoding(roborefer, dataset):
    ds = RefSpatialDataset(dataset, fields=("depth",))
    for i in range(len(ds)):
        s = ds[i]
        png = cv2.imread(str(roborefer / "depth" / f"{s['key'].replace('/', '_')}_depth.png"))[..., 0]
        assert np.array_equal(png, depth_to_png8(s["depth_m"], "inverse")[..., 0])
        valid = valid_depth(s["depth_m"])
        order = np.argsort(s["depth_m"][valid])
        assert np.all(np.diff(png[valid][order].astype(int)) <= 0)  # nearer is never darker
    with pytest.raises(ExportError, match="--depth-encoding"):
        export("roborefer", dataset, roborefer.parent / "x", depth_encoding="metric")


# --- the Unseen split ------------------------------------------------------------------------


def test_hold_out_is_a_fixed_function_of_the_combination():
    qa = {"predicates": ["near", "left_of", "near"]}
    assert combination(qa) == ("left_of", "near") and combination({"predicates": ["near"]}) is None
    f = combination_fraction(("left_of", "near"))
    assert 0 <= f < 1 and f == combination_fraction(("left_of", "near"))
    assert HoldOut(min(f + 1e-9, 0.999)).held_out(qa) and not HoldOut(f).held_out(qa)
    assert not HoldOut(0.0).held_out(qa)
    with pytest.raises(ExportError, match="--unseen-share"):
        HoldOut(1.0)


def test_training_subsets_never_join_held_out_predicates(roborefer, dataset):
    hold = HoldOut(SHARE)
    by_id = {qa["qa_id"]: qa for qa in _qas(dataset)}
    kept = [t["qa_id"] for traces in json.loads((roborefer / "reasoning_metadata.json").read_text()).values()
            for t in traces]
    held = [q for q in by_id.values() if hold.held_out(q)]
    assert held and len(kept) + len(held) == len(by_id)
    assert not any(hold.held_out(by_id[k]) for k in kept)
    summary = json.loads((roborefer / "export.json").read_text())
    assert summary["counts"]["held-out QA"] == len(held) and summary["options"]["unseen_share"] == SHARE
    unseen = json.loads((roborefer / "bench" / "Unseen" / "question.json").read_text())
    trained = {p for k in kept for p in by_id[k]["predicates"]}
    assert unseen
    for q in unseen:
        qa = by_id[q["qa_id"]]
        assert hold.held_out(qa) and set(qa["predicates"]) <= trained and qa["kind"] == "point"
        assert (roborefer / "bench" / "Unseen" / q["mask_path"]).is_file()


def test_bench_splits_partition_the_point_questions(dataset, tmp_path):
    summary = export("bench", dataset, tmp_path / "b", unseen_share=SHARE)
    hold, splits = HoldOut(SHARE), {}
    for split in ("Location", "Placement", "Unseen"):
        splits[split] = [q["qa_id"] for q in json.loads((tmp_path / "b" / split / "question.json").read_text())]
        assert summary.counts[split] == len(splits[split])
    by_id = {qa["qa_id"]: qa for qa in _qas(dataset)}
    assert not any(hold.held_out(by_id[i]) for i in splits["Location"] + splits["Placement"])
    assert all(hold.held_out(by_id[i]) for i in splits["Unseen"])
    plain = export("bench", dataset, tmp_path / "plain")
    assert "Unseen" not in plain.counts
    every = {q["qa_id"] for split in ("Location", "Placement")
             for q in json.loads((tmp_path / "plain" / split / "question.json").read_text())}
    split_up = set(splits["Location"] + splits["Placement"] + splits["Unseen"])
    dropped = every - split_up  # held out, but with a predicate no training QA has
    assert split_up <= every and len(dropped) == summary.counts.get("Unseen skipped (a predicate never trained)", 0)
    trained = HoldOut(SHARE).trained_predicates(by_id.values())
    assert all(hold.held_out(by_id[i]) and not set(by_id[i]["predicates"]) <= trained for i in dropped)
    with pytest.raises(ExportError, match="--unseen-share"):
        export("bench", dataset, tmp_path / "bad", unseen_share=1.5)
    assert not (tmp_path / "bad").exists()


def test_bench_parquet_loads_as_refspatial_bench(dataset, tmp_path):
    datasets = pytest.importorskip("datasets")
    out = tmp_path / "b"
    export("bench", dataset, out, unseen_share=SHARE)
    bench = datasets.load_dataset(str(out), cache_dir=str(tmp_path / "cache"))
    assert set(bench) == {"location", "placement", "unseen"}
    for split, folder in (("location", "Location"), ("placement", "Placement"), ("unseen", "Unseen")):
        rows, questions = bench[split], json.loads((out / folder / "question.json").read_text())
        assert rows.column_names == ["id", "image", "mask", "object", "prompt", "suffix", "step"]
        assert isinstance(rows.features["image"], datasets.Image) and isinstance(rows.features["mask"], datasets.Image)
        assert len(rows) == len(questions)
        for row, q in zip(rows, questions):
            assert (row["id"], row["object"], row["prompt"], row["suffix"], row["step"]) == (
                q["id"], q["object"], q["prompt"], q["suffix"], q["step"])
            mask = cv2.imread(str(out / folder / q["mask_path"]), cv2.IMREAD_UNCHANGED)
            assert np.array_equal(np.asarray(row["mask"]), mask)
    card = (out / "README.md").read_text()
    assert "license: apache-2.0" in card and "| `suffix` |" in card


# --- parquet: card and collate ---------------------------------------------------------------


def test_licence_of_the_card():
    assert licence({PROCEDURAL})[0] == "apache-2.0"
    tag, text = licence({PROCEDURAL, "CC-BY-4.0"})
    assert tag == "other" and "CC-BY-4.0" in text


def test_parquet_card_and_qa_batches_through_a_torch_dataloader(dataset, tmp_path):
    datasets = pytest.importorskip("datasets")
    torch = pytest.importorskip("torch")
    from refspatial.export.parquet import collate

    out = tmp_path / "pq"
    export("parquet", dataset, out)
    card = (out / "README.md").read_text()
    assert "license: apache-2.0" in card and "Apache-2.0" in card
    for column in ("key", "image", "depth", "K", "T_world_cam", "qa", "scene", "relations"):
        assert f"`{column}`" in card
    files = [str(p) for p in sorted((out / "data").glob("*.parquet"))]
    ds = datasets.load_dataset("parquet", data_files=files, split="train", cache_dir=str(tmp_path / "cache"))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        with pytest.raises(RuntimeError, match="equal size"):  # what the collate is for: ragged qa
            next(iter(torch.utils.data.DataLoader(ds.select_columns(["qa"]), batch_size=3)))
    loader = torch.utils.data.DataLoader(ds, batch_size=3, collate_fn=collate)
    records = {s["key"]: s for s in (RefSpatialDataset(dataset, fields=("rgb",))[i] for i in range(len(ds)))}
    seen = 0
    for batch in loader:
        assert batch["image"].dtype == torch.uint8 and batch["image"].shape[1:] == (108, 192, 3)
        assert batch["K"].shape[1:] == (3, 3) and batch["T_world_cam"].dtype == torch.float64
        for key, qa, image in zip(batch["key"], batch["qa"], batch["image"]):
            assert qa == records[key]["qa"] and np.array_equal(image.numpy(), records[key]["rgb"])
            seen += 1
    assert seen == len(records)
