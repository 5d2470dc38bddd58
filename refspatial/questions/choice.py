"""Choice questions: yes/no about a relation, and "which of the two is ..." comparisons."""

from __future__ import annotations

from itertools import permutations

import numpy as np

from ..relations import PREDICATES, ViewFacts
from .common import QA, make_qa, over_objects
from .phrases import Phrasebook
from .balance import PREDICATE_WEIGHTS, weighted_index, weighted_order
from .refer import holds_anything, relation_predicates
from .sides import SIDE_PREDICATES, side_visible


def choice(views: dict[str, ViewFacts], spec: dict, steps: int, rng: np.random.Generator) -> QA | None:
    """Yes/no (balanced: the wanted answer is drawn first) or a two-way pick."""
    book = Phrasebook.get()
    r = rng.random()
    if r < 0.40:
        return _yes_no(views, sorted(relation_predicates(book.phrased, 2)), rng)
    # One-object relations (at the edge, in a corner) have few other ways to be asked: at 17 % of
    # choices, "at a corner" was 0.98 % of a mixed set's QA (read 28, seed 97).
    if r < 0.66:
        return _yes_no(views, sorted(relation_predicates(book.phrased, 1)), rng)
    return _pick(views, sorted(book.data["comparatives"]), rng)


def _yes_no(views, predicates: list[str], rng) -> QA | None:
    view = views["self"]
    # The answer is drawn first and kept while relations are tried in random order: were it
    # redrawn on failure, "no" (far more often available) would crowd out "yes".
    want = bool(rng.random() < 0.5)
    for k in weighted_order(rng, [PREDICATE_WEIGHTS.get(p, 1.0) for p in predicates]):  # rare relations first, often
        name = predicates[int(k)]
        pred = PREDICATES[name]
        # All groups with the wanted answer (verdicts are cached), so rare relations still get asked.
        groups = [g for g in permutations(view.askable(), pred.arity) if pred(view, *g) is want
                  and (name not in SIDE_PREDICATES or side_visible(view, g[1]))
                  and (name != "outside" or holds_anything(view, g[1]))  # "not inside the empty pot?" is idle
                  and (name != "inside" or g[0].box_volume_m3 < g[1].box_volume_m3)]  # "the stool in the jar?"
        if groups:
            break
    else:
        return None
    group = groups[int(rng.integers(len(groups)))]
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
        templates = book.data["yes_no"]
        if name in book.data["yes_no_not_by_the_picture"]:
            templates = [t for t in templates if "image" not in t]
        prompt = book.pick(templates, rng).format(a=words[0], b=words[1], phrase=phrase)
    return make_qa("choice", "yes_no", prompt, "(A)" if values[-1] else "(B)", program, values, views, rng)


def _pick(views, predicates: list[str], rng) -> QA | None:
    view = views["self"]
    # Weighted like descriptions: wider/narrower hold by every reading of wide for few pairs, so
    # drawn evenly they fell under 1 % of a mixed dataset (0.7 %, seed 45).
    name = predicates[weighted_index(rng, [PREDICATE_WEIGHTS.get(p, 1.0) for p in predicates])]
    pred = PREDICATES[name]
    pairs = [(a, b) for a, b in permutations(view.askable(), 2)
             if None not in (pred(view, a, b), pred(view, b, a)) and pred(view, a, b) != pred(view, b, a)]
    if not pairs:
        return None
    a, b = pairs[int(rng.integers(len(pairs)))]
    built = over_objects(view, (a, b), {"op": "pick", "predicate": name}, rng)
    if built is None:
        return None
    program, values, (opt_a, opt_b) = built
    ids = program[-1]["inputs"]
    book = Phrasebook.get()
    prompt = book.template("pick", rng=rng).format(comparative=book.comparative(name, rng), opt_a=opt_a, opt_b=opt_b)
    letter = "(A)" if values[-1] == values[ids[0]] else "(B)"
    return make_qa("choice", "pick", prompt, letter, program, values, views, rng, target=values[-1])
