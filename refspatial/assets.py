"""Object assets: the YAML catalogue, validated, and sampling of one asset from it.

The catalogue (``scene_assets/catalogue.yaml``) is data: groups, sizes, colour words,
materials, semantic fronts, container cavities and support flags. Procedural categories name a
shape builder in ``refspatial.shapes``; ``builder: mesh`` categories name a user's mesh file and
its annotation, imported once at load by ``refspatial.mesh_import``. ``build_asset`` draws only
from the generator it is given, so an asset is a pure function of the catalogue and the
generator state.
"""

from __future__ import annotations

import dataclasses
import hashlib
import math
import re
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable

import numpy as np
import yaml

from .mesh_import import (
    ImportedMesh,
    MeshImportError,
    annotation_path_for,
    import_mesh,
    load_annotation,
)
from .looks import load_looks, look_texture, texture_layout
from .paths import assets_dir
from .scene import Asset, Cavity, MeshData
from .shape_bank import banked, variant_params
from .shapes import BUILDER_LIMITS, BUILDER_PARAMS, BUILDERS
from .shapes.geometry import FinalMesh

_UNIT_TOL = 1e-3
_YAML_LOADER = getattr(yaml, "CSafeLoader", yaml.SafeLoader)  # libyaml parses the catalogue 10x faster
MESH_BUILDER = "mesh"  # the builder name of imported meshes
MESH_PARAMS = ("scale",)  # the only parameter a mesh category may sample: a uniform scale factor
_NO_SCALING = {"scale": [1.0, 1.0]}


class CatalogueError(ValueError):
    """A catalogue entry that cannot be used; the message names file, key and fix in one line."""


@dataclass(frozen=True)
class TextureSpec:
    """A MuJoCo builtin 2-D texture, near-white so it shades the asset's colour without renaming
    it (MuJoCo multiplies the texture by the geom's rgba and maps it without texcoords)."""

    builtin: str  # "gradient", "checker" or "flat"
    mark: str  # "none", "edge", "cross" or "random"
    random: float  # share of texels set to markrgb when mark is "random", in [0, 1]
    rgb1: tuple[float, float, float]
    rgb2: tuple[float, float, float]
    markrgb: tuple[float, float, float]
    size_px: int  # width = height
    repeat: tuple[float, float]  # texrepeat, per metre with texuniform


@dataclass(frozen=True)
class MaterialSpec:
    name: str
    specular: float  # MuJoCo material attributes, each in [0, 1]
    shininess: float
    reflectance: float
    texture: TextureSpec | None = None  # wood grain, brushed metal, paper fibre...


@dataclass(frozen=True)
class CavitySpec:
    """A container's open space as expressions of the sampled parameters (see the catalogue)."""

    shape: str  # "cylinder" or "box", as in scene.Cavity
    half_x: str  # expression: radius (cylinder) or half extent along x (box)
    half_y: str
    floor_z: str
    rim_z: str

    def evaluate(self, params: dict[str, float]) -> Cavity:
        hx, hy, floor, rim = (evaluate(e, params) for e in (self.half_x, self.half_y, self.floor_z, self.rim_z))
        return Cavity(shape=self.shape, half_extents_m=(hx, hy), floor_z_m=floor, rim_z_m=rim)


@dataclass(frozen=True)
class CategorySpec:
    key: str  # catalogue key, e.g. "teddy_bear"
    name: str  # short noun used in text, e.g. "teddy bear"
    plural: str
    group: str  # e.g. "kitchen"; one of the catalogue's groups
    builder: str  # a name in BUILDERS, or "mesh"
    params: dict[str, tuple[float, float]]  # name -> (min, max), sampled uniformly
    colors: tuple[str, ...]
    materials: tuple[str, ...]
    front_side: str  # e.g. "handle"
    front_vector: tuple[float, float, float]  # unit, object frame
    support: bool = False  # other objects may be stacked on it (plate, book, box, tray...)
    cavity: CavitySpec | None = None  # open containers only
    mesh: ImportedMesh | None = None  # builder "mesh" only
    licence: str = "project-own (procedural)"


