"""Object facts as stored in records, and view facts rebuilt from a record alone.

Questions are generated from facts rebuilt from the stored (rounded) record, not
from the unrounded ones, so that ``refspatial verify`` and any independent tool
that re-executes a program on the record sees exactly the inputs the generator
saw: no label can flip on a rounding difference.
"""

from __future__ import annotations

import numpy as np

from ..scene import Cavity, PlacedObject, quat_to_matrix
from .facts import ObjectFacts, ViewFacts, _horizontal
from .masks import BOXES_KEY, PIXELS_KEY, PixelStats, object_boxes, pixel_stats

DIGITS = 6  # micrometres and micro-units: far below every threshold


def rounded(values, digits: int = DIGITS) -> list[float]:
    # ``tolist`` gives the same Python floats as ``float`` of each numpy element, in one call.
    return [round(v, digits) for v in np.asarray(values, dtype=float).ravel().tolist()]


def rounded_rows(rows, digits: int = DIGITS) -> list[list[float]]:
    """``[rounded(r) for r in rows]`` of a 2-D array in one conversion (an outline has dozens of
    corners; ``tolist`` gives the same Python floats as ``float`` of each element)."""
    return [[round(v, digits) for v in row] for row in np.asarray(rows, dtype=float).tolist()]


def object_record(obj: PlacedObject, facts: ObjectFacts) -> dict:
    """Everything about one object that a record keeps (and predicates need)."""
    a = obj.asset
    R = quat_to_matrix(obj.pose.quat_wxyz)
    lo, hi = a.visual.bounds_m
    return {
        "id": obj.object_id,
        "category": a.category,
        "name": a.name,
        "color": a.color,
        "rgba": rounded(a.rgba, 4),
        "material": a.material,
        "licence": a.licence,
        "source": a.source,
        "texture": a.texture.key if a.texture is not None else None,
        "rendered_lab": rounded(facts.lab, 2) if facts.lab is not None else None,
        "params": {k: round(float(v), DIGITS) for k, v in sorted(a.params.items())},
        "pose": {"pos_world_m": rounded(obj.pose.pos_world_m), "quat_wxyz": rounded(obj.pose.quat_wxyz)},
        "box_world": {"center_m": rounded(R @ ((lo + hi) / 2) + obj.pose.pos_world_m), "size_m": rounded(hi - lo),
                      "quat_wxyz": rounded(obj.pose.quat_wxyz)},
        "aabb_world_m": [rounded(facts.aabb_world_m[0]), rounded(facts.aabb_world_m[1])],
        "footprint_world_m": rounded_rows(facts.footprint_world),
        # Already micrometres (``facts._outline`` rounds before its hull), which round() keeps as they are.
        "outline_world_m": facts.outline_world.tolist() if facts.outline_world is not None else None,
        "front_world": rounded(facts.front_world),
        "front_side": a.front_side,
        "volume_m3": round(facts.volume_m3, 9),
        "visible_px": facts.visible_px,
        "visible_share": round(facts.visible_share, 4),
        "visibility": facts.status,
        "support": facts.support,
        "is_support": bool(a.support),
        "cavity": None if a.cavity is None else {
            "shape": a.cavity.shape, "half_extents_m": rounded(a.cavity.half_extents_m),
            "floor_z_m": round(a.cavity.floor_z_m, DIGITS), "rim_z_m": round(a.cavity.rim_z_m, DIGITS)},
    }


def facts_from_record(scene: dict, seg: np.ndarray, depth_m: np.ndarray, K: np.ndarray,
                      T_world_cam: np.ndarray, boxes: list | None = None,
                      pixels: dict[int, PixelStats] | None = None) -> ViewFacts:
    """The view facts of a record, from its scene JSON and its depth and segmentation arrays
    (and the segmentation's ``object_boxes`` and objects' ``pixel_stats``, when the caller has
    them already: the unrounded facts of the same view found them from the same arrays)."""
    K, T = np.asarray(K, dtype=float), np.asarray(T_world_cam, dtype=float)
    right, forward = _horizontal(T[:3, 0]), _horizontal(T[:3, 2])
    boxes = object_boxes(seg) if boxes is None else boxes
    pixels = {} if pixels is None else pixels
    objects = tuple(_object_facts(o, pixels[o["id"]] if o["id"] in pixels else pixel_stats(seg, depth_m, boxes, o["id"]),
                                  right, forward) for o in scene["objects"])
    contacts = frozenset(tuple(p) for p in scene.get("contacts", []))
    table = scene["table"]
    levels = tuple(table.get("levels_m", ()))
    props = frozenset(p["kind"] for p in scene.get("room", {}).get("props", ()))
    return ViewFacts(objects, right, forward, seg, depth_m, K, T, tuple(table["size_m"]), table["top_z_m"],
                     levels, contacts, table_surface=table.get("surface", "table"), prop_kinds=props,
                     cache={BOXES_KEY: boxes})


def _object_facts(o: dict, stats: PixelStats, right, forward) -> ObjectFacts:
    aabb = np.array(o["aabb_world_m"], dtype=float)
    centre = aabb.mean(0)
    pose = np.eye(4)
    pose[:3, :3] = quat_to_matrix(o["pose"]["quat_wxyz"])
    pose[:3, 3] = o["pose"]["pos_world_m"]
    cav = o.get("cavity")
    return ObjectFacts(
        o["id"], o["category"], o["name"], o["color"], aabb, float(centre @ right), float(centre @ forward),
        stats.depth_m, stats.count, o["visibility"],
        footprint_world=np.array(o["footprint_world_m"], dtype=float), front_world=np.array(o["front_world"]),
        outline_world=np.array(o["outline_world_m"], dtype=float) if o.get("outline_world_m") else None,
        front_side=o["front_side"], volume_m3=o["volume_m3"],
        centroid_px=stats.centroid_px,
        visible_share=o["visible_share"], support=o["support"], is_support=o["is_support"], pose_world=pose,
        lab=tuple(o["rendered_lab"]) if o.get("rendered_lab") is not None else None,
        cavity=None if cav is None else Cavity(cav["shape"], tuple(cav["half_extents_m"]), cav["floor_z_m"],
                                               cav["rim_z_m"]),
    )
