"""``refspatial assets import SRC --out LIB``: a folder of annotated meshes -> an asset library.

Annotations come from one table in SRC, ``annotations.csv`` or ``annotations.jsonl`` (a row per
mesh: ``file`` relative to SRC plus the annotation keys of ``mesh_import``, and optionally
``material``, a catalogue material), or else from a YAML file beside each mesh. Meshes are
imported in a process pool; each import is cached on disk per (mesh bytes, the bytes of the
MTL/texture/buffer files it names, annotation), and CoACD decompositions by ``mesh_import``'s
own cache, so importing a grown folder again redoes only the new meshes. A mesh that cannot be
imported is skipped and reported with its reason; the library is written to a hidden folder and
renamed into place, so LIB is either the old library or the new one, never half of one.
"""

from __future__ import annotations

import csv
import hashlib
import io
import json
import os
import re
import tempfile
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass
from multiprocessing import get_context
from pathlib import Path
from typing import Any, Callable

import numpy as np
import yaml
from PIL import Image

from .library import DEFAULT_MATERIAL, FORMAT, INDEX, VERSION, LibraryError, content_sha256, library_sha256
from .mesh_import import (TRIMESH_SUFFIXES, USD_SUFFIXES, MeshImportError, annotation_from_dict,
                          annotation_path_for, default_cache_dir, import_annotated)
from .mesh_texture import texture_from_rgb
from .staging import staged_folder

TABLES = ("annotations.csv", "annotations.jsonl")
COLUMNS = ("file", "category", "name", "plural", "color", "up", "front", "front_side", "scale", "size_m",
           "licence", "source", "collision", "material")
_PARSED = ("front", "scale", "size_m", "collision")  # cells read as YAML values: [0, 0, 1], 0.001, {method: hull}
IMPORT_FORMAT = 1  # bump when what an import writes changes: old cache entries are then ignored


@dataclass(frozen=True)
class Item:
    """One mesh to import and its annotation (a mapping, as read from its table row or YAML)."""

    rel: str  # path relative to SRC, as written in the table
    mesh: Path
    note: dict[str, Any]
    where: str  # the annotation's origin for messages: a YAML path, or "annotations.csv row 7"


def find_items(src: Path) -> tuple[list[Item], list[tuple[str, str]]]:
    """The meshes of SRC with their annotations, and (file, reason) for each that has none."""
    src = Path(src)
    if not src.is_dir():
        raise LibraryError(f"{src}: not a folder; pass the folder that holds the meshes")
    tables = [src / t for t in TABLES if (src / t).is_file()]
    if len(tables) > 1:
        raise LibraryError(f"{src}: holds both {TABLES[0]} and {TABLES[1]}; keep one of them")
    if tables:
        return _table_items(src, tables[0]), []
    items, skipped = [], []
    for mesh in sorted(p for p in src.rglob("*") if p.suffix.lower() in TRIMESH_SUFFIXES + USD_SUFFIXES):
        note_path, rel = annotation_path_for(mesh), mesh.relative_to(src).as_posix()
        if not note_path.is_file():
            skipped.append((rel, f"no annotation: add {note_path.name} beside it, or list it in {TABLES[0]}"))
            continue
        try:
            note = yaml.safe_load(note_path.read_text(encoding="utf-8"))
        except (OSError, yaml.YAMLError) as exc:
            skipped.append((rel, f"{note_path}: unreadable YAML ({' '.join(str(exc).split())})"))
            continue
        items.append(Item(rel, mesh, note, str(note_path)))
    if not items and not skipped:
        raise LibraryError(f"{src}: no mesh files ({', '.join(TRIMESH_SUFFIXES + USD_SUFFIXES)}) found")
    return items, skipped


def _table_items(src: Path, table: Path) -> list[Item]:
    rows = _read_table(table)
    items = []
    for k, row in enumerate(rows, start=2 if table.suffix == ".csv" else 1):
        where = f"{table} {'row' if table.suffix == '.csv' else 'line'} {k}"
        unknown = sorted(set(row) - set(COLUMNS))
        if unknown:
            raise LibraryError(f"{where}: unknown column {unknown[0]!r}; columns are {', '.join(COLUMNS)}")
        if not isinstance(row.get("file"), str) or not row["file"].strip():
            raise LibraryError(f"{where}: file: expected the mesh's path relative to {src}")
        note = {key: value for key, value in row.items() if key != "file" and value not in (None, "")}
        items.append(Item(row["file"], src / row["file"], note, where))
    if not items:
        raise LibraryError(f"{table}: no rows; add one row per mesh (columns: {', '.join(COLUMNS)})")
    return items


