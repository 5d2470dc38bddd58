"""Referring expressions: describe one object so that exactly one object fits.

Hierarchy (RefSpatial's captions): category, then colour, then an ordinal along
the axis where the candidates spread most, then relations to anchor objects.
Every description is compiled to a program and executed; it is kept only if it
picks the intended object and none of its relations is degenerate.
"""

from __future__ import annotations

from dataclasses import dataclass
from itertools import islice, product

import numpy as np

from ..relations import PREDICATES, ObjectFacts, ViewFacts
from .program import ORDINAL_AXES, Node, ProgramError, execute, is_degenerate

MAX_RANK = 3
COMBOS_CHECKED = 4000  # part combinations checked by candidate sets per shape (cheap set operations)
COMBOS_WANTED = 24  # enough fitting combinations to choose from with variety


def relation_predicates(phrased: set[str], arity: int) -> list[str]:
    """Relation predicates of the given arity that have phrases (so they can be put in words)."""
    return sorted(n for n, p in PREDICATES.items() if p.kind == "relation" and p.arity == arity and n in phrased)


@dataclass(frozen=True)
class Ordinal:
    axis: str  # a key of ORDINAL_AXES
    end: str
    rank: int  # 1 = the extreme one


@dataclass(frozen=True)
class Relation:
    predicate: str
    anchors: tuple["Ref", ...]  # none for unary predicates (at the table's edge)
    reverse: bool = False  # the anchor is the predicate's subject ("farther from the camera than")

    @property
    def steps(self) -> int:
        """Anchors plus the one phrase tying them to the subject."""
        return len(self.anchors) + 1


@dataclass(frozen=True)
class Ref:
    object_id: int  # what the description is meant to pick (checked, never trusted)
    category: str | None  # None: any object ("the object left of the mug")
    name: str
    color: str | None = None
    ordinal: Ordinal | None = None
    relations: tuple[Relation, ...] = ()

    @property
    def steps(self) -> int:
        return max(1, sum(r.steps for r in self.relations))


def compile_ref(ref: Ref, program: list[Node], texts: dict[Ref, str] | None = None, view: str = "self") -> int:
    """Append the nodes that resolve ``ref``; returns the index of its ``unique`` node.

    ``texts`` (from ``Phrasebook.describe``) labels each unique node with the words
    that name it, which reasoning traces and audits quote.
    """
    idx = _add(program, {"op": "scene", "view": view})
    idx = _add(program, {"op": "filter", "inputs": [idx], "category": ref.category, "color": ref.color,
                         "view": view})
    for rel in ref.relations:
        anchors = [compile_ref(a, program, texts, view) for a in rel.anchors]
        idx = _add(program, {"op": "relate", "inputs": [idx, *anchors], "predicate": rel.predicate,
                             "reverse": rel.reverse, "view": view})
    if ref.ordinal:
        o = ref.ordinal
        idx = _add(program, {"op": "ordinal", "inputs": [idx], "axis": o.axis, "end": o.end, "rank": o.rank,
                             "view": view})
    node: Node = {"op": "unique", "inputs": [idx], "view": view}
    if texts is not None:
        node["text"] = texts[ref]
    return _add(program, node)


def _add(program: list[Node], node: Node) -> int:
    if node.get("view") == "self":
        del node["view"]  # the default; keeps stored programs short
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
    """Anchor-free descriptions of the target that resolve, most preferred first (memoised per view)."""
    key = ("simple_refs", target.object_id)
    if key not in view.cache:
        view.cache[key] = _simple_refs(view, target)
    return view.cache[key]


def _simple_refs(view: ViewFacts, target: ObjectFacts) -> list[Ref]:
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
        high_end = {"left": "right", "front": "back", "near": "far"}[low_end]
        for end, order in ((low_end, ascending), (high_end, ascending[::-1])):
            rank = order.index(target.object_id) + 1
            if rank <= MAX_RANK:
                spread = float(coords.std()) / (1.0 if axis != "depth" else 2.0)
                options.append((-spread, rank, Ordinal(axis, end, rank)))
    return [o for *_, o in sorted(options, key=lambda t: (t[0], t[1]))]


