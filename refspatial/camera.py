"""Camera framing: look down at the settled objects the way RefSpatial's scenes do.

Each view draws a heading around the objects, a pitch below the horizon and a
field of view, then the distance along the line of sight is chosen so that the
camera height stays in the recipe's band and every object's box projects inside
the image with a margin. Views that cannot satisfy both are redrawn; after
``attempts`` the scene is rejected.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from .compiled import in_frame
from .compose import SceneRejected
from .recipe import Recipe
from .room import camera_clearance_m
from .relations.geometry import project as project_points
from .scene import Camera, Scene, matrix_to_quat
from .seeding import stage_rng

FIT_ITERATIONS = 30  # bisection steps on the viewing distance (sub-millimetre)
NEAREST_M = 0.05  # every object corner at least this far in front of the camera


def frame_cameras(scene: Scene, recipe: Recipe) -> Scene:
    spec = recipe["camera"]
    rng = stage_rng(recipe.hash, scene.seed, "camera")
    corners = _object_corners(scene)
    # Aim at the middle of the objects on the ground plane, at the table top (mid-shelf on a shelf).
    levels = scene.table.levels_m
    aim_z = scene.table.top_z_m + (0.5 * max(levels) if levels else 0.0)
    aim = np.array([*((corners[:, :2].min(0) + corners[:, :2].max(0)) / 2), aim_z])
    # The camera stays inside the walls, clear of the background furniture, with room for a head.
    room = np.array(scene.room.size_m) / 2 - camera_clearance_m(scene.room, scene.table)
    cams = []
    for view in range(spec["views"]):
        cams.append(_frame_one(f"view{view}", corners, aim, spec, rng, room))
    return dataclasses.replace(scene, cameras=tuple(cams))


def look_rotation(yaw: float, pitch: float) -> np.ndarray:
    """World <- MuJoCo camera rotation for a camera heading ``yaw``, tilted by ``pitch`` (radians)."""
    forward = np.array([np.cos(pitch) * np.cos(yaw), np.cos(pitch) * np.sin(yaw), np.sin(pitch)])
    right = np.cross(forward, [0.0, 0.0, 1.0])
    right /= np.linalg.norm(right)
    up = np.cross(right, forward)
    return np.stack([right, up, -forward], axis=1)


def project(points_world: np.ndarray, cam: Camera) -> tuple[np.ndarray, np.ndarray]:
    """Pixel coordinates (N, 2) and depths (N,) of world points seen by a camera."""
    return project_points(points_world, cam.intrinsics(), cam.T_world_cam())


def _object_corners(scene: Scene) -> np.ndarray:
    out = []
    for obj in scene.objects:
        lo, hi = obj.asset.visual.bounds_m
        box = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])])
        T = obj.pose.matrix()
        out.append(box @ T[:3, :3].T + T[:3, 3])
    return np.concatenate(out)


def _frame_one(name: str, corners: np.ndarray, aim: np.ndarray, spec: dict, rng: np.random.Generator,
               room: np.ndarray | None = None) -> Camera:
    for _ in range(spec["attempts"]):
        yaw = float(np.radians(rng.uniform(*spec["yaw_deg"])))
        pitch = float(np.radians(rng.uniform(*spec["pitch_deg"])))
        fovy = float(rng.uniform(*spec["fovy_deg"]))
        rot = look_rotation(yaw, pitch)
        quat = matrix_to_quat(rot)
        h_lo, h_hi = spec["height_above_table_m"]
        d_lo, d_hi = h_lo / np.sin(-pitch), h_hi / np.sin(-pitch)
        if room is not None:  # no farther than the walls (half extents ``room`` about the origin)
            back = rot[:2, 2]
            reach = [(room[k] - np.sign(back[k]) * aim[k]) / abs(back[k]) for k in (0, 1) if abs(back[k]) > 1e-9]
            d_hi = min(d_hi, *reach)
            if d_hi < d_lo:
                continue

        def camera_at(d: float) -> Camera:
            pos = aim + d * rot[:, 2]  # the camera's +z points back, away from what it sees
            return Camera(name, tuple(float(v) for v in pos), quat, fovy, spec["width"], spec["height"])

        # The bisection below moves one camera along its line of sight: its intrinsics and
        # rotation are made once, and each step only sets the position camera_at(d) would have.
        placed = camera_at(d_hi)
        K, T = placed.intrinsics(), placed.T_world_cam()

        def fits(d: float) -> bool:
            T[:3, 3] = aim + d * rot[:, 2]
            uv, z = project_points(corners, K, T)
            return in_frame(uv, z, NEAREST_M, spec["margin_px"], spec["width"], spec["height"])

        if not fits(d_hi):
            continue
        d_min = d_lo if fits(d_lo) else _bisect(fits, d_lo, d_hi)
        # "fill" places the camera between the tightest framing (0) and the farthest allowed (1):
        # close framings spread objects over the image instead of piling them in its centre.
        lo, hi = spec["fill"]
        return camera_at(d_min + float(rng.uniform(lo, hi)) * (d_hi - d_min))
    raise SceneRejected("no_camera_view", f"no {name} within the height band shows every object")


def _bisect(fits, bad: float, good: float) -> float:
    for _ in range(FIT_ITERATIONS):
        mid = (bad + good) / 2
        bad, good = (bad, mid) if fits(mid) else (mid, good)
    return good
