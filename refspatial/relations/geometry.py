"""Small planar and projective geometry used by the predicates.

Footprints are convex polygons on the ground plane given as (N, 2) corner arrays
in counter-clockwise order.
"""

from __future__ import annotations

import numpy as np

from ..compiled import boxes_meet, clip_polygon, inside_planes, inside_planes_grid, polygon_gap, union_counts


def _next(a: np.ndarray) -> np.ndarray:
    """Each corner's successor around the polygon (np.roll(a, -1, axis=0), without its overhead:
    these helpers run tens of thousands of times per scene)."""
    return np.concatenate([a[1:], a[:1]])


def _twice_signed_area(poly: np.ndarray) -> float:
    x, y = poly[:, 0], poly[:, 1]
    return float(np.dot(x, _next(y)) - np.dot(y, _next(x)))


def polygon_area(poly: np.ndarray) -> float:
    if len(poly) < 3:
        return 0.0
    return 0.5 * abs(_twice_signed_area(poly))


def ccw(poly: np.ndarray) -> np.ndarray:
    """The polygon with counter-clockwise winding."""
    return poly if _twice_signed_area(poly) >= 0 else poly[::-1]


def clip_convex(subject: np.ndarray, clipper: np.ndarray) -> np.ndarray:
    """Intersection of two convex polygons (Sutherland-Hodgman, edge by edge: ``compiled.clip_polygon``)."""
    return clip_polygon(np.ascontiguousarray(ccw(subject), dtype=np.float64),
                        np.ascontiguousarray(ccw(clipper), dtype=np.float64))


def overlap_share(a: np.ndarray, b: np.ndarray) -> float:
    """Area of a ∩ b as a share of a's area."""
    if not boxes_meet(a, b):
        return 0.0  # clipping costs a hundred times more
    area = polygon_area(a)
    return polygon_area(clip_convex(a, b)) / area if area > 0 else 0.0


