"""The free-space solver on real renders: points on the support, clear of obstacles, visible, in region."""

import math

import numpy as np
import pytest

from refspatial.relations import TABLE, view_facts
from refspatial.relations.free_space import (
    ANSWER_ROOM_M, CLEARANCE_M, DIRECTIONS, IMAGE_CLEARANCE, MIN_FREE_AREA_M2, OCCLUSION_M, Constraint, _sector, direction_axis, solve,
)
from refspatial.relations.geometry import grown_box, inside_convex, project

from helpers import rendered_scenes


@pytest.fixture(scope="module")
def views(tiny, catalogue):
    return [view_facts(scene, views[0]) for scene, views in rendered_scenes(tiny, catalogue, 3)]


def _check(v, answer, constraints):
    x, y = answer.point
    col, row = int(x * v.width), int(y * v.height)
    assert answer.mask[row, col], "the answer point lies on its own free-region mask"
    world = answer.point_world_m
    assert world[2] == pytest.approx(v.table_top_z_m)
    assert np.all(np.abs(world[:2]) <= np.asarray(v.table_size_m) / 2)
    for o in v.objects:
        assert not inside_convex(world[None, :2], o.footprint_world, grow=CLEARANCE_M - 0.005)[0], o.object_id
    if not any(c.kind == "offset" for c in constraints):  # room for a small thing there (annotator)
        for o in v.objects:
            if o.object_id != answer.support and o.aabb_world_m[0, 2] < world[2] + 0.05:
                assert not inside_convex(world[None, :2], o.ground_outline, grow=ANSWER_ROOM_M - 0.01)[0], o.object_id
    uv, z = project(world[None], v.K, v.T_world_cam)
    assert abs(v.depth_m[int(uv[0, 1]), int(uv[0, 0])] - z[0]) <= OCCLUSION_M + 0.01
    assert answer.area_m2 > MIN_FREE_AREA_M2 or any(c.kind == "offset" for c in constraints)
    # In the picture too the spot keeps clear of every object (the platform under it aside):
    # 1.5 cm behind a cup is free on the table but lies on the cup's outline in the image.
    rows, cols = np.nonzero((v.seg >= 0) & (v.seg != answer.support))
    nearest = np.sqrt((cols + 0.5 - x * v.width) ** 2 + (rows + 0.5 - y * v.height) ** 2).min()
    assert nearest >= IMAGE_CLEARANCE * v.width - 1.0, "the spot lies on an object's outline in the picture"


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
                # ...and squarely so: within the anchor's own width across the direction (1 cm for
                # the snap), not in front of the thing beside it (annotator)
                axis = direction_axis(v, d)
                across = np.array([-axis[1], axis[0], 0.0])
                lo, hi = a.interval_along(across, float(a.center_world_m[:2] @ across[:2]))
                assert lo - 0.01 <= world @ across[:2] <= hi + 0.01, "the spot is beside the anchor's strip"
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


def _brute_force_mask(v, constraints, answer):
    """The definition of a region's image mask, evaluated at every pixel of the frame: the
    pixel's ray meets the platform plane, nothing nearer hides that point, the point is in
    every region, and its 1 cm cell is free."""
    from refspatial.relations.free_space import CELL_M, _in_regions, _platform, _raster

    support, polygon, z = _platform(v, constraints, [v.objects[i] for c in constraints for i in c.anchors])
    raster = _raster(v, support, polygon, z)
    rows, cols = np.mgrid[0:v.height, 0:v.width]
    rays = np.stack([cols + 0.5, rows + 0.5, np.ones_like(cols)], -1).reshape(-1, 3) @ np.linalg.inv(v.K).T
    dirs = rays @ v.T_world_cam[:3, :3].T
    t = v.T_world_cam[:3, 3]
    with np.errstate(divide="ignore", invalid="ignore"):
        s = (z - t[2]) / dirs[:, 2]
    hit = t[:2] + dirs[:, :2] * s[:, None]
    seen = (s > 0) & np.isfinite(s) & (np.abs(v.depth_m.reshape(-1) - s) <= OCCLUSION_M)
    cell = np.floor(hit[seen] / CELL_M).astype(int) - raster.first
    on = (cell >= 0).all(1) & (cell[:, 0] < raster.free.shape[1]) & (cell[:, 1] < raster.free.shape[0])
    free = np.zeros(len(cell), dtype=bool)
    free[on] = raster.free[cell[on, 1], cell[on, 0]]
    mask = np.zeros(len(s), dtype=bool)
    mask[np.flatnonzero(seen)[free]] = _in_regions(v, constraints, hit[seen][free])
    return mask.reshape(v.height, v.width)


