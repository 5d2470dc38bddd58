"""One registry for every spatial predicate.

Three kinds share the registry:
- "relation": returns True, False, or None when the case is too close to call
  (the *undecided band*); no question may rest on an undecided value.
- "measure": returns a Quantity (a number with its unit, rounded only in text),
  or None when it cannot be measured reliably.
- "region": the free-space solver, returning a FreeSpace answer or None.
Each function's docstring states its definition, frame and thresholds.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Callable, Optional

from .facts import ObjectFacts, ViewFacts

Verdict = Optional[bool]


@dataclass(frozen=True)
class Quantity:
    value: float  # in ``unit``, unrounded
    unit: str  # "m", "deg", "m3"


@dataclass(frozen=True)
class Predicate:
    name: str
    family: str
    arity: int  # objects it relates, the subject first
    frame: str  # "viewer", "world", "image", "camera" or "object"
    inverse: str | None  # predicate that holds with the first two objects swapped
    fn: Callable[..., Any]
    kind: str = "relation"  # "relation", "measure" or "region"
    symmetric: bool = False  # p(a, b) == p(b, a): listed once per unordered pair
    # For a relation rarely true of a group: (view, objects) -> the id tuples for which it may
    # hold (a superset of the true ones), so that listing every true group skips the rest.
    candidates: Callable[..., set[tuple[int, ...]]] | None = None

    def __post_init__(self) -> None:
        # Asked at every call: one attribute read instead of two and a comparison.
        object.__setattr__(self, "_one_verdict_for_both_orders", self.symmetric and self.kind == "relation")

    def __call__(self, view: ViewFacts, *objects: ObjectFacts, **options: Any) -> Any:
        if options:
            self._check(objects)
            return None if len({o.object_id for o in objects}) != len(objects) else self.fn(view, *objects, **options)
        # The memo is looked up first: question search asks ~10^5 verdicts per scene, most of them again
        # (the key is spelt out for the usual arities: building it is most of a hit's cost).
        if len(objects) == 2:
            a, b = objects[0].object_id, objects[1].object_id
            # One verdict for both orders of a symmetric relation (test_relations checks they agree).
            key = (self.name, b, a) if a > b and self._one_verdict_for_both_orders else (self.name, a, b)
        else:
            key = (self.name, *[o.object_id for o in objects])
        # A lookup that may miss, not a caught KeyError: the relation table meets every verdict
        # first (a thousand misses a view), and raising cost ten times a lookup.
        value = view.cache.get(key, _UNKNOWN)
        return self._worked_out(view, objects, key) if value is _UNKNOWN else value

    def pair(self, view: ViewFacts, a: ObjectFacts, b: ObjectFacts) -> Any:
        """``self(view, a, b)`` of a two-object predicate: the memo read without the general call's
        argument handling (the description search asks some 1,300 verdicts a record, nearly all
        known already)."""
        i, j = a.object_id, b.object_id
        key = (self.name, j, i) if i > j and self._one_verdict_for_both_orders else (self.name, i, j)
        value = view.cache.get(key, _UNKNOWN)
        return self._worked_out(view, (a, b), key) if value is _UNKNOWN else value

    def _worked_out(self, view: ViewFacts, objects: tuple[ObjectFacts, ...], key: tuple) -> Any:
        """The value of a memo entry not yet made, made."""
        self._check(objects)
        # A predicate with an inverse answers what the inverse answers with the two objects swapped
        # (right_of(a, b) is left_of(b, a) by definition; test_relations checks every pair): a
        # verdict known one way is not worked out again the other (a tenth of the relation stage).
        if self.inverse is not None and self.inverse != self.name and len(objects) == 2:
            swapped = (self.inverse, key[2], key[1])
            if swapped in view.cache:
                value = view.cache[key] = view.cache[swapped]
                return value
        # An object is never related to itself.
        value = None if len(set(key[1:])) != len(objects) else self.fn(view, *objects)
        view.cache[key] = value
        return value

    def _check(self, objects: tuple[ObjectFacts, ...]) -> None:
        if len(objects) != self.arity:
            raise TypeError(f"{self.name} relates {self.arity} objects, got {len(objects)}")


PREDICATES: dict[str, Predicate] = {}
_UNKNOWN = object()  # a memo entry not yet made (None is a verdict: undecided)


def predicate(name: str, family: str, arity: int, frame: str, inverse: str | None = None,
              kind: str = "relation", symmetric: bool = False,
              candidates: Callable[..., set[tuple[int, ...]]] | None = None):
    def register(fn: Callable[..., Any]) -> Callable[..., Any]:
        if name in PREDICATES:
            raise ValueError(f"predicate {name!r} registered twice")
        if candidates is not None and kind != "relation":
            raise ValueError(f"predicate {name!r}: only a relation lists its true groups from candidates")
        PREDICATES[name] = Predicate(name, family, arity, frame, inverse, fn, kind, symmetric, candidates)
        return fn

    return register


def compare(difference: float, margin: float) -> Verdict:
    """True above +margin, False below -margin, undecided in between."""
    if difference > margin:
        return True
    if difference < -margin:
        return False
    return None
