"""One USD stage per scene: the objects' meshes, the table and a camera per view.

Records store no meshes, so the scene is rebuilt from (recipe, seed) with
``pipeline.build_scene``, using the recipe text stored in the dataset's manifest; its hash
must equal the stored ``recipe_hash`` and the catalogue's sha256 the stored one, else the
meshes could differ from what was rendered. Object poses and cameras are taken from the
records themselves, so the stage matches the images exactly even if physics drifts.

Stage conventions: metres (metersPerUnit 1), +z up, like the world frame. MuJoCo cameras
and USD cameras both look down -z with +y up, so a camera's transform is the record's
T_world_cam (OpenCV: +z forward, +y down) times diag(1, -1, -1).
"""

from __future__ import annotations

import hashlib
import re

import tempfile
from pathlib import Path

import numpy as np
from PIL import Image
from pxr import Gf, Sdf, Usd, UsdGeom, UsdShade, Vt

from refspatial.assets import Catalogue, MaterialSpec, load_catalogue
from refspatial.compose import SceneRejected
from refspatial.library import LibraryError, attach
from refspatial.mjcf import TABLE_THICKNESS_M
from refspatial.pipeline import build_scene
from refspatial.recipe import Recipe, RecipeError, load_recipe
from refspatial.scene import Scene, Texture

from .common import FAR_PLANE_M, ExportError, ExportSummary, finish, open_dataset, read_manifest, scenes, staged

NEAR_PLANE_M = 0.02  # MuJoCo znear 0.01 x extent 2 m (mjcf.py)
SENSOR_HEIGHT = 24.0  # vertical aperture, in the focal length's unit; only their ratio projects
CV_TO_GL = np.diag([1.0, -1.0, -1.0])
TEXTURE_DIR = "textures"  # imported meshes' images, as PNG beside the stages that use them


def export_usd(dataset_dir: Path, out_dir: Path, *, ascii: bool = False, overwrite: bool = False) -> ExportSummary:
    """Write ``<scene_id>.usdc`` (or .usda with ``ascii``) for every scene of a dataset."""
    dataset = open_dataset(dataset_dir, ())
    manifest = read_manifest(dataset_dir)
    recipe, catalogue = _libraries(dataset_dir, manifest, _recipe(dataset_dir, manifest),
                                   _catalogue(dataset_dir, manifest))
    records = stages = 0
    with staged(out_dir, overwrite) as tmp:
        for views in scenes(dataset):
            records += len(views)
            recorded = views[0]["scene"]
            scene = _rebuild(recipe, catalogue, recorded)
            path = tmp / f"{recorded['scene_id']}.{'usda' if ascii else 'usdc'}"
            write_stage(path, scene, views, catalogue.materials)
            stages += 1
        return finish("usd", tmp, out_dir, dataset_dir, records, {"stages": stages}, {"ascii": ascii})


def _recipe(dataset_dir: Path, manifest: dict) -> Recipe:
    """The recipe the records were made with, from its stored YAML text."""
    with tempfile.TemporaryDirectory() as d:
        path = Path(d) / f"{manifest['recipe']}.yaml"
        # Datasets since the resolved recipe was stored rebuild without the recipes they extend.
        path.write_text(manifest.get("recipe_resolved_yaml", manifest["recipe_yaml"]), encoding="utf-8")
        try:
            recipe = load_recipe(str(path))
        except RecipeError as e:
            raise ExportError(f"DIR {dataset_dir}: its stored recipe no longer loads ({e})") from None
    if recipe.hash != manifest["recipe_hash"]:
        raise ExportError(f"DIR {dataset_dir}: its recipe text now resolves to hash {recipe.hash[:12]}, "
                          f"the records were made with {manifest['recipe_hash'][:12]}; the recipe it extends "
                          "in recipes/ changed, restore that version to rebuild the meshes")
    return recipe


def _catalogue(dataset_dir: Path, manifest: dict) -> Catalogue:
    catalogue = load_catalogue()
    if catalogue.sha256 != manifest["catalogue_sha256"]:
        raise ExportError(f"DIR {dataset_dir} was made with catalogue {manifest['catalogue_sha256'][:12]}, "
                          f"scene_assets/catalogue.yaml is now {catalogue.sha256[:12]}; restore that "
                          "catalogue to rebuild the meshes")
    return catalogue


