"""The free-space solver on real renders: points on the support, clear of obstacles, visible, in region."""

import numpy as np
import pytest

from refspatial.compose import SceneRejected
from refspatial.pipeline import build_scene
from refspatial.relations import TABLE, view_facts
from refspatial.relations.free_space import (
    CLEARANCE_M, DIRECTIONS, MIN_FREE_AREA_M2, OCCLUSION_M, Constraint, _sector, direction_axis, solve,
)
from refspatial.relations.geometry import inside_convex, project
from refspatial.render import render_views


@pytest.fixture(scope="module")
def views(tiny, catalogue):
    out = []
    for seed in range(40):
        try:
            scene = build_scene(tiny, catalogue, seed)
        except SceneRejected:
            continue
        out.append(view_facts(scene, render_views(scene, catalogue.materials)[0]))
        if len(out) == 3:
            return out
    raise AssertionError("too few usable scenes")


def _check(v, answer, constraints):
    x, y = answer.point
    col, row = int(x * v.width), int(y * v.height)
    assert answer.mask[row, col], "the answer point lies on its own free-region mask"
    world = answer.point_world_m
    assert world[2] == pytest.approx(v.table_top_z_m)
    assert np.all(np.abs(world[:2]) <= np.asarray(v.table_size_m) / 2)
    for o in v.objects:
        assert not inside_convex(world[None, :2], o.footprint_world, grow=CLEARANCE_M - 0.005)[0], o.object_id
    uv, z = project(world[None], v.K, v.T_world_cam)
    assert abs(v.depth_m[int(uv[0, 1]), int(uv[0, 0])] - z[0]) <= OCCLUSION_M + 0.01
    assert answer.area_m2 > MIN_FREE_AREA_M2 or any(c.kind == "offset" for c in constraints)


def test_sector_answers_are_free_visible_and_in_their_sector(views):
    solved = 0
    for v in views:
        for a in v.askable():
            if a.support != TABLE:
                continue
            for d in DIRECTIONS:
                c = (Constraint("sector", (a.object_id,), d),)
                answer = solve(v, c)
                if answer is None:
                    continue
                _check(v, answer, c)
                # the chosen point may be snapped to a pixel centre: allow 1 cm around the sector
                world = answer.point_world_m[:2]
                near = world + np.array([[0, 0], [0.01, 0], [-0.01, 0], [0, 0.01], [0, -0.01]])
                assert _sector(v, c[0], near).any()
                rel = world - a.center_world_m[:2]
                assert rel @ direction_axis(v, d) > 0, "the point lies on the requested side"
                solved += 1
    assert solved >= 5


def test_combined_constraints_and_metric_offsets(views):
    combined = offsets = 0
    for v in views:
        objs = [o for o in v.askable() if o.support == TABLE]
        for a in objs:
            for b in objs:
                if a is b:
                    continue
                for d1 in DIRECTIONS:
                    for d2 in DIRECTIONS:
                        c = (Constraint("sector", (a.object_id,), d1), Constraint("sector", (b.object_id,), d2))
                        answer = solve(v, c)
                        if answer is None:
                            continue
                        _check(v, answer, c)
                        rel_a = answer.point_world_m[:2] - a.center_world_m[:2]
                        rel_b = answer.point_world_m[:2] - b.center_world_m[:2]
                        assert rel_a @ direction_axis(v, d1) > 0 and rel_b @ direction_axis(v, d2) > 0
                        combined += 1
            c = (Constraint("offset", (a.object_id,), "right", 0.10),)
            answer = solve(v, c)
            if answer is not None:
                _check(v, answer, c)
                half = 0.5 * a.extent_along(np.array([*direction_axis(v, "right"), 0]))
                along = (answer.point_world_m[:2] - a.center_world_m[:2]) @ direction_axis(v, "right")
                assert along == pytest.approx(half + 0.10, abs=0.025)
                offsets += 1
    assert combined >= 1 and offsets >= 1


def test_no_answer_when_the_region_is_too_small(views):
    v = views[0]
    a = v.askable()[0]
    tight = (Constraint("sector", (a.object_id,), "left"), Constraint("sector", (a.object_id,), "right"))
    assert solve(v, tight) is None  # opposite sectors of one anchor share no area


def test_sector_box_bounds_the_sector_tightly():
    from refspatial.relations.free_space import HALF_SECTOR_DEG, _sector_box

    rng = np.random.default_rng(0)
    for _ in range(200):
        centre, r = rng.uniform(-1, 1, 2), rng.uniform(0.05, 1)
        a = rng.uniform(-np.pi, np.pi)
        axis = np.array([np.cos(a), np.sin(a)])
        box = _sector_box(centre, axis, r)
        # Points filling the sector (polar samples, arc included) all lie in the box ...
        ang = a + np.radians(HALF_SECTOR_DEG) * np.linspace(-1, 1, 181)
        rad = np.linspace(0, r, 21)
        pts = centre + (rad[:, None, None] * np.stack([np.cos(ang), np.sin(ang)], -1)[None]).reshape(-1, 2)
        assert np.all(pts >= box[0] - 1e-12) and np.all(pts <= box[1] + 1e-12)
        # ... and reach its every side (within the sampling step).
        assert np.allclose(pts.min(0), box[0], atol=r * 1e-3) and np.allclose(pts.max(0), box[1], atol=r * 1e-3)
