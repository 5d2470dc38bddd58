"""A view's facts from real renders, checked object by object against what they summarise."""

import numpy as np
import pytest

from refspatial.relations import view_facts
from refspatial.relations.geometry import covered_pixels, project

from helpers import rendered_scenes


@pytest.fixture(scope="module")
def rendered(tiny, catalogue):
    return [(scene, view, view_facts(scene, view)) for scene, views in rendered_scenes(tiny, catalogue, 2)
            for view in views]


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


def test_stored_outlines_are_the_micrometres_of_the_posed_mesh(rendered):
    """A record keeps each ground outline as it is (no second rounding): it must already be the
    posed mesh's convex outline in whole micrometres, which rounding again leaves unchanged."""
    from scipy.spatial import ConvexHull

    from refspatial.relations.geometry import inside_convex
    from refspatial.relations.stored import DIGITS, object_record, rounded_rows

    checked = 0
    for scene, _, facts in rendered:
        for obj in scene.objects:
            stored = object_record(obj, facts.objects[obj.object_id])["outline_world_m"]
            assert stored == rounded_rows(stored, DIGITS)
            T = obj.pose.matrix()
            xy = (obj.asset.visual.vertices_m @ T[:3, :3].T + T[:3, 3])[:, :2]
            corners = {tuple(c) for c in np.round(xy, DIGITS).tolist()}
            assert all(tuple(c) in corners for c in stored), "each corner is a posed vertex in micrometres"
            hull = xy[ConvexHull(xy).vertices]  # and the outline holds the unrounded mesh's
            assert inside_convex(hull, np.array(stored), grow=1e-6).all()
            checked += 1
    assert checked >= 8
