"""Touching and separated: physical contact after settling, or a clear gap."""

from __future__ import annotations

from .facts import ObjectFacts, ViewFacts
from .registry import Verdict, predicate

SEPARATED_GAP_M = 0.02  # a ground gap wider than this between footprints is clearly apart


@predicate("touching", family="touch_far_from", arity=2, frame="world", inverse="touching", symmetric=True)
def touching(v: ViewFacts, a: ObjectFacts, b: ObjectFacts) -> Verdict:
    """The physics engine reports contact between A and B in the settled scene.

    True: a contact pair (penetration or gap < 2 mm). False: no contact and the
    oriented footprints are more than 2 cm apart on the ground (footprint gap is
    a lower bound of the true gap, so this never misses a contact). Undecided
    otherwise (close without contact, e.g. a cup hovering over a plate's rim).
    """
    if (min(a.object_id, b.object_id), max(a.object_id, b.object_id)) in v.contacts:
        return True
    if v.footprint_gap(a, b) > SEPARATED_GAP_M:
        return False
    return None


@predicate("separated", family="touch_far_from", arity=2, frame="world", inverse="separated", symmetric=True)
def separated(v: ViewFacts, a: ObjectFacts, b: ObjectFacts) -> Verdict:
    """A and B are clearly apart: the negation of ``touching`` with the same undecided band."""
    verdict = touching(v, a, b)
    return None if verdict is None else not verdict
