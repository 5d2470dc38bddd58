"""Shape variants: a recipe's ``objects.shape_variants: N`` gives each procedural category N
fixed shapes, built once per process and reused.

Building a shape is manifold3d booleans and hulls, about 7 ms an object and two thirds of
composing a scene. With variants, an object draws a variant number instead of its shape
parameters, and the parameters are a pure function of (category, its parameter ranges, variant
number), so a long run builds each variant once. Colour, material, texture, size on the table
and pose still vary per object. ``N = 0`` draws fresh parameters for every object, as before.

Banked meshes are shared by every scene of the process, so their arrays are made read-only:
code that would change one in place fails loudly rather than altering later scenes.
"""

from __future__ import annotations

from collections import OrderedDict
from typing import Callable, Hashable, TypeVar

import numpy as np

from .scene import MeshData
from .seeding import stable_int

# Entries kept per process: a built shape and its texture layout each count one. 55 procedural
# categories x 32 variants x 2 is 3,520 entries, about 150 MB; a recipe asking for more variants
# than this holds rebuilds the least recently used ones (slower, never different).
CAPACITY = 8192

T = TypeVar("T")
_BANK: OrderedDict[Hashable, object] = OrderedDict()


def variant_params(category: str, ranges: dict[str, tuple[float, float]], variant: int) -> dict[str, float]:
    """The shape parameters of one variant: uniform in each range, from a generator seeded by
    the category, its ranges and the variant number (a catalogue that changes a range changes
    that category's variants, not anyone else's)."""
    spelled = ";".join(f"{name}={lo!r},{hi!r}" for name, (lo, hi) in sorted(ranges.items()))
    rng = np.random.default_rng(stable_int("shape variant", category, spelled, variant))
    return {name: float(rng.uniform(lo, hi)) for name, (lo, hi) in sorted(ranges.items())}


def banked(key: Hashable, build: Callable[[], T]) -> T:
    """``build()``'s value for ``key``, built at most once while it stays in the bank."""
    if key in _BANK:
        _BANK.move_to_end(key)
        return _BANK[key]  # type: ignore[return-value]
    value = build()
    for mesh in _meshes(value):
        for array in (mesh.vertices_m, mesh.faces, mesh.texcoords, mesh.face_texcoords):
            if array is not None:
                array.flags.writeable = False
    _BANK[key] = value
    if len(_BANK) > CAPACITY:
        _BANK.popitem(last=False)
    return value


def size() -> int:
    """How many entries the bank holds (for benchmarks and tests)."""
    return len(_BANK)


def clear() -> None:
    _BANK.clear()


def _meshes(value: object):
    if isinstance(value, MeshData):
        yield value
    elif isinstance(value, tuple):
        for item in value:
            yield from _meshes(item)
