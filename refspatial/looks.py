"""Looks: which texture each object and each room surface gets (``scene_assets/textures.yaml``).

An object's look is a pure function of its category, material, colour and shape parameters
(hashed, not drawn), so adding looks never moves a draw of the layout. A room surface's look
is drawn from the room's own generator. Users may point a recipe at a folder of images
(``room.images``): those join the surfaces' choices as they are.
"""

from __future__ import annotations

import functools
import hashlib
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import cv2
import numpy as np
import yaml

from . import textures, uv
from .paths import assets_dir
from .scene import MeshData, Texture
from .seeding import stable_int

PATTERN_SEEDS = 2  # distinct patterns per (look, colour): variety enough, and the per-process image cache mostly hits
DEFAULT_TILE_M = 0.12  # box projection repeat for finishes without a category entry
SURFACE_KINDS = ("floor", "wall", "top", "furniture", "outdoors")
IMAGE_SUFFIXES = (".png", ".jpg", ".jpeg")
MAX_IMAGE_PX = 1024  # a user's photo is scaled down to this: texels beyond it only cost upload time


class LooksError(ValueError):
    """textures.yaml or a user's image folder cannot be used; one line naming the file and key."""


@dataclass(frozen=True)
class Look:
    name: str
    generator: str
    size: tuple[int, int]  # height, width
    params: tuple[tuple[str, Any], ...]  # sorted items, hashable for the image cache
    colors: tuple[tuple[float, float, float], ...] = ()  # room looks only


@dataclass(frozen=True)
class Placement:
    """How a category's texture lies on its mesh (see textures.yaml)."""

    projection: str = "box"
    tile_m: float | None = DEFAULT_TILE_M
    face: tuple[float, float, float] | None = None
    face_cos: float = 1.0
    looks: tuple[str, ...] = ()  # empty: the material's finishes


@dataclass(frozen=True)
class Looks:
    looks: dict[str, Look]
    by_material: dict[str, tuple[str, ...]]
    categories: dict[str, Placement]
    surfaces: dict[str, tuple[str, ...]]
    sha256: str

    def placement(self, category: str) -> Placement:
        return self.categories.get(category, Placement())

    def choices(self, category: str, material: str) -> tuple[str, ...]:
        own = self.placement(category).looks
        return own or self.by_material.get(material, ())


@functools.lru_cache(maxsize=4)
def load_looks(path: Path | None = None) -> Looks:
    path = Path(path) if path is not None else assets_dir() / "textures.yaml"
    raw = path.read_bytes()
    doc = yaml.safe_load(raw)
    where = str(path)
    if not isinstance(doc, dict) or doc.get("version") != 1:
        raise LooksError(f"{where}: expected a mapping with version: 1")
    looks = {k: _look(where, k, v) for k, v in _mapping(where, "looks", doc.get("looks")).items()}

    def names(key: str, value: Any) -> tuple[str, ...]:
        if not isinstance(value, list) or not value or any(v not in looks for v in value):
            raise LooksError(f"{where}: {key}: expected a non-empty list of look names defined under looks, got {value!r}")
        return tuple(value)

    by_material = {k: names(f"by_material.{k}", v) for k, v in _mapping(where, "by_material", doc.get("by_material")).items()}
    categories = {k: _placement(where, k, v, names) for k, v in _mapping(where, "categories", doc.get("categories")).items()}
    surfaces = {k: names(f"surfaces.{k}", v) for k, v in _mapping(where, "surfaces", doc.get("surfaces")).items()}
    for kind in SURFACE_KINDS:
        if kind not in surfaces:
            raise LooksError(f"{where}: surfaces.{kind}: missing; list the looks a {kind} may get")
        if any(not looks[n].colors for n in surfaces[kind]):
            raise LooksError(f"{where}: surfaces.{kind}: every look a surface uses needs its own colors")
    return Looks(looks, by_material, categories, surfaces, hashlib.sha256(raw).hexdigest())


def _mapping(where: str, key: str, value: Any) -> dict:
    if not isinstance(value, dict) or not value:
        raise LooksError(f"{where}: {key}: expected a non-empty mapping")
    return value


