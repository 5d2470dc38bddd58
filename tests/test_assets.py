"""Tests for refspatial.assets and refspatial.shapes: the shipped catalogue, shape conventions,
sizes, semantic fronts, collision parts, container cavities and supports, determinism,
catalogue validation, and every category compiled, dropped and filled in MuJoCo."""

from __future__ import annotations

import copy
import hashlib
import math
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
    evaluate,
    load_catalogue,
)
from refspatial.mjcf import DENSITY_KG_M3, FRICTION  # noqa: E402
from refspatial.paths import assets_dir  # noqa: E402
from refspatial.scene import Asset  # noqa: E402

SEEDS = (0, 1, 2)
ORIGINAL = "mug cup bowl plate bottle can box book apple banana vase teddy_bear toy_block"
ADDED = (
    "wine_glass fork spoon knife jar teapot pan pot cutting_board sponge basket tray plant_pot tissue_box "
    "pen_holder orange lemon bread cake donut toy_car ball rubber_duck stapler pencil glasses_case clock "
    "candle lamp laptop keyboard phone remote mouse scissors hammer screwdriver"
)
FURNITURE = "coffee_table side_table stool chair cabinet"
REQUIRED_CATEGORIES = set(ORIGINAL.split()) | set(ADDED.split()) | set(FURNITURE.split())
REQUIRED_GROUPS = set("kitchen dining office toys food tools electronics containers decor furniture".split())
REQUIRED_COLORS = set("red orange yellow green blue purple pink brown black white gray silver".split())
REQUIRED_MATERIALS = set("matte glossy ceramic metal plastic wood paper organic".split())
CONTAINERS = ("mug", "cup", "bowl", "jar", "pan", "pot", "basket", "tray", "plant_pot")  # open, with a cavity
SUPPORTS = ("plate", "book", "box", "cutting_board", "tray", "toy_block", "coffee_table", "side_table", "stool", "cabinet")
BODY_CENTRED = ("mug", "teapot", "pan", "lamp")  # a handle, spout or arm sticks out: the body sits on the axis
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
FOOD_COLORS = {  # what fruit and food may plausibly be called
    "apple": {"red", "green", "yellow"},
    "banana": {"yellow", "green", "brown"},
    "orange": {"orange", "yellow", "green"},
    "lemon": {"yellow", "green"},
    "bread": {"brown", "orange", "yellow", "white"},
}


# ---------------------------------------------------------------- the shipped catalogue


def test_shipped_catalogue_has_the_required_words_and_categories(catalogue: Catalogue) -> None:
    assert REQUIRED_COLORS <= set(catalogue.colors)
    assert REQUIRED_MATERIALS <= set(catalogue.materials)
    assert REQUIRED_CATEGORIES <= set(catalogue.categories) and len(catalogue.categories) >= 40
    assert REQUIRED_GROUPS <= set(catalogue.groups or {})
    for spec in catalogue.categories.values():
        # Oranges and lemons come in their own colour only: in another they read as a lime (read 21).
        least = 1 if spec.key in ("orange", "lemon") else 2 if spec.group == "food" else 3
        assert len(spec.colors) >= least, spec.key
        assert spec.builder in BUILDERS
        assert np.allclose(spec.front_vector, (1, 0, 0)), "+x is the semantic front by convention"
    groups = [spec.group for spec in catalogue.categories.values()]
    assert all(groups.count(group) >= 3 for group in REQUIRED_GROUPS), groups
    assert {k for k, s in catalogue.categories.items() if s.cavity} == set(CONTAINERS)
    assert {k for k, s in catalogue.categories.items() if s.support} == set(SUPPORTS)
    # The catalogue's identity covers the file and the looks its assets are textured with.
    digest = hashlib.sha256((assets_dir() / "catalogue.yaml").read_bytes())
    digest.update(hashlib.sha256((assets_dir() / "textures.yaml").read_bytes()).hexdigest().encode())
    assert catalogue.sha256 == digest.hexdigest()


