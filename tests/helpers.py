"""Hand-built view facts: scenes whose every relation is known by construction (and, for tests
that need real renders, ``rendered_scenes``).

The camera stands 1 m in front of the origin (at y = -1), 0.5 m up, looking along
world +y and pitched down; so "right" is +x, "front" is small y, and objects
farther along +y are farther from the camera. Objects are axis-aligned boxes
standing on a 1.2 x 0.8 m table whose top is at z = 0.
"""

from __future__ import annotations

import numpy as np

from refspatial.camera import look_rotation
from refspatial.relations import TABLE, ObjectFacts, ViewFacts
from refspatial.relations.geometry import project
from refspatial.scene import Cavity

SHAPE = (120, 160)  # rows, cols
K = np.array([[150.0, 0, 80], [0, 150.0, 60], [0, 0, 1]])
T = np.eye(4)
T[:3, :3] = look_rotation(np.pi / 2, -np.radians(30)) @ np.diag([1.0, -1.0, -1.0])
T[:3, 3] = [0.0, -1.0, 0.5]


def obj(oid: int, category: str, color: str, x: float, y: float, size: float = 0.08, status: str = "visible",
        height: float = 0.1, z: float = 0.0, front=(1.0, 0.0, 0.0), support: int | None = TABLE,
        cavity: Cavity | None = None, is_support: bool = False) -> ObjectFacts:
    lo = np.array([x - size / 2, y - size / 2, z])
    hi = np.array([x + size / 2, y + size / 2, z + height])
    centre = (lo + hi) / 2
    uv, depth = project(centre[None], K, T)
    foot = np.array([[lo[0], lo[1]], [hi[0], lo[1]], [hi[0], hi[1]], [lo[0], hi[1]]])
    pose = np.eye(4)
    pose[:3, 3] = [x, y, z]
    px = {"visible": 500, "marginal": 5}.get(status, 0)
    return ObjectFacts(
        oid, category, category.replace("_", " "), color, np.stack([lo, hi]), float(x), float(y),
        float(depth[0]), px, status, footprint_world=foot, front_world=np.array(front, dtype=float),
        volume_m3=size * size * height, centroid_px=(float(uv[0, 0]), float(uv[0, 1])) if px else None,
        support=support, cavity=cavity, is_support=is_support, pose_world=pose,
    )


def view(*objects: ObjectFacts, contacts=(), T_world_cam: np.ndarray = T) -> ViewFacts:
    """A view whose segmentation paints a 7x7 square at each seen object's centroid."""
    seg = np.full(SHAPE, -1, dtype=np.int32)
    for o in objects:
        if o.centroid_px is not None:
            c, r = int(o.centroid_px[0]), int(o.centroid_px[1])
            seg[max(r - 3, 0): r + 4, max(c - 3, 0): c + 4] = o.object_id
    right, forward = (np.r_[T_world_cam[:2, k], 0.0] / np.linalg.norm(T_world_cam[:2, k]) for k in (0, 2))
    return ViewFacts(tuple(objects), right, forward, seg,
                     np.ones(SHAPE, dtype=np.float32), K, T_world_cam, (1.2, 0.8), 0.0, contacts=frozenset(contacts))


def rendered_scenes(recipe, catalogue, count: int, seeds: int = 40) -> list:
    """(scene, its rendered views) of the first ``count`` seeds whose scenes compose and settle."""
    from refspatial.compose import SceneRejected
    from refspatial.pipeline import build_scene
    from refspatial.render import render_views

    out = []
    for seed in range(seeds):
        try:
            scene = build_scene(recipe, catalogue, seed)
        except SceneRejected:
            continue
        out.append((scene, render_views(scene, catalogue.materials)))
        if len(out) == count:
            return out
    raise AssertionError(f"fewer than {count} usable scenes in {seeds} seeds")
