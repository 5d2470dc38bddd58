"""Scene -> MuJoCo model (MjSpec), shared by physics, rendering and MJCF export.

Each object is one body named ``obj<ID>`` carrying a visual mesh geom (group 0,
no collision) and its convex collision parts (group 3, invisible). Physics needs
free joints and collision parts; rendering needs neither, so it asks for a
static model, which compiles faster. Settling needs no visual meshes either
(massless, never colliding): leaving them out halves its compile time.
"""

from __future__ import annotations

import hashlib
import os
import struct
from dataclasses import dataclass
from pathlib import Path

os.environ.setdefault("MUJOCO_GL", "egl")
import mujoco  # noqa: E402
import numpy as np  # noqa: E402

from .assets import MaterialSpec  # noqa: E402
from .mjcf_room import ROOM_GROUP, TABLE_THICKNESS_M, add_room, add_texture  # noqa: E402,F401
from .scene import MeshData, Scene  # noqa: E402

VISUAL_GROUP = 0
COLLISION_GROUP = 3
DENSITY_KG_M3 = 600.0  # household objects are mostly hollow; a mean keeps masses plausible
FRICTION = (1.0, 0.01, 0.002)  # sliding, torsional, rolling: rolling friction stops apples drifting
SHADOW_REACH_M = (0.5, 2.0)  # bounds on the half width of the sun's shadow map
FLOOR_EXTENT_M = 3.0  # model extent for a room: the shadow map (centred on the objects) spans the furniture


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
    # Worker processes each own one core: the compiler's mesh threads only add their start-up
    # (1.2 of 13.5 ms a compile); the compiled model is the same.
    spec.compiler.usethread = False
    spec.option.timestep = opts.timestep_s
    spec.option.integrator = mujoco.mjtIntegrator.mjINT_IMPLICITFAST
    # Elliptic friction cones: a condim-6 contact is 6 constraint rows instead of the pyramid's 10.
    # With the recipes' 6 ms step a settle takes 20-35 % less time than pyramids at 4 ms did, poses
    # within 0.7 mm of theirs (one shelf object 2.2 mm; BENCHMARKS.md, twenty-third session).
    spec.option.cone = mujoco.mjtCone.mjCONE_ELLIPTIC
    _visual_settings(spec, scene, opts)
    add_room(spec, scene, FRICTION, opts.visual, opts.mesh_dir)
    add_objects(spec, scene.objects, materials, opts)
    for cam in scene.cameras:
        spec.worldbody.add_camera(name=cam.name, pos=cam.pos_world_m, quat=cam.quat_wxyz, fovy=cam.fovy_deg)
    return spec


def add_objects(spec: mujoco.MjSpec, objects, materials: dict[str, MaterialSpec], opts: SpecOptions) -> None:
    """The catalogue's materials and each placed object's body (the contact sheet uses it too,
    so the sheet shows objects exactly as scenes do). A model without visual geoms (settling)
    gets no materials: nothing would use them, and their builtin textures cost 0.6 ms of
    every settle's compile; collisions and dynamics never read them."""
    if opts.visual:
        for name, m in materials.items():
            _add_material(spec, f"mat_{name}", m)
    assets: dict[str, bytes] = {}
    for obj in objects:
        _add_object(spec, obj, opts, materials, assets)
    if assets:
        spec.assets = {**spec.assets, **assets}  # one hand-over: the binding copies the whole map


