"""Texture coordinates for procedural meshes, by projection.

Builders make their meshes by boolean unions and hulls, which keep no texture coordinates,
so coordinates are laid on afterwards by projecting each face corner: a box projection by
the face's main axis, a cylinder wrapped once around +z (labels), or a sphere (fruit).
Coordinates are per face corner (``MeshData.face_texcoords``), so positions and smooth
normals stay shared while a seam or a chart border gets its own coordinates. v = 0 is the
image's bottom row (OpenGL).
"""

from __future__ import annotations

import numpy as np

from .scene import MeshData

ATLAS_BODY = (0.01, 0.49)  # u range of an atlas's body half; its face half is (0.51, 0.99)
ATLAS_FACE = (0.51, 0.99)


def _normals(corners: np.ndarray) -> np.ndarray:
    n = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    return n / np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-12)


def _per_corner(uv: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(M, 3, 2) corner coordinates -> texcoords (3M, 2) and face indices (M, 3)."""
    m = uv.shape[0]
    return (np.ascontiguousarray(uv.reshape(-1, 2), dtype=np.float32),
            np.arange(3 * m, dtype=np.int32).reshape(m, 3))


def box(mesh: MeshData, tile_m: float | None = None, face: np.ndarray | None = None,
        face_cos: float = 1.0) -> MeshData:
    """Each face takes the two coordinates across its main normal axis. With ``tile_m`` the
    texture repeats every tile_m metres; without, it spans the object's extent once (print on a
    box, a book's cover). With ``face`` (a direction) the texture is an atlas: faces whose normal
    is within acos(face_cos) of it get the face half, all others the body half."""
    corners = mesh.vertices_m[mesh.faces]  # (M, 3, 3)
    normals = _normals(corners)
    axis = np.argmax(np.abs(normals), axis=1)
    # The two coordinates across each axis, ordered so the texture reads upright on side faces.
    across = np.array([[1, 2], [0, 2], [0, 1]])[axis]  # (M, 2)
    uv = np.take_along_axis(corners, across[:, None, :], axis=2)  # (M, 3, 2)
    lo, hi = mesh.bounds_m
    if tile_m is not None:
        uv = uv / tile_m
    else:
        span = np.maximum(hi - lo, 1e-9)
        uv = (uv - lo[across][:, None, :]) / span[across][:, None, :]
    if face is not None:
        facing = normals @ (np.asarray(face, float) / np.linalg.norm(face)) >= face_cos
        lo_u, hi_u = np.where(facing, ATLAS_FACE[0], ATLAS_BODY[0]), np.where(facing, ATLAS_FACE[1], ATLAS_BODY[1])
        fitted = np.clip(uv[..., 0], 0.0, 1.0)
        uv = np.stack([lo_u[:, None] + fitted * (hi_u - lo_u)[:, None], np.clip(uv[..., 1], 0.0, 1.0)], axis=-1)
    return _with(mesh, uv)


def cylinder(mesh: MeshData) -> MeshData:
    """Wrapped once around +z: u = 0 on the front (+x) turning towards +y, v from the bottom
    (0) to the top (1). Caps (faces within 45 degrees of vertical) take the band at v near 1,
    the container's own finish above a label; faces across the seam are unwrapped."""
    corners = mesh.vertices_m[mesh.faces]
    lo, hi = mesh.bounds_m
    u = (np.arctan2(corners[..., 1], corners[..., 0]) / (2 * np.pi)) % 1.0  # (M, 3)
    # A face spanning the seam has corners near 0 and near 1: lift the small ones by a turn.
    wraps = (u.max(axis=1) - u.min(axis=1)) > 0.5
    u = np.where(wraps[:, None] & (u < 0.5), u + 1.0, u)
    v = (corners[..., 2] - lo[2]) / max(hi[2] - lo[2], 1e-9)
    # Caps take a thin strip of the finish above the label, the same u for all their corners
    # (a cap's centre has no angle).
    cap = np.abs(_normals(corners)[:, 2]) > np.cos(np.radians(45))
    v = np.where(cap[:, None], 0.97 + 0.02 * v, v)
    u = np.where(cap[:, None], 0.5, u)
    return _with(mesh, np.stack([u, v], axis=-1))


def sphere(mesh: MeshData) -> MeshData:
    """u around +z (as the cylinder), v by the polar angle from the bottom pole (0) to the top (1)."""
    corners = mesh.vertices_m[mesh.faces]
    lo, hi = mesh.bounds_m
    centre = (lo + hi) / 2
    d = corners - centre
    u = (np.arctan2(d[..., 1], d[..., 0]) / (2 * np.pi)) % 1.0
    wraps = (u.max(axis=1) - u.min(axis=1)) > 0.5
    u = np.where(wraps[:, None] & (u < 0.5), u + 1.0, u)
    # A corner on the axis (a pole) has no angle of its own: it takes its face's other corners'.
    pole = np.hypot(d[..., 0], d[..., 1]) < 1e-9
    others = np.where(pole, 0.0, u).sum(axis=1) / np.maximum((~pole).sum(axis=1), 1)
    u = np.where(pole, others[:, None], u)
    r = np.maximum(np.linalg.norm(d, axis=-1), 1e-12)
    v = 1.0 - np.arccos(np.clip(d[..., 2] / r, -1, 1)) / np.pi
    return _with(mesh, np.stack([u, v], axis=-1))


def _with(mesh: MeshData, uv: np.ndarray) -> MeshData:
    texcoords, face_texcoords = _per_corner(uv)
    return MeshData(mesh.vertices_m, mesh.faces, texcoords, face_texcoords)


PROJECTIONS = {"box": box, "cylinder": cylinder, "sphere": sphere}
