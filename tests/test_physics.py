import dataclasses

import numpy as np
import pytest

from refspatial.compose import SceneRejected, compose
from refspatial.physics import settle
from refspatial.scene import Pose, quat_to_matrix


def _first_stable(tiny, catalogue, seeds=range(20)):
    for seed in seeds:
        try:
            scene = compose(tiny, catalogue, seed)
            return scene, settle(scene, catalogue.materials, tiny)
        except SceneRejected:
            continue
    raise AssertionError("no stable scene in 20 seeds")


def _lowest_z(o) -> float:
    return float((o.asset.visual.vertices_m @ quat_to_matrix(o.pose.quat_wxyz).T)[:, 2].min() + o.pose.pos_world_m[2])


def test_settled_objects_rest_upright_where_they_were_put(tiny, catalogue):
    before, after = _first_stable(tiny, catalogue)
    drop = tiny["objects"]["drop_height_m"]
    assert any(_lowest_z(o) == pytest.approx(before.table.top_z_m + drop) for o in before.objects)
    for old, new in zip(before.objects, after.objects):
        # Resting, not floating or sunk: on the table, or on or in the thing it was put on or in.
        assert _lowest_z(new) == pytest.approx(_lowest_z(old) - drop, abs=0.006)
        assert quat_to_matrix(new.pose.quat_wxyz)[2, 2] > np.cos(np.radians(tiny["physics"]["max_tilt_deg"]))
        assert np.hypot(*np.subtract(new.pose.pos_world_m[:2], old.pose.pos_world_m[:2])) < 0.04


def test_settling_is_deterministic(tiny, catalogue):
    scene, a = _first_stable(tiny, catalogue)
    b = settle(scene, catalogue.materials, tiny)
    assert [o.pose for o in a.objects] == [o.pose for o in b.objects]


def test_object_beyond_the_edge_falls_and_is_rejected(tiny, catalogue):
    scene, _ = _first_stable(tiny, catalogue)
    edge_x = scene.table.size_m[0] / 2 + 0.2
    moved = dataclasses.replace(scene.objects[0], pose=Pose((edge_x, 0.0, scene.table.top_z_m + 0.002), (1, 0, 0, 0)))
    bad = dataclasses.replace(scene, objects=(moved, *scene.objects[1:]))
    with pytest.raises(SceneRejected) as err:
        settle(bad, catalogue.materials, tiny)
    assert err.value.reason == "fell_off_table"


def test_settled_contacts_are_read_with_every_body_awake(tiny, catalogue):
    """Settling lets resting islands sleep, and a sleeping island's contacts go stale; the scene's
    contacts must be those of the settled poses simulated awake."""
    import mujoco

    from refspatial.mjcf import SpecOptions, build_spec
    from refspatial.physics import contact_pairs

    checked = 0
    for seed in range(20):
        try:
            scene = settle(compose(tiny, catalogue, seed), catalogue.materials, tiny)
        except SceneRejected:
            continue
        model = build_spec(scene, catalogue.materials, SpecOptions(dynamic=True, visual=False)).compile()
        data = mujoco.MjData(model)
        mujoco.mj_forward(model, data)
        assert scene.contacts == contact_pairs(model, data, len(scene.objects))
        checked += len(scene.contacts)
    assert checked > 0  # some scene had a contact between objects


def test_collision_parts_as_cached_assets_compile_to_the_inline_model(tiny, catalogue):
    """Settling hands collision parts to MuJoCo as content-named .msh assets so that its compiler
    cache serves them again in later scenes; the compiled model must be the one inline vertices
    give (every mesh, geom and body array). Whether the cache is hit shows only in the compile's
    time, which benchmarks measure (cpu_profile.py's physics), not tests."""
    from refspatial import mjcf

    scene, _ = _first_stable(tiny, catalogue)
    opts = mjcf.SpecOptions(dynamic=True, visual=False)
    cached = mjcf.build_spec(scene, catalogue.materials, opts)
    inline = mjcf.build_spec(scene, catalogue.materials, opts)
    for mesh in inline.meshes:  # the same parts, handed over as vertex lists
        part = next(p for o in scene.objects for k, p in enumerate(o.asset.collision)
                    if mesh.name == f"{mjcf.body_name(o.object_id)}_col{k}")
        mesh.file = ""
        mesh.uservert = part.vertices_m.ravel().tolist()
        mesh.userface = part.faces.ravel().tolist()
    inline.assets = {}
    a, b = cached.compile(), inline.compile()
    assert a.nmesh == b.nmesh > 0
    for field in ("mesh_vert", "mesh_face", "mesh_graph", "mesh_polyvert", "geom_size", "geom_pos", "geom_quat",
                  "body_mass", "body_inertia", "body_ipos", "body_iquat"):
        np.testing.assert_array_equal(getattr(a, field), getattr(b, field), err_msg=field)
