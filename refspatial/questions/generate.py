"""QA generation for one view: families, answers and reasoning traces.

Each family is a function in ``FAMILIES`` that draws one question from the view
or returns None when this draw found nothing valid; the driver retries up to
``attempts_per_question`` times. Every answer is the value of the stored program
executed on the view, never a value computed beside it.
"""

from __future__ import annotations

from typing import Any, Callable

import cv2
import numpy as np

from ..relations import ViewFacts
from .phrases import Phrasebook
from .program import Node, ProgramError, count_steps, execute, with_results
from .refer import BINARY, Ref, anchored_refs, compile_ref, simple_refs

QA = dict[str, Any]
POINT_TRIES = 20


def questions_for_view(view: ViewFacts, spec: dict, rng: np.random.Generator, key: str) -> list[QA]:
    """Up to ``spec["per_view"]`` distinct questions about one view.

    Family and step count are drawn first and kept through that question's
    attempts, so hard draws (five steps, few anchors) are retried rather than
    silently replaced by easy ones; that keeps the recipe's mix.
    """
    out: list[QA] = []
    seen: set[str] = set()
    if not view.askable():
        return out
    budget = 2 * spec["per_view"]  # draws, so a view with little to ask still ends
    while len(out) < spec["per_view"] and budget > 0:
        budget -= 1
        family = _weighted(spec["families"], rng)
        steps = int(_weighted(spec["steps"], rng))
        for _attempt in range(spec["attempts_per_question"]):
            qa = FAMILIES[family](view, spec, steps, rng)
            if qa is not None and qa["question"] not in seen:
                seen.add(qa["question"])
                out.append({"qa_id": f"{key}#{len(out)}", **qa})
                break
    return out


def _weighted(weights: dict, rng: np.random.Generator) -> Any:
    keys = list(weights)
    p = np.array([weights[k] for k in keys], dtype=float)
    return keys[int(rng.choice(len(keys), p=p / p.sum()))]


# --- answer points -----------------------------------------------------------------------------


def erosion_px(view: ViewFacts) -> int:
    """About 0.5 % of the short image side, so points keep off mask borders at any resolution."""
    return max(1, round(min(view.width, view.height) / 180))


def sample_points(view: ViewFacts, object_id: int, n: int, rng: np.random.Generator) -> list[list[float]] | None:
    """n normalised (x, y) points on the object's eroded visible mask, 3 decimals.

    A point (x, y) stands for pixel column floor(x * W), row floor(y * H); each
    rounded point is checked to land on the (un-eroded) visible mask.
    """
    mask = (view.seg == object_id).astype(np.uint8)
    eroded = cv2.erode(mask, np.ones((3, 3), np.uint8), iterations=erosion_px(view))
    rows, cols = np.nonzero(eroded)
    if len(rows) == 0:
        return None
    points: list[list[float]] = []
    for _ in range(n * POINT_TRIES):
        k = int(rng.integers(len(rows)))
        x = round((cols[k] + 0.5) / view.width, 3)
        y = round((rows[k] + 0.5) / view.height, 3)
        if mask[min(int(y * view.height), view.height - 1), min(int(x * view.width), view.width - 1)]:
            points.append([x, y])
            if len(points) == n:
                return points
    return None


def format_points(points: list[list[float]]) -> str:
    return "[" + ", ".join(f"({x:.3f}, {y:.3f})" for x, y in points) + "]"


# --- families ----------------------------------------------------------------------------------


def _location(view: ViewFacts, spec: dict, steps: int, rng: np.random.Generator) -> QA | None:
    """Point to the one object a description picks (1 to 5 steps)."""
    targets = view.askable()
    target = targets[int(rng.integers(len(targets)))]
    if steps == 1:
        refs = simple_refs(view, target)
        # Mostly the plainest description that works; sometimes a richer one.
        refs = refs[:1] if rng.random() < 0.6 else refs
    else:
        refs = anchored_refs(view, target, steps, rng)
    if not refs:
        return None
    ref: Ref = refs[int(rng.integers(len(refs)))]
    book = Phrasebook.get()
    text, texts = book.describe(ref, rng)
    program: list[Node] = []
    compile_ref(ref, program, texts)
    values = execute(program, view)
    points = sample_points(view, values[-1], spec["answer_points"], rng)
    if points is None:
        return None
    prompt = book.template("location", rng).format(ref=text)
    return _point_qa("location", prompt, points, values[-1], program, values, view, rng, ref=text)


