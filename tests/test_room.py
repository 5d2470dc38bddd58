"""Rooms and lights around every scene family, as rendered: no void, props clear of the
cameras, lights in range, textured objects, and colour words that hold in the image."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from refspatial.assets import load_catalogue
from refspatial.colour import DISTINCT_DELTA_E, delta_e
from refspatial.colour_words import reads_as
from refspatial.compose import SceneRejected
from refspatial.export.common import valid_depth as has_surface
from refspatial.pipeline import build_scene, room_dict
from refspatial.questions.refer import colour_tells_apart, simple_refs
from refspatial.recipe import load_recipe
from refspatial.relations import view_facts
from refspatial.render import render_views
from refspatial.room import PROP_DEPTH_M, camera_clearance_m

FAMILIES = ("tabletop", "kitchen_counter", "shelf", "room")


@pytest.fixture(scope="module")
def catalogue():
    return load_catalogue()


def _scene(catalogue, recipe_name: str, first_seed: int = 1):
    recipe = load_recipe(recipe_name)
    for seed in range(first_seed, first_seed + 10):
        try:
            return recipe, build_scene(recipe, catalogue, seed)
        except SceneRejected:
            continue
    raise AssertionError(f"no {recipe_name} scene in ten seeds")


@pytest.fixture(scope="module")
def rendered(catalogue):
    out = {}
    for name in FAMILIES:
        recipe, scene = _scene(catalogue, name)
        out[name] = (recipe, scene, render_views(scene, catalogue.materials))
    return out


@pytest.mark.parametrize("family", FAMILIES)
def test_no_view_sees_a_void(rendered, family: str) -> None:
    _, _, views = rendered[family]
    for view in views:
        assert has_surface(view.depth_m).all(), f"{family} {view.camera.name} sees past every surface"


@pytest.mark.parametrize("family", FAMILIES)
def test_cameras_stay_inside_the_room_and_clear_of_the_props(rendered, family: str) -> None:
    _, scene, _ = rendered[family]
    room = scene.room
    free = np.array(room.size_m) / 2 - camera_clearance_m(room, scene.table)
    for cam in scene.cameras:
        assert np.all(np.abs(cam.pos_world_m[:2]) <= free + 1e-9), cam
        assert cam.pos_world_m[2] < room.height_m
    for prop in room.props:  # every background piece lies within PROP_DEPTH_M of a wall
        depth_from_wall = min(np.array(room.size_m) / 2 - np.abs(prop.pos_world_m[:2]))
        assert depth_from_wall <= PROP_DEPTH_M + 1e-9, prop


@pytest.mark.parametrize("family", FAMILIES)
def test_lights_and_looks_follow_the_recipe(rendered, family: str) -> None:
    recipe, scene, _ = rendered[family]
    lo, hi = recipe.option("light", "kelvin")
    assert 1 <= len(scene.lights) <= 3 and scene.lights[0].kind == "sun"
    assert all(lo <= light.kelvin <= hi for light in scene.lights)
    assert scene.lights[0].shadow_m > 0, "the sun's shadows must be soft"
    assert all(o.asset.texture is not None for o in scene.objects), "every procedural object wears a look"
    assert room_dict(scene.room)["surfaces"]["floor"]["look"]


def test_objects_are_not_flat_colour(rendered) -> None:
    """Texture and light vary over objects: few pixels repeat their object's most common colour
    (18-44 % did with flat colours), and nothing white is burnt out. A black object's shadowed
    side is one near-black colour however it is lit (a black basket and chair: 38 and 41 %), so
    objects whose commonest colour is near black are left out of the share."""
    flat = total = 0
    for family in FAMILIES:
        _, scene, views = rendered[family]
        for obj in scene.objects:
            px = views[0].rgb[views[0].seg == obj.object_id]
            if len(px) == 0:
                continue
            assert (px == 255).all(axis=1).mean() < 0.1, f"{family}: the {obj.asset.category} is burnt out"
            colours, counts = np.unique(px, axis=0, return_counts=True)
            if colours[counts.argmax()].max() < 16:
                continue
            flat, total = flat + counts.max(), total + len(px)
    assert total > 0 and flat / total < 0.12


def test_the_room_is_a_pure_function_of_recipe_and_seed(catalogue) -> None:
    (_, a), (_, b) = _scene(catalogue, "tabletop", 5), _scene(catalogue, "tabletop", 5)
    assert room_dict(a.room) == room_dict(b.room)
    assert a.lights == b.lights
    (_, c) = _scene(catalogue, "tabletop", 40)
    assert room_dict(a.room) != room_dict(c.room)


def test_colour_words_only_tell_apart_what_looks_different(rendered) -> None:
    recipe, scene, views = rendered["tabletop"]
    facts = view_facts(scene, views[0])
    seen = [o for o in facts.objects if o.status == "visible"]
    target = next(o for o in seen if reads_as(o.lab, o.color))  # its own word is true to the picture
    other = next(o for o in seen if o is not target)
    # A twin of the target's category under another colour word, rendered nearly alike...
    twin = dataclasses.replace(other, category=target.category, name=target.name,
                               color="silver" if target.color != "silver" else "white",
                               lab=tuple(np.add(target.lab, (3.0, 0.0, 0.0))))
    objects = tuple(twin if o.object_id == twin.object_id else o for o in facts.objects)
    alike = dataclasses.replace(facts, objects=objects, cache={})
    assert not colour_tells_apart(alike, target, target.category)
    assert all(r.color is None for r in simple_refs(alike, target))
    # ...and clearly apart: then the colour word may be used.
    far = dataclasses.replace(twin, lab=tuple(np.add(target.lab, (DISTINCT_DELTA_E + 1, 0.0, 0.0))))
    apart = dataclasses.replace(facts, objects=tuple(far if o.object_id == far.object_id else o
                                                     for o in facts.objects), cache={})
    assert colour_tells_apart(apart, target, target.category)
    assert delta_e(far.lab, target.lab) >= DISTINCT_DELTA_E


def test_the_mjcf_export_renders_what_the_generator_rendered(rendered, tmp_path) -> None:
    """Textures travel as PNG files and textured meshes as OBJ with per-corner UVs: the exported
    file, loaded by MuJoCo on its own, shows the same picture (an upside-down texture or a lost
    UV would change every textured pixel)."""
    import mujoco

    from refspatial.mjcf import SpecOptions, build_spec
    from refspatial.physics import write_mjcf

    _, scene, _ = rendered["tabletop"]
    catalogue = load_catalogue()
    xml = write_mjcf(scene, catalogue.materials, tmp_path / "scene.xml")
    assert any(p.suffix == ".png" for p in (tmp_path / "scene_meshes").iterdir())
    images = []
    for model in (build_spec(scene, catalogue.materials, SpecOptions(dynamic=True)).compile(),
                  mujoco.MjModel.from_xml_path(str(xml))):
        data = mujoco.MjData(model)
        mujoco.mj_forward(model, data)
        with mujoco.Renderer(model, 180, 320) as renderer:
            renderer.update_scene(data, scene.cameras[0].name)
            images.append(renderer.render().astype(int))
    differ = (np.abs(images[0] - images[1]).max(axis=-1) > 8).mean()
    assert differ < 0.03, f"{differ:.1%} of the pixels differ"


def test_the_surface_under_the_objects_sets_them_off() -> None:
    """A top whose colour matches an object's is drawn again: things stand out from what holds them."""
    from refspatial.room import STAND_OUT_DELTA_E, sample_room
    from refspatial.colour import srgb_to_lab
    from refspatial.scene import Table

    recipe = load_recipe("tabletop")
    table = Table((1.2, 0.8), 0.75, (1, 1, 1, 1), "flat")
    for seed in range(12):
        plain = sample_room(recipe, table, np.random.default_rng(seed))
        clash = plain.top.rgb  # an object the very colour of the first top drawn
        dressed = sample_room(recipe, table, np.random.default_rng(seed), object_rgbs=(clash,))
        assert delta_e(srgb_to_lab(np.array(dressed.top.rgb)), srgb_to_lab(np.array(clash))) >= STAND_OUT_DELTA_E
        assert dressed.wall.look == plain.wall.look  # only the top is drawn again


