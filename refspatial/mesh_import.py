"""Users' own meshes as assets: read, annotate, normalise, decompose for collision.

A mesh file (OBJ, GLB/GLTF, STL, PLY via trimesh; USD/USDA/USDC via usd-core) comes with a
small YAML annotation (``mug.glb`` -> ``mug.yaml`` beside it, unless named otherwise)::

    category: mug          # what it is (the catalogue key that uses it may differ: my_mug)
    name: mug              # the noun used in text
    plural: mugs
    color: white           # colour word (a catalogue colour when used in a catalogue)
    up: +y                 # the file's up axis: +x, -x, +y, -y, +z or -z
    front: [0, 0, 1]       # the semantic front in the file's own axes
    front_side: handle     # optional; the front's name in text (default "front")
    scale: 0.001           # metres per file unit; or size_m: 0.12, the longest extent in metres
    licence: CC-BY-4.0     # kept with every asset made from it
    source: https://example.org/mug
    collision: {method: coacd, threshold: 0.05}   # optional; or {method: hull}

GLB/GLTF base-colour textures and OBJ+MTL ``map_Kd`` textures come along with their texture
coordinates (``refspatial.mesh_texture``); a material with a base colour but no image gives
the asset that flat colour.

Import moves the mesh into the object frame (up -> +z, front -> +x, footprint centre on the
origin, lowest point on z=0, metres) and splits it into convex parts with CoACD, so a cup
stays hollow in physics. Decompositions take seconds, so they are cached on disk per
(normalised mesh, settings, CoACD version) in ``~/.cache/refspatial/coacd`` (or
``$REFSPATIAL_CACHE/coacd``, or the ``cache_dir`` argument). Without CoACD installed the
mesh collides as one convex hull, with a warning that says so.
"""

from __future__ import annotations

import hashlib
import json
import os
import tempfile
import warnings
from dataclasses import dataclass
from importlib import metadata
from pathlib import Path
from typing import Any

import numpy as np
import trimesh

from .mesh_annotation import (  # noqa: F401  (re-exported: callers import them from here)
    COACD_DEFAULTS,
    MeshAnnotation,
    MeshImportError,
    annotation_from_dict,
    annotation_path_for,
    load_annotation,
)
from .mesh_texture import Surface, surface_of, with_texcoords
from .scene import MeshData, Texture

TRIMESH_SUFFIXES = (".obj", ".glb", ".gltf", ".stl", ".ply", ".off")
USD_SUFFIXES = (".usd", ".usda", ".usdc", ".usdz")
MIN_PART_VOLUME_M3 = 1e-10  # slivers below this (0.1 mm^3) are dropped: MuJoCo rejects them


@dataclass(frozen=True, eq=False)
class ImportedMesh:
    annotation: MeshAnnotation
    annotation_path: Path
    mesh_path: Path
    visual: MeshData  # object frame, metres
    parts: tuple[MeshData, ...]  # convex collision parts, object frame
    sha256: str  # of the mesh file and the annotation bytes
    decomposition: str  # "coacd", "hull" (asked for) or "hull-fallback" (CoACD missing)
    texture: Texture | None = None  # mapped through visual.texcoords
    rgb: tuple[float, float, float] | None = None  # the material's flat base colour, when it has no image


# ---------------------------------------------------------------- reading



def read_mesh(path: Path) -> tuple[np.ndarray, np.ndarray]:
    """(vertices (N, 3) float64, faces (M, 3) int64) in the file's own units and axes, every
    part of a multi-mesh file merged with its scene transform applied."""
    vertices, faces, _ = read_mesh_surface(path)
    return vertices, faces


def read_mesh_surface(path: Path) -> tuple[np.ndarray, np.ndarray, Surface]:
    """As ``read_mesh``, with the base-colour texture and per-corner UVs, or flat colour, of
    GLB/GLTF and OBJ+MTL files (USD, STL and PLY import as geometry only)."""
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix in USD_SUFFIXES:
        return (*_read_usd(path), Surface())
    if suffix not in TRIMESH_SUFFIXES:
        known = ", ".join(TRIMESH_SUFFIXES + USD_SUFFIXES)
        raise MeshImportError(f"{path}: unsupported mesh format {suffix!r}; convert it to one of {known}")
    try:
        mesh = trimesh.load(path, force="mesh", process=True)
    except Exception as exc:  # trimesh raises many types for broken files
        raise MeshImportError(f"{path}: cannot read the mesh ({' '.join(str(exc).split())})") from exc
    if not isinstance(mesh, trimesh.Trimesh) or len(mesh.faces) == 0:
        raise MeshImportError(f"{path}: the file holds no triangles; export the object as a triangle mesh")
    faces = np.asarray(mesh.faces, dtype=np.int64)
    return np.asarray(mesh.vertices, dtype=np.float64), faces, surface_of(mesh)