def _edge_normals(poly: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(corners, outward unit normals of the edges leaving them) of a convex polygon, counter-
    clockwise; outlines rounded as records store them can repeat a corner, which is dropped."""
    poly = ccw(poly)
    edges = _next(poly) - poly
    lengths = np.linalg.norm(edges, axis=1)
    if not np.all(lengths > 0):
        poly, edges, lengths = poly[lengths > 0], edges[lengths > 0], lengths[lengths > 0]
    return poly, np.column_stack([edges[:, 1], -edges[:, 0]]) / lengths[:, None]


def half_planes(poly: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(outward unit normals (K, 2), offsets (K,)) of a convex polygon's edges: a point p is
    inside where p @ normal - offset <= 0 for every edge (``inside_half_planes``). Shared by
    the polygon's bytes: an object's outline is tested again and again, by the free-space
    rasters, the answer snaps and the vertical predicates of every pair."""
    return shared(_key("half_planes", poly), lambda: _half_planes(poly))


def _half_planes(poly: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    poly, normals = _edge_normals(poly)
    offsets = np.einsum("ij,ij->i", poly, normals)
    normals.flags.writeable = offsets.flags.writeable = False
    return normals, offsets


def inside_convex(points: np.ndarray, poly: np.ndarray, grow: float = 0.0) -> np.ndarray:
    """Boolean mask of (N, 2) points inside a convex polygon grown outward by ``grow`` metres."""
    return inside_half_planes(points, half_planes(poly), grow)


def inside_half_planes(points: np.ndarray, planes: tuple[np.ndarray, np.ndarray], grow: float = 0.0) -> np.ndarray:
    """``inside_convex`` of the polygon whose ``half_planes`` are given."""
    normals, offsets = planes
    return inside_planes(np.ascontiguousarray(points, dtype=np.float64), normals, offsets, float(grow))


def grown_box(poly: np.ndarray, grow: float) -> tuple[np.ndarray, np.ndarray]:
    """(lo, hi) corners of the bounding box of ``inside_convex``'s region for ``grow`` >= 0: the
    polygon's edges moved out, whose corners are mitred, so a sharp corner reaches further than
    ``grow`` past the polygon's own box."""
    poly, normals = _edge_normals(poly)
    before = np.concatenate([normals[-1:], normals[:-1]])  # the normal of the edge ending at each corner
    # The two moved edges meet at corner + grow * (n1 + n2) / (1 + n1 . n2).
    corners = poly + grow * (before + normals) / (1 + np.einsum("ij,ij->i", before, normals))[:, None]
    return corners.min(0), corners.max(0)


def inside_convex_grid(xs: np.ndarray, ys: np.ndarray, poly: np.ndarray, grow: float = 0.0) -> np.ndarray:
    """``inside_convex`` of every grid point (x, y), x from ``xs`` and y from ``ys``, as a
    (len(ys), len(xs)) mask (rows follow y).

    Where every edge is axis-aligned (a table top, a room's floor) the test splits into one
    along x and one along y, the same numbers exactly: with a normal component of 0 or +-1
    each product in p . normal is exact, so the dot product is +-x or +-y however it is
    summed. A floor of a quarter of a million cells costs two short vectors then; other
    outlines are tested cell by cell by a compiled loop (``compiled.inside_planes_grid``)."""
    normals, offsets = half_planes(poly)
    unit = (normals == 0) | (np.abs(normals) == 1)
    if not (np.all(unit) and np.all((normals == 0).sum(axis=1) == 1)):
        return inside_planes_grid(np.ascontiguousarray(xs, dtype=np.float64), np.ascontiguousarray(ys, dtype=np.float64),
                                  normals, offsets, float(grow))
    keep_x, keep_y = np.ones(len(xs), dtype=bool), np.ones(len(ys), dtype=bool)
    for (nx, ny), offset in zip(normals, offsets):
        if nx != 0:
            keep_x &= xs * nx - offset <= grow
        else:
            keep_y &= ys * ny - offset <= grow
    return keep_y[:, None] & keep_x[None, :]


_SHARED: dict = {}  # results of pure functions of world geometry (here and in free_space), by their inputs' bytes
_SHARED_MAX = 4096


def shared(key, compute):
    """A pure function's result for inputs seen before: a scene's views ask the same world
    geometry (the outlines are the scene's, not the view's), each view afresh."""
    try:
        return _SHARED[key]
    except KeyError:
        pass
    if len(_SHARED) >= _SHARED_MAX:
        _SHARED.clear()
    value = _SHARED[key] = compute()
    return value


def forget_shared() -> None:
    """Drop every shared result: a benchmark's second pass over the same scenes would otherwise
    find what a long run, meeting each scene once, never does."""
    _SHARED.clear()


def _key(name: str, poly: np.ndarray) -> tuple:
    return name, poly.shape, poly.dtype.str, poly.tobytes()


def widths(poly: np.ndarray) -> tuple[float, float]:
    """A convex polygon's least width (its narrowest shadow over its own edge normals) and its
    longest span (the largest distance between two corners)."""
    return shared(_key("widths", poly), lambda: _widths(poly))


def _widths(poly: np.ndarray) -> tuple[float, float]:
    edges = _next(poly) - poly
    lengths = np.linalg.norm(edges, axis=1)
    normals = np.column_stack([edges[:, 1], -edges[:, 0]])[lengths > 0] / lengths[lengths > 0, None]
    shadows = poly @ normals.T
    d = poly[:, None, :] - poly[None, :, :]
    # ``np.linalg.norm(d, axis=-1)`` bit for bit (it sums the two squares in this order), at a fifth
    # of the cost of reducing a last axis of two.
    spans = np.sqrt(d[..., 0] * d[..., 0] + d[..., 1] * d[..., 1])
    return float((shadows.max(0) - shadows.min(0)).min()), float(spans.max())


def gap_between(a: np.ndarray, b: np.ndarray) -> float:
    """Smallest distance between two convex polygons (0 when they overlap or touch)."""
    # The same number either way round (each test and the minimum below are symmetric).
    ka, kb = _key("gap", a), _key("gap", b)
    return shared((ka, kb) if ka <= kb else (kb, ka), lambda: _gap_between(a, b))


def _gap_between(a: np.ndarray, b: np.ndarray) -> float:
    return float(polygon_gap(np.ascontiguousarray(a, dtype=np.float64), np.ascontiguousarray(b, dtype=np.float64)))


def project(points_world: np.ndarray, K: np.ndarray, T_world_cam: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Pixel coordinates (N, 2) and optical-axis depths (N,) of world points, OpenCV camera."""
    p_cam = (points_world - T_world_cam[:3, 3]) @ T_world_cam[:3, :3]
    z = p_cam[:, 2]
    uv = (p_cam @ K.T)[:, :2] / np.where(np.abs(z) < 1e-9, 1e-9, z)[:, None]
    return uv, z


def covered_pixels(tris: np.ndarray, width: int, height: int) -> int:
    """Pixels of a width x height image whose centre lies in at least one of the (F, 3, 2) pixel-
    coordinate triangles: the union, counted once, with the rasteriser's own centre-sampling rule
    (``covered_pixels_each`` of one set)."""
    return covered_pixels_each([tris], width, height)[0]


def covered_pixels_each(meshes: list[np.ndarray], width: int, height: int) -> list[int]:
    """``covered_pixels`` of each (F, 3, 2) triangle set, worked out together: a view's objects
    in one call (the arithmetic is per triangle and per row, so each count is what it would be
    alone).

    For the silhouette of a closed mesh the triangles of one winding suffice (front faces, or
    back faces, each tile it), so only those with positive signed area are drawn. (cv2.fillPoly
    cannot stand in: it fills many polygons with a parity rule, so overlaps cancel.) Each
    triangle is cut into one span of pixels per row it covers, and a set's spans are counted
    once where they overlap (``compiled.union_counts``).
    """
    if not meshes:
        return []
    tris = np.ascontiguousarray(np.concatenate(meshes), dtype=np.float64)
    return union_counts(tris, np.array([len(m) for m in meshes], np.int64), width, height).tolist()
