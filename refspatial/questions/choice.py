"""Choice questions: yes/no about a relation, and "which of the two is ..." comparisons."""

from __future__ import annotations

import numpy as np

from ..relations import PREDICATES, ViewFacts
from .common import QA, make_qa, over_objects
from .phrases import Phrasebook
from .refer import relation_predicates

PAIR_TRIES = 12


def choice(views: dict[str, ViewFacts], spec: dict, steps: int, rng: np.random.Generator) -> QA | None:
    """Yes/no (balanced: the wanted answer is drawn first) or a two-way pick."""
    book = Phrasebook.get()
    r = rng.random()
    if r < 0.45:
        return _yes_no(views, sorted(relation_predicates(book.phrased, 2)), rng)
    if r < 0.55:
        return _yes_no(views, sorted(relation_predicates(book.phrased, 1)), rng)
    return _pick(views, sorted(book.data["comparatives"]), rng)


def _yes_no(views, predicates: list[str], rng) -> QA | None:
    view = views["self"]
    name = predicates[int(rng.integers(len(predicates)))]
    pred = PREDICATES[name]
    want = bool(rng.random() < 0.5)  # the answer is drawn first, so yes and no stay balanced
    objs = view.askable()
    if len(objs) < pred.arity:
        return None
    for _ in range(PAIR_TRIES):
        group = [objs[int(i)] for i in rng.choice(len(objs), size=pred.arity, replace=False)]
        if pred(view, *group) is want:
            break
    else:
        return None
    built = over_objects(view, group, {"op": "query", "predicate": name}, rng)
    if built is None:
        return None
    program, values, words = built
    book = Phrasebook.get()
    side = group[1].front_side if len(group) > 1 else "front"
    phrase = book.relation_phrase(name, False, rng, side=side)
    if pred.arity == 1:
        prompt = book.template("yes_no_unary", rng=rng).format(a=words[0], phrase=phrase)
    else:
        prompt = book.template("yes_no", rng=rng).format(a=words[0], b=words[1], phrase=phrase)
    return make_qa("choice", "yes_no", prompt, "(A)" if values[-1] else "(B)", program, values, views, rng)


def _pick(views, predicates: list[str], rng) -> QA | None:
    view = views["self"]
    name = predicates[int(rng.integers(len(predicates)))]
    objs = view.askable()
    if len(objs) < 2:
        return None
    for _ in range(PAIR_TRIES):
        a, b = (objs[int(i)] for i in rng.choice(len(objs), size=2, replace=False))
        verdicts = (PREDICATES[name](view, a, b), PREDICATES[name](view, b, a))
        if None not in verdicts and verdicts[0] != verdicts[1]:
            break
    else:
        return None
    built = over_objects(view, (a, b), {"op": "pick", "predicate": name}, rng)
    if built is None:
        return None
    program, values, (opt_a, opt_b) = built
    ids = program[-1]["inputs"]
    book = Phrasebook.get()
    prompt = book.template("pick", rng=rng).format(comparative=book.comparative(name, rng), opt_a=opt_a, opt_b=opt_b)
    letter = "(A)" if values[-1] == values[ids[0]] else "(B)"
    return make_qa("choice", "pick", prompt, letter, program, values, views, rng, target=values[-1])
