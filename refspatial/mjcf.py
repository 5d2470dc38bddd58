"""Scene -> MuJoCo model (MjSpec), shared by physics, rendering and MJCF export.

Each object is one body named ``obj<ID>`` carrying a visual mesh geom (group 0,
no collision) and its convex collision parts (group 3, invisible). Physics needs
free joints and collision parts; rendering needs neither, so it asks for a
static model, which compiles faster. Settling needs no visual meshes either
(massless, never colliding): leaving them out halves its compile time.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

os.environ.setdefault("MUJOCO_GL", "egl")
import mujoco  # noqa: E402
import numpy as np  # noqa: E402

from .assets import MaterialSpec  # noqa: E402
from .scene import BOARD_M, Scene  # noqa: E402

VISUAL_GROUP = 0
COLLISION_GROUP = 3
TABLE_THICKNESS_M = 0.03
DENSITY_KG_M3 = 600.0  # household objects are mostly hollow; a mean keeps masses plausible
FRICTION = (1.0, 0.01, 0.002)  # sliding, torsional, rolling: rolling friction stops apples drifting
FLOOR_EXTENT_M = 3.0  # model extent for a room: the shadow map (centred on the objects) spans the furniture
WALL_HEIGHT_M, WALL_THICKNESS_M = 2.6, 0.1
WALL_RGBA = (0.86, 0.84, 0.80, 1.0)


@dataclass(frozen=True)
class SpecOptions:
    dynamic: bool  # free joints + collision parts (physics), or fixed bodies (rendering)
    mesh_dir: Path | None = None  # write meshes as STL here and reference them by file
    offscreen: tuple[int, int] = (960, 540)  # framebuffer width, height
    timestep_s: float = 0.002
    visual: bool = True  # the visual mesh geoms (settling alone does without them)


def body_name(object_id: int) -> str:
    return f"obj{object_id}"


def build_spec(scene: Scene, materials: dict[str, MaterialSpec], opts: SpecOptions) -> mujoco.MjSpec:
    spec = mujoco.MjSpec()
    spec.modelname = scene.scene_id
    spec.option.timestep = opts.timestep_s
    spec.option.integrator = mujoco.mjtIntegrator.mjINT_IMPLICITFAST
    _visual_settings(spec, scene, opts)
    _add_room(spec, scene)
    for name, m in materials.items():
        _add_material(spec, f"mat_{name}", m)
    for obj in scene.objects:
        _add_object(spec, obj, opts)
    for cam in scene.cameras:
        spec.worldbody.add_camera(name=cam.name, pos=cam.pos_world_m, quat=cam.quat_wxyz, fovy=cam.fovy_deg)
    return spec


def _add_material(spec: mujoco.MjSpec, name: str, m: MaterialSpec) -> None:
    """A catalogue material, with its builtin texture when it has one (wood grain, brushed metal...)."""
    mat = spec.add_material(name=name, specular=m.specular, shininess=m.shininess, reflectance=m.reflectance)
    t = m.texture
    if t is None:
        return
    builtin = {"gradient": mujoco.mjtBuiltin.mjBUILTIN_GRADIENT, "checker": mujoco.mjtBuiltin.mjBUILTIN_CHECKER,
               "flat": mujoco.mjtBuiltin.mjBUILTIN_FLAT}[t.builtin]
    mark = {"none": mujoco.mjtMark.mjMARK_NONE, "edge": mujoco.mjtMark.mjMARK_EDGE,
            "cross": mujoco.mjtMark.mjMARK_CROSS, "random": mujoco.mjtMark.mjMARK_RANDOM}[t.mark]
    spec.add_texture(name=f"{name}_tex", type=mujoco.mjtTexture.mjTEXTURE_2D, builtin=builtin, mark=mark,
                     random=t.random, rgb1=list(t.rgb1), rgb2=list(t.rgb2), markrgb=list(t.markrgb),
                     width=t.size_px, height=t.size_px)
    mat.texrepeat, mat.texuniform = list(t.repeat), True
    mat.textures[mujoco.mjtTextureRole.mjTEXROLE_RGB] = f"{name}_tex"


def _visual_settings(spec: mujoco.MjSpec, scene: Scene, opts: SpecOptions) -> None:
    width, height = opts.offscreen
    for cam in scene.cameras:
        width, height = max(width, cam.width), max(height, cam.height)
    spec.visual.global_.offwidth = width
    spec.visual.global_.offheight = height
    spec.visual.quality.shadowsize = 2048
    spec.visual.quality.offsamples = 4
    spec.visual.headlight.ambient = [0.25, 0.25, 0.25]
    spec.visual.headlight.diffuse = [0.25, 0.25, 0.25]
    spec.visual.headlight.specular = [0.0, 0.0, 0.0]
    spec.visual.map.znear = 0.01  # fraction of the model extent; keeps depth precise up close
    # The sun's shadow map covers half the extent around the table: spent on the
    # whole floor it leaves too few texels, and the floor shows shadow acne.
    spec.visual.map.shadowclip = 0.5
    spec.stat.extent = FLOOR_EXTENT_M if scene.table.surface == "floor" else 2.0
    spec.stat.center = [0.0, 0.0, scene.table.top_z_m]


def _add_room(spec: mujoco.MjSpec, scene: Scene) -> None:
    t = scene.table
    spec.add_texture(
        name="sky", type=mujoco.mjtTexture.mjTEXTURE_SKYBOX, builtin=mujoco.mjtBuiltin.mjBUILTIN_GRADIENT,
        rgb1=[0.80, 0.82, 0.85], rgb2=[0.35, 0.37, 0.40], width=64, height=64,
    )
    builtin = {
        "checker": mujoco.mjtBuiltin.mjBUILTIN_CHECKER,
        "gradient": mujoco.mjtBuiltin.mjBUILTIN_GRADIENT,
        "flat": mujoco.mjtBuiltin.mjBUILTIN_FLAT,
    }[t.texture]
    rgb = np.array(t.rgba[:3])
    spec.add_texture(
        name="table_tex", type=mujoco.mjtTexture.mjTEXTURE_2D, builtin=builtin,
        rgb1=rgb.tolist(), rgb2=(rgb * 0.85).tolist(), width=256, height=256,
    )
    table_mat = spec.add_material(name="table_mat", specular=0.2, shininess=0.3, texrepeat=[4, 4])
    table_mat.textures[mujoco.mjtTextureRole.mjTEXROLE_RGB] = "table_tex"
    world = spec.worldbody
    if t.surface == "table":  # a floor under the table; a "floor" surface is itself the floor
        spec.add_material(name="floor_mat", rgba=[0.45, 0.43, 0.40, 1.0], specular=0.05)
        world.add_geom(name="floor", type=mujoco.mjtGeom.mjGEOM_PLANE, size=[5, 5, 0.1], material="floor_mat")
    half = [t.size_m[0] / 2, t.size_m[1] / 2, TABLE_THICKNESS_M / 2]
    world.add_geom(
        name="table", type=mujoco.mjtGeom.mjGEOM_BOX, size=half, pos=[0, 0, t.top_z_m - half[2]],
        material="table_mat", friction=FRICTION, condim=6,
    )
    for k, h in enumerate(t.levels_m):  # shelf boards: supports like the top, named so physics can tell
        world.add_geom(
            name=f"board{k}", type=mujoco.mjtGeom.mjGEOM_BOX, size=[half[0], half[1], BOARD_M / 2],
            pos=[0, 0, t.top_z_m + h - BOARD_M / 2], material="table_mat", friction=FRICTION, condim=6,
        )
    if t.surface == "floor":  # walls along the floor's edges: a room, not a stage in a void
        spec.add_material(name="wall_mat", rgba=list(WALL_RGBA), specular=0.05)
        for axis in (0, 1):
            for sign in (-1, 1):
                size = [half[0] + WALL_THICKNESS_M, half[1] + WALL_THICKNESS_M, WALL_HEIGHT_M / 2]
                size[axis] = WALL_THICKNESS_M / 2
                pos = [0.0, 0.0, t.top_z_m + WALL_HEIGHT_M / 2]
                pos[axis] = sign * (half[axis] + WALL_THICKNESS_M / 2)
                world.add_geom(type=mujoco.mjtGeom.mjGEOM_BOX, size=size, pos=pos, material="wall_mat",
                               contype=0, conaffinity=0)
    # Legs, continued up as posts to the highest board on a shelf.
    leg_h = (t.top_z_m + (max(t.levels_m) if t.levels_m else 0.0) - TABLE_THICKNESS_M) / 2
    for sx in ((-1, 1) if t.surface == "table" else ()):
        for sy in (-1, 1):
            world.add_geom(
                type=mujoco.mjtGeom.mjGEOM_BOX, size=[0.025, 0.025, leg_h],
                pos=[sx * (half[0] - 0.05), sy * (half[1] - 0.05), leg_h], material="table_mat",
                contype=0, conaffinity=0,
            )
    light_dir = np.array(scene.light.dir_world)
    diffuse = (0.7 * scene.light.intensity * np.ones(3)).tolist()
    # A directional light's shadow map is centred on its position: over the objects, not the
    # origin, since a room's objects may stand metres from the floor's centre.
    aim = np.array([*_objects_centre(scene), t.top_z_m]) if t.surface == "floor" else np.array([0, 0, t.top_z_m])
    world.add_light(
        name="sun", type=mujoco.mjtLightType.mjLIGHT_DIRECTIONAL, dir=light_dir.tolist(),
        pos=(-2.0 * light_dir + aim).tolist(), diffuse=diffuse,
        specular=[0.2, 0.2, 0.2], ambient=[0.1, 0.1, 0.1], castshadow=True,
    )


def _objects_centre(scene: Scene) -> tuple[float, float]:
    """Middle of the objects' positions on the ground plane (the origin when there are none)."""
    if not scene.objects:
        return 0.0, 0.0
    xy = np.array([o.pose.pos_world_m[:2] for o in scene.objects])
    lo, hi = xy.min(0), xy.max(0)
    return float((lo[0] + hi[0]) / 2), float((lo[1] + hi[1]) / 2)


