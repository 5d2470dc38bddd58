"""The balance priors of ``balance.yaml``: weights that favour rarely fitting predicates."""

from __future__ import annotations

import bisect
import itertools
from pathlib import Path

import numpy as np
import yaml

_DATA = yaml.safe_load((Path(__file__).with_name("balance.yaml")).read_text(encoding="utf-8"))
PREDICATE_WEIGHTS: dict[str, float] = {k: float(v) for k, v in _DATA["predicates"].items()}
QUANTITY_WEIGHTS: dict[str, float] = {k: float(v) for k, v in _DATA["quantities"].items()}


def weighted_index(rng: np.random.Generator, weights: list[float]) -> int:
    """An index drawn with probability proportional to its weight (one uniform draw, like the
    unweighted choice it replaces, so the generator's stream keeps its length)."""
    # Python's running sums and bisection are numpy's cumsum and searchsorted here, bit for bit
    # (cumsum adds one after another), without their call costs on a list of a few weights.
    cumulative = list(itertools.accumulate(weights))
    return bisect.bisect_right(cumulative, rng.random() * cumulative[-1])


def weighted_order(rng: np.random.Generator, weights: list[float]) -> np.ndarray:
    """A random order in which heavier items tend to come first (each item's key is u^(1/w) for a
    uniform u: sorting by it samples without replacement in proportion to the weights)."""
    keys = rng.random(len(weights)) ** (1.0 / np.asarray(weights, dtype=float))
    return np.argsort(-keys, kind="stable")