def _look(where: str, name: str, value: Any) -> Look:
    entry = dict(_mapping(where, f"looks.{name}", value))
    gen, size = entry.pop("generator", None), entry.pop("size", None)
    if gen not in textures.GENERATORS:
        raise LooksError(f"{where}: looks.{name}.generator: expected one of {', '.join(sorted(textures.GENERATORS))}, got {gen!r}")
    if not (isinstance(size, list) and len(size) == 2 and all(isinstance(s, int) and 16 <= s <= 2048 for s in size)):
        raise LooksError(f"{where}: looks.{name}.size: expected [height, width] in pixels (16-2048), got {size!r}")
    colors = tuple(tuple(float(c) for c in rgb) for rgb in entry.pop("colors", ()))
    params = tuple(sorted((k, tuple(v) if isinstance(v, list) else v) for k, v in entry.items()))
    try:  # a missing or mistyped parameter fails here, not in the middle of a run
        textures.make(gen, params, (0.5, 0.5, 0.5), 0, (32, 32))
    except (KeyError, TypeError, ValueError) as exc:
        raise LooksError(f"{where}: looks.{name}: generator {gen!r} cannot use these parameters ({exc!r})") from None
    return Look(name, gen, (size[0], size[1]), params, colors)


def _placement(where: str, category: str, value: Any, names) -> Placement:
    entry = _mapping(where, f"categories.{category}", value)
    projection = entry.get("projection", "box")
    if projection not in uv.PROJECTIONS:
        raise LooksError(f"{where}: categories.{category}.projection: expected one of {', '.join(uv.PROJECTIONS)}")
    tile = None if entry.get("fit") else float(entry.get("tile_m", DEFAULT_TILE_M))
    face = tuple(float(c) for c in entry["face"]) if "face" in entry else None
    return Placement(projection, tile, face, float(entry.get("face_cos", 1.0)),
                     names(f"categories.{category}.looks", entry.get("looks")))


# ---------------------------------------------------------------- objects


def look_texture(looks: Looks, category: str, material: str, rgb: tuple[float, float, float],
                 params: dict[str, float]) -> Texture | None:
    """One object's texture (None where its category and material have no look)."""
    choices = looks.choices(category, material)
    if not choices:
        return None
    token = stable_int("look", category, material, *(f"{k}={v:.6f}" for k, v in sorted(params.items())))
    look = looks.looks[choices[token % len(choices)]]
    seed = (token >> 8) % PATTERN_SEEDS
    image = textures.make(look.generator, look.params, rgb, seed, look.size)
    key = f"{look.name}/{seed}/" + "-".join(f"{c:.3f}" for c in rgb)
    return Texture(key, image)


def texture_layout(looks: Looks, category: str, visual: MeshData) -> MeshData:
    """The visual mesh with its category's texture coordinates (the same for every look)."""
    p = looks.placement(category)
    if p.projection == "box":
        return uv.box(visual, p.tile_m, np.array(p.face) if p.face else None, p.face_cos)
    return uv.PROJECTIONS[p.projection](visual)


def texture_bank(looks: Looks, categories: dict, colors: dict[str, tuple[float, float, float]]) -> int:
    """Make every generated texture image that objects of ``categories`` (a catalogue's
    CategorySpecs) and room surfaces can ask for, into the per-process image cache (with each
    room surface's mean colour), and return how many there are. A warm-up: scenes then find
    every image made (benchmarks call it to measure a long run's steady state); records are the
    same with or without it."""
    wanted = set()
    for name, spec in categories.items():
        if spec.mesh is not None:  # imported meshes bring their own images
            continue
        for material in spec.materials:
            for look in (looks.looks[k] for k in looks.choices(name, material)):
                wanted.update((look, colors[c], seed) for c in spec.colors for seed in range(PATTERN_SEEDS))
    surfaces = set()
    for names in looks.surfaces.values():
        for look in (looks.looks[k] for k in names):
            surfaces.update((look, rgb, seed) for rgb in look.colors for seed in range(PATTERN_SEEDS))
    every = wanted | surfaces
    for look, rgb, seed in sorted(every, key=lambda w: (w[0].name, w[1], w[2])):
        textures.make(look.generator, look.params, rgb, seed, look.size)
        if (look, rgb, seed) in surfaces:  # a room surface's mean colour is memoised beside its image
            _texture_mean(look.generator, look.params, rgb, seed, look.size)
    return len(every)


# ---------------------------------------------------------------- room surfaces


