"""RefSpatial-Bench's layout, so RoboRefer's evaluation scripts score a model on our data.

``<Split>/question.json`` lists ``{"id", "object", "prompt", "suffix", "rgb_path",
"mask_path", "category", "step"}``; ``rgb_path`` and ``mask_path`` are relative to the split
folder. The evaluation asks ``f"{prompt} {suffix}"`` (our stored ``question``, byte for
byte) and scores the share of predicted points inside the mask (``score`` below).

Location masks are the target's visible segmentation. Placement masks are the free region
a placement QA stores under ``free_mask`` (run-length code of ``refspatial.annotate``, see
docs/FORMAT.md); placement QA without one are skipped and counted, never given an invented
mask.

With ``--unseen-share F`` (see ``unseen``), questions whose predicate combination is held
out leave Location and Placement for a third split, ``Unseen``, as RefSpatial-Bench has.
Beside the folders, ``data/<split>-00000-of-00001.parquet`` and README.md hold the same
benchmark as Hugging Face Parquet (``bench_parquet``).
"""

from __future__ import annotations

import re
from collections import defaultdict
from pathlib import Path
from typing import Sequence

import numpy as np

from .common import (
    ExportError,
    ExportSummary,
    file_stem,
    finish,
    open_dataset,
    read_manifest,
    samples,
    staged,
    write_json,
    write_png,
)
from .unseen import HoldOut

SPLITS = {"Location": "location", "Placement": "placement"}  # split folder -> QA family = bench category
UNSEEN = "Unseen"
# RoboRefer's point pattern: "(x, y)"; numbers with a dot are normalised, others are pixels.
_TUPLE = re.compile(r"\(([-+]?\d+\.?\d*(?:,\s*[-+]?\d+\.?\d*)*?)\)")


def export_bench(dataset_dir: Path, out_dir: Path, *, unseen_share: float = 0.0,
                 overwrite: bool = False) -> ExportSummary:
    """Write one split folder per bench category that has questions, and their Parquet."""
    from .bench_parquet import write_bench_parquet

    hold = HoldOut(unseen_share)
    with staged(out_dir, overwrite) as tmp:
        records, counts, licences = write_splits(dataset_dir, tmp, hold, (*SPLITS, UNSEEN))
        write_bench_parquet(tmp, read_manifest(dataset_dir), licences, unseen_share)
        return finish("bench", tmp, out_dir, dataset_dir, records, counts, {"unseen_share": unseen_share})


def write_splits(dataset_dir: Path, root: Path, hold: HoldOut,
                 wanted: Sequence[str]) -> tuple[int, dict[str, int], set[str]]:
    """The ``wanted`` split folders under ``root``; (records read, counts, licences of the
    objects in the images written)."""
    trained = hold.trained_predicates(qa for s in samples(open_dataset(dataset_dir, ())) for qa in s["qa"])
    dataset = open_dataset(dataset_dir, ("rgb", "seg"))
    questions: dict[str, list[dict]] = defaultdict(list)
    counts: dict[str, int] = defaultdict(int)
    records, licences = 0, set()
    for s in samples(dataset):
        records += 1
        stem, written = file_stem(s["key"]), set()
        for qa in s["qa"]:
            split = _split(qa, hold, trained, counts)
            if split not in wanted:
                continue
            mask = _mask(qa, s["seg"])
            if mask is None:
                counts[f"{split} skipped (no mask)"] += 1
                continue
            entry = _question(len(questions[split]), qa, stem)
            if split not in written:
                write_png(root / split / entry["rgb_path"], s["rgb"])
                written.add(split)
                licences |= {o["licence"] for o in s["scene"]["objects"]}
            write_png(root / split / entry["mask_path"], mask.astype(np.uint8) * 255)
            questions[split].append(entry)
    for split, entries in sorted(questions.items()):
        write_json(root / split / "question.json", entries)
        counts[split] = len(entries)
    return records, dict(counts), licences


def _split(qa: dict, hold: HoldOut, trained: frozenset[str], counts: dict[str, int]) -> str | None:
    for split, family in SPLITS.items():
        if qa["family"] == family and qa["kind"] == "point":
            if not hold.held_out(qa):
                return split
            if hold.testable(qa, trained):
                return UNSEEN
            counts[f"{UNSEEN} skipped (a predicate never trained)"] += 1
            return None
    return None


def _question(qid: int, qa: dict, stem: str) -> dict:
    prompt = qa["prompt"]
    if not qa["question"].startswith(prompt + " "):
        raise ExportError(f"QA {qa['qa_id']}: question does not start with its prompt plus a space; "
                          "regenerate the dataset with this refspatial version")
    return {
        "id": qid,
        "object": qa.get("ref") or "",
        "prompt": prompt,
        "suffix": qa["question"][len(prompt) + 1:],
        "rgb_path": f"image/{stem}.png",
        "mask_path": f"mask/{qid}.png",
        "category": qa["family"],  # location or placement, in Unseen too
        "step": int(qa["num_steps"]),
        "qa_id": qa["qa_id"],  # provenance; RoboRefer's scripts ignore extra keys
    }


def _mask(qa: dict, seg: np.ndarray) -> np.ndarray | None:
    """The region that counts as a hit, or None when the record has none."""
    if qa["family"] == "placement":
        rle = qa.get("free_mask")
        mask = decode_rle(rle, seg.shape) if rle else None
    else:
        mask = seg == qa["target_id"]
    return mask if mask is not None and mask.any() else None


def decode_rle(rle: dict, shape: tuple[int, int]) -> np.ndarray:
    """A stored free-region mask (refspatial.annotate's run-length code), checked against the image."""
    from refspatial.annotate import rle_decode

    if tuple(rle["size"]) != tuple(shape):
        raise ExportError(f"free_mask size {rle['size']} differs from the image {list(shape)}; regenerate the QA")
    try:
        return rle_decode(rle).astype(bool)
    except ValueError as e:
        raise ExportError(f"free_mask is damaged ({e}); regenerate the QA") from None


# --- scoring, as RoboRefer's summarize_acc.py does it --------------------------------------


def to_pixels(points: str | Sequence[Sequence[float]], width: int, height: int) -> np.ndarray:
    """(N, 2) integer (x, y) pixels of an answer text or a list of points: normalised
    values (floats) become int(x * W), int(y * H); integers are already pixels."""
    if isinstance(points, str):
        points = [[float(v) if "." in v else int(v) for v in m.split(",")] for m in _TUPLE.findall(points)]
    out = []
    for p in points:
        if len(p) != 2:
            continue  # boxes and other tuples are not points
        x, y = p
        if isinstance(x, float) or isinstance(y, float):
            x, y = int(x * width), int(y * height)
        out.append((int(x), int(y)))
    return np.array(out, dtype=np.int64).reshape(-1, 2)


def score(points: str | Sequence[Sequence[float]], mask: np.ndarray) -> float:
    """Share of predicted points inside the mask (non-zero pixels); points off the image
    count as misses and an answer without points scores 0."""
    mask = np.asarray(mask)
    if mask.ndim == 3:
        mask = mask[..., 0]
    h, w = mask.shape
    px = to_pixels(points, w, h)
    if len(px) == 0:
        return 0.0
    inside = (px[:, 0] >= 0) & (px[:, 0] < w) & (px[:, 1] >= 0) & (px[:, 1] < h)
    hits = np.zeros(len(px))
    hits[inside] = mask[px[inside, 1], px[inside, 0]] > 0
    return float(hits.mean())