@dataclass(frozen=True)
class Catalogue:
    categories: dict[str, CategorySpec]
    colors: dict[str, tuple[float, float, float]]
    materials: dict[str, MaterialSpec]
    sha256: str  # of the file bytes (and of every imported mesh), so records can name the catalogue
    groups: dict[str, str] | None = None  # group word -> what belongs in it
    libraries: Any = None  # a library.LibraryMix when a run draws objects from asset libraries too


# ---------------------------------------------------------------- loading and validation

_TOP_KEYS = ("version", "groups", "colors", "materials", "categories")
_CATEGORY_KEYS = ("name", "plural", "group", "builder", "params", "colors", "materials", "front")
_OPTIONAL_KEYS = ("support", "cavity")
_MESH_KEYS = ("builder", "mesh", "group", "materials")
_MESH_OPTIONAL = ("annotation", "params", "support", "cavity")
_MATERIAL_KEYS = ("specular", "shininess", "reflectance")
_TEXTURE_KEYS = ("builtin", "mark", "random", "rgb1", "rgb2", "markrgb", "size_px", "repeat")
_BUILTINS = ("gradient", "checker", "flat")
_MARKS = ("none", "edge", "cross", "random")
_CAVITY_KEYS = {
    "cylinder": ("shape", "radius", "floor_z", "rim_z"),
    "box": ("shape", "half_x", "half_y", "floor_z", "rim_z"),
}
_NUMBER = r"\d+(?:\.\d*)?|\.\d+"
_TERM = re.compile(rf"\s*([+-])?\s*(?:({_NUMBER})\s*\*\s*)?(?:([a-z_][a-z0-9_]*)|({_NUMBER}))\s*")  # sign k*name|number


class _Check:
    """Turns a bad value into a one-line CatalogueError naming the file, the key and the fix."""

    def __init__(self, file: str) -> None:
        self.file = file

    def error(self, key: str, message: str) -> CatalogueError:
        return CatalogueError(f"{self.file}: {key or '(top level)'}: {message}")

    def expect(self, key: str, expected: str, got: Any) -> CatalogueError:
        return self.error(key, f"expected {expected}, got {got!r}")

    def mapping(self, value: Any, key: str, keys: tuple[str, ...] = (), optional: tuple[str, ...] = ()) -> dict:
        """A non-empty mapping with text keys; with `keys`, exactly those (plus `optional`), so typos fail here."""
        if not isinstance(value, dict) or not value or not all(isinstance(k, str) for k in value):
            raise self.expect(key, "a non-empty mapping with text keys", value)
        for k in (k for k in keys if k not in value):
            raise self.error(key, f"missing key {k!r}; add it (required: {', '.join(keys)})")
        allowed = keys + optional
        for k in (k for k in value if keys and k not in allowed):
            raise self.error(f"{key}.{k}".lstrip("."), f"unknown key; remove it or use one of {', '.join(allowed)}")
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

    def flag(self, value: Any, key: str) -> bool:
        if not isinstance(value, bool):
            raise self.expect(key, "true or false", value)
        return value

    def word(self, value: Any, key: str, known: dict, section: str) -> str:
        if not isinstance(value, str) or value not in known:
            raise self.expect(key, f"a word defined under {section}: ({', '.join(sorted(known))})", value)
        return value

    def words(self, value: Any, key: str, known: dict, section: str) -> tuple[str, ...]:
        if not isinstance(value, list) or not value or len(set(map(str, value))) != len(value):
            raise self.expect(key, f"a non-empty list of distinct words from {section}:", value)
        for word in (w for w in value if w not in known):
            raise self.expect(key, f"words defined under {section}: ({', '.join(sorted(known))})", word)
        return tuple(value)


@dataclass(frozen=True)
class _Context:
    """What validating one category needs besides its own entry."""

    ck: _Check
    folder: Path  # mesh paths are relative to the catalogue's folder
    groups: dict[str, str]
    colors: dict[str, tuple[float, float, float]]
    materials: dict[str, MaterialSpec]
    cache_dir: Path | None