def test_shipped_colours_are_plausible(catalogue: Catalogue) -> None:
    assert catalogue.categories["banana"].colors and "blue" not in catalogue.categories["banana"].colors
    for key, allowed in FOOD_COLORS.items():
        assert set(catalogue.categories[key].colors) <= allowed, key
    for spec in catalogue.categories.values():
        assert spec.group != "food" or not {"blue", "purple", "gray", "silver", "black"} & set(spec.colors), spec.key
    rgb = {k: np.array(v) for k, v in catalogue.colors.items()}
    assert rgb["red"].argmax() == 0 and rgb["green"].argmax() == 1 and rgb["blue"].argmax() == 2
    assert rgb["white"].min() > 0.85 and rgb["black"].max() < 0.15


def test_textures_shade_without_renaming_the_colour(catalogue: Catalogue) -> None:
    """MuJoCo multiplies texture and colour: textures stay near white, so a red mug stays red."""
    textured = {name for name, m in catalogue.materials.items() if m.texture is not None}
    assert {"wood", "metal", "paper"} <= textured
    for name in textured:
        t = catalogue.materials[name].texture
        assert min(*t.rgb1, *t.rgb2, *t.markrgb) >= 0.6 and max(t.rgb1) == 1.0, name


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
        assert asset.support == spec.support and (asset.cavity is None) == (spec.cavity is None)
        assert asset.licence == "project-own (procedural)"
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
        if category in BODY_CENTRED:  # the patch it stands on is centred, not the whole footprint
            v = asset.visual.vertices_m
            base = v[v[:, 2] < 0.5 * MM]
            assert len(base) >= 3 and np.all(np.abs((base.min(axis=0) + base.max(axis=0))[:2] / 2) < MM)
            assert abs(centre[1]) < MM
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
    "wine_glass": lambda p: (2 * p["radius_m"], 2 * p["radius_m"], p["height_m"]),
    "fork": lambda p: (p["length_m"], None, p["thickness_m"]),
    "spoon": lambda p: (p["length_m"], p["bowl_width_m"], None),
    "knife": lambda p: (p["length_m"], None, p["handle_thickness_m"]),
    "jar": lambda p: (2 * p["radius_m"], 2 * p["radius_m"], p["height_m"]),
    "teapot": lambda p: (None, None, p["height_m"]),
    "pan": lambda p: (None, 2 * p["radius_m"], None),
    "pot": lambda p: (2 * p["radius_m"], None, p["height_m"]),
    "cutting_board": lambda p: (p["length_m"], p["width_m"], p["thickness_m"]),
    "sponge": lambda p: (p["length_m"], p["width_m"], p["height_m"]),
    "basket": lambda p: (None, None, p["height_m"]),
    "tray": lambda p: (p["length_m"], p["width_m"], p["height_m"]),
    "plant_pot": lambda p: (2 * p["radius_m"], 2 * p["radius_m"], p["height_m"]),
    "tissue_box": lambda p: (p["width_m"], p["length_m"], None),
    "pen_holder": lambda p: (None, None, None),
    "orange": lambda p: (None, None, None),
    "lemon": lambda p: (None, None, None),
    "bread": lambda p: (p["length_m"], p["width_m"], p["height_m"]),
    "cake": lambda p: (None, 2 * p["radius_m"], None),
    "donut": lambda p: (2 * p["radius_m"], 2 * p["radius_m"], None),
    "toy_car": lambda p: (p["length_m"], None, p["height_m"]),
    "ball": lambda p: (None, None, None),
    "rubber_duck": lambda p: (None, None, None),
    "stapler": lambda p: (p["length_m"], p["width_m"], p["height_m"]),
    "pencil": lambda p: (p["length_m"], None, None),
    "glasses_case": lambda p: (None, p["length_m"], p["height_m"]),
    "clock": lambda p: (None, None, None),
    "candle": lambda p: (2 * p["radius_m"], 2 * p["radius_m"], None),
    "lamp": lambda p: (None, None, p["height_m"]),
    "laptop": lambda p: (None, p["width_m"], None),
    "keyboard": lambda p: (p["depth_m"], p["width_m"], None),
    "phone": lambda p: (p["length_m"], p["width_m"], p["thickness_m"]),
    "remote": lambda p: (p["length_m"], p["width_m"], None),
    "mouse": lambda p: (p["length_m"], None, None),
    "scissors": lambda p: (p["length_m"], None, None),
    "hammer": lambda p: (p["length_m"], None, None),
    "screwdriver": lambda p: (p["length_m"], None, None),
    "coffee_table": lambda p: (p["length_m"], p["width_m"], p["height_m"]),
    "side_table": lambda p: (2 * p["radius_m"], 2 * p["radius_m"], p["height_m"]),
    "stool": lambda p: (2 * p["radius_m"], 2 * p["radius_m"], p["height_m"]),
    "chair": lambda p: (p["seat_depth_m"], p["seat_width_m"], p["seat_height_m"] + p["back_m"]),
    "cabinet": lambda p: (None, p["width_m"] + 0.02, p["height_m"]),
}
# (lowest, highest) ratio of each extent to a characteristic parameter, where no one parameter fixes it
RATIOS: dict[str, tuple[str, tuple[tuple[float, float] | None, ...]]] = {
    "orange": ("radius_m", ((1.9, 2.1), (1.9, 2.1), (1.7, 2.05))),
    "lemon": ("radius_m", ((2.5, 4.0), (1.9, 2.1), (1.85, 2.05))),
    "ball": ("radius_m", ((1.9, 2.02), (1.9, 2.02), (1.9, 2.02))),
    "rubber_duck": ("length_m", ((1.0, 1.2), (0.6, 0.85), (0.7, 0.95))),
    "clock": ("radius_m", ((0.6, 1.0), (1.8, 2.2), (2.2, 2.7))),
    "pen_holder": ("radius_m", ((2.0, 3.0), (2.0, 3.0), (3.0, 4.5))),
    "teapot": ("radius_m", ((2.5, 3.6), (1.9, 2.1), None)),
    "laptop": ("depth_m", ((1.1, 1.6), None, (0.85, 1.05))),
    "pan": ("radius_m", ((2.5, 4.0), None, (0.5, 0.9))),
}


