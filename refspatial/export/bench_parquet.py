"""The benchmark as Hugging Face Parquet, laid out as RefSpatial-Bench publishes it.

``data/<split>-00000-of-00001.parquet`` per split (``location``, ``placement``, ``unseen``),
columns ``id``, ``image``, ``mask`` (PNG structs that ``datasets`` decodes as PIL images),
``object``, ``prompt``, ``suffix``, ``step``; README.md declares the splits, so
``datasets.load_dataset(OUT)`` gives them by name. The rows are read back from the split
folders already staged, so the Parquet holds exactly the bytes the folders do.
"""

from __future__ import annotations

import json
from pathlib import Path

from .cards import BENCH, licence, yaml_splits
from .common import ExportError

try:
    import pyarrow as pa
    import pyarrow.parquet as pq
except ImportError:  # pragma: no cover - depends on the environment
    pa = pq = None

COLUMNS = ("id", "image", "mask", "object", "prompt", "suffix", "step")


def write_bench_parquet(root: Path, manifest: dict, licences: set[str], unseen_share: float = 0.0) -> list[str]:
    """One Parquet file per split folder under ``root``; the split names written."""
    if pa is None:
        raise ExportError("the bench export writes Parquet and needs pyarrow; pip install 'pyarrow>=15'")
    from .parquet import hf_schema

    image = pa.struct([("bytes", pa.binary()), ("path", pa.string())])
    schema = hf_schema([("id", pa.int64()), ("image", image), ("mask", image), ("object", pa.string()),
                        ("prompt", pa.string()), ("suffix", pa.string()), ("step", pa.int64())], ("image", "mask"))
    splits = []
    for folder in sorted(p for p in root.iterdir() if (p / "question.json").is_file()):
        rows = [_row(folder, q) for q in json.loads((folder / "question.json").read_text(encoding="utf-8"))]
        split = folder.name.lower()
        (root / "data").mkdir(exist_ok=True)
        pq.write_table(pa.Table.from_pylist(rows, schema=schema), root / "data" / f"{split}-00000-of-00001.parquet",
                       compression="zstd")
        splits.append(split)
    if splits:
        (root / "README.md").write_text(_card(manifest, splits, licences, unseen_share), encoding="utf-8")
    return splits


def _row(folder: Path, q: dict) -> dict:
    def png(rel: str) -> dict:
        return {"bytes": (folder / rel).read_bytes(), "path": rel.replace("/", "_")}

    return {"id": q["id"], "image": png(q["rgb_path"]), "mask": png(q["mask_path"]), "object": q["object"],
            "prompt": q["prompt"], "suffix": q["suffix"], "step": q["step"]}


def _card(manifest: dict, splits: list[str], licences: set[str], unseen_share: float) -> str:
    tag, text = licence(licences)
    return BENCH.format(tag=tag, licence=text, splits=yaml_splits({s: f"data/{s}-*" for s in splits}),
                        recipe=manifest["recipe"], recipe_hash=manifest["recipe_hash"], unseen_share=unseen_share)
