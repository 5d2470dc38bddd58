"""Asset libraries: folders of normalised imported meshes, and drawing scene objects from them.

``refspatial assets import`` (``library_import.py``) writes a library folder::

    library.json          index: format, content hash, one small entry per asset (metadata only)
    assets/<id>.npz       visual vertices/faces/texcoords and convex collision parts, object frame
    textures/<key>.png    base-colour images, named by the sha256 of their pixels

Opening a library reads the index only; an asset's arrays are read the first time a scene
draws it and kept in a per-process cache, so a run over a 2,000-asset library reads only the
assets its scenes use. The library's hash covers every entry, and each entry holds the sha256 of
its own arrays and pixels, checked when they are read: a scene is a pure function of (recipe,
seed, catalogue, the libraries' content), never of the files' paths or timestamps.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path
from typing import Any

import numpy as np
from PIL import Image

from .mesh_texture import texture_from_rgb
from .scene import Asset, MeshData, Texture

INDEX = "library.json"
FORMAT, VERSION = "refspatial-asset-library", 1
CACHE_ASSETS = 1024  # per process: a few hundred MB at most, even for detailed scans
DEFAULT_MATERIAL = "matte"  # a catalogue material: MuJoCo shading for entries that name none
_ENTRY_KEYS = ("id", "category", "name", "plural", "color", "material", "front_side", "licence", "source",
               "file", "texture", "rgb", "size_m", "sha256")


class LibraryError(ValueError):
    """A library that cannot be used; one line naming the folder (or file) and the fix."""


@dataclass(frozen=True)
class LibraryEntry:
    id: str
    category: str
    name: str
    plural: str
    color: str  # colour word used in text
    material: str  # a catalogue material name
    front_side: str
    licence: str
    source: str  # where the mesh came from (a URL, a dataset and its id)
    file: str  # the npz, relative to the library folder
    texture: str | None  # the PNG, relative to the library folder
    rgb: tuple[float, float, float] | None  # the material's flat base colour, if it had one
    size_m: tuple[float, float, float]
    sha256: str  # of the arrays and pixels (see ``content_sha256``)


@dataclass(frozen=True)
class Library:
    path: Path
    sha256: str
    entries: tuple[LibraryEntry, ...]  # sorted by id


@dataclass(frozen=True)
class LibraryMix:
    """The libraries a run draws from and the share of each scene's objects they supply."""

    libraries: tuple[Library, ...]
    share: float

    def manifest(self) -> list[dict[str, Any]]:
        return [{"path": str(lib.path), "sha256": lib.sha256, "assets": len(lib.entries)} for lib in self.libraries]


def content_sha256(arrays: dict[str, np.ndarray], texture_key: str | None) -> str:
    """The hash of an asset's arrays (names, dtypes, shapes, bytes) and its texture's pixels."""
    digest = hashlib.sha256()
    for name in sorted(arrays):
        a = np.ascontiguousarray(arrays[name])
        digest.update(f"{name}:{a.dtype.str}:{a.shape};".encode())
        digest.update(a.tobytes())
    digest.update(f"texture:{texture_key}".encode())
    return digest.hexdigest()


def library_sha256(entries: list[dict[str, Any]]) -> str:
    canonical = json.dumps({"format": FORMAT, "version": VERSION, "assets": entries}, sort_keys=True,
                           separators=(",", ":"))
    return hashlib.sha256(canonical.encode()).hexdigest()


