"""Placement / vacant space: point to a free spot on a support that meets every constraint."""

from __future__ import annotations

from functools import lru_cache

import numpy as np

from ..annotate import rle_encode
from ..relations import TABLE, ViewFacts
from ..relations.free_space import DIRECTIONS, image_clearance, solve, stored_constraints
from .common import QA, erosion_px, format_points, make_qa, sample_mask_points
from .phrases import Phrasebook
from .program import Node, ProgramError, execute
from .refer import Ref, chained_refs, compile_ref, simple_refs

OFFSETS_M = (0.05, 0.10, 0.15, 0.20)
# Shapes per step count: the constraints, and each anchor's steps (1: named plainly; 2-4: picked by
# relations of its own, "left of the object behind the book"). A step count is the anchors' steps
# plus one phrase per constraint ("on" adds none). Two constraints rarely leave free room, so the
# long shapes mostly chain their anchors instead. A chained anchor comes last ("between the cup
# and the bowl left of the lamp"), where its clause cannot be read as the other anchor's.
SHAPES = {1: ((("on_top",), (1,)),),
          2: ((("sector",), (1,)), (("offset",), (1,))),
          3: ((("between",), (1, 1)), (("sector",), (2,))),
          4: ((("sector", "sector"), (1, 1)), (("sector",), (3,)), (("offset",), (3,))),
          5: ((("between", "sector"), (1, 1, 1)), (("between",), (1, 3)), (("sector",), (4,)))}
ANCHORS = {"on_top": 1, "sector": 1, "offset": 1, "between": 2}


def placement(views: dict[str, ViewFacts], spec: dict, steps: int, rng: np.random.Generator) -> QA | None:
    view = views["self"]
    shapes = SHAPES.get(steps, ())
    if not shapes:
        return None
    kinds, anchor_steps = shapes[int(rng.integers(len(shapes)))]
    candidates = [o for o in view.askable() if o.support is not None]
    if "on_top" in kinds:
        candidates = [o for o in candidates if o.is_support]
    else:
        candidates = [o for o in candidates if o.support <= TABLE]  # the table top or a shelf board
    if "offset" in kinds:
        candidates = [o for o in candidates if o.category not in _no_offset_from()]
    if len(candidates) < len(anchor_steps):
        return None
    chosen = [candidates[int(i)] for i in rng.choice(len(candidates), size=len(anchor_steps), replace=False)]
    if kinds[0] == "between" and anchor_steps[0] == anchor_steps[1]:
        chosen[:2] = sorted(chosen[:2], key=lambda o: o.object_id)  # "between A and B" is "between B and A"
    constraints = _constraints(kinds, rng)
    # The free spot depends on the anchors alone, not on how they are described: most drawn
    # spots have no room (four in five), and solving first spares their anchors' description
    # search (chained anchors cost a search each).
    if solve(view, stored_constraints(constraints, [o.object_id for o in chosen]), with_mask=False) is None:
        return None
    others = sum(1 << o.object_id for o in chosen)
    refs = [_anchor_ref(view, o, k, others, rng) for o, k in zip(chosen, anchor_steps)]
    if not all(refs):
        return None
    return _question(views, spec, refs, constraints, rng)


@lru_cache(maxsize=1)
def _no_offset_from() -> frozenset[str]:
    return frozenset(Phrasebook.get().data["no_offset_from"])


def _anchor_ref(view: ViewFacts, obj, steps: int, others: int, rng) -> Ref | None:
    """A description of an anchor in ``steps`` steps that names none of the other anchors."""
    if steps == 1:
        refs = simple_refs(view, obj)[:1]
    else:
        chained = chained_refs(view, obj, steps - 1, Phrasebook.get().phrased, rng)
        refs = [r for r, named in chained if not named & others]
    return refs[0] if refs else None


def _constraints(shape: tuple[str, ...], rng: np.random.Generator) -> list[dict]:
    out, k = [], 0
    for kind in shape:
        c = {"kind": kind, "anchors": list(range(k, k + ANCHORS[kind]))}
        k += ANCHORS[kind]
        if kind in ("sector", "offset"):
            c["direction"] = DIRECTIONS[int(rng.integers(len(DIRECTIONS)))]
        if kind == "offset":
            c["offset_m"] = OFFSETS_M[int(rng.integers(len(OFFSETS_M)))]
        out.append(c)
    return out


def _question(views, spec: dict, refs, constraints: list[dict], rng) -> QA | None:
    view = views["self"]
    book = Phrasebook.get()
    words, texts = [], {}
    for r in refs:
        text, t = book.describe(r, rng, view)
        words.append(text)
        texts.update(t)
    program: list[Node] = []
    anchors = [compile_ref(r, program, texts) for r in refs]
    program.append({"op": "free_space", "inputs": anchors, "constraints": constraints})
    try:
        values = execute(program, view)
    except ProgramError:
        return None
    answer = solve(view, stored_constraints(constraints, [values[i] for i in anchors]))
    extra = []
    if spec["answer_points"] > 1:
        # Further points keep clear of every object in the picture too, as the first one does.
        roomy = answer.mask & image_clearance(view, answer.support)
        extra = sample_mask_points(roomy, spec["answer_points"] - 1, rng, erosion_px(view))
    if extra is None:
        return None
    points = [values[-1], *extra]
    region = " and ".join(_region_words(book, c, words, rng) for c in constraints)
    prompt = book.template("placement", rng=rng).format(region=region)
    qa = make_qa("placement", "point", prompt, format_points(points), program, values, views, rng,
                 points=points, ref=f"the free spot {region}", free_mask=rle_encode(answer.mask),
                 free_area_m2=round(answer.area_m2, 4))
    if qa is not None:  # the trace's last step is the free spot itself
        qa["reasoning_steps"].append({"kind": "Position", "text": qa["ref"], "object_id": None, "point": points[0]})
        qa["reasoning"] = _retrace(qa)
    return qa


def _region_words(book: Phrasebook, c: dict, words: list[str], rng) -> str:
    regions = book.data["regions"]
    a = words[c["anchors"][0]]
    if c["kind"] == "between":
        return book.pick(regions["between"], rng).format(a=a, b=words[c["anchors"][1]])
    if c["kind"] == "on_top":
        return book.pick(regions["on_top"], rng).format(a=a)
    if c["kind"] == "sector":
        direction = book.pick(regions["directions"][c["direction"]], rng)
        return book.pick(regions["sector"], rng).format(dir=direction, a=a)
    direction = book.pick(regions["offset_directions"][c["direction"]], rng)
    offset = f"{round(c['offset_m'] * 100)} cm"
    return book.pick(regions["offset"], rng).format(offset=offset, dir=direction, a=a)


def _retrace(qa: QA) -> str:
    from .common import trace_text

    return f"<think>{trace_text(qa['reasoning_steps'])}</think><answer>{qa['answer']}</answer>"