def load_catalogue(path: Path | None = None, cache_dir: Path | None = None) -> Catalogue:
    """Read and fully validate the catalogue, so a bad entry fails at load and not mid-run.
    Imported meshes are read, normalised and decomposed here (decompositions are cached in
    `cache_dir`, default ``mesh_import.default_cache_dir()``)."""
    path = Path(path) if path is not None else assets_dir() / "catalogue.yaml"
    raw = path.read_bytes()
    ck = _Check(str(path))
    try:
        doc = yaml.load(raw, Loader=_YAML_LOADER)
    except yaml.YAMLError as exc:
        raise ck.error("", f"not valid YAML ({' '.join(str(exc).split())}); fix the syntax") from exc
    top = ck.mapping(doc, "", _TOP_KEYS)
    if top["version"] != 1 or isinstance(top["version"], bool):
        raise ck.expect("version", "1 (the only catalogue format this code reads)", top["version"])
    groups = {k: ck.text(v, f"groups.{k}") for k, v in ck.mapping(top["groups"], "groups").items()}
    in_unit = "[r, g, b] with each in [0, 1]"
    colors = {
        k: ck.numbers(v, f"colors.{k}", 3, in_unit, lambda *c: all(0 <= x <= 1 for x in c))
        for k, v in ck.mapping(top["colors"], "colors").items()
    }
    materials = {k: _material(ck, k, v) for k, v in ck.mapping(top["materials"], "materials").items()}
    ctx = _Context(ck, path.parent, groups, colors, materials, cache_dir)  # type: ignore[arg-type]
    entries = ck.mapping(top["categories"], "categories").items()
    categories = {k: _category(ctx, k, v) for k, v in entries}
    digest = hashlib.sha256(raw)
    digest.update(load_looks().sha256.encode())  # textures are part of what an asset looks like
    for spec in (s for s in categories.values() if s.mesh is not None):
        digest.update(f"\n{spec.key}:{spec.mesh.sha256}".encode())  # type: ignore[union-attr]
    return Catalogue(categories, colors, materials, digest.hexdigest(), groups)  # type: ignore[arg-type]


def _material(ck: _Check, name: str, value: Any) -> MaterialSpec:
    entry = ck.mapping(value, f"materials.{name}", _MATERIAL_KEYS, ("texture",))
    attrs = {
        k: ck.numbers(entry[k], f"materials.{name}.{k}", 0, "a number in [0, 1]", lambda x: 0 <= x <= 1)[0]
        for k in _MATERIAL_KEYS
    }
    texture = _texture(ck, entry["texture"], f"materials.{name}.texture") if "texture" in entry else None
    return MaterialSpec(name=name, **attrs, texture=texture)


def _texture(ck: _Check, value: Any, where: str) -> TextureSpec:
    entry = ck.mapping(value, where, _TEXTURE_KEYS)
    for key, allowed in (("builtin", _BUILTINS), ("mark", _MARKS)):
        if entry[key] not in allowed:
            raise ck.expect(f"{where}.{key}", f"one of {', '.join(allowed)}", entry[key])
    unit, rgb = "a number in [0, 1]", "[r, g, b] with each in [0, 1]"

    def colour(key: str) -> tuple[float, float, float]:
        ok = lambda *c: all(0 <= x <= 1 for x in c)  # noqa: E731
        return ck.numbers(entry[key], f"{where}.{key}", 3, rgb, ok)  # type: ignore[return-value]

    whole = "a whole number in [8, 1024]"
    size = ck.numbers(entry["size_px"], f"{where}.size_px", 0, whole, lambda x: x == int(x) and 8 <= x <= 1024)[0]
    repeat = ck.numbers(entry["repeat"], f"{where}.repeat", 2, "[u, v] with each > 0", lambda u, v: u > 0 and v > 0)
    return TextureSpec(
        builtin=entry["builtin"], mark=entry["mark"],
        random=ck.numbers(entry["random"], f"{where}.random", 0, unit, lambda x: 0 <= x <= 1)[0],
        rgb1=colour("rgb1"), rgb2=colour("rgb2"), markrgb=colour("markrgb"), size_px=int(size),
        repeat=repeat,  # type: ignore[arg-type]
    )


