"""Free space: a vacant, visible point on a support surface that meets every constraint.

The thresholds are the ones published with RefSpatial:
- support: a platform top within 5 cm of the object's bottom covering >= 70 % of
  its footprint (``facts._with_supports``); ``between`` needs both anchors on the same support;
- obstacles: other objects on that platform (the platform itself is not one);
- regions: left/right/front/behind = a 90 degree sector centred on the anchor, pointing along
  the viewer-frame direction, reaching max(footprint diagonal, 0.20 m) beyond the anchor's own
  extent in that direction (measured from the centre, a 0.20 m sector could never hold the
  0.036 m^2 below); on_top = the anchor's top face shrunk to 80 %; between = the planar region
  enclosed by both anchors' footprints (their convex hull);
- free area (1 cm cells of the region on the platform, clear of obstacles) > 0.036 m^2;
- candidates at platform height are projected into the image and dropped when occluded
  (|camera depth - rendered depth| > 2.5 cm); at least 30 % of free cells must be visible;
- the answer is the mean of the visible valid cells, or the valid point nearest to it when the
  mean itself is not valid (ours: for a sector, of the cells within the anchor's own width across
  the direction, so the spot "in front of the lamp" is not in front of the thing beside it). The region's visible image mask is kept with the answer.
Ours besides: the answer point keeps IMAGE_CLEARANCE of the image width away from every object's
pixels (the platform's own aside), and ANSWER_ROOM_M on the platform from every thing on it. 1.5 cm behind a cup is free on the table but sits on the cup's
outline in the picture, where a person sees no room at all.
Metric offsets ("10 cm to the right of the cup") solve for the single point that far beyond
the anchor's extent, which must be free (1.5 cm from any footprint) and visible.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache

import cv2
import numpy as np
from scipy.ndimage import distance_transform_edt

from ..compiled import (BETWEEN, OFFSET, ON_TOP, SECTOR, cell_points, convex_ring, in_regions, in_regions_grid,
                        mark_view_flags, plane_cells, sector_cells, strip_answer, unknown_cells)
from ..scene import LEG_HALF_M, LEG_INSET_M
from ..vector import column_bounds
from .directional import corridor, squarely_between
from .facing import front_reads_two_ways
from .facts import TABLE, ObjectFacts, ViewFacts
from .geometry import grown_box, half_planes, inside_convex, inside_convex_grid, inside_half_planes, project, shared
from .masks import box_of, cached_boxes, padded
from .registry import predicate

CELL_M = 0.01
MIN_RADIUS_M = 0.20
HALF_SECTOR_DEG = 45.0
COS_HALF_SECTOR = float(np.cos(np.radians(HALF_SECTOR_DEG)))
TOP_SHRINK = 0.8
MIN_FREE_AREA_M2 = 0.036
OCCLUSION_M = 0.025
MIN_VISIBLE_SHARE = 0.3
CLEARANCE_M = 0.015  # free cells keep this far from obstacle footprints
EDGE_MARGIN_M = 0.02  # and this far inside the platform's edge
OBSTACLE_BAND_M = 0.05  # objects reaching into this band above the platform are in the way
# ...from this height above it up: a fork lying flat (3 mm) is in the way (annotator read 42: a free
# spot's region took in 1,210 pixels of one under the old 5 mm); a board below is not.
OBSTACLE_MIN_TOP_M = 0.001
DIRECTIONS = ("left", "right", "front", "behind")
IMAGE_CLEARANCE = 0.02  # share of the image width between an answer point and any object's pixels
# The answer point itself keeps this far from every thing on its platform, so "room for one more
# object" there holds for a small one: 1.6 cm from a toy car's nose held nothing (annotator).
ANSWER_ROOM_M = 0.04
ALL_AT_ONCE_CELLS = 40_000  # rasters up to this many cells work out every free cell's view flags at once
BOX_SLACK_M = 1e-9  # sector boxes are grown by this against rounding


@dataclass(frozen=True)
class Constraint:
    kind: str  # "sector", "between", "on_top" or "offset"
    anchors: tuple[int, ...]
    direction: str | None = None  # one of DIRECTIONS, for sector and offset
    offset_m: float | None = None  # for offset


@dataclass(frozen=True, eq=False)
class FreeSpace:
    point: tuple[float, float]  # normalised image (x, y), 3 decimals
    point_world_m: np.ndarray  # (3,)
    mask: np.ndarray | None  # bool (H, W): visible free pixels of the region (None if not asked for)
    area_m2: float  # free area of the region on the platform (visible or not)
    support: int  # TABLE or the platform object's id


def stored_constraints(stored: list[dict], anchor_ids) -> tuple[Constraint, ...]:
    """The constraints of a program's free_space node, whose anchors are positions among its
    inputs, with ``anchor_ids`` the object id at each position."""
    return tuple(Constraint(c["kind"], tuple(anchor_ids[k] for k in c["anchors"]), c.get("direction"),
                            c.get("offset_m")) for c in stored)


def direction_axis(v: ViewFacts, direction: str) -> np.ndarray:
    """Ground-plane unit vector of a viewer-frame direction (memoised per view: every solve asks)."""
    key = ("direction_axis", direction)
    if key not in v.cache:
        axes = {"left": -v.right_axis, "right": v.right_axis, "front": -v.forward_axis, "behind": v.forward_axis}
        axis = v.cache[key] = axes[direction][:2].copy()
        axis.flags.writeable = False  # shared by every caller
    return v.cache[key]


def solve(v: ViewFacts, constraints: tuple[Constraint, ...], with_mask: bool = True) -> FreeSpace | None:
    """The free-space answer meeting every constraint, or None when there is none.

    The image mask costs a pass over a window of pixels; statistics that need only
    the point and area skip it (``with_mask=False``; ``mask`` is then None). Answers
    are memoised per view: a placement question executes its program, then asks
    for the mask of the same answer.
    """
    key = ("free_space", tuple(constraints), with_mask)
    if key not in v.cache:
        if not with_mask:
            v.cache[key] = _solve(v, key[1])
        else:
            # The mask is made last, from the answer found without it: none without the mask is
            # none with it, and the answer's own search is not made twice.
            answer = solve(v, key[1], with_mask=False)
            v.cache[key] = None if answer is None else _masked(v, key[1], answer)
    return v.cache[key]


def _solve(v: ViewFacts, constraints: tuple[Constraint, ...]) -> FreeSpace | None:
    """The answer without its mask."""
    if any(c.kind in ("sector", "offset") and c.direction in ("front", "behind")
           and front_reads_two_ways(v, v.objects[c.anchors[0]]) for c in constraints):
        return None  # "behind the chair" facing away is its front by its own reading
    platform = _platform(v, constraints, _anchors(v, constraints))
    if platform is None:
        return None
    support, polygon, z = platform
    raster = _raster(v, support, polygon, z)
    first, last = _grid(v, constraints, polygon)
    if len(constraints) == 1 and constraints[0].kind == "sector":
        found = _swept_sector(v, constraints[0], raster, support, z, first, last)
    else:
        found = _swept(v, constraints, raster, support, z, first, last)
    if found is None:
        return None
    area, mean, nearest = found
    # The mean of a ring-shaped or split region can fall on an obstacle (or near one in the
    # picture): then use the nearest valid point.
    chosen = mean if np.linalg.norm(nearest - mean) <= CELL_M else nearest
    uv, _ = project(np.array([[*chosen, z]]), v.K, v.T_world_cam)
    if not _cleared_at(image_clearance(v, support), uv[0]):
        chosen = nearest
        uv, _ = project(np.array([[*chosen, z]]), v.K, v.T_world_cam)
    point = _normalised(v, uv[0])
    if point is None:
        return None
    return FreeSpace(point, np.array([*chosen, z]), None, area, support)


def _swept(v: ViewFacts, constraints, raster: _Raster, support: int, z: float, first: np.ndarray,
           last: np.ndarray) -> tuple[float, np.ndarray, np.ndarray] | None:
    """(free area of the regions, mean of the valid cells, the valid cell nearest to it), or None
    when the regions hold too little free, visible or valid room."""
    rows, cols = np.nonzero(raster.block(first, last))  # the free cells; then those in every region
    offset = _has_offset(constraints)
    if not offset and float(len(rows) * CELL_M**2) <= MIN_FREE_AREA_M2:
        # Too little free room in the region's whole box, so in the region, whose free cells are
        # some of the box's (a third of the solves that find none end here).
        return None
    free = cell_points(rows, cols, int(first[0]), int(first[1]), z, CELL_M)[:, :2]  # the cells' centres
    inside = _in_regions(v, constraints, free)
    free = free[inside]
    area = float(len(free) * CELL_M**2)
    if not offset and area <= MIN_FREE_AREA_M2:
        return None
    cells = (rows[inside] + first[1] - raster.first[1], cols[inside] + first[0] - raster.first[0])
    seen, cleared, roomy = raster.flags(v, cells)
    visible = seen[cells]
    if len(free) == 0 or visible.sum() < max(1, MIN_VISIBLE_SHARE * len(free)):
        return None
    valid = free[visible]
    cells = (cells[0][visible], cells[1][visible])
    # A metric offset's single point is where its words put it, and keeps only the solver's
    # clearance, not ANSWER_ROOM_M.
    keep = cleared[cells] if offset else cleared[cells] & roomy[cells]
    valid = valid[keep & _in_strips(v, constraints, valid, support, z) & _squarely_between(v, constraints, valid)]
    if len(valid) == 0:
        return None
    mean = _column_means(valid)
    return area, mean, valid[int(np.argmin(_lengths(valid - mean)))]


def _swept_sector(v: ViewFacts, c: Constraint, raster: _Raster, support: int, z: float, first: np.ndarray,
                  last: np.ndarray) -> tuple[float, np.ndarray, np.ndarray] | None:
    """``_swept`` for one sector, the relation table's four regions round every anchor, as two
    compiled loops (``sector_cells``, ``strip_answer``): the same tests in the same order on a
    few thousand cells, without the forty numpy calls a solve of them cost (tested against
    ``_swept``)."""
    reach = _reach(v, c.anchors[0], c.direction)
    in_box, rows, cols, xs, ys = sector_cells(raster.free, raster.first, first, last, reach.centre, reach.axis,
                                              reach.half + reach.radius, COS_HALF_SECTOR, CELL_M)
    area = float(len(rows) * CELL_M**2)
    if float(in_box * CELL_M**2) <= MIN_FREE_AREA_M2 or area <= MIN_FREE_AREA_M2:
        return None
    seen, cleared, roomy = raster.flags(v, (rows, cols))
    strip = _strip(v, c, support, z)
    visible, valid, mean, nearest = strip_answer(rows, cols, xs, ys, seen, cleared, roomy, reach.axis, strip.across,
                                                 strip.lo, strip.hi, strip.stop)
    if visible < max(1, MIN_VISIBLE_SHARE * len(rows)) or valid == 0:
        return None
    return area, mean, nearest


def _masked(v: ViewFacts, constraints: tuple[Constraint, ...], answer: FreeSpace) -> FreeSpace | None:
    """The answer with its image mask, its point snapped onto the mask where it lies off it (or
    None when no mask pixel will do)."""
    support, polygon, z = _platform(v, constraints, _anchors(v, constraints))
    first, last = _grid(v, constraints, polygon)
    mask = _image_mask(v, constraints, _raster(v, support, polygon, z), z, first, last)
    point, world = answer.point, answer.point_world_m
    if not _on_mask(v, mask, point):
        # The snapped point keeps to everything the solve's own points kept to: a snap that
        # only stayed in the sector landed 2 cm beside a strip's anchor (test, new scenes).
        offset = _has_offset(constraints)
        uv, _ = project(world[None], v.K, v.T_world_cam)
        snapped = _snap(v, mask & image_clearance(v, support), uv[0], z, lambda p: _in_regions(v, constraints, p) &
                        _free_exact(v, p, support, polygon, z) & _in_strips(v, constraints, p, support, z) &
                        _squarely_between(v, constraints, p) & (offset | _roomy_exact(v, p, support, z)))
        if snapped is None:
            return None
        point, world = snapped, _lift(v, snapped, z)
    return FreeSpace(point, world, mask, answer.area_m2, support)


def _anchors(v: ViewFacts, constraints) -> list[ObjectFacts]:
    return [v.objects[i] for c in constraints for i in c.anchors]


def _has_offset(constraints) -> bool:
    return any(c.kind == "offset" for c in constraints)


def _squarely_between(v: ViewFacts, constraints, points: np.ndarray) -> np.ndarray:
    """Which points lie between a "between" region's anchors as the relation reads it: the middle
    of the line joining their centres (BETWEEN_T) and inside its corridor. The region stays
    RefSpatial's hull of both footprints, but a spot 15 % along the line and 21 cm off it, by the
    stool's foot, is beside the stool, not between it and the pot (annotator)."""
    keep = np.ones(len(points), dtype=bool)
    for c in constraints:
        if c.kind != "between":
            continue
        b, d = (v.objects[i] for i in c.anchors)
        q, r = b.center_world_m[:2], d.center_world_m[:2]
        seg = r - q
        length = float(np.linalg.norm(seg))
        if length < 1e-9:
            return np.zeros(len(points), dtype=bool)
        across, half_width = corridor(b, d)
        rel = points - q
        keep &= squarely_between(rel @ seg / length**2, np.abs(rel @ across[:2]), length, half_width)
    return keep


