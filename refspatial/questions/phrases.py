"""Turning programs' structures into words, from the phrasings in templates.yaml."""

from __future__ import annotations

from functools import cached_property, lru_cache
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from ..relations import ViewFacts
from .refer import Ordinal, Ref, Relation

TEMPLATES = Path(__file__).with_name("templates.yaml")


class Phrasebook:
    """The template file, with seeded choices among its paraphrases."""

    def __init__(self, data: dict[str, Any]) -> None:
        self.data = data
        self.point_suffix: str = data["point_suffix"]

    @staticmethod
    @lru_cache(maxsize=1)
    def get() -> "Phrasebook":
        return Phrasebook(yaml.safe_load(TEMPLATES.read_text(encoding="utf-8")))

    @cached_property  # read per description search (frozen: every caller shares it)
    def phrased(self) -> frozenset[str]:
        """Predicates with forward phrases, plus "name:reverse" for those with reverse ones."""
        rel = self.data["relations"]
        return frozenset(rel) | {f"{n}:reverse" for n, e in rel.items() if "reverse" in e}

    @cached_property  # read per description search
    def rule_out_others(self) -> frozenset[str]:
        """Predicates a description may use only where they rule out more than their own anchors."""
        return frozenset(self.data["rule_out_others"])

    @cached_property  # read per description search
    def anchor_pairs(self) -> set[frozenset[str]]:
        """Predicates that may share one anchor in a description ("left of and behind the plate")."""
        return {frozenset(p) for p in self.data["anchor_pairs"]}

    def pick(self, options: list[str], rng: np.random.Generator) -> str:
        return options[int(rng.integers(len(options)))]

    def template(self, *path: str, rng: np.random.Generator) -> str:
        node: Any = self.data
        for key in path:
            node = node[key]
        return self.pick(node, rng)

    def relation_phrase(self, predicate: str, reverse: bool, rng: np.random.Generator, side: str = "front") -> str:
        entry = self.data["relations"][predicate]
        word = self.data["side_words"].get(side, side)
        return self.pick(entry["reverse" if reverse else "forward"], rng).format(side=side, side_word=word)

    def comparative(self, predicate: str, rng: np.random.Generator) -> str:
        return self.pick(self.data["comparatives"][predicate], rng)

    def plural(self, name: str) -> str:
        special = self.data["plurals"].get(name)
        if special:
            return special
        return name + ("es" if name.endswith(("s", "x", "ch", "sh")) else "s")

    def describe(self, ref: Ref, rng: np.random.Generator, view: ViewFacts | None = None) -> tuple[str, dict[Ref, str]]:
        """Words for a description and for every anchor inside it. ``view`` supplies anchors' side names."""
        texts: dict[Ref, str] = {}
        return self._describe(ref, rng, texts, view), texts

    def clauses(self, ref: Ref, rng: np.random.Generator, view: ViewFacts | None,
                texts: dict[Ref, str]) -> str:
        """Just the relation clauses of a description ("to the left of the mug and near the bowl").
        Phrases in a row on the same anchor share its words: "to the left of and behind the plate".
        A clause whose anchor's words run on past its noun ("the stapler nearest the front", "the
        cup left of the bowl") comes last: "farther back than the stapler nearest the front and
        right of the leftmost stapler" read as "nearest the front and right of" (annotator)."""
        rels = ref.relations
        groups: list[list[str]] = [[]]
        open_ends: list[bool] = []
        for k, r in enumerate(rels):
            shared = bool(k + 1 < len(rels) and r.anchors and rels[k + 1].anchors == r.anchors)
            groups[-1].append(self._relation(r, rng, texts, view, named=not shared))
            if not shared:
                open_ends.append(bool(r.anchors) and not texts[r.anchors[-1]].endswith(_noun(r.anchors[-1])))
                groups.append([])
        ordered = [g for g, o in zip(groups, open_ends) if not o] + [g for g, o in zip(groups, open_ends) if o]
        return " and ".join(" and ".join(g) for g in ordered)

    def _describe(self, ref: Ref, rng, texts: dict[Ref, str], view) -> str:
        noun = _noun(ref)
        text = self._ordinal(ref.ordinal, noun, rng) if ref.ordinal else f"the {noun}"
        if ref.relations:
            joiner = " that is " if rng.random() < 0.4 else " "
            text = text + joiner + self.clauses(ref, rng, view, texts)
        texts[ref] = text
        return text

    def _relation(self, rel: Relation, rng, texts: dict[Ref, str], view, named: bool = True) -> str:
        """The phrase and its anchors' words; just the phrase when the next one names them (``named``)."""
        anchors = [self._describe(a, rng, texts, view) for a in rel.anchors] if named else []
        side = view.objects[rel.anchors[0].object_id].front_side if view and rel.anchors else "front"
        phrase = self.relation_phrase(rel.predicate, rel.reverse, rng, side=side)
        return f"{phrase} {' and '.join(anchors)}" if anchors else phrase

    def _ordinal(self, o: Ordinal, noun: str, rng) -> str:
        forms = self.data["ordinals"][o.axis][o.end]
        if o.rank == 1:
            return self.pick(forms["first"], rng).format(noun=noun)
        nth = self.data["nth_words"][o.rank]
        return self.pick(forms["nth"], rng).format(noun=noun, nth=nth)


def _noun(ref: Ref) -> str:
    return f"{ref.color} {ref.name}" if ref.color else ref.name
