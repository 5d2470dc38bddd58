"""Referring expressions: describe one object so that exactly one object fits.

Hierarchy (RefSpatial's captions): category, then colour, then an ordinal along
the axis where the candidates spread most, then relations to anchor objects,
which may themselves be picked by a relation ("the cup left of the object behind
the book": RoboRefer's multi-step chains through an intermediate object).
Every description is compiled to a program and executed; it is kept only if it
picks the intended object and none of its relations is degenerate.
"""

from __future__ import annotations

import functools
import itertools
import math
from dataclasses import dataclass
from typing import Callable

import numpy as np

from ..colour import DISTINCT_DELTA_E, delta_e
from ..colour_words import reads_as
from .balance import PREDICATE_WEIGHTS, weighted_index

from ..relations import PREDICATES, ObjectFacts, ViewFacts
from ..relations.directional import between_candidates
from .program import ORDINAL_AXES, Node, ProgramError, answers_to, execute, is_degenerate
from .sides import SIDE_PREDICATES, side_visible

MAX_RANK = 3
COMBOS_CHECKED = 200_000  # part combinations checked at once per shape (array operations on bit masks)
COMBOS_WANTED = 24  # enough fitting combinations to choose from with variety
# Up to this many combinations, plain loops beat the array operations' set-up (~40 us a call):
# most searches test one kind of part, a few dozen parts.
LOOPED_COMBOS = 64


def relation_predicates(phrased: frozenset[str], arity: int) -> tuple[str, ...]:
    """Relation predicates of the given arity that have phrases (so they can be put in words)."""
    return _relation_predicates(frozenset(phrased), arity)  # the phrasebook's own set is not copied


@functools.lru_cache(maxsize=16)  # every description search asks, always of the phrasebook's one set
def _relation_predicates(phrased: frozenset[str], arity: int) -> tuple[str, ...]:
    return tuple(sorted(n for n, p in PREDICATES.items() if p.kind == "relation" and p.arity == arity and n in phrased))


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


@dataclass(frozen=True)
class Ref:
    object_id: int  # what the description is meant to pick (checked, never trusted)
    category: str | None  # None: any object ("the object left of the mug")
    name: str
    color: str | None = None
    ordinal: Ordinal | None = None
    relations: tuple[Relation, ...] = ()

    def __hash__(self) -> int:
        # The dataclass's own hash, kept once made: descriptions key the search's dicts, and
        # hashing one walks every anchor's description below it (a tenth of the question stage).
        try:
            return self.__dict__["_hash"]
        except KeyError:
            h = hash((self.object_id, self.category, self.name, self.color, self.ordinal, self.relations))
            object.__setattr__(self, "_hash", h)
            return h

    @functools.cached_property  # kept beside the hash: the search asks it of every part it scores
    def named(self) -> int:
        """Bit mask of this object and every object its own relations name, down through chains:
        what naming it as an anchor names."""
        return 1 << self.object_id | _named_objects(self.relations)

    @property
    def steps(self) -> int:
        return max(1, _relation_steps(self.relations))

    @property
    def anchor_steps(self) -> int:
        """Steps as an anchor: the anchor object, plus the relations that pick it when it is chained."""
        return 1 + _relation_steps(self.relations)


def _relation_steps(relations: tuple[Relation, ...]) -> int:
    """One step per phrase, plus each anchor's steps once: "left of and behind the plate" finds the
    plate once (RefSpatial-Bench counts anchor objects and phrases)."""
    anchors = {a for r in relations for a in r.anchors}
    return len(relations) + sum(a.anchor_steps for a in anchors)


def object_key(target: int, relations, ordinals) -> str:
    """What a question about one object asks, wording aside: the object, the relations of its
    description as (predicate, reversed, anchor object ids), chained anchors' included, and the
    ordinals (axis, end, rank). Colour and category words do not count: "the basket" and "the
    brown basket" with one basket seen ask the same."""
    return repr((int(target), sorted(set(relations)), sorted(set(ordinals))))


