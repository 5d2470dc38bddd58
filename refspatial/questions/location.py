"""Location and identify-from-relations: point to (or name) the one object a description picks."""

from __future__ import annotations

import numpy as np

from ..relations import ObjectFacts, ViewFacts
from .common import QA, asked, make_qa, point_qa, target_order
from .phrases import Phrasebook
from .program import Node, execute
from .refer import Ref, anchored_refs, compile_ref, ref_key, simple_refs


LONG_CHAIN = 3  # from this many steps on, a description may fall back to "the object ..."


def describe_target(view: ViewFacts, target, steps: int, rng: np.random.Generator,
                    any_category: bool = False) -> Ref | None:
    """A description of the target with the wanted step count, or None."""
    if steps == 1 and not any_category:
        refs = simple_refs(view, target)
        # Mostly the plainest description that works; sometimes a richer one or a unary relation.
        if not refs or rng.random() < 0.25:
            refs = refs + anchored_refs(view, target, 1, rng, Phrasebook.get().phrased)
        elif rng.random() < 0.6:
            refs = refs[:1]
    else:
        refs = anchored_refs(view, target, steps, rng, Phrasebook.get().phrased, any_category)
        if not refs and steps >= LONG_CHAIN and not any_category:
            # Long chains rarely fit inside one category; "the object that ..." leaves room for them.
            refs = anchored_refs(view, target, steps, rng, Phrasebook.get().phrased, any_category=True)
    return refs[int(rng.integers(len(refs)))] if refs else None


def first_described(view: ViewFacts, steps: int, rng: np.random.Generator, any_category: bool = False,
                    skip: set[str] | frozenset[str] = frozenset()) -> tuple[ObjectFacts, Ref] | None:
    """(target, description) for the first object in ``target_order`` that has a description of
    ``steps`` steps whose ``ref_key`` is not in ``skip`` (descriptions that do not fit are
    remembered per view, so trying every object costs each search once)."""
    for target in target_order(view, rng):
        ref = describe_target(view, target, steps, rng, any_category)
        if ref is not None and (not skip or ref_key(ref) not in skip):
            return target, ref
    return None


def described_target(views: dict[str, ViewFacts], steps: int, rng: np.random.Generator, where: str = "self"):
    """(target, its description's words, the program resolving it) in view ``where``, or None.
    In the record's own view, a description its record has asked already is passed over."""
    view = views[where]
    found = first_described(view, steps, rng, skip=asked(view) if where == "self" else frozenset())
    if found is None:
        return None
    target, ref = found
    text, texts = Phrasebook.get().describe(ref, rng, view)
    program: list[Node] = []
    compile_ref(ref, program, texts, view=where)
    return target, text, program


def location(views: dict[str, ViewFacts], spec: dict, steps: int, rng: np.random.Generator) -> QA | None:
    """Point to the one object a description picks (1 to 5 steps)."""
    view = views["self"]
    found = described_target(views, steps, rng)
    if found is None:
        return None
    _, text, program = found
    return point_qa("location", "location", text, program, execute(program, view), views, spec, rng, ref=text)


def identify(views: dict[str, ViewFacts], spec: dict, steps: int, rng: np.random.Generator) -> QA | None:
    """Which object satisfies these relations? Answered with its name, or by pointing."""
    view = views["self"]
    found = first_described(view, steps, rng, any_category=True, skip=asked(view))
    if found is None:
        return None
    target, ref = found
    name_ref = simple_refs(view, target)[:1]
    if not name_ref:
        return None
    book = Phrasebook.get()
    texts: dict[Ref, str] = {}
    clauses = book.clauses(ref, rng, view, texts)
    texts[ref] = f"the object {clauses}"
    program: list[Node] = []
    compile_ref(ref, program, texts)
    values = execute(program, view)
    if rng.random() < 0.5:
        name, _ = book.describe(name_ref[0], rng, view)
        prompt = book.template("identify_name", rng=rng).format(clauses=clauses)
        return make_qa("identify", "name", prompt, name, program, values, views, rng, target=values[-1],
                       ref=texts[ref], answer_name=name)
    return point_qa("identify", "identify_point", clauses, program, values, views, spec, rng, ref=texts[ref])
