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
