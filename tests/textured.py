"""Textured meshes the tests make themselves: a box whose six sides each map to their own cell
of a 3x2 grid of colours, so where each face's texcoords land can be checked from its normal."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import trimesh
import yaml
from PIL import Image
from trimesh.visual.material import PBRMaterial, SimpleMaterial

# File-frame outward normal of each box side -> its colour (rows of a 3x2 grid, top row first).
SIDES = {(1, 0, 0): (220, 30, 30), (-1, 0, 0): (30, 200, 40), (0, 1, 0): (30, 40, 210),
         (0, -1, 0): (230, 220, 20), (0, 0, 1): (200, 40, 200), (0, 0, -1): (20, 210, 210)}
CELL_PX = 16
BOX_MM = (40.0, 100.0, 60.0)  # x, y (the file's up), z (the file's front)


def grid_image() -> np.ndarray:
    """(2*CELL_PX, 3*CELL_PX, 3) uint8: side k's colour fills cell (row k // 3, column k % 3)."""
    img = np.zeros((2 * CELL_PX, 3 * CELL_PX, 3), dtype=np.uint8)
    for k, colour in enumerate(SIDES.values()):
        r, c = divmod(k, 3)
        img[r * CELL_PX:(r + 1) * CELL_PX, c * CELL_PX:(c + 1) * CELL_PX] = colour
    return img


def textured_box(size_mm=BOX_MM, inside_out: bool = False) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(vertices (36, 3), faces (12, 3), uv (36, 2)): every face has its own corners, each side's
    uvs inside its grid cell, laid out as an affine map of the corner's position on the side."""
    box = trimesh.creation.box(size_mm)
    normals = np.round(box.face_normals).astype(int)
    vertices = box.vertices[box.faces].reshape(-1, 3)
    half = np.asarray(size_mm) / 2
    uv = np.zeros((len(vertices), 2))
    for f, n in enumerate(normals):
        k = list(SIDES).index(tuple(n))
        r, c = divmod(k, 3)
        a, b = [i for i in range(3) if n[i] == 0]
        for j in range(3):
            p = vertices[3 * f + j] / half  # each coordinate -1 or +1
            s, t = 0.2 + 0.6 * (p[a] + 1) / 2, 0.2 + 0.6 * (p[b] + 1) / 2  # inside the cell, off its edges
            uv[3 * f + j] = [(c + s) / 3, 1.0 - (r + t) / 2]  # v = 0 at the image's bottom row
    faces = np.arange(len(vertices)).reshape(-1, 3)
    if inside_out:
        faces = faces[:, ::-1]
    return vertices, faces, uv


def write_textured(path: Path, note: dict, inside_out: bool = False, image: np.ndarray | None = None,
                   factor: tuple | None = None) -> Path:
    """The box as GLB (a PBR base-colour texture) or OBJ (+MTL, map_Kd), with its YAML beside it."""
    vertices, faces, uv = textured_box(inside_out=inside_out)
    picture = Image.fromarray(grid_image() if image is None else image)
    if path.suffix == ".glb":
        material = PBRMaterial(baseColorTexture=picture, baseColorFactor=list(factor or (255, 255, 255, 255)))
    else:
        material = SimpleMaterial(image=picture)
    visual = trimesh.visual.TextureVisuals(uv=uv, material=material)
    path.parent.mkdir(parents=True, exist_ok=True)
    trimesh.Trimesh(vertices, faces, visual=visual, process=False).export(path)
    path.with_suffix(".yaml").write_text(yaml.safe_dump(note, sort_keys=False))
    return path


BOX_NOTE = {"category": "box", "name": "box", "plural": "boxes", "color": "red", "up": "+y", "front": [0, 0, 1],
            "front_side": "label", "scale": 0.001, "licence": "CC0-1.0", "source": "https://example.org/box",
            "collision": {"method": "hull"}}
# Object frame <- file frame for BOX_NOTE (up +y -> +z, front +z -> +x): rows are object axes.
FILE_TO_OBJECT = np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
