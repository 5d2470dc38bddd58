"""The relation engine: per-view facts and the registry of all 31 predicates.

Importing this package registers every predicate module.
"""

from __future__ import annotations

from itertools import combinations, permutations

from . import contact, directional, free_space, metric, placement, vertical  # noqa: F401  (registers predicates)
from .facts import TABLE, ObjectFacts, ViewFacts, view_facts
from .registry import PREDICATES, Predicate, Quantity, Verdict, compare, predicate

__all__ = [
    "PREDICATES", "TABLE", "ObjectFacts", "Predicate", "Quantity", "Verdict", "ViewFacts", "compare",
    "predicate", "computed_relations", "view_facts",
]


def _groups(pred: Predicate, objs: list[ObjectFacts]):
    if pred.arity == 1:
        return ((a,) for a in objs)
    if pred.arity == 2:
        return combinations(objs, 2) if pred.symmetric else permutations(objs, 2)
    return ((a, b, c) for a in objs for b, c in combinations(objs, 2))


def computed_relations(view: ViewFacts) -> list[dict]:
    """What the engine establishes about a view, for statistics and audits.

    Relations: every decided-true tuple (symmetric ones once per unordered pair,
    ``between`` once per unordered anchor pair). Measures: the value and unit for
    every object or pair it applies to. Free space: each anchor and direction
    with a solution, its point and free area. Only askable objects take part.
    """
    objs = view.askable()
    out: list[dict] = []
    for name, pred in sorted(PREDICATES.items()):
        if pred.kind == "region":
            out.extend(_free_space_entries(view, objs))
            continue
        groups = _groups(pred, objs)
        if pred.candidates is not None:  # a relation: only its true groups are listed
            maybe = pred.candidates(view, objs)
            groups = (g for g in groups if tuple(o.object_id for o in g) in maybe)
        pair = pred.arity == 2
        for group in groups:
            value = pred.pair(view, *group) if pair else pred(view, *group)  # the memo's quicker read for two
            listed = value is True if pred.kind == "relation" else value is not None  # else a measure
            if not listed:
                continue  # the id list is made only for what is listed
            entry = {"predicate": name, "objects": [o.object_id for o in group]}
            if pred.kind == "measure":
                entry.update(value=round(value.value, 4), unit=value.unit)
            out.append(entry)
    return out


def _free_space_entries(view: ViewFacts, objs: list[ObjectFacts]) -> list[dict]:
    out = []
    for a in objs:
        for direction in free_space.DIRECTIONS:
            answer = PREDICATES["free_space"](view, a, direction=direction)
            if answer is not None:
                out.append({"predicate": "free_space", "objects": [a.object_id], "direction": direction,
                            "point": list(answer.point), "area_m2": round(answer.area_m2, 4)})
    return out
