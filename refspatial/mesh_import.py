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
import math
import os
import re
import tempfile
import warnings
from dataclasses import dataclass, field
from importlib import metadata
from pathlib import Path
from typing import Any

import numpy as np
import trimesh
import yaml

from .scene import MeshData

TRIMESH_SUFFIXES = (".obj", ".glb", ".gltf", ".stl", ".ply", ".off")
USD_SUFFIXES = (".usd", ".usda", ".usdc", ".usdz")
COACD_DEFAULTS: dict[str, Any] = {  # CoACD's own defaults, with the part count capped for MuJoCo
    "threshold": 0.05,
    "max_convex_hull": 32,
    "preprocess_mode": "auto",
    "preprocess_resolution": 50,
    "resolution": 2000,
    "mcts_nodes": 20,
    "mcts_iterations": 150,
    "mcts_max_depth": 3,
    "seed": 0,
}
MIN_PART_VOLUME_M3 = 1e-10  # slivers below this (0.1 mm^3) are dropped: MuJoCo rejects them
_REQUIRED = ("category", "name", "plural", "color", "up", "front", "licence", "source")
_OPTIONAL = ("front_side", "scale", "size_m", "collision")
_AXIS = re.compile(r"^([+-]?)([xyz])$")


class MeshImportError(ValueError):
    """A mesh or annotation that cannot be imported; one line naming the file, key and fix."""


@dataclass(frozen=True)
class MeshAnnotation:
    category: str
    name: str
    plural: str
    color: str
    up: tuple[float, float, float]  # the file's up axis, unit, file frame
    front: tuple[float, float, float]  # the semantic front, file frame
    licence: str
    source: str
    front_side: str = "front"
    scale: float | None = None  # metres per file unit
    size_m: float | None = None  # or: the longest extent after import
    collision: dict[str, Any] = field(default_factory=lambda: {"method": "coacd"})

    @property
    def licence_text(self) -> str:
        """What an Asset records: the licence and, for attribution, where the mesh came from."""
        return f"{self.licence}; source: {self.source}"


@dataclass(frozen=True, eq=False)
class ImportedMesh:
    annotation: MeshAnnotation
    annotation_path: Path
    mesh_path: Path
    visual: MeshData  # object frame, metres
    parts: tuple[MeshData, ...]  # convex collision parts, object frame
    sha256: str  # of the mesh file and the annotation bytes
    decomposition: str  # "coacd", "hull" (asked for) or "hull-fallback" (CoACD missing)


# ---------------------------------------------------------------- annotation


def annotation_path_for(mesh_path: Path) -> Path:
    return Path(mesh_path).with_suffix(".yaml")


def load_annotation(path: Path) -> MeshAnnotation:
    """Read and validate an annotation file; every problem names the file and the key."""
    try:
        doc = yaml.safe_load(Path(path).read_text())
    except (OSError, yaml.YAMLError) as exc:
        raise MeshImportError(f"{path}: cannot read the annotation ({' '.join(str(exc).split())})") from exc
    if not isinstance(doc, dict):
        raise MeshImportError(f"{path}: expected a mapping of {', '.join(_REQUIRED)}")
    for key in (k for k in _REQUIRED if k not in doc):
        raise MeshImportError(f"{path}: missing key {key!r}; add it (required: {', '.join(_REQUIRED)})")
    for key in (k for k in doc if k not in _REQUIRED + _OPTIONAL):
        raise MeshImportError(f"{path}: {key}: unknown key; remove it or use one of {', '.join(_REQUIRED + _OPTIONAL)}")
    texts = {k: _text(path, k, doc[k]) for k in ("category", "name", "plural", "color", "licence", "source")}
    if ("scale" in doc) == ("size_m" in doc):
        raise MeshImportError(
            f"{path}: give exactly one of scale (metres per file unit) or size_m (longest extent, metres)"
        )
    size_key = "scale" if "scale" in doc else "size_m"
    return MeshAnnotation(
        **texts,
        up=_axis(path, doc["up"]),
        front=_vector(path, doc["front"]),
        front_side=_text(path, "front_side", doc.get("front_side", "front")),
        **{size_key: _positive(path, size_key, doc[size_key])},
        collision=_collision(path, doc.get("collision")),
    )


def _text(path: Path, key: str, value: Any) -> str:
    if not isinstance(value, str) or not value.strip():
        raise MeshImportError(f"{path}: {key}: expected a non-empty word or phrase, got {value!r}")
    return value


