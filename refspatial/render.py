"""Offscreen rendering: RGB, metric depth and instance segmentation of each camera.

MuJoCo renders through EGL (Mesa llvmpipe on CPU machines, NVIDIA's driver on
GPU machines) or OSMesa when the user sets ``MUJOCO_GL=osmesa``. The model and GL
context live only inside this module; callers get plain arrays.

Two passes per camera: the shaded colour pass, then one "segment" pass (flat
id colours, no lighting) read back as ids and depth together, the way MuJoCo's
own Renderer reads depth. One GL context is kept per process and reused across
scenes: creating it costs more than rendering a view on a CPU rasteriser.
"""

from __future__ import annotations

import atexit
import os
import time
from contextlib import contextmanager
from dataclasses import dataclass
from typing import Iterator

import numpy as np

os.environ.setdefault("MUJOCO_GL", "egl")

from .assets import MaterialSpec  # noqa: E402
from .compiled import ids_upright, metres_upright  # noqa: E402
from .mjcf import COLLISION_GROUP, ROOM_GROUP, SpecOptions, build_spec, object_of_geom  # noqa: E402
from .scene import Camera, Scene  # noqa: E402

SPARE_GEOMS = 64  # room in the abstract scene beyond the model's own geoms (lights, decor)


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


class _Context:
    """The process's GL context, grown when a bigger framebuffer is asked for."""

    gl = None
    size = (0, 0)

    @classmethod
    def current(cls, width: int, height: int):
        import mujoco

        if cls.gl is None or width > cls.size[0] or height > cls.size[1]:
            if cls.gl is None:
                atexit.register(cls.release)
            else:
                cls.gl.free()
            cls.size = (max(width, cls.size[0]), max(height, cls.size[1]))
            cls.gl = mujoco.GLContext(*cls.size)
        cls.gl.make_current()
        return cls.gl

    @classmethod
    def release(cls) -> None:
        """Free the context while the interpreter is whole. Left to the destructor, OSMesa's
        free runs after PyOpenGL's modules are torn down and prints a traceback at every exit."""
        if cls.gl is not None:
            cls.gl.free()
            cls.gl, cls.size = None, (0, 0)


PHASES = ("compile", "upload", "colour", "depth+seg", "convert")  # what render_views' timings hold


@contextmanager
def _timed(timings: dict[str, float] | None, phase: str) -> Iterator[None]:
    if timings is None:
        yield
        return
    start = time.perf_counter()
    try:
        yield
    finally:
        timings[phase] = timings.get(phase, 0.0) + time.perf_counter() - start


def gl_info() -> dict[str, str]:
    """Who draws: GL vendor, renderer and version of this process's context (llvmpipe is Mesa
    on the CPU; an NVIDIA renderer string means the GPU)."""
    _Context.current(64, 64)
    from OpenGL import GL

    return {k: GL.glGetString(getattr(GL, f"GL_{k.upper()}")).decode() for k in ("vendor", "renderer", "version")}


def render_views(scene: Scene, materials: dict[str, MaterialSpec],
                 timings: dict[str, float] | None = None) -> list[View]:
    """Render every camera of a settled scene. ``timings``, when given, gains the seconds spent
    in each of PHASES: the model's compile, its upload to the GL context (meshes, textures), the
    colour pass, the depth and segmentation pass (each with its read-back, which waits for the
    GPU), and the conversion of read-back buffers into metres and object ids."""
    import mujoco

    width, height = scene.cameras[0].width, scene.cameras[0].height
    for cam in scene.cameras:
        if (cam.width, cam.height) != (width, height):
            raise ValueError(f"camera {cam.name} is {cam.width}x{cam.height}; all views of a scene must share one size")
    with _timed(timings, "compile"):
        model = build_spec(scene, materials, SpecOptions(dynamic=False, offscreen=(width, height))).compile()
        data = mujoco.MjData(model)
        mujoco.mj_forward(model, data)
    with _timed(timings, "upload"):
        _Context.current(model.vis.global_.offwidth, model.vis.global_.offheight)
        # No text is ever drawn; the smallest font halves the context's set-up time (20 ms a scene).
        ctx = mujoco.MjrContext(model, mujoco.mjtFontScale.mjFONTSCALE_50.value)
    try:
        mujoco.mjr_setBuffer(mujoco.mjtFramebuffer.mjFB_OFFSCREEN.value, ctx)
        ctx.readDepthMap = mujoco.mjtDepthMap.mjDEPTH_ZEROFAR
        lookup = object_of_geom(model, len(scene.objects))
        # One abstract scene for all views, sized to the model: allocating room for thousands of
        # geoms took longer than reading a view back.
        scn = mujoco.MjvScene(model, maxgeom=model.ngeom + SPARE_GEOMS)
        return [_render_one(model, data, ctx, scn, cam, lookup, timings) for cam in scene.cameras]
    finally:
        ctx.free()


