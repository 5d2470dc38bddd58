"""Tests for refspatial.mesh_import and `builder: mesh` catalogue entries: a mug-like mesh the
test makes itself, written as OBJ, GLB, STL and USD in a file frame that is not the object
frame (y up, handle along +z, millimetres), imported, checked and used like a procedural asset."""

from __future__ import annotations

import math
import shutil
import sys
from pathlib import Path

import numpy as np
import pytest
import trimesh
import yaml

import refspatial  # noqa: F401  (sets MUJOCO_GL before mujoco is imported)
import mujoco  # noqa: E402
from refspatial import mesh_import  # noqa: E402
from refspatial.assets import CatalogueError, build_asset, load_catalogue  # noqa: E402
from refspatial.mesh_import import MeshImportError, import_mesh, load_annotation, read_mesh  # noqa: E402
from refspatial.paths import assets_dir  # noqa: E402

HEIGHT_MM, RADIUS_MM, WALL_MM, BASE_MM = 95.0, 40.0, 5.0, 8.0
FAST_COACD = {  # cheap settings: a coarse mug decomposes in about a second
    "method": "coacd",
    "threshold": 0.15,
    "preprocess_resolution": 20,
    "resolution": 500,
    "mcts_iterations": 30,
    "mcts_nodes": 10,
    "mcts_max_depth": 2,
    "max_convex_hull": 12,
}
NOTE = {
    "category": "mug",
    "name": "mug",
    "plural": "mugs",
    "color": "white",
    "up": "+y",
    "front": [0, 0, 1],
    "front_side": "handle",
    "scale": 0.001,
    "licence": "CC-BY-4.0",
    "source": "https://example.org/test-mug",
    "collision": FAST_COACD,
}


def _mug_mm() -> trimesh.Trimesh:
    """A coarse mug in millimetres, z up, handle on +x (the object frame, before the file's axes)."""
    outer = trimesh.creation.cylinder(radius=RADIUS_MM, segment=[(0, 0, 0), (0, 0, HEIGHT_MM)], sections=20)
    inner = trimesh.creation.cylinder(
        radius=RADIUS_MM - WALL_MM, segment=[(0, 0, BASE_MM), (0, 0, 2 * HEIGHT_MM)], sections=20
    )
    handle = trimesh.creation.torus(22.0, 5.0, major_sections=14, minor_sections=8)
    handle.apply_transform(trimesh.transformations.rotation_matrix(math.pi / 2, (1, 0, 0)))
    handle.apply_translation((RADIUS_MM + 8.0, 0, HEIGHT_MM / 2))
    body = trimesh.boolean.difference([outer, inner], engine="manifold")
    return trimesh.boolean.union([body, handle], engine="manifold")


def _file_frame(mesh: trimesh.Trimesh) -> trimesh.Trimesh:
    """Object frame -> file frame: up becomes +y and the handle (+x) becomes +z."""
    out = mesh.copy()
    R = np.array([[0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [1.0, 0.0, 0.0]])  # rows: file axes in object coordinates
    out.vertices = mesh.vertices @ R.T
    return out


def _write_usd(mesh: trimesh.Trimesh, path: Path) -> None:
    """The mesh under a translated Xform, so the reader must apply the prim's transform."""
    from pxr import Gf, Usd, UsdGeom, Vt

    stage = Usd.Stage.CreateNew(str(path))
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.y)
    xform = UsdGeom.Xform.Define(stage, "/Mug")
    xform.AddTranslateOp().Set(Gf.Vec3d(100.0, -20.0, 7.0))
    prim = UsdGeom.Mesh.Define(stage, "/Mug/Geom")
    prim.CreatePointsAttr(Vt.Vec3fArray([Gf.Vec3f(*map(float, p)) for p in mesh.vertices]))
    prim.CreateFaceVertexCountsAttr(Vt.IntArray([3] * len(mesh.faces)))
    prim.CreateFaceVertexIndicesAttr(Vt.IntArray([int(i) for i in mesh.faces.ravel()]))
    stage.GetRootLayer().Save()


