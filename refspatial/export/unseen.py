"""Held-out predicate combinations: a compositional test split, as RefSpatial-Bench's Unseen.

A QA's *combination* is the sorted set of the distinct predicates its program uses
(``qa["predicates"]``), when there are two or more; single-predicate questions have none,
since holding one out would hide a predicate, not a combination. A combination is held out
when the first 8 bytes of sha256(``"refspatial-unseen/" + "+".join(combination)``), read
as a big-endian fraction of 2^64, fall below ``share``. The choice depends on the names
alone: a share holds out the same combinations in every dataset, export and run, whatever
the seeds, order or worker count, and a larger share holds out a superset.

Training exports (``roborefer --unseen-share``) leave out every QA with a held-out
combination, whatever its family, so no training question joins those predicates. The
Unseen split keeps the held-out point questions (location and placement) whose every
predicate still appears in some training QA: what it tests is the new combination, never a
predicate the model was not shown.
"""

from __future__ import annotations

import hashlib
from dataclasses import dataclass
from typing import Iterable

from .base import ExportError

SALT = "refspatial-unseen/"


def combination(qa: dict) -> tuple[str, ...] | None:
    """The QA's predicate combination, or None for fewer than two distinct predicates."""
    names = tuple(sorted(set(qa.get("predicates") or ())))
    return names if len(names) >= 2 else None


def combination_fraction(names: tuple[str, ...]) -> float:
    """Where a combination falls in [0, 1): held out under any share above it."""
    digest = hashlib.sha256((SALT + "+".join(names)).encode("utf-8")).digest()
    return int.from_bytes(digest[:8], "big") / 2.0 ** 64


@dataclass(frozen=True)
class HoldOut:
    """Which QA a training export leaves out (``share`` 0 leaves out none)."""

    share: float = 0.0

    def __post_init__(self) -> None:
        if not 0.0 <= self.share < 1.0:
            raise ExportError(f"--unseen-share must be in [0, 1); got {self.share}; 0.2 holds out about a fifth of the combinations")

    def held_out(self, qa: dict) -> bool:
        names = combination(qa)
        return names is not None and combination_fraction(names) < self.share

    def trained_predicates(self, qas: Iterable[dict]) -> frozenset[str]:
        """Every predicate some kept (training) QA uses."""
        return frozenset(p for qa in qas if not self.held_out(qa) for p in qa.get("predicates") or ())

    def testable(self, qa: dict, trained: frozenset[str]) -> bool:
        """A held-out QA that tests a new combination of predicates seen in training."""
        return self.held_out(qa) and set(qa.get("predicates") or ()) <= trained