# Part kinds and their step costs: unary 1 (phrase), binary 2 (anchor + phrase), between 3.
COMBOS = {1: (("unary",),), 2: (("binary",),), 3: (("between",), ("binary", "unary")),
          4: (("binary", "binary"),), 5: (("between", "binary"), ("binary", "binary", "unary"))}


def anchored_refs(view: ViewFacts, target: ObjectFacts, steps: int, rng: np.random.Generator,
                  phrased: set[str], any_category: bool = False) -> list[Ref]:
    """Descriptions with relations whose step count is ``steps`` (1 to 5), in random order.

    ``phrased`` names the predicates the phrasebook can word. With ``any_category``
    the head is "the object" (identify-from-relations questions).
    """
    parts = _parts(view, target, phrased)
    heads = [None] if any_category else [None, target.color]
    category = None if any_category else target.category
    out: list[Ref] = []
    for color in heads:
        empty = ("no_fit", target.object_id, category, color, steps)
        if empty in view.cache:  # a search that found nothing is not worth repeating on this view
            continue
        head, scored = _scored_parts(view, target, category, color, parts)
        combos = _fitting_combinations(target.object_id, head, scored, COMBOS.get(steps, ()), rng)
        if not combos:
            view.cache[empty] = True
        # Choose the first part's predicate uniformly, so frequent relations do not crowd out rare ones.
        while combos and len(out) < 2:
            names = sorted({c[0].rel.predicate for c in combos})
            name = names[int(rng.integers(len(names)))]
            same = [c for c in combos if c[0].rel.predicate == name]
            chosen = same[int(rng.integers(len(same)))]
            combos.remove(chosen)
            rels = tuple(p.rel for p in chosen)
            ref = Ref(target.object_id, category, "object" if any_category else target.name, color, relations=rels)
            if resolves(ref, view):  # the sets already say it fits; the program is the final word
                out.append(ref)
        if out:
            break
    return out


@dataclass(frozen=True, eq=False)
class _Part:
    """A relation part with what it does to one head's candidates (precomputed for fast search)."""

    rel: Relation
    # Bits of the anchors' ids, and above them one bit for the predicate: two parts may be
    # combined only if their tags share no bit (distinct anchors, distinct predicates).
    tag: int
    # Candidate sets as bit masks (bit i: object i): the search tests ~10^4 combinations per
    # description, and integer AND is several times faster than frozenset intersection.
    kept: int  # candidates it keeps
    undecided: int  # candidates it cannot decide


def _parts(view: ViewFacts, target: ObjectFacts, phrased: set[str]) -> dict[str, list[Relation]]:
    """Relation parts that hold for the target, by kind (memoised per view and target)."""
    key = ("parts", target.object_id)
    if key not in view.cache:
        anchors = {o.object_id: r[0] for o in view.askable() if o.object_id != target.object_id
                   and (r := simple_refs(view, o)[:1])}
        view.cache[key] = {
            "unary": [Relation(n, ()) for n in relation_predicates(phrased, 1) if _holds(view, n, [target])],
            "binary": _binary_parts(view, target, anchors, phrased),
            "between": _between_parts(view, target, anchors) if "between" in phrased else [],
        }
    return view.cache[key]


def _scored_parts(view: ViewFacts, target: ObjectFacts, category: str | None, color: str | None, parts):
    """The head's candidates and, per kind, the parts that keep the target (memoised per view)."""
    key = ("scored", target.object_id, category, color)
    if key not in view.cache:
        head, sets = _kept_sets(view, category, color, parts)
        bit, shift = 1 << target.object_id, len(view.objects)
        scored = {kind: [_Part(r, sum(1 << a.object_id for a in r.anchors) | _PREDICATE_BITS[r.predicate] << shift,
                               *sets[r])
                         for r in rels if r in sets and sets[r][0] & bit]
                  for kind, rels in parts.items()}
        view.cache[key] = (head, scored)
    return view.cache[key]


