"""Quantitative questions: depth, height, width, distance, angle, camera rotation and counts."""

from __future__ import annotations

import numpy as np

from ..relations import ViewFacts
from .balance import QUANTITY_WEIGHTS, weighted_index
from .common import QA, make_qa, over_objects
from .phrases import Phrasebook
from .program import Node, ProgramError, answers_to, execute
from .refer import named_like_a_prop

ONE_OBJECT = ("depth", "camera_distance", "height", "width", "rotate_horizontal", "rotate_vertical")
TWO_OBJECTS = ("distance_between", "centre_distance", "angle_between")
KINDS = ONE_OBJECT + TWO_OBJECTS + ("count",)


def quantity(views: dict[str, ViewFacts], spec: dict, steps: int, rng: np.random.Generator) -> QA | None:
    view = views["self"]
    kind = KINDS[weighted_index(rng, [QUANTITY_WEIGHTS.get(k, 1.0) for k in KINDS])]
    if kind == "count":
        return _count(views, rng)
    objs = view.askable()
    n = 2 if kind in TWO_OBJECTS else 1
    if len(objs) < n:
        return None
    group = [objs[int(i)] for i in rng.choice(len(objs), size=n, replace=False)]
    built = over_objects(view, group, {"op": "measure", "quantity": kind}, rng)
    if built is None:
        return None
    program, values, words = built
    book = Phrasebook.get()
    value = float(values[-1])
    unit = "deg" if kind in ("angle_between", "rotate_horizontal", "rotate_vertical") else "m"
    prompt = book.template("quantity", kind, rng=rng).format(a=words[0], b=words[-1])
    return make_qa("quantitative", kind, prompt, _words(kind, value), program, values, views, rng,
                   answer_value={"value": value, "unit": unit})


def _words(kind: str, value: float) -> str:
    """The answer with its unit and, in words, its rounding: a model should learn what precision
    the number claims."""
    if kind == "rotate_horizontal":
        return f"{abs(value):.0f} degrees to the {'right' if value > 0 else 'left'} (to the nearest degree)"
    if kind == "rotate_vertical":
        return f"{abs(value):.0f} degrees {'up' if value > 0 else 'down'} (to the nearest degree)"
    if kind == "angle_between":
        return f"{value:.0f} degrees (to the nearest degree)"
    if value >= 1.0:
        return f"{value:.2f} m (to the nearest centimetre)"
    return f"{value * 100:.0f} cm (to the nearest centimetre)"


def _count(views, rng) -> QA | None:
    view = views["self"]
    # Not "how many boxes?" beside a tissue box: whether it counts is anyone's guess.
    # Nor "how many plant pots?" in a room with a potted plant by the wall.
    categories = sorted({o.category for o in view.objects if o.status != "hidden"
                         and not named_like_a_prop(view, o.category)
                         and not any(answers_to(view, x, o.category) for x in view.objects if x.category != o.category)})
    if not categories:
        return None
    category = categories[int(rng.integers(len(categories)))]
    program: list[Node] = [{"op": "scene"}, {"op": "filter", "inputs": [0], "category": category, "color": None},
                           {"op": "count", "inputs": [1]}]
    try:
        values = execute(program, view)
    except ProgramError:
        return None
    name = next(o.name for o in view.objects if o.category == category)
    book = Phrasebook.get()
    prompt = book.template("quantity", "count", rng=rng).format(plural=book.plural(name))
    return make_qa("quantitative", "count", prompt, str(values[-1]), program, values, views, rng,
                   answer_value={"value": values[-1], "unit": "count"})