def _libraries(dataset_dir: Path, manifest: dict, recipe: Recipe, catalogue: Catalogue) -> tuple[Recipe, Catalogue]:
    """The asset libraries the run drew from, found where the manifest says and checked by hash."""
    recorded = manifest.get("libraries", [])
    if not recorded and not recipe.option("libraries", "sha256"):
        return recipe, catalogue
    try:
        attached, catalogue = attach(recipe, catalogue, [Path(r["path"]) for r in recorded])
    except LibraryError as e:
        raise ExportError(f"DIR {dataset_dir} was made with asset libraries that cannot be used now ({e}); "
                          "put them back where its manifest.json says") from None
    if attached.hash != recipe.hash:
        raise ExportError(f"DIR {dataset_dir}: its manifest names no asset libraries, but its recipe was made "
                          "with some; put them back and list them under `libraries` in manifest.json")
    return attached, catalogue


def _rebuild(recipe: Recipe, catalogue: Catalogue, recorded: dict) -> Scene:
    """The scene of a record, rebuilt and checked to hold the recorded objects (id, category
    and mesh size): the same recipe and catalogue with other shape code would differ."""
    try:
        scene = build_scene(recipe, catalogue, recorded["seed"])
    except SceneRejected as e:
        raise ExportError(f"scene {recorded['scene_id']} no longer builds ({e}); export with the "
                          "refspatial version that made the dataset") from None
    objs = recorded["objects"]
    same = len(scene.objects) == len(objs) and all(
        o.object_id == r["id"] and o.asset.category == r["category"]
        and np.allclose(o.asset.size_m, r["box_world"]["size_m"], atol=1e-5)
        for o, r in zip(scene.objects, objs))
    if not same:
        raise ExportError(f"scene {recorded['scene_id']} rebuilds with different objects; the shape code "
                          "changed since the dataset was made, export with the refspatial version that made it")
    return scene


def write_stage(path: Path, scene: Scene, views: list[dict], materials: dict[str, MaterialSpec]) -> None:
    """Write one stage: /World/{Objects,Table,Looks,Cameras}."""
    stage = Usd.Stage.CreateNew(str(path))
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.z)
    UsdGeom.SetStageMetersPerUnit(stage, 1.0)
    world = UsdGeom.Xform.Define(stage, "/World")
    stage.SetDefaultPrim(world.GetPrim())
    recorded = views[0]["scene"]
    for k in ("scene_id", "recipe_hash", "seed"):
        world.GetPrim().SetCustomDataByKey(f"refspatial:{k}", recorded[k])
    for group in ("Objects", "Table", "Cameras"):
        UsdGeom.Xform.Define(stage, f"/World/{group}")
    UsdGeom.Scope.Define(stage, "/World/Looks")
    for obj, rec in zip(scene.objects, recorded["objects"]):
        _object(stage, obj, rec, materials[obj.asset.material])
    _table(stage, scene)
    for s in views:
        _camera(stage, s)
    stage.GetRootLayer().Save()


def _material(stage: Usd.Stage, name: str, rgb: tuple, roughness: float) -> UsdShade.Material:
    """A UsdPreviewSurface material under /World/Looks."""
    material = UsdShade.Material.Define(stage, f"/World/Looks/{name}")
    shader = UsdShade.Shader.Define(stage, f"/World/Looks/{name}/PreviewSurface")
    shader.CreateIdAttr("UsdPreviewSurface")
    shader.CreateInput("diffuseColor", Sdf.ValueTypeNames.Color3f).Set(Gf.Vec3f(*map(float, rgb)))
    shader.CreateInput("roughness", Sdf.ValueTypeNames.Float).Set(float(roughness))
    shader.CreateInput("metallic", Sdf.ValueTypeNames.Float).Set(0.0)
    material.CreateSurfaceOutput().ConnectToSource(shader.ConnectableAPI(), "surface")
    return material


def _mesh(stage: Usd.Stage, path: str, vertices: np.ndarray, faces: np.ndarray, rgba: tuple,
          material: UsdShade.Material) -> UsdGeom.Mesh:
    mesh = UsdGeom.Mesh.Define(stage, path)
    points = Vt.Vec3fArray.FromNumpy(np.ascontiguousarray(vertices, dtype=np.float32))
    mesh.CreatePointsAttr(points)
    mesh.CreateFaceVertexCountsAttr(Vt.IntArray([faces.shape[1]] * len(faces)))
    mesh.CreateFaceVertexIndicesAttr(Vt.IntArray.FromNumpy(np.ascontiguousarray(faces.ravel(), dtype=np.int32)))
    mesh.CreateExtentAttr(UsdGeom.PointBased.ComputeExtent(points))
    mesh.CreateSubdivisionSchemeAttr(UsdGeom.Tokens.none)  # flat triangles, as rendered
    mesh.CreateDisplayColorPrimvar(UsdGeom.Tokens.constant).Set(Vt.Vec3fArray([Gf.Vec3f(*map(float, rgba[:3]))]))
    if rgba[3] < 1:
        mesh.CreateDisplayOpacityPrimvar(UsdGeom.Tokens.constant).Set(Vt.FloatArray([float(rgba[3])]))
    UsdShade.MaterialBindingAPI.Apply(mesh.GetPrim()).Bind(material)
    return mesh