def test_a_recipe_can_dress_the_room_with_its_own_images(tmp_path, catalogue) -> None:
    """`room.images` (a folder) and `room.sky` (a panorama), relative to the recipe file."""
    import cv2

    (tmp_path / "textures").mkdir()
    cv2.imwrite(str(tmp_path / "textures" / "slate.png"), np.full((64, 64, 3), (90, 80, 70), np.uint8))
    pano = np.zeros((64, 128, 3), np.uint8)
    pano[:32] = (230, 160, 90)  # BGR: sky over ground
    cv2.imwrite(str(tmp_path / "pano.jpg"), pano)
    recipe_file = tmp_path / "mine.yaml"
    recipe_file.write_text("extends: tabletop\nname: mine\nroom:\n  images: textures\n  sky: pano.jpg\n")
    recipe = load_recipe(str(recipe_file))
    looks_used = set()
    for seed in range(1, 30):
        try:
            scene = build_scene(recipe, catalogue, seed)
        except SceneRejected:
            continue
        assert scene.room.outdoors.look == "image:pano.jpg"
        looks_used |= {scene.room.floor.look, scene.room.wall.look, scene.room.top.look}
        if "image:slate.png" in looks_used:
            break
    assert "image:slate.png" in looks_used
    assert render_views(scene, catalogue.materials)[0].rgb.any()
    recipe_file.write_text("extends: tabletop\nname: mine\nroom:\n  sky: missing.jpg\n")
    with pytest.raises(ValueError, match="room.sky: .*missing.jpg is not a file"):
        load_recipe(str(recipe_file))  # at load, in one line: not once per scene


def test_a_bookcase_behind_a_book_holds_no_spines(catalogue) -> None:
    """Behind a scene with a book, the room's bookcase stands empty: a reader asked for "the book"
    should not have dozens to choose from (annotator)."""
    import mujoco

    from refspatial.mjcf_room import add_room

    def geoms(scene) -> int:
        spec = mujoco.MjSpec()
        add_room(spec, scene, friction=(1.0, 0.005, 0.0001))
        return len(spec.worldbody.geoms)

    for seed in range(1, 40):
        _, scene = _scene(catalogue, "shelf", seed)
        if any(p.kind == "shelf" for p in scene.room.props):
            break
    else:
        raise AssertionError("no shelf scene with a bookcase in 40 seeds")
    plain = [dataclasses.replace(o, asset=dataclasses.replace(o.asset, category="vase")) for o in scene.objects]
    with_book = plain[:-1] + [dataclasses.replace(plain[-1], asset=dataclasses.replace(plain[-1].asset, category="book"))]
    spines = geoms(dataclasses.replace(scene, objects=plain)) - geoms(dataclasses.replace(scene, objects=with_book))
    assert spines > 20