def test_every_category_has_its_size_rule(catalogue: Catalogue) -> None:
    assert set(EXTENTS) == set(catalogue.categories) == set(CATEGORIES)


@pytest.mark.parametrize("category", CATEGORIES)
def test_sizes_follow_the_sampled_params(built: dict, category: str) -> None:
    for asset in _assets_of(built, category):
        for axis, want in enumerate(EXTENTS[category](asset.params)):
            if want is not None:
                assert abs(asset.size_m[axis] - want) < MM, (axis, asset.size_m, want)
        if category in RATIOS:
            name, bounds = RATIOS[category]
            for axis, band in enumerate(bounds):
                ratio = asset.size_m[axis] / asset.params[name]
                assert band is None or band[0] <= ratio <= band[1], (axis, ratio, band)


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


def _end(v: np.ndarray, axis: int, share: float, high: bool) -> np.ndarray:
    """Vertices in the last `share` of the extent along `axis`, at its high or low end."""
    lo, hi = v[:, axis].min(), v[:, axis].max()
    cut = hi - share * (hi - lo) if high else lo + share * (hi - lo)
    return v[v[:, axis] >= cut] if high else v[v[:, axis] <= cut]


def _mug(v, p, size):  # handle beyond the body on +x only
    return v[:, 0].max() > p["radius_m"] + p["handle_reach_m"] - MM and v[:, 0].min() > -p["radius_m"] - 1e-6


def _teddy(v, p, size):  # the muzzle sticks out of the head on +x
    crown = v[v[:, 2] > 0.85 * size[2]]
    cx = (crown[:, 0].max() + crown[:, 0].min()) / 2
    face = v[(v[:, 2] > 0.55 * size[2]) & (v[:, 2] < 0.8 * size[2])]
    return face[:, 0].max() - cx > cx - face[:, 0].min() + 0.03 * size[2]


def _banana(v, p, size):  # a thin stalk ends the +x side; the -x tip swells at once
    return _end(v, 0, 0.08, False)[:, 2].max() > 1.3 * _end(v, 0, 0.08, True)[:, 2].max()


def _laptop(v, p, size):  # the screen stands at the back and leans back, so its display faces +x
    top = v[v[:, 2] > 0.9 * size[2]]
    return top[:, 0].max() < -0.5 * p["depth_m"] and v[:, 0].max() > 0.45 * p["depth_m"]


def _cake(v, p, size):  # the cut: the +x end is two cut edges off the axis, the -x end is round
    return abs(v[v[:, 0].argmax(), 1]) > 0.25 * p["radius_m"] and abs(v[v[:, 0].argmin(), 1]) < 0.1 * p["radius_m"]


