"""Multi-view questions: two views of one scene ("the first image" = the other view, "the second
image" = this one).

The QA lives in the record of the second image and names the first image's record in ``images``.
"""

from __future__ import annotations

import numpy as np

from ..relations import ViewFacts
from ..vector import angle_deg
from .common import QA, make_qa, point_qa
from .location import described_target
from .phrases import Phrasebook
from .program import Node, ProgramError, execute

# "Did the camera turn left or right?" has an answer a person agrees with only while the two
# views look the same way: at 170 degrees apart a left turn and a right turn of 190 degrees
# describe the same pair, and the images share almost nothing. Below 90 degrees both views
# face the same half of the scene.
MAX_HEADING_CHANGE_DEG = 90.0
# Objects seen whole in both images: what a person compares to tell how the camera moved.
MIN_SHARED_OBJECTS = 1
OBJECT_HEADS = ("the object that is ", "the object ")  # Phrasebook's head for a description of any object


def multiview(views: dict[str, ViewFacts], spec: dict, steps: int, rng: np.random.Generator) -> QA | None:
    if "other" not in views:
        return None
    return _same_object(views, spec, steps, rng) if rng.random() < 0.6 else _camera_move(views, rng)


def _same_object(views, spec: dict, steps: int, rng) -> QA | None:
    """Point in the second image to the object a description picks in the first."""
    second = views["self"]
    found = described_target(views, steps, rng, where="other")
    if found is None or second.objects[found[0].object_id].status != "visible":
        return None
    _, text, program = found
    # The same object, now located in the second image.
    program.append({"op": "unique", "inputs": [len(program) - 1], "text": text})
    return point_qa("multiview", "multiview_point", text, program, execute(program, views), views, spec, rng,
                    fill={"is_ref": predicate_words(text)}, ref=text, images=["other", "self"])


def predicate_words(text: str) -> str:
    """A description as the words after "the object that, in the first image, is": a description
    of any object ("the object that is left of the mug") keeps only its relations, so the prompt
    does not say "the object that ... is the object that is left of the mug"."""
    for head in OBJECT_HEADS:
        if text.startswith(head):
            return text[len(head):]
    return text


def heading_change_deg(first: ViewFacts, second: ViewFacts) -> float:
    """Angle in degrees (0 to 180) between the two cameras' viewing directions projected on the
    ground (world z up), read from the views' camera poses (OpenCV camera: +z looks forward)."""
    f1, f2 = (np.asarray(v.T_world_cam[:2, 2], dtype=float) for v in (first, second))
    n1, n2 = np.linalg.norm(f1), np.linalg.norm(f2)
    if n1 < 1e-9 or n2 < 1e-9:  # a camera looking straight down has no heading
        return 180.0
    return angle_deg(f1 @ f2 / (n1 * n2))


def shared_objects(first: ViewFacts, second: ViewFacts) -> list[int]:
    """Ids of the objects seen whole (status "visible") in both views."""
    seen = {o.object_id for o in first.askable()}
    return [o.object_id for o in second.askable() if o.object_id in seen]


def camera_move_askable(first: ViewFacts, second: ViewFacts) -> bool:
    """Whether "which way did the camera move / turn" has one answer a person would give: the
    views' headings differ by less than MAX_HEADING_CHANGE_DEG and both images show at least
    MIN_SHARED_OBJECTS of the same objects whole."""
    return (heading_change_deg(first, second) < MAX_HEADING_CHANGE_DEG
            and len(shared_objects(first, second)) >= MIN_SHARED_OBJECTS)


def _camera_move(views, rng) -> QA | None:
    if not camera_move_askable(views["other"], views["self"]):
        return None
    motion = "shift" if rng.random() < 0.5 else "turn"
    program: list[Node] = [{"op": "camera_move", "motion": motion}]
    try:
        values = execute(program, views)
    except ProgramError:
        return None
    prompt = Phrasebook.get().template("camera_move", motion, rng=rng)
    return make_qa("multiview", f"camera_{motion}", prompt, "(A)" if values[-1] == "left" else "(B)",
                   program, values, views, rng, images=["other", "self"])
