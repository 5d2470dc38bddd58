"""Turning programs' structures into words, from the phrasings in templates.yaml."""

from __future__ import annotations

from functools import lru_cache
from pathlib import Path
from typing import Any

import numpy as np
import yaml

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

    def pick(self, options: list[str], rng: np.random.Generator) -> str:
        return options[int(rng.integers(len(options)))]

    def template(self, family: str, rng: np.random.Generator) -> str:
        return self.pick(self.data[family], rng)

    def relation_phrase(self, predicate: str, reverse: bool, rng: np.random.Generator) -> str:
        entry = self.data["relations"][predicate]
        return self.pick(entry["reverse" if reverse else "forward"], rng)

    def comparative(self, predicate: str, rng: np.random.Generator) -> str:
        return self.pick(self.data["comparatives"][predicate], rng)

    def describe(self, ref: Ref, rng: np.random.Generator) -> tuple[str, dict[Ref, str]]:
        """Words for a description and for every anchor inside it."""
        texts: dict[Ref, str] = {}
        return self._describe(ref, rng, texts), texts

    def _describe(self, ref: Ref, rng: np.random.Generator, texts: dict[Ref, str]) -> str:
        noun = f"{ref.color} {ref.name}" if ref.color else ref.name
        text = self._ordinal(ref.ordinal, noun, rng) if ref.ordinal else f"the {noun}"
        if ref.relations:
            clauses = [self._relation(r, rng, texts) for r in ref.relations]
            joiner = " that is " if rng.random() < 0.4 else " "
            text = text + joiner + " and ".join(clauses)
        texts[ref] = text
        return text

    def _relation(self, rel: Relation, rng: np.random.Generator, texts: dict[Ref, str]) -> str:
        anchors = [self._describe(a, rng, texts) for a in rel.anchors]
        phrase = self.relation_phrase(rel.predicate, rel.reverse, rng)
        return f"{phrase} {' and '.join(anchors)}"

    def _ordinal(self, o: Ordinal, noun: str, rng: np.random.Generator) -> str:
        forms = self.data["ordinals"][o.axis][o.end]
        if o.rank == 1:
            return self.pick(forms["first"], rng).format(noun=noun)
        nth = self.data["nth_words"][o.rank]
        return self.pick(forms["nth"], rng).format(noun=noun, nth=nth)
