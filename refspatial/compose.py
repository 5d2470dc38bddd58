"""Scene composition: pick assets and lay them out on a table (or a floor) without overlap.

Furniture, where a recipe asks for it, stands on the floor first; objects then go on the
floor, into containers, onto small supports, or onto the tops of the furniture.

Pure: ``compose(recipe, catalogue, seed)`` returns the same Scene for the same
inputs. Cameras are framed later (``camera.py``), once physics has settled the
objects, so that every object really is in view.
"""

from __future__ import annotations

import dataclasses

import numpy as np
from scipy.spatial import ConvexHull

from .assets import Catalogue, build_asset
from .library import mix_in
from .recipe import Recipe
from .relations.geometry import inside_convex
from .room import sample_lights, sample_room
from .scene import BOARD_M, Asset, PlacedObject, Pose, Scene, Table, yaw_quat
from .seeding import stage_rng

PLACEMENT_TRIES = 200  # per object, before the scene is rejected as too crowded
MAX_FILL = 0.3  # footprints may cover at most this share of the placement region
HOST_FIT = 0.8  # a hosted object's footprint circle must fit within this share of the cavity or top face
FURNITURE_GROUP = "furniture"  # catalogue group of the pieces a recipe's `furniture` section places
FURNITURE_REPEAT = 0.35  # chance that the next piece repeats one already drawn (two chairs, two stools)
TOP_MARGIN_M = 0.03  # objects on a piece of furniture keep this far inside its top's outline


class SceneRejected(RuntimeError):
    """A scene that cannot be made; ``reason`` is a short slug for the statistics."""

    def __init__(self, reason: str, detail: str = "") -> None:
        super().__init__(f"{reason}: {detail}" if detail else reason)
        self.reason = reason


def compose(recipe: Recipe, catalogue: Catalogue, seed: int) -> Scene:
    table = _sample_table(recipe, stage_rng(recipe.hash, seed, "table"))
    furniture: list[Asset] = []
    if recipe.option("furniture", "count")[1] > 0:  # no draw otherwise: older recipes keep their scenes
        furniture = _sample_furniture(recipe, catalogue, stage_rng(recipe.hash, seed, "furniture"))
    assets = furniture + _sample_assets(recipe, catalogue, stage_rng(recipe.hash, seed, "assets"))
    if catalogue.libraries is not None:  # a stage of its own: runs without libraries draw exactly as before
        assets = furniture + mix_in(assets[len(furniture):], catalogue.libraries, catalogue.colors,
                                    recipe["objects"]["repeat_category"], stage_rng(recipe.hash, seed, "library"))
    objects = _place(recipe, table, assets, len(furniture), stage_rng(recipe.hash, seed, "layout"))
    furniture_keys = _furniture_keys(catalogue)
    colours = tuple(o.asset.rgba[:3] for o in objects if o.asset.category not in furniture_keys)
    room = sample_room(recipe, table, stage_rng(recipe.hash, seed, "room"), object_rgbs=colours)
    # The top is the room's table-top surface: records name what is rendered.
    table = dataclasses.replace(table, rgba=(*room.top.rgb, 1.0), texture=room.top.look)
    lights = sample_lights(recipe, stage_rng(recipe.hash, seed, "light"), room.size_m, room.height_m, table.top_z_m)
    return Scene(recipe.name, recipe.hash, seed, table, objects, cameras=(), lights=lights, room=room)


def _furniture_keys(catalogue: Catalogue) -> set[str]:
    return {k for k, c in catalogue.categories.items() if c.group == FURNITURE_GROUP}


def category_pool(recipe: Recipe, catalogue: Catalogue, section: str = "objects") -> list[str]:
    """The categories a recipe section draws from. "all" means every category outside the
    furniture group for objects, and every furniture category for furniture."""
    wanted = recipe[section]["categories"] if section == "objects" else recipe.option(section, "categories")
    is_furniture = section == "furniture"
    fitting = sorted(k for k, c in catalogue.categories.items() if (c.group == FURNITURE_GROUP) == is_furniture)
    if wanted == "all":
        return fitting
    wrong = [c for c in wanted if c not in fitting]
    if wrong:
        kind = "furniture" if is_furniture else "non-furniture"
        raise ValueError(
            f"{recipe.path}: {section}.categories: {wrong[0]!r} is not a {kind} category of the asset catalogue; "
            f"known: {', '.join(fitting)}"
        )
    return list(wanted)


def _sample_assets(recipe: Recipe, catalogue: Catalogue, rng: np.random.Generator) -> list[Asset]:
    spec = recipe["objects"]
    return _draw(catalogue, category_pool(recipe, catalogue), spec["count"], spec["repeat_category"], rng,
                 recipe.option("objects", "shape_variants"))


