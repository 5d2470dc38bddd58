"""The look of an imported mesh: its base-colour texture and texture coordinates, or a flat colour.

trimesh reads a GLB/GLTF material as a ``PBRMaterial`` (base-colour texture times base-colour
factor, as glTF defines it) and an OBJ+MTL one as a ``SimpleMaterial`` (``map_Kd``; ``Kd`` is
left out when there is a map, as most OBJ viewers do and as exporters that write a default
grey Kd beside every map expect). Its UVs are already in OpenGL's convention (v = 0 at the
image's bottom row; trimesh flips glTF's on reading).

Textures are capped at ``MAX_TEXTURE_PX`` on their longer side: scans ship 2k-8k maps, but an
object rendered at 960x540 covers a few hundred pixels, and a scene of 20 objects with 4k
maps would upload about 1 GB of texels per scene to the renderer.
"""

from __future__ import annotations

import hashlib
from dataclasses import dataclass

import numpy as np
import trimesh
from PIL import Image

from .scene import MeshData, Texture

MAX_TEXTURE_PX = 1024


@dataclass(frozen=True, eq=False)
class Surface:
    """What a mesh file says about colour, per face of the mesh it came with."""

    corner_uv: np.ndarray | None = None  # (M, 3, 2) float32: each face corner's uv (OpenGL v)
    texture: Texture | None = None
    rgb: tuple[float, float, float] | None = None  # a material's flat base colour, in [0, 1]


def surface_of(mesh: trimesh.Trimesh) -> Surface:
    """The texture (with per-corner UVs) or flat colour of a mesh trimesh has read."""
    visual = mesh.visual
    material = getattr(visual, "material", None)
    if not isinstance(visual, trimesh.visual.TextureVisuals) or material is None:
        return Surface()
    image, factor = _image_and_factor(material)
    uv = getattr(visual, "uv", None)
    usable = image is not None and uv is not None and len(uv) == len(mesh.vertices) and np.isfinite(uv).all()
    if not usable:
        return Surface(rgb=None if factor is None else tuple(float(c) for c in factor[:3]))
    rgb = np.asarray(image.convert("RGB"), dtype=np.uint8)
    if factor is not None and not np.allclose(factor[:3], 1.0):
        rgb = np.round(rgb * np.asarray(factor[:3])).clip(0, 255).astype(np.uint8)
    corner_uv = np.asarray(uv, dtype=np.float32)[np.asarray(mesh.faces)]
    return Surface(corner_uv=corner_uv, texture=texture_from_rgb(cap_size(rgb)))


def _image_and_factor(material) -> tuple[Image.Image | None, np.ndarray | None]:
    """The base-colour image and the factor that multiplies it (None: no factor applies)."""
    if isinstance(material, trimesh.visual.material.PBRMaterial):
        factor = material.baseColorFactor
        scaled = None if factor is None else np.asarray(factor, dtype=float) / 255.0
        return material.baseColorTexture, scaled
    image = getattr(material, "image", None)
    diffuse = getattr(material, "diffuse", None)
    flat = None if image is not None or diffuse is None else np.asarray(diffuse, dtype=float) / 255.0
    return image, flat


def cap_size(rgb: np.ndarray, limit: int = MAX_TEXTURE_PX) -> np.ndarray:
    """The image, downscaled (area-averaged, aspect kept) so its longer side is at most `limit`."""
    h, w = rgb.shape[:2]
    if max(h, w) <= limit:
        return np.ascontiguousarray(rgb)
    k = limit / max(h, w)
    size = (max(1, round(w * k)), max(1, round(h * k)))
    return np.asarray(Image.fromarray(rgb).resize(size, Image.Resampling.BOX), dtype=np.uint8)


def texture_from_rgb(rgb: np.ndarray) -> Texture:
    """A Texture keyed by the sha256 of its pixels and shape: the same image gives the same key
    whatever file, path or PNG encoder it came through."""
    rgb = np.ascontiguousarray(rgb, dtype=np.uint8)
    digest = hashlib.sha256(f"{rgb.shape}".encode())
    digest.update(rgb.tobytes())
    return Texture(key=digest.hexdigest(), rgb=rgb)


def indexed_texcoords(corner_uv: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(texcoords (K, 2) float32, face_texcoords (M, 3) int32): each distinct uv stored once,
    in sorted order, so the same mesh always gives the same arrays."""
    flat = np.asarray(corner_uv, dtype=np.float32).reshape(-1, 2)
    texcoords, inverse = np.unique(flat, axis=0, return_inverse=True)
    return np.ascontiguousarray(texcoords), inverse.reshape(-1, 3).astype(np.int32)


def with_texcoords(mesh: MeshData, corner_uv: np.ndarray | None) -> MeshData:
    """The mesh with per-corner texcoords (None leaves it untextured)."""
    if corner_uv is None:
        return mesh
    if len(corner_uv) != len(mesh.faces):
        raise ValueError(f"{len(corner_uv)} faces of texcoords for a mesh of {len(mesh.faces)} faces")
    texcoords, face_texcoords = indexed_texcoords(corner_uv)
    return MeshData(mesh.vertices_m, mesh.faces, texcoords, face_texcoords)


def face_colours(mesh: MeshData, texture: Texture) -> np.ndarray:
    """(M, 3) uint8: the texel under each face's centroid uv (nearest texel, uv wrapped) -- what a
    renderer shows in the middle of each face; tests and checks compare it with expectations."""
    assert mesh.texcoords is not None and mesh.face_texcoords is not None
    uv = mesh.texcoords[mesh.face_texcoords].mean(axis=1) % 1.0
    h, w = texture.rgb.shape[:2]
    cols = np.minimum((uv[:, 0] * w).astype(int), w - 1)
    rows = np.minimum(((1.0 - uv[:, 1]) * h).astype(int), h - 1)  # v = 0 is the bottom row
    return texture.rgb[rows, cols]
