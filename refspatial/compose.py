"""Scene composition: pick assets and lay them out on a table without overlap.

Pure: ``compose(recipe, catalogue, seed)`` returns the same Scene for the same
inputs. Cameras are framed later (``camera.py``), once physics has settled the
objects, so that every object really is in view.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from .assets import Catalogue, build_asset
from .recipe import Recipe
from .scene import BOARD_M, Asset, Light, PlacedObject, Pose, Scene, Table, yaw_quat
from .seeding import stage_rng

PLACEMENT_TRIES = 200  # per object, before the scene is rejected as too crowded
MAX_FILL = 0.3  # footprints may cover at most this share of the placement region
HOST_FIT = 0.8  # a hosted object's footprint circle must fit within this share of the cavity or top face


class SceneRejected(RuntimeError):
    """A scene that cannot be made; ``reason`` is a short slug for the statistics."""

    def __init__(self, reason: str, detail: str = "") -> None:
        super().__init__(f"{reason}: {detail}" if detail else reason)
        self.reason = reason


def compose(recipe: Recipe, catalogue: Catalogue, seed: int) -> Scene:
    table = _sample_table(recipe, stage_rng(recipe.hash, seed, "table"))
    assets = _sample_assets(recipe, catalogue, stage_rng(recipe.hash, seed, "assets"))
    objects = _place(recipe, table, assets, stage_rng(recipe.hash, seed, "layout"))
    light = _sample_light(recipe, stage_rng(recipe.hash, seed, "light"))
    return Scene(recipe.name, recipe.hash, seed, table, objects, cameras=(), light=light)


def category_pool(recipe: Recipe, catalogue: Catalogue) -> list[str]:
    wanted = recipe["objects"]["categories"]
    if wanted == "all":
        return sorted(catalogue.categories)
    missing = [c for c in wanted if c not in catalogue.categories]
    if missing:
        raise ValueError(
            f"{recipe.path}: objects.categories: {missing[0]!r} is not in the asset catalogue; "
            f"known: {', '.join(sorted(catalogue.categories))}"
        )
    return list(wanted)


def _sample_assets(recipe: Recipe, catalogue: Catalogue, rng: np.random.Generator) -> list[Asset]:
    spec = recipe["objects"]
    pool = category_pool(recipe, catalogue)
    n = int(rng.integers(spec["count"][0], spec["count"][1] + 1))
    chosen: list[str] = []
    for _ in range(n):
        # Repeats make ordinals ("the second mug from the left") necessary.
        if chosen and rng.random() < spec["repeat_category"]:
            chosen.append(chosen[int(rng.integers(len(chosen)))])
        else:
            chosen.append(pool[int(rng.integers(len(pool)))])
    return [build_asset(catalogue, c, rng) for c in chosen]


def _sample_table(recipe: Recipe, rng: np.random.Generator) -> Table:
    spec = recipe["table"]
    (xlo, xhi), (ylo, yhi) = spec["size_m"]
    color = spec["colors"][int(rng.integers(len(spec["colors"])))]
    texture = spec["textures"][int(rng.integers(len(spec["textures"])))]
    return Table(
        size_m=(float(rng.uniform(xlo, xhi)), float(rng.uniform(ylo, yhi))),
        top_z_m=float(spec["top_z_m"]),
        rgba=(*map(float, color), 1.0),
        texture=texture,
        levels_m=tuple(float(h) for h in spec["levels_m"]),
    )


def _sample_light(recipe: Recipe, rng: np.random.Generator) -> Light:
    spec = recipe["light"]
    az = np.radians(rng.uniform(*spec["azimuth_deg"]))
    el = np.radians(rng.uniform(*spec["elevation_deg"]))
    direction = -np.array([np.cos(el) * np.cos(az), np.cos(el) * np.sin(az), np.sin(el)])
    return Light(dir_world=tuple(float(v) for v in direction), intensity=float(rng.uniform(*spec["intensity"])))


def footprint_corners(asset: Asset, x: float, y: float, yaw: float, grow_m: float = 0.0) -> np.ndarray:
    """(4, 2) corners of the asset's rotated footprint box on the table."""
    (x0, y0, _), (x1, y1, _) = asset.visual.bounds_m
    local = np.array([[x0, y0], [x1, y0], [x1, y1], [x0, y1]]) + grow_m * np.array([[-1, -1], [1, -1], [1, 1], [-1, 1]])
    c, s = np.cos(yaw), np.sin(yaw)
    return local @ np.array([[c, s], [-s, c]]) + np.array([x, y])


def boxes_overlap(a: np.ndarray, b: np.ndarray) -> bool:
    """Separating-axis test for two convex quads given as (4, 2) corners."""
    for quad in (a, b):
        edges = np.roll(quad, -1, axis=0) - quad
        for nx, ny in np.stack([-edges[:, 1], edges[:, 0]], axis=1):
            pa, pb = a @ (nx, ny), b @ (nx, ny)
            if pa.max() < pb.min() or pb.max() < pa.min():
                return False
    return True