def _sample_furniture(recipe: Recipe, catalogue: Catalogue, rng: np.random.Generator) -> list[Asset]:
    pool = category_pool(recipe, catalogue, "furniture")
    return _draw(catalogue, pool, recipe.option("furniture", "count"), FURNITURE_REPEAT, rng,
                 recipe.option("objects", "shape_variants"))


def _draw(catalogue: Catalogue, pool: list[str], count: list[int], repeat: float,
          rng: np.random.Generator, shape_variants: int = 0) -> list[Asset]:
    n = int(rng.integers(count[0], count[1] + 1))
    chosen: list[str] = []
    for _ in range(n):
        # Repeats make ordinals ("the second mug from the left") necessary.
        if chosen and rng.random() < repeat:
            chosen.append(chosen[int(rng.integers(len(chosen)))])
        else:
            chosen.append(pool[int(rng.integers(len(pool)))])
    return [build_asset(catalogue, c, rng, shape_variants=shape_variants) for c in chosen]


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
        surface=recipe.option("table", "surface"),
    )


def footprint_corners(asset: Asset, x: float, y: float, yaw: float, grow_m: float = 0.0) -> np.ndarray:
    """(4, 2) corners of the asset's rotated footprint box on the table."""
    (x0, y0, _), (x1, y1, _) = asset.visual.bounds_m
    local = np.array([[x0, y0], [x1, y0], [x1, y1], [x0, y1]]) + grow_m * np.array([[-1, -1], [1, -1], [1, 1], [-1, 1]])
    c, s = np.cos(yaw), np.sin(yaw)
    return local @ np.array([[c, s], [-s, c]]) + np.array([x, y])


def boxes_overlap(a: np.ndarray, b: np.ndarray) -> bool:
    """Separating-axis test for two convex quads given as (4, 2) corners."""
    return overlaps_any(a, [b])


def overlaps_any(quad: np.ndarray, others: list[np.ndarray]) -> bool:
    """Whether a convex quad overlaps any of the others, all at once (placement tries up to
    hundreds of poses against every footprint already placed)."""
    if not others:
        return False
    b = np.asarray(others)  # (k, 4, 2)
    near = np.all((b.max(axis=1) >= quad.min(axis=0)) & (b.min(axis=1) <= quad.max(axis=0)), axis=1)
    if not near.any():  # boxes apart: the quads are too (most tries end here)
        return False
    b = b[near]
    own = np.broadcast_to(np.roll(quad, -1, axis=0) - quad, b.shape)
    edges = np.concatenate([own, np.roll(b, -1, axis=1) - b], axis=1)
    axes = (edges @ np.array([[0.0, 1.0], [-1.0, 0.0]])).transpose(0, 2, 1)  # (k, 2, 8): edges turned by 90 deg
    pa, pb = quad @ axes, b @ axes
    separated = (pa.max(axis=1) < pb.min(axis=1)) | (pb.max(axis=1) < pa.min(axis=1))
    return bool(np.any(~separated.any(axis=1)))


TURN = np.pi - -np.pi  # the span of rng.uniform(-np.pi, np.pi), 2 pi exactly


