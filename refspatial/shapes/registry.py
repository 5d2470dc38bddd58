"""The builder registry: catalogue ``builder`` names -> functions, with what each one reads.

A builder maps sampled parameters to ``(visual mesh, convex collision parts)`` in the object
frame. It draws nothing: every number comes from the parameters ``build_asset`` sampled.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Callable

if TYPE_CHECKING:
    from .geometry import FinalMesh

Built = tuple["FinalMesh", list["FinalMesh"]]  # (visual mesh, convex collision parts), from geometry.finish
Builder = Callable[[dict[str, float]], Built]

BUILDERS: dict[str, Builder] = {}
BUILDER_PARAMS: dict[str, tuple[str, ...]] = {}  # parameter names each builder reads
BUILDER_LIMITS: dict[str, tuple[str, ...]] = {}  # "small*k <= big" rules on the catalogue ranges


def register(name: str, needs: str, *limits: str) -> Callable[[Builder], Builder]:
    """Add a builder. `needs` (space-separated names) and `limits` ("small*k <= big", big a
    parameter or a number) let the loader reject catalogue entries the builder cannot build."""

    def add(fn: Builder) -> Builder:
        if name in BUILDERS:
            raise ValueError(f"builder {name!r} is registered twice ({BUILDERS[name].__module__}, {fn.__module__})")
        BUILDERS[name], BUILDER_PARAMS[name], BUILDER_LIMITS[name] = fn, tuple(needs.split()), limits
        return fn

    return add
