"""QA generation for one view: the family registry and the sampling driver.

Each family is a function in ``FAMILIES`` that draws one question from the view
(and, for multi-view questions, the scene's other view) or returns None when
this draw found nothing valid. Every answer is the value of the stored program
executed on the view, never a value computed beside it.
"""

from __future__ import annotations

import json
from typing import Callable

import numpy as np

from ..relations import ViewFacts
from .choice import choice
from .common import ASKED_KEY, QA, weighted
from .location import identify, location
from .multiview import multiview
from .placement import placement
from .quantity import quantity
from .refer import object_key
from .visual import visual_choice

STEP_REDRAWS = 3

FAMILIES: dict[str, Callable[[dict[str, ViewFacts], dict, int, np.random.Generator], QA | None]] = {
    "location": location,
    "placement": placement,
    "identify": identify,
    "choice": choice,
    "quantitative": quantity,
    "multiview": multiview,
    "visual_choice": visual_choice,
}

# Families that draw every question at the recipe's wanted step count; the step audit compares
# their mix with the recipe's (choice, quantitative and multi-view's camera-move half ignore it).
STEPPED_FAMILIES = ("location", "identify", "placement", "visual_choice")


def questions_for_view(view: ViewFacts, spec: dict, rng: np.random.Generator, key: str,
                       other: tuple[str, ViewFacts] | None = None) -> list[QA]:
    """Up to ``spec["per_view"]`` distinct questions about one view.

    Family and step count are drawn first and kept through that question's
    attempts, so hard draws (five steps, few anchors) are retried rather than
    silently replaced by easy ones; that keeps the recipe's mix. ``other`` is
    (record key, facts) of another view of the scene, for multi-view questions.
    """
    views = {"self": view} if other is None else {"self": view, "other": other[1]}
    families = {f: w for f, w in spec["families"].items() if f != "multiview" or other is not None}
    out: list[QA] = []
    programs: set[str] = set()
    # The one-object questions' keys, kept where the families' own target search reads them.
    asked = view.cache[ASKED_KEY] = set()
    if not view.askable() or not families:
        return out
    budget = 3 * spec["per_view"]  # family draws, so a view with little to ask still ends
    while len(out) < spec["per_view"] and budget > 0:
        budget -= 1
        family = weighted(families, rng)
        drawn = _draw(views, spec, family, rng, programs, asked)
        if drawn is not None:
            qa, (program, target) = drawn
            programs.add(program)
            if target is not None:
                asked.add(target)
            if "images" in qa:
                qa["images"] = [other[0] if v == "other" else key for v in qa["images"]]
            out.append({"qa_id": f"{key}#{len(out)}", **qa})
    return out


def _draw(views, spec: dict, family: str, rng: np.random.Generator, programs: set[str],
          asked: set[str]) -> tuple[QA, tuple[str, str | None]] | None:
    """One new question of the family, with its ``_signatures``: neither its program nor its
    object key asked before. A failed step count is redrawn but the family is kept: replacing
    hard families by easy ones on failure would skew the recipe's family mix."""
    for _ in range(STEP_REDRAWS):
        steps = int(weighted(spec["steps"], rng))
        for _attempt in range(spec["attempts_per_question"]):
            qa = FAMILIES[family](views, spec, steps, rng)
            if qa is not None:
                program, target = signatures = _signatures(qa)
                if program not in programs and target not in asked:
                    return qa, signatures
    return None


# Families whose answer is one object the question describes: pointing at it, naming it, or
# choosing the box around it ground the same description.
OBJECT_FAMILIES = ("location", "identify", "visual_choice")


def _signatures(qa: QA) -> tuple[str, str | None]:
    """What a question asks, regardless of wording; a record asks each at most once.

    First the program: the same program asked twice is one question. Then, for a question whose
    answer is one object, that object with the relations and ordinals of its description
    (``object_key``): "the basket" and "the brown basket" when only one basket is seen, "the
    object between A and B, narrower than C" pointed at and named, or one description answered
    by pointing and by choosing its box, are one question to a reader (annotator read 41:
    near-duplicates in 49 of 110 records, 4.9 % of the QA). None for other questions."""
    # Compared, never stored: the repr of each node's sorted items tells programs apart as their
    # JSON would, at a fifth of json.dumps's cost.
    program = [sorted((k, v) for k, v in n.items() if k != "text") for n in qa["steps"]]
    signature = repr((qa["family"], qa["kind"] if qa["kind"] != "name" else "point", program))
    if qa["family"] not in OBJECT_FAMILIES or qa.get("target_id") is None:
        return signature, None
    steps = qa["steps"]
    relations = [(n["predicate"], bool(n.get("reverse")), tuple(steps[i]["result"] for i in n["inputs"][1:]))
                 for n in steps if n["op"] == "relate"]
    ordinals = [(n["axis"], n["end"], n["rank"]) for n in steps if n["op"] == "ordinal"]
    return signature, object_key(qa["target_id"], relations, ordinals)