def _render_one(model, data, ctx, scn, cam: Camera, lookup: np.ndarray,
                timings: dict[str, float] | None) -> View:
    import mujoco

    option = mujoco.MjvOption()
    option.geomgroup[COLLISION_GROUP] = 0
    camera = mujoco.MjvCamera()
    camera.type = mujoco.mjtCamera.mjCAMERA_FIXED
    camera.fixedcamid = model.camera(cam.name).id
    scn.flags[mujoco.mjtRndFlag.mjRND_SEGMENT] = False
    scn.flags[mujoco.mjtRndFlag.mjRND_IDCOLOR] = False
    mujoco.mjv_updateScene(model, data, option, None, camera, mujoco.mjtCatBit.mjCAT_ALL.value, scn)
    if scn.ngeom >= scn.maxgeom:  # MuJoCo drops what does not fit: objects would vanish silently
        raise RuntimeError(f"the scene has more than {scn.maxgeom} visual geoms; raise SPARE_GEOMS")
    room_casts_no_shadow(model, scn)
    rect = mujoco.MjrRect(0, 0, cam.width, cam.height)
    rgb = np.empty((cam.height, cam.width, 3), dtype=np.uint8)
    with _timed(timings, "colour"):
        mujoco.mjr_render(rect, scn, ctx)
        mujoco.mjr_readPixels(rgb, None, rect, ctx)
    scn.flags[mujoco.mjtRndFlag.mjRND_SEGMENT] = True
    scn.flags[mujoco.mjtRndFlag.mjRND_IDCOLOR] = True
    ids = np.empty((cam.height, cam.width, 3), dtype=np.uint8)
    raw = np.empty((cam.height, cam.width), dtype=np.float32)
    with _timed(timings, "depth+seg"):
        mujoco.mjr_render(rect, scn, ctx)
        mujoco.mjr_readPixels(ids, raw, rect, ctx)
    with _timed(timings, "convert"):
        # OpenGL's rows run bottom-up: each conversion reads its buffer upside down, so the
        # flip costs no pass of its own.
        return View(cam, np.ascontiguousarray(rgb[::-1]), metric_depth(model, raw), _segmentation(scn, ids, lookup))


def room_casts_no_shadow(model, scn) -> None:
    """Walls, ceiling and background pieces stay out of the shadow map: under a low sun they
    would shade the whole table, and they stand outside the light's view of the objects anyway."""
    import mujoco

    for k in range(scn.ngeom):
        g = scn.geoms[k]
        if g.objtype == mujoco.mjtObj.mjOBJ_GEOM and model.geom_group[g.objid] == ROOM_GROUP:
            g.castshadow = 0


def metric_depth(model, raw: np.ndarray) -> np.ndarray:
    """A reversed-Z depth read-back (rows bottom-up, as OpenGL reads them) -> metres along the
    optical axis, rows top-down (platform.md: n f / (n + raw (f - n)), in float64)."""
    extent = model.stat.extent
    # One compiled pass (a GPU box spent 8 ms a view converting read-backs as numpy steps, more
    # than its depth pass).
    return metres_upright(raw, float(model.vis.map.znear * extent), float(model.vis.map.zfar * extent))


def _segmentation(scn, ids: np.ndarray, lookup: np.ndarray) -> np.ndarray:
    """Id colours (rows bottom-up) -> object ids, rows top-down: colour value s + 1 is the drawn
    geom with segid s (0 is the background)."""
    import mujoco

    table = np.full(scn.ngeom + 2, -1, dtype=np.int32)
    for k in range(scn.ngeom):
        g = scn.geoms[k]
        if g.segid >= 0 and g.objtype == mujoco.mjtObj.mjOBJ_GEOM and 0 <= g.objid < len(lookup):
            table[g.segid + 1] = lookup[g.objid]
    return ids_upright(ids, table)