def _read_table(table: Path) -> list[dict[str, Any]]:
    try:
        text = table.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise LibraryError(f"{table}: unreadable ({exc}); save it as UTF-8 text") from None
    if table.suffix == ".csv":
        rows = list(csv.DictReader(io.StringIO(text)))
        return [{k: _cell(k, v, table, n) for k, v in row.items()} for n, row in enumerate(rows, start=2)]
    rows = []
    for n, line in enumerate((ln for ln in text.splitlines()), start=1):
        if line.strip():
            try:
                row = json.loads(line)
            except json.JSONDecodeError as exc:
                raise LibraryError(f"{table} line {n}: not JSON ({exc.msg}); write one object per line") from None
            if not isinstance(row, dict):
                raise LibraryError(f"{table} line {n}: expected a JSON object with keys {', '.join(COLUMNS)}")
            rows.append(row)
    return rows


def _cell(key: str | None, value: Any, table: Path, row: int) -> Any:
    if key is None:  # csv puts surplus cells under None
        raise LibraryError(f"{table} row {row}: more cells than columns; quote cells that hold commas")
    if key not in _PARSED or not isinstance(value, str) or not value.strip():
        return value.strip() if isinstance(value, str) else value
    try:
        return yaml.safe_load(value)
    except yaml.YAMLError:
        raise LibraryError(f"{table} row {row}: {key}: cannot read {value!r}; write e.g. [0, 0, 1] or 0.001") from None


# ---------------------------------------------------------------- one asset (in a worker)


def asset_id(rel: str) -> str:
    """A file name for the asset, readable and unique per relative path."""
    stem = re.sub(r"[^A-Za-z0-9._-]+", "_", rel.rsplit(".", 1)[0]).strip("._")[:60] or "asset"
    return f"{stem}-{hashlib.sha256(rel.encode()).hexdigest()[:8]}"


def dependencies(mesh: Path) -> list[Path]:
    """Files a mesh file reads besides itself: an OBJ's MTL files and their maps, a glTF's buffers
    and images (what the import cache key must cover)."""
    found: list[Path] = []
    try:
        if mesh.suffix.lower() == ".obj":
            for line in mesh.read_text(errors="replace").splitlines():
                if line.startswith("mtllib "):
                    mtl = mesh.parent / line.split(None, 1)[1].strip()
                    found.append(mtl)
                    if mtl.is_file():
                        found += [mtl.parent / ln.split()[-1] for ln in mtl.read_text(errors="replace").splitlines()
                                  if ln.strip().startswith("map_") and len(ln.split()) > 1]
        elif mesh.suffix.lower() == ".gltf":
            doc = json.loads(mesh.read_text())
            found += [mesh.parent / x["uri"] for key in ("buffers", "images") for x in doc.get(key, [])
                      if "uri" in x and not x["uri"].startswith("data:")]
    except (OSError, ValueError):
        pass  # the import itself reports unreadable files
    return found


def _cache_key(item: Item, note_bytes: bytes) -> str:
    digest = hashlib.sha256(f"import-format {IMPORT_FORMAT}\n".encode() + note_bytes)
    for path in [item.mesh, *dependencies(item.mesh)]:
        digest.update(path.name.encode())
        digest.update(path.read_bytes() if path.is_file() else b"(missing)")
    return digest.hexdigest()


def import_item(item: Item, staging: Path, cache_dir: Path) -> tuple[dict[str, Any] | None, str, bool]:
    """(index entry or None, the reason it was skipped, whether the cache answered). `cache_dir` is
    the cache root: imports go under ``library/``, CoACD decompositions under ``coacd/``."""
    try:
        material = item.note.get("material", DEFAULT_MATERIAL)
        note = annotation_from_dict({k: v for k, v in item.note.items() if k != "material"}, item.where)
        if not isinstance(material, str) or not material.strip():
            raise MeshImportError(f"{item.where}: material: expected a catalogue material name, got {material!r}")
        if not item.mesh.is_file():
            raise MeshImportError(f"{item.mesh}: no such file; fix the path in {item.where}")
        note_bytes = json.dumps({**item.note, "material": material}, sort_keys=True, default=str).encode()
        cached = cache_dir / "library" / f"{_cache_key(item, note_bytes)}.npz"
        hit = cached.is_file()
        if not hit:
            _write_cached(cached, import_annotated(item.mesh, note, Path(item.where), note_bytes, cache_dir / "coacd"))
        with np.load(cached) as data:
            arrays = {k: data[k] for k in data.files}
    except (MeshImportError, OSError, ValueError) as exc:
        return None, " ".join(str(exc).split()), False
    meta = json.loads(bytes(arrays.pop("meta")).decode())
    rgb = arrays.pop("texture_rgb", None)
    texture = None if rgb is None else texture_from_rgb(rgb)
    ident = asset_id(item.rel)
    _write_npz(staging / "assets" / f"{ident}.npz", arrays)
    png = None
    if texture is not None:
        png = f"textures/{texture.key[:32]}.png"
        _write_png(staging / png, texture.rgb)
    lo, hi = arrays["vertices"].min(axis=0), arrays["vertices"].max(axis=0)
    entry = {"id": ident, **{k: getattr(note, k) for k in ("category", "name", "plural", "color", "front_side",
                                                           "licence", "source")},
             "material": material, "file": f"assets/{ident}.npz", "texture": png, "rgb": meta["rgb"],
             "size_m": [round(float(v), 9) for v in hi - lo],
             "sha256": content_sha256(arrays, None if texture is None else texture.key)}
    return entry, "", hit