def test_region_masks_match_their_per_pixel_definition(views):
    """Masks are computed on a window, with whole cells inside the region taken without a per-pixel
    test; the result must be the definition's, pixel for pixel."""
    checked = 0
    for v in views:
        objs = [o for o in v.askable() if o.support == TABLE]
        cases = [(Constraint("sector", (a.object_id,), d),) for a in objs for d in DIRECTIONS]
        cases += [(Constraint("between", (a.object_id, b.object_id)),) for a in objs for b in objs if a.object_id < b.object_id]
        cases += [(Constraint("offset", (a.object_id,), "left", 0.05),) for a in objs]
        for c in cases:
            answer = solve(v, c)
            if answer is None:
                continue
            expected = _brute_force_mask(v, c, answer)
            assert np.array_equal(answer.mask, expected), (c, int((answer.mask != expected).sum()))
            checked += 1
    assert checked >= 6


def test_grown_regions_hold_every_point_near_the_region(views):
    """_in_regions(grow=g) decides which cells may meet a region, so it must hold every point
    within g of a point of the region (it may hold more)."""
    from refspatial.relations.free_space import _in_regions

    rng = np.random.default_rng(3)
    v = views[0]
    objs = v.askable()
    cases = [(Constraint("sector", (a.object_id,), d),) for a in objs for d in DIRECTIONS]
    cases += [(Constraint("between", (objs[0].object_id, objs[1].object_id)),)]
    cases += [(Constraint("offset", (a.object_id,), "behind", 0.1),) for a in objs]
    for c in cases:
        centre = v.objects[c[0].anchors[0]].center_world_m[:2]
        points = centre + rng.uniform(-0.6, 0.6, (20000, 2))
        inside = points[_in_regions(v, c, points)]
        assert len(inside) > 0, c
        for grow in (0.003, 0.0071):
            step = rng.normal(size=inside.shape)
            step *= rng.uniform(0, grow, (len(inside), 1)) / np.linalg.norm(step, axis=1, keepdims=True)
            assert _in_regions(v, c, inside + step, grow=grow).all(), (c, grow)
            assert not _in_regions(v, c, centre + np.array([[5.0, 5.0]]), grow=grow).any()


def test_compiled_region_test_is_the_regions_definition(views):
    """``_in_regions`` (compiled) answers what ``REGIONS``' numpy functions answer, point for point
    and on grids, for every kind alone and combined, on random points and on points placed on
    the regions' very edges (a sector's arc and sides, an offset's circle, a hull's edges), where
    one differently rounded operation would show."""
    from refspatial.compiled import in_regions_grid
    from refspatial.relations.free_space import REGIONS, _in_regions, _reach, _region_arrays

    rng = np.random.default_rng(11)
    checked = 0
    for v in views:
        objs = v.askable()
        ids = [o.object_id for o in objs]
        cases = [(Constraint("sector", (i,), d),) for i in ids for d in DIRECTIONS]
        cases += [(Constraint("offset", (i,), d, m),) for i in ids for d, m in zip(DIRECTIONS, (0.05, 0.1, 0.15, 0.2))]
        cases += [(Constraint("between", (a, b)),) for a in ids for b in ids if a < b]
        cases += [(Constraint("on_top", (i,)),) for i in ids]
        cases += [(Constraint("between", (ids[0], ids[1])), Constraint("sector", (ids[2 % len(ids)],), "left")),
                  (Constraint("sector", (ids[0],), "front"), Constraint("sector", (ids[1],), "right")), ()]
        for c in cases:
            centre = v.objects[c[0].anchors[0]].center_world_m[:2] if c else np.zeros(2)
            points = [centre + rng.uniform(-0.5, 0.5, (3000, 2))]
            for k in c:  # points on the region's boundary, to the last bit
                if k.kind in ("sector", "offset"):
                    reach = _reach(v, k.anchors[0], k.direction)
                    turn = rng.uniform(-np.pi / 4, np.pi / 4, 400)
                    axis = np.arctan2(reach.axis[1], reach.axis[0]) + turn
                    r = reach.half + reach.radius if k.kind == "sector" else 0.015
                    points.append(reach.centre + r * np.column_stack([np.cos(axis), np.sin(axis)]))
                    points.append(reach.centre + rng.uniform(0, r, (400, 1)) * np.column_stack(
                        [np.cos(axis[0] - turn[0] + np.pi / 4), np.sin(axis[0] - turn[0] + np.pi / 4)]))
            points = np.concatenate(points)
            expected = np.ones(len(points), bool)
            for k in c:
                expected &= REGIONS[k.kind](v, k, points)
            assert np.array_equal(_in_regions(v, c, points), expected), c
            xs, ys = np.sort(points[:60, 0]), np.sort(points[:60, 1])
            grid = np.stack(np.meshgrid(xs, ys), axis=-1).reshape(-1, 2)
            want = np.ones(len(grid), bool)
            for k in c:
                want &= REGIONS[k.kind](v, k, grid)
            assert np.array_equal(in_regions_grid(xs, ys, *_region_arrays(v, c)), want.reshape(len(ys), len(xs))), c
            checked += len(points)
    assert checked > 100_000