def _read_usd(path: Path) -> tuple[np.ndarray, np.ndarray]:
    """Every visible UsdGeom.Mesh of the stage in stage coordinates, polygons fan-triangulated."""
    from pxr import Usd, UsdGeom

    stage = Usd.Stage.Open(str(path))
    if stage is None:
        raise MeshImportError(f"{path}: usd-core cannot open the stage")
    verts: list[np.ndarray] = []
    faces: list[np.ndarray] = []
    offset = 0
    time = Usd.TimeCode.Default()
    for prim in stage.Traverse():
        if not prim.IsA(UsdGeom.Mesh) or UsdGeom.Imageable(prim).ComputeVisibility(time) == UsdGeom.Tokens.invisible:
            continue
        mesh = UsdGeom.Mesh(prim)
        points = np.asarray(mesh.GetPointsAttr().Get(time) or [], dtype=np.float64).reshape(-1, 3)
        counts = np.asarray(mesh.GetFaceVertexCountsAttr().Get(time) or [], dtype=np.int64)
        indices = np.asarray(mesh.GetFaceVertexIndicesAttr().Get(time) or [], dtype=np.int64)
        if len(points) == 0 or len(counts) == 0:
            continue
        M = np.asarray(mesh.ComputeLocalToWorldTransform(time), dtype=np.float64)  # row vectors: p @ M
        tris = _fan(counts, indices)
        if mesh.GetOrientationAttr().Get(time) == UsdGeom.Tokens.leftHanded:
            tris = tris[:, ::-1]
        verts.append(points @ M[:3, :3] + M[3, :3])
        faces.append(tris + offset)
        offset += len(points)
    if not faces:
        raise MeshImportError(f"{path}: no visible UsdGeom.Mesh prims with faces in the stage")
    return np.vstack(verts), np.vstack(faces)


def _fan(counts: np.ndarray, indices: np.ndarray) -> np.ndarray:
    """Triangles (i0, ik, ik+1) of each polygon; faces with fewer than 3 vertices are skipped."""
    starts = np.concatenate([[0], np.cumsum(counts)[:-1]])
    tris = [
        np.column_stack([np.full(n - 2, indices[s]), indices[s + 1 : s + n - 1], indices[s + 2 : s + n]])
        for s, n in zip(starts, counts)
        if n >= 3
    ]
    return np.vstack(tris) if tris else np.zeros((0, 3), dtype=np.int64)


# ---------------------------------------------------------------- object frame


def frame_rotation(up: tuple[float, float, float], front: tuple[float, float, float]) -> np.ndarray:
    """Rotation taking the file's up to +z and its front (made horizontal) to +x."""
    z = np.asarray(up, dtype=float)
    x = np.asarray(front, dtype=float) - np.dot(front, z) * z
    if np.linalg.norm(x) < 0.1:
        raise MeshImportError(f"front {front} is (nearly) parallel to up {up}; the front must point sideways")
    x /= np.linalg.norm(x)
    return np.stack([x, np.cross(z, x), z])  # rows: object axes in file coordinates


def normalise(vertices: np.ndarray, faces: np.ndarray, note: MeshAnnotation) -> trimesh.Trimesh:
    """The mesh in the object frame: rotated, scaled to metres, footprint centre at the origin
    and lowest point on z=0."""
    return normalise_textured(vertices, faces, note, None)[0]


def normalise_textured(vertices: np.ndarray, faces: np.ndarray, note: MeshAnnotation,
                       corner_uv: np.ndarray | None) -> tuple[trimesh.Trimesh, np.ndarray | None]:
    """``normalise``, carrying each face corner's uv along: merging duplicate positions only
    renumbers vertices (faces keep their order), and turning an inside-out mesh reverses every
    face's corners, so the uvs are reversed with them."""
    v = np.asarray(vertices, dtype=np.float64) @ frame_rotation(note.up, note.front).T
    extent = float(np.ptp(v, axis=0).max())
    if extent <= 0:
        raise MeshImportError("the mesh has no extent (all vertices coincide)")
    v *= note.scale if note.scale is not None else note.size_m / extent  # type: ignore[operator]
    lo, hi = v.min(axis=0), v.max(axis=0)
    v -= [(lo[0] + hi[0]) / 2, (lo[1] + hi[1]) / 2, lo[2]]
    mesh = trimesh.Trimesh(v, faces, process=True)
    mesh.remove_unreferenced_vertices()
    corners = v[np.asarray(faces)]
    if mesh.is_watertight and mesh.volume < 0:
        mesh.invert()
        corners = corners[:, ::-1]
        corner_uv = None if corner_uv is None else corner_uv[:, ::-1]
    aligned = len(mesh.faces) == len(corners) and np.allclose(mesh.vertices[mesh.faces], corners, atol=1e-9)
    if corner_uv is not None and not aligned:
        raise MeshImportError("reading dropped or reordered faces (non-finite vertices?), so the texture "
                              "coordinates cannot follow them; re-export the mesh with finite vertices")
    return mesh, corner_uv


def mesh_sha256(mesh: trimesh.Trimesh) -> str:
    digest = hashlib.sha256(np.ascontiguousarray(mesh.vertices, dtype="<f8").tobytes())
    digest.update(np.ascontiguousarray(mesh.faces, dtype="<i8").tobytes())
    return digest.hexdigest()


