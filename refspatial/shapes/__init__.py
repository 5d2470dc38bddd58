"""Shape builders: sampled parameters -> a visual mesh and convex collision parts.

Each builder works in the object frame (origin at the footprint centre on the resting
surface, +z up, +x the semantic front, metres) and is registered under the name the
catalogue's ``builder`` key uses, with the parameters it reads and the limits its ranges
must respect (checked when the catalogue loads). Builders live in one module per group of
things; importing this package registers them all.
"""

from __future__ import annotations

# importing the modules registers their builders
from . import containers, electronics, food, furniture, kitchen, office, tableware, tools, toys  # noqa: F401
from .registry import BUILDER_LIMITS, BUILDER_PARAMS, BUILDERS, Builder, Built, register

__all__ = ["BUILDERS", "BUILDER_LIMITS", "BUILDER_PARAMS", "Builder", "Built", "register"]