def _object(stage: Usd.Stage, obj, rec: dict, spec: MaterialSpec) -> None:
    """An Xform at the recorded pose holding the object-frame visual mesh."""
    name = f"obj{obj.object_id}"
    xform = UsdGeom.Xform.Define(stage, f"/World/Objects/{name}")
    pos, (w, x, y, z) = rec["pose"]["pos_world_m"], rec["pose"]["quat_wxyz"]
    xform.AddTranslateOp(UsdGeom.XformOp.PrecisionDouble).Set(Gf.Vec3d(*pos))
    xform.AddOrientOp(UsdGeom.XformOp.PrecisionDouble).Set(Gf.Quatd(w, x, y, z).GetNormalized())
    prim = xform.GetPrim()
    for k in ("category", "name", "color", "material"):
        prim.SetCustomDataByKey(f"refspatial:{k}", rec[k])
    prim.SetCustomDataByKey("refspatial:id", obj.object_id)
    rgba, visual, texture = obj.asset.rgba, obj.asset.visual, obj.asset.texture
    material = _material(stage, name, rgba[:3], _roughness(spec))
    mesh = _mesh(stage, f"/World/Objects/{name}/visual", visual.vertices_m, visual.faces, rgba, material)
    if texture is not None and visual.face_texcoords is not None:
        _texture(stage, material, texture)
        st = UsdGeom.PrimvarsAPI(mesh).CreatePrimvar("st", Sdf.ValueTypeNames.TexCoord2fArray,
                                                     UsdGeom.Tokens.faceVarying)
        st.Set(Vt.Vec2fArray.FromNumpy(np.ascontiguousarray(visual.texcoords, dtype=np.float32)))
        st.SetIndices(Vt.IntArray.FromNumpy(np.ascontiguousarray(visual.face_texcoords.ravel(), dtype=np.int32)))


def texture_file_name(key: str) -> str:
    """A safe, unique file name for a texture key (procedural keys hold '/', image keys are long
    hashes): readable prefix, then a digest of the whole key so two keys never share a file."""
    readable = re.sub(r"[^A-Za-z0-9_.-]", "_", key)[:40]
    return f"{readable}-{hashlib.sha256(key.encode()).hexdigest()[:10]}.png"


def _texture(stage: Usd.Stage, material: UsdShade.Material, texture: Texture) -> None:
    """Feed the material's diffuse colour from a PNG beside the stage (``textures/<key>.png``,
    written once however many objects share it), looked up through the mesh's ``st`` primvar."""
    folder = Path(stage.GetRootLayer().realPath).parent / TEXTURE_DIR
    png = folder / texture_file_name(texture.key)
    if not png.is_file():
        folder.mkdir(exist_ok=True)
        Image.fromarray(texture.rgb).save(png)
    root = material.GetPath()
    reader = UsdShade.Shader.Define(stage, root.AppendChild("StReader"))
    reader.CreateIdAttr("UsdPrimvarReader_float2")
    reader.CreateInput("varname", Sdf.ValueTypeNames.String).Set("st")
    image = UsdShade.Shader.Define(stage, root.AppendChild("BaseColor"))
    image.CreateIdAttr("UsdUVTexture")
    image.CreateInput("file", Sdf.ValueTypeNames.Asset).Set(f"./{TEXTURE_DIR}/{png.name}")
    image.CreateInput("sourceColorSpace", Sdf.ValueTypeNames.Token).Set("sRGB")
    for wrap in ("wrapS", "wrapT"):
        image.CreateInput(wrap, Sdf.ValueTypeNames.Token).Set("repeat")
    image.CreateInput("st", Sdf.ValueTypeNames.Float2).ConnectToSource(reader.ConnectableAPI(), "result")
    rgb = image.CreateOutput("rgb", Sdf.ValueTypeNames.Float3)
    surface = UsdShade.Shader(stage.GetPrimAtPath(root.AppendChild("PreviewSurface")))
    surface.GetInput("diffuseColor").ConnectToSource(rgb)


