"""USD export of a textured imported mesh: a UsdPreviewSurface whose diffuse colour comes from a
UsdUVTexture reading a PNG beside the stage, looked up through a faceVarying ``st`` primvar."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from PIL import Image
from pxr import Usd, UsdGeom, UsdShade

from refspatial.export.usd import check_stage, write_stage
from refspatial.mesh_import import import_mesh
from refspatial.recipe import load_recipe
from refspatial.room import sample_room
from refspatial.scene import Asset, Camera, Light, PlacedObject, Pose, Scene, Table
from textured import BOX_NOTE, write_textured


def _one_object_scene(asset: Asset) -> tuple[Scene, list[dict]]:
    camera = Camera("view0", (0.0, -1.0, 1.0), (0.92, 0.38, 0.0, 0.0), 45.0, 64, 48)
    table = Table((1.0, 1.0), 0.7, (0.5, 0.5, 0.5, 1.0), "flat")
    room = sample_room(load_recipe("tabletop"), table, np.random.default_rng(0))
    scene = Scene("t", "0" * 64, 1, table, (PlacedObject(0, asset, Pose((0.1, 0.0, 0.7), (1.0, 0.0, 0.0, 0.0))),),
                  (camera,), (Light((0.0, 0.0, -1.0), 1.0),), room)
    obj = {"category": asset.category, "name": asset.name, "color": asset.color, "material": asset.material,
           "pose": {"pos_world_m": [0.1, 0.0, 0.7], "quat_wxyz": [1.0, 0.0, 0.0, 0.0]}}
    recorded = {"scene_id": "t-1", "recipe_hash": "0" * 64, "seed": 1, "objects": [obj], "view": "view0",
                "width": 64, "height": 48}
    return scene, [{"scene": recorded, "K": camera.intrinsics(), "T_world_cam": camera.T_world_cam(), "key": "t-1/view0"}]


def test_the_texture_and_its_coordinates_reach_the_stage(tmp_path: Path) -> None:
    imported = import_mesh(write_textured(tmp_path / "src" / "box.glb", BOX_NOTE), cache_dir=tmp_path)
    asset = Asset("box", "box", "red", (0.8, 0.1, 0.1, 1.0), "matte", imported.visual, imported.parts,
                  (1.0, 0.0, 0.0), "label", texture=imported.texture)
    scene, views = _one_object_scene(asset)
    from refspatial.assets import load_catalogue

    out = tmp_path / "out" / "t-1.usda"
    out.parent.mkdir()
    write_stage(out, scene, views, load_catalogue().materials)

    assert check_stage(out) == []
    stage = Usd.Stage.Open(str(out))
    mesh = UsdGeom.Mesh(stage.GetPrimAtPath("/World/Objects/obj0/visual"))
    st = UsdGeom.PrimvarsAPI(mesh).GetPrimvar("st")
    assert st.GetInterpolation() == UsdGeom.Tokens.faceVarying
    values = np.asarray(st.ComputeFlattened())  # one uv per face corner, in face order
    expected = imported.visual.texcoords[imported.visual.face_texcoords].reshape(-1, 2)
    assert values.shape == expected.shape and np.allclose(values, expected)

    material, _ = UsdShade.MaterialBindingAPI(mesh.GetPrim()).ComputeBoundMaterial()
    surface = material.ComputeSurfaceSource()[0]
    source = surface.GetInput("diffuseColor").GetConnectedSources()[0][0].source
    texture = UsdShade.Shader(source.GetPrim())
    assert texture.GetIdAttr().Get() == "UsdUVTexture"
    asset_path = texture.GetInput("file").Get()
    png = Path(asset_path.resolvedPath or out.parent / asset_path.path)
    assert png.parent == out.parent / "textures" and png.is_file()
    assert np.array_equal(np.asarray(Image.open(png).convert("RGB")), imported.texture.rgb)
    reader = texture.GetInput("st").GetConnectedSources()[0][0].source
    assert UsdShade.Shader(reader.GetPrim()).GetInput("varname").Get() == "st"


def test_untextured_objects_get_no_texture(tmp_path: Path) -> None:
    import trimesh
    import yaml

    trimesh.creation.box((30, 30, 30)).export(tmp_path / "plain.obj")
    (tmp_path / "plain.yaml").write_text(yaml.safe_dump(BOX_NOTE))
    imported = import_mesh(tmp_path / "plain.obj", cache_dir=tmp_path)
    asset = Asset("box", "box", "red", (0.8, 0.1, 0.1, 1.0), "matte", imported.visual, imported.parts,
                  (1.0, 0.0, 0.0), "label")
    scene, views = _one_object_scene(asset)
    from refspatial.assets import load_catalogue

    write_stage(tmp_path / "t.usda", scene, views, load_catalogue().materials)
    stage = Usd.Stage.Open(str(tmp_path / "t.usda"))
    assert not UsdGeom.PrimvarsAPI(stage.GetPrimAtPath("/World/Objects/obj0/visual")).HasPrimvar("st")
    assert not (tmp_path / "textures").exists()
