"""The loader trainers import: a dataset folder of MCAP shards as a stream of sample dicts.

The unit of splitting is the record, not the shard: the global list of (shard, index) pairs,
in manifest order, is optionally shuffled with ``default_rng(seed + epoch)``, evened out to a
multiple of the world size (as torch's ``DistributedSampler`` does: the first records repeated
at the end, or with ``drop_last`` the last few dropped) and then cut into contiguous blocks,
first by rank and then by DataLoader worker. Every rank gets the same number of samples, so no
rank waits at a collective for another that has run out; every process computes the same list,
so the blocks never overlap beyond that padding and never miss a record (without
``drop_last``), however uneven the shards are. Works without torch; with torch the class is an
``IterableDataset`` and ``collate`` returns tensors.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any, Iterator, Sequence

import numpy as np

from refspatial.records import FIELDS, ShardError, ShardReader, sha256_file

try:  # optional: with torch, DataLoader treats the dataset as iterable and splits by worker
    import torch as _torch
    from torch.utils.data import IterableDataset as _Base
    from torch.utils.data import get_worker_info as _get_worker_info
except ImportError:
    _torch = None  # type: ignore[assignment]
    _Base = object  # type: ignore[assignment,misc]
    _get_worker_info = None

MANIFEST = "manifest.json"
FORMAT = "refspatial-shards"
FORMAT_VERSION = 1


@dataclass(frozen=True)
class ShardEntry:
    """One shard as the manifest lists it."""

    path: Path  # absolute: root / file
    records: int
    sha256: str | None


class RefSpatialDataset(_Base):  # type: ignore[misc,valid-type]
    """Sample dicts (see ``ShardReader.read``) plus ``objects`` = ``scene["objects"]``.

    ``__len__`` and ``__getitem__`` cover this rank's records in manifest order; iteration
    covers the same number of records, shuffled when asked, and split further by DataLoader
    worker. Every rank holds ``ceil(records / world_size)`` samples, the first records of the
    (shuffled) list served twice to fill the last ranks, or with ``drop_last``
    ``floor(records / world_size)``, the last records of the list left out (a different few
    each epoch when shuffled). Call ``set_epoch`` before each epoch (with non-persistent
    workers, which re-read it).
    """

    def __init__(
        self,
        root: Path | str,
        fields: Sequence[str] = FIELDS,
        shuffle: bool = False,
        seed: int = 0,
        rank: int = 0,
        world_size: int = 1,
        verify: bool = False,
        drop_last: bool = False,
    ) -> None:
        if isinstance(fields, str) or not set(fields) <= set(FIELDS):
            raise ValueError(f"fields must be a subset of {FIELDS}; got {fields!r}")
        if not (isinstance(world_size, int) and world_size >= 1 and 0 <= rank < world_size):
            raise ValueError(f"need 0 <= rank < world_size; got {rank=}, {world_size=}")
        self.root = Path(root)
        self.fields = tuple(fields)
        self.shuffle, self.seed, self.epoch = shuffle, seed, 0
        self.rank, self.world_size, self.drop_last = rank, world_size, drop_last
        self.shards = load_manifest(self.root, verify=verify)
        counts = np.array([s.records for s in self.shards], dtype=np.int64)
        # Global record list: row j = (shard number, index in shard), in manifest order.
        shard = np.repeat(np.arange(len(counts), dtype=np.int64), counts)
        index = np.arange(len(shard), dtype=np.int64) - (np.cumsum(counts) - counts)[shard]
        self._pairs = np.stack([shard, index], axis=1)
        if world_size > len(self._pairs):
            raise ValueError(f"world_size {world_size} is larger than the {len(self._pairs)} records in "
                             f"{self.root}; use at most {len(self._pairs)} ranks or generate more scenes")
        self._readers: dict[int, ShardReader] = {}

    def set_epoch(self, epoch: int) -> None:
        """Changes the shuffled order; every rank and worker must use the same epoch."""
        self.epoch = epoch

    def __len__(self) -> int:
        return self._per_rank()

    def __getitem__(self, i: int) -> dict:
        """The i-th record of this rank's unshuffled list."""
        mine = self._rank_block(np.arange(len(self._pairs)))
        if not 0 <= i < len(mine):
            raise IndexError(f"index {i} out of range; rank {self.rank} holds {len(mine)} records")
        return self._sample(int(mine[i]))

    def __iter__(self) -> Iterator[dict]:
        worker, n_workers = _worker()
        mine = _block(self._rank_block(self._order()), worker, n_workers)
        for j in mine:
            yield self._sample(int(j))

    def _per_rank(self) -> int:
        n, w = len(self._pairs), self.world_size
        return n // w if self.drop_last else -(-n // w)

    def _rank_block(self, order: np.ndarray) -> np.ndarray:
        """This rank's contiguous block of ``order`` evened out to ``world_size`` equal blocks."""
        per_rank = self._per_rank()
        total = per_rank * self.world_size
        evened = np.resize(order, total)  # repeats from the start when total > len(order)
        return evened[self.rank * per_rank : (self.rank + 1) * per_rank]

    def _order(self) -> np.ndarray:
        """Positions into the global list; identical in every process for (seed, epoch)."""
        n = len(self._pairs)
        if not self.shuffle:
            return np.arange(n)
        return np.random.default_rng(self.seed + self.epoch).permutation(n)

    def _sample(self, j: int) -> dict:
        shard, index = (int(v) for v in self._pairs[j])
        sample = self._reader(shard).read(index, self.fields)
        sample["objects"] = sample["scene"].get("objects", [])
        return sample

    def _reader(self, shard: int) -> ShardReader:
        """Readers are opened lazily, so each worker opens its own after the fork."""
        if shard not in self._readers:
            entry = self.shards[shard]
            reader = ShardReader(entry.path)
            if len(reader) != entry.records:
                raise ValueError(f"{self.root / MANIFEST}: lists {entry.records} records for "
                                 f"{entry.path} but the shard holds {len(reader)}; rebuild the "
                                 "manifest or regenerate the shard")
            self._readers[shard] = reader
        return self._readers[shard]


