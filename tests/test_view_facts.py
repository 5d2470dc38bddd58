"""A view's facts from real renders, checked object by object against what they summarise."""

import numpy as np
import pytest

from refspatial.compose import SceneRejected
from refspatial.pipeline import build_scene
from refspatial.relations import view_facts
from refspatial.relations.geometry import covered_pixels, project
from refspatial.render import render_views


@pytest.fixture(scope="module")
def rendered(tiny, catalogue):
    out = []
    for seed in range(40):
        try:
            scene = build_scene(tiny, catalogue, seed)
        except SceneRejected:
            continue
        for view in render_views(scene, catalogue.materials):
            out.append((scene, view, view_facts(scene, view)))
        if len(out) >= 4:
            return out
    raise AssertionError("too few usable scenes")


def test_each_object_s_visible_share_is_its_pixels_over_its_own_silhouette(rendered):
    # The silhouettes of a view's objects are drawn together: each share must use the object's own.
    checked = 0
    for scene, view, facts in rendered:
        h, w = view.seg.shape
        for obj in scene.objects:
            f = facts.objects[obj.object_id]
            pixels = int(np.count_nonzero(view.seg == obj.object_id))
            assert f.visible_px == pixels
            if not pixels:
                assert f.visible_share == 0.0
                continue
            T = obj.pose.matrix()
            verts = obj.asset.visual.vertices_m @ T[:3, :3].T + T[:3, 3]
            uv, z = project(verts, view.K, view.T_world_cam)
            alone = h * w if np.any(z <= 0.01) else covered_pixels(uv[obj.asset.visual.faces], w, h)
            assert f.visible_share == min(1.0, pixels / max(alone, 1))
            checked += 1
    assert checked >= 8