def ref_key(ref: Ref) -> str:
    """``object_key`` of a description, read from the description itself (before any program
    runs; the program's own steps give the same key)."""
    relations, ordinals = set(), set()
    todo = [ref]
    while todo:
        r = todo.pop()
        if r.ordinal is not None:
            ordinals.add((r.ordinal.axis, r.ordinal.end, r.ordinal.rank))
        for rel in r.relations:
            relations.add((rel.predicate, bool(rel.reverse), tuple(a.object_id for a in rel.anchors)))
            todo.extend(rel.anchors)
    return object_key(ref.object_id, relations, ordinals)


def compile_ref(ref: Ref, program: list[Node], texts: dict[Ref, str] | None = None, view: str = "self") -> int:
    """Append the nodes that resolve ``ref``; returns the index of its ``unique`` node.

    ``texts`` (from ``Phrasebook.describe``) labels each unique node with the words
    that name it, which reasoning traces and audits quote.
    """
    idx = _add(program, {"op": "scene", "view": view})
    idx = _add(program, {"op": "filter", "inputs": [idx], "category": ref.category, "color": ref.color,
                         "view": view})
    compiled: dict[Ref, int] = {}  # an anchor named by two phrases is one node, found once
    for rel in ref.relations:
        anchors = [compiled[a] if a in compiled else compiled.setdefault(a, compile_ref(a, program, texts, view))
                   for a in rel.anchors]
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
    """The description picks exactly its object, without near-ties or idle relations, by a name
    that no background piece of the room also answers to (memoised per view: one in six
    descriptions the search draws has been checked before)."""
    key = ("resolves", ref)
    if key not in view.cache:
        view.cache[key] = _resolves(ref, view)
    return view.cache[key]


def _resolves(ref: Ref, view: ViewFacts) -> bool:
    if named_like_a_prop(view, ref.category):
        return False
    program: list[Node] = []
    compile_ref(ref, program)
    try:
        values = execute(program, view)
        return values[-1] == ref.object_id and not is_degenerate(program, view, values)
    except ProgramError:
        return False


def simple_refs(view: ViewFacts, target: ObjectFacts) -> list[Ref]:
    """Anchor-free descriptions of the target that resolve, most preferred first (memoised per view)."""
    key = ("simple_refs", target.object_id)
    if key not in view.cache:
        view.cache[key] = _simple_refs(view, target)
    return view.cache[key]


# A colour word is used only where it reads clearly: a tissue box whose mean colour lay 11.5 from
# the "white" and the "gray" prototypes alike was "white" by 0.04 (strict audit, seed 63).
COLOUR_MARGIN = 2.0


def colour_tells_apart(view: ViewFacts, target: ObjectFacts, category: str | None) -> bool:
    """Whether the target's colour word may pick it out among things of ``category`` (any, when
    None): its rendered colour, and that of every seen one the word also names, must read as
    that word (``colour_words.reads_as``: a "white" pot in shadow renders gray), and every seen
    one named by another colour must look clearly different in the image (CIE Lab distance of
    the mean visible colours at least DISTINCT_DELTA_E). A "white" and a "silver" spoon that
    render alike are told apart some other way. Facts without rendered colours (records
    written before they were stored) fall back to the words alone."""
    key = ("colour_apart", target.object_id, category)
    if key not in view.cache:
        # Every one the word picks out must look it: "the rearmost gray phone" counts the phones
        # a reader sees as gray, whichever of them is the target.
        namesakes = [o for o in view.objects if o.color == target.color and o.status != "hidden"
                     and answers_to(view, o, category)]
        view.cache[key] = all(o.lab is None or reads_as(o.lab, o.color, COLOUR_MARGIN) for o in namesakes) and all(
            o.lab is None or target.lab is None or delta_e(o.lab, target.lab) >= DISTINCT_DELTA_E
            for o in view.objects
            if o.object_id != target.object_id and o.status != "hidden" and answers_to(view, o, category)
            and o.color != target.color)
    return view.cache[key]