@dataclass(frozen=True)
class _Strip:
    """What a sector's answer point keeps to: its anchor's own width across the direction, up to
    the first other thing standing in that strip beyond the anchor."""

    across: np.ndarray  # (2,) ground-plane unit vector across the direction
    lo: float  # the anchor's extent along ``across``
    hi: float
    stop: float  # along the direction: where the first other thing in the strip begins (inf: none)


def _strip(v: ViewFacts, c: Constraint, support: int, z: float) -> _Strip:
    """Memoised per view: the four directions from every anchor are solved for statistics and
    again by the questions."""
    key = ("free_strip", c.anchors[0], c.direction, support)
    if key not in v.cache:
        across, sides = _sides(v, c.direction)
        lo, hi, _, edge = sides[c.anchors[0]]
        stop = np.inf
        for o in _obstacles(v, support, z):
            if o.object_id == c.anchors[0]:
                continue
            o_lo, o_hi, start, _ = sides[o.object_id]
            if o_hi > lo and o_lo < hi and start >= edge:
                stop = min(stop, start)
        v.cache[key] = _Strip(across, lo, hi, stop)
    return v.cache[key]


def _sides(v: ViewFacts, direction: str) -> tuple[np.ndarray, dict[int, tuple[float, float, float, float]]]:
    """The ground-plane unit vector across a viewer-frame direction, and every object's extent
    across it and along the direction, (low, high) each (memoised per view: every strip, about
    13 a record, reads every obstacle's, and asking each object in turn took a fifth of a sector
    solve's time)."""
    key = ("free_sides", direction)
    if key not in v.cache:
        axis = direction_axis(v, direction)
        along, across = np.array([*axis, 0.0]), np.array([-axis[1], axis[0], 0.0])
        v.cache[key] = across[:2], {o.object_id: (*o.interval_along(across), *o.interval_along(along))
                                    for o in v.objects}
    return v.cache[key]


