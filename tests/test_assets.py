"""Tests for refspatial.assets: the shipped catalogue, shape conventions, collision parts,
determinism, catalogue validation and loading every mesh into MuJoCo."""

from __future__ import annotations

import copy
import hashlib
import random
from pathlib import Path
from typing import Callable

import numpy as np
import pytest
import trimesh
import yaml

import refspatial  # noqa: F401  (sets MUJOCO_GL before mujoco is imported)
import mujoco  # noqa: E402
from refspatial.assets import (  # noqa: E402
    BUILDER_PARAMS,
    BUILDERS,
    Catalogue,
    CatalogueError,
    build_asset,
    load_catalogue,
)
from refspatial.paths import assets_dir  # noqa: E402
from refspatial.scene import Asset  # noqa: E402

SEEDS = (0, 1, 2, 3)
REQUIRED_CATEGORIES = set("mug cup bowl plate bottle can box book apple banana vase teddy_bear toy_block".split())
REQUIRED_COLORS = set("red orange yellow green blue purple pink brown black white gray silver".split())
REQUIRED_MATERIALS = set("matte glossy ceramic metal plastic wood paper organic".split())
HOLLOW = ("mug", "cup", "bowl")
MM = 1e-3


@pytest.fixture(scope="module")
def catalogue() -> Catalogue:
    return load_catalogue()


@pytest.fixture(scope="module")
def built(catalogue: Catalogue) -> dict[tuple[str, int], Asset]:
    """Every category for every seed, built once for the whole module."""
    return {(c, s): build_asset(catalogue, c, np.random.default_rng(s)) for c in catalogue.categories for s in SEEDS}


def _assets_of(built: dict, category: str) -> list[Asset]:
    return [built[category, s] for s in SEEDS]


def _tri(mesh) -> trimesh.Trimesh:
    return trimesh.Trimesh(mesh.vertices_m, mesh.faces, process=False)


CATEGORIES = sorted(REQUIRED_CATEGORIES)


# ---------------------------------------------------------------- the shipped catalogue


def test_shipped_catalogue_has_the_required_words_and_categories(catalogue: Catalogue) -> None:
    assert REQUIRED_COLORS <= set(catalogue.colors)
    assert REQUIRED_MATERIALS <= set(catalogue.materials)
    assert REQUIRED_CATEGORIES <= set(catalogue.categories)
    for spec in catalogue.categories.values():
        assert len(spec.colors) >= 3, spec.key
        assert spec.builder in BUILDERS
        assert np.allclose(spec.front_vector, (1, 0, 0)), "+x is the semantic front by convention"
    assert catalogue.sha256 == hashlib.sha256((assets_dir() / "catalogue.yaml").read_bytes()).hexdigest()


def test_shipped_colours_are_plausible(catalogue: Catalogue) -> None:
    assert catalogue.categories["banana"].colors and "blue" not in catalogue.categories["banana"].colors
    assert set(catalogue.categories["apple"].colors) <= {"red", "green", "yellow"}
    rgb = {k: np.array(v) for k, v in catalogue.colors.items()}
    assert rgb["red"].argmax() == 0 and rgb["green"].argmax() == 1 and rgb["blue"].argmax() == 2
    assert rgb["white"].min() > 0.85 and rgb["black"].max() < 0.15


def test_every_builder_docstring_names_its_params() -> None:
    for name, fn in BUILDERS.items():
        assert fn.__doc__, name
        for param in BUILDER_PARAMS[name]:
            assert param in fn.__doc__, f"{name} docstring does not mention {param}"


# ---------------------------------------------------------------- shapes and conventions


@pytest.mark.parametrize("category", CATEGORIES)
def test_asset_fields(catalogue: Catalogue, built: dict, category: str) -> None:
    spec = catalogue.categories[category]
    for asset in _assets_of(built, category):
        assert (asset.category, asset.name, asset.front_side) == (category, spec.name, spec.front_side)
        assert asset.color in spec.colors and asset.material in spec.materials
        assert asset.rgba == (*catalogue.colors[asset.color], 1.0)
        assert np.isclose(np.linalg.norm(asset.front_local), 1.0)
        assert set(asset.params) == set(spec.params)
        for name, value in asset.params.items():
            lo, hi = spec.params[name]
            assert lo <= value <= hi, (name, value)


