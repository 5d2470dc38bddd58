"""Procedural object assets: the YAML catalogue, validated, and sampling of one asset from it.

The catalogue (``scene_assets/catalogue.yaml``) is data: sizes, colour words, materials and
semantic fronts. The shape builders it names live in ``shapes.py``. ``build_asset`` draws only from the generator it is given, so an
asset is a pure function of the catalogue and the generator state.
"""

from __future__ import annotations

import hashlib
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable

import numpy as np
import trimesh
import yaml

from .paths import assets_dir
from .scene import Asset, MeshData
from .shapes import BUILDER_LIMITS, BUILDER_PARAMS, BUILDERS



_UNIT_TOL = 1e-3


class CatalogueError(ValueError):
    """A catalogue entry that cannot be used; the message names file, key and fix in one line."""


@dataclass(frozen=True)
class MaterialSpec:
    name: str
    specular: float  # MuJoCo material attributes, each in [0, 1]
    shininess: float
    reflectance: float


@dataclass(frozen=True)
class CategorySpec:
    key: str  # catalogue key, e.g. "teddy_bear"
    name: str  # short noun used in text, e.g. "teddy bear"
    plural: str
    builder: str
    params: dict[str, tuple[float, float]]  # name -> (min, max), sampled uniformly
    colors: tuple[str, ...]
    materials: tuple[str, ...]
    front_side: str  # e.g. "handle"
    front_vector: tuple[float, float, float]  # unit, object frame


@dataclass(frozen=True)
class Catalogue:
    categories: dict[str, CategorySpec]
    colors: dict[str, tuple[float, float, float]]
    materials: dict[str, MaterialSpec]
    sha256: str  # of the file bytes, so records can name the catalogue they came from


# ---------------------------------------------------------------- loading and validation

_TOP_KEYS = ("version", "colors", "materials", "categories")
_CATEGORY_KEYS = ("name", "plural", "builder", "params", "colors", "materials", "front")
_MATERIAL_KEYS = ("specular", "shininess", "reflectance")


class _Check:
    """Turns a bad value into a one-line CatalogueError naming the file, the key and the fix."""

    def __init__(self, file: str) -> None:
        self.file = file

    def error(self, key: str, message: str) -> CatalogueError:
        return CatalogueError(f"{self.file}: {key or '(top level)'}: {message}")

    def expect(self, key: str, expected: str, got: Any) -> CatalogueError:
        return self.error(key, f"expected {expected}, got {got!r}")

    def mapping(self, value: Any, key: str, keys: tuple[str, ...] = ()) -> dict:
        """A non-empty mapping with text keys; with `keys`, exactly those, so typos fail here."""
        if not isinstance(value, dict) or not value or not all(isinstance(k, str) for k in value):
            raise self.expect(key, "a non-empty mapping with text keys", value)
        for k in (k for k in keys if k not in value):
            raise self.error(key, f"missing key {k!r}; add it (required: {', '.join(keys)})")
        for k in (k for k in value if keys and k not in keys):
            raise self.error(f"{key}.{k}".lstrip("."), f"unknown key; remove it or use one of {', '.join(keys)}")
        return value

    def numbers(self, value: Any, key: str, n: int, expected: str, ok: Callable[..., bool]) -> tuple[float, ...]:
        """A list of n finite numbers that passes `ok`; a bare number when n == 0."""
        items = [value] if n == 0 else value if isinstance(value, list) and len(value) == n else [None]
        real = all(isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) for v in items)
        if not real or not ok(*items):
            raise self.expect(key, expected, value)
        return tuple(float(v) for v in items)

    def text(self, value: Any, key: str) -> str:
        if not isinstance(value, str) or not value.strip():
            raise self.expect(key, "a non-empty word or phrase", value)
        return value

    def words(self, value: Any, key: str, known: dict, section: str) -> tuple[str, ...]:
        if not isinstance(value, list) or not value or len(set(map(str, value))) != len(value):
            raise self.expect(key, f"a non-empty list of distinct words from {section}:", value)
        for word in (w for w in value if w not in known):
            raise self.expect(key, f"words defined under {section}: ({', '.join(sorted(known))})", word)
        return tuple(value)


def load_catalogue(path: Path | None = None) -> Catalogue:
    """Read and fully validate the catalogue, so a bad entry fails at load and not mid-run."""
    path = Path(path) if path is not None else assets_dir() / "catalogue.yaml"
    raw = path.read_bytes()
    ck = _Check(str(path))
    try:
        doc = yaml.safe_load(raw)
    except yaml.YAMLError as exc:
        raise ck.error("", f"not valid YAML ({' '.join(str(exc).split())}); fix the syntax") from exc
    top = ck.mapping(doc, "", _TOP_KEYS)
    if top["version"] != 1 or isinstance(top["version"], bool):
        raise ck.expect("version", "1 (the only catalogue format this code reads)", top["version"])
    in_unit = "[r, g, b] with each in [0, 1]"
    colors = {
        k: ck.numbers(v, f"colors.{k}", 3, in_unit, lambda *c: all(0 <= x <= 1 for x in c))
        for k, v in ck.mapping(top["colors"], "colors").items()
    }
    materials = {k: _material(ck, k, v) for k, v in ck.mapping(top["materials"], "materials").items()}
    entries = ck.mapping(top["categories"], "categories").items()
    categories = {k: _category(ck, k, v, colors, materials) for k, v in entries}
    return Catalogue(categories, colors, materials, hashlib.sha256(raw).hexdigest())  # type: ignore[arg-type]