def _positive(path: Path, key: str, value: Any) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value) or value <= 0:
        raise MeshImportError(f"{path}: {key}: expected a positive number, got {value!r}")
    return float(value)


def _axis(path: Path, value: Any) -> tuple[float, float, float]:
    match = _AXIS.match(str(value).strip().lower())
    if not match:
        raise MeshImportError(f"{path}: up: expected one of +x, -x, +y, -y, +z, -z, got {value!r}")
    vector = np.zeros(3)
    vector["xyz".index(match.group(2))] = -1.0 if match.group(1) == "-" else 1.0
    return tuple(vector)  # type: ignore[return-value]


def _vector(path: Path, value: Any) -> tuple[float, float, float]:
    ok = (
        isinstance(value, list)
        and len(value) == 3
        and all(isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) for v in value)
    )
    if not ok or np.linalg.norm(value) < 1e-9:
        raise MeshImportError(f"{path}: front: expected a non-zero vector [x, y, z] in the file's axes, got {value!r}")
    v = np.asarray(value, dtype=float)
    return tuple(v / np.linalg.norm(v))  # type: ignore[return-value]


def _collision(path: Path, value: Any) -> dict[str, Any]:
    settings = dict(value or {"method": "coacd"})
    method = settings.pop("method", "coacd")
    if method == "hull" and not settings:
        return {"method": "hull"}
    if method != "coacd":
        raise MeshImportError(f"{path}: collision.method: expected coacd or hull, got {method!r}")
    for key in (k for k in settings if k not in COACD_DEFAULTS):
        raise MeshImportError(f"{path}: collision.{key}: unknown CoACD setting; use {', '.join(COACD_DEFAULTS)}")
    return {"method": "coacd", **COACD_DEFAULTS, **settings}


# ---------------------------------------------------------------- reading


def read_mesh(path: Path) -> tuple[np.ndarray, np.ndarray]:
    """(vertices (N, 3) float64, faces (M, 3) int64) in the file's own units and axes, every
    part of a multi-mesh file merged with its scene transform applied."""
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix in USD_SUFFIXES:
        return _read_usd(path)
    if suffix not in TRIMESH_SUFFIXES:
        known = ", ".join(TRIMESH_SUFFIXES + USD_SUFFIXES)
        raise MeshImportError(f"{path}: unsupported mesh format {suffix!r}; convert it to one of {known}")
    try:
        mesh = trimesh.load(path, force="mesh", process=True)
    except Exception as exc:  # trimesh raises many types for broken files
        raise MeshImportError(f"{path}: cannot read the mesh ({' '.join(str(exc).split())})") from exc
    if not isinstance(mesh, trimesh.Trimesh) or len(mesh.faces) == 0:
        raise MeshImportError(f"{path}: the file holds no triangles; export the object as a triangle mesh")
    return np.asarray(mesh.vertices, dtype=np.float64), np.asarray(mesh.faces, dtype=np.int64)


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
    v = np.asarray(vertices, dtype=np.float64) @ frame_rotation(note.up, note.front).T
    extent = float(np.ptp(v, axis=0).max())
    if extent <= 0:
        raise MeshImportError("the mesh has no extent (all vertices coincide)")
    v *= note.scale if note.scale is not None else note.size_m / extent  # type: ignore[operator]
    lo, hi = v.min(axis=0), v.max(axis=0)
    v -= [(lo[0] + hi[0]) / 2, (lo[1] + hi[1]) / 2, lo[2]]
    mesh = trimesh.Trimesh(v, faces, process=True)
    mesh.remove_unreferenced_vertices()
    if mesh.is_watertight and mesh.volume < 0:
        mesh.invert()
    return mesh


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
    vertices, faces = read_mesh(mesh_path)
    try:
        mesh = normalise(vertices, faces, note)
    except MeshImportError as exc:
        raise MeshImportError(f"{note_path}: {exc}") from None
    parts, method = convex_parts(mesh, note.collision, cache_dir)
    digest = hashlib.sha256(mesh_path.read_bytes())  # (a .gltf's external .bin files are not included)
    digest.update(note_path.read_bytes())
    return ImportedMesh(
        annotation=note,
        annotation_path=note_path,
        mesh_path=mesh_path,
        visual=_data(mesh),
        parts=tuple(_data(p) for p in parts),
        sha256=digest.hexdigest(),
        decomposition=method,
    )


def _data(mesh: trimesh.Trimesh) -> MeshData:
    return MeshData(
        np.ascontiguousarray(mesh.vertices, dtype=np.float64), np.ascontiguousarray(mesh.faces, dtype=np.int32)
    )
