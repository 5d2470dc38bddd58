"""Textured imports: GLB base-colour textures and OBJ+MTL map_Kd survive import with texcoords
that still point at each face's own part of the image after the axis swap, scaling, centring,
vertex merging and inside-out repair of normalisation; flat material colours and size caps."""

from __future__ import annotations

from collections import defaultdict
from pathlib import Path

import numpy as np
import pytest
import trimesh

from refspatial.mesh_import import import_mesh
from refspatial.mesh_texture import MAX_TEXTURE_PX, cap_size, face_colours, texture_from_rgb
from refspatial.scene import MeshData
from textured import BOX_MM, BOX_NOTE, FILE_TO_OBJECT, SIDES, grid_image, write_textured


def _expected_colours(mesh: MeshData) -> np.ndarray:
    """Each face's colour, from its normal carried back to the file frame."""
    tm = trimesh.Trimesh(mesh.vertices_m, mesh.faces, process=False)
    file_normals = np.round(tm.face_normals @ FILE_TO_OBJECT).astype(int)  # rows: object -> file
    return np.array([SIDES[tuple(n)] for n in file_normals], dtype=np.uint8)


@pytest.mark.parametrize("suffix", [".glb", ".obj"])
@pytest.mark.parametrize("inside_out", [False, True])
def test_every_face_keeps_its_part_of_the_texture(tmp_path: Path, suffix: str, inside_out: bool) -> None:
    result = import_mesh(write_textured(tmp_path / f"box{suffix}", BOX_NOTE, inside_out), cache_dir=tmp_path)
    visual = result.visual
    assert result.texture is not None and np.array_equal(result.texture.rgb, grid_image())
    assert visual.texcoords.dtype == np.float32 and visual.texcoords.shape[1] == 2
    assert visual.face_texcoords.dtype == np.int32 and visual.face_texcoords.shape == visual.faces.shape
    assert len(visual.vertices_m) == 8  # positions merged (smooth normals), uvs kept per corner
    assert trimesh.Trimesh(visual.vertices_m, visual.faces).volume > 0  # outward, also when the file was not
    assert np.array_equal(face_colours(visual, result.texture), _expected_colours(visual))
    assert np.allclose(np.ptp(visual.vertices_m, axis=0), np.array(BOX_MM)[[2, 0, 1]] / 1000)


@pytest.mark.parametrize("inside_out", [False, True])
def test_each_corner_keeps_its_own_uv(tmp_path: Path, inside_out: bool) -> None:
    """A side's two triangles share two corners: those must get the same uv from both, which fails
    if corner uvs were paired with the wrong corners (say, faces reversed and uvs not)."""
    visual = import_mesh(write_textured(tmp_path / "box.glb", BOX_NOTE, inside_out), cache_dir=tmp_path).visual
    tm = trimesh.Trimesh(visual.vertices_m, visual.faces, process=False)
    seen: dict[tuple, set] = defaultdict(set)
    for f, normal in enumerate(np.round(tm.face_normals).astype(int)):
        for corner in range(3):
            uv = visual.texcoords[visual.face_texcoords[f, corner]]
            seen[(tuple(normal), int(visual.faces[f, corner]))].add(tuple(np.round(uv, 5)))
    assert len(seen) == 24 and all(len(uvs) == 1 for uvs in seen.values())


def test_the_base_colour_factor_multiplies_the_texture(tmp_path: Path) -> None:
    result = import_mesh(write_textured(tmp_path / "box.glb", BOX_NOTE, factor=(255, 128, 0, 255)), cache_dir=tmp_path)
    expected = np.round(grid_image() * np.array([1.0, 128 / 255, 0.0])).astype(np.uint8)
    assert np.array_equal(result.texture.rgb, expected)


def test_a_material_colour_without_an_image_is_a_flat_colour(tmp_path: Path) -> None:
    from trimesh.visual.material import PBRMaterial

    box = trimesh.creation.box((30, 30, 30))
    box.visual = trimesh.visual.TextureVisuals(material=PBRMaterial(baseColorFactor=[255, 51, 0, 255]))
    box.export(tmp_path / "flat.glb")
    (tmp_path / "flat.yaml").write_text(_yaml(BOX_NOTE))
    result = import_mesh(tmp_path / "flat.glb", cache_dir=tmp_path)
    assert result.texture is None and result.visual.texcoords is None
    assert result.rgb == pytest.approx((1.0, 0.2, 0.0))


def test_untextured_files_import_as_before(tmp_path: Path) -> None:
    trimesh.creation.box((30, 30, 30)).export(tmp_path / "plain.obj")
    (tmp_path / "plain.yaml").write_text(_yaml(BOX_NOTE))
    result = import_mesh(tmp_path / "plain.obj", cache_dir=tmp_path)
    assert result.texture is None and result.rgb is None and result.visual.face_texcoords is None


def test_big_textures_are_capped_and_keep_their_aspect() -> None:
    rgb = np.zeros((1500, 3000, 3), dtype=np.uint8)
    rgb[:, 1500:] = 200  # right half light: still right half after the downscale
    small = cap_size(rgb)
    assert small.shape == (MAX_TEXTURE_PX // 2, MAX_TEXTURE_PX, 3)
    assert small[:, : MAX_TEXTURE_PX // 2 - 1].max() == 0 and small[:, MAX_TEXTURE_PX // 2 + 1 :].min() == 200
    assert cap_size(rgb[:8, :8]).shape == (8, 8, 3)


def test_texture_keys_follow_the_pixels() -> None:
    a, b = grid_image(), grid_image()
    b[0, 0, 0] ^= 1
    assert texture_from_rgb(a).key == texture_from_rgb(a.copy()).key != texture_from_rgb(b).key
    assert texture_from_rgb(a).key != texture_from_rgb(a.reshape(64, 24, 3)).key  # same bytes, other shape


def _yaml(note: dict) -> str:
    import yaml

    return yaml.safe_dump(note, sort_keys=False)
