"""Procedural textures, texture coordinates and the looks catalogue (textures.yaml)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from refspatial import looks, textures, uv
from refspatial.colour import delta_e, srgb_to_lab
from refspatial.scene import MeshData
from refspatial.shapes import BUILDERS

RED = (0.80, 0.08, 0.08)


@pytest.mark.parametrize("name", sorted(looks.load_looks().looks))
def test_every_look_is_deterministic_and_textured(name: str) -> None:
    look = looks.load_looks().looks[name]
    rgb = look.colors[0] if look.colors else RED
    a = textures.make(look.generator, look.params, rgb, 1, look.size)
    b = textures.make(look.generator, look.params, rgb, 1, look.size)
    assert a.shape == (*look.size, 3) and a.dtype == np.uint8
    assert np.array_equal(a, b)
    assert not np.array_equal(a, textures.make(look.generator, look.params, rgb, 2, look.size)), "seed ignored"
    assert a.reshape(-1, 3).std(axis=0).max() > 2.0, "a look must not be a flat colour"


# Finishes and skins shade the colour word's rgb, and print covers a minority of a label: the
# colour most of the surface shows (the median pixel) is still the colour word's.
@pytest.mark.parametrize("name", ["grain_fine", "glaze_pooled", "brushed_coarse", "fur_long", "weave_coarse",
                                  "skin_apple_streaked", "label_can_wide", "print_busy", "plaster_mottled"])
def test_finishes_keep_the_colour_word(name: str) -> None:
    look = looks.load_looks().looks[name]
    image = textures.make(look.generator, look.params, RED, 0, look.size)
    median = np.median(image.reshape(-1, 3), axis=0) / 255.0
    assert delta_e(srgb_to_lab(median), srgb_to_lab(np.array(RED))) < 10


def test_noise_tiles_without_a_seam() -> None:
    field = textures.noise(np.random.default_rng(3), (128, 256), (4, 8), 4)
    # Across the wrap the step is no bigger than between neighbours anywhere else.
    inner = np.abs(np.diff(field, axis=1)).max()
    assert np.abs(field[:, 0] - field[:, -1]).max() <= inner * 1.5
    assert np.abs(field[0] - field[-1]).max() <= np.abs(np.diff(field, axis=0)).max() * 1.5


def test_colour_temperature_runs_from_warm_to_cool() -> None:
    warm, neutral, cool = (np.array(textures.kelvin_rgb(k)) for k in (2700, 6500, 10000))
    assert warm[0] == 1.0 and warm[2] < 0.6  # candle-ish: red-heavy
    assert np.all(neutral > 0.95)  # daylight: near white
    assert cool[2] == 1.0 and cool[0] < 0.9


def _can() -> MeshData:
    visual, _ = BUILDERS["can"]({"radius_m": 0.033, "height_m": 0.12})
    return MeshData(np.asarray(visual.vertices, float), np.asarray(visual.faces, np.int32))


def test_cylinder_projection_unwraps_the_seam_and_puts_the_front_at_u0() -> None:
    mesh = uv.cylinder(_can())
    corners = mesh.texcoords[mesh.face_texcoords]  # (M, 3, 2)
    assert (corners[..., 0].max(axis=1) - corners[..., 0].min(axis=1)).max() < 0.25, "a face spans the seam"
    assert corners[..., 1].min() >= 0.0 and corners[..., 1].max() <= 1.0
    front = np.argmax(mesh.vertices_m[:, 0])  # the +x-most vertex
    faces = np.argwhere(mesh.faces == front)
    u = corners[faces[:, 0], faces[:, 1], 0] % 1.0
    assert np.all(np.minimum(u, 1 - u) < 0.05), "the label's front must face +x"


def test_box_fit_spans_each_side_once_and_the_atlas_splits_faces() -> None:
    visual, _ = BUILDERS["phone"]({"length_m": 0.15, "width_m": 0.07, "thickness_m": 0.008})
    mesh = MeshData(np.asarray(visual.vertices, float), np.asarray(visual.faces, np.int32))
    fitted = uv.box(mesh)
    assert fitted.texcoords.min() >= -1e-6 and fitted.texcoords.max() <= 1 + 1e-6
    atlas = uv.box(mesh, face=np.array([0, 0, 1.0]), face_cos=0.9)
    corners = atlas.texcoords[atlas.face_texcoords]
    normals = np.cross(*(mesh.vertices_m[mesh.faces[:, k]] - mesh.vertices_m[mesh.faces[:, 0]] for k in (1, 2)))
    up = normals[:, 2] / np.linalg.norm(normals, axis=1) >= 0.9
    assert np.all(corners[up][..., 0] >= uv.ATLAS_FACE[0]) and np.all(corners[~up][..., 0] <= uv.ATLAS_BODY[1])


def test_dressing_is_a_pure_function_of_the_asset() -> None:
    spec = looks.load_looks()
    params = {"radius_m": 0.033, "height_m": 0.12}
    a_tex, a_mesh = looks.look_texture(spec, "can", "metal", RED, params), looks.texture_layout(spec, "can", _can())
    b_tex, b_mesh = looks.look_texture(spec, "can", "metal", RED, params), looks.texture_layout(spec, "can", _can())
    assert a_tex.key == b_tex.key and np.array_equal(a_mesh.texcoords, b_mesh.texcoords)
    assert a_tex.key.split("/")[0] in spec.categories["can"].looks
    assert len(a_mesh.face_texcoords) == len(a_mesh.faces)


def test_every_category_has_three_looks() -> None:
    from refspatial.assets import load_catalogue

    spec = looks.load_looks()
    for key, cat in load_catalogue().categories.items():
        variants = {name for m in cat.materials for name in spec.choices(key, m)}
        assert len(variants) >= 3, key


def test_a_users_image_folder_becomes_a_surface(tmp_path: Path) -> None:
    import cv2

    image = np.zeros((40, 60, 3), np.uint8)
    image[:, :30] = (10, 200, 30)  # BGR on disk
    cv2.imwrite(str(tmp_path / "moss.png"), image)
    (tmp_path / "notes.txt").write_text("not an image")
    found = looks.image_folder(tmp_path)
    assert [p.name for p in found] == ["moss.png"]
    drawn = [looks.surface(looks.load_looks(), "floor", np.random.default_rng(s), found) for s in range(60)]
    assert len({d.name for d in drawn}) > 2
    mine = [d for d in drawn if d.name == "image:moss.png"]
    assert mine and tuple(mine[0].texture.rgb[0, 0]) == (30, 200, 10)  # RGB in memory, as drawn


def test_a_bad_image_folder_is_one_clear_error(tmp_path: Path) -> None:
    with pytest.raises(looks.LooksError, match="holds no .png or .jpg"):
        looks.image_folder(tmp_path)
    with pytest.raises(looks.LooksError, match="is not a folder"):
        looks.image_folder(tmp_path / "missing")


def test_a_look_with_a_wrong_parameter_fails_at_load(tmp_path: Path) -> None:
    text = (looks.assets_dir() / "textures.yaml").read_text().replace("rings: 14, warp: 0.8", "ringz: 14, warp: 0.8", 1)
    bad = tmp_path / "textures.yaml"
    bad.write_text(text)
    with pytest.raises(looks.LooksError, match="grain_fine.*cannot use these parameters"):
        looks.load_looks(bad)


def test_a_window_shows_the_part_of_a_panorama_it_faces(tmp_path: Path) -> None:
    """An equirectangular image's centre column is world +x, azimuth turning left (counter-
    clockwise) towards the image's left edge: a window facing +y shows what lies 90 degrees left."""
    import cv2

    pano = np.full((90, 360, 3), 40, np.uint8)
    pano[30:60, 85:95] = (0, 0, 255)  # BGR red: a mark 90 degrees left of the centre (+y)
    cv2.imwrite(str(tmp_path / "pano.png"), pano)
    facing_y = looks.outdoor_view(tmp_path / "pano.png", np.pi / 2, (45, 70))
    facing_x = looks.outdoor_view(tmp_path / "pano.png", 0.0, (45, 70))
    red = (facing_y.rgb[..., 0] > 200) & (facing_y.rgb[..., 2] < 50)
    assert red.any() and abs(np.nonzero(red)[1].mean() - 35) < 4, "the mark sits mid-window"
    assert not ((facing_x.rgb[..., 0] > 200) & (facing_x.rgb[..., 2] < 50)).any()


def test_texture_bank_holds_every_image_scenes_ask_for() -> None:
    """After the bank, composing scenes of every family makes no new texture image, and works out
    no room surface's mean colour again."""
    from refspatial.assets import load_catalogue
    from refspatial.compose import SceneRejected, compose
    from refspatial.recipe import load_recipe

    catalogue = load_catalogue()
    made = looks.texture_bank(looks.load_looks(), catalogue.categories, catalogue.colors)
    assert made <= textures.CACHE_IMAGES, "the image cache would evict part of the bank"
    before, means = textures._make.cache_info().misses, looks._texture_mean.cache_info().misses
    for name in ("tabletop", "kitchen_counter", "shelf", "room"):
        for seed in range(3):
            try:
                compose(load_recipe(name), catalogue, seed)
            except SceneRejected:  # a crowded draw is redrawn by the pipeline; its textures were made
                pass
    assert textures._make.cache_info().misses == before
    assert looks._texture_mean.cache_info().misses == means