def _shadow_reach_m(scene: Scene) -> float:
    """Half width of the sun's shadow map: the objects' spread around their centre plus the
    shadow the tallest one throws, within bounds that keep furniture tops covered."""
    if not scene.objects:
        return SHADOW_REACH_M[1]
    xy = np.array([o.pose.pos_world_m[:2] for o in scene.objects])
    spread = float(np.linalg.norm(xy.max(0) - xy.min(0))) / 2
    tallest = max(float(o.asset.size_m[2]) for o in scene.objects)
    elevation = np.arcsin(min(1.0, abs(scene.light.dir_world[2])))
    reach = spread + tallest / max(np.tan(elevation), 0.3) + 0.15
    return float(np.clip(reach, *SHADOW_REACH_M))


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
    # The sun's map is fitted to the objects and its shadows are softened (light radius): at
    # 1024 texels they look as at 2048 and a view renders 15-30 ms sooner on a CPU rasteriser.
    spec.visual.quality.shadowsize = 1024
    spec.visual.quality.offsamples = 4
    spec.visual.headlight.ambient = [0.2, 0.2, 0.2]
    spec.visual.headlight.diffuse = [0.15, 0.15, 0.15]
    spec.visual.headlight.specular = [0.0, 0.0, 0.0]
    spec.visual.map.znear = 0.01  # fraction of the model extent; keeps depth precise up close
    spec.stat.extent = FLOOR_EXTENT_M if scene.table.surface == "floor" else 2.0
    # The sun's shadow map spans the objects and their shadows, no more: every texel spent
    # beyond them is lost to the objects, whose edges then fray.
    spec.visual.map.shadowclip = _shadow_reach_m(scene) / spec.stat.extent
    spec.stat.center = [0.0, 0.0, scene.table.top_z_m]


def _mesh(spec: mujoco.MjSpec, name: str, mesh: MeshData, opts: SpecOptions,
          assets: dict[str, bytes] | None = None) -> None:
    """Add a mesh: as a file beside an exported model (``mesh_dir``), as a content-named asset
    MuJoCo's compiler cache can reuse (collision parts: ``assets`` collects them), or inline."""
    vertices, faces = mesh.vertices_m, mesh.faces
    if opts.mesh_dir is None and assets is not None:
        filename, data = msh_asset(mesh)
        assets[filename] = data
        spec.add_mesh(name=name, file=filename)
        return
    if opts.mesh_dir is None:
        mesh_spec = spec.add_mesh(name=name, uservert=vertices.ravel().tolist(), userface=faces.ravel().tolist())
        if mesh.texcoords is not None:
            mesh_spec.usertexcoord = mesh.texcoords.ravel().tolist()
            mesh_spec.userfacetexcoord = mesh.face_texcoords.ravel().tolist()
        return
    import trimesh

    if mesh.texcoords is not None:  # STL has no texture coordinates; OBJ does
        filename = f"{name.replace('/', '_')}.obj"
        _write_obj(opts.mesh_dir / filename, vertices, faces, mesh.texcoords, mesh.face_texcoords)
    else:
        filename = f"{name.replace('/', '_')}.stl"
        trimesh.Trimesh(vertices, faces, process=False).export(opts.mesh_dir / filename)
    spec.add_mesh(name=name, file=filename)


def msh_asset(mesh: MeshData) -> tuple[str, bytes]:
    """(file name, bytes) of an untextured mesh (a collision part) in MuJoCo's binary .msh
    format, named by its content, memoised on the mesh.

    MuJoCo's compiler keeps what it makes of a mesh file (convex hull, its graph, the bounding
    volume hierarchy) in a per-process asset cache keyed by file name: a shape variant's
    collision parts, met again in a later scene, then cost nothing to compile (a settle's
    compile falls from about 10 to 1.6 ms once the bank's variants have been seen). The model is
    the same as from inline vertices, which the binding also stores as float32. Only collision
    parts go this way: a cached mesh holds ~750 bytes a vertex, and visual meshes are ten times
    larger and meet the render model's compile only."""
    if mesh.texcoords is not None:
        raise ValueError("msh_asset: a textured mesh needs its texture coordinates inline")
    try:
        return mesh.__dict__["_msh"]
    except KeyError:
        pass
    vertices = np.ascontiguousarray(mesh.vertices_m, dtype="<f4")
    faces = np.ascontiguousarray(mesh.faces, dtype="<i4")
    data = struct.pack("<4i", len(vertices), 0, 0, len(faces)) + vertices.tobytes() + faces.tobytes()
    out = (f"{hashlib.blake2b(data, digest_size=16).hexdigest()}.msh", data)
    mesh.__dict__["_msh"] = out  # a frozen dataclass's own memo, as its cached properties keep theirs
    return out


