"""Per-stage random generators derived from stable hashes.

Every stage of the pipeline draws from its own generator, keyed by
(recipe hash, scene seed, stage name). Adding draws to one stage therefore never
moves the numbers another stage sees, and nothing depends on process, time or
Python's salted ``hash()``.
"""

from __future__ import annotations

import hashlib

import numpy as np


def stable_int(*parts: object, bits: int = 64) -> int:
    """An integer from the sha256 of the parts' text, identical on every machine."""
    text = "\x1f".join(str(p) for p in parts)
    digest = hashlib.sha256(text.encode("utf-8")).digest()
    return int.from_bytes(digest[: bits // 8], "little")


def stage_rng(recipe_hash: str, seed: int, stage: str) -> np.random.Generator:
    """The generator for one named stage of one scene."""
    return np.random.default_rng(stable_int(recipe_hash, seed, stage))


def scene_seed(base_seed: int, index: int) -> int:
    """Seed of the index-th scene of a run started with ``base_seed``.

    Hashing (rather than ``base_seed + index``) keeps runs with nearby base seeds
    from sharing scenes. 62 bits keep the value a positive int64 everywhere.
    """
    return stable_int("scene", base_seed, index, bits=64) >> 2