def _category(ctx: _Context, key: str, value: Any) -> CategorySpec:
    where, ck = f"categories.{key}", ctx.ck
    if isinstance(value, dict) and value.get("builder") == MESH_BUILDER:
        return _mesh_category(ctx, key, value)
    entry = ck.mapping(value, where, _CATEGORY_KEYS, _OPTIONAL_KEYS)
    if entry["builder"] not in BUILDERS:
        known = ", ".join([*sorted(BUILDERS), MESH_BUILDER])
        raise ck.expect(f"{where}.builder", f"one of {known}", entry["builder"])
    front = ck.mapping(entry["front"], f"{where}.front", ("side", "vector"))
    unit = f"a unit vector [x, y, z] in the object frame (length 1 within {_UNIT_TOL})"
    return CategorySpec(
        key=key,
        name=ck.text(entry["name"], f"{where}.name"),
        plural=ck.text(entry["plural"], f"{where}.plural"),
        group=ck.word(entry["group"], f"{where}.group", ctx.groups, "groups"),
        builder=entry["builder"],
        params=_params(ck, entry["params"], f"{where}.params", entry["builder"]),
        colors=ck.words(entry["colors"], f"{where}.colors", ctx.colors, "colors"),
        materials=ck.words(entry["materials"], f"{where}.materials", ctx.materials, "materials"),
        front_side=ck.text(front["side"], f"{where}.front.side"),
        front_vector=ck.numbers(  # type: ignore[arg-type]
            front["vector"], f"{where}.front.vector", 3, unit, lambda *v: abs(math.hypot(*v) - 1) <= _UNIT_TOL
        ),
        support=ck.flag(entry.get("support", False), f"{where}.support"),
        cavity=_cavity(ck, entry.get("cavity"), f"{where}.cavity", BUILDER_PARAMS[entry["builder"]]),
    )


def _mesh_category(ctx: _Context, key: str, value: dict) -> CategorySpec:
    """An imported mesh: name, plural, colour, front and licence come from its annotation file."""
    where, ck = f"categories.{key}", ctx.ck
    entry = ck.mapping(value, where, _MESH_KEYS, _MESH_OPTIONAL)
    mesh_path = ctx.folder / ck.text(entry["mesh"], f"{where}.mesh")
    note = entry.get("annotation")
    note_path = ctx.folder / ck.text(note, f"{where}.annotation") if note is not None else None
    note_path = note_path or annotation_path_for(mesh_path)
    try:
        ck.word(load_annotation(note_path).color, f"{where} (color in {note_path})", ctx.colors, "colors")
        imported = import_mesh(mesh_path, note_path, cache_dir=ctx.cache_dir)  # the slow part: checked last
    except (MeshImportError, OSError) as exc:
        raise ck.error(f"{where}.mesh", " ".join(str(exc).split())) from exc
    a = imported.annotation
    return CategorySpec(
        key=key, name=a.name, plural=a.plural, group=ck.word(entry["group"], f"{where}.group", ctx.groups, "groups"),
        builder=MESH_BUILDER, params=_params(ck, entry.get("params", _NO_SCALING), f"{where}.params", MESH_BUILDER),
        colors=(a.color,), materials=ck.words(entry["materials"], f"{where}.materials", ctx.materials, "materials"),
        front_side=a.front_side, front_vector=(1.0, 0.0, 0.0),
        support=ck.flag(entry.get("support", False), f"{where}.support"),
        cavity=_cavity(ck, entry.get("cavity"), f"{where}.cavity", MESH_PARAMS), mesh=imported, licence=a.licence_text,
    )