def _choice(view: ViewFacts, spec: dict, steps: int, rng: np.random.Generator) -> QA | None:
    """Yes/no about a relation, or which of two objects a comparative picks (always 2 steps)."""
    objs = view.askable()
    if len(objs) < 2:
        return None
    a, b = (objs[int(i)] for i in rng.choice(len(objs), size=2, replace=False))
    ref_a, ref_b = simple_refs(view, a)[:1], simple_refs(view, b)[:1]
    if not ref_a or not ref_b:
        return None
    predicate = BINARY[int(rng.integers(len(BINARY)))]
    book = Phrasebook.get()
    text_a, texts = book.describe(ref_a[0], rng)
    text_b, texts_b = book.describe(ref_b[0], rng)
    program: list[Node] = []
    ia = compile_ref(ref_a[0], program, texts)
    ib = compile_ref(ref_b[0], program, texts_b)
    if rng.random() < 0.5:
        program.append({"op": "query", "inputs": [ia, ib], "predicate": predicate})
    else:
        program.append({"op": "pick", "inputs": [ia, ib] if rng.random() < 0.5 else [ib, ia], "predicate": predicate})
    try:
        values = execute(program, view)
    except ProgramError:
        return None
    if program[-1]["op"] == "query":
        phrase = book.relation_phrase(predicate, False, rng)
        prompt = book.template("yes_no", rng).format(a=text_a, b=text_b, phrase=phrase)
        return _choice_qa("yes_no", prompt, "(A)" if values[-1] else "(B)", None, program, values, predicate)
    first, second = program[-1]["inputs"]
    opts = {first: values[first], second: values[second]}
    names = {values[ia]: text_a, values[ib]: text_b}
    prompt = book.template("pick", rng).format(
        comparative=book.comparative(predicate, rng), opt_a=names[opts[first]], opt_b=names[opts[second]]
    )
    letter = "(A)" if values[-1] == opts[first] else "(B)"
    return _choice_qa("pick", prompt, letter, values[-1], program, values, predicate)


FAMILIES: dict[str, Callable[[ViewFacts, dict, int, np.random.Generator], QA | None]] = {
    "location": _location,
    "choice": _choice,
}


# --- records -----------------------------------------------------------------------------------


def _predicates(program: list[Node]) -> list[str]:
    return [n["predicate"] for n in program if "predicate" in n]


def _point_qa(family, prompt, points, target, program, values, view, rng, ref) -> QA | None:
    trace = _trace(program, values, view, rng)
    if trace is None:
        return None
    book = Phrasebook.get()
    answer = format_points(points)
    lines = "\n".join(f"[Position] [{s['text']}]: {format_points([s['point']])}" for s in trace)
    return {
        "family": family,
        "kind": "point",
        "prompt": prompt,
        "question": f"{prompt} {book.point_suffix}",
        "answer": answer,
        "answer_points": points,
        "target_id": int(target),
        "ref": ref,
        "steps": with_results(program, values),
        "num_steps": count_steps(program),
        "predicates": _predicates(program),
        "reasoning_steps": trace,
        "reasoning": f"<think>{lines}</think><answer>{answer}</answer>",
    }


def _trace(program, values, view, rng) -> list[dict] | None:
    """One [Position] step per object the description names, anchors first, target last."""
    steps = []
    for node, value in zip(program, values):
        if node["op"] != "unique":
            continue
        point = sample_points(view, value, 1, rng)
        if point is None:
            return None
        steps.append({"kind": "Position", "text": node["text"], "object_id": int(value), "point": point[0]})
    return steps


def _choice_qa(kind, prompt, answer, target, program, values, predicate) -> QA:
    return {
        "family": "choice",
        "kind": kind,
        "prompt": prompt,
        "question": prompt,
        "answer": answer,
        "answer_points": [],
        "target_id": None if target is None else int(target),
        "ref": None,
        "steps": with_results(program, values),
        "num_steps": count_steps(program),
        "predicates": [predicate],
        "reasoning_steps": [],
        "reasoning": None,
    }
