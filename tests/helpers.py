"""Hand-built view facts: scenes whose every relation is known by construction.

The viewer looks along world +y, so "right" is +x, "front" is small y, and the
camera depth of an object is its y plus 1 m.
"""

from __future__ import annotations

import numpy as np

from refspatial.relations import ObjectFacts, ViewFacts


def obj(oid: int, category: str, color: str, x: float, y: float, size: float = 0.08, status: str = "visible",
        height: float = 0.1) -> ObjectFacts:
    half = np.array([size / 2, size / 2, 0])
    centre = np.array([x, y, height / 2])
    aabb = np.stack([centre - half - [0, 0, height / 2], centre + half + [0, 0, height / 2]])
    return ObjectFacts(oid, category, category.replace("_", " "), color, aabb, float(x), float(y), float(y + 1.0),
                       500 if status == "visible" else (5 if status == "marginal" else 0), status)


def view(*objects: ObjectFacts, shape=(60, 80)) -> ViewFacts:
    seg = np.full(shape, -1, dtype=np.int32)
    return ViewFacts(tuple(objects), np.array([1.0, 0, 0]), np.array([0, 1.0, 0]), seg,
                     np.ones(shape, dtype=np.float32))