@pytest.fixture(scope="module")
def mesh_files(tmp_path_factory) -> dict[str, Path]:
    """The same mug as OBJ, GLB, STL and USDA, each with its annotation beside it."""
    folder = tmp_path_factory.mktemp("meshes")
    mesh = _file_frame(_mug_mm())
    files = {}
    for suffix in ("obj", "glb", "stl"):
        files[suffix] = folder / f"mug_{suffix}.{suffix}"
        mesh.export(files[suffix])
    files["usda"] = folder / "mug_usda.usda"
    _write_usd(mesh, files["usda"])
    for path in files.values():
        path.with_suffix(".yaml").write_text(yaml.safe_dump(NOTE, sort_keys=False))
    return files


@pytest.fixture(scope="module")
def cache(tmp_path_factory) -> Path:
    return tmp_path_factory.mktemp("coacd-cache")


@pytest.fixture(scope="module")
def imported(mesh_files, cache) -> dict[str, mesh_import.ImportedMesh]:
    pytest.importorskip("coacd")
    return {fmt: import_mesh(path, cache_dir=cache) for fmt, path in mesh_files.items()}


# ---------------------------------------------------------------- import


@pytest.mark.parametrize("fmt", ["obj", "glb", "stl", "usda"])
def test_import_puts_the_mesh_in_the_object_frame_in_metres(imported, fmt: str) -> None:
    result = imported[fmt]
    v = result.visual.vertices_m
    lo, hi = v.min(axis=0), v.max(axis=0)
    assert abs(lo[2]) < 1e-9 and np.allclose((lo + hi)[:2] / 2, 0, atol=1e-9)  # footprint centred, on z=0
    assert hi[2] - lo[2] == pytest.approx(HEIGHT_MM / 1000, abs=1e-5)  # millimetres scaled to metres
    assert hi[1] - lo[1] == pytest.approx(2 * RADIUS_MM / 1000, rel=0.02)
    base = v[v[:, 2] < 1e-6]
    assert base[:, 0].mean() < -0.005  # the body sits on -x: the handle (the front) is on +x
    assert v[:, 0].max() > RADIUS_MM / 1000  # and sticks out there
    assert result.decomposition == "coacd" and result.annotation.front_side == "handle"
    assert result.annotation.licence_text == "CC-BY-4.0; source: https://example.org/test-mug"


@pytest.mark.parametrize("fmt", ["obj", "glb", "stl", "usda"])
def test_import_gives_convex_parts_that_cover_the_mesh_and_compile(imported, fmt: str) -> None:
    result = imported[fmt]
    assert len(result.parts) >= 3  # a hollow mug needs several
    for part in result.parts:
        mesh = trimesh.Trimesh(part.vertices_m, part.faces, process=False)
        assert mesh.is_convex and mesh.volume > 0
        assert part.faces.dtype == np.int32 and part.vertices_m.dtype == np.float64
    allv = np.vstack([p.vertices_m for p in result.parts])
    assert np.allclose(allv.min(axis=0), result.visual.bounds_m[0], atol=0.004)
    assert np.allclose(allv.max(axis=0), result.visual.bounds_m[1], atol=0.004)
    spec = mujoco.MjSpec()
    body = spec.worldbody.add_body(name="mug")
    body.add_freejoint()
    for k, mesh in enumerate((result.visual, *result.parts)):
        spec.add_mesh(name=f"m{k}", uservert=mesh.vertices_m.ravel(), userface=mesh.faces.ravel())
        body.add_geom(type=mujoco.mjtGeom.mjGEOM_MESH, meshname=f"m{k}", density=0 if k == 0 else 500)
    assert spec.compile().nmesh == 1 + len(result.parts)


