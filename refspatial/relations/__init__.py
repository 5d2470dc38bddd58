"""The relation engine: per-view facts and the predicate registry.

Importing this package registers every predicate module.
"""

from __future__ import annotations

from itertools import combinations, permutations

from . import directional  # noqa: F401  (registers predicates)
from .facts import ObjectFacts, ViewFacts, view_facts
from .registry import PREDICATES, Predicate, Verdict, compare, predicate

__all__ = [
    "PREDICATES", "ObjectFacts", "Predicate", "Verdict", "ViewFacts", "compare", "predicate",
    "true_relations", "view_facts",
]


def true_relations(view: ViewFacts) -> list[dict]:
    """Every decided-true relation among the askable objects of a view.

    Stored with each record so that statistics and audits can count predicates
    without re-running the engine. ``between`` is listed once per unordered anchor pair.
    """
    objs = view.askable()
    out: list[dict] = []
    for name, pred in sorted(PREDICATES.items()):
        if pred.arity == 2:
            groups = permutations(objs, 2)
        else:
            groups = ((a, b, c) for a in objs for b, c in combinations(objs, 2))
        for group in groups:
            if pred(view, *group) is True:
                out.append({"predicate": name, "objects": [o.object_id for o in group]})
    return out