_PREDICATE_BITS = {name: 1 << k for k, name in enumerate(sorted(PREDICATES))}  # placed above the object-id bits


def _fitting_combinations(target: int, head: int, scored, shapes, rng) -> list[tuple[_Part, ...]]:
    """Every combination of parts with a wanted shape that, by the candidate sets, picks only the
    target with no idle part (checking at most COMBOS_CHECKED per shape, in random order)."""
    found = []
    for shape in shapes:
        lists = [[scored[kind][int(i)] for i in rng.permutation(len(scored[kind]))] for kind in shape]
        for combo in islice(product(*lists), COMBOS_CHECKED):
            if len(combo) > 1 and not _independent(combo):
                continue
            if _picks_only(1 << target, head, [(p.kept, p.undecided) for p in combo]):
                found.append(combo)
                if len(found) >= COMBOS_WANTED:
                    return found
    return found


def _independent(combo: tuple[_Part, ...]) -> bool:
    """Distinct anchors and distinct predicates across the parts."""
    seen = 0
    for p in combo:
        if seen & p.tag:
            return False
        seen |= p.tag
    return True


def _kept_sets(view: ViewFacts, category: str | None, color: str | None, parts):
    """The head's candidates, and for each part (kept, undecided): the candidates it keeps, and
    those it cannot decide (a program fails if one of those is still a candidate when it runs).
    All three are bit masks over object ids."""
    ids = [o.object_id for o in view.objects if o.status != "hidden"
           and category in (None, o.category) and color in (None, o.color)]
    if any(view.objects[i].status != "visible" for i in ids):
        return 0, {}
    out = {}
    for rel in (r for group in parts.values() for r in group):
        anchors = [a.object_id for a in rel.anchors]
        kept = undecided = 0
        for i in ids:
            if i in anchors:
                continue
            args = [*anchors, i] if rel.reverse else [i, *anchors]
            verdict = PREDICATES[rel.predicate](view, *(view.objects[k] for k in args))
            if verdict is None:
                undecided |= 1 << i
            elif verdict:
                kept |= 1 << i
        out[rel] = (kept, undecided)
    return sum(1 << i for i in ids), out


def _picks_only(target: int, head: int, parts: list[tuple[int, int]]) -> bool:
    """Run in order, the parts decide every remaining candidate, keep only the target, and none of
    them is idle (dropping any one leaves more than the target). Sets are bit masks; ``target``
    is the target's bit."""
    remaining = head
    for kept, undecided in parts:
        if remaining & undecided:
            return False
        remaining &= kept
    if remaining != target:
        return False
    for k in range(len(parts)):
        others = head
        for j, (kept, _) in enumerate(parts):
            if j != k:
                others &= kept
        if others == target:
            return False
    return True


def _holds(view: ViewFacts, name: str, objs: list[ObjectFacts]) -> bool:
    return PREDICATES[name](view, *objs) is True


def _binary_parts(view: ViewFacts, target: ObjectFacts, anchors: dict[int, Ref], phrased: set[str]):
    parts = []
    for name in relation_predicates(phrased, 2):
        pred = PREDICATES[name]
        for aid, ref in anchors.items():
            anchor = view.objects[aid]
            if _holds(view, name, [target, anchor]):
                parts.append(Relation(name, (ref,)))
            if pred.inverse is None and f"{name}:reverse" in phrased and _holds(view, name, [anchor, target]):
                parts.append(Relation(name, (ref,), reverse=True))
    return parts


def _between_parts(view: ViewFacts, target: ObjectFacts, anchors: dict[int, Ref]) -> list[Relation]:
    ids = sorted(anchors)
    return [Relation("between", (anchors[b], anchors[c])) for i, b in enumerate(ids) for c in ids[i + 1:]
            if _holds(view, "between", [target, view.objects[b], view.objects[c]])]
