"""RoboRefer's training layout (LLaVA style): one JSON list per subset, image/ and depth/.

RoboRefer registers each subset as a ``spatialdataset`` with ``data_path`` = the JSON list,
``image_path`` and, for RGB-D training, ``depth_path``: image/ and depth/, except
image_multi_view/ and depth_multi_view/ for multi_view_qa and image_visual_choice/ (with
depth/) for visual_choice_qa, as RefSpatial's registration has them. ``roborefer_mixture.py``
beside the subsets is that registration, ready to paste (``roborefer_mixture``). A record
holds up to ``max_turns`` QA turns about the same image(s) (RoboRefer cuts at 15);
``<image>`` appears once per image, in the first human turn only. Questions and answers
are the stored texts, byte for byte; the point suffix is already inside ``question``.

Subsets follow RefSpatial's: choice_qa, reasoning_template_qa (location, answered with the
``<think>..</think><answer>..</answer>`` trace), vacant_qa (placement), multi_view_qa (QA
whose ``images`` name two views of a scene), visual_choice_qa (the stored marks drawn on a
copy of the image), and ``<family>_qa`` for any other family. A subset file is written
only when it has records.

Depth images are 8-bit, near bright, in one of ``common.DEPTH_ENCODINGS``: ``linear``
(metric depth min-max normalised) or ``inverse`` (relative inverse depth, what RoboRefer's
inference feeds its depth encoder from Depth Anything V2). With ``unseen_share`` > 0 the
subsets leave out QA whose predicate combination is held out (``unseen``), and
``bench/Unseen/`` holds those questions in RefSpatial-Bench's layout: a training set and a
compositional test set from one command.
"""

from __future__ import annotations

from collections import defaultdict
from pathlib import Path

from .common import (
    DEPTH_ENCODINGS,
    ExportError,
    ExportSummary,
    depth_to_png8,
    file_stem,
    finish,
    open_dataset,
    read_manifest,
    scenes,
    staged,
    write_json,
    write_png,
)
from .roborefer_mixture import write_mixture
from .unseen import HoldOut

MAX_TURNS = 15  # RoboRefer's cut
SUBSETS = {"choice": "choice_qa", "location": "reasoning_template_qa", "placement": "vacant_qa",
           "multiview": "multi_view_qa", "visual_choice": "visual_choice_qa"}
WITH_REASONING = {"reasoning_template_qa"}  # subsets whose gpt turn is the reasoning trace
VISUAL = "visual_choice_qa"
MULTI_VIEW = "multi_view_qa"
FOLDERS = {VISUAL: ("image_visual_choice", "depth"),  # subset -> (image folder, depth folder)
           MULTI_VIEW: ("image_multi_view", "depth_multi_view")}
PLAIN = ("image", "depth")
METADATA = "reasoning_metadata.json"
TRACE_KEYS = ("qa_id", "family", "kind", "num_steps", "predicates", "target_id", "answer_points",
              "reasoning_steps")