def _in_strips(v: ViewFacts, constraints, points: np.ndarray, support: int, z: float) -> np.ndarray:
    """Which points lie squarely towards each sector's direction: within its anchor's own width
    across that direction (the shadow of its ground outline), and short of the next thing in that
    strip. The region stays RefSpatial's 90 degree sector, but the answer point keeps to the
    strip: a spot 26 cm to the side and 18 cm in front of a lamp 19 cm wide is in front of the
    candle beside it, not of the lamp (annotator); "to the left of the rightmost keyboard" is the
    room beside it, not a spot past the other keyboard 36 cm away (annotator, read 32)."""
    keep = np.ones(len(points), dtype=bool)
    for c in constraints:
        if c.kind != "sector":
            continue
        strip = _strip(v, c, support, z)
        lateral = _dot(points, strip.across)
        keep &= (lateral >= strip.lo) & (lateral <= strip.hi)
        keep &= _dot(points, direction_axis(v, c.direction)) <= strip.stop
    return keep


def _platform(v: ViewFacts, constraints, anchors: list[ObjectFacts]):
    """(support id, platform polygon, top z) shared by all anchors, or None."""
    if any(c.kind == "on_top" for c in constraints):
        top = v.objects[next(c for c in constraints if c.kind == "on_top").anchors[0]]
        if not top.is_support:
            return None
        centre = top.footprint_world.mean(0)
        polygon = centre + TOP_SHRINK * (top.footprint_world - centre)
        return top.object_id, polygon, float(top.aabb_world_m[1, 2])
    supports = {a.support for a in anchors}
    if len(supports) != 1 or None in supports:
        return None
    support = supports.pop()
    if support <= TABLE:  # the table top, or a shelf board (support -(k + 2)) of the same extent
        hx, hy = np.asarray(v.table_size_m) / 2
        level = -1 if support == TABLE else -support - 2
        z = v.table_top_z_m + (v.table_levels_m[level] if level >= 0 else 0.0)
        if v.table_levels_m and level < len(v.table_levels_m) - 1:
            # A shelf's posts stand on every board below the highest: the strip at each end
            # between them holds nothing a person could place (annotator: a spot wedged there).
            hx -= LEG_INSET_M + LEG_HALF_M + CLEARANCE_M
        return support, np.array([[-hx, -hy], [hx, -hy], [hx, hy], [-hx, hy]]), z
    base = v.objects[support]
    return support, base.footprint_world, float(base.aabb_world_m[1, 2])


@dataclass(frozen=True, eq=False)
class _Reach:
    """An anchor seen towards one viewer-frame direction: what sectors and offsets are built on."""

    centre: np.ndarray  # (2,) the anchor's centre on the ground
    axis: np.ndarray  # (2,) ground-plane unit vector of the direction
    half: float  # the anchor's half extent along the axis
    radius: float  # how far a sector reaches beyond that: max(footprint diagonal, MIN_RADIUS_M)
    sector_box: np.ndarray  # (2, 2) bounding box of the sector


def _reach(v: ViewFacts, anchor: int, direction: str) -> _Reach:
    """Memoised per view: each anchor and direction is solved for statistics and again and again
    by the question search."""
    key = ("free_reach", anchor, direction)
    if key not in v.cache:
        a, axis = v.objects[anchor], direction_axis(v, direction)
        centre, half = a.center_world_m[:2], 0.5 * a.extent_along(np.array([*axis, 0.0]))
        radius = max(float(np.hypot(*(a.footprint_world[2] - a.footprint_world[0]))), MIN_RADIUS_M)
        v.cache[key] = _Reach(centre, axis, half, radius, _sector_box(centre, axis, half + radius))
    return v.cache[key]


