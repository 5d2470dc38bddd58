"""The 3-D exports, loaded back with their own libraries: usd-core, pycolmap, open3d."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pytest

from refspatial.data import RefSpatialDataset
from refspatial.export import ExportError, export
from refspatial.export.common import project, valid_depth
from refspatial.recipe import load_recipe
from refspatial.shards import generate

MULTIVIEW = Path(__file__).parent / "data" / "tiny_multiview.yaml"


@pytest.fixture(scope="module")
def multiview_dataset(tmp_path_factory, catalogue):
    """The same folder as test_export.py's fixture: generated once per session."""
    out = tmp_path_factory.getbasetemp() / "export-multiview"
    generate(out, load_recipe(str(MULTIVIEW)), catalogue, n_scenes=4, base_seed=5, workers=1, scenes_per_shard=2)
    return out


def _scenes(root: Path, fields=("rgb", "depth")) -> dict[str, list[dict]]:
    ds = RefSpatialDataset(root, fields=fields)
    out: dict[str, list[dict]] = {}
    for i in range(len(ds)):
        s = ds[i]
        out.setdefault(s["scene"]["scene_id"], []).append(s)
    return out


# --- usd ------------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def usd_out(multiview_dataset, tmp_path_factory):
    out = tmp_path_factory.mktemp("usd") / "out"
    export("usd", multiview_dataset, out)
    return out


def test_usd_stages_pass_the_checker(usd_out, multiview_dataset):
    from pxr import Usd, UsdGeom

    from refspatial.export.usd import check_stage

    scenes = _scenes(multiview_dataset, fields=())
    paths = sorted(usd_out.glob("*.usdc"))
    assert [p.stem for p in paths] == sorted(scenes)
    for path in paths:
        assert check_stage(path) == []
        stage = Usd.Stage.Open(str(path))
        assert UsdGeom.GetStageUpAxis(stage) == UsdGeom.Tokens.z and UsdGeom.GetStageMetersPerUnit(stage) == 1.0
        assert stage.GetDefaultPrim().GetPath() == "/World"


def test_usd_objects_sit_where_the_records_say(usd_out, multiview_dataset):
    from pxr import Usd, UsdGeom, UsdShade

    for scene_id, views in _scenes(multiview_dataset, fields=()).items():
        stage = Usd.Stage.Open(str(usd_out / f"{scene_id}.usdc"))
        for obj in views[0]["scene"]["objects"]:
            mesh = UsdGeom.Mesh(stage.GetPrimAtPath(f"/World/Objects/obj{obj['id']}/visual"))
            M = np.array(mesh.ComputeLocalToWorldTransform(Usd.TimeCode.Default())).T  # column vectors
            points = np.asarray(mesh.GetPointsAttr().Get(), dtype=np.float64) @ M[:3, :3].T + M[:3, 3]
            lo, hi = obj["aabb_world_m"]  # of the rendered mesh at the settled pose
            assert np.allclose(points.min(0), lo, atol=1e-4) and np.allclose(points.max(0), hi, atol=1e-4)
            color = mesh.GetDisplayColorPrimvar().Get()[0]
            assert np.allclose(color, obj["rgba"][:3], atol=1e-6)
            material, _ = UsdShade.MaterialBindingAPI(mesh.GetPrim()).ComputeBoundMaterial()
            shader = material.ComputeSurfaceSource()[0]
            assert shader.GetIdAttr().Get() == "UsdPreviewSurface"
        assert stage.GetPrimAtPath("/World/Table/top").IsValid()


def _usd_pixels(camera_prim, points: np.ndarray, width: int, height: int) -> np.ndarray:
    from pxr import Gf, Usd, UsdGeom

    frustum = UsdGeom.Camera(camera_prim).GetCamera(Usd.TimeCode.Default()).frustum
    view, proj = frustum.ComputeViewMatrix(), frustum.ComputeProjectionMatrix()
    ndc = np.array([proj.Transform(view.Transform(Gf.Vec3d(*p))) for p in points])
    return np.stack([(ndc[:, 0] + 1) / 2 * width, (1 - ndc[:, 1]) / 2 * height], axis=1)


def test_usd_cameras_project_like_the_records(usd_out, multiview_dataset):
    from pxr import Usd

    for scene_id, views in _scenes(multiview_dataset, fields=()).items():
        stage = Usd.Stage.Open(str(usd_out / f"{scene_id}.usdc"))
        for s in views:
            points = np.array([o["box_world"]["center_m"] for o in s["scene"]["objects"]])
            want, _ = project(points, s["K"], s["T_world_cam"])
            prim = stage.GetPrimAtPath(f"/World/Cameras/{s['scene']['view']}")
            got = _usd_pixels(prim, points, s["scene"]["width"], s["scene"]["height"])
            assert np.abs(got - want).max() < 1e-3