@pytest.mark.parametrize("radius", [0.5, 1.0, 2 ** 0.5, 5.0, 19.2, 40.0])
def test_far_from_equals_scipy_distance_transform(radius):
    """The clearance mask (rectangular dilations of a window) is scipy's whole-image transform to
    the pixel, whole-number radii and objects at the image's corners included."""
    from scipy.ndimage import distance_transform_edt

    from refspatial.relations.free_space import _far_from

    rng = np.random.default_rng(7)
    for k in range(6):
        pixels = np.zeros((60, 90), dtype=bool)
        for _ in range(k + 1):
            r, c = rng.integers(0, 60), rng.integers(0, 90)
            pixels[r:r + rng.integers(1, 12), c:c + rng.integers(1, 12)] = True
        pixels[0, 0] = k % 2 == 0
        pixels[-1, -1] = k % 3 == 0
        expected = distance_transform_edt(~pixels) >= radius
        assert np.array_equal(_far_from(pixels, radius), expected)
        # Given a window holding every True pixel, the whole frame's answer.
        rows, cols = np.flatnonzero(pixels.any(1)), np.flatnonzero(pixels.any(0))
        r0, c0 = max(rows[0] - int(rng.integers(0, 3)), 0), max(cols[0] - int(rng.integers(0, 3)), 0)
        window = pixels[r0:rows[-1] + 1 + int(rng.integers(0, 3)), c0:cols[-1] + 1 + int(rng.integers(0, 3))]
        assert np.array_equal(_far_from(window, radius, at=(r0, c0), shape=pixels.shape), expected)
    empty = np.zeros((20, 30), dtype=bool)
    assert np.array_equal(_far_from(empty, radius), distance_transform_edt(~empty) >= radius)


@pytest.mark.parametrize("n", [1, 2, 3, 5, 26, 369, 370, 1601])
def test_disk_rectangles_make_up_the_disk_and_each_is_needed(n):
    """The clearance's dilation: the union of its rectangles is every offset within squared
    distance n - 1, and dropping any one of them loses some offset."""
    from refspatial.relations.free_space import _disk_rectangles

    r = math.isqrt(n - 1) + 1
    dy, dx = np.mgrid[-r:r + 1, -r:r + 1]
    rects = _disk_rectangles(n)
    cover = [(np.abs(dx) <= w) & (np.abs(dy) <= h) for w, h in rects]
    assert np.array_equal(np.logical_or.reduce(cover), dx * dx + dy * dy <= n - 1)
    for k in range(len(cover)):
        assert not np.array_equal(np.logical_or.reduce(cover[:k] + cover[k + 1:]), np.logical_or.reduce(cover))