def _place(recipe: Recipe, table: Table, assets: list[Asset], rng: np.random.Generator) -> tuple[PlacedObject, ...]:
    spec = recipe["objects"]
    side = float(rng.uniform(*recipe["table"]["region_m"]))
    # Grow the region for big object sets (several plates) instead of rejecting them.
    area = sum(float(np.prod(a.size_m[:2] + spec["min_gap_m"])) for a in assets)
    side = min(max(side, np.sqrt(area / MAX_FILL)), min(table.size_m) - 0.05)
    # The region may sit anywhere on the table that keeps it whole.
    slack = np.maximum(np.array(table.size_m) - side, 0) / 2
    centre = rng.uniform(-slack, slack)
    placed: list[PlacedObject] = []
    surfaces = surface_heights(table)
    quads: list[list[np.ndarray]] = [[] for _ in surfaces]  # footprints already placed, per surface
    hosts: list[PlacedObject] = []  # containers and supports still free to take one object
    # Big things first: they are the hardest to fit, and they host the small ones.
    order = sorted(range(len(assets)), key=lambda i: -float(np.prod(assets[i].size_m[:2])))
    for i in order:
        asset = assets[i]
        on_host = _on_host(i, asset, hosts, spec, rng)
        if on_host is not None:
            placed.append(on_host)
            continue
        level = _level(asset, surfaces, rng)
        for _ in range(PLACEMENT_TRIES):
            x, y = centre + rng.uniform(-side / 2, side / 2, size=2)
            yaw = float(rng.uniform(-np.pi, np.pi))
            quad = footprint_corners(asset, x, y, yaw, grow_m=spec["min_gap_m"] / 2)
            inside = np.all(np.abs(quad) <= np.array(table.size_m) / 2 - 0.02)
            if level is not None and inside and not any(boxes_overlap(quad, q) for q in quads[level]):
                break
        else:
            continue  # left out; the scene is rejected below only if too few objects remain
        quads[level].append(quad)
        z = surfaces[level] + spec["drop_height_m"]
        placed.append(PlacedObject(i, asset, Pose((float(x), float(y), z), yaw_quat(yaw))))
        if asset.cavity is not None or asset.support:
            hosts.append(placed[-1])
    if len(placed) < spec["count"][0]:
        missing = len(assets) - len(placed)
        raise SceneRejected("crowded", f"{missing} of {len(assets)} objects found no room after {PLACEMENT_TRIES} tries")
    # Ids stay 0..n-1 in draw order, whatever was left out.
    kept = sorted(placed, key=lambda o: o.object_id)
    return tuple(dataclasses.replace(o, object_id=k) for k, o in enumerate(kept))


def surface_heights(table: Table) -> list[float]:
    """World heights of the table top and of each shelf board above it."""
    return [table.top_z_m] + [table.top_z_m + h for h in table.levels_m]


def _level(asset: Asset, surfaces: list[float], rng: np.random.Generator) -> int | None:
    """A surface the object fits under the next board on (clearance for a hand), or None."""
    clearance = 0.04
    fits = [k for k, z in enumerate(surfaces)
            if k + 1 == len(surfaces) or z + float(asset.size_m[2]) + clearance < surfaces[k + 1] - BOARD_M]
    k = int(rng.integers(len(surfaces)))  # drawn whatever fits, so the stream does not shift
    return (k if k in fits else fits[0]) if fits else None


def _on_host(i: int, asset: Asset, hosts: list[PlacedObject], spec: dict, rng: np.random.Generator):
    """Put the object into a container or onto a support, by the recipe's odds, if one fits it.

    The draws happen whether or not a host fits, so a change in hosts never
    shifts the rest of the layout's random stream more than it must.
    """
    wants_fill, wants_stack = rng.random() < spec["fill"], rng.random() < spec["stack"]
    yaw = float(rng.uniform(-np.pi, np.pi))
    jitter = rng.uniform(-1.0, 1.0, size=2)
    radius = 0.5 * float(np.hypot(*asset.size_m[:2]))
    for host in hosts:
        cav, hsize = host.asset.cavity, host.asset.size_m
        if wants_fill and cav is not None and radius <= HOST_FIT * min(cav.half_extents_m):
            slack = min(cav.half_extents_m) * HOST_FIT - radius
            z_local = cav.floor_z_m
        elif wants_stack and host.asset.support and radius <= HOST_FIT * 0.5 * min(hsize[:2]):
            slack = 0.5 * min(hsize[:2]) * HOST_FIT - radius
            z_local = float(host.asset.visual.bounds_m[1, 2])
        else:
            continue
        hosts.remove(host)
        x, y, z = host.pose.pos_world_m
        offset = jitter * max(slack, 0.0) * 0.5
        return PlacedObject(i, asset, Pose((float(x + offset[0]), float(y + offset[1]),
                                            float(z + z_local + spec["drop_height_m"])), yaw_quat(yaw)))
    return None