def _grid(v: ViewFacts, constraints, polygon: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(first, last) (x, y) indices of the 1 cm lattice cells (fixed to the world origin, so that
    every question on a platform shares one obstacle raster) inside the platform's box and the
    region's box. Worked out in Python floats (the same operations as on arrays, so the same
    numbers): every solve asks it, and the dozen calls on two-element arrays cost more than a
    sector's compiled sweep."""
    xs, ys = polygon.T.tolist()
    x0, y0, x1, y1 = min(xs), min(ys), max(xs), max(ys)
    for c in constraints:  # shrink the grid to the region's box when one is known
        if c.kind == "sector":
            (bx0, by0), (bx1, by1) = _reach(v, c.anchors[0], c.direction).sector_box.tolist()
        elif c.kind == "offset":
            reach = _reach(v, c.anchors[0], c.direction)
            r = reach.half + reach.radius + (c.offset_m or 0.0)
            cx, cy = reach.centre.tolist()
            bx0, by0, bx1, by1 = cx - r, cy - r, cx + r, cy + r
        elif c.kind == "between":  # within the hull of the anchors' footprints: a room's floor is metres wide
            cx, cy = np.concatenate([v.objects[i].footprint_world for i in c.anchors]).T.tolist()
            bx0, by0, bx1, by1 = min(cx), min(cy), max(cx), max(cy)
        else:
            continue
        x0, y0, x1, y1 = max(x0, bx0), max(y0, by0), min(x1, bx1), min(y1, by1)
    first = (math.ceil(x0 / CELL_M - 0.5), math.ceil(y0 / CELL_M - 0.5))
    last = (math.floor(x1 / CELL_M - 0.5), math.floor(y1 / CELL_M - 0.5))
    # an empty box has last = first - 1
    return np.array(first), np.array([max(last[0], first[0] - 1), max(last[1], first[1] - 1)])