def test_image_clearance_is_the_whole_frame_s_distance_transform(views):
    """The clearance mask, read only around the objects and, for an object platform, again around
    its own pixels, is the whole frame's transform of every other object's pixels."""
    from scipy.ndimage import distance_transform_edt

    from refspatial.relations.free_space import image_clearance

    for v in views:
        for support in (TABLE, *(o.object_id for o in v.objects)):
            others = (v.seg >= 0) & (v.seg != support)
            expected = distance_transform_edt(~others) >= IMAGE_CLEARANCE * v.width
            assert np.array_equal(image_clearance(v, support), expected), support


def test_flat_things_on_a_platform_are_in_the_way_and_things_below_it_are_not():
    """A fork lying flat (3 mm) takes its place on the table (annotator read 42: a free spot's region
    held the fork's pixels); a thing standing on a board below the platform is not in its way."""
    from helpers import obj, view

    from refspatial.relations.free_space import _obstacles

    fork = obj(1, "fork", "silver", 0.1, 0.0, size=0.15, height=0.003)
    below = obj(2, "cup", "red", -0.1, 0.0, height=0.08, z=-0.1, support=None)
    v = view(obj(0, "bowl", "white", 0.0, 0.2), fork, below)
    assert [o.object_id for o in _obstacles(v, TABLE, 0.0)] == [0, 1]


def test_no_free_spot_between_a_shelf_s_posts():
    """The posts stand on every board below the highest: the strip at each end between them is not
    free (annotator: a spot wedged between the end posts). The highest board has no posts on it."""
    import dataclasses

    from helpers import obj, view

    from refspatial.relations.free_space import _platform
    from refspatial.scene import LEG_HALF_M, LEG_INSET_M

    shelf = dataclasses.replace(view(obj(0, "mug", "red", 0.0, 0.0)), table_levels_m=(0.38, 0.76))
    hx = shelf.table_size_m[0] / 2
    for support, inner in ((TABLE, True), (-2, True), (-3, False)):
        mug = dataclasses.replace(shelf.objects[0], support=support)
        _, polygon, _ = _platform(shelf, (Constraint("sector", (0,), "left"),), [mug])
        reach = polygon[:, 0].max()
        assert (reach <= hx - LEG_INSET_M - LEG_HALF_M) if inner else reach == pytest.approx(hx), support


def test_grid_inside_test_equals_the_pointwise_one():
    """The separable grid test (axis-aligned platforms) gives exactly the pointwise test's flags,
    on cell centres that straddle every edge; turned polygons go the pointwise way."""
    from refspatial.relations.geometry import inside_convex_grid

    rng = np.random.default_rng(3)
    for _ in range(50):
        hx, hy = rng.uniform(0.05, 3.0, 2)
        xs = (np.arange(-int(hx * 100) - 5, int(hx * 100) + 5) + 0.5) * 0.01
        ys = (np.arange(-int(hy * 100) - 5, int(hy * 100) + 5) + 0.5) * 0.01
        square = np.array([[-hx, -hy], [hx, -hy], [hx, hy], [-hx, hy]])
        turn = rng.uniform(0, np.pi)
        turned = square @ np.array([[np.cos(turn), np.sin(turn)], [-np.sin(turn), np.cos(turn)]])
        points = np.stack(np.meshgrid(xs, ys), axis=-1).reshape(-1, 2)
        for poly in (square, square[::-1], turned):
            for grow in (0.0, -0.02, 0.015):
                expected = inside_convex(points, poly, grow).reshape(len(ys), len(xs))
                assert np.array_equal(inside_convex_grid(xs, ys, poly, grow), expected)


def test_between_spots_lie_in_the_middle_of_the_line_joining_their_anchors(views):
    """A spot 15 % along the line from a stool to a pot and 21 cm off it is beside the stool, not
    between the two (annotator): the answer keeps to the middle of the line and its corridor."""
    solved = 0
    for v in views:
        objs = [o for o in v.askable() if o.support == TABLE]
        for a in objs:
            for b in objs:
                if a.object_id >= b.object_id:
                    continue
                c = (Constraint("between", (a.object_id, b.object_id)),)
                answer = solve(v, c)
                if answer is None:
                    continue
                _check(v, answer, c)
                seg = b.center_world_m[:2] - a.center_world_m[:2]
                t = (answer.point_world_m[:2] - a.center_world_m[:2]) @ seg / (seg @ seg)
                assert 0.2 - 0.05 <= t <= 0.8 + 0.05, (a.object_id, b.object_id, t)
                solved += 1
    assert solved >= 1