@pytest.mark.parametrize("category", CATEGORIES)
def test_visual_mesh_is_a_closed_outward_volume_within_budget(built: dict, category: str) -> None:
    for asset in _assets_of(built, category):
        v, f = asset.visual.vertices_m, asset.visual.faces
        assert v.dtype == np.float64 and v.ndim == 2 and v.shape[1] == 3
        assert f.dtype == np.int32 and f.ndim == 2 and f.shape[1] == 3
        assert len(v) <= 3000
        mesh = _tri(asset.visual)
        assert mesh.is_watertight and mesh.is_winding_consistent
        assert mesh.volume > 0  # outward, counter-clockwise faces


@pytest.mark.parametrize("category", CATEGORIES)
def test_object_frame_rests_on_z0_with_footprint_centred(built: dict, category: str) -> None:
    for asset in _assets_of(built, category):
        lo, hi = asset.visual.bounds_m
        assert abs(lo[2]) < 1e-6
        centre = (lo + hi)[:2] / 2
        if category == "mug":  # the handle sticks out on +x: the body is centred instead
            r = asset.params["radius_m"]
            assert abs(lo[0] + r) < MM and abs(centre[1]) < MM
        else:
            assert np.all(np.abs(centre) < MM), centre


# expected (x, y, z) extents from the sampled parameters; None = not fixed by one parameter
EXTENTS: dict[str, Callable[[dict], tuple]] = {
    "mug": lambda p: (2 * p["radius_m"] + p["handle_reach_m"] + p["handle_radius_m"], 2 * p["radius_m"], p["height_m"]),
    "cup": lambda p: (2 * p["radius_top_m"], 2 * p["radius_top_m"], p["height_m"]),
    "bowl": lambda p: (2 * p["radius_m"], 2 * p["radius_m"], p["height_m"]),
    "plate": lambda p: (2 * p["radius_m"], 2 * p["radius_m"], p["height_m"]),
    "bottle": lambda p: (2 * p["radius_m"], 2 * p["radius_m"], p["height_m"]),
    "can": lambda p: (2 * p["radius_m"], 2 * p["radius_m"], p["height_m"]),
    "box": lambda p: (p["length_m"], p["width_m"], p["height_m"]),
    "book": lambda p: (p["cover_width_m"], p["cover_length_m"], p["thickness_m"]),
    "apple": lambda p: (2 * p["radius_m"], 2 * p["radius_m"], None),
    "banana": lambda p: (None, None, None),
    "vase": lambda p: (2 * p["radius_m"], 2 * p["radius_m"], p["height_m"]),
    "teddy_bear": lambda p: (None, None, p["height_m"]),
    "toy_block": lambda p: (p["size_m"], p["size_m"], p["size_m"]),
}


@pytest.mark.parametrize("category", CATEGORIES)
def test_sizes_follow_the_sampled_params(built: dict, category: str) -> None:
    for asset in _assets_of(built, category):
        for axis, want in enumerate(EXTENTS[category](asset.params)):
            if want is not None:
                assert abs(asset.size_m[axis] - want) < MM, (axis, asset.size_m, want)


def test_free_shapes_have_plausible_sizes(built: dict) -> None:
    for asset in _assets_of(built, "banana"):
        p = asset.params
        assert 0.75 * p["length_m"] < asset.size_m[0] <= p["length_m"] + 2 * p["radius_m"]
        assert asset.size_m[2] <= 2.2 * p["radius_m"]
    for asset in _assets_of(built, "apple"):
        p = asset.params
        assert 1.6 * p["radius_m"] * p["squash"] < asset.size_m[2] < 2 * p["radius_m"] * p["squash"] + p["stem_length_m"]
    for asset in _assets_of(built, "teddy_bear"):
        assert 0.3 < asset.size_m[0] / asset.size_m[2] < 0.9 and 0.3 < asset.size_m[1] / asset.size_m[2] < 0.9


def test_front_features_point_to_plus_x(built: dict) -> None:
    for asset in _assets_of(built, "mug"):  # handle beyond the body on +x only
        v = asset.visual.vertices_m
        assert v[:, 0].max() > asset.params["radius_m"] + asset.params["handle_reach_m"] - MM
        assert v[:, 0].min() > -asset.params["radius_m"] - 1e-6
    for asset in _assets_of(built, "teddy_bear"):  # the muzzle sticks out of the head on +x
        v, h = asset.visual.vertices_m, asset.size_m[2]
        crown = v[v[:, 2] > 0.85 * h]
        cx = (crown[:, 0].max() + crown[:, 0].min()) / 2
        face = v[(v[:, 2] > 0.55 * h) & (v[:, 2] < 0.8 * h)]
        assert face[:, 0].max() - cx > cx - face[:, 0].min() + 0.03 * h
    for asset in _assets_of(built, "banana"):  # a thin stalk ends the +x side; the -x tip swells at once
        v = asset.visual.vertices_m
        span = np.ptp(v[:, 0])
        stem, tip = v[v[:, 0] > v[:, 0].max() - 0.08 * span], v[v[:, 0] < v[:, 0].min() + 0.08 * span]
        assert tip[:, 2].max() > 1.3 * stem[:, 2].max()