def _params(ck: _Check, value: Any, where: str, builder: str) -> dict[str, tuple[float, float]]:
    """Ranges for exactly the builder's parameters, checked against the builder's limits."""
    raw = ck.mapping(value, where)
    needs = MESH_PARAMS if builder == MESH_BUILDER else BUILDER_PARAMS[builder]
    for name in (n for n in needs if n not in raw):
        raise ck.error(where, f"builder {builder!r} needs {name}; add {name}: [min, max]")
    for name in (n for n in raw if n not in needs):
        raise ck.error(f"{where}.{name}", f"builder {builder!r} does not use it; remove it (uses {', '.join(needs)})")
    expected = "[min, max] with 0 < min <= max"
    ranges = {n: ck.numbers(raw[n], f"{where}.{n}", 2, expected, lambda lo, hi: 0 < lo <= hi) for n in needs}
    for rule in BUILDER_LIMITS.get(builder, ()):
        left, big = (side.strip() for side in rule.split("<="))
        small, k = left.split("*")
        hi, lo = ranges[small][1] * float(k), ranges[big][0] if big in ranges else float(big)
        if hi > lo:
            bound = f"min({big})" if big in ranges else big
            raise ck.error(where, f"expected max({small})*{k} <= {bound}, got {hi:.4g} > {lo:.4g}; narrow the ranges")
    return ranges  # type: ignore[return-value]


def _cavity(ck: _Check, value: Any, where: str, names: tuple[str, ...]) -> CavitySpec | None:
    """A cavity entry: `shape` plus expressions ("radius_m - wall_m", "0.8*height_m", "0.004")
    in the parameters `names`, each checked by evaluating it with every parameter at 1."""
    if value is None:
        return None
    shape = value.get("shape") if isinstance(value, dict) else None
    if shape not in _CAVITY_KEYS:
        raise ck.expect(f"{where}.shape", "cylinder or box", shape)
    entry = ck.mapping(value, where, _CAVITY_KEYS[shape])
    exprs = {k: str(v) if isinstance(v, (int, float)) and not isinstance(v, bool) else v for k, v in entry.items()}
    for k in (k for k in exprs if k != "shape"):
        try:
            evaluate(ck.text(exprs[k], f"{where}.{k}"), dict.fromkeys(names, 1.0))
        except ValueError as exc:
            raise ck.error(f"{where}.{k}", str(exc)) from None
    hx, hy = (exprs["radius"], exprs["radius"]) if shape == "cylinder" else (exprs["half_x"], exprs["half_y"])
    return CavitySpec(shape, hx, hy, exprs["floor_z"], exprs["rim_z"])


def evaluate(expr: str, params: dict[str, float]) -> float:
    """Value of a sum of terms (`number`, `name` or `number*name`) joined by + and -."""
    total, pos = 0.0, 0
    while pos < len(expr) or pos == 0:
        match = _TERM.match(expr, pos)
        if not match or match.end() == pos or (pos > 0 and match.group(1) is None):
            hint = "use terms like 0.5*name, name or 0.01 joined by + and -"
            raise ValueError(f"cannot read {expr!r} at {expr[pos:]!r}; {hint}")
        sign, k, name, number = match.groups()
        if name is not None and name not in params:
            raise ValueError(f"{name!r} in {expr!r} is not a parameter (parameters: {', '.join(params)})")
        value = float(number) if number else float(k or 1.0) * params[name]
        total, pos = total - value if sign == "-" else total + value, match.end()
    return total


# ---------------------------------------------------------------- sampling