@pytest.mark.parametrize("poly", [
    np.array([[0.0, 0.0], [0.3, 0.02], [0.0, 0.05]]),  # a sliver: its sharp corner's mitre reaches far
    np.array([[0.1, 0.1], [0.2, 0.2], [0.1, 0.3], [0.0, 0.2]]),  # a square turned by 45 degrees
])
def test_grown_box_holds_the_grown_polygon(poly):
    # The raster of cells clear of obstacles looks only inside this box: a cell the grown
    # polygon holds outside it would be called roomy by the raster and not by the exact test.
    grow = ANSWER_ROOM_M
    lo, hi = grown_box(poly, grow)
    xs, ys = np.meshgrid(np.linspace(-0.5, 1.5, 801), np.linspace(-0.5, 0.6, 441))
    points = np.column_stack([xs.ravel(), ys.ravel()])
    held = points[inside_convex(points, poly, grow=grow)]
    assert np.all(held >= lo - 1e-12) and np.all(held <= hi + 1e-12)
    assert np.all(held.min(0) - lo < 0.01) and np.all(hi - held.max(0) < 0.01)  # and it is tight
    assert np.any(held.max(0) > poly.max(0) + grow + 0.01)  # past the plain box grown by grow


def test_cell_flags_match_the_tests_they_cache(views):
    # The raster's per-cell flags (seen, cleared, roomy) against each test made at the cells'
    # centres directly, as the solver did per region before they were cached.
    from refspatial.relations import free_space as fs
    checked = 0
    for v in views:
        support, polygon, z = fs._platform(v, (), [v.objects[0]])
        raster = fs._raster(v, support, polygon, z)
        seen, cleared, roomy = raster.flags(v, np.nonzero(raster.free))
        every = np.indices(raster.free.shape).reshape(2, -1)  # and the raster itself, cell by cell
        cells = (np.column_stack([every[1] + raster.first[0], every[0] + raster.first[1]]) + 0.5) * fs.CELL_M
        exact = fs._free_exact(v, cells, support, polygon, z).reshape(raster.free.shape)
        assert np.array_equal(raster.free, exact)
        rows, cols = np.nonzero(raster.free)
        centres = (np.column_stack([cols + raster.first[0], rows + raster.first[1]]) + 0.5) * fs.CELL_M
        uv, depth = project(np.column_stack([centres, np.full(len(centres), z)]), v.K, v.T_world_cam)
        inside = (uv[:, 0] >= 0) & (uv[:, 0] < v.width) & (uv[:, 1] >= 0) & (uv[:, 1] < v.height) & (depth > 0)
        shown = np.zeros(len(uv), dtype=bool)
        u, w = uv[inside].astype(int).T
        shown[inside] = np.abs(v.depth_m[w, u] - depth[inside]) <= OCCLUSION_M
        assert np.array_equal(seen[rows, cols], shown)
        clear = fs.image_clearance(v, support)
        on_clear = np.zeros(len(uv), dtype=bool)
        on_clear[inside] = clear[w, u]
        assert np.array_equal(cleared[rows, cols], on_clear)
        room = np.ones(len(centres), dtype=bool)
        for o in v.objects:
            if o.object_id != support and o.aabb_world_m[0, 2] < z + fs.OBSTACLE_BAND_M:
                outline = o.ground_outline if o.ground_outline is not None else o.footprint_world
                room &= ~inside_convex(centres, outline, grow=ANSWER_ROOM_M)
        assert np.array_equal(roomy[rows, cols], room)
        checked += len(centres)
    assert checked > 1000