FRONT_CHECKS: dict[str, Callable[[np.ndarray, dict, np.ndarray], bool]] = {
    "mug": _mug,
    "teddy_bear": _teddy,
    "banana": _banana,
    "laptop": _laptop,
    "cake": _cake,
    "teapot": lambda v, p, s: (  # spout out on +x, handle on -x
        v[:, 0].max() > p["radius_m"] + 0.8 * p["spout_m"] and v[:, 0].min() < -1.1 * p["radius_m"]
    ),
    "pan": lambda v, p, s: (  # the handle on +x, nothing beyond the rim on -x
        v[:, 0].max() > p["radius_m"] + 0.9 * p["handle_length_m"] and v[:, 0].min() > -p["radius_m"] - 1e-6
    ),
    "lamp": lambda v, p, s: v[v[:, 2] > 0.5 * s[2]][:, 0].max() > p["base_radius_m"],  # the shade hangs in front
    "scissors": lambda v, p, s: np.ptp(_end(v, 0, 0.1, True)[:, 1]) < 0.3 * np.ptp(_end(v, 0, 0.25, False)[:, 1]),
    "fork": lambda v, p, s: np.ptp(_end(v, 0, 0.1, True)[:, 1]) > 1.25 * np.ptp(_end(v, 0, 0.1, False)[:, 1]),
    "spoon": lambda v, p, s: v[v[:, 2].argmax(), 0] > 0,  # the bowl's rim is higher than the handle's end
    "knife": lambda v, p, s: _end(v, 0, 0.3, True)[:, 2].max() < 0.5 * _end(v, 0, 0.3, False)[:, 2].max(),
    "hammer": lambda v, p, s: np.ptp(_end(v, 0, 0.15, True)[:, 1]) > 3 * np.ptp(_end(v, 0, 0.15, False)[:, 1]),
    "screwdriver": lambda v, p, s: np.ptp(_end(v, 0, 0.05, True)[:, 2]) < 0.5 * np.ptp(_end(v, 0, 0.05, False)[:, 2]),
    "pencil": lambda v, p, s: np.ptp(_end(v, 0, 0.03, True)[:, 1]) < 0.6 * np.ptp(_end(v, 0, 0.03, False)[:, 1]),
    "mouse": lambda v, p, s: v[v[:, 2].argmax(), 0] < 0,  # highest under the palm, sloping to the buttons
    "keyboard": lambda v, p, s: _end(v, 0, 0.05, False)[:, 2].max() > _end(v, 0, 0.05, True)[:, 2].max() + 2 * MM,
    "toy_car": lambda v, p, s: v[v[:, 2] > 0.95 * s[2]][:, 0].mean() < -0.05 * p["length_m"],  # cabin set back
    "rubber_duck": lambda v, p, s: 0.5 * s[2] < v[v[:, 0].argmax(), 2] < 0.8 * s[2],  # the beak is the front tip
    "chair": lambda v, p, s: v[v[:, 2] > p["seat_height_m"] + 0.05][:, 0].max() < -0.3 * p["seat_depth_m"],  # back at -x
    "cabinet": lambda v, p, s: v[:, 0].max() > p["depth_m"] / 2 + 0.015,  # handles stand out of the doors
}


@pytest.mark.parametrize("category", sorted(FRONT_CHECKS))
def test_front_features_point_to_plus_x(built: dict, category: str) -> None:
    """The named front side (handle, spout, screen, blades, tip...) is where +x says it is."""
    for asset in _assets_of(built, category):
        assert FRONT_CHECKS[category](asset.visual.vertices_m, asset.params, asset.size_m), asset.params


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


def _cavity_points(cav, n: int = 8, inset: float = 0.95) -> np.ndarray:
    """A grid over the cavity volume, its cross-section shrunk by `inset` (the relation engine
    calls things inside at 90 % of the half extents)."""
    hx, hy = (inset * h for h in cav.half_extents_m)
    zs = np.linspace(cav.floor_z_m + MM, cav.rim_z_m - MM, n)
    x, y, z = np.meshgrid(np.linspace(-hx, hx, n), np.linspace(-hy, hy, n), zs)
    points = np.column_stack([x.ravel(), y.ravel(), z.ravel()])
    if cav.shape == "cylinder":
        points = points[np.hypot(points[:, 0] / hx, points[:, 1] / hy) <= 1.0]
    return points