def build_asset(catalogue: Catalogue, category: str, rng: np.random.Generator, color: str | None = None,
                shape_variants: int = 0) -> Asset:
    """Sample one instance of a category. The colour index is drawn even when `color` is given,
    so pinning a colour never moves the material or any later draw. With ``shape_variants``
    (a recipe's `objects.shape_variants`), the shape is one of that many fixed variants of the
    category, built once per process (``refspatial.shape_bank``)."""
    spec = catalogue.categories.get(category)
    if spec is None:
        raise ValueError(f"unknown category {category!r}; the catalogue has {', '.join(sorted(catalogue.categories))}")
    if color is not None and color not in spec.colors:
        raise ValueError(f"colour {color!r} is not allowed for {category!r}; allowed: {', '.join(spec.colors)}")
    if shape_variants:
        params = variant_params(category, spec.params, int(rng.integers(shape_variants)))
    else:
        params = {n: float(rng.uniform(lo, hi)) for n, (lo, hi) in sorted(spec.params.items())}
    drawn = spec.colors[int(rng.integers(len(spec.colors)))]
    material = spec.materials[int(rng.integers(len(spec.materials)))]
    color = drawn if color is None else color
    flat = spec.mesh.rgb if spec.mesh is not None and spec.mesh.rgb is not None else catalogue.colors[color]
    texture = spec.mesh.texture if spec.mesh is not None else None
    # An imported mesh is only scaled (no building to save); a procedural shape of a variant is banked.
    bank = shape_variants > 0 and spec.mesh is None
    visual, parts = _shape(spec, params, bank)
    if visual.texcoords is None:  # an imported mesh brings its own texture; procedural ones get a look
        looks = load_looks()
        texture = look_texture(looks, category, material, flat, params)
        if texture is not None:
            visual = _laid_out(looks, spec, params, visual, bank)
    return Asset(
        category=category, name=spec.name, color=color, rgba=(*flat, 1.0), material=material,
        visual=visual, collision=parts, texture=texture, front_local=spec.front_vector, front_side=spec.front_side,
        params=params,
        licence=spec.licence, cavity=spec.cavity.evaluate(params) if spec.cavity else None, support=spec.support,
    )


def build_variants(catalogue: Catalogue, categories: list[str], variants: int) -> list[tuple[MeshData, ...]]:
    """Build every shape variant of ``categories`` (and its texture layouts) into the
    per-process bank, and return each shape's collision parts. A warm-up: a long run's scenes
    find every variant built (benchmarks call it to measure that steady state); records are the
    same with or without it."""
    looks, out = load_looks(), []
    for category in sorted(set(categories)):
        spec = catalogue.categories[category]
        if spec.mesh is not None:
            continue
        for variant in range(variants):
            params = variant_params(category, spec.params, variant)
            visual, parts = _shape(spec, params, bank=True)
            if any(looks.choices(category, m) for m in spec.materials):
                _laid_out(looks, spec, params, visual, bank=True)
            out.append(parts)
    return out


def _shape_key(spec: CategorySpec, params: dict[str, float]) -> tuple:
    return spec.key, spec.builder, tuple(sorted(params.items()))


def _shape(spec: CategorySpec, params: dict[str, float], bank: bool) -> tuple[MeshData, tuple[MeshData, ...]]:
    if not bank:
        return _geometry(spec, params)
    return banked(_shape_key(spec, params), lambda: _geometry(spec, params))


def _laid_out(looks, spec: CategorySpec, params: dict[str, float], visual: MeshData, bank: bool) -> MeshData:
    """The visual mesh with its category's texture coordinates (banked with the shape)."""
    if not bank:
        return texture_layout(looks, spec.key, visual)
    return banked((*_shape_key(spec, params), looks.placement(spec.key)), lambda: texture_layout(looks, spec.key, visual))


def _geometry(spec: CategorySpec, params: dict[str, float]) -> tuple[MeshData, tuple[MeshData, ...]]:
    if spec.mesh is not None:
        k = params["scale"]
        scaled = (dataclasses.replace(m, vertices_m=m.vertices_m * k) for m in (spec.mesh.visual, *spec.mesh.parts))
        visual = next(scaled)
        return visual, tuple(scaled)
    visual, parts = BUILDERS[spec.builder](params)
    return _mesh_data(visual), tuple(_mesh_data(p) for p in parts)


def _mesh_data(mesh: FinalMesh) -> MeshData:
    vertices = np.ascontiguousarray(mesh.vertices, dtype=np.float64)
    return MeshData(vertices_m=vertices, faces=np.ascontiguousarray(mesh.faces, dtype=np.int32))
