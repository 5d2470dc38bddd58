"""Multi-view questions: two views of one scene ("image 1" = the other view, "image 2" = this one).

The QA lives in the record of image 2 and names image 1's record in ``images``.
"""

from __future__ import annotations

import numpy as np

from ..relations import ViewFacts
from .common import QA, make_qa, point_qa
from .location import described_target
from .phrases import Phrasebook
from .program import Node, ProgramError, execute


def multiview(views: dict[str, ViewFacts], spec: dict, steps: int, rng: np.random.Generator) -> QA | None:
    if "other" not in views:
        return None
    return _same_object(views, spec, steps, rng) if rng.random() < 0.6 else _camera_move(views, rng)


def _same_object(views, spec: dict, steps: int, rng) -> QA | None:
    """Point in image 2 to the object a description picks in image 1."""
    second = views["self"]
    found = described_target(views, steps, rng, where="other")
    if found is None or second.objects[found[0].object_id].status != "visible":
        return None
    _, text, program = found
    # The same object, now located in image 2.
    program.append({"op": "unique", "inputs": [len(program) - 1], "text": text})
    return point_qa("multiview", "multiview_point", text, program, execute(program, views), views, spec, rng,
                    ref=text, images=["other", "self"])


def _camera_move(views, rng) -> QA | None:
    motion = "shift" if rng.random() < 0.5 else "turn"
    program: list[Node] = [{"op": "camera_move", "motion": motion}]
    try:
        values = execute(program, views)
    except ProgramError:
        return None
    prompt = Phrasebook.get().template("camera_move", motion, rng=rng)
    return make_qa("multiview", f"camera_{motion}", prompt, "(A)" if values[-1] == "left" else "(B)",
                   program, values, views, rng, images=["other", "self"])