def _cell_axes(first: np.ndarray, counts: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """x and y coordinates of the centres of counts = (nx, ny) lattice cells from cell index ``first``."""
    xs = (np.arange(first[0], first[0] + counts[0]) + 0.5) * CELL_M
    ys = (np.arange(first[1], first[1] + counts[1]) + 0.5) * CELL_M
    return xs, ys


def _cell_centres(first: np.ndarray, counts: np.ndarray) -> np.ndarray:
    """Centres of counts = (nx, ny) lattice cells from cell index ``first``, row by row (y)."""
    return np.stack(np.meshgrid(*_cell_axes(first, counts)), axis=-1).reshape(-1, 2)


def _sector_box(centre: np.ndarray, axis: np.ndarray, r: float) -> np.ndarray:
    """(2, 2) bounding box of the circular sector (radius r, HALF_SECTOR_DEG either side of the
    axis) around centre: its apex, the arc's ends, and the arc's extreme points in x and y
    where they fall inside it. A quarter of the square around the centre, so solves test
    fewer cells. It only bounds the cells a solve tests (the sector's own test decides each),
    so it is grown by BOX_SLACK_M against rounding, and worked out in scalars (it is made for
    every anchor and direction a view meets)."""
    cx, cy = float(centre[0]), float(centre[1])
    mid, half = math.atan2(float(axis[1]), float(axis[0])), math.radians(HALF_SECTOR_DEG)
    angles = [mid - half, mid + half]
    angles += [k * math.pi / 2 for k in range(-4, 5) if abs(k * math.pi / 2 - mid) <= half]
    xs = [cx] + [cx + r * math.cos(a) for a in angles]
    ys = [cy] + [cy + r * math.sin(a) for a in angles]
    return np.array([[min(xs) - BOX_SLACK_M, min(ys) - BOX_SLACK_M], [max(xs) + BOX_SLACK_M, max(ys) + BOX_SLACK_M]])


def _in_regions(v: ViewFacts, constraints, points: np.ndarray, grow: float = 0.0) -> np.ndarray:
    """Whether each point lies in every region. With ``grow`` > 0, a cheap superset instead:
    each region's bounding half-planes and circles moved out by ``grow`` metres, which holds
    every point within ``grow`` of the region (and some more, near its corners).

    The regions' own test (``grow`` 0) runs compiled (``compiled.in_regions``): the same
    arithmetic as ``REGIONS``' functions, which define it (tested against them), in one pass
    instead of a dozen numpy calls per region; placement masks ask it of thousands of points."""
    if grow > 0:
        keep = np.ones(len(points), dtype=bool)
        for c in constraints:
            keep &= REGIONS[c.kind](v, c, points, grow)
        return keep
    return in_regions(np.ascontiguousarray(points, dtype=np.float64), *_region_arrays(v, tuple(constraints)))


_REGION_KINDS = {"sector": SECTOR, "between": BETWEEN, "on_top": ON_TOP, "offset": OFFSET}


def _region_arrays(v: ViewFacts, constraints: tuple[Constraint, ...]):
    """The regions as ``compiled.in_regions`` reads them: kinds, a row of numbers each, and the
    between regions' half-planes (memoised per view: a mask and its solve ask again)."""
    key = ("region_arrays", constraints)
    if key not in v.cache:
        params = np.zeros((len(constraints), 6))
        spans = np.zeros((len(constraints), 2), np.int64)
        normals, offsets, count = [np.zeros((0, 2))], [np.zeros(0)], 0
        for k, c in enumerate(constraints):
            if c.kind == "sector":
                reach = _reach(v, c.anchors[0], c.direction)
                params[k] = (*reach.centre, *reach.axis, reach.half + reach.radius, COS_HALF_SECTOR)
            elif c.kind == "offset":  # ``_offset``'s target, in its own numpy steps
                reach = _reach(v, c.anchors[0], c.direction)
                params[k, :2] = reach.centre + (reach.half + c.offset_m) * reach.axis
                params[k, 4] = CELL_M * 1.5
            elif c.kind == "between":
                planes = _between_planes(v, c)
                normals.append(planes[0])
                offsets.append(planes[1])
                spans[k] = count, count + len(planes[1])
                count += len(planes[1])
        kinds = np.array([_REGION_KINDS[c.kind] for c in constraints], np.int64)
        v.cache[key] = kinds, params, spans, np.concatenate(normals), np.concatenate(offsets)
    return v.cache[key]


def _sector(v: ViewFacts, c: Constraint, points: np.ndarray, grow: float = 0.0) -> np.ndarray:
    reach = _reach(v, c.anchors[0], c.direction)
    rel = points - reach.centre
    dist = _lengths(rel)
    if grow > 0:  # a 90 degree sector is the disc cut by the two half-planes facing its edges
        turn = np.radians(HALF_SECTOR_DEG)
        sides = [reach.axis @ np.array([[np.cos(a), np.sin(a)], [-np.sin(a), np.cos(a)]]) for a in (turn, -turn)]
        return (rel @ sides[0] >= -grow) & (rel @ sides[1] >= -grow) & (dist <= reach.half + reach.radius + grow)
    along = _dot(rel, reach.axis)
    return (along >= COS_HALF_SECTOR * dist) & (dist <= reach.half + reach.radius) & (dist > 1e-9)


def _between(v: ViewFacts, c: Constraint, points: np.ndarray, grow: float = 0.0) -> np.ndarray:
    return inside_half_planes(points, _between_planes(v, c), grow=grow)


def _between_planes(v: ViewFacts, c: Constraint) -> tuple[np.ndarray, np.ndarray]:
    """The half-planes of the hull of both anchors' footprints."""
    key = ("between_hull", *sorted(c.anchors))
    if key not in v.cache:  # the mask and every solve with this pair ask again
        corners = np.concatenate([v.objects[i].footprint_world for i in c.anchors])
        v.cache[key] = half_planes(corners[convex_ring(corners)])
    return v.cache[key]


def _on_top(v: ViewFacts, c: Constraint, points: np.ndarray, grow: float = 0.0) -> np.ndarray:
    return np.ones(len(points), dtype=bool)  # the platform polygon already is the shrunk top face


def _offset(v: ViewFacts, c: Constraint, points: np.ndarray, grow: float = 0.0) -> np.ndarray:
    reach = _reach(v, c.anchors[0], c.direction)
    target = reach.centre + (reach.half + c.offset_m) * reach.axis
    return _lengths(points - target) <= CELL_M * 1.5 + grow


def _dot(points: np.ndarray, axis: np.ndarray) -> np.ndarray:
    """``points @ axis`` of (N, 2) points as a plain multiply and add, as the compiled sector sweep
    does it: numpy's BLAS fuses them on CPUs with FMA (an ulp apart on a third of the values, and
    otherwise on CPUs without it), which would leave the two paths, and machines, free to differ
    for a cell on a region's very edge."""
    return points[:, 0] * axis[0] + points[:, 1] * axis[1]


def _lengths(d: np.ndarray) -> np.ndarray:
    """``np.linalg.norm(d, axis=1)`` of (N, 2) vectors, bit for bit (the same two squares summed
    in the same order), without the general reduction's cost: rooms' floors solve for tens of
    thousands of cells."""
    x, y = d[:, 0], d[:, 1]
    return np.sqrt(x * x + y * y)


def _column_means(points: np.ndarray) -> np.ndarray:
    """``points.mean(0)`` of (N, 2) points, bit for bit: numpy sums along the first axis one row
    after another (no pairwise summation), as a running sum does, then divides by N; over a
    1-D column the running sum takes half the time of the strided reduction."""
    return np.array([np.cumsum(points[:, 0])[-1], np.cumsum(points[:, 1])[-1]]) / len(points)


REGIONS = {"sector": _sector, "between": _between, "on_top": _on_top, "offset": _offset}


class _Raster:
    """Which 1 cm lattice cells of a platform are free: on it, EDGE_MARGIN_M inside its edge, and
    CLEARANCE_M clear of every obstacle footprint (tested at the cell centres).

    Made once per view and platform (the free cells once per scene: they are world geometry):
    the relation stage and the questions solve hundreds of regions on the same few platforms,
    and testing every obstacle per region cost more than everything else in those stages
    together. The per-view flags of ``flags`` are worked out as solves need them: cell by cell
    on a room's floor, all at once on rasters of at most ALL_AT_ONCE_CELLS.
    """

    def __init__(self, v: ViewFacts, support: int, polygon: np.ndarray, z: float) -> None:
        self.support, self.z = support, z
        self.first = np.floor(polygon.min(0) / CELL_M).astype(int)
        # Which cells are free, and which roomy, is world geometry: a scene's views share it.
        self._obstacles = _obstacles(v, support, z)
        self._world = (polygon.tobytes(), z, *((o.footprint_world.tobytes(), o.ground_outline.tobytes())
                                              for o in self._obstacles))
        self.free = shared(("free_raster", self._world), lambda: self._free(polygon))
        self._flags: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None
        self._known: np.ndarray | None = None  # cells whose seen and cleared flags are worked out

    def _free(self, polygon: np.ndarray) -> np.ndarray:
        last = np.floor(polygon.max(0) / CELL_M).astype(int)
        shape = (last - self.first + 1)[::-1]  # rows follow y, columns x
        free = inside_convex_grid(*_cell_axes(self.first, shape[::-1]), polygon, grow=-EDGE_MARGIN_M)
        for o in self._obstacles:
            self._clear_of(free, o.footprint_world, CLEARANCE_M)
        free.flags.writeable = False
        return free

    def _roomy(self) -> np.ndarray:
        roomy = self.free.copy()
        for o in self._obstacles:
            self._clear_of(roomy, o.ground_outline, ANSWER_ROOM_M)
        roomy.flags.writeable = False
        return roomy

    def flags(self, v: ViewFacts, cells: tuple[np.ndarray, np.ndarray]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Bool rasters (seen, cleared, roomy), known at least at ``cells`` ((rows, columns) of
        free cells of this raster) in view ``v``, the raster's own: a cell's centre at the
        platform's height is unoccluded in the picture, falls on a pixel ``image_clearance``
        keeps, and lies ANSWER_ROOM_M clear of every obstacle's ground outline. Each is a
        property of the cell alone, worked out once, when a solve first looks at the cell: the
        four directions from every anchor and every question after them meet the same cells, and
        a room's floor holds half a million of them, most never looked at (testing all of them
        took 0.3 s a view). Only the cells in a solve's regions are asked, not their box: a
        sector fills about half of its box.

        A table top or shelf board holds at most a few ten thousand free cells, and the solves
        of a view look at most of them (two thirds on tabletops): there every free cell is worked
        out at the first call, in one pass instead of a dozen."""
        at_once = self.free.size <= ALL_AT_ONCE_CELLS
        if self._flags is None:
            self._flags = (np.zeros_like(self.free), np.zeros_like(self.free),
                           shared(("roomy_raster", self._world), self._roomy))
            self._known = np.zeros_like(self.free)
            if at_once:
                self._work_out(v, np.nonzero(self.free))
        if at_once:
            return self._flags  # every free cell is known, and solves ask only free cells
        todo = unknown_cells(self._known, cells[0], cells[1])
        if len(todo[0]):
            self._work_out(v, todo)
        return self._flags

    def _work_out(self, v: ViewFacts, cells: tuple[np.ndarray, np.ndarray]) -> None:
        """The seen and cleared flags of ``cells`` ((rows, columns) not yet known)."""
        seen, cleared, _ = self._flags
        rows, cols = cells
        # The cells' centres are made, and their flags set, by compiled passes (a room's solves
        # ask some 4,000 new cells each, 17 times a record: the gathers, stacks and scatters cost
        # as much as numpy's projection between them, which stays numpy's for BLAS's bits).
        points = cell_points(rows, cols, int(self.first[0]), int(self.first[1]), float(self.z), CELL_M)
        uv, depth = project(points, v.K, v.T_world_cam)
        mark_view_flags(uv, depth, v.depth_m, image_clearance(v, self.support), OCCLUSION_M, rows, cols,
                        seen, cleared, self._known)

    def _clear_of(self, cells: np.ndarray, outline: np.ndarray, grow: float) -> None:
        """Clear the flags (a raster like ``free``) of the cells whose centres lie within the
        outline grown by ``grow``, tested over the grown outline's box only: a turned or sharp
        corner's grown edges reach past the outline's own box plus ``grow`` (and a cell more is
        taken, against rounding)."""
        lo, hi = grown_box(outline, grow)
        last = self.first + cells.shape[::-1] - 1
        a = np.maximum(np.floor(lo / CELL_M).astype(int) - 1, self.first)
        b = np.minimum(np.floor(hi / CELL_M).astype(int) + 1, last)
        if np.any(b < a):
            return
        hit = inside_convex_grid(*_cell_axes(a, b - a + 1), outline, grow=grow)
        cells[a[1] - self.first[1]:b[1] - self.first[1] + 1, a[0] - self.first[0]:b[0] - self.first[0] + 1] &= ~hit

    def block(self, first: np.ndarray, last: np.ndarray) -> np.ndarray:
        """A copy of the free flags of cells first..last (inclusive (x, y) indices), rows
        following y; cells off the raster are not free."""
        out = np.zeros((last - first + 1)[::-1], dtype=bool)
        a, b = np.maximum(first, self.first), np.minimum(last, self.first + self.free.shape[::-1] - 1)
        if np.all(b >= a):
            (x0, y0), (x1, y1) = a - first, b - first + 1
            (u0, v0), (u1, v1) = a - self.first, b - self.first + 1
            out[y0:y1, x0:x1] = self.free[v0:v1, u0:u1]
        return out


def _raster(v: ViewFacts, support: int, polygon: np.ndarray, z: float) -> _Raster:
    key = ("free_raster", support, polygon.tobytes())
    if key not in v.cache:
        v.cache[key] = _Raster(v, support, polygon, z)
    return v.cache[key]


def _free_exact(v: ViewFacts, points: np.ndarray, support: int, polygon: np.ndarray, z: float) -> np.ndarray:
    """The raster's test at arbitrary points rather than cell centres (for the few answer points
    that are snapped to a pixel)."""
    keep = inside_convex(points, polygon, grow=-EDGE_MARGIN_M)
    for o in _obstacles(v, support, z):
        keep &= ~inside_convex(points, o.footprint_world, grow=CLEARANCE_M)
    return keep


def _roomy_exact(v: ViewFacts, points: np.ndarray, support: int, z: float) -> np.ndarray:
    """The roomy raster's test (ANSWER_ROOM_M clear of every obstacle's ground outline) at
    arbitrary points."""
    keep = np.ones(len(points), dtype=bool)
    for o in _obstacles(v, support, z):
        keep &= ~inside_convex(points, o.ground_outline, grow=ANSWER_ROOM_M)
    return keep


def _obstacles(v: ViewFacts, support: int, z: float) -> tuple[ObjectFacts, ...]:
    """Every object, seen or not, occupying the space just above a platform at height z: the
    platform itself is not one, nor is anything on a shelf board below or above (memoised per
    view: every strip and raster asks)."""
    key = ("free_obstacles", support, z)
    if key not in v.cache:
        band_top, lowest_top = z + OBSTACLE_BAND_M, z + OBSTACLE_MIN_TOP_M
        v.cache[key] = tuple(o for o in v.objects if o.object_id != support
                             and o.aabb_world_m[0, 2] < band_top and o.aabb_world_m[1, 2] > lowest_top)
    return v.cache[key]


def image_clearance(v: ViewFacts, support: int) -> np.ndarray:
    """Bool (H, W): pixels at least IMAGE_CLEARANCE of the image width from every object's pixels,
    the platform's own excepted (memoised per view and platform)."""
    # The table top and every shelf board exclude no object's pixels: one mask serves them all.
    key = ("image_clearance", support if support >= 0 else TABLE)
    if key not in v.cache:
        v.cache[key] = _clearance(v, support)
    return v.cache[key]


