"""Referring expressions: describe one object so that exactly one object fits.

Hierarchy (RefSpatial's captions): category, then colour, then an ordinal along
the axis where the candidates spread most, then relations to anchor objects.
Every description is compiled to a program and executed; it is kept only if it
picks the intended object and none of its relations is degenerate.
"""

from __future__ import annotations

from dataclasses import dataclass
import numpy as np

from ..relations import PREDICATES, ObjectFacts, ViewFacts
from .program import ORDINAL_AXES, Node, ProgramError, execute, is_degenerate

MAX_RANK = 3
COMBOS_CHECKED = 200_000  # part combinations checked at once per shape (array operations on bit masks)
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
    # Two parts may be combined only if they share no anchor and no predicate.
    anchors: int  # bit mask of the anchors' ids
    predicate: int  # index of the predicate
    # Candidate sets as bit masks (bit i: object i): the search tests up to ~10^5 combinations
    # per description, as whole arrays of masks at once.
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
        bit = 1 << target.object_id
        scored = {kind: [_Part(r, sum(1 << a.object_id for a in r.anchors), _PREDICATE_INDEX[r.predicate], *kept)
                         for r, kept in zip(rels, sets.get(kind, ())) if kept[0] & bit]
                  for kind, rels in parts.items()}
        view.cache[key] = (head, scored)
    return view.cache[key]


_PREDICATE_INDEX = {name: k for k, name in enumerate(sorted(PREDICATES))}


def _fitting_combinations(target: int, head: int, scored, shapes, rng) -> list[tuple[_Part, ...]]:
    """Up to COMBOS_WANTED combinations of parts with a wanted shape that, by the candidate sets,
    pick only the target with no idle part, in random order (shapes in the order given)."""
    found: list[tuple[_Part, ...]] = []
    for shape in shapes:
        lists = [scored[kind] for kind in shape]
        size = int(np.prod([len(x) for x in lists]))
        if size == 0:
            continue
        if size > COMBOS_CHECKED:  # keep a random share of each list so that the product fits
            keep = (COMBOS_CHECKED / size) ** (1 / len(lists))
            lists = [[x[int(i)] for i in rng.permutation(len(x))[:max(1, int(len(x) * keep))]] for x in lists]
        fits = np.argwhere(_fits(1 << target, head, lists))
        for row in fits[rng.permutation(len(fits))][:COMBOS_WANTED - len(found)]:
            found.append(tuple(lists[k][i] for k, i in enumerate(row)))
        if len(found) >= COMBOS_WANTED:
            break
    return found


def _fits(target: int, head: int, lists: list[list[_Part]]) -> np.ndarray:
    """For every combination (one part from each list, in order), whether it is independent
    (distinct anchors, distinct predicates) and, run in order, decides every remaining candidate,
    keeps only the target, and has no idle part (dropping any one leaves more than the target).
    Returns a boolean array with one axis per list. ``target`` is the target's bit."""
    n = len(lists)
    wide = max(head.bit_length(), *(p.kept.bit_length() | p.undecided.bit_length() | p.anchors.bit_length()
                                    for x in lists for p in x)) > 63
    dtype = object if wide else np.uint64  # Python ints past 63 objects: slower, same logic

    def column(k: int, field: str) -> np.ndarray:
        shape = [1] * n
        shape[k] = -1
        return np.array([getattr(p, field) for p in lists[k]], dtype=int if field == "predicate" else dtype).reshape(shape)

    kept = [column(k, "kept") for k in range(n)]
    ok = np.ones([len(x) for x in lists], dtype=bool)
    remaining = np.array(head, dtype=dtype)
    for k in range(n):
        ok &= (remaining & column(k, "undecided")) == 0
        remaining = remaining & kept[k]
    ok &= remaining == target
    for k in range(n):
        others = np.array(head, dtype=dtype)
        for j in range(n):
            if j != k:
                others = others & kept[j]
        ok &= others != target
    for i in range(n):
        for j in range(i + 1, n):
            ok &= ((column(i, "anchors") & column(j, "anchors")) == 0) & (column(i, "predicate") != column(j, "predicate"))
    return ok


def _kept_sets(view: ViewFacts, category: str | None, color: str | None, parts):
    """The head's candidates, and per kind, for each of its parts in order (kept, undecided): the
    candidates it keeps, and those it cannot decide (a program fails if one of those is still a
    candidate when it runs). All three are bit masks over object ids."""
    ids = [o.object_id for o in view.objects if o.status != "hidden"
           and category in (None, o.category) and color in (None, o.color)]
    if any(view.objects[i].status != "visible" for i in ids):
        return 0, {}
    return sum(1 << i for i in ids), {kind: [_kept(view, rel, ids) for rel in rels] for kind, rels in parts.items()}


def _kept(view: ViewFacts, rel: Relation, ids: list[int]) -> tuple[int, int]:
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
    return kept, undecided


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