def _in_any_part(asset: Asset, points: np.ndarray) -> np.ndarray:
    filled = np.zeros(len(points), dtype=bool)
    for part in asset.collision:
        filled |= _inside_convex(part.vertices_m, part.faces, points)
    return filled


@pytest.mark.parametrize("category", CONTAINERS)
def test_container_cavity_is_open_in_the_visual_and_in_physics(built: dict, category: str) -> None:
    """The catalogue's cavity is empty of the visual mesh and of every collision part (so things
    fit inside, in pictures and in physics), it stands on a solid floor, and its rim is the top
    of the wall (the highest point of the wall on the -x side, away from handles)."""
    for asset in _assets_of(built, category)[:2]:
        cav = asset.cavity
        assert cav is not None and cav.shape in ("cylinder", "box") and 0 <= cav.floor_z_m < cav.rim_z_m
        points = _cavity_points(cav)
        assert len(points) > 200
        assert not _inside_closed(asset.visual.vertices_m, asset.visual.faces, points).any()
        assert not _in_any_part(asset, points).any()
        floor = np.array([[0.0, 0.0, cav.floor_z_m - MM]])
        assert _inside_closed(asset.visual.vertices_m, asset.visual.faces, floor)[0] and _in_any_part(asset, floor)[0]
        v = asset.visual.vertices_m
        hx, hy = cav.half_extents_m
        if cav.shape == "cylinder":
            scale = np.hypot(v[:, 0] / hx, v[:, 1] / hy)
        else:
            scale = np.maximum(np.abs(v[:, 0]) / hx, np.abs(v[:, 1]) / hy)
        wall = v[(scale > 1.0) & (v[:, 0] < 0)]
        assert abs(wall[:, 2].max() - cav.rim_z_m) < 1.5 * MM, (wall[:, 2].max(), cav.rim_z_m)


@pytest.mark.parametrize("category", CONTAINERS)
def test_container_cavity_expression_matches_its_mesh_for_extreme_params(catalogue: Catalogue, category: str) -> None:
    """The cavity expressions hold over the whole parameter range, not only for the seeds:
    build at every range's minimum and at every range's maximum."""
    spec = catalogue.categories[category]
    for pick in (0, 1):
        params = {name: bounds[pick] for name, bounds in spec.params.items()}
        visual, parts = BUILDERS[spec.builder](params)
        cav = spec.cavity.evaluate(params)  # type: ignore[union-attr]
        points = _cavity_points(cav, n=7)
        assert not _inside_closed(np.asarray(visual.vertices), np.asarray(visual.faces), points).any(), pick
        for part in parts:
            assert not _inside_convex(np.asarray(part.vertices), np.asarray(part.faces), points).any(), pick


def test_cavity_expressions_evaluate() -> None:
    params = {"radius_m": 0.04, "wall_m": 0.004, "height_m": 0.1}
    assert evaluate("radius_m - wall_m", params) == pytest.approx(0.036)
    assert evaluate("0.5*height_m + 0.01 - 2*wall_m", params) == pytest.approx(0.052)
    assert evaluate("0.02", params) == pytest.approx(0.02)
    for bad in ("radius_m * wall_m", "depth_m", "radius_m -", "", "1e-3"):
        with pytest.raises(ValueError):
            evaluate(bad, params)


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
    with pytest.raises(ValueError, match="unknown category 'spork'"):
        build_asset(catalogue, "spork", np.random.default_rng(0))


# ---------------------------------------------------------------- validation


_LOADER = getattr(yaml, "CSafeLoader", yaml.SafeLoader)
_DUMPER = getattr(yaml, "CSafeDumper", yaml.SafeDumper)


def _shipped() -> dict:
    return yaml.load((assets_dir() / "catalogue.yaml").read_text(), Loader=_LOADER)