def _clearance(v: ViewFacts, support: int) -> np.ndarray:
    radius = IMAGE_CLEARANCE * v.width
    boxes = cached_boxes(v)
    own = box_of(boxes, support)
    others = any(b is not None for i, b in enumerate(boxes) if i != support)
    if support < 0 or own is None or not others:  # every object's pixels but the platform's
        return _far_from_objects(v, boxes, support, radius)
    # An object platform's mask differs from every object's (the TABLE mask) only within the
    # clearance radius of the platform's own pixels: there the transform of the other objects'
    # pixels is taken again, over that box grown once more by the radius, which holds every
    # pixel close enough to matter (pixels further than the radius never make one near).
    reach = _reach_px(radius) + 1
    inner = padded(own, reach, v.seg.shape)
    outer = padded(inner, reach, v.seg.shape)
    window = v.seg[outer]
    pixels = (window >= 0) & (window != support)
    out = image_clearance(v, TABLE).copy()
    if not pixels.any():  # nothing else near the platform's pixels: all of it is far
        out[inner] = True
        return out
    near = _far_from(pixels, radius)
    out[inner] = near[inner[0].start - outer[0].start:inner[0].stop - outer[0].start,
                      inner[1].start - outer[1].start:inner[1].stop - outer[1].start]
    return out


