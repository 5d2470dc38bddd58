"""Tests for refspatial.data: splitting by rank and worker, shuffling, collate and errors."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

import refspatial.data as data
from refspatial.data import RefSpatialDataset, collate
from refspatial.records import Record, ShardError, ShardWriter, sha256_file

SIZES = (5, 1, 0, 4, 2)  # uneven on purpose, one empty shard


def make_record(shard: int, i: int) -> Record:
    rng = np.random.default_rng([shard, i])
    h, w = 12, 16
    return Record(
        key=f"tabletop-1a2b3c4d-{shard}-{i}/view0",
        scene={"seed": i, "objects": [{"id": k, "name": "cup"} for k in range(1 + i % 3)]},
        rgb=rng.integers(0, 256, (h, w, 3), dtype=np.uint8),
        depth_m=rng.random((h, w), dtype=np.float32),
        seg=rng.integers(-1, 3, (h, w)).astype(np.int32),
        K=np.array([[20.0, 0, 8], [0, 20.0, 6], [0, 0, 1]]),
        T_world_cam=np.eye(4),
        relations=[],
        qa=[{"question": "Point to the cup.", "answer_px": [[1.0, 2.0]] * (1 + i % 2)}],
    )


def make_dataset(root: Path, sizes: tuple[int, ...] = SIZES) -> list[str]:
    """Shards plus a manifest in the format the shards module writes; returns all keys in order."""
    shards, keys = [], []
    for s, n in enumerate(sizes):
        file = f"shards/shard-{s:05d}.mcap"
        recs = [make_record(s, i) for i in range(n)]
        with ShardWriter(root / file, {"refspatial": {"version": "test"}}) as w:
            for r in recs:
                w.write(r)
        keys += [r.key for r in recs]
        shards.append({"file": file, "records": n, "qa": n, "sha256": sha256_file(root / file),
                       "scenes": [10 * s, 10 * s + 10]})
    manifest = {"format": "refspatial-shards", "format_version": 1, "shards": shards,
                "records": len(keys)}
    (root / "manifest.json").write_text(json.dumps(manifest))
    return keys


@pytest.fixture(scope="module")
def dataset(tmp_path_factory) -> tuple[Path, list[str]]:
    root = tmp_path_factory.mktemp("ds")
    return root, make_dataset(root)


def test_iterates_every_record_in_manifest_order(dataset):
    root, keys = dataset
    ds = RefSpatialDataset(root)
    samples = list(ds)
    assert len(ds) == len(keys) and [s["key"] for s in samples] == keys
    s = samples[0]
    assert s["objects"] == s["scene"]["objects"] and s["shard"] == "shard-00000.mcap"
    assert s["rgb"].dtype == np.uint8 and s["depth_m"].dtype == np.float32
    assert s["seg"].dtype == np.int32 and s["K"].shape == (3, 3)
    assert [ds[i]["key"] for i in range(len(ds))] == keys


def _split_keys(root: Path, world_size: int, workers: int = 1, **kw) -> list[list[str]]:
    """Keys seen by each (rank, worker), simulating DataLoader workers without torch."""
    parts = []
    for rank in range(world_size):
        ds = RefSpatialDataset(root, fields=(), rank=rank, world_size=world_size, **kw)
        for worker in range(workers):
            info = SimpleNamespace(id=worker, num_workers=workers)
            with pytest.MonkeyPatch.context() as mp:
                mp.setattr(data, "_get_worker_info", lambda: info)
                parts.append([s["key"] for s in ds])
        assert sum(len(p) for p in parts[-workers:]) == len(ds)
    return parts


@pytest.mark.parametrize("world_size", [1, 2, 3, 5, 7, 12])
@pytest.mark.parametrize("workers", [1, 2, 3])
@pytest.mark.parametrize("shuffle", [False, True])
def test_ranks_and_workers_cover_the_records(dataset, world_size, workers, shuffle):
    """Every rank gets ceil(n / world_size) samples: all records, the first few twice."""
    root, keys = dataset
    parts = _split_keys(root, world_size, workers, shuffle=shuffle, seed=3)
    per_rank = [sum(map(len, parts[r * workers : (r + 1) * workers])) for r in range(world_size)]
    assert per_rank == [-(-len(keys) // world_size)] * world_size
    seen = [k for p in parts for k in p]
    assert set(seen) == set(keys)  # nothing lost
    assert len(seen) - len(set(seen)) == sum(per_rank) - len(keys)  # only the padding twice
    assert max(map(len, parts)) - min(map(len, parts)) <= 1


@pytest.mark.parametrize("world_size", [1, 5, 7, 12])
@pytest.mark.parametrize("shuffle", [False, True])
def test_drop_last_leaves_out_the_remainder(dataset, world_size, shuffle):
    root, keys = dataset
    parts = _split_keys(root, world_size, 2, shuffle=shuffle, seed=3, drop_last=True)
    per_rank = [len(parts[2 * r]) + len(parts[2 * r + 1]) for r in range(world_size)]
    assert per_rank == [len(keys) // world_size] * world_size
    seen = [k for p in parts for k in p]
    assert len(seen) == len(set(seen)) and set(seen) <= set(keys)


def test_ranks_yield_equal_batch_counts_in_a_dataloader(dataset):
    """Equal batch counts are what keeps distributed training from hanging at the last step."""
    pytest.importorskip("torch")
    from torch.utils.data import DataLoader

    root, _ = dataset
    for drop_last in (False, True):
        batches = []
        for rank in range(5):  # 12 records over 5 ranks: 3 each (padded) or 2 each (dropped)
            ds = RefSpatialDataset(root, fields=(), rank=rank, world_size=5, drop_last=drop_last)
            batches.append(len(list(DataLoader(ds, batch_size=2, collate_fn=collate))))
        assert len(set(batches)) == 1, (drop_last, batches)


def test_world_size_larger_than_the_dataset_is_an_error(dataset):
    root, keys = dataset
    with pytest.raises(ValueError, match=rf"world_size 13 is larger than the {len(keys)} records in .*; "
                                         rf"use at most {len(keys)} ranks"):
        RefSpatialDataset(root, rank=0, world_size=13)


def test_getitem_is_this_ranks_unshuffled_list(dataset):
    root, keys = dataset
    for rank in range(3):
        plain = RefSpatialDataset(root, fields=(), rank=rank, world_size=3)
        shuffled = RefSpatialDataset(root, fields=(), rank=rank, world_size=3, shuffle=True)
        expected = [s["key"] for s in plain]
        assert [shuffled[i]["key"] for i in range(len(shuffled))] == expected
    with pytest.raises(IndexError, match="rank 2 holds"):
        plain[len(plain)]


def test_shuffle_is_deterministic_per_seed_and_epoch(dataset):
    root, keys = dataset

    def order(seed: int, epoch: int) -> list[str]:
        ds = RefSpatialDataset(root, fields=(), shuffle=True, seed=seed)
        ds.set_epoch(epoch)
        return [s["key"] for s in ds]

    assert order(0, 0) == order(0, 0) and order(5, 2) == order(5, 2)
    assert order(0, 0) != order(0, 1) and order(0, 1) != order(0, 2)
    assert order(0, 0) != order(1, 0) and sorted(order(0, 3)) == sorted(keys)


def test_fields_selection(dataset):
    root, _ = dataset
    sample = next(iter(RefSpatialDataset(root, fields=("depth",))))
    assert "depth_m" in sample and "rgb" not in sample and "seg" not in sample
    with pytest.raises(ValueError, match="fields must be a subset"):
        RefSpatialDataset(root, fields=("depth_m",))
    with pytest.raises(ValueError, match="rank < world_size"):
        RefSpatialDataset(root, rank=2, world_size=2)


def test_collate_stacks_arrays_into_tensors_and_lists_the_rest(dataset):
    torch = pytest.importorskip("torch")
    root, _ = dataset
    samples = list(RefSpatialDataset(root))[:4]
    batch = collate(samples)
    assert all(isinstance(batch[k], torch.Tensor) for k in ("rgb", "depth_m", "seg", "K", "T_world_cam"))
    assert batch["rgb"].shape == (4, 12, 16, 3) and batch["rgb"].dtype == torch.uint8
    assert batch["depth_m"].shape == (4, 12, 16) and batch["depth_m"].dtype == torch.float32
    assert batch["seg"].shape == (4, 12, 16) and batch["seg"].dtype == torch.int32
    assert batch["K"].shape == (4, 3, 3) and batch["T_world_cam"].shape == (4, 4, 4)
    assert np.array_equal(batch["rgb"][2].numpy(), samples[2]["rgb"])
    assert batch["qa"] == [s["qa"] for s in samples] and len(batch["objects"]) == 4
    assert batch["key"] == [s["key"] for s in samples]
    odd = dict(samples[1], rgb=np.zeros((2, 2, 3), np.uint8))
    with pytest.raises(ValueError, match="cannot stack 'rgb'"):
        collate([samples[0], odd])
    with pytest.raises(ValueError, match="at least one"):
        collate([])


def test_missing_manifest(tmp_path):
    with pytest.raises(FileNotFoundError, match=rf"{tmp_path / 'manifest.json'} not found"):
        RefSpatialDataset(tmp_path)


def test_manifest_errors(tmp_path):
    make_dataset(tmp_path, (2, 3))
    manifest_path = tmp_path / "manifest.json"
    manifest = json.loads(manifest_path.read_text())
    manifest_path.write_text(json.dumps({**manifest, "format_version": 2}))
    with pytest.raises(ValueError, match="format_version"):
        RefSpatialDataset(tmp_path)
    wrong_count = {**manifest, "shards": [dict(manifest["shards"][0], records=3), manifest["shards"][1]]}
    manifest_path.write_text(json.dumps(wrong_count))
    ds = RefSpatialDataset(tmp_path)  # counts are checked when a shard is opened
    with pytest.raises(ValueError, match="lists 3 records for .*shard-00000.mcap but the shard holds 2"):
        list(ds)
    manifest_path.write_text(json.dumps(manifest))
    (tmp_path / "shards" / "shard-00001.mcap").unlink()
    with pytest.raises(FileNotFoundError, match="shard-00001.mcap but it does not exist"):
        RefSpatialDataset(tmp_path)


def test_sha_mismatch_only_checked_with_verify(tmp_path):
    make_dataset(tmp_path, (2, 3))
    shard = tmp_path / "shards" / "shard-00001.mcap"
    raw = bytearray(shard.read_bytes())
    raw[len(raw) // 2] ^= 0xFF
    shard.write_bytes(bytes(raw))
    RefSpatialDataset(tmp_path)
    with pytest.raises(ShardError, match="shard-00001.mcap: sha256 .* differs from"):
        RefSpatialDataset(tmp_path, verify=True)


def test_imports_and_iterates_without_torch(dataset):
    """Hide torch in a fresh interpreter: the module still imports and the dataset is plain."""
    root, keys = dataset
    code = ("import sys; sys.modules['torch'] = None\n"
            "import refspatial.data as d\n"
            "assert d._Base is object\n"
            f"samples = list(d.RefSpatialDataset({str(root)!r}, fields=('rgb',)))\n"
            "batch = d.collate(samples[:3])\n"
            "assert type(batch['rgb']).__name__ == 'ndarray' and batch['rgb'].shape[0] == 3\n"
            "print(len(samples))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         cwd=Path(__file__).parents[1], check=True)
    assert out.stdout.strip() == str(len(keys))


def test_torch_dataloader_workers(dataset):
    torch = pytest.importorskip("torch")
    from torch.utils.data import DataLoader, IterableDataset

    root, keys = dataset
    seen = []
    for rank in range(2):
        ds = RefSpatialDataset(root, rank=rank, world_size=2, shuffle=True, seed=1)
        assert isinstance(ds, IterableDataset)
        ds.set_epoch(4)
        got = [s["key"] for s in DataLoader(ds, batch_size=None, num_workers=2)]
        assert len(got) == len(ds)
        seen += got
    assert sorted(seen) == sorted(keys)
    loader = DataLoader(RefSpatialDataset(root), batch_size=4, num_workers=2, collate_fn=collate)
    batches = list(loader)
    assert sum(len(b["key"]) for b in batches) == len(keys)
    assert batches[0]["rgb"].shape == (4, 12, 16, 3) and isinstance(batches[0]["rgb"], torch.Tensor)
    tensors = [{"rgb": torch.zeros(2, 3), "qa": []}, {"rgb": torch.ones(2, 3), "qa": [1]}]
    assert collate(tensors)["rgb"].shape == (2, 2, 3)