def _dump(doc: dict) -> str:
    return yaml.dump(doc, Dumper=_DUMPER, sort_keys=False)


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
WOOD_TEXTURE = ("materials", "wood", "texture")
MESH_ENTRY = {"builder": "mesh", "mesh": "m.obj", "group": "dining", "materials": ["ceramic"]}
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
    "texture unknown builtin": (
        _set(*WOOD_TEXTURE, "builtin", value="marble"),
        r"materials\.wood\.texture\.builtin: expected one of gradient",
    ),
    "texture random out of range": (
        _set(*WOOD_TEXTURE, "random", value=1.5),
        r"materials\.wood\.texture\.random: expected a number in \[0, 1\]",
    ),
    "texture missing key": (_delete(*WOOD_TEXTURE, "repeat"), r"materials\.wood\.texture: missing key 'repeat'"),
    "wrong version": (_set("version", value=2), r"version: expected 1"),
    "missing section": (_delete("materials"), r"\(top level\): missing key 'materials'"),
    "empty categories": (_set("categories", value={}), r"categories: expected a non-empty mapping"),
    "missing groups": (_delete("groups"), r"\(top level\): missing key 'groups'"),
    "unknown group": (
        _set(*MUG, "group", value="bathroom"),
        r"categories\.mug\.group: expected a word defined under groups: .*got 'bathroom'",
    ),
    "missing group": (_delete(*CAN, "group"), r"categories\.can: missing key 'group'"),
    "support not a flag": (
        _set(*BOOK, "support", value="yes"), r"categories\.book\.support: expected true or false, got 'yes'",
    ),
    "unknown cavity shape": (
        _set(*MUG, "cavity", "shape", value="sphere"), r"categories\.mug\.cavity\.shape: expected cylinder or box",
    ),
    "cavity missing key": (_delete(*MUG, "cavity", "rim_z"), r"categories\.mug\.cavity: missing key 'rim_z'"),
    "cavity key of the other shape": (
        _set(*MUG, "cavity", "half_x", value="radius_m"), r"categories\.mug\.cavity\.half_x: unknown key",
    ),
    "cavity unknown parameter": (
        _set(*MUG, "cavity", "radius", value="radius_m - wall_thickness_m"),
        r"categories\.mug\.cavity\.radius: 'wall_thickness_m' in .* is not a parameter \(parameters: radius_m",
    ),
    "cavity bad expression": (
        _set(*MUG, "cavity", "floor_z", value="base_m * 2"),
        r"categories\.mug\.cavity\.floor_z: cannot read 'base_m \* 2'",
    ),
    "mesh entry without a mesh file": (
        _set("categories", "my_mug", value=dict(MESH_ENTRY, mesh="meshes/nowhere.obj")),
        r"categories\.my_mug\.mesh: .*nowhere\.yaml: cannot read the annotation",
    ),
    "mesh entry with a name": (
        _set("categories", "my_mug", value=dict(MESH_ENTRY, name="mug")),
        r"categories\.my_mug\.name: unknown key; remove it or use one of builder, mesh, group, materials, annotation",
    ),
}


@pytest.mark.parametrize("case", sorted(BAD_ENTRIES))
def test_bad_catalogue_entries_fail_at_load_with_one_line_naming_file_and_key(tmp_path: Path, case: str) -> None:
    edit, pattern = BAD_ENTRIES[case]
    doc = copy.deepcopy(_shipped())
    edit(doc)
    path = tmp_path / "catalogue.yaml"
    path.write_text(_dump(doc))
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
    path.write_text(_dump(_shipped()))
    loaded = load_catalogue(path)
    digest = hashlib.sha256(path.read_bytes())
    digest.update(hashlib.sha256((assets_dir() / "textures.yaml").read_bytes()).hexdigest().encode())
    assert loaded.sha256 == digest.hexdigest()  # the bytes, and the looks that dress its assets
    assert set(loaded.categories) == set(load_catalogue().categories)


# ---------------------------------------------------------------- MuJoCo


def _add_asset(spec: mujoco.MjSpec, name: str, asset: Asset, pos: tuple[float, float, float]) -> None:
    """A free body with the asset's visual (no collision) and its convex parts, as mjcf.py does."""
    body = spec.worldbody.add_body(name=name, pos=list(pos))
    body.add_freejoint()
    for k, mesh in enumerate((asset.visual, *asset.collision)):
        spec.add_mesh(name=f"{name}_{k}", uservert=mesh.vertices_m.ravel(), userface=mesh.faces.ravel())
        visual = k == 0
        body.add_geom(
            type=mujoco.mjtGeom.mjGEOM_MESH, meshname=f"{name}_{k}", density=0 if visual else DENSITY_KG_M3,
            contype=0 if visual else 1, conaffinity=0 if visual else 1, group=0 if visual else 3,
            friction=list(FRICTION), condim=6,
        )


