"""The room around a scene, and its lights: walls, floor, a window, a door and background
furniture drawn from the recipe's ``room`` section, and 1-3 lights of varied colour
temperature from its ``light`` section.

Background furniture stands against the walls, no deeper than ``PROP_DEPTH_M``; cameras keep
``camera_clearance_m`` from the walls (``camera.py``), so the line from a camera to any object
stays inside the free middle of the room and no prop can hide an object. Pure: everything is
drawn from the generators passed in.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from . import looks as looks_mod
from .colour import delta_e, srgb_to_lab
from .recipe import Recipe
from .scene import Light, Prop, Room, Surface, Table

PROP_DEPTH_M = 0.5  # deepest background piece; cameras stay clear of it
CAMERA_GAP_M = 0.3  # and keep this much more room for a head
# Walls stand at least this far beyond the table's edges: the props, the head room, and the
# farthest a recipe's camera band puts a camera from what it looks at (0.8 m up at -30 deg).
FREE_AROUND_M = PROP_DEPTH_M + CAMERA_GAP_M + 1.6
PROP_KINDS = {  # kind -> ((depth, width, height) ranges in metres)
    "cabinet": ((0.4, 0.5), (0.8, 1.4), (0.8, 1.0)),
    "shelf": ((0.3, 0.4), (0.8, 1.2), (1.6, 2.0)),
    "sofa": ((0.45, 0.5), (1.6, 2.2), (0.7, 0.85)),
    "plant": ((0.35, 0.45), (0.35, 0.45), (0.9, 1.5)),
}
WINDOW_M = ((1.0, 1.6), (1.0, 1.4), (0.8, 1.0))  # width, height, sill height
DOOR_M = ((0.8, 0.95), (2.0, 2.1))  # width, height
STAND_OUT_DELTA_E = 15.0  # an object's colour against the surface under it: clearly apart
SUPPORT_REDRAWS = 8  # looks tried for that surface before keeping the last (rare: ~7 objects, 7 looks)
SURFACE_TILE_M = {"floor": 1.2, "wall": 1.5, "top": 0.8, "furniture": 0.6, "outdoors": 1.0}
OUTDOOR_VIEW_PX = (128, 256)  # the window's view when cut from a user's panorama


def camera_clearance_m(room: Room | None, table: Table) -> float:
    """How far a camera keeps from the walls: past the props (none on a floor scene)."""
    if room is None or table.surface == "floor":
        return CAMERA_GAP_M
    return PROP_DEPTH_M + CAMERA_GAP_M


def sample_room(recipe: Recipe, table: Table, rng: np.random.Generator,
                catalogue_looks: looks_mod.Looks | None = None,
                object_rgbs: tuple[tuple[float, float, float], ...] = ()) -> Room:
    """The room; the surface the objects stand on (the top, or a floor scene's floor) is drawn
    again, up to SUPPORT_REDRAWS times, until its colour sets off every object's colour word
    (and a top differs in look from the floor)."""
    looks = catalogue_looks or looks_mod.load_looks()
    images = _images(recipe)
    if table.surface == "floor":  # the walls stand at the floor's edges
        size = table.size_m
    else:
        (xlo, xhi), (ylo, yhi) = recipe.option("room", "size_m")
        size = (max(float(rng.uniform(xlo, xhi)), table.size_m[0] + 2 * FREE_AROUND_M),
                max(float(rng.uniform(ylo, yhi)), table.size_m[1] + 2 * FREE_AROUND_M))
    height = float(rng.uniform(*recipe.option("room", "height_m")))
    surfaces = {kind: _surface(looks, kind, rng, images) for kind in looks_mod.SURFACE_KINDS}
    under = "floor" if table.surface == "floor" else "top"
    for _ in range(SUPPORT_REDRAWS):
        # A top in the floor's own look would melt into it: the table's edge must show.
        apart = under == "floor" or surfaces["top"].look != surfaces["floor"].look
        if apart and _sets_off(surfaces[under].rgb, object_rgbs):
            break
        surfaces[under] = _surface(looks, under, rng, images)
    props = _openings(size, rng)
    if table.surface != "floor":
        props += _furniture(size, recipe.option("room", "props"), rng)
    outdoors = surfaces["outdoors"]
    sky = _sky(recipe)
    if sky is not None:  # the user's panorama, as seen through this room's window
        window = next(p for p in props if p.kind == "window")
        view = looks_mod.outdoor_view(sky, window.yaw_rad + math.pi, OUTDOOR_VIEW_PX)
        outdoors = Surface(f"image:{sky.name}", tuple(float(c) for c in view.rgb.reshape(-1, 3).mean(0) / 255), view,
                           SURFACE_TILE_M["outdoors"])
    return Room(size, height, surfaces["floor"], surfaces["wall"], surfaces["top"], surfaces["furniture"], tuple(props),
                outdoors)


def _sets_off(surface_rgb: tuple[float, float, float], object_rgbs) -> bool:
    under = srgb_to_lab(np.array(surface_rgb))
    return all(delta_e(under, srgb_to_lab(np.array(rgb))) >= STAND_OUT_DELTA_E for rgb in object_rgbs)


# load_recipe has made both paths absolute and checked that they exist.
def _sky(recipe: Recipe) -> Path | None:
    """The recipe's equirectangular image for the view out of the window."""
    name = recipe.option("room", "sky")
    return None if name is None else Path(name)


def _images(recipe: Recipe) -> tuple[Path, ...]:
    folder = recipe.option("room", "images")
    return () if folder is None else looks_mod.image_folder(folder)


def _surface(looks: looks_mod.Looks, kind: str, rng: np.random.Generator, images: tuple[Path, ...]) -> Surface:
    # A user's images dress the big surfaces; furniture keeps the generated finishes.
    s = looks_mod.surface(looks, kind, rng, images if kind in ("floor", "wall", "top") else ())
    return Surface(s.name, s.rgb, s.texture, SURFACE_TILE_M[kind])


def _wall_frame(size: tuple[float, float], wall: int) -> tuple[np.ndarray, np.ndarray, float]:
    """Inward normal, direction along the wall, and the wall's length, for walls 0-3 (+x, -x, +y, -y)."""
    axis, sign = divmod(wall, 2)
    normal = np.zeros(2)
    normal[axis] = -1.0 if sign == 0 else 1.0
    along = np.array([-normal[1], normal[0]])
    return normal, along, size[1 - axis]


def _at_wall(size: tuple[float, float], wall: int, offset: float, depth: float) -> tuple[np.ndarray, float]:
    """Centre on the floor of something `depth` deep against a wall, `offset` along it, and its yaw
    (its +x facing into the room)."""
    normal, along, _ = _wall_frame(size, wall)
    half = np.array(size) / 2
    base = -normal * half  # the wall's foot (normal has one non-zero component)
    centre = base + normal * depth / 2 + along * offset
    return centre, math.atan2(normal[1], normal[0])


def _openings(size: tuple[float, float], rng: np.random.Generator) -> list[Prop]:
    """A window in one wall and a door in another."""
    walls = rng.permutation(4)
    out = []
    for kind, wall in (("window", int(walls[0])), ("door", int(walls[1]))):
        _, _, length = _wall_frame(size, wall)
        if kind == "window":
            w, h, sill = (float(rng.uniform(*r)) for r in WINDOW_M)
        else:
            (w, h), sill = (float(rng.uniform(*r)) for r in DOOR_M), 0.0
        offset = float(rng.uniform(-1, 1)) * max(length / 2 - w / 2 - 0.3, 0.0)
        centre, yaw = _at_wall(size, wall, offset, 0.0)
        out.append(Prop(kind, (float(centre[0]), float(centre[1]), sill), yaw, (0.05, w, h)))
    return out


def _furniture(size: tuple[float, float], count: list[int], rng: np.random.Generator) -> list[Prop]:
    """Background pieces against the walls, each in its own stretch of wall (so none overlap)."""
    n = int(rng.integers(count[0], count[1] + 1))
    kinds = sorted(PROP_KINDS)
    slots = rng.permutation(8)[:n]  # two stretches per wall
    out = []
    for slot in slots:
        wall, half_of_wall = divmod(int(slot), 2)
        kind = kinds[int(rng.integers(len(kinds)))]
        d, w, h = (float(rng.uniform(*r)) for r in PROP_KINDS[kind])
        _, _, length = _wall_frame(size, wall)
        room_for = length / 2 - w - 0.2
        if room_for <= 0:
            continue
        offset = (1 if half_of_wall else -1) * (0.1 + w / 2 + float(rng.uniform(0, room_for)))
        centre, yaw = _at_wall(size, wall, offset, d)
        out.append(Prop(kind, (float(centre[0]), float(centre[1]), 0.0), yaw, (d, w, h)))
    return out


def sample_lights(recipe: Recipe, rng: np.random.Generator, room_size: tuple[float, float], height: float,
                  top_z: float) -> tuple[Light, ...]:
    """A sun (key light, soft shadows) and 0-2 lamps under the ceiling, each with its own colour
    temperature and strength."""
    spec = recipe["light"]
    az = np.radians(rng.uniform(*spec["azimuth_deg"]))
    el = np.radians(rng.uniform(*spec["elevation_deg"]))
    direction = -np.array([np.cos(el) * np.cos(az), np.cos(el) * np.sin(az), np.sin(el)])
    intensity = float(rng.uniform(*spec["intensity"]))
    lo_k, hi_k = recipe.option("light", "kelvin")
    count = recipe.option("light", "count")
    soft = recipe.option("light", "soft_m")
    sun = Light(tuple(float(v) for v in direction), intensity, float(rng.uniform(lo_k, hi_k)), "sun", None,
                float(rng.uniform(*soft)))
    lamps = []
    for _ in range(int(rng.integers(count[0], count[1] + 1)) - 1):
        x, y = (float(rng.uniform(-0.35, 0.35)) * s for s in room_size)
        z = max(height - 0.3, top_z + 1.0)
        lamps.append(Light((0.0, 0.0, -1.0), float(rng.uniform(0.15, 0.4)), float(rng.uniform(lo_k, hi_k)), "lamp",
                           (x, y, z), 0.0))
    return (sun, *lamps)