def _roughness(spec: MaterialSpec) -> float:
    """MuJoCo shininess in [0, 1] read as gloss; UsdPreviewSurface wants roughness."""
    return float(np.clip(1.0 - spec.shininess, 0.05, 1.0))


_BOX_FACES = np.array([[0, 1, 3, 2], [4, 6, 7, 5], [0, 4, 5, 1], [2, 3, 7, 6], [0, 2, 6, 4], [1, 5, 7, 3]])


def _box(half: np.ndarray) -> np.ndarray:
    """The 8 corners of an axis-aligned box centred on the origin (outward quads above)."""
    return np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)]) * half


def _table(stage: Usd.Stage, scene: Scene) -> None:
    """The top and four legs, where mjcf.py puts them (texture left out: a flat colour)."""
    t = scene.table
    material = _material(stage, "table", t.rgba[:3], 0.7)
    half = np.array([t.size_m[0] / 2, t.size_m[1] / 2, TABLE_THICKNESS_M / 2])
    top = _box(half) + [0, 0, t.top_z_m - half[2]]
    _mesh(stage, "/World/Table/top", top, _BOX_FACES, t.rgba, material)
    leg_h = (t.top_z_m - TABLE_THICKNESS_M) / 2
    corners = [(-1, -1), (-1, 1), (1, -1), (1, 1)] if t.surface == "table" else []  # a floor has no legs
    for k, (sx, sy) in enumerate(corners):
        centre = [sx * (half[0] - 0.05), sy * (half[1] - 0.05), leg_h]
        _mesh(stage, f"/World/Table/leg{k}", _box(np.array([0.025, 0.025, leg_h])) + centre, _BOX_FACES,
              t.rgba, material)


def _camera(stage: Usd.Stage, s: dict) -> None:
    """A camera whose projection equals the record's K and T_world_cam."""
    scene, K = s["scene"], s["K"]
    cam = UsdGeom.Camera.Define(stage, f"/World/Cameras/{scene['view']}")
    T = np.array(s["T_world_cam"], dtype=np.float64).copy()
    T[:3, :3] = T[:3, :3] @ CV_TO_GL
    cam.AddTransformOp().Set(Gf.Matrix4d(T.T.tolist()))  # USD matrices act on row vectors
    w, h = scene["width"], scene["height"]
    focal = K[1, 1] * SENSOR_HEIGHT / h
    h_aperture = focal * w / K[0, 0]
    cam.CreateProjectionAttr(UsdGeom.Tokens.perspective)
    cam.CreateFocalLengthAttr(float(focal))
    cam.CreateVerticalApertureAttr(float(SENSOR_HEIGHT))
    cam.CreateHorizontalApertureAttr(float(h_aperture))
    # Offsets move the principal point off the image centre (zero for refspatial's K).
    cam.CreateHorizontalApertureOffsetAttr(float((w / 2 - K[0, 2]) * h_aperture / w))
    cam.CreateVerticalApertureOffsetAttr(float((K[1, 2] - h / 2) * SENSOR_HEIGHT / h))
    cam.CreateClippingRangeAttr(Gf.Vec2f(NEAR_PLANE_M, FAR_PLANE_M))
    prim = cam.GetPrim()
    prim.SetCustomDataByKey("refspatial:key", s["key"])
    prim.SetCustomDataByKey("refspatial:resolution", Gf.Vec2i(w, h))


def check_stage(path: Path) -> list[str]:
    """Problems usd-core's checker reports for a stage file (empty when it is compliant):
    ``UsdUtils.ComplianceChecker`` where usd-core still has it (< 26), else the
    ``UsdValidation`` validators that replaced it (what ``usdchecker`` runs)."""
    from pxr import UsdUtils

    if hasattr(UsdUtils, "ComplianceChecker"):
        checker = UsdUtils.ComplianceChecker()
        checker.CheckCompliance(str(path))
        return list(checker.GetErrors()) + list(checker.GetFailedChecks())
    from pxr import UsdValidation

    validators = UsdValidation.ValidationRegistry().GetOrLoadAllValidators()
    errors = UsdValidation.ValidationContext(validators).Validate(Usd.Stage.Open(str(path)))
    return [e.GetErrorAsString() for e in errors if e.GetType() != UsdValidation.ValidationErrorType.Info]
