"""Per-view facts about each object, the inputs every predicate reads.

"Viewer frame": the camera's right and forward axes projected onto the ground
plane (gravity is world -z), so "left of" means the same thing whether the
camera looks steeply down or almost level.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..render import View
from ..scene import Scene

VISIBLE_SHARE_OF_IMAGE = 0.0006  # below this many pixels (share of the image) an object is too small to ask about
MIN_VISIBLE_PX = 20


@dataclass(frozen=True, eq=False)
class ObjectFacts:
    object_id: int
    category: str
    name: str
    color: str
    aabb_world_m: np.ndarray  # (2, 3) min and max corners of the posed visual mesh
    lateral_m: float  # centre along the viewer's right axis
    forward_m: float  # centre along the viewer's ground-projected forward axis
    depth_m: float  # median camera depth of the visible surface (inf if unseen)
    visible_px: int
    status: str  # "visible" (may be asked about), "marginal" (seen, too little to ask) or "hidden"

    @property
    def center_world_m(self) -> np.ndarray:
        return self.aabb_world_m.mean(axis=0)

    @property
    def footprint_m(self) -> np.ndarray:
        """(x, y) extents of the world box on the ground."""
        return self.aabb_world_m[1, :2] - self.aabb_world_m[0, :2]

    def extent_along(self, axis_world: np.ndarray) -> float:
        """Width of the world box projected on a horizontal unit axis."""
        return float(np.abs(self.footprint_m * axis_world[:2]).sum())


@dataclass(frozen=True, eq=False)
class ViewFacts:
    objects: tuple[ObjectFacts, ...]  # indexed by object id
    right_axis: np.ndarray  # (3,) world, horizontal unit vector
    forward_axis: np.ndarray  # (3,) world, horizontal unit vector, away from the viewer
    seg: np.ndarray  # int32 (H, W)
    depth_m: np.ndarray  # float32 (H, W)

    @property
    def width(self) -> int:
        return int(self.seg.shape[1])

    @property
    def height(self) -> int:
        return int(self.seg.shape[0])

    def askable(self) -> list[ObjectFacts]:
        return [o for o in self.objects if o.status == "visible"]


def view_facts(scene: Scene, view: View) -> ViewFacts:
    R = view.T_world_cam[:3, :3]
    right = _horizontal(R[:, 0])
    forward = _horizontal(R[:, 2])
    counts = np.bincount(view.seg.ravel() + 1, minlength=len(scene.objects) + 1)[1:]
    min_px = max(MIN_VISIBLE_PX, VISIBLE_SHARE_OF_IMAGE * view.seg.size)
    objects = []
    for obj in scene.objects:
        verts = obj.asset.visual.vertices_m @ obj.pose.matrix()[:3, :3].T + obj.pose.pos_world_m
        aabb = np.stack([verts.min(0), verts.max(0)])
        centre = aabb.mean(0)
        px = int(counts[obj.object_id])
        depth = float(np.median(view.depth_m[view.seg == obj.object_id])) if px else float("inf")
        status = "visible" if px >= min_px else ("marginal" if px else "hidden")
        objects.append(
            ObjectFacts(obj.object_id, obj.asset.category, obj.asset.name, obj.asset.color, aabb,
                        float(centre @ right), float(centre @ forward), depth, px, status)
        )
    return ViewFacts(tuple(objects), right, forward, view.seg, view.depth_m)


def _horizontal(v: np.ndarray) -> np.ndarray:
    h = np.array([v[0], v[1], 0.0])
    n = np.linalg.norm(h)
    if n < 1e-6:
        raise ValueError("camera looks straight down: the viewer frame is undefined; keep pitch_deg above -89")
    return h / n
