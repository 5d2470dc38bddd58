"""Hugging Face ``datasets``-ready Parquet: one row per record, its QA as a nested list.

Why a row per record and not per QA: a record carries 6-10 QA about one image, and the
image bytes dominate the size (a 960x540 PNG is ~130 kB, a QA ~1 kB); a row per QA would
store each image that many times. ``ds.map(..., batched=True)`` or pandas ``explode`` turn
the rows into one sample per QA where a trainer wants that.

Images are ``{"bytes": png, "path": name}`` structs, and the Arrow schema carries the
``huggingface`` features metadata, so ``datasets.load_dataset("parquet", data_files=...)``
decodes ``image`` and ``depth`` as PIL images; README.md (the dataset card: licence and
every column, ``cards``) declares the files as the train split, so ``load_dataset(OUT)``
works too. Only pyarrow is needed to write. ``collate`` batches rows in a torch DataLoader.
"""

from __future__ import annotations

import itertools
import json
from pathlib import Path
from typing import Any

import numpy as np

from .cards import RECORDS, licence, yaml_splits
from .common import (
    ExportError,
    ExportSummary,
    depth_to_png8,
    file_stem,
    finish,
    open_dataset,
    png_bytes,
    samples,
    staged,
)

try:
    import pyarrow as pa
    import pyarrow.parquet as pq
except ImportError:  # pragma: no cover - depends on the environment
    pa = pq = None

ROW_GROUP = 100  # rows; small groups let `datasets` stream image data without huge reads
def _schema() -> pa.Schema:
    image = pa.struct([("bytes", pa.binary()), ("path", pa.string())])
    matrix = pa.list_(pa.list_(pa.float64()))
    qa = pa.struct([
        ("qa_id", pa.string()), ("family", pa.string()), ("kind", pa.string()), ("prompt", pa.string()),
        ("question", pa.string()), ("answer", pa.string()), ("answer_points", matrix),
        ("target_id", pa.int64()), ("ref", pa.string()), ("num_steps", pa.int64()),
        ("predicates", pa.list_(pa.string())), ("reasoning", pa.string()), ("images", pa.list_(pa.string())),
        ("json", pa.string()),
    ])
    fields = [("key", pa.string()), ("scene_id", pa.string()), ("view", pa.string()),
              ("view_index", pa.int64()), ("width", pa.int64()), ("height", pa.int64()),
              ("image", image), ("depth", image), ("K", matrix), ("T_world_cam", matrix),
              ("scene", pa.string()), ("relations", pa.string()), ("qa", pa.list_(qa))]
    return hf_schema(fields, ("image", "depth"))


def hf_schema(fields: list[tuple[str, pa.DataType]], images: tuple[str, ...]) -> pa.Schema:
    """An Arrow schema with the ``huggingface`` features metadata, so ``datasets`` decodes
    the ``images`` columns (``{"bytes", "path"}`` structs) as PIL images."""
    schema = pa.schema(fields)
    features = {f.name: _feature(f.type) for f in schema}
    features.update({name: {"_type": "Image"} for name in images})
    meta = {"huggingface": json.dumps({"info": {"features": features}}, sort_keys=True)}
    return schema.with_metadata(meta)


_VALUES = {"string": "string", "int64": "int64", "double": "float64", "float": "float32",
           "bool": "bool", "binary": "binary"}


def _feature(t: pa.DataType) -> object:
    """The ``datasets`` feature dict of an Arrow type (list literals: read by datasets 3 and 4)."""
    if pa.types.is_struct(t):
        return {t.field(i).name: _feature(t.field(i).type) for i in range(t.num_fields)}
    if pa.types.is_list(t):
        return [_feature(t.value_type)]
    return {"_type": "Value", "dtype": _VALUES[str(t)]}