def _far_from_objects(v: ViewFacts, boxes, support: int, radius: float) -> np.ndarray:
    """``_far_from`` every object's pixels but the platform's, over the whole frame: the pixels
    are looked at only inside the box around the others' boxes (the rest of a frame is sky,
    floor and table, and testing it cost a third of the clearance)."""
    others = [b for i, b in enumerate(boxes) if b is not None and i != support]
    if not others:
        return _far_from(np.zeros(v.seg.shape, bool), radius)
    r0, r1 = min(b[0].start for b in others), max(b[0].stop for b in others)
    c0, c1 = min(b[1].start for b in others), max(b[1].stop for b in others)
    window = v.seg[r0:r1, c0:c1]
    return _far_from((window >= 0) & (window != support), radius, at=(r0, c0), shape=v.seg.shape)


def _reach_px(radius_px: float) -> int:
    """A feature pixel more than this many pixels away in either axis is never near."""
    return math.isqrt(_far_square(radius_px))


def _far_square(radius_px: float) -> int:
    """The smallest whole squared distance n with sqrt(n) >= radius_px."""
    n = math.ceil(radius_px * radius_px)  # the smallest squared distance that is far enough
    while n > 0 and math.sqrt(n - 1) >= radius_px:
        n -= 1
    while math.sqrt(n) < radius_px:
        n += 1
    return n


def _far_from(pixels: np.ndarray, radius_px: float, at: tuple[int, int] = (0, 0),
              shape: tuple[int, int] | None = None) -> np.ndarray:
    """Bool (H, W): the exact Euclidean distance to the nearest True pixel is at least radius_px,
    as ``distance_transform_edt(~pixels) >= radius_px``: no True pixel lies within squared
    distance n - 1 (n the smallest whole squared distance that is far enough), worked out as a
    dilation by that disk of pixels (``_near``), in whole numbers, so no rounding can flip a pixel.

    ``pixels`` may be a window, at (row, column) ``at`` of a frame of ``shape``, holding every True
    pixel of the frame (at least one); the answer is then the whole frame's."""
    if shape is None:
        shape = pixels.shape
        if not pixels.any():  # scipy's answer for an image with no feature pixel, kept as it was
            return distance_transform_edt(~pixels) >= radius_px
    n = _far_square(radius_px)  # the smallest squared distance that is far enough
    if n == 0:
        return np.ones(shape, bool)
    # Pixels beyond the radius from the box around every True pixel are far; inside the box
    # grown by it, the transform of that window alone is exact, since it holds every True pixel.
    rows, cols = np.flatnonzero(pixels.any(1)), np.flatnonzero(pixels.any(0))
    if len(rows) == 0:
        raise ValueError("_far_from: a window must hold at least one True pixel")
    reach = math.isqrt(n) + 1
    r0, r1 = max(rows[0] + at[0] - reach, 0), min(rows[-1] + at[0] + reach + 1, shape[0])
    c0, c1 = max(cols[0] + at[1] - reach, 0), min(cols[-1] + at[1] + reach + 1, shape[1])
    window = np.zeros((r1 - r0, c1 - c0), bool)  # the frame's pixels there: True ones only from ``pixels``
    a0, a1 = max(r0, at[0]), min(r1, at[0] + pixels.shape[0])
    b0, b1 = max(c0, at[1]), min(c1, at[1] + pixels.shape[1])
    window[a0 - r0:a1 - r0, b0 - c0:b1 - c0] = pixels[a0 - at[0]:a1 - at[0], b0 - at[1]:b1 - at[1]]
    far = np.ones(shape, bool)
    np.logical_not(_near(window, n), out=far[r0:r1, c0:c1])
    return far


def _near(pixels: np.ndarray, n: int) -> np.ndarray:
    """Bool: some True pixel lies within squared distance n - 1 (pixels off the image are not True).

    The disk of pixel offsets dx^2 + dy^2 <= n - 1 is the union of the rectangles at the corners
    of its staircase outline (12 for the clearance's 19.2 px), widths growing as heights shrink,
    so the mask is the union of as many rectangular dilations, exact by construction. They are
    built up from one another, since dilating by one rectangle and then another is dilating by
    their sum (and a dilation of a union is the union of the dilations): with A_k the pixels'
    columns dilated by rectangle k's half height (each from the next shorter one's) and R(w) a
    row dilation,
        near = R(w_1)(A_1 | R(w_2 - w_1)(A_2 | ... R(w_12 - w_11)(A_12))),
    two dozen narrow passes instead of twelve full rectangles, each costing with its length (0.76
    against 1.40 ms on a 300 x 700 window; OpenCV's exact distance transform took 1.5 times the
    full rectangles' time)."""
    src = pixels.view(np.uint8)
    rects = _disk_rectangles(n)  # (half width, half height), from the tallest to the widest
    w, h = rects[-1]
    columns = near = _dilated(src, 0, h)
    for w_k, h_k in reversed(rects[:-1]):
        columns = _dilated(columns, 0, h_k - h)
        near = np.bitwise_or(columns, _dilated(near, w - w_k, 0))
        w, h = w_k, h_k
    return _dilated(near, w, 0).view(bool)


def _dilated(src: np.ndarray, half_w: int, half_h: int) -> np.ndarray:
    kernel = cv2.getStructuringElement(cv2.MORPH_RECT, (2 * half_w + 1, 2 * half_h + 1))
    return cv2.dilate(src, kernel, borderType=cv2.BORDER_CONSTANT, borderValue=0)


@lru_cache(maxsize=8)
def _disk_rectangles(n: int) -> tuple[tuple[int, int], ...]:
    """(half width, half height) of the fewest centred rectangles whose union is the disk
    dx^2 + dy^2 <= n - 1 (n >= 1): one per step of its outline, from the tallest to the widest."""
    top = math.isqrt(n - 1)
    out: list[tuple[int, int]] = []
    for dy in range(top, -1, -1):
        half_w = math.isqrt(n - 1 - dy * dy)
        if not out or half_w > out[-1][0]:
            out.append((half_w, dy))
    return tuple(out)


def _cleared_at(clear: np.ndarray, uv: np.ndarray) -> bool:
    """Whether one image point (pixels) falls on a cleared pixel, in scalars (a solve asks it of its
    answer): as ``compiled.mark_view_flags`` reads every cell's, and the whole-array reading in
    the tests. A point off the image, or not finite, is not cleared."""
    x, y = float(uv[0]), float(uv[1])
    if not (math.isfinite(x) and math.isfinite(y)):
        return False
    col, row = math.floor(x), math.floor(y)
    return 0 <= col < clear.shape[1] and 0 <= row < clear.shape[0] and bool(clear[row, col])