def test_cell_flags_worked_out_cell_by_cell_match_the_whole(views, monkeypatch):
    # On a room's floor, flags are worked out for the cells a solve looks at, when it first does:
    # cell sets asked in any order, overlapping or not, leave the same flags as a table's
    # raster, which works out all its free cells at the first call.
    from refspatial.relations import free_space as fs
    rng = np.random.default_rng(3)
    for v in views:
        support, polygon, z = fs._platform(v, (), [v.objects[0]])
        whole = fs._Raster(v, support, polygon, z)
        every = np.nonzero(whole.free)
        assert whole.free.size <= fs.ALL_AT_ONCE_CELLS
        expected = [f.copy() for f in whole.flags(v, (every[0][:1], every[1][:1]))]
        assert np.array_equal(whole._known, whole.free)
        monkeypatch.setattr(fs, "ALL_AT_ONCE_CELLS", 0)  # as on a floor: cell by cell
        part = fs._Raster(v, support, polygon, z)
        for _ in range(12):
            pick = rng.random(len(every[0])) < rng.uniform(0.01, 0.3)
            cells = (every[0][pick], every[1][pick])
            got = part.flags(v, cells)
            for f, e in zip(got[:2], expected[:2]):
                assert np.array_equal(f[cells], e[cells])
        got = part.flags(v, every)  # the rest
        for f, e in zip(got, expected):
            assert np.array_equal(f, e)
        monkeypatch.undo()


@pytest.mark.parametrize("lazy", [False, True])
def test_the_compiled_sector_sweep_equals_the_general_one(views, monkeypatch, lazy):
    # The relation table's single-sector solves run as two compiled loops; every anchor and
    # direction (and the same boxes moved half off the raster) must give the general sweep's
    # area, mean and nearest cell bit for bit, or None with it. ``lazy``: flags worked out cell by
    # cell, as on a room's floor.
    from refspatial.relations import free_space as fs
    if lazy:
        monkeypatch.setattr(fs, "ALL_AT_ONCE_CELLS", 0)
    answers = nones = 0
    for v in views:
        for a in v.askable():
            for d in DIRECTIONS:
                c = Constraint("sector", (a.object_id,), d)
                platform = fs._platform(v, (c,), [a])
                if platform is None:
                    continue
                support, polygon, z = platform
                first, last = fs._grid(v, (c,), polygon)
                raster = fs._raster(v, support, polygon, z)
                for shift in (np.zeros(2, int), (raster.first - first) + np.array([-7, 5])):
                    args = (raster, support, z, first + shift, last + shift)
                    general, swept = fs._swept(v, (c,), *args), fs._swept_sector(v, c, *args)
                    if general is None:
                        assert swept is None
                        nones += 1
                        continue
                    assert swept is not None and swept[0] == general[0]
                    assert np.array_equal(swept[1], general[1]) and np.array_equal(swept[2], general[2])
                    answers += 1
    assert answers >= 5 and nones >= 5


def _cleared(clear: np.ndarray, uv: np.ndarray) -> np.ndarray:
    """The whole-array reading of the clearance mask the solver's compiled and scalar reads
    follow: which image points (N, 2 pixels) fall on cleared pixels; points off the image do not."""
    cols, rows = np.floor(uv[:, 0]).astype(int), np.floor(uv[:, 1]).astype(int)
    h, w = clear.shape
    ok = (cols >= 0) & (cols < w) & (rows >= 0) & (rows < h)
    out = np.zeros(len(uv), dtype=bool)
    out[ok] = clear[rows[ok], cols[ok]]
    return out


def _unoccluded(depth_m: np.ndarray, uv: np.ndarray, z: np.ndarray, margin: float) -> np.ndarray:
    """The whole-array occlusion test the compiled one follows: which projected points (pixels uv,
    optical-axis depths z) the rendered depth shows, within ``margin``."""
    cols, rows = np.floor(uv[:, 0]).astype(int), np.floor(uv[:, 1]).astype(int)
    h, w = depth_m.shape
    ok = (z > 0) & (cols >= 0) & (cols < w) & (rows >= 0) & (rows < h)
    out = np.zeros(len(uv), dtype=bool)
    out[ok] = np.abs(depth_m[rows[ok], cols[ok]] - z[ok]) <= margin
    return out


def test_one_point_clearance_read_equals_the_array_read():
    """``_cleared_at`` (a solve's answer point, in scalars) against the whole-array reading:
    inside, on and past every edge, far off, and not finite."""
    from refspatial.relations.free_space import _cleared_at

    rng = np.random.default_rng(5)
    clear = rng.random((54, 96)) < 0.5
    points = np.concatenate([
        rng.uniform(-20, 120, size=(4000, 2)),
        [[0, 0], [96, 54], [95.999999, 53.999999], [-1e-12, 3], [3, -1e-12], [96, 0], [0, 54], [1e30, 5],
         [-1e30, 5], [np.nan, 5], [5, np.inf], [-np.inf, 5]]])
    with np.errstate(invalid="ignore"):  # numpy's cast of NaN and inf to integers
        expected = _cleared(clear, points)
    assert [_cleared_at(clear, p) for p in points] == expected.tolist()


