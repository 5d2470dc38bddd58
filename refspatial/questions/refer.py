"""Referring expressions: describe one object so that exactly one object fits.

Hierarchy (RefSpatial's captions): category, then colour, then an ordinal along
the axis where the candidates spread most, then relations to anchor objects.
Every description is compiled to a program and executed; it is kept only if it
picks the intended object and none of its relations is degenerate.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..relations import ObjectFacts, ViewFacts
from .program import ORDINAL_AXES, Node, ProgramError, execute, is_degenerate

BINARY = ("left_of", "right_of", "in_front_of", "behind", "closer_to_camera")
MAX_RANK = 3


@dataclass(frozen=True)
class Ordinal:
    axis: str  # a key of ORDINAL_AXES
    end: str
    rank: int  # 1 = the extreme one


@dataclass(frozen=True)
class Relation:
    predicate: str
    anchors: tuple["Ref", ...]
    reverse: bool = False  # the anchor is the predicate's subject ("farther from the camera than")

    @property
    def steps(self) -> int:
        """Anchors plus the one phrase tying them to the subject."""
        return len(self.anchors) + 1


@dataclass(frozen=True)
class Ref:
    object_id: int  # what the description is meant to pick (checked, never trusted)
    category: str
    name: str
    color: str | None = None
    ordinal: Ordinal | None = None
    relations: tuple[Relation, ...] = ()

    @property
    def steps(self) -> int:
        return max(1, sum(r.steps for r in self.relations))


def compile_ref(ref: Ref, program: list[Node], texts: dict[Ref, str] | None = None) -> int:
    """Append the nodes that resolve ``ref``; returns the index of its ``unique`` node.

    ``texts`` (from ``Phrasebook.describe``) labels each unique node with the words
    that name it, which reasoning traces and audits quote.
    """
    idx = _add(program, {"op": "scene"})
    idx = _add(program, {"op": "filter", "inputs": [idx], "category": ref.category, "color": ref.color})
    for rel in ref.relations:
        anchors = [compile_ref(a, program, texts) for a in rel.anchors]
        idx = _add(program, {"op": "relate", "inputs": [idx, *anchors], "predicate": rel.predicate,
                             "reverse": rel.reverse})
    if ref.ordinal:
        o = ref.ordinal
        idx = _add(program, {"op": "ordinal", "inputs": [idx], "axis": o.axis, "end": o.end, "rank": o.rank})
    node: Node = {"op": "unique", "inputs": [idx]}
    if texts is not None:
        node["text"] = texts[ref]
    return _add(program, node)


def _add(program: list[Node], node: Node) -> int:
    program.append(node)
    return len(program) - 1


def resolves(ref: Ref, view: ViewFacts) -> bool:
    """The description picks exactly its object, without near-ties or idle relations."""
    program: list[Node] = []
    compile_ref(ref, program)
    try:
        return execute(program, view)[-1] == ref.object_id and not is_degenerate(program, view)
    except ProgramError:
        return False


def simple_refs(view: ViewFacts, target: ObjectFacts) -> list[Ref]:
    """Anchor-free descriptions of the target that resolve, most preferred first."""
    base = Ref(target.object_id, target.category, target.name)
    coloured = Ref(target.object_id, target.category, target.name, target.color)
    out = [r for r in (base, coloured) if resolves(r, view)]
    for head in (base, coloured):
        for ordinal in _ordinals(view, head, target):
            ref = Ref(head.object_id, head.category, head.name, head.color, ordinal)
            if resolves(ref, view):
                out.append(ref)
    return out


def _ordinals(view: ViewFacts, head: Ref, target: ObjectFacts) -> list[Ordinal]:
    """Ordinals over the head's candidates, axes with the most spread first."""
    ids = [o.object_id for o in view.objects if o.category == head.category
           and head.color in (None, o.color) and o.status != "hidden"]
    if len(ids) < 2:
        return []
    options = []
    for axis, (key, low_end, _) in ORDINAL_AXES.items():
        coords = np.array([key(view.objects[i]) for i in ids])
        if not np.all(np.isfinite(coords)):
            continue
        ascending = sorted(ids, key=lambda i: key(view.objects[i]))
        high_end = _other_end(axis, low_end)
        for end, order in ((low_end, ascending), (high_end, ascending[::-1])):
            rank = order.index(target.object_id) + 1
            if rank <= MAX_RANK:
                spread = float(coords.std()) / (1.0 if axis != "depth" else 2.0)
                options.append((-spread, rank, Ordinal(axis, end, rank)))
    return [o for *_, o in sorted(options, key=lambda t: (t[0], t[1]))]


def _other_end(axis: str, low_end: str) -> str:
    return {"left": "right", "front": "back", "near": "far"}[low_end]


def anchored_refs(view: ViewFacts, target: ObjectFacts, steps: int, rng: np.random.Generator) -> list[Ref]:
    """Descriptions with anchors whose step count is ``steps`` (2 to 5), in random order.

    Parts: a binary relation costs 2 steps (anchor + phrase), ``between`` costs 3
    (two anchors + phrase). 2 = binary, 3 = between, 4 = two binaries, 5 = between + binary.
    """
    anchors = {o.object_id: simple_refs(view, o)[:1] for o in view.askable() if o.object_id != target.object_id}
    anchors = {k: v[0] for k, v in anchors.items() if v}
    binaries = _binary_parts(view, target, anchors)
    betweens = _between_parts(view, target, anchors) if steps in (3, 5) else []
    combos: list[tuple[Relation, ...]] = {
        2: [(b,) for b in binaries],
        3: [(b,) for b in betweens],
        4: [(a, b) for i, a in enumerate(binaries) for b in binaries[i + 1:] if _distinct(a, b)],
        5: [(a, b) for a in betweens for b in binaries if _distinct(a, b)],
    }.get(steps, [])
    order = rng.permutation(len(combos))
    out = []
    for k in order:
        rels = combos[int(k)]
        for color in (None, target.color):
            ref = Ref(target.object_id, target.category, target.name, color, relations=rels)
            if resolves(ref, view):
                out.append(ref)
                break
        if len(out) >= 4:  # enough to choose from; resolving is the costly part
            break
    return out


def _distinct(a: Relation, b: Relation) -> bool:
    ids_a = {x.object_id for x in a.anchors}
    return not ids_a & {x.object_id for x in b.anchors} and a.predicate != b.predicate


def _binary_parts(view: ViewFacts, target: ObjectFacts, anchors: dict[int, Ref]) -> list[Relation]:
    from ..relations import PREDICATES

    parts = []
    for aid, ref in anchors.items():
        anchor = view.objects[aid]
        for name in BINARY:
            pred = PREDICATES[name]
            if pred(view, target, anchor) is True:
                parts.append(Relation(name, (ref,)))
            if pred.inverse is None and pred(view, anchor, target) is True:
                parts.append(Relation(name, (ref,), reverse=True))
    return parts


def _between_parts(view: ViewFacts, target: ObjectFacts, anchors: dict[int, Ref]) -> list[Relation]:
    from ..relations import PREDICATES

    ids = sorted(anchors)
    parts = []
    for i, b in enumerate(ids):
        for c in ids[i + 1:]:
            if PREDICATES["between"](view, target, view.objects[b], view.objects[c]) is True:
                parts.append(Relation("between", (anchors[b], anchors[c])))
    return parts