def test_formats_agree(imported) -> None:
    reference = imported["obj"].visual.bounds_m
    for fmt in ("glb", "stl", "usda"):
        assert np.allclose(imported[fmt].visual.bounds_m, reference, atol=1e-5), fmt


def test_the_decomposition_is_cached_and_the_cache_is_hit(mesh_files, cache, imported, monkeypatch) -> None:
    import coacd

    assert len(list(cache.glob("*.npz"))) == 4  # one entry per distinct normalised mesh

    def refuse(*args, **kwargs):
        raise AssertionError("CoACD ran although the decomposition was cached")

    monkeypatch.setattr(coacd, "run_coacd", refuse)
    again = import_mesh(mesh_files["glb"], cache_dir=cache)
    first = imported["glb"]
    assert len(again.parts) == len(first.parts)
    assert all(np.array_equal(a.vertices_m, b.vertices_m) for a, b in zip(again.parts, first.parts))


def test_a_different_setting_is_a_different_cache_entry(mesh_files, cache, imported, tmp_path) -> None:
    note = dict(NOTE, collision=dict(FAST_COACD, max_convex_hull=4))
    folder = tmp_path / "other"
    folder.mkdir()
    shutil.copy(mesh_files["obj"], folder / "mug.obj")
    (folder / "mug.yaml").write_text(yaml.safe_dump(note))
    result = import_mesh(folder / "mug.obj", cache_dir=cache)
    assert len(result.parts) <= 4 and len(list(cache.glob("*.npz"))) == 5


def test_the_imported_mug_stays_hollow_in_physics(imported) -> None:
    """A ball dropped into the imported mug comes to rest on its inner floor, not on a hull."""
    result = imported["obj"]
    spec = mujoco.MjSpec()
    spec.worldbody.add_geom(type=mujoco.mjtGeom.mjGEOM_PLANE, size=[1, 1, 0.1])
    body = spec.worldbody.add_body(name="mug")
    for k, part in enumerate(result.parts):
        spec.add_mesh(name=f"p{k}", uservert=part.vertices_m.ravel(), userface=part.faces.ravel())
        body.add_geom(type=mujoco.mjtGeom.mjGEOM_MESH, meshname=f"p{k}")
    base = result.visual.vertices_m[result.visual.vertices_m[:, 2] < 1e-6]
    axis_x = (base[:, 0].min() + base[:, 0].max()) / 2
    ball = spec.worldbody.add_body(name="ball", pos=[axis_x, 0, 0.12])
    ball.add_freejoint()
    ball.add_geom(type=mujoco.mjtGeom.mjGEOM_SPHERE, size=[0.012, 0, 0], density=500)
    model = spec.compile()
    data = mujoco.MjData(model)
    while data.time < 1.0:
        mujoco.mj_step(model, data)
    z = data.xpos[model.body("ball").id][2]
    assert z < (BASE_MM + 12.0 + 6.0) / 1000, z  # on (or within a few mm of) the floor, well below the rim


def test_without_coacd_one_hull_and_a_warning(mesh_files, tmp_path, monkeypatch) -> None:
    monkeypatch.setitem(sys.modules, "coacd", None)  # import coacd now raises ImportError
    with pytest.warns(UserWarning, match="coacd is not installed.*one convex hull.*pip install"):
        result = import_mesh(mesh_files["stl"], cache_dir=tmp_path)
    assert result.decomposition == "hull-fallback" and len(result.parts) == 1
    assert not list(tmp_path.glob("*.npz"))


def test_collision_hull_on_request(mesh_files, tmp_path) -> None:
    folder = tmp_path / "hull"
    folder.mkdir()
    shutil.copy(mesh_files["stl"], folder / "mug.stl")
    (folder / "mug.yaml").write_text(yaml.safe_dump(dict(NOTE, collision={"method": "hull"})))
    result = import_mesh(folder / "mug.stl", cache_dir=tmp_path)
    assert result.decomposition == "hull" and len(result.parts) == 1
    # The README's short form, `collision: hull`, means the same in a YAML note (and in JSON lines).
    (folder / "mug.yaml").write_text(yaml.safe_dump(dict(NOTE, collision="hull")))
    result = import_mesh(folder / "mug.stl", cache_dir=tmp_path)
    assert result.decomposition == "hull" and len(result.parts) == 1