def test_compiled_cell_gathers_equal_numpys():
    """A raster's not-yet-known cells and their centre points, compiled, against the numpy steps
    they replaced, to the bit: the points feed numpy's projection, whose pixels decide the flags."""
    from refspatial.compiled import cell_points, unknown_cells
    from refspatial.relations.free_space import CELL_M

    rng = np.random.default_rng(4)
    for _ in range(50):
        shape = tuple(int(n) for n in rng.integers(1, 400, 2))
        known = rng.random(shape) < rng.random()
        n = int(rng.integers(0, 3000))
        rows, cols = rng.integers(0, shape[0], n), rng.integers(0, shape[1], n)
        todo = ~known[rows, cols]
        got = unknown_cells(known, rows, cols)
        assert np.array_equal(got[0], rows[todo]) and np.array_equal(got[1], cols[todo])
        first = rng.integers(-500, 500, 2)
        z = float(rng.uniform(-1, 2))
        want = np.column_stack([(np.column_stack([cols + first[0], rows + first[1]]) + 0.5) * CELL_M,
                                np.full(n, z)])
        assert np.array_equal(cell_points(rows, cols, int(first[0]), int(first[1]), z, CELL_M), want.reshape(n, 3))


def test_compiled_view_flags_equal_the_array_definitions():
    """``compiled.mark_view_flags`` (every free cell a solve meets) against the whole-array
    occlusion and clearance readings: depths within, exactly at and past the margin, points behind
    the camera, inside, on and past every edge of the image, far off, and not finite; each point's
    flags land on its own cell, and every cell given is marked known."""
    from refspatial.compiled import mark_view_flags

    # A margin of a power of two, so that a depth exactly that far from a rendered one exists:
    # there the test tells <= from <.
    margin = 2.0 ** -5
    rng = np.random.default_rng(9)
    depth = rng.uniform(0.5, 2.0, (54, 96)).astype(np.float32)
    clear = rng.random((54, 96)) < 0.5
    edges = [[96.0, k + 0.5] for k in range(54)] + [[k + 0.5, 54.0] for k in range(96)]  # just past the image
    uv = np.concatenate([
        rng.uniform(-20, 120, size=(4000, 2)), edges,
        [[0, 0], [96, 54], [95.999999, 53.999999], [-1e-12, 3], [3, -1e-12], [-0.0, 3], [96, 0], [0, 54],
         [1e30, 5], [-1e30, 5], [np.nan, 5], [5, np.inf], [-np.inf, 5]]])
    cols, rows = np.clip(np.floor(np.nan_to_num(uv)), 0, [95, 53]).astype(int).T
    z = depth[rows, cols] + rng.choice([0.0, margin, -margin, 0.04, -0.04, 1e-3], len(uv))
    z[::7] *= -1  # behind the camera
    z[::11] = 0.0
    with np.errstate(invalid="ignore"):  # numpy's cast of NaN and inf to integers
        expected = _unoccluded(depth, uv, z, margin), _cleared(clear, uv)
    shape = (70, 70)  # the points' cells, scattered over a raster with cells left untouched
    cells = np.unravel_index(rng.permutation(shape[0] * shape[1])[:len(uv)], shape)
    rasters = [np.zeros(shape, bool), np.ones(shape, bool), np.zeros(shape, bool)]  # seen, cleared, known
    mark_view_flags(uv, z, depth, clear, margin, *cells, *rasters)
    seen, cleared = rasters[0][cells], rasters[1][cells]
    assert np.array_equal(seen, expected[0]) and np.array_equal(cleared, expected[1])
    assert rasters[2].sum() == len(uv) and rasters[2][cells].all()
    untouched = ~rasters[2]
    assert not rasters[0][untouched].any() and rasters[1][untouched].all()
    assert 0 < seen.sum() < len(uv) and 0 < cleared.sum() < len(uv)
    assert (np.abs(depth[rows, cols] - z) == margin)[seen].any()  # some seen exactly at the margin
