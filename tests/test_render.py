"""Camera framing and the renderer's arrays: shapes, units, and agreement with geometry."""

import numpy as np
import pytest

from refspatial.camera import _object_corners, project
from refspatial.render import PHASES, gl_info, render_views

from helpers import rendered_scenes


@pytest.fixture(scope="module")
def rendered(tiny, catalogue):
    scene, views = rendered_scenes(tiny, catalogue, 1, seeds=20)[0]
    return scene, views[0]


def test_camera_follows_the_recipe(rendered, tiny):
    scene, view = rendered
    cam, spec = view.camera, tiny["camera"]
    T = cam.T_world_cam()
    height = T[2, 3] - scene.table.top_z_m
    lo, hi = spec["height_above_table_m"]
    assert lo - 1e-6 <= height <= hi + 1e-6
    pitch = np.degrees(np.arcsin(T[2, 2]))  # OpenCV +z is the viewing direction
    assert spec["pitch_deg"][0] - 1e-6 <= pitch <= spec["pitch_deg"][1] + 1e-6
    uv, z = project(_object_corners(scene), cam)
    m = spec["margin_px"]
    assert np.all(z > 0) and np.all(uv >= m - 1e-6)
    assert np.all(uv <= [cam.width - m + 1e-6, cam.height - m + 1e-6])


def test_the_compiled_framing_test_is_numpys():
    """The camera bisection's test of projected corners (compiled) against the numpy reductions it
    replaced, on points inside, on and just past every margin, behind the camera and not finite."""
    from refspatial.compiled import in_frame

    rng = np.random.default_rng(3)
    w, h, m, near = 960, 540, 12, 0.05
    edges = np.array([m, w - m, h - m, np.nextafter(m, 0), np.nextafter(w - m, 2 * w), np.nextafter(h - m, 2 * h)])
    seen = set()
    for _ in range(3000):
        n = int(rng.integers(1, 9))
        uv = np.c_[rng.uniform(m, w - m, n), rng.uniform(m, h - m, n)]
        z = rng.uniform(near, 3.0, n)
        for _ in range(int(rng.integers(0, 3))):
            k, axis = int(rng.integers(n)), int(rng.integers(2))
            uv[k, axis] = rng.choice(np.r_[edges, np.nan, -1.0, 2e3])
        if rng.random() < 0.2:
            z[int(rng.integers(n))] = rng.choice([near, np.nextafter(near, 1), 0.0, -1.0, np.nan])
        want = bool(np.all(z > near) and np.all(uv >= m) and np.all(uv[:, 0] <= w - m) and np.all(uv[:, 1] <= h - m))
        assert in_frame(uv, z, near, m, w, h) is want
        seen.add(want)
    assert seen == {True, False}


def test_arrays_have_documented_types(rendered, tiny):
    _, view = rendered
    h, w = tiny["camera"]["height"], tiny["camera"]["width"]
    assert view.rgb.shape == (h, w, 3) and view.rgb.dtype == np.uint8
    assert view.depth_m.shape == (h, w) and view.depth_m.dtype == np.float32
    assert view.seg.shape == (h, w) and view.seg.dtype == np.int32
    assert view.rgb.std() > 5  # a real picture, not a blank buffer


def test_segmentation_ids_are_the_scene_objects(rendered):
    scene, view = rendered
    ids = set(np.unique(view.seg)) - {-1}
    assert ids and ids <= {o.object_id for o in scene.objects}


def test_depth_backprojects_onto_the_object_it_labels(rendered):
    """Pixels labelled object k, lifted to 3-D with depth and K, land inside k's world box."""
    scene, view = rendered
    K, T = view.K, view.T_world_cam
    rows, cols = np.nonzero(view.seg >= 0)
    z = view.depth_m[rows, cols]
    rays = np.linalg.inv(K) @ np.stack([cols + 0.5, rows + 0.5, np.ones_like(z)])
    world = (T[:3, :3] @ (rays * z) + T[:3, 3:4]).T
    for obj in scene.objects:
        sel = view.seg[rows, cols] == obj.object_id
        if not sel.any():
            continue
        verts = obj.asset.visual.vertices_m @ obj.pose.matrix()[:3, :3].T + obj.pose.pos_world_m
        lo, hi = verts.min(0) - 0.01, verts.max(0) + 0.01
        inside = np.all((world[sel] >= lo) & (world[sel] <= hi), axis=1)
        assert inside.mean() > 0.97, f"object {obj.object_id}: {inside.mean():.2%} of its pixels inside its box"