def _world(spacing: float, n: int) -> tuple[mujoco.MjSpec, list[tuple[float, float]]]:
    spec = mujoco.MjSpec()
    spec.option.timestep = 0.002
    spec.worldbody.add_geom(type=mujoco.mjtGeom.mjGEOM_PLANE, size=[20, 20, 0.1], friction=list(FRICTION), condim=6)
    side = math.ceil(math.sqrt(n))
    return spec, [(spacing * (i % side), spacing * (i // side)) for i in range(n)]


def _run(spec: mujoco.MjSpec, seconds: float) -> tuple[mujoco.MjModel, mujoco.MjData]:
    model = spec.compile()
    data = mujoco.MjData(model)
    while data.time < seconds:
        mujoco.mj_step(model, data)
    return model, data


def _tilt_deg(quat: np.ndarray) -> float:
    return float(np.degrees(2 * np.arccos(min(1.0, abs(quat[0])))))


def test_every_mesh_compiles_and_rests_in_mujoco(built: dict) -> None:
    """One body per category: visual + collision meshes compile, and each object dropped
    in its resting pose stays upright on a plane (the pose as built is stable)."""
    assets = [built[c, SEEDS[0]] for c in CATEGORIES]
    spec, grid = _world(1.3, len(assets))  # furniture is up to 1.2 m long
    for i, (asset, (x, y)) in enumerate(zip(assets, grid)):
        _add_asset(spec, f"obj{i}", asset, (x, y, 0.001))
    model, data = _run(spec, 0.8)
    assert model.nmesh == sum(1 + len(a.collision) for a in assets)
    for i, category in enumerate(CATEGORIES):
        body = model.body(f"obj{i}").id
        assert _tilt_deg(data.xquat[body]) < 3, category
        assert np.linalg.norm(data.xpos[body][:2] - grid[i]) < 0.01, category  # it did not slide or roll away


def _rest_height(asset: Asset) -> float:
    """Where something put on a support comes to rest: a tray's floor, a plate's well, else the top."""
    if asset.cavity is not None:
        return asset.cavity.floor_z_m
    return asset.params["thickness_m"] if asset.category == "plate" else float(asset.size_m[2])


def test_containers_hold_and_supports_carry_what_is_put_on_them(built: dict) -> None:
    """A ball dropped into each container's cavity ends on the cavity floor, inside the cavity
    (the collision parts keep it open); a cube dropped on each support rests on top of it."""
    cases = [(c, "ball") for c in CONTAINERS] + [(c, "cube") for c in SUPPORTS if c not in CONTAINERS]
    spec, grid = _world(1.3, len(cases))
    expected = []
    for i, ((category, probe), (x, y)) in enumerate(zip(cases, grid)):
        asset = built[category, SEEDS[0]]
        _add_asset(spec, f"obj{i}", asset, (x, y, 0.0))
        if probe == "ball":
            cav = asset.cavity
            r = min(0.4 * min(cav.half_extents_m), 0.4 * (cav.rim_z_m - cav.floor_z_m), 0.015)
            z, size, geom = cav.rim_z_m + r + 0.005, [r, 0, 0], mujoco.mjtGeom.mjGEOM_SPHERE
            expected.append((cav.floor_z_m + r, cav))
        else:
            r = 0.0125
            z, size, geom = float(asset.size_m[2]) + r + 0.01, [r, r, r], mujoco.mjtGeom.mjGEOM_BOX
            expected.append((_rest_height(asset) + r, None))
        probe_body = spec.worldbody.add_body(name=f"probe{i}", pos=[x, y, z])
        probe_body.add_freejoint()
        probe_body.add_geom(type=geom, size=size, density=500, friction=list(FRICTION), condim=6)
    model, data = _run(spec, 1.0)
    for i, ((category, _), (want_z, cav)) in enumerate(zip(cases, expected)):
        host = model.body(f"obj{i}").id
        assert _tilt_deg(data.xquat[host]) < 3, category
        local = data.xmat[host].reshape(3, 3).T @ (data.xpos[model.body(f"probe{i}").id] - data.xpos[host])
        assert abs(local[2] - want_z) < 3 * MM, (category, local, want_z)
        if cav is not None:
            hx, hy = cav.half_extents_m
            if cav.shape == "cylinder":
                assert np.hypot(local[0] / hx, local[1] / hy) < 1.0, category
            else:
                assert max(abs(local[0]) / hx, abs(local[1]) / hy) < 1.0, category
        else:
            assert np.hypot(*local[:2]) < 0.02, (category, local)


def test_union_survives_a_piece_that_is_not_a_volume():
    """A rare parameter draw can fold a thin piece into a non-volume (seen once in 1000 scenes);
    booleans refuse those, so union falls back to the piece's hull instead of failing the scene."""
    from refspatial.shapes import geometry as g

    open_box = trimesh.creation.box((0.02, 0.02, 0.005))
    open_box = trimesh.Trimesh(open_box.vertices, open_box.faces[:-2], process=False)  # one side missing
    assert not open_box.is_volume
    with pytest.raises(ValueError):
        trimesh.boolean.union([open_box, trimesh.creation.box((0.01, 0.01, 0.01))], engine="manifold")
    merged = g.union([open_box, trimesh.creation.box((0.01, 0.01, 0.01))])
    assert merged.is_volume and merged.volume > 0


@pytest.mark.parametrize("sections", [3, 8, 32])
def test_revolve_is_a_closed_outward_solid_of_the_exact_volume(sections: int):
    """A revolved rectangle is an n-sided prism: volume n/2 r^2 sin(2 pi / n) h, whichever way
    the profile runs; repeated profile points and a pole met twice add nothing."""
    from refspatial.shapes import geometry as g

    r, h = 0.03, 0.05
    exact = sections / 2 * r**2 * math.sin(2 * math.pi / sections) * h
    for profile in ([(0, 0), (r, 0), (r, h), (0, h)], [(0, h), (r, h), (r, h), (r, 0), (0, 0)]):
        mesh = g.revolve(profile, sections)
        assert mesh.is_watertight and mesh.is_winding_consistent
        assert mesh.volume == pytest.approx(exact, rel=1e-12)
        assert len(mesh.vertices) == 2 * sections + 2  # one vertex per pole
    cone = g.revolve([(0, 0), (r, 0), (0, h)], sections)
    assert cone.volume == pytest.approx(exact / 3, rel=1e-12) and cone.is_volume


def test_cylinder_box_and_moves_match_trimesh_geometry():
    """The direct constructors build the same solids trimesh's would, at a fraction of the cost."""
    from refspatial.shapes import geometry as g

    for p0, p1 in (((0, 0, 0), (0, 0, 0.1)), ((0.1, 0.2, 0.3), (0.1, 0.15, 0.3)), ((0, 0, 0), (0.05, -0.02, -0.08))):
        ours = g.cylinder(0.02, p0, p1, 12)
        theirs = trimesh.creation.cylinder(radius=0.02, segment=[p0, p1], sections=12)
        assert ours.is_volume and ours.volume == pytest.approx(theirs.volume, rel=1e-12)
        assert np.allclose(np.sort(ours.vertices, axis=0), np.sort(theirs.vertices, axis=0), atol=1e-12)
    # Corners in either order give the same box (a builder once cut a recess with swapped corners).
    for lo, hi in (((0, 0, 0), (0.1, 0.2, 0.3)), ((0.1, 0.2, 0.0), (0.0, 0.0, 0.3))):
        b = g.box(lo, hi)
        assert b.is_volume and b.volume == pytest.approx(0.006)
        assert np.allclose(b.bounds, [[0, 0, 0], [0.1, 0.2, 0.3]])
    b = g.box((0, 0, 0), (0.1, 0.2, 0.3))
    turned = g.rotated(b, math.pi / 2, g.Z, (0.05, 0.1, 0))
    assert np.allclose(turned.bounds, [[-0.05, 0.05, 0], [0.15, 0.15, 0.3]])
    assert g.moved(b, (1, 2, 3)).bounds[0].tolist() == [1, 2, 3]
    assert np.array_equal(b.bounds, [[0, 0, 0], [0.1, 0.2, 0.3]])  # inputs are never changed