def test_usd_camera_with_an_off_centre_principal_point(tmp_path):
    from pxr import Usd

    from refspatial.export.usd import _camera

    K = np.array([[150.0, 0, 70.0], [0, 150.0, 40.0], [0, 0, 1]])
    T = np.eye(4)
    T[:3, :3] = np.array([[1, 0, 0], [0, 0, -1], [0, 1, 0]])  # looking along world +y
    stage = Usd.Stage.CreateInMemory()
    sample = {"key": "x/view0", "scene": {"view": "view0", "width": 160, "height": 90}, "K": K, "T_world_cam": T}
    _camera(stage, sample)
    points = np.array([[0.1, 2.0, 0.05], [-0.3, 1.0, -0.2], [0.0, 3.0, 0.0]])
    want, _ = project(points, K, T)
    got = _usd_pixels(stage.GetPrimAtPath("/World/Cameras/view0"), points, 160, 90)
    assert np.abs(got - want).max() < 1e-3


def test_usd_refuses_a_recipe_or_catalogue_that_changed(multiview_dataset, tmp_path):
    for key, value, message in (("recipe_resolved_yaml", None, "recipe text"),
                                ("catalogue_sha256", "0" * 64, "catalogue")):
        copy = tmp_path / key
        shutil.copytree(multiview_dataset, copy)
        manifest = json.loads((copy / "manifest.json").read_text())
        changed = manifest[key].replace("per_view: 8", "per_view: 7") if not value else value
        assert changed != manifest[key]
        manifest[key] = changed
        (copy / "manifest.json").write_text(json.dumps(manifest))
        with pytest.raises(ExportError, match=message):
            export("usd", copy, tmp_path / f"out-{key}")
        assert not (tmp_path / f"out-{key}").exists()


# --- colmap ---------------------------------------------------------------------------------


def test_colmap_reconstructions_reproject_within_a_pixel(multiview_dataset, tmp_path):
    pycolmap = pytest.importorskip("pycolmap")
    summary = export("colmap", multiview_dataset, tmp_path / "colmap", stride=4)
    scenes = _scenes(multiview_dataset)
    tracks = []
    for scene_id, views in scenes.items():
        root = tmp_path / "colmap" / scene_id
        rec = pycolmap.Reconstruction(str(root / "sparse" / "0"))
        assert rec.num_images() == len(views) == 2
        for s in views:
            image = rec.find_image_with_name(f"{s['scene']['view']}.png")
            assert (root / "images" / image.name).is_file()
            K = s["K"]
            assert image.camera.model.name == "PINHOLE"
            assert np.allclose(image.camera.params, [K[0, 0], K[1, 1], K[0, 2], K[1, 2]])
            assert np.allclose(image.cam_from_world().matrix(), np.linalg.inv(s["T_world_cam"])[:3], atol=1e-9)
        for point in rec.points3D.values():
            for el in point.track.elements:
                image = rec.image(el.image_id)
                error = np.linalg.norm(image.project_point(point.xyz) - image.points2D[el.point2D_idx].xy)
                assert error < 1.0
            tracks.append(point.track.length())
    assert sum(tracks) == summary.counts["observations"] and len(tracks) == summary.counts["points3D"]
    assert np.mean(tracks) > 1.1  # views agree: many points are seen, unoccluded, by both


def test_colmap_text_output_loads(multiview_dataset, tmp_path):
    pycolmap = pytest.importorskip("pycolmap")
    export("colmap", multiview_dataset, tmp_path / "txt", stride=8, text=True)
    folder = min(p for p in (tmp_path / "txt").iterdir() if p.is_dir()) / "sparse" / "0"
    assert (folder / "cameras.txt").is_file()
    assert pycolmap.Reconstruction(str(folder)).num_points3D() > 0


# --- point clouds -------------------------------------------------------------------------


def test_pointclouds_back_project_every_surface_pixel(multiview_dataset, tmp_path):
    o3d = pytest.importorskip("open3d")
    export("pointcloud", multiview_dataset, tmp_path / "pc")
    export("pointcloud", multiview_dataset, tmp_path / "objects", objects_only=True, voxel_size_m=0.005)
    ds = RefSpatialDataset(multiview_dataset, fields=("rgb", "depth", "seg"))
    for i in range(len(ds)):
        s = ds[i]
        name = Path(s["scene"]["scene_id"]) / f"{s['scene']['view']}.ply"
        cloud = o3d.io.read_point_cloud(str(tmp_path / "pc" / name))
        valid = valid_depth(s["depth_m"])
        assert len(cloud.points) == valid.sum()
        uv, z = project(np.asarray(cloud.points), s["K"], s["T_world_cam"])
        cols, rows = np.floor(uv).astype(int).T
        assert np.allclose(uv - np.floor(uv), 0.5, atol=1e-4)  # pixel centres
        assert valid[rows, cols].all() and np.allclose(z, s["depth_m"][rows, cols], atol=1e-5)
        assert np.allclose(np.asarray(cloud.colors) * 255, s["rgb"][rows, cols], atol=0.5)
        small = o3d.io.read_point_cloud(str(tmp_path / "objects" / name))
        assert 0 < len(small.points) <= (valid & (s["seg"] >= 0)).sum()


def test_pointcloud_keeps_sky_on_request(multiview_dataset, tmp_path):
    o3d = pytest.importorskip("open3d")
    summary = export("pointcloud", multiview_dataset, tmp_path / "all", keep_background=True)
    ds = RefSpatialDataset(multiview_dataset, fields=("depth",))
    assert summary.counts["points"] == sum(ds[i]["depth_m"].size for i in range(len(ds)))
    first = min((tmp_path / "all").rglob("*.ply"))
    assert len(o3d.io.read_point_cloud(str(first)).points) > 0