def named_like_a_prop(view: ViewFacts, category: str | None) -> bool:
    """Whether a background piece in the room looks like a thing of this category (templates.yaml
    ``prop_lookalikes``), so that its name would pick more than the scene's own objects."""
    table = _phrasebook().data["prop_lookalikes"]
    return category is not None and any(category in table.get(kind, ()) for kind in view.prop_kinds)


def _simple_refs(view: ViewFacts, target: ObjectFacts) -> list[Ref]:
    base = Ref(target.object_id, target.category, target.name)
    heads = [base]
    if colour_tells_apart(view, target, target.category):
        heads.append(Ref(target.object_id, target.category, target.name, target.color))
    out = [r for r in heads if resolves(r, view)]
    for head in heads:
        for ordinal in _ordinals(view, head, target):
            ref = Ref(head.object_id, head.category, head.name, head.color, ordinal)
            if resolves(ref, view):
                out.append(ref)
    return out


def _ordinals(view: ViewFacts, head: Ref, target: ObjectFacts) -> list[Ordinal]:
    """Ordinals over the head's candidates, axes with the most spread first."""
    axes = _ordinal_axes(view, head.category, head.color)
    if not axes:
        return []
    options = []
    for axis, ends, ascending, values in axes:
        most = min(MAX_RANK, (len(ascending) + 1) // 2)
        for end, order in zip(ends, (ascending, ascending[::-1])):
            rank = order.index(target.object_id) + 1
            # Counted from the nearer end: "the third-closest" of three books is "the farthest",
            # and "the second from the right" of two mugs is "the leftmost" (annotator).
            if rank <= most:
                spread = _spread(view, ("ordinal_spread", head.category, head.color, axis), values, axis)
                options.append((-spread, rank, Ordinal(axis, end, rank)))
    return [o for *_, o in sorted(options, key=lambda t: (t[0], t[1]))]


def _ordinal_axes(view: ViewFacts, category: str | None,
                  color: str | None) -> list[tuple[str, tuple[str, str], list[int], list[float]]]:
    """For each ordinal axis on which every one of the head's seen candidates has a finite
    position: (axis, (low end, high end), the candidates' ids in ascending order, their
    positions in id order). Empty with fewer than two candidates. The same for every target under
    one head (memoised per view)."""
    key = ("ordinal_axes", category, color)
    if key not in view.cache:
        ids = [o.object_id for o in view.objects if answers_to(view, o, category)
               and color in (None, o.color) and o.status != "hidden"]
        axes = []
        for axis, (position, low_end, _) in ORDINAL_AXES.items() if len(ids) >= 2 else ():
            values = [position(view.objects[i]) for i in ids]
            if all(math.isfinite(c) for c in values):
                high_end = {"left": "right", "front": "back", "near": "far"}[low_end]
                axes.append((axis, (low_end, high_end), sorted(ids, key=dict(zip(ids, values)).__getitem__), values))
        view.cache[key] = axes
    return view.cache[key]


def _spread(view: ViewFacts, key: tuple, values: list[float], axis: str) -> float:
    """How far a head's candidates spread along an axis (their positions' standard deviation,
    halved for depth), worked out only for an axis that ranks some target (memoised per view
    under ``key``)."""
    if key not in view.cache:
        view.cache[key] = float(np.array(values).std()) / (1.0 if axis != "depth" else 2.0)
    return view.cache[key]


# Part kinds and their step counts: unary (a phrase: 1 step), binary (an anchor and a phrase: 2),
# between (two anchors and a phrase: 3), pair (two phrases tied to one anchor, "to the left of and
# behind the plate": 3; the pairs a person reads as one direction are templates.yaml's
# `anchor_pairs`), and the chained kinds, a phrase tying the target to an
# anchor that is itself picked by a relation: chain3 ("left of the bowl at the table's edge": 3),
# chain4 ("left of the object behind the book": 4), chain5 (an anchor found in three steps: 5),
# between_chain ("between the plate and the bowl behind the mug": 5).
# Chains carry most long descriptions: two independent relations, each needed, rarely fit among a
# handful of objects. A chain goes last in its shape, so that no phrase after it can be read as
# part of the anchor's description.
COMBOS = {1: (("unary",),), 2: (("binary",),), 3: (("between",), ("binary", "unary"), ("chain3",), ("pair",)),
          4: (("binary", "binary"), ("chain4",)),
          5: (("between", "binary"), ("binary", "binary", "unary"), ("unary", "chain4"), ("binary", "chain3"),
              ("chain5",), ("pair", "binary"), ("between_chain",))}
CHAIN_ANCHOR_STEPS = {"chain3": 1, "chain4": 2, "chain5": 3, "between_chain": 2}  # the chained anchor's own relations' steps
# A chained anchor is picked by one relation: with two, "the mug left of the object behind the
# book and near the bowl" would not say whether the mug or the object is near the bowl.
ANCHOR_COMBOS = {1: (("unary",),), 2: (("binary",),), 3: (("between",),)}
CHAIN_CHOICES = 4  # descriptions kept per chained anchor: some must avoid the target


def anchored_refs(view: ViewFacts, target: ObjectFacts, steps: int, rng: np.random.Generator,
                  phrased: set[str], any_category: bool = False, wanted: int = 2,
                  as_anchor: bool = False) -> list[Ref]:
    """Up to ``wanted`` descriptions with relations whose step count is ``steps`` (1 to 5), in random order.

    ``phrased`` names the predicates the phrasebook can word. With ``any_category``
    the head is "the object" (identify-from-relations questions). ``as_anchor``: the
    description will be a chained anchor, so it has one relation (ANCHOR_COMBOS).
    """
    category = None if any_category else target.category
    heads = [None, target.color] if not any_category and colour_tells_apart(view, target, category) else [None]
    shapes = (ANCHOR_COMBOS if as_anchor else COMBOS).get(steps, ())
    if len(shapes) > 1:  # a permutation of one draws nothing from the generator
        # No form crowds out the others. Shuffling the list swaps it as ``rng.permutation`` swaps
        # its range, with the same draws: the same order, at a quarter of the cost (every search asks).
        shapes = list(shapes)
        rng.shuffle(shapes)
    out: list[Ref] = []
    for color in heads:
        empty = ("no_fit", target.object_id, category, color, steps, as_anchor)
        if empty in view.cache:  # a search that found nothing is not worth repeating on this view
            continue
        head = _head(view, category, color)
        combos = _fitting_combinations(target.object_id, head, shapes, rng,
                                       lambda kind: _scored_parts(view, target, head, kind, phrased, rng), view.cache)
        if not combos:
            view.cache[empty] = True
        # Choose the first part's predicate by the balance weights (rare relations up), so frequent
# relations do not crowd out rare ones.
        while combos and len(out) < wanted:
            names = sorted({c[0].rels[0].predicate for c in combos})
            name = names[weighted_index(rng, [PREDICATE_WEIGHTS.get(n, 1.0) for n in names])]
            same = [c for c in combos if c[0].rels[0].predicate == name]
            chosen = same[int(rng.integers(len(same)))]
            combos.remove(chosen)
            rels = tuple(r for p in chosen for r in p.rels)
            ref = Ref(target.object_id, category, "object" if any_category else target.name, color, relations=rels)
            if resolves(ref, view):  # the sets already say it fits; the program is the final word
                out.append(ref)
        if out:
            break
    return out


# Not frozen: a frozen dataclass sets each field through object.__setattr__, and the search makes
# some 360 parts a record (1 % of the relation and question stages' instructions); none is changed.
@dataclass(eq=False, slots=True)
class _Part:
    """A relation part with what it does to one head's candidates (precomputed for fast search):
    one relation, or for a pair two relations to the same anchor, applied in order."""

    rels: tuple[Relation, ...]
    # Two parts may be combined only if they share no object and no predicate.
    objects: int  # bit mask of the ids of every object the part names, chained anchors included
    predicates: int  # bit mask of the predicates' indices
    # Candidate sets as bit masks (bit i: object i): the search tests up to ~10^5 combinations
    # per description, as whole arrays of masks at once.
    kept: int  # candidates it keeps
    undecided: int  # candidates it cannot decide


def _head(view: ViewFacts, category: str | None, color: str | None) -> int:
    """The head's candidates as a bit mask; 0 when one of them is only partly visible, since
    relations about a cut-off object cannot be decided safely (memoised per view)."""
    key = ("head", category, color)
    if key not in view.cache:
        # A name a background piece shares resolves nothing (``resolves``): no search under it.
        ids = [] if named_like_a_prop(view, category) else [
            o.object_id for o in view.objects if o.status != "hidden"
            and answers_to(view, o, category) and color in (None, o.color)]
        view.cache[key] = 0 if any(view.objects[i].status != "visible" for i in ids) else sum(1 << i for i in ids)
    return view.cache[key]


def _scored_parts(view: ViewFacts, target: ObjectFacts, head: int, kind: str, phrased: set[str], rng) -> list[_Part]:
    """The parts of one kind that keep the target among the head's candidates (memoised per view)."""
    key = ("scored", target.object_id, head, kind)
    if key not in view.cache:
        parts = []
        if kind == "pair":
            parts = _pairs(head, _scored_parts(view, target, head, "binary", phrased, rng))
        elif head:
            weak = _phrasebook().rule_out_others
            for rel in _parts(view, target, kind, phrased, rng):
                kept, undecided = _kept(view, rel, head)
                named = 0  # ``_named_objects`` of the one relation
                for a in rel.anchors:
                    named |= a.named
                if not kept >> target.object_id & 1 or (rel.predicate in weak and not head & ~named & ~kept):
                    continue  # misses the target, or a weak relation that only leaves out its anchor
                parts.append(_Part((rel,), named, 1 << _PREDICATE_INDEX[rel.predicate], kept, undecided))
        view.cache[key] = parts
    return view.cache[key]


def _pairs(head: int, binary: list[_Part]) -> list[_Part]:
    """Two binary parts on the same plainly named anchor whose predicates read as one direction
    together ("to the left of and behind the plate"), each ruling out a candidate the other keeps.
    Run in order, the second relation meets only what the first kept: its undecided ones count
    only there."""
    allowed = _phrasebook().anchor_pairs
    # Only parts on the same unchained anchor, neither reversed, can pair: grouped by anchor object
    # first, the rest are never tested (one pair in eight shared an anchor object: 9,622 of 78,306
    # in 24 tabletop records). Sorted back, the pairs keep the order of the plain double loop.
    by_anchor: dict[int, list[int]] = {}
    for i, part in enumerate(binary):
        (rel,) = part.rels
        if not rel.reverse and not rel.anchors[0].relations:
            by_anchor.setdefault(rel.anchors[0].object_id, []).append(i)
    out = []
    for group in by_anchor.values():
        for n, i in enumerate(group):
            for j in group[n + 1:]:
                a, b = binary[i], binary[j]
                (ra,), (rb,) = a.rels, b.rels
                if ra.anchors == rb.anchors and frozenset((ra.predicate, rb.predicate)) in allowed and (
                        head & a.kept & ~b.kept and head & b.kept & ~a.kept):
                    out.append((i, j, _Part((ra, rb), a.objects, a.predicates | b.predicates, a.kept & b.kept,
                                            a.undecided | (a.kept & b.undecided))))
    return [part for _, _, part in sorted(out, key=lambda x: x[:2])]  # in the order of the parts


_PREDICATE_INDEX = {name: k for k, name in enumerate(sorted(PREDICATES))}


@functools.lru_cache(maxsize=1)  # the late import cost 2 us a call, ~140 calls a tabletop record
def _phrasebook():
    """The template file's phrasebook (imported late: phrases imports this module)."""
    from .phrases import Phrasebook

    return Phrasebook.get()


def _fitting_combinations(target: int, head: int, shapes, rng,
                          parts_of: Callable[[str], list[_Part]], memo: dict) -> list[tuple[_Part, ...]]:
    """Up to COMBOS_WANTED combinations of parts with a wanted shape that, by the candidate sets,
    pick only the target with no idle part, in random order (shapes in the order given). Parts are
    asked for by kind only when a shape needs them: chained kinds cost a search per object."""
    found: list[tuple[_Part, ...]] = []
    for shape in shapes:
        lists = []
        for kind in shape:  # a kind with no parts ends the shape: the kinds after it go unsearched
            lists.append(parts_of(kind))
            if not lists[-1]:
                break
        if not lists[-1]:
            continue
        size = math.prod(len(x) for x in lists)
        if size > COMBOS_CHECKED:  # keep a random share of each list so that the product fits
            keep = (COMBOS_CHECKED / size) ** (1 / len(lists))
            lists = [[x[int(i)] for i in rng.permutation(len(x))[:max(1, int(len(x) * keep))]] for x in lists]
            fits = np.argwhere(_fits(1 << target, head, lists))
        else:
            fits = _fitting_rows(target, head, shape, lists, memo)
        for row in fits[rng.permutation(len(fits))[:COMBOS_WANTED - len(found)]].tolist():  # cut before gathering
            found.append(tuple(lists[k][i] for k, i in enumerate(row)))
        if len(found) >= COMBOS_WANTED:
            break
    return found


def _fitting_rows(target: int, head: int, shape, lists, memo: dict) -> np.ndarray:
    """``np.argwhere`` of ``_fits`` for a shape's whole part lists (memoised per view in ``memo``:
    the lists are the view's memoised parts, and a third of the searches repeat one, a question's
    later attempts asking again of the same target)."""
    key = ("fits", target, head, shape)
    if key not in memo:
        memo[key] = np.argwhere(_fits(1 << target, head, lists))
    return memo[key]


def _fits(target: int, head: int, lists: list[list[_Part]]) -> np.ndarray:
    """For every combination (one part from each list, in order), whether it is independent
    (distinct objects, distinct predicates) and, run in order, decides every remaining candidate,
    keeps only the target, and has no idle part (dropping any one leaves more than the target).
    Returns a boolean array with one axis per list. ``target`` is the target's bit."""
    n = len(lists)
    if math.prod(len(x) for x in lists) <= LOOPED_COMBOS:
        fits = [_fits_one(target, head, combo) for combo in itertools.product(*lists)]
        return np.array(fits, dtype=bool).reshape([len(x) for x in lists])
    bits = head
    for x in lists:
        for p in x:
            bits |= p.kept | p.undecided | p.objects | p.predicates
    wide = bits.bit_length() > 63
    dtype = object if wide else np.uint64  # Python ints past 63 objects: slower, same logic

    def column(k: int, field: str) -> np.ndarray:
        shape = [1] * n
        shape[k] = -1
        return np.array([getattr(p, field) for p in lists[k]], dtype=dtype).reshape(shape)

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
            ok &= ((column(i, "objects") & column(j, "objects")) == 0) & ((column(i, "predicates") & column(j, "predicates")) == 0)
    return ok


def _fits_one(target: int, head: int, combo: tuple[_Part, ...]) -> bool:
    """``_fits`` for one combination, by the same tests in the same order."""
    remaining = head
    for p in combo:
        if remaining & p.undecided:
            return False
        remaining &= p.kept
    if remaining != target:
        return False
    for k in range(len(combo)):
        others = head
        for j, p in enumerate(combo):
            if j != k:
                others &= p.kept
        if others == target:
            return False
    return not any(a.objects & b.objects or a.predicates & b.predicates
                   for i, a in enumerate(combo) for b in combo[i + 1:])


def _parts(view: ViewFacts, target: ObjectFacts, kind: str, phrased: set[str], rng) -> list[Relation]:
    """Relation parts of one kind that hold for the target (memoised per view, target and kind)."""
    key = ("parts", target.object_id, kind)
    if key not in view.cache:
        if kind == "unary":
            parts = [Relation(n, ()) for n in relation_predicates(phrased, 1) if _holds(view, n, [target])]
        elif kind == "binary":
            parts = _binary_parts(view, target, _simple_anchors(view, target), phrased)
        elif kind == "between":
            parts = _between_parts(view, target, _simple_anchors(view, target)) if "between" in phrased else []
        elif kind == "between_chain":
            parts = _between_chain_parts(view, target, _simple_anchors(view, target),
                                         _chained_anchors(view, target, CHAIN_ANCHOR_STEPS[kind], phrased, rng)
                                         ) if "between" in phrased else []
        else:
            anchors = _chained_anchors(view, target, CHAIN_ANCHOR_STEPS[kind], phrased, rng)
            parts = _binary_parts(view, target, anchors, phrased)
        view.cache[key] = parts
    return view.cache[key]


def _simple_anchors(view: ViewFacts, target: ObjectFacts) -> dict[int, Ref]:
    """Every other object's plainest description (memoised per view and target: the binary,
    between and chained kinds each ask)."""
    key = ("simple_anchors", target.object_id)
    if key not in view.cache:
        view.cache[key] = {o.object_id: r[0] for o in view.askable() if o.object_id != target.object_id
                           and (r := simple_refs(view, o)[:1])}
    return view.cache[key]


def _chained_anchors(view: ViewFacts, target: ObjectFacts, steps: int, phrased: set[str], rng) -> dict[int, Ref]:
    """Each other object's description by relations in ``steps`` steps that does not name the target."""
    out = {}
    for o in view.askable():
        if o.object_id != target.object_id:
            usable = [r for r, named in chained_refs(view, o, steps, phrased, rng) if not named >> target.object_id & 1]
            if usable:
                out[o.object_id] = usable[0]
    return out


def chained_refs(view: ViewFacts, obj: ObjectFacts, steps: int, phrased: set[str], rng) -> list[tuple[Ref, int]]:
    """Descriptions of an object by relations in ``steps`` steps (1 to 3), to serve as a chained
    anchor, each with the bit mask of the other objects it names (memoised per view).

    A description with its own category ("the bowl behind the book") is preferred; where the
    category alone already picks the object, the relation would be idle, so the head becomes
    "the object". Each is one unchained relation (ANCHOR_COMBOS), so chains never nest deeper
    than one link.
    """
    key = ("chained", obj.object_id, steps)
    if key not in view.cache:
        refs = (anchored_refs(view, obj, steps, rng, phrased, wanted=CHAIN_CHOICES, as_anchor=True)
                or anchored_refs(view, obj, steps, rng, phrased, any_category=True, wanted=CHAIN_CHOICES,
                                 as_anchor=True))
        view.cache[key] = [(r, _named_objects(r.relations)) for r in refs]
    return view.cache[key]


def _named_objects(relations: tuple[Relation, ...]) -> int:
    """Bit mask of the objects some relations name: their anchors, down through chains."""
    mask = 0
    for rel in relations:
        for a in rel.anchors:
            mask |= a.named
    return mask


def _kept(view: ViewFacts, rel: Relation, head: int) -> tuple[int, int]:
    """The head's candidates (the set bits of ``head``) the relation keeps, and those it cannot
    decide, as bit masks: the relation's verdicts on every visible object but its anchors, worked
    out once per view and relation, then cut to the head (every head under which the search meets
    a relation to an anchor asks the same verdicts of its own candidates; ``_head`` holds visible
    objects only)."""
    anchors = rel.anchors
    ids = (anchors[0].object_id,) if len(anchors) == 1 else tuple(a.object_id for a in anchors)
    kept, undecided = _verdict_masks(view, rel.predicate, ids, rel.reverse)
    return kept & head, undecided & head


def _verdict_masks(view: ViewFacts, predicate: str, anchors: tuple[int, ...], reverse: bool) -> tuple[int, int]:
    """Bit masks of the visible objects (anchors aside) a relation to ``anchors`` keeps, and of
    those it cannot decide (memoised per view)."""
    key = ("kept", predicate, anchors, reverse)
    known = view.cache.get(key)
    if known is not None:
        return known
    anchor_facts = [view.objects[k] for k in anchors]
    pred = PREDICATES[predicate]
    one = anchor_facts[0] if len(anchor_facts) == 1 else None
    kept = undecided = 0
    for o in view.objects:
        if o.status != "visible" or o.object_id in anchors:
            continue
        if one is not None:  # the usual case, one anchor: the memo's quicker read
            verdict = pred.pair(view, one, o) if reverse else pred.pair(view, o, one)
        else:
            verdict = pred(view, *anchor_facts, o) if reverse else pred(view, o, *anchor_facts)
        if verdict is None:
            undecided |= 1 << o.object_id
        elif verdict:
            kept |= 1 << o.object_id
    view.cache[key] = kept, undecided
    return kept, undecided


def _holds(view: ViewFacts, name: str, objs: list[ObjectFacts]) -> bool:
    return PREDICATES[name](view, *objs) is True


def holds_anything(view: ViewFacts, container: ObjectFacts) -> bool:
    """Some seen object is inside the container (memoised per view and facts object: every
    description search with an "outside" part asks it of every anchor)."""
    key = ("holds_anything", container)
    if key not in view.cache:
        view.cache[key] = any(_holds(view, "inside", [o, container]) for o in view.objects
                              if o.object_id != container.object_id and o.status != "hidden")
    return view.cache[key]


def _binary_parts(view: ViewFacts, target: ObjectFacts, anchors: dict[int, Ref], phrased: set[str]):
    parts = []
    objects = [(view.objects[aid], ref) for aid, ref in anchors.items()]
    for name in relation_predicates(phrased, 2):
        # What depends on the predicate alone is settled once, not per anchor: every description
        # search runs this for each target over every predicate and anchor (~10^3 tests a view).
        pred = PREDICATES[name]
        sided, outside = name in SIDE_PREDICATES, name == "outside"
        reverse = pred.inverse is None and f"{name}:reverse" in phrased
        for anchor, ref in objects:
            if sided and not side_visible(view, anchor):
                continue  # its named side cannot be seen here
            if outside and not holds_anything(view, anchor):
                continue  # "outside the empty pan" rules nothing out: a person reads it as nonsense
            if pred.pair(view, target, anchor) is True:
                parts.append(Relation(name, (ref,)))
            if reverse and pred.pair(view, anchor, target) is True:
                parts.append(Relation(name, (ref,), reverse=True))
    return parts


def _between_chain_parts(view: ViewFacts, target: ObjectFacts, simple: dict[int, Ref],
                         chained: dict[int, Ref]) -> list[Relation]:
    """Between two anchors, the second picked by a relation of its own: "between the plate and the
    bowl behind the mug" (five steps: three objects, two phrases). The chained anchor comes last,
    so its phrase can only be read as its own."""
    maybe = _between_maybe(view, target)
    out = []
    for plain, chain in ((b, c) for b in sorted(simple) for c in sorted(chained) if b != c):
        if ((plain, chain) in maybe and (_named_objects(chained[chain].relations) >> plain & 1) == 0
                and _holds(view, "between", [target, view.objects[plain], view.objects[chain]])):
            out.append(Relation("between", (simple[plain], chained[chain])))
    return out


def _between_parts(view: ViewFacts, target: ObjectFacts, anchors: dict[int, Ref]) -> list[Relation]:
    ids = sorted(anchors)
    maybe = _between_maybe(view, target)
    return [Relation("between", (anchors[b], anchors[c])) for i, b in enumerate(ids) for c in ids[i + 1:]
            if (b, c) in maybe and _holds(view, "between", [target, view.objects[b], view.objects[c]])]


def _between_maybe(view: ViewFacts, target: ObjectFacts) -> frozenset[tuple[int, int]]:
    """The anchor pairs (both orders) the target may lie between by the plan-view test of
    ``between_candidates`` (a superset of the pairs it lies between; memoised per view). The
    full test of any other pair could only say no, and those tests were a tenth of the question
    stage's verdicts."""
    key = ("between_maybe",)
    if key not in view.cache:
        pairs: dict[int, set[tuple[int, int]]] = {}
        for a, b, c in between_candidates(view, view.objects):
            pairs.setdefault(a, set()).update(((b, c), (c, b)))
        view.cache[key] = {a: frozenset(p) for a, p in pairs.items()}
    return view.cache[key].get(target.object_id, frozenset())
