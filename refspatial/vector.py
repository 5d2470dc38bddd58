"""Small vector arithmetic that the relation engine calls hundreds of times a record."""

from __future__ import annotations

import math

import numpy as np


def length(v) -> float:
    """``np.linalg.norm(v)`` of a float64 vector, bit for bit: the same dot product and a
    correctly rounded square root, without the general function's conversions and checks (~3 of
    its ~4 us a call; relations and questions ask ~700 lengths a record). Anything else (other
    dtypes, matrices) goes to numpy as before."""
    a = np.asarray(v)
    if a.dtype != np.float64 or a.ndim != 1:
        return float(np.linalg.norm(a))
    return math.sqrt(a.dot(a))


def column_bounds(a: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(a.min(0), a.max(0))`` of an (N, k) array, bit for bit (a minimum or maximum is exact),
    reduced column by column: numpy reduces the first axis of a narrow array slowly, 160 us for
    the (6000, 2) pixel corners of a placement mask's cells against 13 us by columns."""
    columns = [a[:, k] for k in range(a.shape[1])]
    return np.array([c.min() for c in columns]), np.array([c.max() for c in columns])


def angle_deg(cosine: float) -> float:
    """``float(np.degrees(np.arccos(np.clip(cosine, -1.0, 1.0))))``, bit for bit: the same arccos
    of the same clamped value, without numpy's clip of a scalar (3 of the line's 4 us; the facing
    and side predicates ask it of every pair)."""
    return float(np.degrees(np.arccos(min(max(cosine, -1.0), 1.0))))