def test_size_m_scales_the_longest_extent(mesh_files, tmp_path) -> None:
    note = {k: v for k, v in NOTE.items() if k != "scale"} | {"size_m": 0.2, "collision": {"method": "hull"}}
    (tmp_path / "big.yaml").write_text(yaml.safe_dump(note))
    result = import_mesh(mesh_files["obj"], tmp_path / "big.yaml", cache_dir=tmp_path)
    assert np.ptp(result.visual.vertices_m, axis=0).max() == pytest.approx(0.2)


def test_usd_reader_applies_the_prims_transform(mesh_files) -> None:
    vertices, faces = read_mesh(mesh_files["usda"])
    raw = _file_frame(_mug_mm())
    assert len(faces) == len(raw.faces)
    assert np.allclose(vertices.min(axis=0), raw.vertices.min(axis=0) + (100.0, -20.0, 7.0), atol=1e-4)


def test_usd_polygons_are_fan_triangulated(tmp_path) -> None:
    """A quad-faced cube in USD reads as a closed box of 12 triangles."""
    from pxr import Gf, Usd, UsdGeom, Vt

    cube = trimesh.creation.box(extents=(2.0, 3.0, 4.0))
    quads = [[0, 1, 3, 2], [4, 6, 7, 5], [0, 4, 5, 1], [2, 3, 7, 6], [0, 2, 6, 4], [1, 5, 7, 3]]
    stage = Usd.Stage.CreateNew(str(tmp_path / "cube.usda"))
    prim = UsdGeom.Mesh.Define(stage, "/Cube")
    prim.CreatePointsAttr(Vt.Vec3fArray([Gf.Vec3f(*map(float, p)) for p in cube.vertices]))
    prim.CreateFaceVertexCountsAttr(Vt.IntArray([4] * 6))
    prim.CreateFaceVertexIndicesAttr(Vt.IntArray([i for q in quads for i in q]))
    stage.GetRootLayer().Save()
    vertices, faces = read_mesh(tmp_path / "cube.usda")
    mesh = trimesh.Trimesh(vertices, faces)
    assert len(faces) == 12 and mesh.is_watertight and abs(mesh.volume) == pytest.approx(24.0)


# ---------------------------------------------------------------- annotations


@pytest.mark.parametrize(
    "change, pattern",
    [
        ({"licence": None}, r"missing key 'licence'"),
        ({"size_m": 0.1}, r"exactly one of scale .* or size_m"),
        ({"up": "sideways"}, r"up: expected one of \+x"),
        ({"front": [0, 1, 0]}, r"front .* parallel to up"),
        ({"front": [0, 0]}, r"front: expected a non-zero vector"),
        ({"scale": -1}, r"scale: expected a positive number"),
        ({"colour": "red"}, r"colour: unknown key"),
        ({"collision": {"method": "vhacd"}}, r"collision\.method: expected coacd or hull"),
        ({"collision": {"thresh": 0.1}}, r"collision\.thresh: unknown CoACD setting"),
    ],
)
def test_bad_annotations_name_the_file_and_key(mesh_files, tmp_path, change: dict, pattern: str) -> None:
    note = {k: v for k, v in (NOTE | change).items() if v is not None}
    path = tmp_path / "note.yaml"
    path.write_text(yaml.safe_dump(note))
    with pytest.raises(MeshImportError, match=pattern) as info:
        import_mesh(mesh_files["obj"], path, cache_dir=tmp_path)
    assert str(path) in str(info.value) and "\n" not in str(info.value)