def export_parquet(dataset_dir: Path, out_dir: Path, *, overwrite: bool = False) -> ExportSummary:
    """One Parquet file per source shard under data/, plus README.md and export.json."""
    if pa is None:
        raise ExportError("the parquet export needs pyarrow; pip install 'pyarrow>=15'")
    dataset = open_dataset(dataset_dir, ("rgb", "depth"))
    schema, n_files = _schema(), len(dataset.shards)
    records = qa = 0
    licences: set[str] = set()
    with staged(out_dir, overwrite) as tmp:
        (tmp / "data").mkdir()
        groups = itertools.groupby(samples(dataset), key=lambda s: s["shard"])
        for i, (_, group) in enumerate(groups):
            group = list(group)
            licences |= {o["licence"] for s in group for o in s["scene"]["objects"]}
            rows = [_row(s) for s in group]
            records += len(rows)
            qa += sum(len(r["qa"]) for r in rows)
            table = pa.Table.from_pylist(rows, schema=schema)
            pq.write_table(table, tmp / "data" / f"train-{i:05d}-of-{n_files:05d}.parquet",
                           compression="zstd", row_group_size=ROW_GROUP)
        m = json.loads((Path(dataset_dir) / "manifest.json").read_text(encoding="utf-8"))
        tag, text = licence(licences)
        card = RECORDS.format(tag=tag, licence=text, splits=yaml_splits({"train": "data/train-*.parquet"}),
                              recipe=m["recipe"], recipe_hash=m["recipe_hash"], records=records, qa=qa)
        (tmp / "README.md").write_text(card, encoding="utf-8")
        return finish("parquet", tmp, out_dir, dataset_dir, records, {"rows": records, "qa": qa}, {})


def _row(s: dict) -> dict:
    scene, stem = s["scene"], file_stem(s["key"])
    return {
        "key": s["key"], "scene_id": scene["scene_id"], "view": scene["view"],
        "view_index": scene["view_index"], "width": scene["width"], "height": scene["height"],
        "image": {"bytes": png_bytes(s["rgb"]), "path": f"{stem}.png"},
        "depth": {"bytes": png_bytes(depth_to_png8(s["depth_m"])), "path": f"{stem}_depth.png"},
        "K": s["K"].tolist(), "T_world_cam": s["T_world_cam"].tolist(),
        "scene": _dumps(scene), "relations": _dumps(s["relations"]),
        "qa": [_qa(q) for q in s["qa"]],
    }


def _qa(q: dict) -> dict:
    keys = ("qa_id", "family", "kind", "prompt", "question", "answer", "answer_points", "target_id",
            "ref", "num_steps", "predicates", "reasoning", "images")
    return {**{k: q.get(k) for k in keys}, "json": _dumps(q)}


def _dumps(obj: object) -> str:
    return json.dumps(obj, sort_keys=True, ensure_ascii=False, separators=(",", ":"))


# --- reading ----------------------------------------------------------------------------------

_MATRICES = ("K", "T_world_cam")
_IMAGES = ("image", "depth")


def collate(rows: list[dict]) -> dict[str, Any]:
    """Batch rows of this export as ``datasets`` gives them, for ``DataLoader(collate_fn=...)``.

    ``qa`` stays one list per row, each QA the whole stored dict (its ``json``, with
    family-specific fields such as ``free_mask`` or ``marks``): rows hold different numbers
    of QA, which torch's default collate refuses. ``image`` and ``depth`` become uint8
    (B, H, W, 3) tensors, ``K`` and ``T_world_cam`` float64 (B, 3, 3) and (B, 4, 4); every
    other column a list, one item per row. Views of different sizes cannot share a batch.
    """
    import torch

    if not rows:
        raise ValueError("collate needs at least one row")
    out: dict[str, Any] = {}
    for name in rows[0]:
        values = [r[name] for r in rows]
        if name == "qa":
            out[name] = [[json.loads(q["json"]) for q in qa] for qa in values]
        elif name in _IMAGES:
            out[name] = torch.from_numpy(_stack(name, [np.asarray(v.convert("RGB")) for v in values]))
        elif name in _MATRICES:
            out[name] = torch.tensor(values, dtype=torch.float64)
        else:
            out[name] = values
    return out


def _stack(name: str, arrays: list[np.ndarray]) -> np.ndarray:
    shapes = sorted({a.shape for a in arrays})
    if len(shapes) > 1:
        raise ValueError(f"cannot batch {name!r}: sizes {shapes} differ; batch views of one recipe "
                         "(one resolution) together or resize them in a transform")
    return np.stack(arrays)