# ---------------------------------------------------------------- collision parts


@pytest.mark.parametrize("category", CATEGORIES)
def test_collision_parts_are_convex_and_cover_the_visual(built: dict, category: str) -> None:
    for asset in _assets_of(built, category):
        assert asset.collision
        for part in asset.collision:
            assert part.vertices_m.dtype == np.float64 and part.faces.dtype == np.int32
            mesh = _tri(part)
            assert mesh.is_convex and mesh.volume > 0
        allv = np.vstack([p.vertices_m for p in asset.collision])
        lo, hi = asset.visual.bounds_m
        assert np.all(np.abs(allv.min(axis=0) - lo) < 5 * MM) and np.all(np.abs(allv.max(axis=0) - hi) < 5 * MM)


def _inside_convex(vertices: np.ndarray, faces: np.ndarray, points: np.ndarray) -> np.ndarray:
    tri = vertices[faces]
    normals = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    return np.all(np.einsum("fi,pfi->pf", normals, points[:, None] - tri[None, :, 0]) < 0, axis=1)


def _inside_closed(vertices: np.ndarray, faces: np.ndarray, points: np.ndarray) -> np.ndarray:
    """Generalised winding number > 1/2 (Van Oosterom-Strackee solid angles); needs no rtree."""
    tri, inside = vertices[faces], []
    for chunk in np.array_split(points, max(1, len(points) // 64)):
        a, b, c = (tri[None, :, k] - chunk[:, None] for k in range(3))
        la, lb, lc = (np.linalg.norm(x, axis=-1) for x in (a, b, c))
        dot = lambda u, v: np.einsum("pfi,pfi->pf", u, v)  # noqa: E731
        det = dot(a, np.cross(b, c))
        den = la * lb * lc + dot(a, b) * lc + dot(b, c) * la + dot(c, a) * lb
        inside.append(np.arctan2(det, den).sum(axis=1) / (2 * np.pi) > 0.5)
    return np.concatenate(inside)


@pytest.mark.parametrize("category", HOLLOW)
def test_containers_keep_their_cavity_open(built: dict, category: str) -> None:
    """Sample a vertical half-plane midway between two wall wedges (where chords cut in most),
    away from the mug's handle. Of the cavity points (inside the visual's convex hull, outside
    the visual) at most 8 % may lie in a collision part; one hull per wedge on the bowl's
    curved wall would fill about 16 %."""
    theta = np.radians(180 + 15)
    for asset in _assets_of(built, category)[:2]:
        lo, hi = asset.visual.bounds_m
        rr, zz = np.meshgrid(np.linspace(0, -lo[0], 28)[1:], np.linspace(0, hi[2], 28)[1:-1])
        points = np.column_stack([rr.ravel() * np.cos(theta), rr.ravel() * np.sin(theta), zz.ravel()])
        hull = _tri(asset.visual).convex_hull
        in_hull = _inside_convex(hull.vertices, hull.faces, points)
        cavity = points[in_hull & ~_inside_closed(asset.visual.vertices_m, asset.visual.faces, points)]
        assert len(cavity) > 200
        filled = np.zeros(len(cavity), dtype=bool)
        for part in asset.collision:
            filled |= _inside_convex(part.vertices_m, part.faces, cavity)
        assert filled.mean() < 0.08, filled.mean()
        floor = np.array([[0.0, 0.0, 0.001]])
        assert any(_inside_convex(p.vertices_m, p.faces, floor)[0] for p in asset.collision)  # the base is solid
        assert len(asset.collision) >= 9  # base + wall segments (+ handle)


# ---------------------------------------------------------------- determinism and sampling


@pytest.mark.parametrize("category", CATEGORIES)
def test_same_seed_same_asset_different_seed_different_shape(catalogue: Catalogue, built: dict, category: str) -> None:
    again = build_asset(catalogue, category, np.random.default_rng(SEEDS[0]))
    first = built[category, SEEDS[0]]
    assert np.array_equal(again.visual.vertices_m, first.visual.vertices_m)
    assert np.array_equal(again.visual.faces, first.visual.faces)
    assert all(np.array_equal(a.vertices_m, b.vertices_m) for a, b in zip(again.collision, first.collision))
    assert (again.params, again.color, again.material) == (first.params, first.color, first.material)
    other = built[category, SEEDS[1]]
    assert first.visual.vertices_m.shape != other.visual.vertices_m.shape or not np.array_equal(
        first.visual.vertices_m, other.visual.vertices_m
    )


def test_draws_only_from_the_given_generator(catalogue: Catalogue) -> None:
    np_state, py_state = np.random.get_state(), random.getstate()
    rng = np.random.default_rng(7)
    for category in CATEGORIES:
        build_asset(catalogue, category, rng)
    after = np.random.get_state()
    assert all(np.array_equal(a, b) if isinstance(a, np.ndarray) else a == b for a, b in zip(np_state, after))
    assert random.getstate() == py_state


def test_pinned_colour_is_used_and_moves_no_other_draw(catalogue: Catalogue) -> None:
    free = build_asset(catalogue, "mug", np.random.default_rng(5))
    rng = np.random.default_rng(5)
    pinned = build_asset(catalogue, "mug", rng, color="black")
    assert pinned.color == "black" and pinned.rgba == (*catalogue.colors["black"], 1.0)
    assert (pinned.params, pinned.material) == (free.params, free.material)
    fresh = np.random.default_rng(5)
    build_asset(catalogue, "mug", fresh)
    assert rng.random() == fresh.random()  # the same number of draws either way


def test_disallowed_colour_or_unknown_category_raise(catalogue: Catalogue) -> None:
    with pytest.raises(ValueError, match=r"'blue'.*'banana'.*allowed: yellow, green, brown"):
        build_asset(catalogue, "banana", np.random.default_rng(0), color="blue")
    with pytest.raises(ValueError, match="unknown category 'spoon'"):
        build_asset(catalogue, "spoon", np.random.default_rng(0))


# ---------------------------------------------------------------- validation


def _shipped() -> dict:
    return yaml.safe_load((assets_dir() / "catalogue.yaml").read_text())


def _set(*path: str, value: object) -> Callable[[dict], None]:
    def edit(doc: dict) -> None:
        node = doc
        for key in path[:-1]:
            node = node[key]
        node[path[-1]] = value

    return edit


def _delete(*path: str) -> Callable[[dict], None]:
    def edit(doc: dict) -> None:
        node = doc
        for key in path[:-1]:
            node = node[key]
        del node[path[-1]]

    return edit


MUG, CAN, BOOK = ("categories", "mug"), ("categories", "can"), ("categories", "book")
BAD_ENTRIES = {  # case -> (edit of the shipped catalogue, pattern the one-line message must match)
    "unknown builder": (_set(*MUG, "builder", value="mugg"), r"categories\.mug\.builder: expected one of"),
    "unknown colour": (
        _set("categories", "apple", "colors", value=["red", "teal", "green"]),
        r"categories\.apple\.colors: .*got 'teal'",
    ),
    "duplicate colour": (
        _set("categories", "apple", "colors", value=["red", "red", "green"]),
        r"categories\.apple\.colors: expected .*distinct",
    ),
    "unknown material": (_set(*CAN, "materials", value=["tin"]), r"categories\.can\.materials: .*got 'tin'"),
    "missing key": (_delete("categories", "cup", "plural"), r"categories\.cup: missing key 'plural'"),
    "unknown key": (_set("categories", "cup", "colour", value=["red"]), r"categories\.cup\.colour: unknown key"),
    "reversed range": (
        _set(*MUG, "params", "radius_m", value=[0.05, 0.01]),
        r"categories\.mug\.params\.radius_m: expected \[min, max\] with 0 < min <= max, got \[0\.05, 0\.01\]$",
    ),
    "zero range": (_set(*CAN, "params", "radius_m", value=[0, 0.03]), r"categories\.can\.params\.radius_m: expected \["),
    "scalar range": (_set(*CAN, "params", "height_m", value=0.1), r"categories\.can\.params\.height_m: expected \["),
    "missing param": (
        _delete(*MUG, "params", "handle_radius_m"),
        r"categories\.mug\.params: builder 'mug' needs handle_radius_m; add handle_radius_m: \[min, max\]",
    ),
    "unused param": (
        _set("categories", "bowl", "params", "depth_m", value=[0.01, 0.02]),
        r"categories\.bowl\.params\.depth_m: builder 'bowl' does not use it",
    ),
    "ranges that cannot build": (
        _set(*MUG, "params", "wall_m", value=[0.01, 0.02]),
        r"categories\.mug\.params: expected max\(wall_m\)\*3 <= min\(radius_m\), got 0\.06 > 0\.036",
    ),
    "zero front vector": (_set(*BOOK, "front", "vector", value=[0, 0, 0]), r"book\.front\.vector: expected a unit vector"),
    "non-unit front vector": (_set(*BOOK, "front", "vector", value=[1, 1, 0]), r"book\.front\.vector: expected a unit"),
    "short front vector": (_set(*BOOK, "front", "vector", value=[1, 0]), r"book\.front\.vector: expected a unit vector"),
    "empty front side": (_set(*BOOK, "front", "side", value=""), r"categories\.book\.front\.side: expected a non-empty"),
    "colour out of range": (_set("colors", "red", value=[1.2, 0, 0]), r"colors\.red: expected \[r, g, b\]"),
    "material out of range": (
        _set("materials", "metal", "specular", value=2),
        r"materials\.metal\.specular: expected a number in \[0, 1\], got 2$",
    ),
    "material missing attribute": (_delete("materials", "wood", "shininess"), r"materials\.wood: missing key 'shininess'"),
    "wrong version": (_set("version", value=2), r"version: expected 1"),
    "missing section": (_delete("materials"), r"\(top level\): missing key 'materials'"),
    "empty categories": (_set("categories", value={}), r"categories: expected a non-empty mapping"),
}


@pytest.mark.parametrize("case", sorted(BAD_ENTRIES))
def test_bad_catalogue_entries_fail_at_load_with_one_line_naming_file_and_key(tmp_path: Path, case: str) -> None:
    edit, pattern = BAD_ENTRIES[case]
    doc = copy.deepcopy(_shipped())
    edit(doc)
    path = tmp_path / "catalogue.yaml"
    path.write_text(yaml.safe_dump(doc, sort_keys=False))
    with pytest.raises(CatalogueError, match=pattern) as info:
        load_catalogue(path)
    message = str(info.value)
    assert "\n" not in message and message.startswith(f"{path}: ")
    assert isinstance(info.value, ValueError)


def test_invalid_yaml_is_a_catalogue_error(tmp_path: Path) -> None:
    path = tmp_path / "broken.yaml"
    path.write_text("version: 1\ncolors: [red: \n")
    with pytest.raises(CatalogueError, match="not valid YAML") as info:
        load_catalogue(path)
    assert "\n" not in str(info.value) and "broken.yaml" in str(info.value)


def test_a_valid_copy_loads_and_its_hash_is_of_the_bytes(tmp_path: Path) -> None:
    path = tmp_path / "catalogue.yaml"
    path.write_text(yaml.safe_dump(_shipped(), sort_keys=False))
    loaded = load_catalogue(path)
    assert loaded.sha256 == hashlib.sha256(path.read_bytes()).hexdigest()
    assert set(loaded.categories) == set(load_catalogue().categories)


# ---------------------------------------------------------------- MuJoCo


def test_every_mesh_compiles_and_rests_in_mujoco(built: dict) -> None:
    """One body per category: visual + collision meshes compile, and each object dropped
    in its resting pose stays upright on a plane (the pose as built is stable)."""
    spec = mujoco.MjSpec()
    spec.worldbody.add_geom(type=mujoco.mjtGeom.mjGEOM_PLANE, size=[5, 5, 0.1])
    assets = [built[c, SEEDS[0]] for c in CATEGORIES]
    for i, asset in enumerate(assets):
        body = spec.worldbody.add_body(name=f"obj{i}", pos=[0.5 * i, 0, 0.001])
        body.add_freejoint()
        for k, mesh in enumerate((asset.visual, *asset.collision)):
            spec.add_mesh(name=f"obj{i}_{k}", uservert=mesh.vertices_m.ravel(), userface=mesh.faces.ravel())
            visual = k == 0
            body.add_geom(
                type=mujoco.mjtGeom.mjGEOM_MESH, meshname=f"obj{i}_{k}", density=0 if visual else 500,
                contype=0 if visual else 1, conaffinity=0 if visual else 1, group=0 if visual else 3,
            )
    model = spec.compile()
    assert model.nmesh == sum(1 + len(a.collision) for a in assets)
    data = mujoco.MjData(model)
    while data.time < 0.6:
        mujoco.mj_step(model, data)
    for i, category in enumerate(CATEGORIES):
        quat = data.xquat[model.body(f"obj{i}").id]
        tilt = np.degrees(2 * np.arccos(min(1.0, abs(quat[0]))))
        assert tilt < 3, (category, tilt)