def _write_cached(path: Path, imported) -> None:
    v = imported.visual
    arrays = {"vertices": v.vertices_m, "faces": v.faces, "parts": np.array(len(imported.parts))}
    if v.texcoords is not None:
        arrays |= {"texcoords": v.texcoords, "face_texcoords": v.face_texcoords}
    for i, part in enumerate(imported.parts):
        arrays |= {f"part{i}_vertices": part.vertices_m, f"part{i}_faces": part.faces}
    if imported.texture is not None:
        arrays["texture_rgb"] = imported.texture.rgb
    meta = {"rgb": None if imported.rgb is None else [float(c) for c in imported.rgb],
            "decomposition": imported.decomposition}
    arrays["meta"] = np.frombuffer(json.dumps(meta).encode(), dtype=np.uint8)
    _write_npz(path, arrays)


def _write_npz(path: Path, arrays: dict[str, np.ndarray]) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, suffix=".tmp")
    with os.fdopen(fd, "wb") as handle:
        np.savez(handle, **arrays)
    os.replace(tmp, path)  # workers sharing a cache never read half a file


def _write_png(path: Path, rgb: np.ndarray) -> None:
    if path.is_file():
        return  # named by its pixels: an existing file is this same image
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, suffix=".tmp")
    with os.fdopen(fd, "wb") as handle:
        Image.fromarray(rgb).save(handle, format="PNG")
    os.replace(tmp, path)


def _import_star(args: tuple[Item, Path, Path]) -> tuple[dict[str, Any] | None, str, bool]:
    return import_item(*args)


# ---------------------------------------------------------------- the whole library


@dataclass(frozen=True)
class ImportSummary:
    out: Path
    sha256: str
    imported: int
    skipped: list[tuple[str, str]]  # (file, reason)
    cached: int


def import_library(src: Path, out: Path, workers: int = 1, cache_dir: Path | None = None,
                   on_skip: Callable[[str, str], None] | None = None) -> ImportSummary:
    """Import every annotated mesh of `src` into the library folder `out` (replaced whole)."""
    out = Path(out)
    if out.exists() and not (out / INDEX).is_file() and (not out.is_dir() or any(out.iterdir())):
        raise LibraryError(f"--out {out}: exists and is not an asset library; choose a new or empty folder")
    items, skipped = find_items(src)
    total = len(items) + len(skipped)
    cache = Path(cache_dir) if cache_dir is not None else default_cache_dir().parent
    cannot = lambda why: LibraryError(f"--out {out}: cannot write there ({why}); choose another folder")  # noqa: E731
    with staged_folder(out, cannot) as staging:
        jobs = [(item, staging, cache) for item in items]
        if workers > 1 and len(jobs) > 1:
            with ProcessPoolExecutor(workers, mp_context=get_context("spawn")) as pool:
                results = list(pool.map(_import_star, jobs, chunksize=max(1, len(jobs) // (8 * workers))))
        else:
            results = [_import_star(job) for job in jobs]
        entries, hits = [], 0
        for item, (entry, reason, hit) in zip(items, results):
            if entry is None:
                skipped.append((item.rel, reason))
            else:
                entries.append(entry)
                hits += hit
        for rel, reason in skipped:
            if on_skip:
                on_skip(rel, reason)
        if not entries:
            raise LibraryError(f"{src}: none of {total} meshes could be imported; "
                               "fix the reasons listed above")
        entries.sort(key=lambda e: e["id"])
        sha = library_sha256(entries)
        index = {"format": FORMAT, "version": VERSION, "sha256": sha, "assets": entries}
        (staging / INDEX).write_text(json.dumps(index, indent=1, sort_keys=True) + "\n", encoding="utf-8")
    return ImportSummary(out, sha, len(entries), skipped, hits)
