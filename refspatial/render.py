"""Offscreen rendering: RGB, metric depth and instance segmentation of each camera.

MuJoCo renders through EGL (Mesa llvmpipe on CPU machines, NVIDIA's driver on
GPU machines) or OSMesa when the user sets ``MUJOCO_GL=osmesa``. The model and GL
context live only inside ``render_views``; callers get plain arrays.
"""

from __future__ import annotations

import os
from dataclasses import dataclass

import numpy as np

os.environ.setdefault("MUJOCO_GL", "egl")

from .assets import MaterialSpec  # noqa: E402
from .mjcf import COLLISION_GROUP, SpecOptions, build_spec, object_of_geom  # noqa: E402
from .scene import Camera, Scene  # noqa: E402


@dataclass(frozen=True, eq=False)
class View:
    camera: Camera
    rgb: np.ndarray  # uint8 (H, W, 3)
    depth_m: np.ndarray  # float32 (H, W), distance along the optical axis
    seg: np.ndarray  # int32 (H, W), object id, -1 for table, floor and sky

    @property
    def K(self) -> np.ndarray:
        return self.camera.intrinsics()

    @property
    def T_world_cam(self) -> np.ndarray:
        return self.camera.T_world_cam()


def render_views(scene: Scene, materials: dict[str, MaterialSpec]) -> list[View]:
    """Render every camera of a settled scene."""
    import mujoco

    spec = build_spec(scene, materials, SpecOptions(dynamic=False))
    model = spec.compile()
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    lookup = object_of_geom(model, len(scene.objects))
    option = mujoco.MjvOption()
    option.geomgroup[COLLISION_GROUP] = 0
    views = []
    width = max(c.width for c in scene.cameras)
    height = max(c.height for c in scene.cameras)
    renderer = mujoco.Renderer(model, height=height, width=width)
    try:
        for cam in scene.cameras:
            views.append(_render_one(renderer, data, option, cam, lookup))
    finally:
        renderer.close()
    return views


def _render_one(renderer, data, option, cam: Camera, lookup: np.ndarray) -> View:
    import mujoco

    if (renderer.width, renderer.height) != (cam.width, cam.height):
        raise ValueError(f"camera {cam.name} is {cam.width}x{cam.height}; all views of a scene must share one size")
    renderer.update_scene(data, camera=cam.name, scene_option=option)
    rgb = renderer.render().copy()
    renderer.enable_depth_rendering()
    renderer.update_scene(data, camera=cam.name, scene_option=option)
    depth = renderer.render().astype(np.float32)
    renderer.disable_depth_rendering()
    renderer.enable_segmentation_rendering()
    renderer.update_scene(data, camera=cam.name, scene_option=option)
    ids = renderer.render()
    renderer.disable_segmentation_rendering()
    is_geom = ids[..., 1] == int(mujoco.mjtObj.mjOBJ_GEOM)
    seg = np.where(is_geom, lookup[np.clip(ids[..., 0], 0, len(lookup) - 1)], -1).astype(np.int32)
    return View(cam, rgb, depth, seg)