def test_table_depth_matches_ray_plane_intersection(rendered):
    scene, view = rendered
    K, T = view.K, view.T_world_cam
    rows, cols = np.nonzero(view.seg == -1)
    rays_cam = np.linalg.inv(K) @ np.stack([cols + 0.5, rows + 0.5, np.ones(len(rows))])
    rays_world = T[:3, :3] @ rays_cam
    # depth along the optical axis at which each ray meets the table top plane
    t = (scene.table.top_z_m - T[2, 3]) / rays_world[2]
    hit = T[:3, 3:4] + rays_world * t
    on_table = (t > 0) & np.all(np.abs(hit[:2].T) < np.array(scene.table.size_m) / 2 - 0.05, axis=1)
    assert on_table.sum() > 100
    err = np.abs(view.depth_m[rows[on_table], cols[on_table]] - t[on_table])
    assert np.median(err) < 0.002


def test_matches_mujocos_own_renderer(rendered, catalogue):
    """The two-pass renderer gives MuJoCo Renderer's pixels, depth and segmentation (the room's
    geoms kept out of the shadow map in both, as render.py does)."""
    import mujoco

    from refspatial.render import room_casts_no_shadow

    from refspatial.mjcf import COLLISION_GROUP, SpecOptions, build_spec, object_of_geom

    scene, view = rendered
    cam = view.camera
    model = build_spec(scene, catalogue.materials, SpecOptions(dynamic=False, offscreen=(cam.width, cam.height))).compile()
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    option = mujoco.MjvOption()
    option.geomgroup[COLLISION_GROUP] = 0
    lookup = object_of_geom(model, len(scene.objects))
    with mujoco.Renderer(model, cam.height, cam.width) as r:
        r.update_scene(data, camera=cam.name, scene_option=option)
        room_casts_no_shadow(model, r.scene)
        rgb = r.render()
        r.enable_depth_rendering()
        r.update_scene(data, camera=cam.name, scene_option=option)
        depth = r.render()
        r.enable_segmentation_rendering()
        r.update_scene(data, camera=cam.name, scene_option=option)
        ids = r.render()
    seg = np.where(ids[..., 1] == int(mujoco.mjtObj.mjOBJ_GEOM), lookup[np.clip(ids[..., 0], 0, len(lookup) - 1)], -1)
    assert np.array_equal(rgb, view.rgb)
    assert np.allclose(depth, view.depth_m, rtol=1e-4, atol=1e-5)  # float32 formulas differ at 100 m (sky)
    assert np.array_equal(seg, view.seg)


def test_timed_render_fills_every_phase_and_draws_the_same_view(rendered, catalogue):
    """bench.py's per-phase table (where a view's render time goes, on CPU or GPU) reads these."""
    scene, view = rendered
    timings: dict[str, float] = {}
    timed = render_views(scene, catalogue.materials, timings)[0]
    assert set(timings) == set(PHASES) and all(t > 0 for t in timings.values())
    assert np.array_equal(timed.rgb, view.rgb) and np.array_equal(timed.seg, view.seg)


def test_gl_info_names_the_renderer():
    info = gl_info()
    assert set(info) == {"vendor", "renderer", "version"} and all(info.values())


def test_repeated_renders_are_identical(rendered, catalogue):
    scene, view = rendered
    again = render_views(scene, catalogue.materials)[0]
    assert np.array_equal(again.rgb, view.rgb) and np.array_equal(again.seg, view.seg)
    assert np.array_equal(again.depth_m, view.depth_m)


SCRIPT = """
import sys
from refspatial.assets import load_catalogue
from refspatial.pipeline import build_scene
from refspatial.recipe import load_recipe
from refspatial.render import render_views

views = render_views(build_scene(load_recipe(sys.argv[1]), load_catalogue(), 1), load_catalogue().materials)
print(views[0].rgb.shape)
"""


@pytest.mark.skipif(__import__("ctypes.util").util.find_library("OSMesa") is None,
                    reason="MUJOCO_GL=osmesa needs libosmesa6 (apt-get install -y libosmesa6)")
def test_osmesa_exits_without_a_traceback_from_the_contexts_destructor():
    import os
    import subprocess
    import sys

    from conftest import TINY

    env = {**os.environ, "MUJOCO_GL": "osmesa", "PYOPENGL_PLATFORM": "osmesa"}
    r = subprocess.run([sys.executable, "-c", SCRIPT, str(TINY)], capture_output=True, text=True, env=env, timeout=300)
    assert r.returncode == 0 and r.stdout.strip() == "(108, 192, 3)", r.stderr
    assert "Traceback" not in r.stderr and "Exception ignored" not in r.stderr, r.stderr