def export_roborefer(dataset_dir: Path, out_dir: Path, *, max_turns: int = MAX_TURNS,
                     depth_encoding: str = "linear", unseen_share: float = 0.0,
                     overwrite: bool = False) -> ExportSummary:
    """Write the subsets, images, depth images, reasoning metadata and registration of a
    dataset (and with ``unseen_share`` > 0, the Unseen test split under bench/)."""
    if not 1 <= max_turns <= MAX_TURNS:
        raise ExportError(f"--max-turns must be in [1, {MAX_TURNS}] (RoboRefer cuts at 15); got {max_turns}")
    if depth_encoding not in DEPTH_ENCODINGS:
        raise ExportError(f"--depth-encoding {depth_encoding!r} is unknown; choose one of {', '.join(DEPTH_ENCODINGS)}")
    hold = HoldOut(unseen_share)
    dataset = open_dataset(dataset_dir, ("rgb", "depth"))
    out = _Out(max_turns, depth_encoding, hold)
    records = 0
    with staged(out_dir, overwrite) as tmp:
        for views in scenes(dataset):
            records += len(views)
            for s in views:
                _write_view(tmp, PLAIN, s, depth_encoding)
            _scene_records(views, out, tmp)
        for name, rows in sorted(out.subsets.items()):  # compact: these lists run to millions of turns
            write_json(tmp / f"{name}.json", rows, indent=None)
        write_json(tmp / METADATA, out.metadata, indent=None)
        write_mixture(tmp, read_manifest(dataset_dir), {name: FOLDERS.get(name, PLAIN) for name in out.subsets})
        counts = {f"{name} records": len(rows) for name, rows in out.subsets.items()}
        counts["turns"] = sum(len(r["conversations"]) // 2 for rows in out.subsets.values() for r in rows)
        if unseen_share > 0:
            counts.update(_unseen(dataset_dir, tmp / "bench", hold, out.held_out))
        options = {"max_turns": max_turns, "depth_encoding": depth_encoding, "unseen_share": unseen_share}
        return finish("roborefer", tmp, out_dir, dataset_dir, records, counts, options)


class _Out:
    """What the export gathers while it reads: subset rows, traces, held-out QA."""

    def __init__(self, max_turns: int, depth_encoding: str, hold: HoldOut) -> None:
        self.max_turns, self.depth_encoding, self.hold = max_turns, depth_encoding, hold
        self.subsets: dict[str, list[dict]] = defaultdict(list)
        self.metadata: dict[str, list[dict]] = {}
        self.held_out = 0


def _write_view(tmp: Path, folders: tuple[str, str], s: dict, depth_encoding: str) -> None:
    stem = file_stem(s["key"])
    write_png(tmp / folders[0] / f"{stem}.png", s["rgb"])
    write_png(tmp / folders[1] / f"{stem}_depth.png", depth_to_png8(s["depth_m"], depth_encoding))


def _unseen(dataset_dir: Path, root: Path, hold: HoldOut, held_out: int) -> dict[str, int]:
    from .bench import UNSEEN, write_splits
    from .bench_parquet import write_bench_parquet

    _, counts, licences = write_splits(dataset_dir, root, hold, (UNSEEN,))
    write_bench_parquet(root, read_manifest(dataset_dir), licences, hold.share)
    return {"held-out QA": held_out, **{f"bench {k}": v for k, v in counts.items()}}


def _scene_records(views: list[dict], out: _Out, tmp: Path) -> None:
    """A scene's QA grouped by (subset, images), in the order the records hold them."""
    by_key = {s["key"]: s for s in views}
    groups: dict[tuple[str, tuple[str, ...]], list[dict]] = defaultdict(list)
    multi_view_written: set[str] = set()
    for s in views:
        for qa in s["qa"]:
            if out.hold.held_out(qa):
                out.held_out += 1
                continue
            subset = SUBSETS.get(qa["family"], f"{qa['family']}_qa")
            images = tuple(qa.get("images") or (s["key"],))
            if not set(images) <= set(by_key):
                raise ExportError(f"QA {qa['qa_id']} names images {list(images)} outside its scene; "
                                  "regenerate the dataset")
            if subset == VISUAL:
                _visual_record(s, qa, out, tmp)
            else:
                groups[(subset, images)].append(qa)
    for (subset, images), qas in groups.items():
        if subset == MULTI_VIEW:
            for key in sorted(set(images) - multi_view_written):
                _write_view(tmp, FOLDERS[MULTI_VIEW], by_key[key], out.depth_encoding)
                multi_view_written.add(key)
        turns = [(qa["question"], _gpt(qa, subset), _trace(qa)) for qa in qas]
        stems = [file_stem(k) for k in images]
        base = "-".join([stems[0], *(k.rsplit("/", 1)[-1] for k in images[1:])])
        _add(out, subset, f"{base}_{subset}", [f"{st}.png" for st in stems],
             [f"{st}_depth.png" for st in stems], turns, out.max_turns)


def _gpt(qa: dict, subset: str) -> str:
    """The trace for reasoning subsets (its <answer> is the stored answer text), else the answer."""
    return qa["reasoning"] if subset in WITH_REASONING and qa.get("reasoning") else qa["answer"]


def _trace(qa: dict) -> dict:
    return {k: qa.get(k) for k in TRACE_KEYS}


def _visual_record(s: dict, qa: dict, out: _Out, tmp: Path) -> None:
    """One record per visual-choice QA: its own marks drawn on a copy of the image."""
    from refspatial.annotate import draw_marks

    stem = f"{file_stem(s['key'])}_{qa['qa_id'].rsplit('#', 1)[-1]}"
    write_png(tmp / FOLDERS[VISUAL][0] / f"{stem}.png", draw_marks(s["rgb"], qa["marks"]))
    turn = (qa["question"], qa["answer"], _trace(qa))
    _add(out, VISUAL, f"{stem}_{VISUAL}", [f"{stem}.png"], [f"{file_stem(s['key'])}_depth.png"], [turn], 1)


def _add(out: _Out, subset: str, base_id: str, images: list[str], depths: list[str],
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
        out.subsets[subset].append({"id": record_id, "image": images[0] if one else images,
                                    "depth": depths[0] if one else depths, "conversations": conversations})
        out.metadata[record_id] = [trace for _, _, trace in chunk]