def _block(a: np.ndarray, k: int, n: int) -> np.ndarray:
    """Block k of n contiguous near-equal blocks (sizes differ by at most one)."""
    return a[len(a) * k // n : len(a) * (k + 1) // n]


def _worker() -> tuple[int, int]:
    info = _get_worker_info() if _get_worker_info is not None else None
    return (0, 1) if info is None else (info.id, info.num_workers)


def load_manifest(root: Path | str, verify: bool = False) -> tuple[ShardEntry, ...]:
    """Shard entries of ``root/manifest.json``; checks that each file exists and, with
    ``verify``, that its sha256 matches (reads every byte)."""
    from refspatial.manifest import read_manifest

    path = Path(root) / MANIFEST
    # Missing: FileNotFoundError; damaged: a ValueError saying how to rebuild it. The loader
    # needs only each shard's file and record count.
    manifest = read_manifest(root, fields=("shards",), shard_fields=("file", "records"))
    entries = tuple(_entry(path, i, s) for i, s in enumerate(manifest.get("shards", [])))
    for e in entries:
        if not e.path.is_file():
            raise FileNotFoundError(f"{path} lists {e.path} but it does not exist; regenerate "
                                    "the missing shard (refspatial generate skips complete ones)")
        if verify:
            _verify_sha(path, e)
    return entries


def _entry(manifest: Path, i: int, shard: Any) -> ShardEntry:
    try:
        records = int(shard["records"])
        return ShardEntry(manifest.parent / shard["file"], records, shard.get("sha256"))
    except (KeyError, TypeError, ValueError):
        raise ValueError(f"{manifest}: shards[{i}] needs 'file' (str) and 'records' (int); "
                         f"got {shard!r}") from None


def _verify_sha(manifest: Path, e: ShardEntry) -> None:
    if not e.sha256:
        raise ValueError(f"{manifest}: no sha256 for {e.path}; pass verify=False or rebuild "
                         "the manifest")
    got = sha256_file(e.path)
    if got != e.sha256:
        raise ShardError(f"{e.path}: sha256 {got[:16]}... differs from {manifest}'s "
                         f"{e.sha256[:16]}...; the file changed after the manifest was written, "
                         "regenerate the shard or rebuild the manifest")


def collate(samples: list[dict]) -> dict:
    """Batch sample dicts: arrays (numpy or torch) are stacked into one torch tensor when torch
    is installed (dtypes kept: rgb uint8, depth_m float32, seg int32, K and T_world_cam float64),
    else into one numpy array; everything else (keys, qa, objects, relations, answer points ...)
    stays a list, one item per sample."""
    if not samples:
        raise ValueError("collate needs at least one sample")
    keys = list(samples[0])
    for s in samples[1:]:
        if list(s) != keys:
            raise ValueError(f"samples have different keys: {keys} vs {list(s)}; "
                             "read them with the same fields")
    return {k: _stack(k, [s[k] for s in samples]) for k in keys}


def _stack(name: str, values: list) -> Any:
    first = values[0]
    is_torch = type(first).__module__.startswith("torch")
    if not (isinstance(first, np.ndarray) or is_torch):
        return values
    shapes = {tuple(v.shape) for v in values}
    if len(shapes) > 1:
        raise ValueError(f"cannot stack {name!r}: shapes {sorted(shapes)} differ; resize in a "
                         "transform or batch views of one resolution together")
    if is_torch:
        return _torch.stack(values)
    stacked = np.stack(values)
    return stacked if _torch is None else _torch.from_numpy(stacked)
