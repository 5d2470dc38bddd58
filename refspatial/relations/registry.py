"""One registry for every spatial predicate.

A predicate is a small function of view facts and object facts returning True,
False, or None when the case is too close to call (the *undecided band*); no
question may rest on an undecided value. Its docstring states the definition,
frame and thresholds.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, Optional

from .facts import ObjectFacts, ViewFacts

Verdict = Optional[bool]


@dataclass(frozen=True)
class Predicate:
    name: str
    family: str
    arity: int  # objects it relates, the subject first
    frame: str  # "viewer", "world", "image", "camera" or "object"
    inverse: str | None  # predicate that holds with the first two objects swapped
    fn: Callable[..., Verdict]

    def __call__(self, view: ViewFacts, *objects: ObjectFacts) -> Verdict:
        if len(objects) != self.arity:
            raise TypeError(f"{self.name} relates {self.arity} objects, got {len(objects)}")
        if len({o.object_id for o in objects}) != len(objects):
            return None  # an object is never related to itself
        return self.fn(view, *objects)


PREDICATES: dict[str, Predicate] = {}


def predicate(name: str, family: str, arity: int, frame: str, inverse: str | None = None):
    def register(fn: Callable[..., Verdict]) -> Callable[..., Verdict]:
        if name in PREDICATES:
            raise ValueError(f"predicate {name!r} registered twice")
        PREDICATES[name] = Predicate(name, family, arity, frame, inverse, fn)
        return fn

    return register


def compare(difference: float, margin: float) -> Verdict:
    """True above +margin, False below -margin, undecided in between."""
    if difference > margin:
        return True
    if difference < -margin:
        return False
    return None