def test_unknown_format_and_missing_file(tmp_path) -> None:
    (tmp_path / "thing.fbx").write_bytes(b"")
    with pytest.raises(MeshImportError, match=r"unsupported mesh format '\.fbx'; convert it to one of"):
        read_mesh(tmp_path / "thing.fbx")
    with pytest.raises(MeshImportError, match="cannot read the annotation"):
        load_annotation(tmp_path / "nothing.yaml")


# ---------------------------------------------------------------- catalogue entries


def _catalogue_with_mesh(folder: Path, mesh_file: Path, entry: dict) -> Path:
    doc = yaml.safe_load((assets_dir() / "catalogue.yaml").read_text())
    (folder / "meshes").mkdir(exist_ok=True)
    shutil.copy(mesh_file, folder / "meshes" / mesh_file.name)
    shutil.copy(mesh_file.with_suffix(".yaml"), folder / "meshes" / mesh_file.with_suffix(".yaml").name)
    doc["categories"]["my_mug"] = {"builder": "mesh", "mesh": f"meshes/{mesh_file.name}", **entry}
    path = folder / "catalogue.yaml"
    path.write_text(yaml.safe_dump(doc, sort_keys=False))
    return path


def test_a_mesh_category_builds_like_a_procedural_one(mesh_files, cache, imported, tmp_path) -> None:
    entry = {
        "group": "dining",
        "materials": ["ceramic"],
        "params": {"scale": [0.9, 1.1]},
        "support": False,
        "cavity": {"shape": "cylinder", "radius": "0.03*scale", "floor_z": "0.009*scale", "rim_z": "0.095*scale"},
    }
    path = _catalogue_with_mesh(tmp_path, mesh_files["glb"], entry)
    catalogue = load_catalogue(path, cache_dir=cache)
    spec = catalogue.categories["my_mug"]
    assert (spec.name, spec.plural, spec.colors, spec.front_side, spec.group) == (
        "mug",
        "mugs",
        ("white",),
        "handle",
        "dining",
    )
    asset = build_asset(catalogue, "my_mug", np.random.default_rng(3))
    again = build_asset(catalogue, "my_mug", np.random.default_rng(3))
    k = asset.params["scale"]
    assert 0.9 <= k <= 1.1 and np.array_equal(asset.visual.vertices_m, again.visual.vertices_m)
    assert asset.size_m[2] == pytest.approx(k * HEIGHT_MM / 1000, abs=1e-5)
    assert asset.licence == "CC-BY-4.0; source: https://example.org/test-mug"
    assert asset.cavity is not None and asset.cavity.rim_z_m == pytest.approx(0.095 * k)
    assert len(asset.collision) == len(imported["glb"].parts) and asset.front_local == (1.0, 0.0, 0.0)
    shipped = load_catalogue()
    assert catalogue.sha256 != shipped.sha256 and set(shipped.categories) < set(catalogue.categories)


def test_a_changed_mesh_changes_the_catalogue_hash(mesh_files, cache, tmp_path) -> None:
    path = _catalogue_with_mesh(tmp_path, mesh_files["obj"], {"group": "dining", "materials": ["ceramic"]})
    first = load_catalogue(path, cache_dir=cache).sha256
    mesh_path = tmp_path / "meshes" / mesh_files["obj"].name
    mesh_path.write_text(mesh_path.read_text() + "\n# touched\n")
    assert load_catalogue(path, cache_dir=cache).sha256 != first


def test_a_mesh_entry_with_a_bad_annotation_fails_at_load(mesh_files, cache, tmp_path) -> None:
    path = _catalogue_with_mesh(tmp_path, mesh_files["obj"], {"group": "dining", "materials": ["ceramic"]})
    note_path = tmp_path / "meshes" / mesh_files["obj"].with_suffix(".yaml").name
    note_path.write_text(yaml.safe_dump(dict(NOTE, color="teal")))
    with pytest.raises(CatalogueError, match=r"categories\.my_mug .*color.*got 'teal'") as info:
        load_catalogue(path, cache_dir=cache)
    assert "\n" not in str(info.value)
