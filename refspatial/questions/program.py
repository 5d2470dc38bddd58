"""A small functional program language over view facts.

A program is a list of nodes (plain dicts, so they are stored as they are). Each
node names an operation from ``OPS``, its arguments, and ``inputs``: indices of
earlier nodes whose values it consumes. Executing a program gives every node a
value; the last node's value is the answer. Any near-tie (an undecided predicate,
an ordinal whose neighbours are too close) makes the whole program ambiguous,
so no stored answer ever rests on one.
"""

from __future__ import annotations

from typing import Any, Callable

import numpy as np

from ..relations import PREDICATES, ViewFacts
from ..relations.directional import MIN_MARGIN_M, DEPTH_MARGIN_M

Node = dict[str, Any]
Value = Any  # list[int] (a set of object ids, sorted), int (one object) or bool


class ProgramError(Exception):
    """The program does not pick out a definite answer on this view."""


OPS: dict[str, Callable[..., Value]] = {}


def op(name: str):
    def register(fn: Callable[..., Value]) -> Callable[..., Value]:
        OPS[name] = fn
        return fn

    return register


@op("scene")
def _scene(view: ViewFacts, node: Node) -> list[int]:
    """All objects a viewer can see (visible or marginal); hidden ones do not exist for the viewer."""
    return [o.object_id for o in view.objects if o.status != "hidden"]


@op("filter")
def _filter(view: ViewFacts, node: Node, ids: list[int]) -> list[int]:
    """Objects of the node's category (and colour, when given). Fails if a barely visible object matches."""
    out = [i for i in ids if view.objects[i].category == node["category"]
           and node.get("color") in (None, view.objects[i].color)]
    if any(view.objects[i].status != "visible" for i in out):
        raise ProgramError(f"a barely visible {node['category']} makes the description unsafe")
    return out


@op("relate")
def _relate(view: ViewFacts, node: Node, ids: list[int], *anchors: int) -> list[int]:
    """Objects for which the predicate holds against the anchors (subject first, or last when reversed)."""
    pred = PREDICATES[node["predicate"]]
    kept = []
    for i in ids:
        if i in anchors:
            continue
        args = [i, *anchors] if not node.get("reverse") else [*anchors, i]
        verdict = pred(view, *(view.objects[a] for a in args))
        if verdict is None:
            raise ProgramError(f"{node['predicate']} is undecided for object {i}")
        if verdict:
            kept.append(i)
    return kept


ORDINAL_AXES = {
    # axis -> (coordinate of an object, end whose rank 1 has the smallest coordinate, margin)
    "left_right": (lambda o: o.lateral_m, "left", MIN_MARGIN_M),
    "front_back": (lambda o: o.forward_m, "front", MIN_MARGIN_M),
    "depth": (lambda o: o.depth_m, "near", DEPTH_MARGIN_M),
}


@op("ordinal")
def _ordinal(view: ViewFacts, node: Node, ids: list[int]) -> int:
    """The rank-th object from the named end along an axis; its neighbours must be clearly apart."""
    key, low_end, margin = ORDINAL_AXES[node["axis"]]
    order = sorted(ids, key=lambda i: key(view.objects[i]))
    if node["end"] != low_end:
        order.reverse()
    rank = node["rank"]
    if len(order) < max(rank, 2):
        raise ProgramError(f"ordinal rank {rank} over {len(order)} objects")
    coords = [key(view.objects[i]) for i in order]
    for j in (rank - 2, rank):  # neighbours before and after the chosen one
        if 0 <= j < len(coords) and abs(coords[j] - coords[rank - 1]) <= margin:
            raise ProgramError("ordinal neighbours are a near-tie")
    return order[rank - 1]


@op("unique")
def _unique(view: ViewFacts, node: Node, ids: list[int] | int) -> int:
    """The one object a description picks; anything else is not a valid referring expression."""
    if isinstance(ids, int):
        return ids
    if len(ids) != 1:
        raise ProgramError(f"description matches {len(ids)} objects")
    return ids[0]


@op("query")
def _query(view: ViewFacts, node: Node, *objects: int) -> bool:
    """Truth of a predicate over unique objects (yes/no questions)."""
    verdict = PREDICATES[node["predicate"]](view, *(view.objects[i] for i in objects))
    if verdict is None:
        raise ProgramError(f"{node['predicate']} is undecided")
    return verdict


@op("pick")
def _pick(view: ViewFacts, node: Node, a: int, b: int) -> int:
    """Of two unique objects, the one the predicate holds for against the other ("which is further left")."""
    pred = PREDICATES[node["predicate"]]
    forward, backward = pred(view, view.objects[a], view.objects[b]), pred(view, view.objects[b], view.objects[a])
    if forward and not backward:
        return a
    if backward and not forward:
        return b
    raise ProgramError(f"{node['predicate']} does not separate objects {a} and {b}")


def execute(program: list[Node], view: ViewFacts, skip: int | None = None) -> list[Value]:
    """Values of every node, in order. Raises ProgramError on ambiguity.

    ``skip`` names a node to bypass (its value becomes its first input's), which
    is how the degeneracy test removes one relation at a time.
    """
    values: list[Value] = []
    for k, node in enumerate(program):
        inputs = [values[i] for i in node.get("inputs", [])]
        if k == skip:
            values.append(inputs[0])
            continue
        fn = OPS.get(node["op"])
        if fn is None:
            raise ProgramError(f"unknown operation {node['op']!r}")
        values.append(fn(view, node, *inputs))
    return values


def answer(program: list[Node], view: ViewFacts) -> Value:
    return execute(program, view)[-1]


def count_steps(program: list[Node]) -> int:
    """RefSpatial-Bench's step count: anchor objects plus the relation phrases tied to them.

    The viewer-frame ordinals and the target's own category and colour do not
    count; a description without anchors is one step (locating the target).
    """
    relations = [n for n in program if n["op"] in ("relate", "query", "pick")]
    anchors = {i for n in relations for i in n["inputs"][1:]}
    return max(1, len(anchors) + len(relations))


def is_degenerate(program: list[Node], view: ViewFacts) -> bool:
    """True if some relation node can be skipped without changing the answer (CLEVR's test)."""
    target = answer(program, view)
    for k, node in enumerate(program):
        if node["op"] != "relate":
            continue
        try:
            if execute(program, view, skip=k)[-1] == target:
                return True
        except ProgramError:
            continue
    return False


def with_results(program: list[Node], values: list[Value]) -> list[Node]:
    """Nodes annotated with their values, the form stored in records."""
    out = []
    for node, value in zip(program, values):
        out.append({**node, "result": value if not isinstance(value, np.generic) else value.item()})
    return out