# ---------------------------------------------------------------- collision


def default_cache_dir() -> Path:
    root = os.environ.get("REFSPATIAL_CACHE")
    return (Path(root) if root else Path.home() / ".cache" / "refspatial") / "coacd"


def convex_parts(
    mesh: trimesh.Trimesh, collision: dict[str, Any], cache_dir: Path | None = None
) -> tuple[list[trimesh.Trimesh], str]:
    """Convex parts approximating the mesh and how they were made ("coacd", "hull", "hull-fallback")."""
    if collision.get("method") == "hull":
        return [mesh.convex_hull], "hull"
    try:
        import coacd
    except ImportError:
        warnings.warn(
            "coacd is not installed, so an imported mesh collides as one convex hull (a cup or basket "
            "becomes solid and nothing fits inside); install it with: pip install 'coacd>=1.0.14,<2'",
            stacklevel=3,
        )
        return [mesh.convex_hull], "hull-fallback"
    settings = {k: v for k, v in collision.items() if k != "method"}
    cache = Path(cache_dir) if cache_dir is not None else default_cache_dir()
    key = hashlib.sha256(
        json.dumps(
            {"mesh": mesh_sha256(mesh), "settings": settings, "coacd": metadata.version("coacd"), "format": 1},
            sort_keys=True,
        ).encode()
    ).hexdigest()
    cached = _read_parts(cache / f"{key}.npz")
    if cached is None:
        coacd.set_log_level("error")
        raw = coacd.run_coacd(coacd.Mesh(np.asarray(mesh.vertices), np.asarray(mesh.faces)), **settings)
        cached = [np.asarray(v, dtype=np.float64) for v, _ in raw]
        _write_parts(cache / f"{key}.npz", cached)
    parts = [p for p in (_convex(points) for points in cached) if p is not None]
    return (parts, "coacd") if parts else ([mesh.convex_hull], "hull")


def _convex(points: np.ndarray) -> trimesh.Trimesh | None:
    """The hull of one part's points (CoACD's own faces are not always exactly convex)."""
    if len(points) < 4:
        return None
    try:
        part = trimesh.convex.convex_hull(points)
    except (RuntimeError, ValueError, IndexError):  # qhull (QhullError) refuses flat or degenerate sets
        return None
    return part if part.volume > MIN_PART_VOLUME_M3 else None


def _read_parts(path: Path) -> list[np.ndarray] | None:
    if not path.is_file():
        return None
    try:
        with np.load(path) as data:
            return [data[f"part{i}"] for i in range(int(data["count"]))]
    except (OSError, ValueError, KeyError):
        return None  # a damaged cache entry is recomputed


def _write_parts(path: Path, parts: list[np.ndarray]) -> None:
    """Write next to the target, then rename: workers sharing the cache never see half a file."""
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, suffix=".npz.tmp")
    with os.fdopen(fd, "wb") as handle:
        np.savez(handle, count=len(parts), **{f"part{i}": p for i, p in enumerate(parts)})
    os.replace(tmp, path)


# ---------------------------------------------------------------- the whole import


def import_mesh(mesh_path: Path, annotation_path: Path | None = None, cache_dir: Path | None = None) -> ImportedMesh:
    """Read, annotate, normalise and decompose one mesh file."""
    mesh_path = Path(mesh_path)
    note_path = Path(annotation_path) if annotation_path is not None else annotation_path_for(mesh_path)
    note = load_annotation(note_path)
    return import_annotated(mesh_path, note, note_path, note_path.read_bytes(), cache_dir)


def import_annotated(mesh_path: Path, note: MeshAnnotation, where: Path, note_bytes: bytes,
                     cache_dir: Path | None = None) -> ImportedMesh:
    """``import_mesh`` with the annotation already read (from a YAML file or a table row at `where`)."""
    vertices, faces, surface = read_mesh_surface(mesh_path)
    try:
        mesh, corner_uv = normalise_textured(vertices, faces, note, surface.corner_uv)
    except MeshImportError as exc:
        raise MeshImportError(f"{where}: {exc}") from None
    parts, method = convex_parts(mesh, note.collision, cache_dir)
    digest = hashlib.sha256(Path(mesh_path).read_bytes())  # (a .gltf's external .bin files are not included)
    digest.update(note_bytes)
    if surface.texture is not None:  # an OBJ's map lives in another file: its pixels count too
        digest.update(surface.texture.key.encode())
    return ImportedMesh(
        annotation=note,
        annotation_path=Path(where),
        mesh_path=Path(mesh_path),
        visual=with_texcoords(_data(mesh), corner_uv),
        parts=tuple(_data(p) for p in parts),
        sha256=digest.hexdigest(),
        decomposition=method,
        texture=surface.texture,
        rgb=surface.rgb,
    )


def _data(mesh: trimesh.Trimesh) -> MeshData:
    return MeshData(
        np.ascontiguousarray(mesh.vertices, dtype=np.float64), np.ascontiguousarray(mesh.faces, dtype=np.int32)
    )
