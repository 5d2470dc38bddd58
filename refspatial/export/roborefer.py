"""RoboRefer's training layout (LLaVA style): one JSON list per subset, image/ and depth/.

RoboRefer registers each subset as a ``spatialdataset`` with ``data_path`` = the JSON list,
``image_path`` = image/ (image_visual_choice/ for visual_choice_qa) and, for RGB-D training,
``depth_path`` = depth/. A record holds up to ``max_turns`` QA turns about the same
image(s) (RoboRefer cuts at 15); ``<image>`` appears once per image, in the first human
turn only. Questions and answers are the stored texts, byte for byte; the point suffix is
already inside ``question``.

Subsets follow RefSpatial's: choice_qa, reasoning_template_qa (location, answered with the
``<think>..</think><answer>..</answer>`` trace), vacant_qa (placement), multi_view_qa (QA
whose ``images`` name two views of a scene), visual_choice_qa (the stored marks drawn on a
copy of the image), and ``<family>_qa`` for any other family. A subset file is written
only when it has records.
"""

from __future__ import annotations

from collections import defaultdict
from pathlib import Path

from .common import (
    ExportError,
    ExportSummary,
    depth_to_png8,
    file_stem,
    finish,
    open_dataset,
    scenes,
    staged,
    write_json,
    write_png,
)

MAX_TURNS = 15  # RoboRefer's cut
SUBSETS = {"choice": "choice_qa", "location": "reasoning_template_qa", "placement": "vacant_qa",
           "multiview": "multi_view_qa", "visual_choice": "visual_choice_qa"}
WITH_REASONING = {"reasoning_template_qa"}  # subsets whose gpt turn is the reasoning trace
VISUAL = "visual_choice_qa"
VISUAL_IMAGES = "image_visual_choice"
METADATA = "reasoning_metadata.json"
TRACE_KEYS = ("qa_id", "family", "kind", "num_steps", "predicates", "target_id", "answer_points",
              "reasoning_steps")


def export_roborefer(dataset_dir: Path, out_dir: Path, *, max_turns: int = MAX_TURNS,
                     overwrite: bool = False) -> ExportSummary:
    """Write the subsets, images, depth images and reasoning metadata of a dataset."""
    if not 1 <= max_turns <= MAX_TURNS:
        raise ExportError(f"--max-turns must be in [1, {MAX_TURNS}] (RoboRefer cuts at 15); got {max_turns}")
    dataset = open_dataset(dataset_dir, ("rgb", "depth"))
    subsets: dict[str, list[dict]] = defaultdict(list)
    metadata: dict[str, list[dict]] = {}
    records = 0
    with staged(out_dir, overwrite) as tmp:
        for views in scenes(dataset):
            records += len(views)
            for s in views:
                stem = file_stem(s["key"])
                write_png(tmp / "image" / f"{stem}.png", s["rgb"])
                write_png(tmp / "depth" / f"{stem}_depth.png", depth_to_png8(s["depth_m"]))
            _scene_records(views, max_turns, subsets, metadata, tmp)
        for name, rows in sorted(subsets.items()):  # compact: these lists run to millions of turns
            write_json(tmp / f"{name}.json", rows, indent=None)
        write_json(tmp / METADATA, metadata, indent=None)
        counts = {f"{name} records": len(rows) for name, rows in subsets.items()}
        counts["turns"] = sum(len(r["conversations"]) // 2 for rows in subsets.values() for r in rows)
        return finish("roborefer", tmp, out_dir, dataset_dir, records, counts, {"max_turns": max_turns})


def _scene_records(views: list[dict], max_turns: int, subsets: dict, metadata: dict, tmp: Path) -> None:
    """A scene's QA grouped by (subset, images), in the order the records hold them."""
    keys = {s["key"] for s in views}
    groups: dict[tuple[str, tuple[str, ...]], list[dict]] = defaultdict(list)
    for s in views:
        for qa in s["qa"]:
            subset = SUBSETS.get(qa["family"], f"{qa['family']}_qa")
            images = tuple(qa.get("images") or (s["key"],))
            if not set(images) <= keys:
                raise ExportError(f"QA {qa['qa_id']} names images {list(images)} outside its scene; "
                                  "regenerate the dataset")
            if subset == VISUAL:
                _visual_record(s, qa, subsets[VISUAL], metadata, tmp)
            else:
                groups[(subset, images)].append(qa)
    for (subset, images), qas in groups.items():
        turns = [(qa["question"], _gpt(qa, subset), _trace(qa)) for qa in qas]
        stems = [file_stem(k) for k in images]
        base = "-".join([stems[0], *(k.rsplit("/", 1)[-1] for k in images[1:])])
        _add(subsets[subset], metadata, f"{base}_{subset}", [f"{st}.png" for st in stems],
             [f"{st}_depth.png" for st in stems], turns, max_turns)


def _gpt(qa: dict, subset: str) -> str:
    """The trace for reasoning subsets (its <answer> is the stored answer text), else the answer."""
    return qa["reasoning"] if subset in WITH_REASONING and qa.get("reasoning") else qa["answer"]


def _trace(qa: dict) -> dict:
    return {k: qa.get(k) for k in TRACE_KEYS}


def _visual_record(s: dict, qa: dict, rows: list[dict], metadata: dict, tmp: Path) -> None:
    """One record per visual-choice QA: its own marks drawn on a copy of the image."""
    from refspatial.annotate import draw_marks

    stem = f"{file_stem(s['key'])}_{qa['qa_id'].rsplit('#', 1)[-1]}"
    write_png(tmp / VISUAL_IMAGES / f"{stem}.png", draw_marks(s["rgb"], qa["marks"]))
    turn = (qa["question"], qa["answer"], _trace(qa))
    _add(rows, metadata, f"{stem}_{VISUAL}", [f"{stem}.png"], [f"{file_stem(s['key'])}_depth.png"], [turn], 1)


def _add(rows: list[dict], metadata: dict, base_id: str, images: list[str], depths: list[str],
         turns: list[tuple[str, str, dict]], max_turns: int) -> None:
    """Records of at most ``max_turns`` turns each, ids ``<base_id>_<k>``."""
    tokens = "<image>\n" * len(images)
    for k in range(0, len(turns), max_turns):
        chunk = turns[k:k + max_turns]
        conversations = []
        for j, (question, answer, _) in enumerate(chunk):
            conversations.append({"from": "human", "value": (tokens if j == 0 else "") + question})
            conversations.append({"from": "gpt", "value": answer})
        record_id = f"{base_id}_{k // max_turns}"
        one = len(images) == 1
        rows.append({"id": record_id, "image": images[0] if one else images,
                     "depth": depths[0] if one else depths, "conversations": conversations})
        metadata[record_id] = [trace for _, _, trace in chunk]