def _place(recipe: Recipe, table: Table, assets: list[Asset], n_furniture: int,
           rng: np.random.Generator) -> tuple[PlacedObject, ...]:
    """Lay out the assets; the first ``n_furniture`` are furniture and stand on the table/floor."""
    spec = recipe["objects"]
    extent = _region(float(rng.uniform(*recipe["table"]["region_m"])), assets, table, spec["min_gap_m"])
    # The region may sit anywhere on the table that keeps it whole.
    slack = np.maximum(np.array(table.size_m) - extent, 0) / 2
    centre = rng.uniform(-slack, slack)
    low, span = -extent / 2, extent / 2 - -extent / 2  # where a try's footprint centre is drawn
    on_table = np.array(table.size_m) / 2 - 0.02  # a footprint's corners stay this far inside
    placed: list[PlacedObject] = []
    surfaces = surface_heights(table)
    quads: list[list[np.ndarray]] = [[] for _ in surfaces]  # footprints already placed, per surface
    hosts: list[PlacedObject] = []  # containers and supports still free to take one object
    tops: list[_Top] = []  # furniture tops that take several objects
    # Furniture first, then big things: they are the hardest to fit, and they host the small ones.
    order = sorted(range(len(assets)), key=lambda i: (i >= n_furniture, -float(np.prod(assets[i].size_m[:2]))))
    for i in order:
        asset, furniture = assets[i], i < n_furniture
        on_host = None if furniture else _on_host(i, asset, hosts, spec, rng)
        if on_host is None and tops and not furniture:  # furniture stands on the floor, never on a top
            on_host = _on_top(i, asset, tops, recipe.option("objects", "on_furniture"), spec, rng)
        if on_host is not None:
            placed.append(on_host)
            continue
        level = 0 if furniture else _level(asset, surfaces, rng)
        for _ in range(PLACEMENT_TRIES):
            # rng.uniform(low, high) is low + (high - low) u, u drawn in order: worked out here,
            # the same numbers without its argument checks (compose 5-9 % quicker).
            x, y = centre + (low + span * rng.random(2))
            yaw = -np.pi + TURN * rng.random()
            quad = footprint_corners(asset, x, y, yaw, grow_m=spec["min_gap_m"] / 2)
            inside = np.all(np.abs(quad) <= on_table)
            if level is not None and inside and not overlaps_any(quad, quads[level]):
                break
        else:
            continue  # left out; the scene is rejected below only if too few objects remain
        quads[level].append(quad)
        z = surfaces[level] + spec["drop_height_m"]
        placed.append(PlacedObject(i, asset, Pose((float(x), float(y), z), yaw_quat(yaw))))
        if furniture and asset.support:
            tops.append(_Top(placed[-1], top_outline(asset)))
        elif not furniture and (asset.cavity is not None or asset.support):
            hosts.append(placed[-1])
    if len(placed) - n_furniture < spec["count"][0] or sum(o.object_id < n_furniture for o in placed) < \
            recipe.option("furniture", "count")[0]:
        missing = len(assets) - len(placed)
        raise SceneRejected("crowded", f"{missing} of {len(assets)} objects found no room after {PLACEMENT_TRIES} tries")
    # Ids stay 0..n-1 in draw order, whatever was left out.
    kept = sorted(placed, key=lambda o: o.object_id)
    return tuple(dataclasses.replace(o, object_id=k) for k, o in enumerate(kept))


def _region(side: float, assets: list[Asset], table: Table, gap: float) -> np.ndarray:
    """Extents (x, y) of the placement region: a square of the recipe's side, grown for big object
    sets (several plates) instead of rejecting them, and cut to the table along each axis on its
    own, so that a long, narrow shelf or counter is used along its length. Where the cut leaves
    less area than the set needs, the region grows along the axis with room left."""
    need = sum(float(np.prod(a.size_m[:2] + gap)) for a in assets) / MAX_FILL
    limit = np.array(table.size_m, dtype=float) - 0.05
    extent = np.minimum(max(side, float(np.sqrt(need))), limit)
    if float(np.prod(extent)) < need * (1 - 1e-9):  # not where sqrt(need) squared misses by rounding
        wide = int(np.argmax(limit - extent))
        extent[wide] = min(limit[wide], need / float(extent[1 - wide]))
    return extent


@dataclasses.dataclass
class _Top:
    """A piece of furniture's top face, and the footprints already put on it (its own frame)."""

    piece: PlacedObject
    outline: np.ndarray  # (K, 2) convex, counter-clockwise, object frame
    quads: list[np.ndarray] = dataclasses.field(default_factory=list)


def top_outline(asset: Asset) -> np.ndarray:
    """The convex outline, in the object frame, of the flat top face an asset's highest vertices form."""
    v = asset.visual.vertices_m
    top = v[v[:, 2] >= v[:, 2].max() - 1e-3, :2]
    return top[ConvexHull(top).vertices]  # scipy orders a 2-D hull counter-clockwise


def _on_top(i: int, asset: Asset, tops: list[_Top], odds: float, spec: dict, rng: np.random.Generator):
    """Put the object somewhere on a furniture top, by the recipe's odds, if it finds room there."""
    if rng.random() >= odds:
        return None
    top = tops[int(rng.integers(len(tops)))]
    lo, hi = top.outline.min(0), top.outline.max(0)
    for _ in range(PLACEMENT_TRIES // 4):
        x, y = rng.uniform(lo, hi)
        yaw = float(rng.uniform(-np.pi, np.pi))
        quad = footprint_corners(asset, x, y, yaw, grow_m=spec["min_gap_m"] / 2)  # in the piece's frame
        if inside_convex(quad, top.outline, grow=-TOP_MARGIN_M).all() and \
                not overlaps_any(quad, top.quads):
            break
    else:
        return None
    top.quads.append(quad)
    T = top.piece.pose.matrix()
    z_top = float(top.piece.asset.visual.bounds_m[1, 2])
    pos = T[:3, :3] @ np.array([x, y, z_top]) + T[:3, 3] + np.array([0.0, 0.0, spec["drop_height_m"]])
    piece_yaw = 2.0 * np.arctan2(top.piece.pose.quat_wxyz[3], top.piece.pose.quat_wxyz[0])
    return PlacedObject(i, asset, Pose(tuple(float(c) for c in pos), yaw_quat(yaw + piece_yaw)))


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