def _material(ck: _Check, name: str, value: Any) -> MaterialSpec:
    entry = ck.mapping(value, f"materials.{name}", _MATERIAL_KEYS)
    attrs = {
        k: ck.numbers(entry[k], f"materials.{name}.{k}", 0, "a number in [0, 1]", lambda x: 0 <= x <= 1)[0]
        for k in _MATERIAL_KEYS
    }
    return MaterialSpec(name=name, **attrs)


def _category(ck: _Check, key: str, value: Any, colors: dict, materials: dict) -> CategorySpec:
    where = f"categories.{key}"
    entry = ck.mapping(value, where, _CATEGORY_KEYS)
    if entry["builder"] not in BUILDERS:
        raise ck.expect(f"{where}.builder", f"one of {', '.join(sorted(BUILDERS))}", entry["builder"])
    front = ck.mapping(entry["front"], f"{where}.front", ("side", "vector"))
    unit = f"a unit vector [x, y, z] in the object frame (length 1 within {_UNIT_TOL})"
    return CategorySpec(
        key=key,
        name=ck.text(entry["name"], f"{where}.name"),
        plural=ck.text(entry["plural"], f"{where}.plural"),
        builder=entry["builder"],
        params=_params(ck, entry["params"], f"{where}.params", entry["builder"]),
        colors=ck.words(entry["colors"], f"{where}.colors", colors, "colors"),
        materials=ck.words(entry["materials"], f"{where}.materials", materials, "materials"),
        front_side=ck.text(front["side"], f"{where}.front.side"),
        front_vector=ck.numbers(  # type: ignore[arg-type]
            front["vector"], f"{where}.front.vector", 3, unit, lambda *v: abs(math.hypot(*v) - 1) <= _UNIT_TOL
        ),
    )


def _params(ck: _Check, value: Any, where: str, builder: str) -> dict[str, tuple[float, float]]:
    """Ranges for exactly the builder's parameters, checked against the builder's limits."""
    raw, needs = ck.mapping(value, where), BUILDER_PARAMS[builder]
    for name in (n for n in needs if n not in raw):
        raise ck.error(where, f"builder {builder!r} needs {name}; add {name}: [min, max]")
    for name in (n for n in raw if n not in needs):
        raise ck.error(f"{where}.{name}", f"builder {builder!r} does not use it; remove it (uses {', '.join(needs)})")
    expected = "[min, max] with 0 < min <= max"
    ranges = {n: ck.numbers(raw[n], f"{where}.{n}", 2, expected, lambda lo, hi: 0 < lo <= hi) for n in needs}
    for rule in BUILDER_LIMITS[builder]:
        left, big = (side.strip() for side in rule.split("<="))
        small, k = left.split("*")
        hi, lo = ranges[small][1] * float(k), ranges[big][0] if big in ranges else float(big)
        if hi > lo:
            bound = f"min({big})" if big in ranges else big
            raise ck.error(where, f"expected max({small})*{k} <= {bound}, got {hi:.4g} > {lo:.4g}; narrow the ranges")
    return ranges  # type: ignore[return-value]


# ---------------------------------------------------------------- sampling


def build_asset(catalogue: Catalogue, category: str, rng: np.random.Generator, color: str | None = None) -> Asset:
    """Sample one instance of a category. The colour index is drawn even when `color` is given,
    so pinning a colour never moves the material or any later draw."""
    spec = catalogue.categories.get(category)
    if spec is None:
        raise ValueError(f"unknown category {category!r}; the catalogue has {', '.join(sorted(catalogue.categories))}")
    if color is not None and color not in spec.colors:
        raise ValueError(f"colour {color!r} is not allowed for {category!r}; allowed: {', '.join(spec.colors)}")
    params = {n: float(rng.uniform(lo, hi)) for n, (lo, hi) in sorted(spec.params.items())}
    drawn = spec.colors[int(rng.integers(len(spec.colors)))]
    material = spec.materials[int(rng.integers(len(spec.materials)))]
    color = drawn if color is None else color
    visual, parts = BUILDERS[spec.builder](params)
    return Asset(
        category=category, name=spec.name, color=color, rgba=(*catalogue.colors[color], 1.0), material=material,
        visual=_mesh_data(visual), collision=tuple(_mesh_data(p) for p in parts),
        front_local=spec.front_vector, front_side=spec.front_side, params=params,
    )


def _mesh_data(mesh: trimesh.Trimesh) -> MeshData:
    vertices = np.ascontiguousarray(mesh.vertices, dtype=np.float64)
    return MeshData(vertices_m=vertices, faces=np.ascontiguousarray(mesh.faces, dtype=np.int32))