@dataclass(frozen=True, eq=False)
class SurfaceLook:
    name: str  # look name, or "image:<file name>" for a user's image
    rgb: tuple[float, float, float]  # the surface's mean colour (for the audit and contrast checks)
    texture: Texture


def surface(looks: Looks, kind: str, rng: np.random.Generator, images: tuple[Path, ...] = ()) -> SurfaceLook:
    """One look for a room surface: a generated one, or (when a recipe names a folder) one of the
    user's images, each choice drawn from ``rng``."""
    names = looks.surfaces[kind]
    pick = int(rng.integers(len(names) + len(images)))
    color_draw = float(rng.random())
    seed = int(rng.integers(PATTERN_SEEDS))
    if pick >= len(names):
        path = images[pick - len(names)]
        image = user_image(path)
        return SurfaceLook(f"image:{path.name}", _mean(image), Texture(f"image:{_digest(path)}", image))
    look = looks.looks[names[pick]]
    rgb = look.colors[int(color_draw * len(look.colors))]
    image = textures.make(look.generator, look.params, rgb, seed, look.size)
    key = f"{look.name}/{seed}/" + "-".join(f"{c:.3f}" for c in rgb)
    return SurfaceLook(look.name, _texture_mean(look.generator, look.params, rgb, seed, look.size), Texture(key, image))


@functools.lru_cache(maxsize=textures.CACHE_IMAGES)
def _texture_mean(kind: str, params: tuple, rgb: tuple, seed: int, size: tuple) -> tuple[float, float, float]:
    """``_mean`` of a generated texture, memoised like the image itself: a room draws five to
    seven surfaces, and averaging a 256x256 image each time cost 3 ms a record."""
    return _mean(textures.make(kind, params, rgb, seed, size))


@functools.lru_cache(maxsize=16)
def image_folder(folder: str | Path) -> tuple[Path, ...]:
    """The images of a user's texture folder, sorted by name (so runs do not depend on the file
    system); listed once per process, not once per scene."""
    path = Path(folder).expanduser()
    if not path.is_dir():
        raise LooksError(f"room.images: {path} is not a folder; point it at a folder of .png or .jpg images")
    found = tuple(sorted(p for p in path.iterdir() if p.suffix.lower() in IMAGE_SUFFIXES))
    if not found:
        raise LooksError(f"room.images: {path} holds no .png or .jpg image; add some or remove the key")
    return found


@functools.lru_cache(maxsize=64)
def user_image(path: Path) -> np.ndarray:
    bgr = cv2.imread(str(path), cv2.IMREAD_COLOR)
    if bgr is None:
        raise LooksError(f"room.images: cannot read {path} as an image; remove it or convert it to PNG")
    scale = MAX_IMAGE_PX / max(bgr.shape[:2])
    if scale < 1:
        bgr = cv2.resize(bgr, (int(bgr.shape[1] * scale), int(bgr.shape[0] * scale)), interpolation=cv2.INTER_AREA)
    rgb = np.ascontiguousarray(bgr[..., ::-1])
    rgb.flags.writeable = False
    return rgb


def outdoor_view(path: Path, facing_rad: float, size: tuple[int, int]) -> Texture:
    """What a window facing ``facing_rad`` (world yaw of its outward direction) shows of a user's
    equirectangular image: 70 degrees of azimuth around that direction, from 15 degrees below the
    horizon to 30 above (the image's columns run once around, its rows from +90 to -90 degrees)."""
    pano = user_image(path)
    ph, pw, _ = pano.shape
    h, w = size
    az = facing_rad + np.radians(np.linspace(35, -35, w))  # left to right as seen from inside
    el = np.radians(np.linspace(30, -15, h))
    cols = ((0.5 - az / (2 * np.pi)) % 1.0 * pw).astype(int) % pw
    rows = np.clip(((0.5 - el / np.pi) * ph).astype(int), 0, ph - 1)
    view = np.ascontiguousarray(pano[rows[:, None], cols[None, :]])
    return Texture(f"image:{_digest(path)}:{np.degrees(facing_rad):.1f}", view)


@functools.lru_cache(maxsize=64)
def _digest(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()[:16]


def _mean(image: np.ndarray) -> tuple[float, float, float]:
    return tuple(float(c) for c in image.reshape(-1, 3).mean(axis=0) / 255.0)  # type: ignore[return-value]