def _mesh(spec: mujoco.MjSpec, name: str, vertices: np.ndarray, faces: np.ndarray, opts: SpecOptions) -> None:
    if opts.mesh_dir is None:
        spec.add_mesh(name=name, uservert=vertices.ravel().tolist(), userface=faces.ravel().tolist())
        return
    import trimesh

    filename = f"{name.replace('/', '_')}.stl"
    trimesh.Trimesh(vertices, faces, process=False).export(opts.mesh_dir / filename)
    spec.add_mesh(name=name, file=filename)


def _add_object(spec: mujoco.MjSpec, obj, opts: SpecOptions) -> None:
    name = body_name(obj.object_id)
    body = spec.worldbody.add_body(name=name, pos=obj.pose.pos_world_m, quat=obj.pose.quat_wxyz)
    asset = obj.asset
    if opts.visual:
        _mesh(spec, f"{name}_visual", asset.visual.vertices_m, asset.visual.faces, opts)
        body.add_geom(
            name=f"{name}_visual", type=mujoco.mjtGeom.mjGEOM_MESH, meshname=f"{name}_visual",
            rgba=list(asset.rgba), material=f"mat_{asset.material}", group=VISUAL_GROUP,
            contype=0, conaffinity=0, density=0.0,
        )
    if not opts.dynamic:
        return
    body.add_freejoint(name=f"{name}_free")
    for k, part in enumerate(asset.collision):
        mesh_name = f"{name}_col{k}"
        _mesh(spec, mesh_name, part.vertices_m, part.faces, opts)
        body.add_geom(
            name=mesh_name, type=mujoco.mjtGeom.mjGEOM_MESH, meshname=mesh_name, group=COLLISION_GROUP,
            rgba=[0.5, 0.5, 0.5, 0.0], density=DENSITY_KG_M3, friction=FRICTION, condim=6,
        )


def object_of_geom(model: mujoco.MjModel, n_objects: int) -> np.ndarray:
    """Array mapping geom id -> object id (-1 for the table, floor and everything else)."""
    lookup = np.full(model.ngeom, -1, dtype=np.int32)
    for oid in range(n_objects):
        body = model.body(body_name(oid)).id
        lookup[model.geom_bodyid == body] = oid
    return lookup
