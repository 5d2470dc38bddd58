"""Visual choice: coloured boxes drawn around a few objects; which box holds the described one?

The record keeps the clean image and stores the marks (box, colour, label);
``refspatial.annotate.draw_marks`` draws them for exports and audits.
"""

from __future__ import annotations

import re

import numpy as np

from ..relations import ViewFacts
from ..relations.masks import box_of, cached_boxes
from .common import QA, make_qa
from .location import described_target
from .phrases import Phrasebook
from .program import execute

MAX_IOU = 0.3  # boxes overlapping more than this would make the marks themselves ambiguous
# ...and a box holding most of another's would too: "which box contains the sponge?" fits both the
# sponge's box and the box around the basket it lies in (annotator).
MAX_COVER = 0.5
LABELS = "ABCD"


def visual_choice(views: dict[str, ViewFacts], spec: dict, steps: int, rng: np.random.Generator) -> QA | None:
    view = views["self"]
    found = described_target(views, steps, rng)
    if found is None:
        return None
    target, text, program = found
    others = [o for o in view.askable() if o.object_id != target.object_id]
    order = [others[int(i)] for i in rng.permutation(len(others))]
    chosen, limit = [target], 3 + int(rng.random() < 0.3)
    for o in order:
        if len(chosen) == limit:
            break
        if all(marks_apart(_box(view, o.object_id), _box(view, c.object_id)) for c in chosen):
            chosen.append(o)
    if len(chosen) < 3:
        return None
    book = Phrasebook.get()
    colours = book.data["mark_colors"]
    names = [list(colours)[int(i)] for i in rng.permutation(len(colours))[: len(chosen)]]
    shuffled = [chosen[int(i)] for i in rng.permutation(len(chosen))]
    marks = [{"label": LABELS[k], "color": names[k], "rgb": colours[names[k]], "object_id": o.object_id,
              "box_px": _box(view, o.object_id)} for k, o in enumerate(shuffled)]
    labels = [{"label": m["label"], "object_id": m["object_id"]} for m in marks]
    program.append({"op": "mark", "inputs": [len(program) - 1], "marks": labels})
    values = execute(program, view)
    # "Which box holds the box?" reads two ways: where the description names a box, the marks are frames.
    mark = "frame" if re.search(r"\bbox", text) else "box"
    options = " ".join(f"({m['label']}) the {m['color']} {mark}" for m in marks)
    prompt = book.template("visual_choice", rng=rng).format(ref=text, options=options, mark=mark,
                                                             marks={"box": "boxes", "frame": "frames"}[mark])
    return make_qa("visual_choice", "box", prompt, f"({values[-1]})", program, values, views, rng,
                   target=values[-2], ref=text, marks=marks)


def _box(view: ViewFacts, object_id: int) -> list[int]:
    """The object's pixel box (x0, y0, x1, y1, inclusive), padded a little; its mask's tight box
    is the segmentation's ``object_boxes`` slice."""
    rows, cols = box_of(cached_boxes(view), object_id)
    pad = max(1, round(min(view.width, view.height) / 180))
    return [max(0, cols.start - pad), max(0, rows.start - pad),
            min(view.width - 1, cols.stop - 1 + pad), min(view.height - 1, rows.stop - 1 + pad)]


def marks_apart(a: list[int], b: list[int]) -> bool:
    """Two marks a reader cannot confuse: little overlap, and neither mostly inside the other."""
    return _iou(a, b) < MAX_IOU and _cover(a, b) < MAX_COVER


def _cover(a: list[int], b: list[int]) -> float:
    """The share of the smaller box that the other one covers."""
    inter = max(0, min(a[2], b[2]) - max(a[0], b[0])) * max(0, min(a[3], b[3]) - max(a[1], b[1]))
    smaller = min((a[2] - a[0]) * (a[3] - a[1]), (b[2] - b[0]) * (b[3] - b[1]))
    return inter / smaller if smaller else 0.0


def _iou(a: list[int], b: list[int]) -> float:
    ix = max(0, min(a[2], b[2]) - max(a[0], b[0]))
    iy = max(0, min(a[3], b[3]) - max(a[1], b[1]))
    inter = ix * iy
    union = (a[2] - a[0]) * (a[3] - a[1]) + (b[2] - b[0]) * (b[3] - b[1]) - inter
    return inter / union if union else 0.0