WARM_BATCH = 256  # meshes per warm-up compile: one model of every part would hold gigabytes at once


def warm_mesh_cache(parts) -> int:
    """Compile collision parts into MuJoCo's asset cache, as a long run's scenes leave it (for
    benchmarks of that steady state; models are the same either way); returns how many."""
    assets = dict(msh_asset(p) for p in parts)
    names = sorted(assets)
    for start in range(0, len(names), WARM_BATCH):
        spec = mujoco.MjSpec()
        spec.compiler.usethread = False
        batch = names[start:start + WARM_BATCH]
        spec.assets = {n: assets[n] for n in batch}
        for k, filename in enumerate(batch):
            spec.add_mesh(name=f"part{k}", file=filename)
            # Only a mesh a geom uses is cached as scenes find it (with its inertia worked out).
            spec.worldbody.add_body().add_geom(type=mujoco.mjtGeom.mjGEOM_MESH, meshname=f"part{k}",
                                               density=DENSITY_KG_M3)
        spec.compile()
    return len(names)


def _write_obj(path: Path, vertices: np.ndarray, faces: np.ndarray, uv: np.ndarray, face_uv: np.ndarray) -> None:
    """A Wavefront OBJ with per-corner texture coordinates (``f v/vt``), 1-based as OBJ counts."""
    lines = [f"v {x:.7g} {y:.7g} {z:.7g}" for x, y, z in vertices]
    lines += [f"vt {u:.6g} {v:.6g}" for u, v in uv]
    lines += [f"f {a + 1}/{ta + 1} {b + 1}/{tb + 1} {c + 1}/{tc + 1}"
              for (a, b, c), (ta, tb, tc) in zip(faces, face_uv)]
    path.write_text("\n".join(lines) + "\n", encoding="ascii")


def _textured_material(spec: mujoco.MjSpec, name: str, asset, materials: dict[str, MaterialSpec],
                       folder: Path | None) -> str:
    """The catalogue material's shading with the asset's own texture (shared by equal textures)."""
    m = materials[asset.material]
    tex = add_texture(spec, f"tex_{asset.texture.key}", asset.texture, folder)
    mat = spec.add_material(name=f"{name}_mat", specular=m.specular, shininess=m.shininess, reflectance=m.reflectance)
    mat.textures[mujoco.mjtTextureRole.mjTEXROLE_RGB] = tex
    return mat.name


def _add_object(spec: mujoco.MjSpec, obj, opts: SpecOptions, materials: dict[str, MaterialSpec],
                assets: dict[str, bytes]) -> None:
    name = body_name(obj.object_id)
    body = spec.worldbody.add_body(name=name, pos=obj.pose.pos_world_m, quat=obj.pose.quat_wxyz)
    asset = obj.asset
    if opts.visual:
        _mesh(spec, f"{name}_visual", asset.visual, opts)
        material, rgba = f"mat_{asset.material}", list(asset.rgba)
        if asset.texture is not None:  # the texture carries the whole colour: white rgba, own material
            material, rgba = _textured_material(spec, name, asset, materials, opts.mesh_dir), [1.0, 1.0, 1.0, asset.rgba[3]]
        body.add_geom(
            name=f"{name}_visual", type=mujoco.mjtGeom.mjGEOM_MESH, meshname=f"{name}_visual",
            rgba=rgba, material=material, group=VISUAL_GROUP, contype=0, conaffinity=0, density=0.0,
        )
    if not opts.dynamic:
        return
    body.add_freejoint(name=f"{name}_free")
    for k, part in enumerate(asset.collision):
        mesh_name = f"{name}_col{k}"
        _mesh(spec, mesh_name, part, opts, assets)
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