def _image_mask(v: ViewFacts, constraints, raster: _Raster, z: float, first: np.ndarray,
                last: np.ndarray) -> np.ndarray:
    """Pixels whose ray meets the platform plane, unoccluded, inside the region and in a free cell.

    Only the image window covering the free cells that may meet the region is evaluated, and
    the region is tested per pixel only in cells that cross its edge (``_cell_codes``).
    """
    # The solve's box bounds cell centres: a cell one past it can still hold part of the region.
    lo, hi = first - 1, last + 1
    codes = _cell_codes(v, constraints, raster, lo, hi)
    cell_rows, cell_cols = np.nonzero(codes)
    cells = np.column_stack([cell_cols, cell_rows]) + lo
    corners = (cells[:, None, :] + np.array([[0, 0], [1, 0], [1, 1], [0, 1]])).reshape(-1, 2) * CELL_M
    uv, depth = project(np.column_stack([corners, np.full(len(corners), z)]), v.K, v.T_world_cam)
    mask = np.zeros((v.height, v.width), dtype=bool)
    if len(uv) == 0:
        return mask
    c0, r0, c1, r1 = 0, 0, v.width, v.height  # a cell reaching behind the camera: any pixel may see it
    if np.all(depth > 0):  # the corners' pixel box, a pixel wider each way, inside the frame
        (u0, w0), (u1, w1) = (b.tolist() for b in column_bounds(uv))
        c0, r0 = min(max(math.floor(u0) - 1, 0), v.width), min(max(math.floor(w0) - 1, 0), v.height)
        c1, r1 = min(max(math.ceil(u1) + 1, 0), v.width), min(max(math.ceil(w1) + 1, 0), v.height)
    M, t = _pixel_rays(v)
    window, at, x, y = plane_cells(v.depth_m, r0, c0, r1 - r0, c1 - c0, M, t, float(z), CELL_M, OCCLUSION_M, lo, codes)
    keep = window == WHOLE
    edge = window.ravel()[at] == EDGE  # pixels in cells that cross the region's edge: tested one by one
    keep.ravel()[at[edge]] = _in_regions(v, constraints, np.column_stack([x[edge], y[edge]]))
    mask[r0:r1, c0:c1] = keep
    return mask


def _pixel_rays(v: ViewFacts) -> tuple[np.ndarray, np.ndarray]:
    """(M, t): the world direction of a pixel's ray is M (u, w, 1), scaled so that its camera-frame
    z is 1 (the depth at which it meets a plane is then comparable with the depth image,
    ``plane_cells``), and t the camera's position (memoised per view: every placement mask asks)."""
    key = ("pixel_rays",)
    if key not in v.cache:
        v.cache[key] = v.T_world_cam[:3, :3] @ np.linalg.inv(v.K), np.ascontiguousarray(v.T_world_cam[:3, 3])
    return v.cache[key]


WHOLE, EDGE = 1, 2  # cell codes; 0 is a cell that is not free or lies outside the region
HALF_DIAGONAL_M = CELL_M * np.sqrt(0.5) * (1 + 1e-9)  # a cell lies within this of its centre


def _cell_codes(v: ViewFacts, constraints, raster: _Raster, first: np.ndarray, last: np.ndarray) -> np.ndarray:
    """Per lattice cell first..last (rows following y): WHOLE where the cell is free and wholly in
    the region (its four corners are, and every region is convex: a 90 degree sector, a hull, a
    disc, or an intersection of those), EDGE where it is free and may meet the region (its centre
    is within half a diagonal of it), and 0 elsewhere."""
    xs = np.arange(first[0], last[0] + 2) * CELL_M
    ys = np.arange(first[1], last[1] + 2) * CELL_M
    inside = in_regions_grid(xs, ys, *_region_arrays(v, tuple(constraints)))  # ``_in_regions`` of the grid
    whole = inside[:-1, :-1] & inside[:-1, 1:] & inside[1:, :-1] & inside[1:, 1:]
    centres = _cell_centres(first, last - first + 1)
    near = _in_regions(v, constraints, centres, grow=HALF_DIAGONAL_M).reshape(whole.shape)
    return np.where(raster.block(first, last) & near, np.where(whole, WHOLE, EDGE), 0).astype(np.uint8)


SNAP_TRIES = 256  # mask pixels, nearest first, tried for a snapped answer point


def _snap(v: ViewFacts, mask: np.ndarray, uv: np.ndarray, z: float, valid) -> tuple[float, float] | None:
    """The mask pixel nearest to an image point whose plane point is ``valid`` by the exact test
    (a mask pixel is only known to fall in a free cell), as a normalised point that rounds back
    onto the mask."""
    rows, cols = np.nonzero(mask)
    if len(rows) == 0:
        return None
    order = np.argsort((cols + 0.5 - uv[0]) ** 2 + (rows + 0.5 - uv[1]) ** 2, kind="stable")[:SNAP_TRIES]
    for k in order:
        point = _normalised(v, np.array([cols[k] + 0.5, rows[k] + 0.5]))
        if point is not None and _on_mask(v, mask, point) and valid(_lift(v, point, z)[None, :2])[0]:
            return point
    return None


def _normalised(v: ViewFacts, uv: np.ndarray) -> tuple[float, float] | None:
    x, y = round(float(uv[0]) / v.width, 3), round(float(uv[1]) / v.height, 3)
    return (x, y) if 0 <= x < 1 and 0 <= y < 1 else None


def _on_mask(v: ViewFacts, mask: np.ndarray, point: tuple[float, float]) -> bool:
    return bool(mask[int(point[1] * v.height), int(point[0] * v.width)])


def _lift(v: ViewFacts, point: tuple[float, float], z: float) -> np.ndarray:
    """World point on the plane z seen at a normalised image point."""
    ray = np.linalg.inv(v.K) @ np.array([point[0] * v.width, point[1] * v.height, 1.0])
    d = v.T_world_cam[:3, :3] @ ray
    t = v.T_world_cam[:3, 3]
    return t + d * (z - t[2]) / d[2]


@predicate("free_space", family="free_space", arity=1, frame="viewer", kind="region")
def free_space(v: ViewFacts, a: ObjectFacts, direction: str = "left") -> FreeSpace | None:
    """A free, visible point on A's support in a viewer-frame direction from A (see module docstring)."""
    return solve(v, (Constraint("sector", (a.object_id,), direction),), with_mask=False)