def load_library(path: Path) -> Library:
    """Read a library's index (not its meshes) and check it."""
    path = Path(path)
    index = path / INDEX
    try:
        doc = json.loads(index.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise LibraryError(f"{path}: no {INDEX}; pass a folder made by `refspatial assets import`") from None
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise LibraryError(f"{index}: unreadable ({' '.join(str(exc).split())}); import the library again") from None
    if not isinstance(doc, dict) or doc.get("format") != FORMAT or doc.get("version") != VERSION:
        raise LibraryError(f"{index}: not a {FORMAT} version {VERSION} index; import the library again")
    raw = doc.get("assets")
    if not isinstance(raw, list) or not raw or any(not isinstance(e, dict) or set(e) != set(_ENTRY_KEYS) for e in raw):
        raise LibraryError(f"{index}: assets: expected a non-empty list of entries with keys {', '.join(_ENTRY_KEYS)}")
    if library_sha256(raw) != doc.get("sha256"):
        raise LibraryError(f"{index}: its entries do not match its sha256 (edited by hand?); import the library again")
    entries = tuple(_entry(e) for e in raw)
    return Library(path.resolve(), doc["sha256"], entries)


def _entry(e: dict[str, Any]) -> LibraryEntry:
    rgb = None if e["rgb"] is None else tuple(float(c) for c in e["rgb"])
    return LibraryEntry(**{**e, "rgb": rgb, "size_m": tuple(float(c) for c in e["size_m"])})


# ---------------------------------------------------------------- lazy geometry


@lru_cache(maxsize=CACHE_ASSETS)
def _geometry(folder: str, file: str, texture: str | None, sha256: str) -> tuple[MeshData, tuple[MeshData, ...],
                                                                                  Texture | None]:
    """One asset's meshes and texture, read once per process (the arguments are its identity)."""
    try:
        with np.load(Path(folder) / file) as data:
            arrays = {k: data[k] for k in data.files}
        rgb = None if texture is None else np.asarray(Image.open(Path(folder) / texture).convert("RGB"))
    except (OSError, ValueError) as exc:
        raise LibraryError(f"{Path(folder) / file}: unreadable ({' '.join(str(exc).split())}); "
                           "import the library again") from None
    tex = None if rgb is None else texture_from_rgb(rgb)
    if content_sha256(arrays, None if tex is None else tex.key) != sha256:
        raise LibraryError(f"{Path(folder) / file}: its content changed since import; import the library again")
    visual = MeshData(arrays["vertices"], arrays["faces"], arrays.get("texcoords"), arrays.get("face_texcoords"))
    parts = tuple(MeshData(arrays[f"part{i}_vertices"], arrays[f"part{i}_faces"])
                  for i in range(int(arrays["parts"])))
    return visual, parts, tex


def library_asset(library: Library, entry: LibraryEntry, colors: dict[str, tuple[float, float, float]]) -> Asset:
    """The entry as a scene asset. Its rgba is the material's flat colour, else the colour word's
    reference rgb (a textured asset's texture carries its look), else the texture's mean."""
    visual, parts, texture = _geometry(str(library.path), entry.file, entry.texture, entry.sha256)
    rgb = entry.rgb or colors.get(entry.color)
    if rgb is None:
        rgb = tuple(texture.rgb.reshape(-1, 3).mean(axis=0) / 255.0) if texture is not None else (0.5, 0.5, 0.5)
    return Asset(category=entry.category, name=entry.name, color=entry.color,
                 rgba=(*(float(c) for c in rgb), 1.0), material=entry.material, visual=visual, collision=parts,
                 front_local=(1.0, 0.0, 0.0), front_side=entry.front_side, licence=entry.licence,
                 texture=texture, source=entry.source)


# ---------------------------------------------------------------- drawing


def mix_in(objects: list[Asset], mix: LibraryMix, colors: dict[str, tuple[float, float, float]], repeat: float,
           rng: np.random.Generator) -> list[Asset]:
    """Replace a share of the drawn objects with library assets. round(share * n) is rounded
    stochastically, so the expected share is exact for any n; a replaced object repeats an earlier
    library pick with the recipe's repeat chance (ordinals need same-kind objects)."""
    n = len(objects)
    k = min(n, int(np.floor(mix.share * n + rng.random())))
    slots = sorted(int(s) for s in rng.choice(n, size=k, replace=False)) if k else []
    pool = [(lib, e) for lib in mix.libraries for e in lib.entries]
    picks: list[tuple[Library, LibraryEntry]] = []
    out = list(objects)
    for slot in slots:
        if picks and rng.random() < repeat:
            picks.append(picks[int(rng.integers(len(picks)))])
        else:
            picks.append(pool[int(rng.integers(len(pool)))])
        out[slot] = library_asset(*picks[-1], colors)
    return out


def attach(recipe, catalogue, paths: list[Path] | None = None, share: float | None = None):
    """(recipe, catalogue) drawing from the recipe's libraries plus `paths`, at `share` (else the
    recipe's). The recipe's ``libraries`` section becomes the libraries' content hashes and the
    share, so the recipe hash -- and with it every stage's seed, the manifest and resuming --
    follows the libraries' content. Without libraries both come back unchanged."""
    from .recipe import Recipe, recipe_hash

    own = recipe.option("libraries", "paths")
    folders = [recipe.path.parent / p for p in own] + [Path(p) for p in paths or []]
    if not folders:
        return recipe, catalogue
    if share is not None and not 0 <= share <= 1:
        raise LibraryError(f"--asset-share {share}: expected a share between 0 and 1")
    libraries = tuple(load_library(f) for f in folders)
    for lib in libraries:
        for entry in (e for e in lib.entries if e.material not in catalogue.materials):
            raise LibraryError(f"{lib.path}: asset {entry.id}: material {entry.material!r} is not in the catalogue; "
                               f"re-import it with one of {', '.join(sorted(catalogue.materials))}")
    mix = LibraryMix(libraries, recipe.option("libraries", "share") if share is None else float(share))
    data = {**recipe.data, "libraries": {"share": mix.share, "sha256": [lib.sha256 for lib in libraries]}}
    wanted = recipe.data.get("libraries", {}).get("sha256")
    if wanted and wanted != data["libraries"]["sha256"]:
        raise LibraryError(f"the recipe was made with libraries {', '.join(h[:12] for h in wanted)}, the folders "
                           f"given hold {', '.join(lib.sha256[:12] for lib in libraries)}; pass those libraries")
    attached = Recipe(recipe.name, recipe.path, data, recipe.text, recipe_hash(data))
    return attached, dataclasses.replace(catalogue, libraries=mix)
